//! DFSPH's substep as the pipeline calls it: density and factors, divergence solve,
//! non-pressure forces, constant-density solve, particle update (Bender & Koschier 2017,
//! Alg. 1), and its state: the iteration buffers, the pair gradients and the relaxation count.
//! The warm starts (the last solves' pressure values) are per-particle values that must follow
//! the particles from one step to the next, so they are kept as the fluid's attributes
//! [`WARM_DENSITY`] and [`WARM_DIVERGENCE`].

use super::{Dfsph, DfsphBuffers, FactorInput, Factors, SolveContext, WarmPush};
use crate::diagnostics::Stage;
use crate::domain::Separation;
use crate::fluid::Attributes;
use crate::kernel::ViscosityLaplacian;
use crate::math::{Real, Vector};
use crate::neighbors::Pairs;
use crate::params::FluidParams;
use crate::solver::context::{Outcome, StepContext};
use crate::solver::pairs::PairGradients;
use crate::solver::{PressureSolver, WallReaction, WallRequest};
use crate::{forces, integrate};

/// Attribute holding the constant-density solve's pressure values `π = p/ρ²` (warm start).
pub(crate) const WARM_DENSITY: &str = "dfsph.warm_density";
/// Attribute holding the divergence solve's pressure values (warm start).
pub(crate) const WARM_DIVERGENCE: &str = "dfsph.warm_divergence";
/// Attribute holding each particle's density as the last constant-density solve predicted it
/// (see [`Dfsph::carry_density_error`]).
pub(crate) const PREDICTED_DENSITY: &str = "dfsph.predicted_density";
/// Attribute holding the time step of that prediction (zero: none made).
pub(crate) const PREDICTED_DT: &str = "dfsph.predicted_dt";

/// Largest carried prediction error ([`Dfsph::carry_density_error`]), as a fraction of the
/// rest density: each particle's carried value is clamped to `±CARRIED_ERROR_LIMIT·ρ0`.
///
/// The carried value stands in for the linear prediction's second-order error in a smooth
/// flow, a fraction of a percent (salva scene, 20,000 particles: mean 0.15–0.3 %, a few
/// percent of the particles above 1 %). Where the front hits a wall the error is tens of
/// percent for one step (62,234-particle tank: 16 %, 31 %, 68 %, 81 % in the first four
/// steps of the impact at the far wall) and is not repeated the next step; carried, it drove
/// a correction whose own error was carried again, a runaway that spread from the impact
/// (the particles above 5 % grew 67 → 185 → 281 → 506 → 862 in 12 steps and the tank
/// diverged 20 steps later). Measured in the two scenes that diverged without a limit (that
/// tank at 5 ms steps, and the 2,500-particle tank at 10 ms steps, `tests/solvers.rs`): every
/// limit tried from 0.5 % to 20 % held both, and the mean compression falls as the limit
/// rises (62,234 particles: 0.128 / 0.117 / 0.109 / 0.105 / 0.103 / 0.103 % at 0.5 / 1 / 2 /
/// 5 / 10 / 20 %; 2,500 particles at 10 ms: 0.30 / 0.19 / 0.16 / 0.149 / 0.145 % at 0.5 / 2 /
/// 5 / 10 / 20 %). 5 % is four times under the largest limit tried that still held, and
/// above nearly all the values a smooth flow carries.
pub(crate) const CARRIED_ERROR_LIMIT: Real = 0.05;

/// With [`Dfsph::carry_density_error`]: turns the attribute [`PREDICTED_DENSITY`] into each
/// particle's last prediction error, `ρ_i − ρ_predicted`, scaled by `(dt/dt_last)²` (the
/// error is second order in the step; `dt_last` from [`PREDICTED_DT`], zero where no
/// prediction was made: a new particle, the first step) and clamped to `±limit`
/// ([`CARRIED_ERROR_LIMIT`] times `ρ0`), records `dt` as the next prediction's step, and
/// returns the attribute's index.
fn carried_errors(attributes: &mut Attributes, densities: &[Real], dt: Real, limit: Real) -> usize {
    let n = densities.len();
    let wp = attributes.ensure(PREDICTED_DENSITY, n);
    let wt = attributes.ensure(PREDICTED_DT, n);
    let (predicted, last_dt) = attributes.pair_mut(wp, wt);
    for ((p, t), &rho) in predicted.iter_mut().zip(last_dt.iter_mut()).zip(densities) {
        *p = if *t > 0.0 {
            let s = dt / *t;
            ((rho - *p) * (s * s)).clamp(-limit, limit)
        } else {
            0.0
        };
        *t = dt;
    }
    wp
}

/// The inputs both solves share, borrowed field by field from the step context (a function
/// would borrow the whole context while the solves write its velocities).
macro_rules! solve_context {
    ($gradients:expr, $ctx:expr, $closed:expr) => {{
        let p = $ctx.params;
        SolveContext {
            positions: $ctx.positions,
            neighbors: $ctx.neighbors,
            gradients: $gradients,
            wall: $ctx.wall,
            densities: $ctx.densities,
            mass: p.particle_mass,
            ratio: $ctx.phases.map(|ph| ph.ratio),
            rest_density: p.rest_density,
            dt: $ctx.dt,
            expected_neighbours: p.expected_neighbours(),
            closed: $closed,
            self_density: p.particle_mass * p.density_kernel.w(0.0, p.smoothing_length),
            predict_walls: false,
            contact_radius: None,
        }
    }};
}

/// DFSPH's buffers and its persistent relaxation count.
#[derive(Clone, Debug, Default)]
pub(crate) struct DfsphState {
    /// Factors, iteration values, the velocities being corrected, the relaxation count.
    pub buffers: DfsphBuffers,
    /// Kernel gradients of every neighbour pair (computed once per substep by the density
    /// pass, read by both solves and by the walls' reaction).
    pub gradients: PairGradients,
    /// Interacting fluids: `1/ρ` times each particle's viscosity weight (see
    /// `solver::context::Phases`); empty for one fluid.
    pub viscous_inv_densities: Vec<Real>,
}

impl PressureSolver for DfsphState {
    type Settings = Dfsph;
    const PREDICTS_POSITIONS: bool = false;
    const WALL_REACTION: WallReaction = WallReaction::Impulse { added_mass: true };

    fn walls(settings: &Dfsph, params: &FluidParams) -> WallRequest {
        WallRequest {
            planes: settings.predict_walls,
            ..WallRequest::density_kernel(params, settings.hydrostatic_walls)
        }
    }

    fn step<S: Separation>(
        &mut self,
        settings: &Dfsph,
        ctx: &mut StepContext<'_>,
        sep: S,
    ) -> Outcome {
        let n = ctx.positions.len();
        let p = ctx.params;
        self.buffers.resize(n);
        let wd = ctx.attributes.ensure(WARM_DENSITY, n);
        let wv = ctx.attributes.ensure(WARM_DIVERGENCE, n);
        // A fluid filling a periodic box has no free surface (see `SolveContext::closed`).
        let closed = super::fills_periodic_box(
            &p.domain,
            n,
            p.particle_mass,
            p.rest_density,
            ctx.wall.is_some(),
            settings.max_density_error,
        );
        let pushed = {
            let (_, warm_divergence) = ctx.attributes.pair_mut(wd, wv);
            settings.divergence_solve && super::divergence_warm_start(warm_divergence, closed)
        };
        self.start_applied_neighbour(ctx, wv, pushed);
        self.density_and_factors(ctx, wv, pushed, sep);
        if settings.divergence_solve {
            self.divergence_solve(settings, ctx, (wd, wv), closed, pushed);
        }
        let forces = self.non_pressure_forces(ctx);
        self.density_solve(settings, ctx, (wd, wv), closed, forces);
        ctx.report
            .timed(Stage::ParticleUpdate, || {
                integrate::advance_positions(
                    ctx.dt,
                    ctx.velocities,
                    ctx.positions,
                    ctx.previous_positions,
                )
            })
            .into()
    }

    /// `γ·Σπ + Σπ̂` over the substep: all the pressure values the divergence and density
    /// solves applied (warm starts included: what the attributes hold now), the particle's
    /// own mirrored by `γ`, and with hydrostatic walls the neighbours' average as applied.
    fn wall_impulse_scale(&self, settings: &Dfsph, ctx: &StepContext<'_>, i: usize) -> Real {
        let n = ctx.positions.len();
        let warm = |name| ctx.attributes.find(name, n);
        let (Some(wd), Some(wv)) = (warm(WARM_DENSITY), warm(WARM_DIVERGENCE)) else {
            return 0.0;
        };
        let Some(w) = ctx.wall else { return 0.0 };
        let total = wd[i]
            + if settings.divergence_solve {
                wv[i]
            } else {
                0.0
            };
        let applied = &self.buffers.applied_neighbour;
        let wall_pi =
            super::wall_neighbour_pressure(ctx.neighbors, &self.gradients, w, i, |j| applied[j]);
        (w.mirror * total + wall_pi) * ctx.params.particle_mass * ctx.dt
    }

    /// Under gravity `g·dt² ≤ K·max_density_error·spacing`, `K` = `Dfsph::gravity_substep`
    /// (default 5): the density solve undoes, every substep, the compression gravity makes in
    /// it (a displacement of about `g·dt²`); keeping it within `K·max_density_error` spacings
    /// keeps the work per substep a few times the error the solve is asked to reach. Without it a fluid at rest takes CFL substeps of
    /// ~30 ms (nothing moves yet), far outside the solve's linearisation. At the default 0.1 %
    /// target this is 5 ms for 5 cm particles and 3.2 ms for 2 cm.
    fn time_step_limit(
        &mut self,
        settings: &Dfsph,
        params: &FluidParams,
        _: Real,
        gravity: Vector,
        _: Real,
    ) -> Real {
        let g = gravity.length();
        if g > 0.0 {
            (settings.gravity_substep * settings.max_density_error * params.particle_spacing / g)
                .sqrt()
        } else {
            Real::INFINITY
        }
    }

    fn relaxation_halvings(&self) -> u32 {
        self.buffers.relaxation_halvings
    }

    fn heap_bytes(&self) -> usize {
        self.buffers.heap_bytes()
            + self.gradients.heap_bytes()
            + self.viscous_inv_densities.capacity() * std::mem::size_of::<Real>()
    }
}

impl DfsphState {
    /// Hydrostatic walls: the pressure values their neighbour part is applied with this
    /// substep, starting with the divergence warm start's push (see
    /// [`DfsphBuffers::applied_neighbour`]).
    fn start_applied_neighbour(&mut self, ctx: &StepContext<'_>, wv: usize, pushed: bool) {
        if ctx.wall.is_some_and(|w| w.neighbour_pressure) {
            let applied = &mut self.buffers.applied_neighbour;
            applied.clear();
            if pushed {
                applied.extend_from_slice(ctx.attributes.get(wv));
            } else {
                applied.resize(ctx.positions.len(), 0.0);
            }
        }
    }

    /// Density and DFSPH factors, and the divergence solve's warm start (same pass).
    fn density_and_factors<S: Separation>(
        &mut self,
        ctx: &mut StepContext<'_>,
        wv: usize,
        pushed: bool,
        sep: S,
    ) {
        let p = ctx.params;
        let h = p.smoothing_length;
        let (dt, wall) = (ctx.dt, ctx.wall);
        let warm_divergence = ctx.attributes.get(wv);
        let velocities = &*ctx.velocities;
        let ratio = ctx.phases.map(|ph| ph.ratio);
        let (buffers, gradients) = (&mut self.buffers, &mut self.gradients);
        ctx.report.timed(Stage::Density, || {
            let viscosity = (p.explicit_viscosity() > 0.0).then(|| ViscosityLaplacian::new(h));
            let push = pushed.then_some(WarmPush {
                pi: warm_divergence,
                velocities,
                dt,
                ratio,
            });
            let pairs = Pairs {
                positions: ctx.positions,
                neighbors: ctx.neighbors,
                mass: p.particle_mass,
                h,
                sep,
            };
            let input = FactorInput {
                wall,
                viscosity,
                push,
            };
            let out = Factors {
                densities: ctx.densities,
                inv_densities: ctx.inv_densities,
                alpha: &mut buffers.alpha,
                grads: gradients,
                pushed: &mut buffers.velocities,
            };
            crate::with_kernel!(p.density_kernel, K =>
                super::density_and_factors::<K, S>(&pairs, &input, out));
            // Interacting fluids: each push weighted by its particle's ratio.
            if let Some(r) = ratio {
                super::phase_factors(
                    (ctx.neighbors, gradients),
                    (p.particle_mass, h),
                    (wall, r),
                    ctx.densities,
                    &mut buffers.alpha,
                );
            }
        });
    }

    /// The divergence solve (Alg. 2) on the current velocities.
    fn divergence_solve(
        &mut self,
        settings: &Dfsph,
        ctx: &mut StepContext<'_>,
        (wd, wv): (usize, usize),
        closed: bool,
        pushed: bool,
    ) {
        let t0 = std::time::Instant::now();
        let (_, warm_divergence) = ctx.attributes.pair_mut(wd, wv);
        let solve = solve_context!(&self.gradients, ctx, closed);
        let stats = super::divergence_solve(
            &solve,
            settings,
            &mut self.buffers,
            pushed,
            warm_divergence,
            ctx.velocities,
        );
        let report = &mut *ctx.report;
        report.timings.add(Stage::DivergenceSolve, t0.elapsed());
        report.divergence_iterations += stats.iterations;
        report.solver_wall_neighbour_dropped += stats.neighbour_dropped as u32;
        report.solver_divergence_error = report.solver_divergence_error.max(stats.error);
        report.solver_capped += stats.capped as u32;
    }

    /// Viscosity and gravity (and the hydrostatic wall term) into the accelerations. Returns
    /// whether any force acts (else the accelerations are zero).
    fn non_pressure_forces(&mut self, ctx: &mut StepContext<'_>) -> bool {
        let p = ctx.params;
        let mut forces = false;
        if p.explicit_viscosity() > 0.0 {
            forces = true;
            let (gradients, velocities) = (&self.gradients, &mut self.buffers.velocities);
            let dt = ctx.dt;
            let (phases, weighted) = (ctx.phases, &mut self.viscous_inv_densities);
            let limited = ctx.report.timed(Stage::ViscosityForce, || {
                ctx.accelerations.fill(Vector::ZERO);
                // Interacting fluids: each pair at `√(ε_i·ε_j)`, then `r_i` on particle `i`.
                let inv = match phases {
                    Some(ph) => {
                        ph.viscous_inv_densities(ctx.inv_densities, weighted);
                        &weighted[..]
                    }
                    None => &ctx.inv_densities[..],
                };
                // From the pair Laplacians stored by the density pass.
                let limited = super::viscosity(
                    (ctx.neighbors, gradients),
                    (ctx.velocities, inv),
                    (p.explicit_viscosity() * p.particle_mass, dt),
                    velocities,
                    ctx.accelerations,
                );
                if let Some(ph) = phases {
                    ph.scale(ctx.accelerations);
                }
                limited
            });
            ctx.report.viscosity_limited += limited;
        }
        if ctx.gravity != Vector::ZERO {
            let (gravity, wall) = (ctx.gravity, ctx.wall);
            ctx.report.timed(Stage::ExternalForces, || {
                if forces {
                    forces::external::add_gravity(gravity, ctx.accelerations);
                } else {
                    ctx.accelerations.fill(gravity);
                }
                if let Some(w) = wall
                    && w.hydrostatic_on
                {
                    for (a, h) in ctx.accelerations.iter_mut().zip(&w.hydrostatic) {
                        *a += *h;
                    }
                }
            });
            forces = true;
        }
        if !forces {
            ctx.accelerations.fill(Vector::ZERO);
        }
        forces
    }

    /// The constant-density solve (Alg. 3) on the predicted velocities; the pressures
    /// reported are all the pressure the substep applied (both solves' values, `π = p/ρ²`
    /// applied over the same `dt`).
    fn density_solve(
        &mut self,
        settings: &Dfsph,
        ctx: &mut StepContext<'_>,
        (wd, wv): (usize, usize),
        closed: bool,
        forces: bool,
    ) {
        let t0 = std::time::Instant::now();
        if forces {
            integrate::add_accelerations(ctx.dt, ctx.accelerations, ctx.velocities);
        }
        // The last prediction's error, carried (see `Dfsph::carry_density_error`).
        let carry = settings.carry_density_error && !closed;
        let limit = CARRIED_ERROR_LIMIT * ctx.params.rest_density;
        let wp = carry.then(|| carried_errors(ctx.attributes, ctx.densities, ctx.dt, limit));
        let (warm_density, predicted) = ctx.attributes.pair_mut(wd, wp.unwrap_or(wv));
        let mut solve = solve_context!(&self.gradients, ctx, closed);
        solve.predict_walls = settings.predict_walls;
        solve.contact_radius = settings.predict_walls.then_some(ctx.params.particle_radius);
        let stats = super::density_solve(
            &solve,
            settings,
            &mut self.buffers,
            (warm_density, carry.then_some(&*predicted)),
            ctx.velocities,
        );
        if carry {
            let rates = &self.buffers.rates;
            for ((p, &rho), &r) in predicted.iter_mut().zip(ctx.densities.iter()).zip(rates) {
                *p = rho + ctx.dt * r;
            }
        }
        let (warm_density, warm_divergence) = (ctx.attributes.get(wd), ctx.attributes.get(wv));
        let report = &mut *ctx.report;
        report.timings.add(Stage::DensitySolve, t0.elapsed());
        report.solver_relaxation_halvings = report
            .solver_relaxation_halvings
            .max(self.buffers.relaxation_halvings);
        report.solver_iterations += stats.iterations;
        report.solver_density_error = report.solver_density_error.max(stats.error);
        report.solver_capped += stats.capped as u32;
        report.solver_wall_neighbour_dropped += stats.neighbour_dropped as u32;
        for (((pr, &w), &wv), &rho) in ctx
            .pressures
            .iter_mut()
            .zip(warm_density.iter())
            .zip(warm_divergence.iter())
            .zip(ctx.densities.iter())
        {
            *pr = (w + wv) * rho * rho;
        }
    }
}
