//! What a game's collision tests check, in one place: no particle inside a solid, none
//! outside the container that should hold them (both with the offending particle ids), a
//! closed triangle mesh that parry would treat as a solid ([`check_container`]), and the
//! state hash that proves two runs bitwise equal ([`crate::Fluid::state_hash`]).
//!
//! # Examples
//!
//! ```
//! use rapier_sph::prelude::*;
//! use rapier_sph::check;
//! use rapier_sph::rapier3d::parry::shape::Cuboid;
//! use rapier_sph::rapier3d::prelude::{ColliderBuilder, RigidBodyBuilder};
//!
//! let mut world = FluidWorld::new();
//! let floor = world.physics.insert_body(RigidBodyBuilder::fixed());
//! world.physics.insert_collider(ColliderBuilder::cuboid(1.0, 0.1, 1.0), Some(floor));
//! let mut water = Fluid::new(FluidParamsBuilder::water(0.05))?;
//! water.add_block(Vector::new(-0.2, 0.1, -0.2), Vector::new(0.4, 0.2, 0.4))?;
//! let water = world.fluids.insert(water);
//! for _ in 0..10 {
//!     world.step()?;
//! }
//! let fluid = &world.fluids[water];
//! // Nothing went into the floor...
//! check::no_particle_in_solids(fluid, &world.physics.colliders)?;
//! // ...and everything stayed above it, within a 2 m box.
//! let room = Cuboid::new(Vector::new(1.0, 1.0, 1.0));
//! check::all_inside(fluid, &room, &Pose::from_translation(Vector::new(0.0, 1.1, 0.0)))?;
//! // Two runs agree bit for bit when their hashes do.
//! let hash = fluid.state_hash();
//! # let _ = hash;
//! # Ok::<(), SphError>(())
//! ```

use crate::error::{SphError, SphResult};
use crate::fluid::Fluid;
use crate::math::Pose;
use parry3d::shape::Shape;
use rapier3d::geometry::{ColliderHandle, ColliderSet};

pub use crate::query::check_container;

/// Every particle of `fluid` inside a solid collider it meets (enabled, not a sensor, its
/// collision groups passing the fluid's), by parry's `contains_point`, as `(particle id,
/// collider)` sorted by id then collider. A triangle mesh is a volume only when built with
/// `TriMeshFlags::ORIENTED`, a heightfield never is: particles under a terrain or inside a
/// closed surface mesh are not found here. Costs one bounding-box test per particle and
/// collider, and a point query for those inside the box.
pub fn particles_in_solids(fluid: &Fluid, colliders: &ColliderSet) -> Vec<(u32, ColliderHandle)> {
    let groups = fluid.params().collision_groups;
    let mut found = Vec::new();
    for (h, co) in colliders.iter() {
        if !co.is_enabled() || co.is_sensor() || !groups.test(co.collision_groups()) {
            continue;
        }
        let aabb = co.compute_aabb();
        let (shape, pose) = (co.shape(), co.position());
        for (x, &id) in fluid.positions().iter().zip(fluid.ids()) {
            if aabb.contains_local_point(*x) && shape.contains_point(pose, *x) {
                found.push((id, h));
            }
        }
    }
    found.sort_unstable_by_key(|&(id, h)| (id, h.into_raw_parts()));
    found
}

/// The ids (sorted) of every particle of `fluid` that is not inside `shape` at `pose` (parry's
/// `contains_point`; a non-finite particle is outside): the water that left its tank. Give the
/// container's cavity (a cuboid of the tank's inside), not its walls.
pub fn particles_outside(fluid: &Fluid, shape: &dyn Shape, pose: &Pose) -> Vec<u32> {
    let mut ids: Vec<u32> = fluid
        .positions()
        .iter()
        .zip(fluid.ids())
        .filter(|(x, _)| !(x.is_finite() && shape.contains_point(pose, **x)))
        .map(|(_, &id)| id)
        .collect();
    ids.sort_unstable();
    ids
}

/// Checks that no particle is inside a solid ([`particles_in_solids`]).
///
/// # Errors
/// [`SphError::ParticlesInSolid`] with the offending ids and colliders.
pub fn no_particle_in_solids(fluid: &Fluid, colliders: &ColliderSet) -> SphResult<()> {
    let found = particles_in_solids(fluid, colliders);
    if found.is_empty() {
        return Ok(());
    }
    Err(SphError::ParticlesInSolid { particles: found })
}

/// Checks that every particle is inside the container `shape` at `pose`
/// ([`particles_outside`]).
///
/// # Errors
/// [`SphError::InvalidParameter`] naming `pose` when it is not finite;
/// [`SphError::ParticlesOutside`] with the offending ids.
pub fn all_inside(fluid: &Fluid, shape: &dyn Shape, pose: &Pose) -> SphResult<()> {
    if !pose.is_finite() {
        return Err(SphError::InvalidParameter {
            field: "pose",
            value: pose.translation.length() as f64,
            reason: "must be finite",
        });
    }
    let ids = particles_outside(fluid, shape, pose);
    if ids.is_empty() {
        return Ok(());
    }
    Err(SphError::ParticlesOutside { ids })
}
