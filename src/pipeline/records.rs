//! Reading what the last frame did to the watched colliders (`boundary::forces`).

use super::FluidPipeline;
use crate::boundary::forces::{ColliderForce, FluidContactEvent};
use crate::error::{SphError, SphResult};
use crate::fluid::FluidHandle;
use rapier3d::dynamics::RigidBodyHandle;
use rapier3d::geometry::ColliderHandle;

const NOT_FORCE_WATCHED: &str = "no collider with ActiveEvents::CONTACT_FORCE_EVENTS had this \
     handle at the last step (it does not exist, was removed, or lacks the flag)";
const NOT_EVENT_WATCHED: &str = "no collider with ActiveEvents::COLLISION_EVENTS had this \
     handle at the last step (it does not exist, was removed, or lacks the flag)";

impl FluidPipeline {
    /// The force and torque every fluid applied to `collider` over the last frame (wall
    /// pressure, viscosity and contact together; N and N·m, the frame's impulse over its
    /// length), for a collider whose `ActiveEvents::CONTACT_FORCE_EVENTS` flag is set. Fixed,
    /// kinematic and dynamic colliders alike; zero when no fluid came near it. Colliders
    /// without the flag cost nothing (see [`crate::boundary_forces`] for what is summed, and
    /// for which solvers).
    ///
    /// # Errors
    /// [`SphError::UnknownHandle`] (argument `"collider"`) when no collider with the flag had
    /// this handle at the last step.
    ///
    /// # Examples
    /// ```
    /// use rapier_sph::prelude::*;
    /// use rapier_sph::rapier3d::prelude::{ActiveEvents, ColliderBuilder, RigidBodyBuilder};
    ///
    /// let mut world = FluidWorld::new();
    /// let ground = world.physics.insert_body(RigidBodyBuilder::fixed());
    /// let floor = world.physics.insert_collider(
    ///     ColliderBuilder::cuboid(1.0, 0.1, 1.0).active_events(ActiveEvents::CONTACT_FORCE_EVENTS),
    ///     Some(ground),
    /// );
    /// let mut water = Fluid::new(FluidParamsBuilder::water(0.05).build()?)?;
    /// water.add_block(Vector::new(-0.2, 0.1, -0.2), Vector::new(0.4, 0.3, 0.4))?;
    /// world.fluids.insert(water);
    /// for _ in 0..3 {
    ///     world.step()?;
    /// }
    /// let f = world.pipeline.collider_force(floor)?;
    /// assert!(f.force.y < 0.0); // the water presses the floor down
    /// # Ok::<(), rapier_sph::SphError>(())
    /// ```
    pub fn collider_force(&self, collider: ColliderHandle) -> SphResult<ColliderForce> {
        self.records
            .forces
            .iter()
            .find(|f| f.collider == collider)
            .copied()
            .ok_or(SphError::UnknownHandle {
                argument: "collider",
                reason: NOT_FORCE_WATCHED,
            })
    }

    /// The forces of every collider whose `CONTACT_FORCE_EVENTS` flag is set, as
    /// [`FluidPipeline::collider_force`], sorted by handle.
    pub fn collider_forces(&self) -> &[ColliderForce] {
        &self.records.forces
    }

    /// The sum over `body`'s colliders whose `CONTACT_FORCE_EVENTS` flag is set of
    /// [`FluidPipeline::collider_force`] (torques about the body's center of mass).
    ///
    /// # Errors
    /// [`SphError::UnknownHandle`] (argument `"body"`) when none of the body's colliders had
    /// the flag at the last step.
    ///
    /// # Examples
    /// ```
    /// use rapier_sph::prelude::*;
    /// use rapier_sph::rapier3d::prelude::{ActiveEvents, ColliderBuilder, RigidBodyBuilder};
    ///
    /// let mut world = FluidWorld::new();
    /// let ground = world.physics.insert_body(RigidBodyBuilder::fixed());
    /// world.physics.insert_collider(ColliderBuilder::cuboid(1.0, 0.1, 1.0), Some(ground));
    /// // A crate dropped onto a puddle: what the water does to it, per frame.
    /// let crate_body = world.physics.insert_body(
    ///     RigidBodyBuilder::dynamic().translation(Vector::new(0.0, 0.3, 0.0)),
    /// );
    /// world.physics.insert_collider(
    ///     ColliderBuilder::cuboid(0.1, 0.1, 0.1).active_events(ActiveEvents::CONTACT_FORCE_EVENTS),
    ///     Some(crate_body),
    /// );
    /// let mut water = Fluid::new(FluidParamsBuilder::water(0.05).build()?)?;
    /// water.add_block(Vector::new(-0.3, 0.1, -0.3), Vector::new(0.6, 0.1, 0.6))?;
    /// world.fluids.insert(water);
    /// for _ in 0..10 {
    ///     world.step()?;
    ///     let f = world.pipeline.body_force(crate_body)?;
    ///     assert!(f.force.is_finite() && f.torque.is_finite());
    /// }
    /// # Ok::<(), rapier_sph::SphError>(())
    /// ```
    pub fn body_force(&self, body: RigidBodyHandle) -> SphResult<ColliderForce> {
        let mut sum: Option<ColliderForce> = None;
        for f in self.records.forces.iter().filter(|f| f.body == Some(body)) {
            match &mut sum {
                Some(s) => {
                    s.force += f.force;
                    s.torque += f.torque;
                    s.touching += f.touching;
                }
                None => sum = Some(*f),
            }
        }
        sum.ok_or(SphError::UnknownHandle {
            argument: "body",
            reason: "none of its colliders had ActiveEvents::CONTACT_FORCE_EVENTS at the last step",
        })
    }

    /// The last frame's events: a fluid started or stopped touching a collider whose
    /// `ActiveEvents::COLLISION_EVENTS` flag is set (a particle within
    /// [`crate::boundary_forces::touch_distance`] of its surface at the end of a substep).
    /// Started events come first, each list in the set's fluid order, then by collider
    /// handle.
    ///
    /// # Examples
    /// ```
    /// use rapier_sph::prelude::*;
    /// use rapier_sph::rapier3d::prelude::{ActiveEvents, ColliderBuilder, RigidBodyBuilder};
    ///
    /// let mut world = FluidWorld::new();
    /// let ground = world.physics.insert_body(RigidBodyBuilder::fixed());
    /// let floor = world.physics.insert_collider(
    ///     ColliderBuilder::cuboid(1.0, 0.1, 1.0).active_events(ActiveEvents::COLLISION_EVENTS),
    ///     Some(ground),
    /// );
    /// let mut water = Fluid::new(FluidParamsBuilder::water(0.05).build()?)?;
    /// water.add_block(Vector::new(-0.1, 0.3, -0.1), Vector::new(0.2, 0.1, 0.2))?; // falls
    /// let water = world.fluids.insert(water);
    /// let mut started = None;
    /// for frame in 0..30 {
    ///     world.step()?;
    ///     if let Some(e) = world.pipeline.contact_events().first() {
    ///         assert_eq!((e.fluid, e.collider, e.kind), (water, floor, FluidContactKind::Started));
    ///         started.get_or_insert(frame);
    ///     }
    /// }
    /// assert!(started.is_some());
    /// assert!(!world.pipeline.touching(water, floor)?.is_empty()); // the ids resting on it
    /// # Ok::<(), rapier_sph::SphError>(())
    /// ```
    pub fn contact_events(&self) -> &[FluidContactEvent] {
        &self.records.events
    }

    /// The ids of `fluid`'s particles that touched `collider` during the last frame (sorted;
    /// empty when none), for a collider whose `COLLISION_EVENTS` flag is set. Particles a sink
    /// drained after touching it in the frame are counted.
    ///
    /// # Errors
    /// [`SphError::UnknownHandle`] (argument `"collider"`) when no collider with the flag had
    /// this handle at the last step; [`SphError::UnknownFluid`] for a fluid the last step did
    /// not step.
    pub fn touching(&self, fluid: FluidHandle, collider: ColliderHandle) -> SphResult<&[u32]> {
        let watched = self
            .records
            .watch
            .slot(collider)
            .is_some_and(|k| self.records.watch.list[k].events);
        if !watched {
            return Err(SphError::UnknownHandle {
                argument: "collider",
                reason: NOT_EVENT_WATCHED,
            });
        }
        if self.runtimes.get(fluid).is_none() {
            return Err(SphError::UnknownFluid);
        }
        Ok(self
            .records
            .touching
            .iter()
            .find(|t| t.0 == fluid && t.1 == collider)
            .map_or(&[][..], |t| &t.2[..]))
    }
}
