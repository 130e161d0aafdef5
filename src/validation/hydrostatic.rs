//! The hydrostatic tank: a column of water settling in a closed box
//! ([`crate::scenes::HydrostaticTank`], reused as is), against `p = ρ0·g·depth`.
//!
//! Geometry: a box [`WIDTH`] wide and deep, the water `2·WIDTH` deep, `resolution` particles
//! across (so `resolution × 2·resolution × resolution` particles), the water preset at spacing
//! `WIDTH / resolution`. Released from a lattice at rest density (no pressure), the column
//! compresses under its weight, rings acoustically and settles; the run lasts [`DURATION`].
//!
//! Errors, averaged over the samples of the last quarter of the run (the settled state; the
//! average removes the residual acoustic ringing, which a pressure gauge would also average):
//! - `bottom_pressure`: [`crate::scenes::HydrostaticTank::bottom_pressure_error`], signed;
//! - `pressure_rms`: [`crate::scenes::HydrostaticTank::pressure_profile_rms`];
//! - `mean_density_error`, `settled_max_density_error`: mean and largest compression
//!   `max(ρ − ρ0, 0)/ρ0` over the particles (as the step report counts it).

use super::{DriveSpec, Method, Metric, RunRecord, SimCurve, TimePolicy, drive};
use crate::error::{SphError, SphResult};
use crate::math::{Real, Vector};
use crate::params::FluidParamsBuilder;
use crate::scenes::HydrostaticTank;

/// Width (and depth, z) of the box (m); the water is twice as deep.
pub const WIDTH: Real = 0.1;

/// Simulated time (s): about 40 acoustic round trips of the 0.2 m column at c = 30 m/s, and
/// several viscous decay times of the ringing at the water preset's viscosity.
pub const DURATION: Real = 1.0;

/// Runs the tank once (see [`super::Scene::run`]).
pub fn run(
    method: &Method,
    resolution: usize,
    policy: TimePolicy,
    progress: &mut dyn FnMut(Real),
) -> SphResult<RunRecord> {
    if resolution < 2 {
        return Err(SphError::InvalidParameter {
            field: "resolution",
            value: resolution as f64,
            reason: "at least 2 particles across the tank",
        });
    }
    let params = FluidParamsBuilder::water(WIDTH / resolution as Real)
        .solver(method.solver)
        .wall_density(method.wall_density)
        .build()?;
    let n = resolution;
    let mut tank = HydrostaticTank::new(params.clone(), [n, 2 * n, n])?;
    let g = tank.world.physics.gravity.length();
    let f = &tank.world.fluids[tank.fluid];
    let particles = f.len();
    let energy_bound: f64 = f
        .positions()
        .iter()
        .map(|p| (params.particle_mass * g * p.y) as f64)
        .sum();
    // Characteristic speed: the shallow-water wave speed sqrt(g·depth) of the sloshing that
    // the settling excites.
    let dt_ref = super::reference_step(&params, (g * tank.fluid_height).sqrt(), g);
    let max = Vector::new(WIDTH, 2.0 * tank.fluid_height, WIDTH);
    let eps = 1e-4;
    let inside = move |p: Vector| {
        p.cmpge(Vector::splat(-eps)).all() && p.cmple(max + Vector::splat(eps)).all()
    };
    let settle_from = 0.75 * DURATION;
    let rho0 = params.rest_density;
    // (bottom, rms, mean compression, max compression) summed over the settled samples.
    let mut sums = [0.0f64; 3];
    let mut max_settled: f64 = 0.0;
    let mut count = 0usize;
    let mut bottom_curve = Vec::new();
    let fluid = tank.fluid;
    let fluid_height = tank.fluid_height;
    let driven = {
        let tank_ref = &mut tank;
        let world = &mut tank_ref.world;
        drive(
            world,
            fluid,
            &DriveSpec {
                duration: DURATION,
                sample_dt: DURATION / 200.0,
                dt_ref,
                policy,
                energy_bound,
                inside: &inside,
            },
            &mut |t, world| {
                let view = TankView {
                    world,
                    fluid,
                    fluid_height,
                };
                let bottom = view.bottom_pressure_error() as f64;
                bottom_curve.push((t as f64, bottom));
                if t >= settle_from {
                    let f = &world.fluids[fluid];
                    let comp: Vec<f64> = f
                        .densities()
                        .iter()
                        .map(|&r| (((r - rho0) / rho0) as f64).max(0.0))
                        .collect();
                    sums[0] += bottom;
                    sums[1] += view.pressure_profile_rms() as f64;
                    sums[2] += comp.iter().sum::<f64>() / comp.len().max(1) as f64;
                    max_settled = comp.iter().copied().fold(max_settled, f64::max);
                    count += 1;
                }
            },
            progress,
        )?
    };
    let avg = |k: usize| {
        if count == 0 {
            f64::NAN
        } else {
            sums[k] / count as f64
        }
    };
    let errors = vec![
        Metric {
            name: "bottom_pressure",
            value: avg(0),
        },
        Metric {
            name: "pressure_rms",
            value: avg(1),
        },
        Metric {
            name: "mean_density_error",
            value: avg(2),
        },
        Metric {
            name: "settled_max_density_error",
            value: if count == 0 { f64::NAN } else { max_settled },
        },
    ];
    Ok(RunRecord {
        scene: super::Scene::Hydrostatic.name(),
        method: method.name,
        resolution,
        spacing: params.particle_spacing,
        particles,
        particles_end: driven.particles_end,
        escaped: driven.escaped,
        policy,
        dt_ref,
        dt_mean: driven.simulated / driven.substeps.max(1) as Real,
        simulated: driven.simulated,
        duration: DURATION,
        wall_seconds: driven.wall_seconds,
        substeps: driven.substeps,
        particle_steps: driven.particle_steps,
        errors,
        max_density_error: driven.max_density_error,
        stable: driven.note.is_empty(),
        note: driven.note,
        curves: vec![SimCurve {
            name: "bottom_pressure",
            points: bottom_curve,
        }],
    })
}

/// The tank's error measures on a borrowed world (the tank itself is borrowed by the run).
struct TankView<'a> {
    world: &'a crate::FluidWorld,
    fluid: crate::FluidHandle,
    fluid_height: Real,
}

impl TankView<'_> {
    fn bottom_pressure_error(&self) -> Real {
        HydrostaticTank::bottom_pressure_error_of(self.world, self.fluid, self.fluid_height)
    }
    fn pressure_profile_rms(&self) -> Real {
        HydrostaticTank::pressure_profile_rms_of(self.world, self.fluid, self.fluid_height)
    }
}
