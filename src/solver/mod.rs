//! Pressure solvers: how a fluid keeps its density. Chosen per fluid with
//! [`crate::FluidParams::solver`]; all solvers share the particles, the neighbour search, the
//! kernels, the walls' density contributions and collider contact.
//!
//! | solver | idea | cost per step | use it for |
//! |---|---|---|---|
//! | [`Solver::Wcsph`] | pressure from an equation of state (Müller et al. 2003; the Unity paper) | 3 neighbour passes, small time steps (`dt ≤ 0.4·h/c`) | reproducing the paper (the paper preset's default) |
//! | [`Solver::Dfsph`] | pressure solved for: divergence-free and constant-density (Bender & Koschier 2017) | 1 + 2 per iteration, large time steps | the water preset's default: the most accurate, and the cheapest per 1/60 s frame measured (a pool of 10,240 particles: 30.9 ms of CPU per frame against PBF 41.6, Clavet 43.1, WCSPH 51.3; `cargo run --release --example frame_budget`) |
//! | [`Solver::Clavet`] | double-density relaxation of predicted positions (Clavet et al. 2005) | 2 + viscosity, acoustic time steps | games wanting cohesive, splashy liquid; the paper's future work |
//! | [`Solver::Pbf`] | incompressibility as a position constraint, a fixed number of Jacobi iterations (Macklin & Müller 2013) | 2 per iteration (default 4 iterations) + viscosity, any time step | a fixed cost per substep that never diverges (it takes more substeps than DFSPH under gravity: 1.35× DFSPH's CPU in that pool) |

//!
//! # How a solver plugs in
//!
//! Each solver is a folder (or file) of its own with its settings (a variant of [`Solver`]),
//! a state holding its buffers, and an implementation of the crate's `PressureSolver` trait,
//! which the pipeline calls once per substep with the step context (the particle arrays,
//! neighbour lists, walls and report). The pipeline never matches on the solver: it asks the
//! state what it needs (positions predicted before the neighbour search or not, which wall
//! tables, its share of the walls' reaction on bodies, its time-step limit). ARCHITECTURE.md
//! lists what a new solver implements.

pub mod clavet;
pub(crate) mod context;
pub mod dfsph;
pub(crate) mod pairs;
pub mod pbf;
pub(crate) mod settings;
pub mod springs;
mod wcsph;

use crate::domain::Separation;
use crate::kernel::KernelKind;
use crate::math::{Real, Vector};
use crate::params::FluidParams;
use context::{Outcome, StepContext};

/// Most halvings of a fluid's Jacobi relaxation `ω` (down to 1/8), shared by DFSPH and PBF:
/// both halve `ω` when their iteration diverges and keep the count on the fluid (one count per
/// fluid, saved in snapshots, reported as [`crate::StepReport::solver_relaxation_halvings`]).
/// Why and when, per solver: [`dfsph::MAX_RELAXATION_HALVINGS`], [`pbf::MAX_RELAXATION_HALVINGS`].
pub const MAX_RELAXATION_HALVINGS: u32 = 3;

/// The relaxation `ω = 0.5^halvings` after `halvings` halvings.
#[inline]
pub(crate) fn relaxation(halvings: u32) -> Real {
    Real::powi(0.5, halvings as i32)
}
pub use dfsph::{HYDROSTATIC_WALL_MIRROR, WALL_MIRROR};
pub use settings::{Clavet, Dfsph, Pbf, Solver, Springs, WcsphDensity, WcsphPressure};

/// What a solver asks of the wall stage (`boundary::wall`).
#[derive(Copy, Clone, Debug)]
pub(crate) struct WallRequest {
    /// Kernel of the walls' pressure-gradient table (the solver's force kernel).
    pub force_kernel: KernelKind,
    /// The walls' hydrostatic pressure (DFSPH's and PBF's `hydrostatic_walls`).
    pub hydrostatic: bool,
    /// Clavet's two densities' wall tables.
    pub double_density: bool,
    /// Each particle's walls as planes (`boundary::WallWorkspace::plane_chunks`; DFSPH's
    /// `predict_walls`).
    pub planes: bool,
}

impl WallRequest {
    /// The request of a solver whose forces use the fluid's density kernel (DFSPH, PBF), with
    /// the walls' hydrostatic pressure or not.
    pub(crate) fn density_kernel(params: &FluidParams, hydrostatic: bool) -> Self {
        Self {
            force_kernel: params.density_kernel,
            hydrostatic,
            double_density: false,
            planes: false,
        }
    }
}

/// How the impulse a particle's wall term gave it goes back to a dynamic body.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum WallReaction {
    /// As an impulse; with `added_mass` the particle moves along with the body in the
    /// direction its wall term pushed it (the added-mass solve of
    /// `boundary::bodies::Coupling::exchange`, as for contact).
    Impulse {
        /// Whether the exchange treats the particle as moving with the body along the wall's
        /// normal.
        added_mass: bool,
    },
}

/// What every pressure solver implements. The pipeline calls these through [`SolverState`].
pub(crate) trait PressureSolver {
    /// The solver's settings (a [`Solver`] variant's payload).
    type Settings;
    /// `true` for the position-based solvers (PBF, Clavet): the pipeline adds gravity and
    /// predicts the positions to the substep's end before the neighbour search; the solver
    /// then corrects the predicted positions. `false`: the solver integrates at its end.
    const PREDICTS_POSITIONS: bool;
    /// How the solver's wall term reacts on dynamic bodies.
    const WALL_REACTION: WallReaction;
    /// What the solver asks of the wall stage.
    fn walls(settings: &Self::Settings, params: &FluidParams) -> WallRequest;
    /// Density, pressure, forces and the particle update of one substep.
    fn step<S: Separation>(
        &mut self,
        settings: &Self::Settings,
        ctx: &mut StepContext<'_>,
        sep: S,
    ) -> Outcome;
    /// The impulse particle `i`'s wall term gave it this substep is `gradient_c · scale`,
    /// `gradient_c` the dynamic bodies' share of the wall density's gradient; this returns
    /// `scale` (read after [`PressureSolver::step`]).
    fn wall_impulse_scale(
        &self,
        settings: &Self::Settings,
        ctx: &StepContext<'_>,
        i: usize,
    ) -> Real;
    /// The impulse particle `i`'s wall term gave the dynamic bodies this substep (N·s, on
    /// the bodies), `gradient_c` the dynamic bodies' share of the wall density's gradient:
    /// `gradient_c · scale` ([`PressureSolver::wall_impulse_scale`]) unless the solver's
    /// wall term is not along it (Clavet's two densities; read after
    /// [`PressureSolver::step`]).
    fn wall_impulse(
        &self,
        settings: &Self::Settings,
        ctx: &StepContext<'_>,
        i: usize,
        gradient_c: Vector,
    ) -> Vector {
        gradient_c * self.wall_impulse_scale(settings, ctx, i)
    }
    /// The solver's own stability limit on the substep (s), beyond the CFL and viscous limits
    /// every solver shares; `speed` is the fluid's largest speed.
    fn time_step_limit(
        &mut self,
        settings: &Self::Settings,
        params: &FluidParams,
        speed: Real,
        gravity: Vector,
        courant: Real,
    ) -> Real;
    /// How many times the solver halved its Jacobi relaxation (0 if it has none).
    fn relaxation_halvings(&self) -> u32 {
        0
    }
    /// Heap bytes held.
    fn heap_bytes(&self) -> usize;
}

/// The part of a solver's state that a save and restore must carry for the run to continue
/// bit for bit: the relaxation count (DFSPH, PBF) and Clavet's springs.
#[derive(Clone, Debug, Default)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub(crate) struct SolverMemory {
    /// See [`crate::StepReport::solver_relaxation_halvings`].
    pub relaxation_halvings: u32,
    /// Clavet's viscoelastic springs.
    pub springs: springs::SpringSet,
}

/// The state of a fluid's solver: one variant per solver (the registration).
#[derive(Clone, Debug)]
pub(crate) enum SolverState {
    /// See [`Solver::Wcsph`].
    Wcsph(wcsph::WcsphState),
    /// See [`Solver::Dfsph`].
    Dfsph(dfsph::DfsphState),
    /// See [`Solver::Pbf`].
    Pbf(pbf::PbfState),
    /// See [`Solver::Clavet`].
    Clavet(clavet::ClavetState),
}

/// Runs `$body` with `$state` bound to the solver's state and `$settings` to its settings.
macro_rules! dispatch {
    ($state:expr, $solver:expr, |$st:ident, $settings:ident| $body:expr) => {
        match ($state, $solver) {
            (SolverState::Wcsph($st), Solver::Wcsph) => {
                let $settings = &();
                $body
            }
            (SolverState::Dfsph($st), Solver::Dfsph(s)) => {
                let $settings = s;
                $body
            }
            (SolverState::Pbf($st), Solver::Pbf(s)) => {
                let $settings = s;
                $body
            }
            (SolverState::Clavet($st), Solver::Clavet(s)) => {
                let $settings = s;
                $body
            }
            _ => unreachable!("the solver state is rebuilt when the settings change solver"),
        }
    };
}

impl SolverState {
    /// A fresh state for `solver`.
    pub fn new(solver: &Solver) -> Self {
        match solver {
            Solver::Wcsph => SolverState::Wcsph(Default::default()),
            Solver::Dfsph(_) => SolverState::Dfsph(Default::default()),
            Solver::Pbf(_) => SolverState::Pbf(Default::default()),
            Solver::Clavet(_) => SolverState::Clavet(Default::default()),
        }
    }

    /// `true` when this state belongs to `solver`'s kind.
    pub fn is_for(&self, solver: &Solver) -> bool {
        matches!(
            (self, solver),
            (SolverState::Wcsph(_), Solver::Wcsph)
                | (SolverState::Dfsph(_), Solver::Dfsph(_))
                | (SolverState::Pbf(_), Solver::Pbf(_))
                | (SolverState::Clavet(_), Solver::Clavet(_))
        )
    }

    /// See [`PressureSolver::PREDICTS_POSITIONS`].
    pub fn predicts_positions(&self) -> bool {
        match self {
            SolverState::Wcsph(_) => wcsph::WcsphState::PREDICTS_POSITIONS,
            SolverState::Dfsph(_) => dfsph::DfsphState::PREDICTS_POSITIONS,
            SolverState::Pbf(_) => pbf::PbfState::PREDICTS_POSITIONS,
            SolverState::Clavet(_) => clavet::ClavetState::PREDICTS_POSITIONS,
        }
    }

    /// See [`PressureSolver::WALL_REACTION`].
    pub fn wall_reaction(&self) -> WallReaction {
        match self {
            SolverState::Wcsph(_) => wcsph::WcsphState::WALL_REACTION,
            SolverState::Dfsph(_) => dfsph::DfsphState::WALL_REACTION,
            SolverState::Pbf(_) => pbf::PbfState::WALL_REACTION,
            SolverState::Clavet(_) => clavet::ClavetState::WALL_REACTION,
        }
    }

    /// See [`PressureSolver::walls`].
    pub fn walls(&self, params: &FluidParams) -> WallRequest {
        fn of<T: PressureSolver>(_: &T, s: &T::Settings, p: &FluidParams) -> WallRequest {
            T::walls(s, p)
        }
        dispatch!(self, &params.solver, |st, settings| of(
            st, settings, params
        ))
    }

    /// See [`PressureSolver::step`]; the separation (open or periodic domain) is chosen here,
    /// so each solver's substep is compiled for both.
    pub fn step(&mut self, ctx: &mut StepContext<'_>) -> Outcome {
        let params = ctx.params;
        dispatch!(self, &params.solver, |st, settings| {
            crate::with_separation!(params.domain, S, sep => st.step(settings, ctx, sep))
        })
    }

    /// See [`PressureSolver::wall_impulse_scale`].
    pub fn wall_impulse_scale(&self, ctx: &StepContext<'_>, i: usize) -> Real {
        dispatch!(self, &ctx.params.solver, |st, settings| st
            .wall_impulse_scale(settings, ctx, i))
    }

    /// See [`PressureSolver::wall_impulse`].
    pub fn wall_impulse(&self, ctx: &StepContext<'_>, i: usize, gradient_c: Vector) -> Vector {
        dispatch!(self, &ctx.params.solver, |st, settings| st
            .wall_impulse(settings, ctx, i, gradient_c))
    }

    /// See [`PressureSolver::time_step_limit`].
    pub fn time_step_limit(
        &mut self,
        params: &FluidParams,
        speed: Real,
        gravity: Vector,
        courant: Real,
    ) -> Real {
        dispatch!(self, &params.solver, |st, settings| st
            .time_step_limit(settings, params, speed, gravity, courant))
    }

    #[cfg_attr(not(feature = "snapshot"), allow(dead_code))]
    /// What a snapshot keeps of the state.
    pub fn memory(&self) -> SolverMemory {
        let relaxation_halvings = match self {
            SolverState::Wcsph(s) => s.relaxation_halvings(),
            SolverState::Dfsph(s) => s.relaxation_halvings(),
            SolverState::Pbf(s) => s.relaxation_halvings(),
            SolverState::Clavet(s) => s.relaxation_halvings(),
        };
        let springs = match self {
            SolverState::Clavet(c) => c.springs.clone(),
            _ => Default::default(),
        };
        SolverMemory {
            relaxation_halvings,
            springs,
        }
    }

    /// Restores what [`SolverState::memory`] kept (the count clamped to
    /// [`MAX_RELAXATION_HALVINGS`]).
    #[cfg_attr(not(feature = "snapshot"), allow(dead_code))]
    pub fn restore(&mut self, memory: SolverMemory) {
        let halvings = memory.relaxation_halvings.min(MAX_RELAXATION_HALVINGS);
        match self {
            SolverState::Wcsph(_) => {}
            SolverState::Dfsph(s) => s.buffers.relaxation_halvings = halvings,
            SolverState::Pbf(s) => s.buffers.relaxation_halvings = halvings,
            SolverState::Clavet(s) => s.springs = memory.springs,
        }
    }

    /// See [`PressureSolver::heap_bytes`].
    pub fn heap_bytes(&self) -> usize {
        match self {
            SolverState::Wcsph(s) => s.heap_bytes(),
            SolverState::Dfsph(s) => s.heap_bytes(),
            SolverState::Pbf(s) => s.heap_bytes(),
            SolverState::Clavet(s) => s.heap_bytes(),
        }
    }
}

/// The end of a position-based solver's substep (PBF, Clavet): velocities from the corrected
/// positions, then viscosity on the new velocities (the role XSPH plays in Macklin & Müller).
/// Interacting fluids ([`StepContext::phases`]): each pair at `√(ε_i·ε_j)`, and each
/// particle's velocity change divided by its own mass (`r_i` times the reference's), as
/// WCSPH's and DFSPH's viscosity: the pair's momentum exchange stays antisymmetric.
pub(crate) fn finish_position_step<S: Separation>(ctx: &mut StepContext<'_>, sep: S) -> Outcome {
    let p = ctx.params;
    let dt = ctx.dt;
    let mut outcome: Outcome = ctx
        .report
        .timed(crate::Stage::ParticleUpdate, || {
            crate::integrate::velocities_from_positions(
                dt,
                ctx.positions,
                ctx.previous_positions,
                ctx.velocities,
            )
        })
        .into();
    if p.explicit_viscosity() > 0.0 {
        let limited = ctx.report.timed(crate::Stage::ViscosityForce, || {
            ctx.accelerations.fill(Vector::ZERO);
            let pairs = crate::neighbors::Pairs {
                positions: ctx.positions,
                neighbors: ctx.neighbors,
                mass: p.particle_mass,
                h: p.smoothing_length,
                sep,
            };
            // Interacting fluids only: the weighted `1/ρ` (a buffer per substep of a group).
            let mut weighted = Vec::new();
            let inv = match ctx.phases {
                Some(ph) => {
                    ph.viscous_inv_densities(ctx.inv_densities, &mut weighted);
                    &weighted[..]
                }
                None => &ctx.inv_densities[..],
            };
            let limited = crate::forces::viscosity::add_accelerations(
                &pairs,
                ctx.velocities,
                inv,
                (p.explicit_viscosity(), dt),
                ctx.accelerations,
            );
            if let Some(ph) = ctx.phases {
                ph.scale(ctx.accelerations);
            }
            crate::integrate::add_accelerations(dt, ctx.accelerations, ctx.velocities);
            limited
        });
        ctx.report.viscosity_limited += limited;
        outcome = crate::integrate::scan(ctx.positions, ctx.velocities).into();
    }
    outcome
}
