//! What a step did and how long each stage took.

use crate::math::Real;
use std::fmt;
use std::time::Duration;

/// The named stages of one step, in the order they run.
///
/// # Examples
/// ```
/// use rapier_sph::prelude::*;
/// let mut world = FluidWorld::new();
/// let mut water = Fluid::new(FluidParamsBuilder::water(0.05))?;
/// water.add_block(Vector::ZERO, Vector::splat(0.2))?;
/// world.fluids.insert(water);
/// let report = world.step()?;
/// // Where a frame's time went, stage by stage (no collider here: no contact stage).
/// for stage in Stage::ALL {
///     println!("{:>22} {:?}", stage.name(), report.timings.get(stage));
/// }
/// assert!(report.timings.get(Stage::NeighbourSearch) > std::time::Duration::ZERO);
/// assert_eq!(report.timings.get(Stage::Contact), std::time::Duration::ZERO);
/// # Ok::<(), SphError>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum Stage {
    /// Overlap relaxation of particles just added or pushed out of a solid (runs only then;
    /// its neighbour searches and wall updates count under their own stages).
    Relaxation,
    /// Sort particles by cell, build cells and neighbour lists.
    NeighbourSearch,
    /// Density and pressure-gradient contributions of nearby colliders (skipped when no
    /// collider is near, or when the fluid's `wall_density` is off).
    WallDensity,
    /// Kernel-summed density (DFSPH: and its factors), and the step report's density error
    /// measured from it.
    Density,
    /// Pressure from density (equation of state; WCSPH only).
    Pressure,
    /// DFSPH divergence solve.
    DivergenceSolve,
    /// Symmetric pressure force (WCSPH only). For one fluid with the paper's pressure force
    /// and explicit viscosity, WCSPH computes the viscosity in the same pass over the pairs
    /// and times both here ([`Stage::ViscosityForce`] then reads zero).
    PressureForce,
    /// Viscosity force (skipped when ε = 0).
    ViscosityForce,
    /// Gravity (skipped when zero).
    ExternalForces,
    /// DFSPH constant-density solve.
    DensitySolve,
    /// Symplectic Euler: velocity, then position.
    ParticleUpdate,
    /// Surface tension and adhesion (Akinci et al. 2013; skipped when both are 0).
    SurfaceTension,
    /// Collider contact (skipped when no collider is near the fluid).
    Contact,
    /// Diffusion of the scalars the particles carry (a dye, a temperature; see
    /// [`crate::scalars`]); runs only for a fluid that has scalars with a diffusivity.
    ScalarDiffusion,
    /// The implicit viscosity solve (Weiler et al. 2018; runs only for a fluid that asks for
    /// it, see [`crate::ViscositySolve`]), after the solver's substep.
    ViscositySolve,
}

impl Stage {
    /// All stages in step order.
    pub const ALL: [Stage; 15] = [
        Stage::Relaxation,
        Stage::NeighbourSearch,
        Stage::WallDensity,
        Stage::Density,
        Stage::Pressure,
        Stage::DivergenceSolve,
        Stage::PressureForce,
        Stage::ViscosityForce,
        Stage::ExternalForces,
        Stage::DensitySolve,
        Stage::ParticleUpdate,
        Stage::SurfaceTension,
        Stage::Contact,
        Stage::ScalarDiffusion,
        Stage::ViscositySolve,
    ];

    /// The stage's name as printed in reports.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Relaxation => "overlap relaxation",
            Stage::NeighbourSearch => "neighbour search",
            Stage::WallDensity => "wall density",
            Stage::Density => "density",
            Stage::Pressure => "pressure calculation",
            Stage::DivergenceSolve => "divergence solve",
            Stage::PressureForce => "pressure force",
            Stage::ViscosityForce => "viscosity force",
            Stage::ExternalForces => "external forces",
            Stage::DensitySolve => "density solve",
            Stage::ParticleUpdate => "particle update",
            Stage::SurfaceTension => "surface tension",
            Stage::Contact => "collider contact",
            Stage::ScalarDiffusion => "scalar diffusion",
            Stage::ViscositySolve => "viscosity solve",
        }
    }
}

/// Wall time per stage, summed over fluids (and over steps when accumulated).
///
/// # Examples
/// ```
/// use rapier_sph::prelude::*;
/// use rapier_sph::StageTimings;
/// let mut world = FluidWorld::new();
/// let mut water = Fluid::new(FluidParamsBuilder::water(0.05))?;
/// water.add_block(Vector::ZERO, Vector::splat(0.2))?;
/// world.fluids.insert(water);
/// // A per-stage profile over ten frames (its Display prints a table).
/// let mut total = StageTimings::default();
/// for _ in 0..10 {
///     total.accumulate(&world.step()?.timings);
/// }
/// assert!(total.total() >= total.get(Stage::Density));
/// println!("{total}");
/// # Ok::<(), SphError>(())
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct StageTimings {
    times: [Duration; Stage::ALL.len()],
}

impl StageTimings {
    /// Time spent in `stage`.
    pub fn get(&self, stage: Stage) -> Duration {
        self.times[stage as usize]
    }

    /// Adds `d` to `stage`.
    pub fn add(&mut self, stage: Stage, d: Duration) {
        self.times[stage as usize] += d;
    }

    /// Total over all stages.
    pub fn total(&self) -> Duration {
        self.times.iter().sum()
    }

    /// Adds every stage of `other`.
    pub fn accumulate(&mut self, other: &StageTimings) {
        for (a, b) in self.times.iter_mut().zip(other.times) {
            *a += b;
        }
    }
}

/// What one call to [`crate::FluidPipeline::step`] did.
///
/// # Examples
/// ```
/// use rapier_sph::prelude::*;
/// let mut world = FluidWorld::new();
/// let mut water = Fluid::new(FluidParamsBuilder::water(0.05))?;
/// water.add_block(Vector::ZERO, Vector::splat(0.2))?;
/// world.fluids.insert(water);
/// let report = world.step()?;
/// assert_eq!((report.particles, report.quarantined, report.emitted), (64, 0, 0));
/// println!("{} substeps; where the time went:\n{}", report.substeps, report.timings);
/// # Ok::<(), SphError>(())
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepReport {
    /// Wall time of each stage.
    pub timings: StageTimings,
    /// Particles over all fluids.
    pub particles: usize,
    /// Directed neighbour pairs found (sum of neighbour-list lengths).
    pub neighbour_pairs: usize,
    /// Particles whose motion a collider changed.
    pub contacts: usize,
    /// Particles kept at their start position because a corrected position failed the check.
    pub contact_fallbacks: usize,
    /// Particles that started inside a solid and were pushed out.
    pub depenetrated: usize,
    /// Particles whose position or velocity became NaN or infinite during the step.
    pub non_finite: usize,
    /// Largest particle speed after the update (m/s).
    pub max_speed: Real,
    /// Particle speeds limited to what the moving bodies near them can give (a wall moving
    /// at `V` gives at most `2V`; see [`crate::FluidPipeline::step`]), counted per substep.
    pub speed_limited: usize,
    /// Largest relative compression `max(ρ − ρ0, 0)/ρ0` over all particles and substeps
    /// (under-density at a free surface is not an error; see `density::density_error`).
    pub max_density_error: Real,
    /// Mean relative compression over all particles (each fluid weighted by its count),
    /// averaged over the substeps.
    pub mean_density_error: Real,
    /// Substeps the frame was divided into (see [`crate::TimeStepping`]).
    pub substeps: u32,
    /// `true` when the substep cap bound: the substeps were longer than the stability
    /// limit asked for.
    pub substep_cap_hit: bool,
    /// Shortest and longest substep (s).
    pub min_substep: Real,
    /// Longest substep (s).
    pub max_substep: Real,
    /// Pressure-solver iterations over all substeps and fluids (DFSPH: constant-density solve).
    pub solver_iterations: u32,
    /// DFSPH divergence-solve iterations over all substeps and fluids.
    pub divergence_iterations: u32,
    /// Largest average density error a solver ended a substep with (fraction of `ρ0`).
    pub solver_density_error: Real,
    /// Largest average divergence error a divergence solve ended with (`|Dρ/Dt|·dt/ρ0`).
    pub solver_divergence_error: Real,
    /// Solves stopped by their iteration cap before reaching their error target.
    pub solver_capped: u32,
    /// DFSPH and PBF: the most times any fluid's Jacobi relaxation has been halved because a
    /// solve diverged (0: never, the usual case; see
    /// [`crate::solver::dfsph::MAX_RELAXATION_HALVINGS`] and
    /// [`crate::solver::pbf::MAX_RELAXATION_HALVINGS`]).
    pub solver_relaxation_halvings: u32,
    /// DFSPH with hydrostatic walls: solves that diverged and finished without the walls'
    /// neighbour part (see `solver::dfsph::DfsphBuffers::applied_neighbour`).
    pub solver_wall_neighbour_dropped: u32,
    /// Particles with a collider within their kernel support (walls counting in density).
    pub particles_near_walls: usize,
    /// Most particles moved by one round of overlap relaxation (particles just added, or pushed
    /// out of a solid, overlapping beyond 1 % compression; 0 when nothing overlapped).
    pub relaxed: usize,
    /// Overlap relaxation rounds run over all substeps and fluids (each: one neighbour search
    /// and one position projection).
    pub relax_rounds: u32,
    /// An overlap relaxation was stopped by its budget ([`crate::pipeline::RELAX_FRAME_ROUNDS`]
    /// rounds per fluid and frame) before every particle was within 2 % of the rest lattice's
    /// density: the rest of the overlap met the solver (which turns it into velocity) and the
    /// relaxation goes on in the next frame.
    pub relax_unfinished: bool,
    /// When a relaxation is unfinished at the frame's end: the largest compression it left,
    /// as a fraction of the rest lattice's density beyond the 2 % it settles at (0 otherwise).
    pub relax_compression: Real,
    /// An unfinished relaxation removed less than [`crate::pipeline::RELAX_PROGRESS`] (10 %)
    /// of its compression over the whole frame: the overlap cannot be relaxed where it is
    /// (more fluid than its closed container holds at rest density, positions `f32` cannot
    /// separate). The fluid stays compressed, the solver holds it as it can, and the next
    /// frames spend fewer rounds on it (down to [`crate::pipeline::RELAX_STALLED_ROUNDS`]).
    pub relax_stalled: bool,
    /// Particles whose viscous exchange was limited, summed over substeps: the viscosity
    /// asked for more than the explicit update can hold in the substep (see
    /// `src/forces/viscosity.rs`; the substep cap bound, or a particle had almost no
    /// neighbours), and brought them at most half way to their common velocity.
    pub viscosity_limited: usize,
    /// Conjugate-gradient iterations of the implicit viscosity solve, summed over substeps
    /// and fluids (0 when no fluid uses it; see [`crate::ViscositySolve`]).
    pub viscosity_iterations: usize,
    /// The largest relative residual (`|b − A v|/|b|`) an implicit viscosity solve stopped
    /// at over the step's substeps and fluids: below the settings' tolerance unless the
    /// iteration cap bound (0 when no fluid uses a solve).
    pub viscosity_residual: Real,
    /// Particles whose scalar diffusion was limited, summed over substeps and scalars: the
    /// diffusivity asked for more than the explicit update holds in the substep (`D·dt >
    /// h²/30` on a resting lattice; see [`crate::scalars`]), and the scalar diffused at the
    /// bound's rate there instead.
    pub scalar_limited: usize,
    /// Particles removed because their position or velocity was no longer finite (they are
    /// taken out before they can poison their neighbours; see [`crate::Fluid::quarantined`]).
    pub quarantined: usize,
    /// Particles added by emitters during the step (see [`crate::emitter`]).
    pub emitted: usize,
    /// Particles removed by sinks during the step.
    pub drained: usize,
    /// Particles that were due from an emitter but could not be placed (the nozzle was
    /// blocked by particles or a solid); they are not emitted.
    pub emitter_blocked: usize,
    /// `true` when a fluid's capacity stopped its emitters during the step.
    pub capacity_reached: bool,
    /// Dynamic bodies that received impulses from the fluid (applied through rapier at the
    /// end of the step; see `src/boundary/bodies.rs`).
    pub coupled_bodies: usize,
    /// Fluids that slept through the step (not stepped; see [`crate::sleep`]).
    pub sleeping: usize,
}

impl fmt::Display for StageTimings {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let total = self.total().as_secs_f64().max(1e-12);
        for stage in Stage::ALL {
            let t = self.get(stage).as_secs_f64();
            writeln!(
                f,
                "  {:<22} {:>10.3} ms {:>6.1} %",
                stage.name(),
                t * 1e3,
                100.0 * t / total
            )?;
        }
        write!(f, "  {:<22} {:>10.3} ms", "total", total * 1e3)
    }
}

impl StepReport {
    /// Runs `f`, adding its wall time to `stage`.
    pub(crate) fn timed<T>(&mut self, stage: Stage, f: impl FnOnce() -> T) -> T {
        let t0 = std::time::Instant::now();
        let out = f();
        self.timings.add(stage, t0.elapsed());
        out
    }
}
