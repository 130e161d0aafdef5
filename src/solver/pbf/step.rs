//! PBF's substep as the pipeline calls it (Macklin & Müller 2013, Alg. 1): the pipeline has
//! added gravity and predicted the positions; this runs the position solve on them, then the
//! velocity update and viscosity.

use super::{Pbf, PbfBuffers, PbfContext};
use crate::diagnostics::Stage;
use crate::domain::Separation;
use crate::math::{Real, Vector};
use crate::params::FluidParams;
use crate::solver::context::{Outcome, StepContext};
use crate::solver::{PressureSolver, WallReaction, WallRequest};

/// PBF's buffers and its persistent relaxation count.
#[derive(Clone, Debug, Default)]
pub(crate) struct PbfState {
    /// λ, corrections, partial sums, the relaxation count.
    pub buffers: PbfBuffers,
}

impl PressureSolver for PbfState {
    type Settings = Pbf;
    const PREDICTS_POSITIONS: bool = true;
    // The reaction goes through the added-mass solve as WCSPH's and DFSPH's: explicit, it
    // threw a 1 kg/m³ box at 2·10⁶ m/s (`tests/light_bodies.rs`) once the coupling stopped
    // counting the last frame's impulse as rapier's acceleration. Its walls stand the body at
    // its substep's end pose, so the exchange adds rapier's share of the substep to the solve
    // (`Coupling::exchange`, `with_rapier`).
    const WALL_REACTION: WallReaction = WallReaction::Impulse { added_mass: true };

    fn walls(settings: &Pbf, params: &FluidParams) -> WallRequest {
        WallRequest::density_kernel(params, settings.hydrostatic_walls)
    }

    fn step<S: Separation>(
        &mut self,
        settings: &Pbf,
        ctx: &mut StepContext<'_>,
        sep: S,
    ) -> Outcome {
        let p = ctx.params;
        let dt = ctx.dt;
        // Hydrostatic walls: the wall pressure's hydrostatic part moves the predicted positions
        // by `a_h·dt²` (its acceleration over the substep), as DFSPH adds it to the velocities.
        if let Some(w) = ctx.wall
            && w.hydrostatic_on
        {
            ctx.report.timed(Stage::ExternalForces, || {
                for (x, a) in ctx.positions.iter_mut().zip(&w.hydrostatic) {
                    *x += *a * (dt * dt);
                }
            });
        }
        let scaled = Pbf {
            artificial_pressure: if settings.artificial_pressure_dt_scaling {
                settings.artificial_pressure * artificial_pressure_scale(p, ctx.gravity, dt)
            } else {
                settings.artificial_pressure
            },
            ..*settings
        };
        let solve = PbfContext {
            settings: &scaled,
            neighbors: ctx.neighbors,
            wall: ctx.wall,
            mass: p.particle_mass,
            h: p.smoothing_length,
            spacing: p.particle_spacing,
            rest_density: p.rest_density,
            tolerance: 0.0,
            max_move: Real::INFINITY,
            safeguard: true,
            ratio: ctx.phases.map(|ph| ph.ratio),
        };
        // The position solve (densities are measured in its first pass).
        let buffers = &mut self.buffers;
        let stats = ctx.report.timed(Stage::DensitySolve, || {
            crate::with_kernel!(p.density_kernel, K => super::solve::<K, S>(
                &solve, buffers, ctx.positions, ctx.densities, ctx.inv_densities, sep))
        });
        let report = &mut *ctx.report;
        report.solver_relaxation_halvings = report
            .solver_relaxation_halvings
            .max(self.buffers.relaxation_halvings);
        report.solver_iterations += stats.iterations;
        report.solver_density_error = report.solver_density_error.max(stats.error);
        // The pressure the corrections stand for: Δx = dt²·a with a = −Σ m (π_i + π_j) ∇W
        // gives π = −Σλ/(ρ0·dt²).
        // In `f32` while `1/dt²` is finite, else in `f64` (a frame of 10⁻³⁰ s made it infinite
        // and the pressures NaN); clamped to the largest finite `f32`.
        let scale = -1.0 / (p.rest_density * dt * dt);
        let wide_scale = -1.0 / (p.rest_density as f64 * (dt as f64).powi(2));
        for ((pr, &l), &rho) in ctx
            .pressures
            .iter_mut()
            .zip(self.buffers.lambda_sum.iter())
            .zip(ctx.densities.iter())
        {
            let value = if scale.is_finite() {
                l * scale * rho * rho
            } else {
                (l as f64 * wide_scale * (rho as f64).powi(2)) as Real
            };
            *pr = value.clamp(-Real::MAX, Real::MAX);
        }
        crate::solver::finish_position_step(ctx, sep)
    }

    /// `m·Σω·λ_w/(ρ0·dt)`: the wall's share of the position corrections over all iterations
    /// turned into velocity (`v = Δx/dt`), as applied (relaxation included, and the
    /// neighbours' part with hydrostatic walls; [`PbfBuffers::wall_lambda_sum`]).
    fn wall_impulse_scale(&self, _: &Pbf, ctx: &StepContext<'_>, i: usize) -> Real {
        let p = ctx.params;
        -self.buffers.wall_lambda_sum[i] * p.particle_mass / (p.rest_density * ctx.dt)
    }

    /// Under gravity `g·dt² ≤ max_density_error·spacing`: a fixed number of Jacobi iterations
    /// leaves a compression that grows with gravity's displacement per substep (a 1 m column
    /// of 5 cm particles: 6.0 % at 1/60 s, 1.6 % at 1/120 s, 0.7 % at 1/240 s). 7.1 ms for
    /// 5 cm particles, 4.5 ms for 2 cm at the default 1 %. A static bound, not a feedback on
    /// the measured error: shortening the substep after a long one turns the compression the
    /// long one left into a velocity ∝ 1/dt (it threw a Taylor–Green box apart).
    fn time_step_limit(
        &mut self,
        settings: &Pbf,
        params: &FluidParams,
        _: Real,
        gravity: Vector,
        _: Real,
    ) -> Real {
        let g = gravity.length();
        if g > 0.0 && settings.max_density_error.is_finite() {
            (settings.max_density_error * params.particle_spacing / g).sqrt()
        } else {
            Real::INFINITY
        }
    }

    fn relaxation_halvings(&self) -> u32 {
        self.buffers.relaxation_halvings
    }

    fn heap_bytes(&self) -> usize {
        self.buffers.heap_bytes()
    }
}

/// The factor `min(1, (dt/dt_ref)²)` on the artificial pressure (eq. 13) of a substep `dt`,
/// with [`Pbf::artificial_pressure_dt_scaling`].
/// `s_corr` is a position correction applied in every iteration whether or not the particle
/// is compressed, and the velocity update turns it into `Δx/dt`: at a fixed strength its speed
/// grows as `1/dt` (a tank at rest, 5 cm particles, one 1/60 s frame at 256 substeps: kinetic
/// energy 1.8e4 J, 10⁴ times what free fall could release, against 0.23 J without the
/// artificial pressure; the test `pbf_energy_does_not_grow_as_the_substep_shrinks`). As a
/// pressure, a force, it moves a particle by `a·dt²`: scaled by `dt²` its speed shrinks with
/// the substep instead. `k` keeps its meaning at `dt_ref = √(0.01·spacing/g)`, the substep
/// PBF's time step limit picks at its default `max_density_error` (7.1 ms for 5 cm particles
/// under 9.81 m/s²), and is not raised above it for longer substeps (whose results are those
/// `k` was chosen at). Without gravity there is no such substep: the factor is 1.
fn artificial_pressure_scale(params: &FluidParams, gravity: Vector, dt: Real) -> Real {
    let g = gravity.length();
    let reference_squared = Pbf::default().max_density_error * params.particle_spacing / g;
    if g > 0.0 && dt * dt < reference_squared {
        dt * dt / reference_squared
    } else {
        1.0
    }
}
