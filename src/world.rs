//! [`FluidWorld`]: a rapier world and its fluids in one value, for the simple case.

use crate::diagnostics::StepReport;
use crate::error::SphResult;
use crate::fluid::FluidSet;
use crate::pipeline::FluidPipeline;
use rapier3d::pipeline::{EventHandler, PhysicsHooks, PhysicsWorld};

/// A rapier [`PhysicsWorld`] plus fluids, stepped together: rapier first, then the fluids,
/// with the world's gravity and time step (`physics.integration_parameters.dt`).
///
/// Every field is public, so you can reach into rapier as usual.
///
/// # Examples
///
/// ```
/// use rapier_sph::prelude::*;
/// use rapier_sph::rapier3d::prelude::{ColliderBuilder, RigidBodyBuilder};
///
/// let mut world = FluidWorld::new();
/// let floor = world.physics.insert_body(RigidBodyBuilder::fixed());
/// world.physics.insert_collider(ColliderBuilder::cuboid(1.0, 0.1, 1.0), Some(floor));
/// let mut water = Fluid::new(FluidParamsBuilder::water(0.05).build()?)?;
/// water.add_block(Vector::new(-0.2, 0.1, -0.2), Vector::new(0.4, 0.2, 0.4))?;
/// let water = world.fluids.insert(water);
/// for _ in 0..5 {
///     let report = world.step()?; // rapier, then the fluid's substeps
///     assert_eq!(report.non_finite, 0);
/// }
/// assert!(world.fluids[water].positions().iter().all(|p| p.y > 0.0));
/// # Ok::<(), rapier_sph::SphError>(())
/// ```
#[derive(Default)]
pub struct FluidWorld {
    /// The rapier world (bodies, colliders, broad-phase, ...).
    pub physics: PhysicsWorld,
    /// The fluids.
    pub fluids: FluidSet,
    /// The fluid pipeline (holds the last step report).
    pub pipeline: FluidPipeline,
}

impl FluidWorld {
    /// An empty world with rapier's defaults (gravity −9.81 m/s² along y, dt = 1/60 s).
    pub fn new() -> Self {
        Self::default()
    }

    /// Steps rapier, then the fluids, by `physics.integration_parameters.dt`.
    ///
    /// # Errors
    ///
    /// As [`FluidPipeline::step`]: [`crate::SphError::InvalidTimeStep`] for a time step that
    /// is not finite or below [`crate::pipeline::MIN_TIME_STEP`], [`crate::SphError::InvalidParameter`] for a non-finite
    /// gravity, [`crate::SphError::InvalidParameter`] naming `num_solver_iterations` when
    /// it is 0; the fluids are left unchanged (rapier has stepped).
    pub fn step(&mut self) -> SphResult<&StepReport> {
        self.physics.step();
        self.step_fluids()
    }

    /// [`FluidWorld::step`] with rapier's physics hooks and event handler
    /// (`PhysicsWorld::step_with_events`): collision events, contact forces and contact
    /// filtering for the game, then the fluids.
    ///
    /// # Errors
    ///
    /// As [`FluidWorld::step`].
    ///
    /// # Examples
    ///
    /// ```
    /// use rapier_sph::prelude::*;
    /// use rapier_sph::rapier3d::prelude::{ChannelEventCollector, ColliderBuilder, RigidBodyBuilder};
    ///
    /// let mut world = FluidWorld::new();
    /// let floor = world.physics.insert_body(RigidBodyBuilder::fixed());
    /// world.physics.insert_collider(ColliderBuilder::cuboid(1.0, 0.1, 1.0), Some(floor));
    /// let mut water = Fluid::new(FluidParamsBuilder::water(0.05))?;
    /// water.add_block(Vector::new(-0.2, 0.1, -0.2), Vector::new(0.4, 0.2, 0.4))?;
    /// world.fluids.insert(water);
    /// let (collisions, _collision_events) = std::sync::mpsc::channel();
    /// let (forces, _force_events) = std::sync::mpsc::channel();
    /// let (tears, _tear_events) = std::sync::mpsc::channel();
    /// let events = ChannelEventCollector::new(collisions, forces, tears);
    /// world.step_with_events(&(), &events)?;
    /// # Ok::<(), rapier_sph::SphError>(())
    /// ```
    pub fn step_with_events(
        &mut self,
        hooks: &dyn PhysicsHooks,
        events: &dyn EventHandler,
    ) -> SphResult<&StepReport> {
        self.physics.step_with_events(hooks, events);
        self.step_fluids()
    }

    /// Steps only the fluids, with the world's gravity and time step, against the rapier
    /// world as it is (for a world stepped elsewhere, or static geometry after rapier has
    /// stepped once).
    ///
    /// # Errors
    ///
    /// As [`FluidPipeline::step`].
    pub fn step_fluids(&mut self) -> SphResult<&StepReport> {
        self.pipeline
            .step_world(&mut self.physics, &mut self.fluids)
    }
}
