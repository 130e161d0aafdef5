//! Weakly-compressible SPH, the Unity paper's method (Müller et al. 2003): pressure from the
//! equation of state, Müller's symmetric pressure force, viscosity, gravity, symplectic
//! Euler. Its stages are the paper's Tables 1–2: density, pressure calculation, pressure
//! force, viscosity force, external forces, particle update.

use super::context::{Outcome, StepContext};
use super::{PressureSolver, WallReaction, WallRequest};
use crate::diagnostics::Stage;
use crate::domain::Separation;
use crate::kernel::Kernel;
use crate::math::{Real, Vector};
use crate::neighbors::Pairs;
use crate::params::FluidParams;
use crate::solver::settings::{WcsphDensity, WcsphPressure};
use crate::{delta_sph, density, forces, integrate, pressure};
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// WCSPH keeps no state between substeps (only scratch for interacting fluids and Adami's
/// walls).
#[derive(Clone, Debug, Default)]
pub(crate) struct WcsphState {
    /// Interacting fluids: `1/ρ` times each particle's viscosity weight (see
    /// `solver::context::Phases`); empty for one fluid.
    viscous_inv_densities: Vec<Real>,
    /// With [`WcsphPressure::Adami`] and walls: each particle's wall pressure value `π̂_i`
    /// of the substep (see `pressure::wcsph::symmetric_accelerations`), for the walls'
    /// reaction on bodies; empty otherwise.
    wall_pi: Vec<Real>,
}

impl PressureSolver for WcsphState {
    type Settings = ();
    const PREDICTS_POSITIONS: bool = false;
    const WALL_REACTION: WallReaction = WallReaction::Impulse { added_mass: true };

    /// Adami's walls ([`WcsphPressure::Adami`]) ask for the walls' hydrostatic pressure.
    fn walls(_: &(), params: &FluidParams) -> WallRequest {
        WallRequest {
            force_kernel: params.pressure_kernel,
            hydrostatic: params.wcsph_pressure == WcsphPressure::Adami,
            double_density: false,
            planes: false,
        }
    }

    fn step<S: Separation>(&mut self, _: &(), ctx: &mut StepContext<'_>, sep: S) -> Outcome {
        let p = ctx.params;
        let wall = ctx.wall;
        let continuity = match p.wcsph_density {
            WcsphDensity::Summation => None,
            WcsphDensity::Continuity { delta } => Some(delta),
        };
        if continuity.is_some() {
            let t0 = std::time::Instant::now();
            crate::with_kernel!(p.density_kernel, K => continuity_densities::<K, S>(ctx, sep));
            ctx.report.timings.add(Stage::Density, t0.elapsed());
        } else {
            ctx.report.timed(Stage::Density, || {
                crate::with_kernel!(p.density_kernel, K => density::compute::<K, S>(
                    ctx.positions, ctx.neighbors, p.particle_mass, p.smoothing_length,
                    wall.map(|w| &w.density[..]), ctx.densities, ctx.inv_densities, sep));
            });
        }
        ctx.report.timed(Stage::Pressure, || {
            pressure::eos::compute(
                ctx.densities,
                p.equation_of_state,
                p.rest_density,
                p.clamp_negative_pressure,
                ctx.pressures,
            );
            // Interacting fluids: each particle's own fluid's pressure, `ρ0_i/ρ_ref` times
            // the reference's at the same relative density (`crate::fluid::interaction`).
            if let Some(ph) = ctx.phases {
                for (pr, &r) in ctx.pressures.iter_mut().zip(ph.ratio) {
                    *pr /= r;
                }
            }
        });
        let fused = p.wcsph_pressure == WcsphPressure::Paper
            && ctx.phases.is_none()
            && p.explicit_viscosity() > 0.0;
        if fused {
            // One pass for both (bit for bit the two below): timed as the pressure force.
            ctx.report.viscosity_limited += Self::pressure_and_viscosity(ctx, sep);
        } else {
            // Overwrites the accelerations.
            self.pressure_force(ctx, sep);
        }
        let pairs = Pairs {
            positions: ctx.positions,
            neighbors: ctx.neighbors,
            mass: p.particle_mass,
            h: p.smoothing_length,
            sep,
        };
        if !fused && p.explicit_viscosity() > 0.0 {
            let (phases, weighted) = (ctx.phases, &mut self.viscous_inv_densities);
            let inv = match phases {
                Some(ph) => {
                    ph.viscous_inv_densities(ctx.inv_densities, weighted);
                    &weighted[..]
                }
                None => &ctx.inv_densities[..],
            };
            let limited = ctx.report.timed(Stage::ViscosityForce, || {
                forces::viscosity::add_accelerations(
                    &pairs,
                    ctx.velocities,
                    inv,
                    (p.explicit_viscosity(), ctx.dt),
                    ctx.accelerations,
                )
            });
            ctx.report.viscosity_limited += limited;
        }
        // Interacting fluids: the pair forces divided by each particle's own mass.
        if let Some(ph) = ctx.phases {
            ph.scale(ctx.accelerations);
        }
        if ctx.gravity != Vector::ZERO {
            ctx.report.timed(Stage::ExternalForces, || {
                forces::external::add_gravity(ctx.gravity, ctx.accelerations);
                // Adami's walls: the hydrostatic part of the wall pressure (already per unit
                // of each particle's own rest density, as DFSPH adds it).
                if let Some(w) = wall
                    && w.hydrostatic_on
                {
                    for (a, h) in ctx.accelerations.iter_mut().zip(&w.hydrostatic) {
                        *a += *h;
                    }
                }
            });
        }
        let outcome: (usize, Real) = ctx.report.timed(Stage::ParticleUpdate, || {
            integrate::symplectic_euler(
                ctx.dt,
                ctx.accelerations,
                ctx.velocities,
                ctx.positions,
                ctx.previous_positions,
            )
        });
        // With the continuity density, the pipeline advances it after contact
        // (`pipeline::substep`, `delta_sph::advance`).
        outcome.into()
    }

    /// The wall pressure force over the substep: `−m·g_c·p/(2ρ²)` with the paper's forces,
    /// `−m·g_c·(π_i + π̂_i)` with Adami's walls.
    fn wall_impulse_scale(&self, _: &(), ctx: &StepContext<'_>, i: usize) -> Real {
        let inv = ctx.inv_densities[i];
        let (m, dt) = (ctx.params.particle_mass, ctx.dt);
        match ctx.params.wcsph_pressure {
            WcsphPressure::Paper => 0.5 * ctx.pressures[i] * inv * inv * m * dt,
            WcsphPressure::Adami => {
                let wall = self.wall_pi.get(i).copied().unwrap_or(0.0);
                (ctx.pressures[i] * inv * inv + wall) * m * dt
            }
        }
    }

    /// The acoustic limit `dt ≤ courant · h / (c + v)`.
    fn time_step_limit(
        &mut self,
        _: &(),
        params: &FluidParams,
        speed: Real,
        _: Vector,
        courant: Real,
    ) -> Real {
        let c = params.equation_of_state.speed_of_sound();
        courant * params.smoothing_length / (c + speed)
    }

    fn heap_bytes(&self) -> usize {
        (self.viscous_inv_densities.capacity() + self.wall_pi.capacity())
            * std::mem::size_of::<Real>()
    }
}

impl WcsphState {
    /// Müller's pressure force and the explicit viscosity in one pass over the pairs
    /// (`pressure::fused`), overwriting `ctx.accelerations`; returns the particles whose
    /// viscosity was limited. For one fluid (no phases) with [`WcsphPressure::Paper`].
    fn pressure_and_viscosity<S: Separation>(ctx: &mut StepContext<'_>, sep: S) -> usize {
        let p = ctx.params;
        let input = pressure::fused::FusedInput {
            pairs: Pairs {
                positions: ctx.positions,
                neighbors: ctx.neighbors,
                mass: p.particle_mass,
                h: p.smoothing_length,
                sep,
            },
            inv_densities: ctx.inv_densities,
            pressures: ctx.pressures,
            wall: ctx.wall.map(|w| &w.gradient[..]),
            velocities: ctx.velocities,
            viscosity: (p.explicit_viscosity(), ctx.dt),
        };
        let acc = &mut *ctx.accelerations;
        ctx.report.timed(Stage::PressureForce, || {
            crate::with_kernel!(p.pressure_kernel, K =>
                pressure::fused::pressure_and_viscosity::<K, S>(&input, acc))
        })
    }

    /// The pressure accelerations into `ctx.accelerations` (overwritten): the paper's
    /// (Müller's form) or, with [`WcsphPressure::Adami`], the symmetric form with Adami's
    /// wall pressure.
    fn pressure_force<S: Separation>(&mut self, ctx: &mut StepContext<'_>, sep: S) {
        let p = ctx.params;
        let wall = ctx.wall.map(|w| &w.gradient[..]);
        let wall_pi = &mut self.wall_pi;
        ctx.report.timed(Stage::PressureForce, || match p.wcsph_pressure {
            WcsphPressure::Paper => {
                crate::with_kernel!(p.pressure_kernel, K => pressure::wcsph::pressure_accelerations::<K, S>(
                    ctx.positions, ctx.inv_densities, ctx.pressures, ctx.neighbors, p.particle_mass,
                    p.smoothing_length, wall, ctx.accelerations, sep));
            }
            WcsphPressure::Adami => {
                let input = pressure::wcsph::SymmetricInput {
                    positions: ctx.positions,
                    inv_densities: ctx.inv_densities,
                    pressures: ctx.pressures,
                    neighbors: ctx.neighbors,
                    mass: p.particle_mass,
                    h: p.smoothing_length,
                    wall,
                };
                wall_pi.resize(ctx.positions.len(), 0.0);
                crate::with_kernel!(p.pressure_kernel, K => pressure::wcsph::symmetric_accelerations::<K, S>(
                    &input, ctx.accelerations, wall_pi, sep));
            }
        });
    }
}

/// WCSPH's continuity density (`crate::delta_sph`): `ρ_i = ρ_f,i + ρ_wall,i` into `ctx.densities` and `1/ρ_i` into `ctx.inv_densities`;
/// particles without a stored density first take their summed one, at least `ρ0`.
fn continuity_densities<K: Kernel, S: Separation>(ctx: &mut StepContext<'_>, sep: S) {
    let p = ctx.params;
    let n = ctx.positions.len();
    let k = ctx.attributes.ensure(delta_sph::ATTRIBUTE, n);
    let wall = ctx.wall.map(|w| &w.density[..]);
    let stored = ctx.attributes.get_mut(k);
    if stored.iter().any(|&r| r <= 0.0) {
        crate::density::compute::<K, S>(
            ctx.positions,
            ctx.neighbors,
            p.particle_mass,
            p.smoothing_length,
            wall,
            ctx.densities,
            ctx.inv_densities,
            sep,
        );
        for (i, (s, &summed)) in stored.iter_mut().zip(ctx.densities.iter()).enumerate() {
            if *s <= 0.0 {
                *s = summed.max(p.rest_density) - wall.map_or(0.0, |w| w[i]);
            }
        }
    }
    let stored = &*stored;
    crate::par_chunks_mut!(ctx.densities, crate::par::CHUNK)
        .zip(crate::par_chunks_mut!(ctx.inv_densities, crate::par::CHUNK))
        .enumerate()
        .for_each(|(c, (rho, inv))| {
            let base = c * crate::par::CHUNK;
            for (k, (r, v)) in rho.iter_mut().zip(inv.iter_mut()).enumerate() {
                let i = base + k;
                *r = stored[i] + wall.map_or(0.0, |w| w[i]);
                *v = 1.0 / *r;
            }
        });
}
