//! Pre-stabilisation (Macklin et al. 2014, "Unified particle physics for real-time
//! applications", section 4.4): particles that were just placed (`add_particles`) or pushed
//! out of a solid may overlap far beyond any compression a flow produces (denser than the
//! fluid's own rest lattice). Every solver would turn that overlap into velocity within one
//! step (an explosion). Instead, the overlap beyond [`RELAX_TOLERANCE`] is projected out of
//! the *positions* only, with the PBF density constraint (unilateral, no artificial pressure,
//! moves of at most [`RELAX_MAX_MOVE`] spacings per round, each round with a fresh neighbour
//! search), each round's move swept through collider contact, with kinematic bodies standing
//! at their pose of the substep's start (where the particles are; rapier has already moved
//! them to the frame's end; dynamic bodies at rest at that end pose) and moving no body. The
//! projection leaves velocities as they were (contact reflects those of the particles it
//! pushes). It runs only when particles were
//! added or depenetrated (or an earlier relaxation was stopped by its budget); otherwise it
//! costs one flag check. Its time is reported as [`Stage::Relaxation`].
//!
//! **Budget.** A fluid's relaxation runs at most [`RELAX_FRAME_ROUNDS`] rounds per frame,
//! over all the frame's substeps together ([`RelaxBudget`]); what is not finished goes on in
//! the next frame, and the report says how much compression is left
//! ([`StepReport::relax_unfinished`], [`StepReport::relax_compression`]). Some overlap
//! cannot be relaxed at all: a closed tank holding more particles than it fits at rest
//! density (the same block spawned twice into a tank it fills), positions the precision of
//! `f32` cannot separate (a 5 mm fluid 100 km from the origin), a spacing raised tenfold in
//! a container. A frame whose rounds removed less than [`RELAX_PROGRESS`] of the compression
//! it started with has *stalled*: the next frame's budget is halved, down to
//! [`RELAX_STALLED_ROUNDS`], and the report says so ([`StepReport::relax_stalled`]); the
//! fluid stays compressed and the solver holds it as it can (its iteration cap bounds that
//! work). A frame that progresses again, or new particles, restore the whole budget.

use super::contact::{Scene, collider_contact};
use super::workspace::Workspace;
use crate::boundary::Coupling;
use crate::boundary::wall::WallQuery;
use crate::diagnostics::{Stage, StepReport};
use crate::domain::Separation;
use crate::fluid::Fluid;
use crate::math::{Real, Vector};
use crate::params::FluidParams;
use crate::solver::pbf::{Pbf, PbfContext};

/// Most relaxation rounds a fluid runs in one frame (each: a neighbour search, one Jacobi
/// projection, one contact sweep: less work than one substep of any solver, which adds its
/// solve to the same search and sweep). A block of 20³ particles spawned at half spacing
/// (8× ρ0) needs about 190 (stability case 6). Why 256: the default cap on substeps per frame
/// ([`crate::TimeStepping`]), so a frame that relaxes costs at most about twice the worst frame
/// of the default time stepping; before this budget the cap was 1,000 rounds per *substep*,
/// and a tank filled twice over ran them in each of 256 substeps (250–335 s for one 1/60 s
/// frame of 1,024 particles).
pub const RELAX_FRAME_ROUNDS: u32 = 256;
/// The smallest frame budget, reached after five stalled frames in a row (256 halved five
/// times): a stalled relaxation costs at most 8 rounds a frame, and still notices when
/// room appears (a wall moved away, particles drained).
pub const RELAX_STALLED_ROUNDS: u32 = 8;
/// A frame's relaxation progressed when its rounds left at most 90 % (this fraction, 10 %,
/// removed) of the largest compression it started with, or of the lowest an earlier frame
/// left since new particles came (over the rest lattice's density, beyond
/// the 2 % it settles at). Jacobi projection removes a spawn's overlap far faster than that per
/// frame while it can (case 6's 8× block: from 700 % to 2 % in 190 rounds); an overfilled
/// closed tank stays at its fill ratio.
pub const RELAX_PROGRESS: Real = 0.1;
/// Compression the relaxation leaves alone (1 %: the fluid's own rest lattice is within
/// 0.003 % of ρ0, and WCSPH is designed for about 1 %).
const RELAX_TOLERANCE: Real = 0.01;
/// The relaxation is done when no particle is compressed more than this. Jacobi projection
/// approaches [`RELAX_TOLERANCE`] from above only slowly (the last 0.1 % takes as many
/// rounds as the first 700 %); leaving the solver at most 1 % more than the tolerance, the
/// compression WCSPH is designed for, turns into velocities of a few centimetres per second.
const RELAX_SETTLED: Real = 2.0 * RELAX_TOLERANCE;
/// Largest move of a particle per relaxation round, in spacings (a position-based
/// safeguard: the projection's linearisation holds for small moves).
pub(super) const RELAX_MAX_MOVE: Real = 0.2;

/// One fluid's relaxation rounds: what is left of this frame's budget, and what the frame's
/// rounds achieved (kept by the pipeline from one frame to the next; see the module docs).
#[derive(Clone, Debug, Default)]
pub(crate) struct RelaxBudget {
    /// Rounds left in this frame.
    pub left: u32,
    /// Stalled frames in a row (each halves the next frame's budget).
    halvings: u32,
    /// The largest compression beyond the settled bound at this frame's first and last
    /// round, if a round ran.
    first: Option<Real>,
    last: Real,
    /// The smallest compression an unfinished frame has left since the budget was restored
    /// (a frame progresses when it goes [`RELAX_PROGRESS`] below it).
    best: Option<Real>,
    /// The fluid's next id when the budget was last set: new particles restore it.
    next_id: u32,
    /// The compression an unfinished relaxation left, as a factor of the rest density
    /// (`1 + RELAX_SETTLED +` the largest compression left; 1 when it finished): the solver
    /// holds the fluid at it until the relaxation removes it (see [`RelaxBudget::held`]).
    hold: Real,
    /// The frame's depenetration comes from a rigid carry alone (set by the pipeline's
    /// carry, see `boundary::teleport::Teleports::carry`): the particles are pushed
    /// out of solids, and relaxed only if any was.
    pub rigid_carry: bool,
}

/// Most halvings of the budget: 256 → 8 rounds.
const MAX_BUDGET_HALVINGS: u32 = 5;

/// What a frame's relaxation left: the compression beyond the settled bound, and whether
/// the frame stalled.
#[derive(Copy, Clone, Debug)]
pub(crate) struct RelaxLeft {
    pub compression: Real,
    pub stalled: bool,
}

impl RelaxBudget {
    /// The budget of a new frame of `fluid`.
    pub fn begin_frame(&mut self, fluid: &Fluid) {
        if fluid.next_id() != self.next_id {
            self.halvings = 0;
            self.best = None;
            self.next_id = fluid.next_id();
        }
        self.left = (RELAX_FRAME_ROUNDS >> self.halvings).max(RELAX_STALLED_ROUNDS);
        self.first = None;
    }

    /// The frame's end, with the relaxation still `pending` or not: what it left, if it ran
    /// and did not finish (and the next frame's budget).
    pub fn end_frame(&mut self, pending: bool) -> Option<RelaxLeft> {
        // A carry's flag lasts its frame (a frame without rounds left never read it).
        self.rigid_carry = false;
        let first = self.first?;
        if !pending {
            self.halvings = 0;
            self.best = None;
            return None;
        }
        // Progress is measured against the lowest compression left so far: a fluid that
        // sloshes in an overfilled tank goes up and down without getting anywhere.
        let best = self.best.map_or(first, |b| b.min(first));
        let stalled = self.last > (1.0 - RELAX_PROGRESS) * best;
        self.best = Some(best.min(self.last));
        self.halvings = if stalled {
            (self.halvings + 1).min(MAX_BUDGET_HALVINGS)
        } else {
            0
        };
        Some(RelaxLeft {
            compression: self.last,
            stalled,
        })
    }

    /// The rest density factor the solver holds the fluid at while its relaxation is
    /// `pending`: what the relaxation has not removed yet is held, not turned into velocity.
    /// Without it every solver meets a compression the relaxation could not remove with the
    /// pressure of that whole compression in one substep: DFSPH in a closed tank filled
    /// twice over reached 2·10^10 m/s in the first frame, its particles clumped at 48 ρ0.
    pub fn held(&self, pending: bool) -> Real {
        if pending { self.hold.max(1.0) } else { 1.0 }
    }

    /// Records a round's largest compression beyond the settled bound.
    fn record(&mut self, compression: Real) {
        self.first.get_or_insert(compression);
        self.last = compression;
    }
}

/// Relaxes the fluid's overlaps, within what is left of the frame's `budget`. Returns whether
/// it finished: no particle compressed beyond [`RELAX_SETTLED`].
pub(super) fn relax_overlaps(
    fluid: &mut Fluid,
    ws: &mut Workspace,
    scene: Option<Scene<'_>>,
    mut bodies: Option<&mut Coupling>,
    budget: &mut RelaxBudget,
    report: &mut StepReport,
) -> bool {
    let n = fluid.len();
    let depenetrate = fluid.needs_depenetration;
    ws.previous_positions.resize(n, Vector::ZERO);
    ws.previous_positions.copy_from_slice(fluid.positions());
    ws.inv_densities.resize(n, 0.0);
    let lattice_density = lattice_density(fluid.params());
    let rigid_carry = std::mem::take(&mut budget.rigid_carry);
    let mut round = 0;
    while budget.left > 0 {
        budget.left -= 1;
        report.relax_rounds += 1;
        search(fluid, ws, report);
        if round == 0 {
            separate_coincident(fluid, ws);
            if depenetrate {
                // Out of the solids first: a particle inside one would be pushed by the
                // wall's density from the inside.
                let pushed = collider_contact(
                    fluid,
                    ws,
                    scene,
                    true,
                    (bodies.as_deref_mut(), false),
                    report,
                );
                ws.previous_positions.copy_from_slice(fluid.positions());
                if rigid_carry && pushed == 0 {
                    // A rigid carry that landed in no solid made no overlap (the carried
                    // water's compression is its solver's, not the carry's).
                    budget.hold = 1.0;
                    return true;
                }
            }
        }
        let moved = project(fluid, ws, scene, bodies.as_deref(), lattice_density, report);
        if moved == 0 {
            budget.hold = 1.0;
            return true;
        }
        report.relaxed = report.relaxed.max(moved);
        // Each round's move is swept through the solids before the next projection sees it
        // (an expanding block must meet the walls it expands against, not pile onto them
        // after the last round).
        collider_contact(
            fluid,
            ws,
            scene,
            false,
            (bodies.as_deref_mut(), false),
            report,
        );
        ws.previous_positions.copy_from_slice(fluid.positions());
        // The densities are those the round corrected: within the settled bound, this
        // round's moves were the last small ones.
        let densest = fluid.densities().iter().copied().fold(0.0, Real::max);
        if densest <= lattice_density * (1.0 + RELAX_SETTLED) {
            budget.hold = 1.0;
            return true;
        }
        budget.record(densest / lattice_density - 1.0 - RELAX_SETTLED);
        round += 1;
    }
    budget.hold = 1.0 + RELAX_SETTLED + budget.last;
    false
}

/// Overlap means denser than the fluid's own spawn lattice (what `add_block` makes): for SI
/// presets that is ρ0 to 0.003 %; the paper's preset is at 5.5 ρ0 on its lattice and is left
/// as the paper has it.
fn lattice_density(p: &FluidParams) -> Real {
    let (h, s) = (p.smoothing_length, p.particle_spacing);
    let r = (h / s).ceil() as i32;
    let mut sum = 0.0;
    for x in -r..=r {
        for y in -r..=r {
            for z in -r..=r {
                let d = Vector::new(x as Real, y as Real, z as Real).length() * s;
                sum += p.density_kernel.w(d, h);
            }
        }
    }
    (sum * p.particle_mass).max(p.rest_density)
}

/// A neighbour search at the current positions (the positions at the round's start follow).
fn search(fluid: &mut Fluid, ws: &mut Workspace, report: &mut StepReport) {
    let (p, mut particles) = fluid.split_mut();
    let previous = Some(&mut ws.previous_positions);
    report.timed(Stage::NeighbourSearch, || {
        ws.search.search(
            &mut particles,
            previous,
            p.smoothing_length,
            p.domain.minimum_image(),
        )
    });
}

/// Particles at exactly the same place have no separation to push along (the smooth
/// kernels' gradients vanish at 0): moves each one that has a coincident neighbour by a small
/// offset that depends only on its id (deterministic).
fn separate_coincident(fluid: &mut Fluid, ws: &mut Workspace) {
    let (p, particles) = fluid.split_mut();
    let positions = particles.positions;
    let s = p.particle_spacing;
    let domain = p.domain.minimum_image();
    let mut any = false;
    for i in 0..positions.len() {
        let xi = positions[i];
        let hit = ws.search.lists.of(i).iter().any(|&j| {
            let r = match &domain {
                None => xi - positions[j as usize],
                Some(d) => d.sep(xi, positions[j as usize]),
            };
            r.length() < 1e-3 * s
        });
        if hit {
            let id = particles.ids[i];
            let frac = ((id as f64 * 0.618_033_988_75).fract() as Real) * 0.9 + 0.1;
            let dir = crate::math::coincident_direction(id, u32::MAX)
                + crate::math::coincident_direction(id.wrapping_mul(3), u32::MAX - 1) * 0.5;
            positions[i] += dir * (0.05 * s * frac);
            any = true;
        }
    }
    if any {
        ws.search.grid.build_cells();
        ws.search.build_lists(positions, p.smoothing_length, domain);
    }
}

/// One projection round of the PBF density constraint against the lattice's density, walls
/// counting (a particle on a solid's surface is compressed by the wall as much as by fluid).
/// Returns how many particles it moved.
fn project(
    fluid: &mut Fluid,
    ws: &mut Workspace,
    scene: Option<Scene<'_>>,
    bodies: Option<&Coupling>,
    lattice_density: Real,
    report: &mut StepReport,
) -> usize {
    let (p, particles) = fluid.split_mut();
    let wall = match scene {
        Some(scene) if p.wall_density => {
            let query = WallQuery {
                params: p,
                force_kernel: p.density_kernel,
                scene: (scene.bvh, scene.colliders, scene.bodies),
                coupling: bodies,
                hydrostatic: None,
                viscous: false,
                predicted: false,
                watch: None,
                planes: false,
            };
            let positions = &particles.positions[..];
            report.timed(Stage::WallDensity, || {
                ws.wall.update(&ws.search, positions, &query)
            });
            ws.wall.any().then_some(&ws.wall)
        }
        _ => None,
    };
    let settings = Pbf {
        iterations: 1,
        relaxation: 0.01,
        artificial_pressure: 0.0,
        ..Pbf::default()
    };
    let ctx = PbfContext {
        settings: &settings,
        neighbors: &ws.search.lists,
        wall,
        mass: p.particle_mass,
        h: p.smoothing_length,
        spacing: p.particle_spacing,
        rest_density: lattice_density,
        tolerance: RELAX_TOLERANCE,
        max_move: RELAX_MAX_MOVE * p.particle_spacing,
        safeguard: false,
        ratio: None,
    };
    let (buffers, inv) = (&mut ws.relax, &mut ws.inv_densities);
    let stats = report.timed(Stage::Relaxation, || {
        crate::with_separation!(p.domain, S, sep =>
            crate::with_kernel!(p.density_kernel, K => crate::solver::pbf::solve::<K, S>(
                &ctx, buffers, particles.positions, particles.densities, inv, sep)))
    });
    stats.moved
}
