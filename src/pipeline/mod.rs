//! One frame of the fluid, divided into substeps (see [`TimeStepping`]), each the ordered list
//! of named, timed stages of `substep.rs`:
//!
//! ```text
//! particles ─▶ 0 overlap relaxation (only after particles were added) ─▶ 1 prediction (PBF, Clavet)
//!   ─▶ 2 neighbour search ─▶ 3 wall density ─▶ 4 the solver: density, pressure, forces, update
//!   ─▶ 5 wall viscosity ─▶ 6 wall reaction on bodies ─▶ 7 collider contact
//! after the substeps: sinks, emitters, the impulses to rapier
//! ```
//!
//! Each stage is timed into [`StepReport::timings`]. A stage a scene does not use is skipped,
//! not run on zeros: no viscosity pass when ε = 0, no gravity pass when gravity is zero, no
//! wall or contact work when no collider is near the fluid. ARCHITECTURE.md describes who
//! owns which data and how to add a stage or a solver.

mod contact;
mod interaction;
mod mixture;
mod records;
mod relax;
mod sleep;
mod substep;
mod time_stepping;
mod workspace;

pub use relax::{RELAX_FRAME_ROUNDS, RELAX_PROGRESS, RELAX_STALLED_ROUNDS};
pub use time_stepping::{MAX_GRAVITY, MAX_SUBSTEPS, MIN_TIME_STEP, TimeStepping};

use crate::boundary::Coupling;
use crate::boundary::forces::Records;
use crate::diagnostics::{Stage, StepReport};
use crate::error::{SphError, SphResult};
use crate::fluid::{FluidHandle, FluidSet};
use crate::math::{Real, Vector};
use crate::neighbors::NeighborLists;
use contact::Scene;
use parry3d::query::DefaultQueryDispatcher;
use rapier3d::dynamics::{IntegrationParameters, RigidBodyHandle, RigidBodySet};
use rapier3d::geometry::{BroadPhaseBvh, ColliderSet};
use rapier3d::pipeline::{PhysicsWorld, QueryFilter};
use substep::SubstepInput;
use workspace::Runtimes;

/// Steps fluids alongside a rapier world. Holds its time-stepping policy, the last report,
/// and per fluid the solver's state and the step's scratch; the particles live in the
/// [`FluidSet`] and the bodies in the rapier sets, passed explicitly as rapier's own
/// `PhysicsPipeline` does.
///
/// # Examples
/// ```
/// use rapier_sph::prelude::*;
/// use rapier_sph::rapier3d::prelude::PhysicsWorld;
///
/// let mut world = PhysicsWorld::default(); // no collider: the drop falls freely
/// let mut fluids = FluidSet::new();
/// let mut drop = Fluid::new(FluidParamsBuilder::water(0.05))?;
/// drop.add_block(Vector::ZERO, Vector::splat(0.2))?;
/// let drop = fluids.insert(drop);
/// let mut pipeline = FluidPipeline::with_time_stepping(TimeStepping::Adaptive {
///     courant: 0.3,
///     max_substeps: 64,
/// });
/// world.step();
/// let report = pipeline.step_world(&mut world, &mut fluids)?;
/// assert_eq!(report.particles, 64);
/// assert!(fluids[drop].velocities().iter().all(|v| v.y < 0.0));
/// # Ok::<(), SphError>(())
/// ```
#[derive(Clone, Debug)]
pub struct FluidPipeline {
    /// How frames are divided into substeps (default: adaptive, Courant 0.4).
    pub time_stepping: TimeStepping,
    /// The substeps rapier takes per step (its `integration_parameters.num_solver_iterations`,
    /// default 4): moving bodies are followed along the path rapier's substeps give them
    /// (see `boundary::Coupling::begin_frame`). [`FluidPipeline::step_world`],
    /// [`FluidPipeline::step_with_parameters`] and [`crate::FluidWorld`] keep it in sync with
    /// rapier's; set it yourself only for [`FluidPipeline::step`].
    pub rapier_substeps: usize,
    report: StepReport,
    coupling: Coupling,
    runtimes: Runtimes,
    /// The watched colliders' forces and touches of the last frame (`boundary::forces`).
    records: Records,
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
            runtimes: Runtimes::default(),
            records: Records::default(),
            no_bodies: RigidBodySet::new(),
        }
    }

    /// The coupling's state kept from one frame to the next: the linear velocity each
    /// dynamic body near a fluid was left with (saved in snapshots).
    pub fn coupling_memory(&self) -> &[(RigidBodyHandle, Vector)] {
        self.coupling.left_velocities()
    }

    /// Restores [`FluidPipeline::coupling_memory`] (snapshots).
    pub fn set_coupling_memory(&mut self, memory: Vec<(RigidBodyHandle, Vector)>) {
        self.coupling.set_left_velocities(memory);
    }

    /// Marks `body`'s move of the next step as a teleport: the body is seen at rest during
    /// that frame and the water in and on it goes along with it (or stays behind, see
    /// [`FluidPipeline::set_teleport_carry`]). A `set_position` is found without a mark.
    ///
    /// # Examples
    /// ```
    /// use rapier_sph::prelude::*;
    /// use rapier_sph::rapier3d::prelude::*;
    /// let mut world = FluidWorld::new();
    /// let bucket = world.physics.insert_body(RigidBodyBuilder::kinematic_position_based());
    /// world.physics.bodies[bucket].set_next_kinematic_translation(Vector::new(5.0, 0.0, 0.0));
    /// world.pipeline.mark_teleport(bucket);
    /// world.step()?;
    /// # Ok::<(), rapier_sph::SphError>(())
    /// ```
    pub fn mark_teleport(&mut self, body: RigidBodyHandle) {
        self.coupling.teleports.mark(body);
    }

    /// Whether `body` carries the water in and on it when it jumps (a `set_position`, or a
    /// move marked with [`FluidPipeline::mark_teleport`]); by default it does. Water left
    /// behind that the body lands on is pushed out of it.
    pub fn set_teleport_carry(&mut self, body: RigidBodyHandle, carry: bool) {
        self.coupling.teleports.set_carry(body, carry);
    }

    /// The report of the last step.
    pub fn report(&self) -> &StepReport {
        &self.report
    }

    /// The neighbour lists of `fluid`'s last substep (indices into its current particle
    /// order), if this pipeline stepped it.
    pub fn neighbor_lists(&self, fluid: FluidHandle) -> Option<&NeighborLists> {
        self.runtimes.get(fluid).map(|r| &r.ws.search.lists)
    }

    /// The viscoelastic springs of a Clavet fluid ([`crate::solver::Springs`]), if this
    /// pipeline stepped it with springs on.
    pub fn springs(&self, fluid: FluidHandle) -> Option<&crate::solver::springs::SpringSet> {
        match &self.runtimes.get(fluid)?.solver {
            crate::solver::SolverState::Clavet(c) => Some(&c.springs),
            _ => None,
        }
    }

    #[cfg_attr(not(feature = "snapshot"), allow(dead_code))]
    /// What a snapshot keeps of `fluid`'s solver state (default when never stepped).
    pub(crate) fn solver_memory(&self, fluid: FluidHandle) -> crate::solver::SolverMemory {
        self.runtimes
            .get(fluid)
            .map_or_else(Default::default, |r| r.solver.memory())
    }

    /// Restores what [`FluidPipeline::solver_memory`] kept for `fluid` of `fluids`.
    #[cfg_attr(not(feature = "snapshot"), allow(dead_code))]
    pub(crate) fn restore_solver_memory(
        &mut self,
        fluid: FluidHandle,
        fluids: &FluidSet,
        memory: crate::solver::SolverMemory,
    ) {
        if let Some(rt) = self.runtimes.get_or_sync(fluid, fluids) {
            rt.solver.restore(memory);
        }
    }

    /// Heap bytes held for the fluids it steps: the solvers' states and the step's scratch
    /// (the particle arrays are the fluids': [`crate::Fluid::heap_bytes`]).
    pub fn heap_bytes(&self) -> usize {
        self.runtimes.heap_bytes()
    }

    /// Advances every fluid of `fluids` by `dt` seconds under `gravity`, with contact against
    /// the colliders of `colliders` found through `broad_phase` (rapier's BVH, filled by
    /// rapier's own step: call this right after it). The frame is divided into substeps by
    /// [`FluidPipeline::time_stepping`], whose substeps follow the fastest moving body near a
    /// fluid as they follow its fastest particle. Near moving bodies no particle leaves
    /// faster than the fluid's fastest at the frame's start, plus gravity's share, plus twice
    /// the fastest kinematic body surface near it (a reflection off a moving wall; dynamic
    /// bodies exchange momentum with the water and are left to it); faster particles
    /// are slowed to it and counted in [`StepReport::speed_limited`].
    ///
    /// # Errors
    /// Bad input (a `dt` that is not finite or below [`MIN_TIME_STEP`], gravity not finite or
    /// stronger than [`MAX_GRAVITY`], an invalid
    /// [`TimeStepping`], `rapier_substeps` of 0, an empty broad-phase beside a non-empty
    /// collider set) returns an error and changes nothing.
    pub fn step(
        &mut self,
        gravity: Vector,
        dt: Real,
        fluids: &mut FluidSet,
        bodies: &mut RigidBodySet,
        colliders: &ColliderSet,
        broad_phase: &BroadPhaseBvh,
    ) -> SphResult<&StepReport> {
        let rapier = (bodies, colliders, broad_phase);
        self.step_probed(gravity, dt, fluids, rapier, None)
    }

    /// [`FluidPipeline::step`], calling `probe` (if any) after every substep.
    fn step_probed(
        &mut self,
        gravity: Vector,
        dt: Real,
        fluids: &mut FluidSet,
        (bodies, colliders, broad_phase): RapierSets<'_>,
        probe: Option<SubstepProbe<'_>>,
    ) -> SphResult<&StepReport> {
        self.validate(gravity, dt)?;
        self.runtimes.groups.sync(fluids)?;
        for (_, f) in fluids.iter() {
            f.check_fractions()?;
        }
        let has_colliders = self.check_broad_phase(broad_phase, colliders)?;
        let surroundings = (gravity, broad_phase);
        self.begin_frame(dt, fluids, bodies, colliders, surroundings, has_colliders);
        // The BVH is the broad-phase's own tree; an empty body set keeps it from borrowing
        // `bodies`, which the coupling writes impulses into at the end of the step.
        let query = broad_phase.as_query_pipeline(
            &DefaultQueryDispatcher,
            &self.no_bodies,
            colliders,
            QueryFilter::default(),
        );
        let bvh = query.bvh;
        let mut frame = Frame {
            gravity,
            dt,
            policy: self.time_stepping,
            scene: has_colliders.then_some(Scene {
                bvh,
                colliders,
                bodies,
                watch: &self.records.watch,
            }),
            colliders,
            bodies: &*bodies,
            fluids,
            runtimes: &mut self.runtimes,
            coupling: &mut self.coupling,
            report: StepReport::default(),
            watch: &self.records.watch,
            fell_asleep: Vec::new(),
            // Shortened to the frame's borrows (the probe's own lifetime is the caller's).
            probe: probe.map(|p| p as SubstepProbe<'_>),
        };
        // Called from outside rayon's pool, every parallel stage would hand its work to the
        // pool and wait for a worker to wake up: tens of microseconds per stage, more than a
        // small fluid's whole step. Entering the pool once per step avoids that.
        #[cfg(feature = "parallel")]
        if rayon::current_thread_index().is_none() {
            rayon::scope(|_| frame.run());
        } else {
            frame.run();
        }
        #[cfg(not(feature = "parallel"))]
        frame.run();
        let mut report = frame.report;
        let fell_asleep = frame.fell_asleep;
        let forces = self
            .runtimes
            .all_mut()
            // The groups' runtimes come after the fluids' and never sleep.
            .zip(
                fluids
                    .iter()
                    .map(|(_, f)| f.is_sleeping())
                    .chain(std::iter::repeat(false)),
            )
            .map(|(r, asleep)| (r.handle, &mut r.ws.forces, asleep));
        self.records.finish(dt, forces);
        report.coupled_bodies = self.coupling.apply(bodies);
        for near in &fell_asleep {
            sleep::sleep_bodies(near, &self.coupling, bodies);
        }
        self.report = report;
        Ok(&self.report)
    }

    /// Whether the broad-phase holds colliders; an error if it is empty beside colliders
    /// with a finite pose (rapier has not stepped since they were added). Colliders with a
    /// non-finite pose (a body set to NaN) are not in the BVH, and not in contact either.
    fn check_broad_phase(
        &self,
        broad_phase: &BroadPhaseBvh,
        colliders: &ColliderSet,
    ) -> SphResult<bool> {
        let query = broad_phase.as_query_pipeline(
            &DefaultQueryDispatcher,
            &self.no_bodies,
            colliders,
            QueryFilter::default(),
        );
        let finite =
            |c: &rapier3d::geometry::Collider| crate::math::is_finite(c.position().translation);
        if query.bvh.is_empty() && colliders.iter().any(|(_, c)| finite(c)) {
            return Err(SphError::BroadPhaseNotUpdated {
                colliders: colliders.len(),
            });
        }
        Ok(!query.bvh.is_empty())
    }

    /// The frame's preparations before its substeps: the fluids' runtimes matched by handle,
    /// the bodies that teleported, the watched colliders, the moving bodies' table, the
    /// sleeping fluids woken by what changed around them (`surroundings`: gravity and the
    /// broad-phase).
    fn begin_frame(
        &mut self,
        dt: Real,
        fluids: &mut FluidSet,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        surroundings: (Vector, &BroadPhaseBvh),
        has_colliders: bool,
    ) {
        self.runtimes.sync(fluids);
        let radius = fluids
            .iter()
            .map(|(_, f)| f.params().particle_radius)
            .fold(Real::MAX, Real::min);
        let bodies = if has_colliders {
            bodies
        } else {
            &self.no_bodies
        };
        self.coupling
            .detect_teleports(dt, self.rapier_substeps, 0.5 * radius, bodies, colliders);
        let scene_colliders = has_colliders.then_some((bodies, colliders));
        match scene_colliders {
            Some((bodies, colliders)) => self.records.watch.collect(colliders, bodies),
            None => self.records.watch = Default::default(),
        }
        self.coupling
            .begin_frame(dt, self.rapier_substeps, bodies, colliders);
        let query = surroundings.1.as_query_pipeline(
            &DefaultQueryDispatcher,
            &self.no_bodies,
            colliders,
            QueryFilter::default(),
        );
        let around = sleep::Surroundings {
            gravity: surroundings.0,
            dt,
            bvh: has_colliders.then_some(query.bvh),
            colliders,
            coupling: &self.coupling,
            watch: &self.records.watch,
        };
        for ((_, fluid), rt) in fluids.iter_mut().zip(self.runtimes.iter_mut()) {
            if fluid.is_sleeping() && sleep::disturbed(fluid, rt, &around) {
                fluid.wake_up();
            }
            if !fluid.is_sleeping() {
                // A sleeping fluid keeps the records of the last frame it was stepped in.
                rt.ws.forces.begin_frame(&self.records.watch);
            }
        }
        // The groups' runtimes record the forces of their fluids stepped together.
        for g in &mut self.runtimes.groups.list {
            g.rt.ws.forces.begin_frame(&self.records.watch);
        }
    }

    /// Advances every fluid by one frame of a rapier [`PhysicsWorld`] that has just stepped
    /// (with `step` or `step_with_events`): its gravity, its `integration_parameters.dt` and
    /// its substep count ([`FluidPipeline::rapier_substeps`] follows
    /// `num_solver_iterations`), its bodies, colliders and broad-phase.
    ///
    /// # Errors
    /// As [`FluidPipeline::step_with_parameters`]; nothing changes on error.
    ///
    /// # Examples
    /// ```
    /// use rapier_sph::prelude::*;
    /// use rapier_sph::rapier3d::prelude::{ColliderBuilder, PhysicsWorld, RigidBodyBuilder};
    ///
    /// let mut world = PhysicsWorld::default();
    /// let floor = world.insert_body(RigidBodyBuilder::fixed());
    /// world.insert_collider(ColliderBuilder::cuboid(1.0, 0.1, 1.0), Some(floor));
    /// let mut fluids = FluidSet::new();
    /// let mut water = Fluid::new(FluidParamsBuilder::water(0.05))?;
    /// water.add_block(Vector::new(-0.2, 0.1, -0.2), Vector::new(0.4, 0.2, 0.4))?;
    /// fluids.insert(water);
    /// let mut pipeline = FluidPipeline::new();
    /// world.integration_parameters.num_solver_iterations = 2;
    /// for _frame in 0..3 {
    ///     world.step_with_events(&(), &()); // rapier first, with the game's hooks and events
    ///     pipeline.step_world(&mut world, &mut fluids)?; // then the fluid, in one call
    /// }
    /// assert_eq!(pipeline.rapier_substeps, 2);
    /// # Ok::<(), rapier_sph::SphError>(())
    /// ```
    pub fn step_world(
        &mut self,
        world: &mut PhysicsWorld,
        fluids: &mut FluidSet,
    ) -> SphResult<&StepReport> {
        self.step_with_parameters(
            world.gravity,
            &world.integration_parameters,
            fluids,
            &mut world.bodies,
            &world.colliders,
            &world.broad_phase,
        )
    }

    /// [`FluidPipeline::step`] with the frame's length and rapier's substep count taken from
    /// rapier's own `integration`: `dt` and `num_solver_iterations`
    /// ([`FluidPipeline::rapier_substeps`] is set to it). For a game that keeps rapier's sets
    /// itself; [`FluidPipeline::step_world`] for one that uses rapier's `PhysicsWorld`.
    ///
    /// # Errors
    /// [`SphError::InvalidParameter`] naming `num_solver_iterations` when it is 0; then
    /// [`FluidPipeline::step`]'s errors (`dt` not finite or below [`MIN_TIME_STEP`]:
    /// `InvalidTimeStep`).
    /// Nothing changes on error.
    pub fn step_with_parameters(
        &mut self,
        gravity: Vector,
        integration: &IntegrationParameters,
        fluids: &mut FluidSet,
        bodies: &mut RigidBodySet,
        colliders: &ColliderSet,
        broad_phase: &BroadPhaseBvh,
    ) -> SphResult<&StepReport> {
        let rapier = (bodies, colliders, broad_phase);
        self.step_with_parameters_probed(gravity, integration, fluids, rapier, None)
    }

    /// [`FluidPipeline::step_with_parameters`], calling `probe` (if any) after every substep
    /// with the time into the frame and the fluids: what the validation runner's energy check
    /// samples between frames.
    pub(crate) fn step_with_parameters_probed(
        &mut self,
        gravity: Vector,
        integration: &IntegrationParameters,
        fluids: &mut FluidSet,
        rapier: RapierSets<'_>,
        probe: Option<SubstepProbe<'_>>,
    ) -> SphResult<&StepReport> {
        let substeps = integration.num_solver_iterations;
        if substeps == 0 {
            return Err(SphError::InvalidParameter {
                field: "num_solver_iterations",
                value: 0.0,
                reason: "rapier takes at least one substep per step",
            });
        }
        let before = std::mem::replace(&mut self.rapier_substeps, substeps);
        let dt = integration.dt;
        if let Err(e) = self.validate(gravity, dt) {
            self.rapier_substeps = before;
            return Err(e);
        }
        self.step_probed(gravity, dt, fluids, rapier, probe)
    }

    /// The checks of [`FluidPipeline::step`]'s arguments and of the pipeline's settings.
    fn validate(&self, gravity: Vector, dt: Real) -> SphResult<()> {
        if !dt.is_finite() || dt < MIN_TIME_STEP {
            return Err(SphError::InvalidTimeStep { dt: dt as f64 });
        }
        self.time_stepping.validate()?;
        if self.rapier_substeps == 0 {
            return Err(SphError::InvalidParameter {
                field: "rapier_substeps",
                value: 0.0,
                reason: "rapier takes at least one substep per step",
            });
        }
        if !crate::math::is_finite(gravity) || !(gravity.length() <= MAX_GRAVITY) {
            return Err(SphError::InvalidParameter {
                field: "gravity",
                value: gravity.length() as f64,
                reason: "must be finite and at most MAX_GRAVITY (10^6 m/s^2)",
            });
        }
        Ok(())
    }
}

/// Called after every substep with the time into the frame (s) and the fluids (the validation
/// runner's energy check: `validation::drive`).
pub(crate) type SubstepProbe<'a> = &'a mut (dyn FnMut(Real, &FluidSet) + Send);

/// The rapier sets a step reads (and writes the fluid's impulses to): bodies, colliders and
/// the broad-phase holding them.
pub(crate) type RapierSets<'a> = (&'a mut RigidBodySet, &'a ColliderSet, &'a BroadPhaseBvh);

/// One frame in progress: what every substep shares.
struct Frame<'a> {
    gravity: Vector,
    dt: Real,
    policy: TimeStepping,
    scene: Option<Scene<'a>>,
    colliders: &'a ColliderSet,
    /// Every body (attached emitters follow theirs, with or without colliders near).
    bodies: &'a RigidBodySet,
    fluids: &'a mut FluidSet,
    runtimes: &'a mut Runtimes,
    coupling: &'a mut Coupling,
    report: StepReport,
    /// The watched colliders (the sleep test keeps them in its fingerprint).
    watch: &'a crate::boundary::forces::Watch,
    /// The boxes of the fluids that fell asleep at this frame's end: the dynamic bodies in
    /// them are put to sleep with them once the coupling's impulses are applied.
    fell_asleep: Vec<parry3d::bounding_volume::Aabb>,
    /// Called after every substep ([`SubstepProbe`]).
    probe: Option<SubstepProbe<'a>>,
}

impl Frame<'_> {
    /// Quarantine, the substeps, the emitters.
    fn run(&mut self) {
        self.carry();
        self.quarantine();
        let (mut elapsed, mut weighted_error, mut counted) = (0.0, 0.0f64, 0usize);
        self.report.min_substep = Real::MAX;
        loop {
            let remaining = self.dt - elapsed;
            let fluids = self.fluids.iter().map(|(_, f)| f);
            let (h, last, cap_hit) = time_stepping::next_substep(
                self.policy,
                remaining,
                self.report.substeps,
                fluids.zip(self.runtimes.iter_mut()),
                self.gravity,
            );
            self.report.substep_cap_hit |= cap_hit;
            self.report.substeps += 1;
            self.report.min_substep = self.report.min_substep.min(h);
            self.report.max_substep = self.report.max_substep.max(h);
            let back = (remaining, if last { 0.0 } else { remaining - h });
            self.substep(h, back, (&mut weighted_error, &mut counted));
            elapsed += h;
            if let Some(probe) = self.probe.as_deref_mut() {
                probe(elapsed, self.fluids);
            }
            if last {
                break;
            }
        }
        self.end_relaxations();
        self.emit();
        self.sleep_tests();
        self.report.particles = self.fluids.num_particles();
        if counted > 0 {
            self.report.mean_density_error = (weighted_error / counted as f64) as Real;
        }
    }

    /// Bodies that jumped carry the water in and on them (`boundary::teleport`); the
    /// particles they land on or carry into others are pushed out and relaxed by the first
    /// substep.
    fn carry(&mut self) {
        let teleports = &self.coupling.teleports;
        if teleports.frame().is_empty() {
            return;
        }
        for ((_, fluid), rt) in self.fluids.iter_mut().zip(self.runtimes.iter_mut()) {
            let margin = fluid.params().smoothing_length;
            let (_, particles) = fluid.split_mut();
            let (_, rigid) = teleports.carry(particles.positions, particles.velocities, margin);
            // A rigid carry (`Teleports::carry`) made no overlap: the first substep
            // pushes particles out of the solids they may have landed in and relaxes only if
            // it pushed any out. Relaxing the carried water otherwise moved every particle of
            // a settled bucket of Clavet's water, whose hydrostatic compression exceeds the
            // relaxation's tolerance, and gave it 0.069 J (`tests/kinematic_jumps.rs`).
            rt.relax.rigid_carry = rigid && !fluid.needs_depenetration && !fluid.relax_pending;
            fluid.needs_depenetration = true;
        }
    }

    /// Removes what the caller may have broken since the last frame (a NaN written through
    /// `velocities_mut`), and measures the speeds the first substep starts from.
    fn quarantine(&mut self) {
        for ((_, fluid), rt) in self.fluids.iter_mut().zip(self.runtimes.iter_mut()) {
            rt.ws.frame_error = 0.0;
            if fluid.is_sleeping() {
                self.report.sleeping += 1;
                (rt.ws.max_speed, rt.ws.bodies_near) = (0.0, Default::default());
                continue;
            }
            // The scan (parallel) counts them and skips them in the maximum speed; the serial
            // removal runs only when there is something to remove.
            let (bad, vmax) = self.report.timed(Stage::ParticleUpdate, || {
                crate::integrate::scan(fluid.positions(), fluid.velocities())
            });
            if bad > 0 {
                self.report.quarantined += fluid.quarantine_non_finite();
            }
            rt.ws.max_speed = vmax;
            rt.relax.begin_frame(fluid);
            rt.ws.bodies_near = Default::default();
            rt.ws.frame_speed = vmax + self.gravity.length() * self.dt;
            if self.scene.is_some() && !self.coupling.is_off() && !fluid.is_empty() {
                // Bodies that can reach the fluid during the frame.
                let (lo, hi) = crate::integrate::bounds(fluid.positions());
                let p = fluid.params();
                let reach = p.smoothing_length
                    + p.particle_radius
                    + (vmax + self.gravity.length() * self.dt) * self.dt;
                let fluid_box = parry3d::bounding_volume::Aabb::new(lo, hi);
                rt.ws.bodies_near = self
                    .coupling
                    .surface_speeds_near(&fluid_box, reach, self.dt);
            }
            if let Some(capacity) = fluid.capacity() {
                rt.ws.reserve(capacity);
            }
        }
        self.runtimes.begin_group_frames();
    }

    /// One substep of every fluid, then their sinks; adds the density error summed over the
    /// particles and their count to `error`.
    fn substep(&mut self, dt: Real, back: (Real, Real), error: (&mut f64, &mut usize)) {
        let input = SubstepInput {
            gravity: self.gravity,
            dt,
            scene: self.scene,
            back,
        };
        let pairs = self.fluids.iter_mut().zip(self.runtimes.with_groups_mut());
        for ((_, fluid), (rt, grouped)) in pairs {
            if grouped || fluid.is_sleeping() {
                continue; // stepped with its group below, or asleep
            }
            let n = fluid.len();
            let result = substep::substep(fluid, rt, &input, self.coupling, &mut self.report);
            rt.ws.frame_error = rt.ws.frame_error.max(result.mean_error);
            *error.0 += result.mean_error as f64 * n as f64;
            *error.1 += n;
            if result.non_finite > 0 {
                self.report.quarantined += fluid.quarantine_non_finite();
            }
            self.report.drained += fluid.drain_sinks(self.colliders);
        }
        if !self.runtimes.groups.list.is_empty() {
            self.substep_groups(&input, error);
        }
    }

    /// One substep of each group of interacting fluids (`interaction`), then its fluids'
    /// sinks.
    fn substep_groups(&mut self, input: &SubstepInput<'_>, error: (&mut f64, &mut usize)) {
        let mut fluids: Vec<&mut crate::Fluid> = self.fluids.iter_mut().map(|(_, f)| f).collect();
        for g in 0..self.runtimes.groups.list.len() {
            let group = &mut self.runtimes.groups.list[g];
            let result = group.substep(&mut fluids, input, self.coupling, &mut self.report);
            for &k in group.members() {
                let fluid = &mut *fluids[k];
                *error.0 += result.mean_error as f64 * fluid.len() as f64;
                *error.1 += fluid.len();
                if result.non_finite > 0 {
                    self.report.quarantined += fluid.quarantine_non_finite();
                }
                self.report.drained += fluid.drain_sinks(self.colliders);
            }
            self.runtimes.spread_group_speed(g);
        }
    }

    /// What the frame's overlap relaxations left unfinished (see `relax::RelaxBudget`).
    fn end_relaxations(&mut self) {
        for ((_, fluid), rt) in self.fluids.iter_mut().zip(self.runtimes.iter_mut()) {
            if fluid.is_sleeping() {
                continue;
            }
            if let Some(left) = rt.relax.end_frame(fluid.relax_pending) {
                let r = &mut self.report;
                r.relax_compression = r.relax_compression.max(left.compression);
                r.relax_stalled |= left.stalled;
            }
        }
        for left in self.runtimes.end_group_relaxations() {
            let r = &mut self.report;
            r.relax_compression = r.relax_compression.max(left.compression);
            r.relax_stalled |= left.stalled;
        }
    }

    /// Emitters: the particles due during the frame, where they are at its end (into sleeping
    /// fluids too, which wakes them); notes per fluid whether particles came or went.
    fn emit(&mut self) {
        let world = crate::emitter::EmitWorld {
            bvh: self.scene.map(|s| s.bvh),
            colliders: self.colliders,
            bodies: self.bodies,
        };
        for ((_, fluid), rt) in self.fluids.iter_mut().zip(self.runtimes.iter_mut()) {
            let before = (fluid.emitted(), fluid.drained());
            let e = fluid.run_emitters(self.dt, world);
            self.report.emitted += e.emitted;
            self.report.emitter_blocked += e.blocked;
            self.report.capacity_reached |= e.capacity_reached;
            rt.ws.frame_changed = (fluid.emitted(), fluid.drained()) != before || e.blocked > 0;
        }
    }

    /// The sleep test of every awake fluid that may sleep (see [`crate::sleep`]).
    fn sleep_tests(&mut self) {
        let around = sleep::Surroundings {
            gravity: self.gravity,
            dt: self.dt,
            bvh: self.scene.map(|s| s.bvh),
            colliders: self.colliders,
            coupling: self.coupling,
            watch: self.watch,
        };
        let pairs = self.fluids.iter_mut().zip(self.runtimes.with_groups_mut());
        for ((_, fluid), (rt, grouped)) in pairs {
            // A fluid stepped with its group stays awake: the group sleeps as one or not at all.
            if grouped || fluid.is_sleeping() || fluid.params().sleep.is_none() {
                continue;
            }
            if let Some(near) = sleep::test(fluid, rt, &around, rt.ws.frame_changed) {
                self.fell_asleep.push(near);
            }
        }
    }
}
