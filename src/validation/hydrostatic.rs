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

use super::{
    DriveSpec, Method, Metric, RunRecord, RunSetup, SimCurve, TimePolicy, drive, inside_box,
    metrics, potential_energy,
};
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
        .wcsph_pressure(method.wcsph_pressure)
        .wcsph_density(method.wcsph_density)
        .build()?;
    let n = resolution;
    let mut tank = HydrostaticTank::new(params.clone(), [n, 2 * n, n])?;
    let g = tank.world.physics.gravity.length();
    let f = &tank.world.fluids[tank.fluid];
    let particles = f.len();
    let energy_bound = potential_energy(f, params.particle_mass, g);
    // Characteristic speed: the shallow-water wave speed sqrt(g·depth) of the sloshing that
    // the settling excites.
    let dt_ref = super::reference_step(&params, (g * tank.fluid_height).sqrt(), g);
    let inside = inside_box(Vector::new(WIDTH, 2.0 * tank.fluid_height, WIDTH), 1e-4);
    let settle_from = 0.75 * DURATION;
    let mut settled = Settled::new(params.rest_density);
    let mut bottom_curve = Vec::new();
    let fluid = tank.fluid;
    let fluid_height = tank.fluid_height;
    let driven = drive(
        &mut tank.world,
        fluid,
        &DriveSpec {
            duration: DURATION,
            sample_dt: DURATION / 200.0,
            dt_ref,
            policy,
            energy_bound,
            gravity: g,
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
                settled.add(&view, bottom);
            }
        },
        progress,
    )?;
    let setup = RunSetup {
        scene: super::Scene::Hydrostatic.name(),
        method: method.name,
        resolution,
        spacing: params.particle_spacing,
        particles,
        policy,
        dt_ref,
        duration: DURATION,
    };
    Ok(setup.record(
        driven,
        settled.errors(),
        vec![SimCurve {
            name: "bottom_pressure",
            points: bottom_curve,
        }],
    ))
}

/// The error measures summed over the samples of the settled state (the last quarter of
/// the run), averaged by [`Settled::errors`].
struct Settled {
    rest_density: Real,
    /// Bottom-pressure error, pressure-profile RMS, mean compression.
    sums: [f64; 3],
    /// Largest compression of any particle in any settled sample.
    max_compression: f64,
    count: usize,
}

impl Settled {
    fn new(rest_density: Real) -> Self {
        Self {
            rest_density,
            sums: [0.0; 3],
            max_compression: 0.0,
            count: 0,
        }
    }

    /// Adds one sample of the tank in `view`, whose bottom-pressure error is `bottom`.
    fn add(&mut self, view: &TankView, bottom: f64) {
        let rho0 = self.rest_density;
        let comp: Vec<f64> = view.world.fluids[view.fluid]
            .densities()
            .iter()
            .map(|&r| (((r - rho0) / rho0) as f64).max(0.0))
            .collect();
        self.sums[0] += bottom;
        self.sums[1] += view.pressure_profile_rms() as f64;
        self.sums[2] += comp.iter().sum::<f64>() / comp.len().max(1) as f64;
        self.max_compression = comp.iter().copied().fold(self.max_compression, f64::max);
        self.count += 1;
    }

    /// The run's errors (see the module's doc); NaN when no sample was settled (the run
    /// stopped early).
    fn errors(&self) -> Vec<Metric> {
        let avg = |k: usize| {
            if self.count == 0 {
                f64::NAN
            } else {
                self.sums[k] / self.count as f64
            }
        };
        metrics([
            ("bottom_pressure", avg(0)),
            ("pressure_rms", avg(1)),
            ("mean_density_error", avg(2)),
            (
                "settled_max_density_error",
                if self.count == 0 {
                    f64::NAN
                } else {
                    self.max_compression
                },
            ),
        ])
    }
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
