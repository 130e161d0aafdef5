//! One frame of the fluid: divided into substeps (see [`TimeStepping`]), each a flat list of
//! named, timed stages:
//!
//! ```text
//! particles ─▶ 1 neighbour search ─▶ 2 wall density ─▶ 3 density
//!   WCSPH: ─▶ 4 pressure (EOS) ─▶ 5 pressure force ─▶ 6 viscosity ─▶ 7 gravity ─▶ 8 particle update
//!   DFSPH: ─▶ 4 divergence solve ─▶ 5 viscosity ─▶ 6 gravity ─▶ 7 density solve ─▶ 8 particle update
//!   PBF, Clavet: (gravity and position prediction before 1) ─▶ 7 position solve (PBF) or
//!          relaxation (Clavet) ─▶ 8 velocity update ─▶ 6 viscosity
//!        ─▶ 9 collider contact
//! ```
//!
//! Each stage is a function of its own module, timed into [`StepReport::timings`]. A stage a
//! scene does not use is skipped, not run on zeros: no viscosity pass when ε = 0, no gravity
//! pass when gravity is zero, no wall or contact work when no collider is near the fluid.

use crate::boundary::Coupling;
use crate::boundary::contact::{self, ContactResponse, Movers};
use crate::diagnostics::{Stage, StepReport};
use crate::domain::{MinimumImage, Separation};
use crate::error::{SphError, SphResult};
use crate::fluid::{Fluid, FluidSet};
use crate::kernel::ViscosityLaplacian;
use crate::math::{Real, Vector};
use crate::solver::{Solver, dfsph};
use crate::{density, forces, integrate, par, pressure};
use parry3d::query::DefaultQueryDispatcher;
use rapier3d::dynamics::RigidBodySet;
use rapier3d::geometry::{BroadPhaseBvh, ColliderSet};
use rapier3d::pipeline::QueryFilter;
#[cfg(feature = "parallel")]
use rayon::prelude::*;
use std::time::Instant;

/// How [`FluidPipeline::step`] divides the caller's frame into substeps.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub enum TimeStepping {
    /// One substep of exactly the frame's `dt`: the caller is responsible for stability
    /// (benchmarks and convergence studies use this).
    Fixed,
    /// Substeps from the CFL condition, recomputed before each substep from the fluids'
    /// current maximum speed:
    ///
    /// - every solver: `dt ≤ courant · spacing / (v_max + |g|·dt)` (a particle moves at
    ///   most `courant` spacings per substep), and the explicit viscosity limit
    ///   `dt ≤ ρ0·h²/(30·ε)`;
    /// - WCSPH also the acoustic limit `dt ≤ courant · h / (c + v_max)`, Clavet the same with
    ///   `c·√k` (its stiffness `k` is in units of `c²/(h·ρ0)`, its springs' in `c²/(h²·N)`);
    /// - DFSPH under gravity also `g·dt² ≤ 5·max_density_error·spacing`: gravity's
    ///   compression within one substep stays a few times the solve's error target.
    ///
    /// The frame is split into equal substeps that meet the limits; at most `max_substeps`
    /// of them. When the cap binds the substeps are longer than the limits ask and the report
    /// says so (`substep_cap_hit`); contact still keeps every particle out of every solid.
    Adaptive {
        /// Courant number (default 0.4).
        courant: Real,
        /// Cap on substeps per frame (default 256).
        max_substeps: u32,
    },
}

impl Default for TimeStepping {
    fn default() -> Self {
        TimeStepping::Adaptive {
            courant: 0.4,
            max_substeps: 256,
        }
    }
}

/// Steps fluids alongside a rapier world. Holds its time-stepping policy and the last report;
/// all state lives in the [`FluidSet`] and the rapier sets, passed explicitly as rapier's own
/// `PhysicsPipeline` does.
#[derive(Clone, Debug)]
pub struct FluidPipeline {
    /// How frames are divided into substeps (default: adaptive, Courant 0.4).
    pub time_stepping: TimeStepping,
    /// The substeps rapier takes per step (its `integration_parameters.num_solver_iterations`,
    /// default 4): moving bodies are followed along the path rapier's substeps give them
    /// (see [`crate::boundary::Coupling::begin_frame`]). [`crate::FluidWorld`] keeps it in
    /// sync; set it when you step rapier with other parameters.
    pub rapier_substeps: usize,
    report: StepReport,
    coupling: Coupling,
    /// Always empty: lets the broad-phase's BVH be borrowed without `bodies` (kept here so
    /// the step does not allocate one).
    no_bodies: RigidBodySet,
}

impl Default for FluidPipeline {
    fn default() -> Self {
        Self::with_time_stepping(TimeStepping::default())
    }
}

impl FluidPipeline {
    /// A new pipeline with adaptive time stepping.
    pub fn new() -> Self {
        Self::default()
    }

    /// A new pipeline with the given time-stepping policy.
    pub fn with_time_stepping(time_stepping: TimeStepping) -> Self {
        Self {
            time_stepping,
            rapier_substeps: 4,
            report: StepReport::default(),
            coupling: Coupling::default(),
            no_bodies: RigidBodySet::new(),
        }
    }

    /// The coupling's state kept from one frame to the next: the linear velocity each
    /// dynamic body near a fluid was left with (saved in snapshots).
    pub fn coupling_memory(&self) -> &[(rapier3d::dynamics::RigidBodyHandle, Vector)] {
        self.coupling.left_velocities()
    }

    /// Restores [`FluidPipeline::coupling_memory`] (snapshots).
    pub fn set_coupling_memory(
        &mut self,
        memory: Vec<(rapier3d::dynamics::RigidBodyHandle, Vector)>,
    ) {
        self.coupling.set_left_velocities(memory);
    }

    /// The report of the last step.
    pub fn report(&self) -> &StepReport {
        &self.report
    }

    /// Advances every fluid of `fluids` by `dt` seconds under `gravity`, with contact against
    /// the colliders of `colliders` found through `broad_phase` (rapier's BVH, filled by
    /// rapier's own step: call this right after it). The frame is divided into substeps by
    /// [`FluidPipeline::time_stepping`].
    ///
    /// Bad input (a non-finite or non-positive `dt`, non-finite gravity, `rapier_substeps`
    /// of 0, an empty broad-phase beside a non-empty collider set) returns an error and
    /// changes nothing.
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
        if let TimeStepping::Adaptive {
            courant,
            max_substeps,
        } = self.time_stepping
        {
            if !(courant.is_finite() && courant > 0.0) {
                return Err(SphError::InvalidParameter {
                    field: "courant",
                    value: courant as f64,
                    reason: "must be positive and finite",
                });
            }
            if max_substeps == 0 {
                return Err(SphError::InvalidParameter {
                    field: "max_substeps",
                    value: 0.0,
                    reason: "must be at least 1",
                });
            }
        }
        if self.rapier_substeps == 0 {
            return Err(SphError::InvalidParameter {
                field: "rapier_substeps",
                value: 0.0,
                reason: "rapier takes at least one substep per step",
            });
        }
        if !crate::math::is_finite(gravity) {
            return Err(SphError::InvalidParameter {
                field: "gravity",
                value: gravity.length() as f64,
                reason: "must be finite",
            });
        }
        // The BVH is the broad-phase's own tree; an empty body set keeps it from borrowing
        // `bodies`, which the coupling writes impulses into at the end of the step.
        let no_bodies = &self.no_bodies;
        let query = broad_phase.as_query_pipeline(
            &DefaultQueryDispatcher,
            no_bodies,
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
        let time_stepping = self.time_stepping;
        let coupling = &mut self.coupling;
        coupling.begin_frame(
            dt,
            self.rapier_substeps,
            if has_colliders { bodies } else { no_bodies },
            colliders,
        );
        // The stages read the bodies; the coupling writes its impulses once they are done.
        let bodies_mut = bodies;
        let bodies: &RigidBodySet = &*bodies_mut;
        let mut run = || {
            // Quarantine what the caller may have broken since the last frame (a NaN written
            // through `velocities_mut`), and measure the speeds the first substep starts from.
            for (_, fluid) in fluids.iter_mut() {
                // The scan (parallel) counts them and skips them in the maximum speed; the
                // serial removal runs only when there is something to remove.
                let (bad, vmax) = timed(&mut report, Stage::ParticleUpdate, || {
                    integrate::scan(&fluid.positions, &fluid.velocities)
                });
                if bad > 0 {
                    report.quarantined += fluid.quarantine_non_finite();
                }
                fluid.workspace.max_speed = vmax;
                if matches!(time_stepping, TimeStepping::Adaptive { .. }) {
                    refresh_clavet_stiffest(fluid);
                }
            }
            let mut elapsed: Real = 0.0;
            let mut weighted_mean_error = 0.0f64;
            let mut counted = 0usize;
            report.min_substep = Real::MAX;
            loop {
                let remaining = dt - elapsed;
                let (h, last) = match time_stepping {
                    TimeStepping::Fixed => (dt, true),
                    TimeStepping::Adaptive {
                        courant,
                        max_substeps,
                    } => {
                        let limit = fluids
                            .iter()
                            .map(|(_, f)| stable_time_step(f, gravity, courant, remaining))
                            .fold(Real::MAX, Real::min);
                        let left = max_substeps.saturating_sub(report.substeps).max(1);
                        let needed = (remaining / limit).ceil().max(1.0);
                        if needed > left as Real {
                            report.substep_cap_hit = true;
                        }
                        let count = needed.min(left as Real);
                        if count <= 1.0 {
                            (remaining, true)
                        } else {
                            (remaining / count, false)
                        }
                    }
                };
                report.substeps += 1;
                report.min_substep = report.min_substep.min(h);
                report.max_substep = report.max_substep.max(h);
                // Seconds from the substep's start and end to the frame's end (moving bodies
                // stand at their end-of-frame poses; see `boundary::bodies`).
                let back = (dt - elapsed, if last { 0.0 } else { dt - elapsed - h });
                for (_, fluid) in fluids.iter_mut() {
                    let n = fluid.len();
                    let mean = step_fluid(
                        fluid,
                        gravity,
                        h,
                        has_colliders.then_some((bvh, colliders, bodies)),
                        (&mut *coupling, back),
                        &mut report,
                    );
                    weighted_mean_error += mean as f64 * n as f64;
                    counted += n;
                    if fluid.workspace.non_finite > 0 {
                        report.quarantined += fluid.quarantine_non_finite();
                    }
                    report.drained += fluid.drain_sinks(colliders);
                }
                elapsed += h;
                if last {
                    break;
                }
            }
            // Emitters: the particles due during the frame, where they are at its end.
            for (_, fluid) in fluids.iter_mut() {
                let e = fluid.run_emitters(dt, has_colliders.then_some(bvh), colliders);
                report.emitted += e.emitted;
                report.emitter_blocked += e.blocked;
                report.capacity_reached |= e.capacity_reached;
            }
            report.particles = fluids.num_particles();
            if counted > 0 {
                report.mean_density_error = (weighted_mean_error / counted as f64) as Real;
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
        report.coupled_bodies = self.coupling.apply(bodies_mut);
        self.report = report;
        Ok(&self.report)
    }
}

/// The walls' viscosity (see [`crate::boundary::wall`]): `dv_i/dt = ε_w/ρ_i·Σ_k L_k (v_k −
/// v_i)`, integrated implicitly over the substep against the walls' velocities at its start,
/// `v_i' = (v_i + α_i v̄_i)/(1 + α_i)` with `α_i = dt·ε_w·L_i/ρ_i` and `v̄_i` the walls'
/// `L`-weighted velocity: the particle tends to the wall's velocity and never overshoots it,
/// at any substep. Each dynamic body's share of a particle's velocity change goes back to the
/// body as the opposite impulse (`records`, in particle order; explicit: the body's velocity
/// is the substep start's, as for contact without the added-mass solve), applied at the
/// particle's position: the force is tangential, so only there does the torque the body
/// takes equal the angular momentum the particle gains.
#[allow(clippy::too_many_arguments)]
fn wall_viscosity(
    epsilon: Real,
    mass: Real,
    dt: Real,
    wall: &crate::boundary::WallWorkspace,
    positions: &[Vector],
    inv_densities: &[Real],
    velocities: &mut [Vector],
    records: &mut Vec<crate::boundary::bodies::ImpulseRecord>,
) {
    let factor = |i: usize| dt * epsilon * inv_densities[i];
    if wall.coupled_any {
        for (i, cw) in wall.coupled.iter().enumerate() {
            if cw.entry == u32::MAX || cw.viscous <= 0.0 {
                continue;
            }
            let f = factor(i);
            let alpha = f * wall.viscous[i];
            // The body's share of `v_i' − v_i = f·(Σ L_k v_k − L v_i)/(1 + α)`.
            let dv = (cw.viscous_velocity - velocities[i] * cw.viscous) * (f / (1.0 + alpha));
            records.push(crate::boundary::bodies::ImpulseRecord {
                entry: cw.entry,
                particle: i as u32,
                normal: Vector::ZERO,
                impulse: -dv * mass,
                point: positions[i],
            });
        }
    }
    crate::par_chunks_mut!(velocities, par::CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            let base = c * par::CHUNK;
            for (k, v) in out.iter_mut().enumerate() {
                let i = base + k;
                let l = wall.viscous[i];
                if l > 0.0 {
                    let f = factor(i);
                    *v = (*v + wall.viscous_velocity[i] * f) / (1.0 + f * l);
                }
            }
        });
}

/// Bound of the Clavet relaxation's `θ = λ·dt²` per squared Courant number (see
/// `stable_time_step`): 1.2 at the default Courant number 0.4, 90 % of the linear stability
/// bound 4/3.
const CLAVET_THETA_PER_COURANT2: Real = 7.5;

/// Computes the Clavet fluid's stiffest rest mode if its parameters changed since it was last
/// computed (see [`crate::solver::clavet::stiffest_rest_mode`]); other solvers drop it.
fn refresh_clavet_stiffest(fluid: &mut Fluid) {
    let p = fluid.params();
    let Solver::Clavet(settings) = p.solver else {
        fluid.workspace.clavet_stiffest = None;
        return;
    };
    let (h, s) = (p.smoothing_length, p.particle_spacing);
    let c = p.equation_of_state.speed_of_sound();
    if let Some((h0, s0, c0, k0, _)) = fluid.workspace.clavet_stiffest
        && (h0, s0, c0, k0) == (h, s, c, settings)
    {
        return;
    }
    let lambda = crate::solver::clavet::stiffest_rest_mode(&settings, h, s, c);
    fluid.workspace.clavet_stiffest = Some((h, s, c, settings, lambda));
}

/// The longest stable substep for `fluid` (see [`TimeStepping::Adaptive`]), at most `remaining`.
fn stable_time_step(fluid: &Fluid, gravity: Vector, courant: Real, remaining: Real) -> Real {
    if fluid.is_empty() {
        return remaining;
    }
    let p = fluid.params();
    let v = fluid.workspace.max_speed;
    let g = gravity.length();
    let s = p.particle_spacing;
    // courant·s = v·dt + g·dt², solved for dt.
    let cs = courant * s;
    let mut limit = if g > 0.0 {
        2.0 * cs / (v + (v * v + 4.0 * g * cs).sqrt())
    } else if v > 0.0 {
        cs / v
    } else {
        remaining
    };
    if p.viscosity > 0.0 {
        let h = p.smoothing_length;
        limit = limit.min(p.rest_density * h * h / (30.0 * p.viscosity));
    }
    match p.solver {
        Solver::Wcsph => {
            let c = p.equation_of_state.speed_of_sound();
            limit = limit.min(courant * p.smoothing_length / (c + v));
        }
        Solver::Clavet(cl) => {
            // The relaxation pushes like an equation of state whose speed of sound is
            // `c·√k` (its stiffnesses are in units of c²/(h·ρ0)). Linear stability: with the
            // forces taken at the predicted positions, a mode of stiffness λ (per unit mass)
            // evolves as x' = (1 − θ)(x + dt·v), θ = λ·dt², which is bounded iff θ ≤ 4/3. The
            // stiffest mode of the rest lattice (h = 2s, k_c = k, default near stiffness;
            // power iteration on the linearised relaxation of periodic lattices of 6, 8, 10
            // and 12 spacings) has λ ≈ 6.4–6.8·k·c²/h², so θ ≈ 6.8·courant² = 1.08 at the
            // default Courant number 0.4: inside the bound (it allows courant ≤ 0.44).
            let c = p.equation_of_state.speed_of_sound()
                * cl.stiffness
                    .max(cl.cohesion)
                    .max(cl.near_stiffness.unwrap_or(cl.stiffness))
                    .max(cl.springs.map_or(0.0, |s| s.stiffness))
                    .max(1e-6)
                    .sqrt();
            limit = limit.min(courant * p.smoothing_length / (c + v));
            // That estimate holds at h = 2s. The stiffest mode grows faster than c²/h² with
            // the support in spacings (λ·h²/c² = 6.6, 12.1, 21.1 at h/s = 2, 2.5, 3: the
            // acoustic substep's θ is 1.06, 1.94, 3.37, unstable from about 2.2 spacings;
            // session 11), so the fluid's own stiffest mode (computed once per parameter set,
            // `refresh_clavet_stiffest`) also bounds the substep: θ = λ·dt² ≤
            // CLAVET_THETA_PER_COURANT2·courant², 1.2 at the default Courant number (90 % of
            // the bound 4/3). At h = 2s the acoustic limit above is the tighter one.
            if let Some((.., lambda)) = fluid.workspace.clavet_stiffest
                && lambda > 0.0
            {
                limit = limit.min(courant * (CLAVET_THETA_PER_COURANT2 / lambda).sqrt());
            }
        }
        Solver::Dfsph(d) if g > 0.0 => {
            // The density solve undoes, every substep, the compression that gravity makes in
            // it (a displacement of about g·dt²). Keeping that displacement within
            // 5·max_density_error spacings keeps the work per substep a few times the error
            // the solve is asked to reach; without it a fluid at rest takes CFL substeps of
            // ~30 ms (nothing moves yet), far outside the solve's linearisation. At the
            // default 0.1 % target this is 5 ms for 5 cm particles and 3.2 ms for 2 cm.
            limit = limit.min((5.0 * d.max_density_error * s / g).sqrt());
        }
        Solver::Pbf(b) if g > 0.0 && b.max_density_error.is_finite() => {
            // A fixed number of Jacobi iterations leaves a compression that grows with
            // gravity's displacement per substep, g·dt² (measured on a 1 m column of 5 cm
            // particles: 6.0 % at 1/60 s, 1.6 % at 1/120 s, 0.7 % at 1/240 s). Keeping that
            // displacement within `max_density_error` spacings holds the column near the
            // target: 7.1 ms for 5 cm particles, 4.5 ms for 2 cm at the default 1 %. A static
            // bound, not a feedback on the measured error: shortening the substep after a
            // long one turns the compression the long one left into a velocity ∝ 1/dt (tried:
            // it threw a Taylor–Green box apart).
            limit = limit.min((b.max_density_error * s / g).sqrt());
        }
        Solver::Dfsph(_) | Solver::Pbf(_) => {}
    }
    limit.min(remaining)
}

fn timed<T>(report: &mut StepReport, stage: Stage, f: impl FnOnce() -> T) -> T {
    let t0 = Instant::now();
    let out = f();
    report.timings.add(stage, t0.elapsed());
    out
}

/// One substep of one fluid. Returns the mean relative density error it measured.
fn step_fluid(
    fluid: &mut Fluid,
    gravity: Vector,
    dt: Real,
    colliders: Option<(&parry3d::partitioning::Bvh, &ColliderSet, &RigidBodySet)>,
    (coupling, back): (&mut Coupling, (Real, Real)),
    report: &mut StepReport,
) -> Real {
    let n = fluid.len();
    fluid.workspace.non_finite = 0;
    if n == 0 {
        return 0.0;
    }
    // Periodic box: particles added outside it (or moved there by the caller) start in it.
    if let Some(d) = fluid.params().domain.minimum_image() {
        timed(report, Stage::ParticleUpdate, || {
            integrate::wrap_positions(&d, &mut fluid.positions)
        });
    }
    if fluid.needs_depenetration || fluid.relax_pending {
        fluid.relax_pending = !relax_overlaps(fluid, colliders, report);
        report.relax_unfinished |= fluid.relax_pending;
    }
    // Moving bodies near this fluid during this substep (none: nothing more is done).
    let mut coupling = match colliders {
        Some((_, colliders, _)) if !coupling.is_off() => {
            timed(report, Stage::Contact, || {
                let p = fluid.params();
                let (lo, hi) = integrate::bounds(&fluid.positions);
                let v = fluid.workspace.max_speed + gravity.length() * dt;
                let margin = p.smoothing_length + p.particle_radius + 2.0 * v * dt;
                let fluid_box = parry3d::bounding_volume::Aabb::new(lo, hi);
                coupling.begin_substep(colliders, &fluid_box, margin, back.0, back.1);
            });
            Some(coupling)
        }
        _ => None,
    };
    let p = fluid.params().clone();
    let h = p.smoothing_length;
    let domain = p.domain.minimum_image();
    let dfsph_settings = match p.solver {
        Solver::Dfsph(d) => Some(d),
        _ => None,
    };
    let pbf_settings = match p.solver {
        Solver::Pbf(b) => Some(b),
        _ => None,
    };
    let clavet_settings = match p.solver {
        Solver::Clavet(c) => Some(c),
        _ => None,
    };
    let position_based = pbf_settings.is_some() || clavet_settings.is_some();
    let Fluid {
        positions,
        velocities,
        accelerations,
        densities,
        pressures,
        ids,
        warm_density,
        warm_divergence,
        springs,
        solver_relaxation,
        workspace: ws,
        ..
    } = fluid;

    // 0. PBF and Clavet predict first (gravity, then positions) and search neighbours at the
    //    predicted positions (Macklin & Müller 2013, Alg. 1 lines 2–4; Clavet et al. 2005,
    //    Alg. 1).
    if position_based {
        ws.previous_positions.resize(n, Vector::ZERO);
        if gravity != Vector::ZERO {
            timed(report, Stage::ExternalForces, || {
                accelerations.fill(gravity);
                integrate::add_accelerations(dt, accelerations, velocities);
            });
        }
        timed(report, Stage::ParticleUpdate, || {
            integrate::predict_positions(dt, velocities, positions, &mut ws.previous_positions)
        });
    }

    // 1. Neighbour search: sort by cell (every per-particle array follows), cells, lists.
    timed(report, Stage::NeighbourSearch, || {
        search_neighbours(
            h,
            domain,
            positions,
            velocities,
            ids,
            dfsph_settings
                .is_some()
                .then_some((warm_density, warm_divergence)),
            position_based,
            ws,
        )
    });
    report.neighbour_pairs += ws.neighbors.total_pairs();

    // 2. Wall density: colliders within the kernel support count in the density.
    let force_kernel = if p.solver == Solver::Wcsph {
        p.pressure_kernel
    } else {
        p.density_kernel
    };
    match colliders {
        Some((bvh, colliders, bodies)) if p.wall_density => {
            let near = timed(report, Stage::WallDensity, || {
                ws.wall.update(
                    &ws.grid,
                    &ws.neighbors,
                    positions,
                    p.density_kernel,
                    force_kernel,
                    h,
                    p.particle_spacing,
                    p.rest_density,
                    bvh,
                    colliders,
                    bodies,
                    p.collision_groups,
                    coupling.as_deref(),
                    // The hydrostatic wall pressure is a DFSPH and PBF option (see
                    // `boundary::wall`).
                    match p.solver {
                        Solver::Dfsph(d) if d.hydrostatic_walls => Some(gravity),
                        Solver::Pbf(b) if b.hydrostatic_walls => Some(gravity),
                        _ => None,
                    },
                    p.wall_viscosity > 0.0,
                    // PBF and Clavet predicted the positions to the substep's end: the
                    // moving bodies are taken there too.
                    position_based,
                )
            });
            if clavet_settings.is_some() {
                timed(report, Stage::WallDensity, || {
                    ws.wall.update_clavet(
                        &ws.grid,
                        positions,
                        h,
                        p.particle_spacing,
                        colliders,
                        bodies,
                        coupling.as_deref(),
                    )
                });
            }
            report.particles_near_walls += near;
        }
        _ => ws.wall.clear(),
    }
    // Taken out of the workspace for the solver stages (a move, no copy), put back below.
    let wall_ws = std::mem::take(&mut ws.wall);
    let wall = wall_ws.any().then_some(&wall_ws);

    ws.inv_densities.resize(n, 0.0);
    ws.previous_positions.resize(n, Vector::ZERO);
    // The separation (plain or minimum image) is chosen here once: every stage below is
    // compiled for each, so the open domain runs exactly the code it ran before.
    let (non_finite, max_speed) = crate::with_separation!(p.domain, S, sep => match (dfsph_settings, pbf_settings) {
        _ if clavet_settings.is_some() => step_clavet(
            &p,
            &clavet_settings.unwrap_or_default(),
            dt,
            wall,
            ids,
            springs,
            positions,
            velocities,
            accelerations,
            densities,
            pressures,
            ws,
            report,
            sep,
        ),
        (_, Some(settings)) => step_pbf(
            &p,
            &settings,
            dt,
            wall,
            positions,
            velocities,
            accelerations,
            densities,
            pressures,
            solver_relaxation,
            ws,
            report,
            sep,
        ),
        (None, None) => step_wcsph(
            &p,
            gravity,
            dt,
            wall,
            positions,
            velocities,
            accelerations,
            densities,
            pressures,
            ws,
            report,
            sep,
        ),
        (Some(settings), None) => step_dfsph(
            &p,
            &settings,
            gravity,
            dt,
            wall,
            positions,
            velocities,
            accelerations,
            densities,
            pressures,
            warm_density,
            warm_divergence,
            solver_relaxation,
            ws,
            report,
            sep,
        ),
    });
    // The walls' viscosity (ε_w > 0), after the solver, on the velocities it left.
    let mut viscous_records = std::mem::take(&mut ws.wall_viscous_impulses);
    viscous_records.clear();
    if p.wall_viscosity > 0.0
        && let Some(w) = wall
        && w.viscous.len() == velocities.len()
    {
        timed(report, Stage::ViscosityForce, || {
            wall_viscosity(
                p.wall_viscosity,
                p.particle_mass,
                dt,
                w,
                positions,
                &ws.inv_densities,
                velocities,
                &mut viscous_records,
            )
        });
    }
    // Fluid → body through the walls' pressure: each particle's wall force from dynamic
    // bodies pushes those bodies back (Newton's third law; see `boundary::bodies`). With
    // `g_c` the dynamic bodies' share of the wall density's gradient, the impulse the
    // particle's wall term gave it over the substep, and so minus the body's, is
    // - WCSPH: `−m·g_c·p/(2ρ²)·dt` (the wall pressure force);
    // - DFSPH: `−m·g_c·(γ·Σπ + Σπ̂)·dt` (`Σπ̂` the neighbours' average with hydrostatic walls,
    //   0 otherwise), `Σπ` all the pressure values the divergence and density
    //   solves applied this substep (warm starts included: what `warm_*` hold now), plus
    //   minus the dynamic bodies' share of the hydrostatic wall term (when on), `m·h_c·dt`;
    // - PBF: `m·g_c·Σω·λ_w/(ρ0·dt)`, the wall's share of the position corrections over all
    //   iterations turned into velocity (`v = Δx/dt`; `λ_w = λ`, with hydrostatic walls
    //   `λ + λ̂`, and minus the hydrostatic part as for DFSPH). Until session 14 `Σλ` without
    //   the relaxation `ω`: after a halving the bodies took up to 8× the particles' impulse.
    // Clavet's wall term leaves dynamic bodies out (they meet its fluid through contact,
    // whose impulses reach the bodies for every solver; see `WallWorkspace::update_clavet`),
    // and it has no wall viscosity (refused by `FluidParams::validate`).
    if let (Some(c), Some(w)) = (coupling.as_deref_mut(), wall)
        && w.coupled_any
        && clavet_settings.is_none()
    {
        let m = p.particle_mass;
        let divergence = dfsph_settings.is_some_and(|d| d.divergence_solve);
        timed(report, Stage::Contact, || {
            let records = &mut ws.wall_impulses;
            records.resize_with(1, Vec::new);
            records[0].clear();
            for (i, cw) in w.coupled.iter().enumerate() {
                let (gc, e, point) = (cw.gradient, cw.entry, cw.point);
                if e == u32::MAX {
                    continue;
                }
                let scale = match p.solver {
                    Solver::Wcsph => {
                        let inv = ws.inv_densities[i];
                        0.5 * pressures[i] * inv * inv * m * dt
                    }
                    Solver::Dfsph(_) => {
                        let total = |j: usize| {
                            warm_density[j] + if divergence { warm_divergence[j] } else { 0.0 }
                        };
                        // With hydrostatic walls the wall's pressure adds the neighbours'
                        // (see `WallWorkspace::neighbour_pressure`), with the values it was
                        // applied with (`DfsphBuffers::applied_neighbour`).
                        let applied = &ws.dfsph.applied_neighbour;
                        let wall_pi = crate::solver::dfsph::wall_neighbour_pressure(
                            &ws.neighbors,
                            &ws.gradients,
                            w,
                            i,
                            |j| applied[j],
                        );
                        (w.mirror * total(i) + wall_pi) * m * dt
                    }
                    // The wall term's λ as applied (`PbfBuffers::wall_lambda_sum`: relaxation
                    // included, and the neighbours' part with hydrostatic walls).
                    Solver::Pbf(_) => -ws.pbf.wall_lambda_sum[i] * m / (p.rest_density * dt),
                    Solver::Clavet(_) => 0.0,
                };
                // The hydrostatic wall term (DFSPH; see `boundary::wall`) pushed the particle
                // by `m·h_c·dt`: the body takes the opposite.
                let impulse = gc * scale - cw.hydrostatic * (m * dt);
                if impulse != Vector::ZERO {
                    records[0].push(crate::boundary::bodies::ImpulseRecord {
                        entry: e,
                        particle: i as u32,
                        // The particle moves along with the body in the direction its wall
                        // term pushed it (the added-mass solve of `Coupling::exchange`, as
                        // for contact). Not for PBF, whose reaction is a position correction
                        // turned into velocity: with it PBF's boxes float 5–17 % too deep
                        // (measured, 4 cm; without, within 5 %), not understood yet; still
                        // so with the bodies at their end pose (`WallWorkspace::update`):
                        // 0.269 for the 250 kg/m³ box at 2.5 cm, +7.6 %.
                        normal: if matches!(p.solver, Solver::Pbf(_)) {
                            Vector::ZERO
                        } else {
                            gc.normalize_or_zero()
                        },
                        impulse,
                        point,
                    });
                }
            }
            records[0].append(&mut viscous_records);
            c.exchange(records, velocities, p.particle_mass);
        });
    }
    ws.wall_viscous_impulses = viscous_records;
    ws.wall = wall_ws;
    report.non_finite += non_finite;
    report.max_speed = report.max_speed.max(max_speed);
    ws.non_finite = non_finite;
    ws.max_speed = max_speed;
    // The step report's density error (counted with the density stage, whose output it reads).
    let (max_err, mean_err) = timed(report, Stage::Density, || {
        density::density_error(densities, p.rest_density, &mut ws.partials)
    });
    report.max_density_error = report.max_density_error.max(max_err);

    // 9. Collider contact.
    let depenetrated = collider_contact(
        &p,
        ws,
        colliders,
        fluid.needs_depenetration,
        positions,
        velocities,
        report,
        coupling.as_deref_mut(),
    );
    // Particles pushed out of a solid land on its surface, on top of each other: relax them
    // (and check for more) before the next substep gives them dynamics (`relax_overlaps`).
    fluid.needs_depenetration = depenetrated > 0;
    // Periodic box: particles that left it re-enter through the opposite face.
    if let Some(d) = domain {
        timed(report, Stage::ParticleUpdate, || {
            integrate::wrap_positions(&d, &mut fluid.positions)
        });
    }
    mean_err
}

/// Stage 1: sorts the particles by cell (every per-particle array named here follows the
/// permutation: the DFSPH warm starts when given, `ws.previous_positions` when `previous`),
/// then builds the cells and the neighbour lists.
fn search_neighbours(
    h: Real,
    domain: Option<MinimumImage>,
    positions: &mut Vec<Vector>,
    velocities: &mut Vec<Vector>,
    ids: &mut Vec<u32>,
    warm: Option<(&mut Vec<Real>, &mut Vec<Real>)>,
    previous: bool,
    ws: &mut crate::fluid::Workspace,
) {
    let reordered = match &domain {
        None => ws.grid.sort(positions, h),
        Some(d) => ws.grid.sort_periodic(positions, h, d),
    };
    if reordered {
        let perm = ws.grid.permutation();
        par::permute(positions, &mut ws.scratch_vectors, perm);
        par::permute(velocities, &mut ws.scratch_vectors, perm);
        par::permute(ids, &mut ws.scratch_ids, perm);
        if let Some((density, divergence)) = warm {
            par::permute(density, &mut ws.scratch_reals, perm);
            par::permute(divergence, &mut ws.scratch_reals, perm);
        }
        if previous {
            par::permute(&mut ws.previous_positions, &mut ws.scratch_vectors, perm);
        }
    }
    ws.grid.build_cells();
    build_lists(ws, positions, h, domain);
}

/// The neighbour lists over the current cells (minimum-image distances in a periodic box).
fn build_lists(
    ws: &mut crate::fluid::Workspace,
    positions: &[Vector],
    h: Real,
    domain: Option<MinimumImage>,
) {
    match domain {
        None => ws.neighbors.build(&ws.grid, positions, h),
        Some(d) => ws.neighbors.build_periodic(&ws.grid, positions, h, d),
    }
}

/// Collider contact of every particle, swept from `ws.previous_positions` to `positions`.
/// Returns the number of particles pushed out of a solid.
fn collider_contact(
    p: &crate::FluidParams,
    ws: &mut crate::fluid::Workspace,
    colliders: Option<(&parry3d::partitioning::Bvh, &ColliderSet, &RigidBodySet)>,
    depenetrate: bool,
    positions: &mut [Vector],
    velocities: &mut [Vector],
    report: &mut StepReport,
    coupling: Option<&mut Coupling>,
) -> usize {
    let Some((bvh, colliders, _)) = colliders else {
        ws.contact.clear();
        return 0;
    };
    let counts = timed(report, Stage::Contact, || {
        ws.contact.gather(
            &ws.grid,
            &ws.previous_positions,
            positions,
            p.particle_radius,
            bvh,
            colliders,
            p.collision_groups,
            coupling.as_deref(),
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
            depenetrate,
            &ws.previous_positions,
            positions,
            velocities,
            coupling.as_deref().map(|c| Movers {
                table: c.table(),
                mass: p.particle_mass,
                records: &mut ws.impulses,
            }),
        )
    });
    // Fluid → body: the impulses contact recorded on dynamic bodies.
    if let Some(c) = coupling
        && !c.table().is_empty()
    {
        timed(report, Stage::Contact, || {
            c.exchange(&ws.impulses, velocities, p.particle_mass)
        });
    }
    report.contacts += counts.contacts;
    report.contact_fallbacks += counts.fallbacks;
    report.depenetrated += counts.depenetrated;
    counts.depenetrated
}

/// Most relaxation rounds per substep (each: neighbour search, one projection). A block
/// of 20³ particles spawned at half spacing (8× ρ0) needs about 190 (stability case 6); a
/// relaxation the cap stops carries on in the next substep and the report says so
/// ([`StepReport::relax_unfinished`]).
const RELAX_ROUNDS: u32 = 1000;
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
const RELAX_MAX_MOVE: Real = 0.2;

/// Pre-stabilisation (Macklin et al. 2014, "Unified particle physics for real-time
/// applications", section 4.4): particles that were just placed (`add_particles`) or pushed out
/// of a solid may overlap far beyond any compression a flow produces (denser than the fluid's
/// own rest lattice). Every solver would turn
/// that overlap into velocity within one step (an explosion). Instead, the overlap beyond
/// [`RELAX_TOLERANCE`] is projected out of the *positions* only, with the PBF density
/// constraint (unilateral, no artificial pressure, moves of at most [`RELAX_MAX_MOVE`] spacings
/// per round, up to [`RELAX_ROUNDS`] rounds with a fresh neighbour search each), each round's
/// move swept through collider contact. Velocities are left as they were. Runs only when
/// particles were added or depenetrated (or an earlier relaxation was stopped by
/// [`RELAX_ROUNDS`]); otherwise it costs one flag check. Returns whether it finished: no
/// particle compressed beyond [`RELAX_SETTLED`].
fn relax_overlaps(
    fluid: &mut Fluid,
    colliders: Option<(&parry3d::partitioning::Bvh, &ColliderSet, &RigidBodySet)>,
    report: &mut StepReport,
) -> bool {
    let p = fluid.params().clone();
    let h = p.smoothing_length;
    let domain = p.domain.minimum_image();
    let depenetrate = fluid.needs_depenetration;
    let Fluid {
        positions,
        velocities,
        ids,
        warm_density,
        warm_divergence,
        densities,
        workspace: ws,
        ..
    } = fluid;
    let n = positions.len();
    ws.previous_positions.resize(n, Vector::ZERO);
    ws.previous_positions.copy_from_slice(positions);
    ws.inv_densities.resize(n, 0.0);
    let settings = crate::solver::Pbf {
        iterations: 1,
        relaxation: 0.01,
        artificial_pressure: 0.0,
        ..crate::solver::Pbf::default()
    };
    // Overlap means denser than the fluid's own spawn lattice (what `add_block` makes): for
    // SI presets that is ρ0 to 0.003 %; the paper's preset is at 5.5 ρ0 on its lattice and
    // is left as the paper has it.
    let lattice_density = {
        let s = p.particle_spacing;
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
    };
    let mut finished = false;
    for round in 0..RELAX_ROUNDS {
        report.relax_rounds += 1;
        timed(report, Stage::NeighbourSearch, || {
            search_neighbours(
                h,
                domain,
                positions,
                velocities,
                ids,
                Some((&mut *warm_density, &mut *warm_divergence)),
                true,
                ws,
            )
        });
        if round == 0 {
            // Particles at exactly the same place have no separation to push along (the
            // smooth kernels' gradients vanish at 0): move each one that has a coincident
            // neighbour by a small offset that depends only on its id (deterministic).
            let s = p.particle_spacing;
            let mut any = false;
            for i in 0..n {
                let xi = positions[i];
                let hit = ws.neighbors.of(i).iter().any(|&j| {
                    let r = match &domain {
                        None => xi - positions[j as usize],
                        Some(d) => d.sep(xi, positions[j as usize]),
                    };
                    r.length() < 1e-3 * s
                });
                if hit {
                    let id = ids[i];
                    let frac = ((id as f64 * 0.618_033_988_75).fract() as Real) * 0.9 + 0.1;
                    let dir = crate::math::coincident_direction(id, u32::MAX)
                        + crate::math::coincident_direction(id.wrapping_mul(3), u32::MAX - 1) * 0.5;
                    positions[i] += dir * (0.05 * s * frac);
                    any = true;
                }
            }
            if any {
                ws.grid.build_cells();
                build_lists(ws, positions, h, domain);
            }
        }
        if round == 0 && depenetrate {
            // Out of the solids first: a particle inside one would be pushed by the wall's
            // density from the inside.
            collider_contact(&p, ws, colliders, true, positions, velocities, report, None);
            ws.previous_positions.copy_from_slice(positions);
        }
        // Walls that count in the density count here too (a particle on a solid's surface
        // is compressed by the wall as much as by fluid).
        let wall = match colliders {
            Some((bvh, colliders, bodies)) if p.wall_density => {
                timed(report, Stage::WallDensity, || {
                    ws.wall.update(
                        &ws.grid,
                        &ws.neighbors,
                        positions,
                        p.density_kernel,
                        p.density_kernel,
                        h,
                        p.particle_spacing,
                        p.rest_density,
                        bvh,
                        colliders,
                        bodies,
                        p.collision_groups,
                        None,
                        None,
                        false,
                        false,
                    )
                });
                ws.wall.any().then_some(&ws.wall)
            }
            _ => None,
        };
        let ctx = crate::solver::pbf::PbfContext {
            neighbors: &ws.neighbors,
            wall,
            mass: p.particle_mass,
            h,
            spacing: p.particle_spacing,
            rest_density: lattice_density,
            tolerance: RELAX_TOLERANCE,
            max_move: RELAX_MAX_MOVE * p.particle_spacing,
            safeguard: false,
        };
        let stats = timed(report, Stage::DensitySolve, || {
            crate::with_separation!(p.domain, S, sep =>
                crate::with_kernel!(p.density_kernel, K => crate::solver::pbf::solve_in::<K, S>(
                    &ctx, &settings, &mut ws.pbf, positions, densities, &mut ws.inv_densities,
                    sep)))
        });
        if stats.moved == 0 {
            finished = true;
            break;
        }
        report.relaxed = report.relaxed.max(stats.moved);
        // Each round's move is swept through the solids before the next projection sees it
        // (an expanding block must meet the walls it expands against, not pile onto them
        // after the last round).
        collider_contact(
            &p, ws, colliders, false, positions, velocities, report, None,
        );
        ws.previous_positions.copy_from_slice(positions);
        // `densities` are those the round corrected: within the settled bound, this round's
        // moves were the last small ones.
        let densest = densities.iter().copied().fold(0.0, Real::max);
        if densest <= lattice_density * (1.0 + RELAX_SETTLED) {
            finished = true;
            break;
        }
    }
    finished
}

/// Stages 3–8 of WCSPH (the Unity paper). Returns `(non-finite count, max speed)`.
#[allow(clippy::too_many_arguments)]
fn step_wcsph<S: Separation>(
    p: &crate::FluidParams,
    gravity: Vector,
    dt: Real,
    wall: Option<&crate::boundary::WallWorkspace>,
    positions: &mut [Vector],
    velocities: &mut [Vector],
    accelerations: &mut [Vector],
    densities: &mut [Real],
    pressures: &mut [Real],
    ws: &mut crate::fluid::Workspace,
    report: &mut StepReport,
    sep: S,
) -> (usize, Real) {
    let h = p.smoothing_length;
    // 3. Density (fluid sum plus walls).
    timed(report, Stage::Density, || {
        crate::with_kernel!(p.density_kernel, K => density::compute_in::<K, S>(
            positions, &ws.neighbors, p.particle_mass, h, wall.map(|w| &w.density[..]),
            densities, &mut ws.inv_densities, sep));
    });

    // 4. Pressure.
    timed(report, Stage::Pressure, || {
        pressure::eos::compute(
            densities,
            p.equation_of_state,
            p.rest_density,
            p.clamp_negative_pressure,
            pressures,
        );
    });

    // 5. Pressure force (overwrites the accelerations).
    timed(report, Stage::PressureForce, || {
        crate::with_kernel!(p.pressure_kernel, K => pressure::wcsph::pressure_accelerations_in::<K, S>(
            positions, &ws.inv_densities, pressures, &ws.neighbors, p.particle_mass, h,
            wall.map(|w| &w.gradient[..]), accelerations, sep));
    });

    // 6. Viscosity force.
    if p.viscosity > 0.0 {
        timed(report, Stage::ViscosityForce, || {
            forces::viscosity::add_accelerations_in(
                positions,
                velocities,
                &ws.inv_densities,
                &ws.neighbors,
                p.particle_mass,
                p.viscosity,
                h,
                accelerations,
                sep,
            );
        });
    }

    // 7. External forces.
    if gravity != Vector::ZERO {
        timed(report, Stage::ExternalForces, || {
            forces::external::add_gravity(gravity, accelerations)
        });
    }

    // 8. Particle update (symplectic Euler).
    timed(report, Stage::ParticleUpdate, || {
        integrate::symplectic_euler(
            dt,
            accelerations,
            velocities,
            positions,
            &mut ws.previous_positions,
        )
    })
}

/// Stages 3–8 of DFSPH (see [`crate::solver::dfsph`]). Returns `(non-finite count, max speed)`.
#[allow(clippy::too_many_arguments)]
fn step_dfsph<S: Separation>(
    p: &crate::FluidParams,
    settings: &crate::solver::Dfsph,
    gravity: Vector,
    dt: Real,
    wall: Option<&crate::boundary::WallWorkspace>,
    positions: &mut [Vector],
    velocities: &mut [Vector],
    accelerations: &mut [Vector],
    densities: &mut [Real],
    pressures: &mut [Real],
    warm_density: &mut [Real],
    warm_divergence: &mut [Real],
    solver_relaxation: &mut u32,
    ws: &mut crate::fluid::Workspace,
    report: &mut StepReport,
    sep: S,
) -> (usize, Real) {
    let h = p.smoothing_length;
    let n = positions.len();
    ws.dfsph.resize(n);
    ws.dfsph.relaxation_halvings = *solver_relaxation;
    // 3. Density and DFSPH factors, and the divergence solve's warm start (same pass).
    // A fluid filling a periodic box has no free surface (see `dfsph::SolveContext::closed`).
    let closed = dfsph::fills_periodic_box(
        &p.domain,
        n,
        p.particle_mass,
        p.rest_density,
        wall.is_some(),
        settings.max_density_error,
    );
    let pushed = settings.divergence_solve && dfsph::divergence_warm_start(warm_divergence, closed);
    // Hydrostatic walls: the pressure values their neighbour part is applied with this
    // substep, starting with the divergence warm start's push (see
    // `dfsph::DfsphBuffers::applied_neighbour`).
    if wall.is_some_and(|w| w.neighbour_pressure) {
        let applied = &mut ws.dfsph.applied_neighbour;
        applied.clear();
        if pushed {
            applied.extend_from_slice(warm_divergence);
        } else {
            applied.resize(n, 0.0);
        }
    }
    timed(report, Stage::Density, || {
        let viscosity = (p.viscosity > 0.0).then(|| ViscosityLaplacian::new(h));
        let push = pushed.then_some(dfsph::WarmPush {
            pi: warm_divergence,
            velocities,
            dt,
        });
        crate::with_kernel!(p.density_kernel, K => dfsph::density_and_factors_in::<K, S>(
            positions, &ws.neighbors, p.particle_mass, h, wall, viscosity, push,
            densities, &mut ws.inv_densities, &mut ws.dfsph.alpha, &mut ws.gradients,
            &mut ws.dfsph.velocities, sep));
    });
    let ctx = dfsph::SolveContext {
        positions,
        neighbors: &ws.neighbors,
        gradients: &ws.gradients,
        wall,
        densities,
        mass: p.particle_mass,
        h,
        rest_density: p.rest_density,
        dt,
        expected_neighbours: p.expected_neighbours(),
        closed,
        self_density: p.particle_mass * p.density_kernel.w(0.0, h),
    };

    // 4. Divergence solve.
    if settings.divergence_solve {
        let stats = timed(report, Stage::DivergenceSolve, || {
            dfsph::divergence_solve(
                &ctx,
                settings,
                &mut ws.dfsph,
                pushed,
                warm_divergence,
                velocities,
            )
        });
        report.divergence_iterations += stats.iterations;
        report.solver_wall_neighbour_dropped += stats.neighbour_dropped as u32;
        report.solver_divergence_error = report.solver_divergence_error.max(stats.error);
        report.solver_capped += stats.capped as u32;
    }

    // 5–6. Non-pressure forces, then the predicted velocity.
    let mut forces = false;
    if p.viscosity > 0.0 {
        forces = true;
        timed(report, Stage::ViscosityForce, || {
            accelerations.fill(Vector::ZERO);
            // From the pair Laplacians stored by the density pass.
            dfsph::viscosity(
                &ws.neighbors,
                ctx.gradients,
                velocities,
                &ws.inv_densities,
                p.particle_mass,
                p.viscosity,
                &mut ws.dfsph.velocities,
                accelerations,
            );
        });
    }
    if gravity != Vector::ZERO {
        timed(report, Stage::ExternalForces, || {
            if forces {
                forces::external::add_gravity(gravity, accelerations);
            } else {
                accelerations.fill(gravity);
            }
            if let Some(w) = wall
                && w.hydrostatic_on
            {
                for (a, h) in accelerations.iter_mut().zip(&w.hydrostatic) {
                    *a += *h;
                }
            }
        });
        forces = true;
    }
    if !forces {
        accelerations.fill(Vector::ZERO);
    }

    // 7. Constant-density solve on the predicted velocities.
    let stats = timed(report, Stage::DensitySolve, || {
        if forces {
            integrate::add_accelerations(dt, accelerations, velocities);
        }
        dfsph::density_solve(&ctx, settings, &mut ws.dfsph, warm_density, velocities)
    });
    *solver_relaxation = ws.dfsph.relaxation_halvings;
    report.solver_relaxation_halvings = report
        .solver_relaxation_halvings
        .max(ws.dfsph.relaxation_halvings);
    report.solver_iterations += stats.iterations;
    report.solver_density_error = report.solver_density_error.max(stats.error);
    report.solver_capped += stats.capped as u32;
    report.solver_wall_neighbour_dropped += stats.neighbour_dropped as u32;
    // The pressure reported is all the pressure the step applied: the constant-density and
    // the divergence solves' values (both are `π = p/ρ²` applied over the same `dt`).
    for (((pr, &w), &wv), &rho) in pressures
        .iter_mut()
        .zip(warm_density.iter())
        .zip(warm_divergence.iter())
        .zip(ctx.densities)
    {
        *pr = (w + wv) * rho * rho;
    }

    // 8. Particle update: the velocities are final; move.
    timed(report, Stage::ParticleUpdate, || {
        integrate::advance_positions(dt, velocities, positions, &mut ws.previous_positions)
    })
}

/// Stages 3–8 of PBF (see [`crate::solver::pbf`]); gravity and the position prediction ran
/// before the neighbour search. Returns `(non-finite count, max speed)`.
#[allow(clippy::too_many_arguments)]
fn step_pbf<S: Separation>(
    p: &crate::FluidParams,
    settings: &crate::solver::Pbf,
    dt: Real,
    wall: Option<&crate::boundary::WallWorkspace>,
    positions: &mut [Vector],
    velocities: &mut [Vector],
    accelerations: &mut [Vector],
    densities: &mut [Real],
    pressures: &mut [Real],
    solver_relaxation: &mut u32,
    ws: &mut crate::fluid::Workspace,
    report: &mut StepReport,
    sep: S,
) -> (usize, Real) {
    let h = p.smoothing_length;
    ws.pbf.relaxation_halvings = *solver_relaxation;
    // Hydrostatic walls: the wall pressure's hydrostatic part moves the predicted positions by
    // `a_h·dt²` (its acceleration over the substep), as DFSPH adds it to the velocities.
    if let Some(w) = wall
        && w.hydrostatic_on
    {
        timed(report, Stage::ExternalForces, || {
            for (x, a) in positions.iter_mut().zip(&w.hydrostatic) {
                *x += *a * (dt * dt);
            }
        });
    }
    let ctx = crate::solver::pbf::PbfContext {
        neighbors: &ws.neighbors,
        wall,
        mass: p.particle_mass,
        h,
        spacing: p.particle_spacing,
        rest_density: p.rest_density,
        tolerance: 0.0,
        max_move: Real::INFINITY,
        safeguard: true,
    };
    // 3–5. The position solve (densities are measured in its first pass).
    let stats = timed(report, Stage::DensitySolve, || {
        crate::with_kernel!(p.density_kernel, K => crate::solver::pbf::solve_in::<K, S>(
            &ctx, settings, &mut ws.pbf, positions, densities, &mut ws.inv_densities, sep))
    });
    *solver_relaxation = ws.pbf.relaxation_halvings;
    report.solver_relaxation_halvings = report
        .solver_relaxation_halvings
        .max(ws.pbf.relaxation_halvings);
    report.solver_iterations += stats.iterations;
    report.solver_density_error = report.solver_density_error.max(stats.error);
    // The pressure the corrections stand for: Δx = dt²·a with a = −Σ m (π_i + π_j) ∇W gives
    // π = −Σλ/(ρ0·dt²).
    let scale = -1.0 / (p.rest_density * dt * dt);
    for ((pr, &l), &rho) in pressures
        .iter_mut()
        .zip(ws.pbf.lambda_sum.iter())
        .zip(densities.iter())
    {
        *pr = l * scale * rho * rho;
    }

    finish_position_step(p, dt, positions, velocities, accelerations, ws, report, sep)
}

/// Stages 3–8 of the double-density relaxation (see [`crate::solver::clavet`]); gravity and
/// the position prediction ran before the neighbour search. Returns `(non-finite count, max
/// speed)`.
#[allow(clippy::too_many_arguments)]
fn step_clavet<S: Separation>(
    p: &crate::FluidParams,
    settings: &crate::solver::Clavet,
    dt: Real,
    wall: Option<&crate::boundary::WallWorkspace>,
    ids: &[u32],
    springs: &mut crate::solver::springs::SpringSet,
    positions: &mut [Vector],
    velocities: &mut [Vector],
    accelerations: &mut [Vector],
    densities: &mut [Real],
    pressures: &mut [Real],
    ws: &mut crate::fluid::Workspace,
    report: &mut StepReport,
    sep: S,
) -> (usize, Real) {
    let h = p.smoothing_length;
    let c = p.equation_of_state.speed_of_sound();
    let ctx = crate::solver::clavet::ClavetContext {
        neighbors: &ws.neighbors,
        h,
        spacing: p.particle_spacing,
        speed_of_sound: c,
        dt,
        wall,
    };
    // Springs (if any) first, on the predicted positions (the paper's Alg. 1 order); timed
    // with the relaxation.
    let error = timed(report, Stage::DensitySolve, || {
        if let Some(s) = &settings.springs {
            let sctx = crate::solver::springs::SpringContext {
                neighbors: &ws.neighbors,
                ids,
                h,
                speed_of_sound: c,
                expected_neighbours: p.expected_neighbours(),
                dt,
            };
            crate::solver::springs::apply_in(&sctx, s, springs, &mut ws.springs, positions, sep);
        } else if !springs.is_empty() {
            // Springs switched off: forget them.
            *springs = Default::default();
        }
        crate::solver::clavet::relax_in(&ctx, settings, &mut ws.clavet, positions, densities, sep)
    });
    report.solver_iterations += 1;
    report.solver_density_error = report.solver_density_error.max(error);
    // Densities: the relative density times ρ0; pressures: a linear equation of state with the
    // fluid's speed of sound at that density (the acceleration the relaxation applies).
    for ((rho, pr), inv) in densities
        .iter_mut()
        .zip(pressures.iter_mut())
        .zip(ws.inv_densities.iter_mut())
    {
        let rel = *rho;
        *rho = rel * p.rest_density;
        *inv = 1.0 / rho.max(Real::MIN_POSITIVE);
        let k = if rel < 1.0 {
            settings.cohesion
        } else {
            settings.stiffness
        };
        *pr = k * p.rest_density * c * c * (rel - 1.0);
    }
    finish_position_step(p, dt, positions, velocities, accelerations, ws, report, sep)
}

/// Stages 8 and 6 of the position-based solvers (PBF, Clavet): velocities from the corrected
/// positions, then viscosity on the new velocities (the role XSPH plays in Macklin & Müller).
/// Returns `(non-finite count, max speed)`.
fn finish_position_step<S: Separation>(
    p: &crate::FluidParams,
    dt: Real,
    positions: &[Vector],
    velocities: &mut [Vector],
    accelerations: &mut [Vector],
    ws: &mut crate::fluid::Workspace,
    report: &mut StepReport,
    sep: S,
) -> (usize, Real) {
    let (mut non_finite, mut max_speed) = timed(report, Stage::ParticleUpdate, || {
        integrate::velocities_from_positions(dt, positions, &ws.previous_positions, velocities)
    });
    if p.viscosity > 0.0 {
        timed(report, Stage::ViscosityForce, || {
            accelerations.fill(Vector::ZERO);
            forces::viscosity::add_accelerations_in(
                positions,
                velocities,
                &ws.inv_densities,
                &ws.neighbors,
                p.particle_mass,
                p.viscosity,
                p.smoothing_length,
                accelerations,
                sep,
            );
            integrate::add_accelerations(dt, accelerations, velocities);
        });
        (non_finite, max_speed) = integrate::scan(positions, velocities);
    }
    (non_finite, max_speed)
}
