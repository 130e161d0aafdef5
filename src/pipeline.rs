//! One step of the fluid, as a flat list of named, timed stages:
//!
//! ```text
//! particles ─▶ 1 neighbour search ─▶ 2 density ─▶ 3 pressure ─▶ 4 pressure force
//!           ─▶ 5 viscosity force ─▶ 6 external forces ─▶ 7 particle update ─▶ 8 collider contact
//! ```
//!
//! Each stage is a function of its own module, timed into [`StepReport::timings`]. A stage a
//! scene does not use is skipped, not run on zeros: no viscosity pass when ε = 0, no gravity
//! pass when gravity is zero, no contact work when no collider is near the fluid.

use crate::boundary::contact::{self, ContactResponse};
use crate::diagnostics::{Stage, StepReport};
use crate::error::{SphError, SphResult};
use crate::fluid::{Fluid, FluidSet};
use crate::math::{Real, Vector};
use crate::{density, forces, integrate, par, pressure};
use parry3d::query::DefaultQueryDispatcher;
use rapier3d::dynamics::RigidBodySet;
use rapier3d::geometry::{BroadPhaseBvh, ColliderSet};
use rapier3d::pipeline::QueryFilter;
use std::time::Instant;

/// Steps fluids alongside a rapier world. Holds only the last report; all state lives in the
/// [`FluidSet`] and the rapier sets, passed explicitly as rapier's own `PhysicsPipeline` does.
#[derive(Clone, Debug, Default)]
pub struct FluidPipeline {
    report: StepReport,
}

impl FluidPipeline {
    /// A new pipeline.
    pub fn new() -> Self {
        Self::default()
    }

    /// The report of the last step.
    pub fn report(&self) -> &StepReport {
        &self.report
    }

    /// Advances every fluid of `fluids` by `dt` seconds under `gravity`, with contact against
    /// the colliders of `colliders` found through `broad_phase` (rapier's BVH, filled by
    /// rapier's own step: call this right after it).
    ///
    /// Bad input (a non-finite or non-positive `dt`, non-finite gravity, an empty broad-phase
    /// beside a non-empty collider set) returns an error and changes nothing.
    pub fn step(
        &mut self,
        gravity: Vector,
        dt: Real,
        fluids: &mut FluidSet,
        bodies: &mut RigidBodySet,
        colliders: &ColliderSet,
        broad_phase: &BroadPhaseBvh,
    ) -> SphResult<&StepReport> {
        if !dt.is_finite() || dt <= 0.0 {
            return Err(SphError::InvalidTimeStep { dt: dt as f64 });
        }
        if !crate::math::is_finite(gravity) {
            return Err(SphError::InvalidParameter {
                field: "gravity",
                value: gravity.length() as f64,
                reason: "must be finite",
            });
        }
        let query = broad_phase.as_query_pipeline(
            &DefaultQueryDispatcher,
            bodies,
            colliders,
            QueryFilter::default(),
        );
        let bvh = query.bvh;
        if !colliders.is_empty() && bvh.is_empty() {
            return Err(SphError::BroadPhaseNotUpdated {
                colliders: colliders.len(),
            });
        }
        let has_colliders = !bvh.is_empty();

        let mut report = StepReport::default();
        let mut weighted_mean_error = 0.0f64;
        let mut run = || {
            for (_, fluid) in fluids.iter_mut() {
                step_fluid(
                    fluid,
                    gravity,
                    dt,
                    has_colliders.then_some((bvh, colliders)),
                    &mut report,
                    &mut weighted_mean_error,
                );
            }
        };
        // Called from outside rayon's pool, every parallel stage would hand its work to the
        // pool and wait for a worker to wake up: tens of microseconds per stage, more than a
        // small fluid's whole step. Entering the pool once per step avoids that.
        #[cfg(feature = "parallel")]
        if rayon::current_thread_index().is_none() {
            rayon::scope(|_| run());
        } else {
            run();
        }
        #[cfg(not(feature = "parallel"))]
        run();
        if report.particles > 0 {
            report.mean_density_error = (weighted_mean_error / report.particles as f64) as Real;
        }
        self.report = report;
        Ok(&self.report)
    }
}

fn timed<T>(report: &mut StepReport, stage: Stage, f: impl FnOnce() -> T) -> T {
    let t0 = Instant::now();
    let out = f();
    report.timings.add(stage, t0.elapsed());
    out
}

fn step_fluid(
    fluid: &mut Fluid,
    gravity: Vector,
    dt: Real,
    colliders: Option<(&parry3d::partitioning::Bvh, &ColliderSet)>,
    report: &mut StepReport,
    weighted_mean_error: &mut f64,
) {
    let n = fluid.len();
    report.particles += n;
    if n == 0 {
        return;
    }
    let p = fluid.params().clone();
    let h = p.smoothing_length;
    let Fluid {
        positions,
        velocities,
        accelerations,
        densities,
        pressures,
        ids,
        workspace: ws,
        ..
    } = fluid;

    // 1. Neighbour search: sort by cell (every per-particle array follows), cells, lists.
    timed(report, Stage::NeighbourSearch, || {
        if ws.grid.sort(positions, h) {
            let perm = ws.grid.permutation();
            par::permute(positions, &mut ws.scratch_vectors, perm);
            par::permute(velocities, &mut ws.scratch_vectors, perm);
            par::permute(ids, &mut ws.scratch_ids, perm);
        }
        ws.grid.build_cells();
        ws.neighbors.build(&ws.grid, positions, h);
    });
    report.neighbour_pairs += ws.neighbors.total_pairs();

    // 2. Density.
    ws.inv_densities.resize(n, 0.0);
    timed(report, Stage::Density, || {
        crate::with_kernel!(p.density_kernel, K => density::compute::<K>(
            positions, &ws.neighbors, p.particle_mass, h, densities, &mut ws.inv_densities));
    });
    let (max_err, mean_err) = density::density_error(densities, p.rest_density, &mut ws.partials);
    report.max_density_error = report.max_density_error.max(max_err);
    *weighted_mean_error += mean_err as f64 * n as f64;

    // 3. Pressure.
    timed(report, Stage::Pressure, || {
        pressure::eos::compute(
            densities,
            p.equation_of_state,
            p.rest_density,
            p.clamp_negative_pressure,
            pressures,
        );
    });

    // 4. Pressure force (overwrites the accelerations).
    timed(report, Stage::PressureForce, || {
        crate::with_kernel!(p.pressure_kernel, K => pressure::wcsph::pressure_accelerations::<K>(
            positions, &ws.inv_densities, pressures, &ws.neighbors, p.particle_mass, h, accelerations));
    });

    // 5. Viscosity force.
    if p.viscosity > 0.0 {
        timed(report, Stage::ViscosityForce, || {
            forces::viscosity::add_accelerations(
                positions,
                velocities,
                &ws.inv_densities,
                &ws.neighbors,
                p.particle_mass,
                p.viscosity,
                h,
                accelerations,
            );
        });
    }

    // 6. External forces.
    if gravity != Vector::ZERO {
        timed(report, Stage::ExternalForces, || {
            forces::external::add_gravity(gravity, accelerations)
        });
    }

    // 7. Particle update (symplectic Euler).
    ws.previous_positions.resize(n, Vector::ZERO);
    let (non_finite, max_speed) = timed(report, Stage::ParticleUpdate, || {
        integrate::symplectic_euler(
            dt,
            accelerations,
            velocities,
            positions,
            &mut ws.previous_positions,
        )
    });
    report.non_finite += non_finite;
    report.max_speed = report.max_speed.max(max_speed);

    // 8. Collider contact.
    if let Some((bvh, colliders)) = colliders {
        let counts = timed(report, Stage::Contact, || {
            ws.contact.gather(
                &ws.grid,
                &ws.previous_positions,
                positions,
                p.particle_radius,
                bvh,
                colliders,
                p.collision_groups,
            );
            if !ws.contact.any() {
                return contact::ContactCounts::default();
            }
            let response = ContactResponse {
                radius: p.particle_radius,
                restitution: p.restitution,
                friction: p.friction,
            };
            contact::resolve(
                &ws.grid,
                &ws.contact,
                colliders,
                response,
                fluid.needs_depenetration,
                &ws.previous_positions,
                positions,
                velocities,
            )
        });
        report.contacts += counts.contacts;
        report.contact_fallbacks += counts.fallbacks;
        report.depenetrated += counts.depenetrated;
    } else {
        ws.contact.clear();
    }
    fluid.needs_depenetration = false;
}
