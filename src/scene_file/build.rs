//! A checked scene made into a world: bodies and their colliders first (the names fluids
//! refer to), then fluids with their blocks, fills, emitters and sinks; the camera.

use super::{
    BodyDesc, BodyKind, CameraDesc, ColliderDesc, FillDesc, Finite, FluidDesc, SceneError,
    SceneFile, default_azimuth, default_elevation, invalid,
};
use crate::fluid::{Fluid, FluidHandle};
use crate::math::{Real, Rotation, Vector};
use crate::world::FluidWorld;
use rapier3d::prelude::{ColliderBuilder, ColliderHandle, RigidBodyBuilder, RigidBodyHandle};
use std::path::Path;

impl SceneFile {
    /// Builds the world. Relative mesh paths are resolved against `base_dir` (the scene
    /// file's folder); `path` names the scene in errors.
    ///
    /// # Errors
    /// [`SceneError::Invalid`] naming the field: a collider name no collider has, a mesh file
    /// that cannot be read, a fill or a fluid the crate refuses (too many particles for
    /// memory, an unbounded shape).
    pub fn build(&self, path: &Path, base_dir: &Path) -> Result<BuiltScene, SceneError> {
        self.check_names().map_err(|(f, m)| invalid(path, f, m))?;
        let mut world = FluidWorld::new();
        world.physics.gravity = self.gravity.vector();
        let (dt, steps_per_frame) = self.time_step();
        world.physics.integration_parameters.dt = dt;
        let mut builder = WorldBuilder {
            path,
            base_dir,
            world,
            named_colliders: Vec::new(),
        };
        let mut bodies = Vec::new();
        for (bi, b) in self.bodies.iter().enumerate() {
            bodies.push(builder.add_body(bi, b)?);
        }
        let mut fluids = Vec::new();
        for (fi, f) in self.fluids.iter().enumerate() {
            fluids.push(builder.add_fluid(fi, f)?);
        }
        Ok(BuiltScene {
            world: builder.world,
            fluids,
            bodies,
            named_colliders: builder.named_colliders,
            dt,
            steps_per_frame,
            frames: self.frames(),
            camera: self.camera.clone().unwrap_or(CameraDesc::Auto {
                azimuth: default_azimuth(),
                elevation: default_elevation(),
                degrees_per_second: Finite(0.0),
            }),
        })
    }
}

/// The world as [`SceneFile::build`] fills it: bodies first (with their colliders, whose
/// names the fluids' sinks refer to), then fluids. Holds what every part needs: the file's
/// path (for errors), the folder mesh paths are relative to, and the names given so far.
struct WorldBuilder<'a> {
    path: &'a Path,
    base_dir: &'a Path,
    world: FluidWorld,
    named_colliders: Vec<(String, ColliderHandle)>,
}

impl WorldBuilder<'_> {
    /// [`invalid`] for this scene file.
    fn invalid(&self, field: String, message: String) -> SceneError {
        invalid(self.path, field, message)
    }

    /// Inserts body `bi` and its colliders; returns its handle.
    fn add_body(&mut self, bi: usize, b: &BodyDesc) -> Result<RigidBodyHandle, SceneError> {
        let builder = match b.kind {
            BodyKind::Fixed => RigidBodyBuilder::fixed(),
            BodyKind::Dynamic => RigidBodyBuilder::dynamic(),
            BodyKind::KinematicPositionBased => RigidBodyBuilder::kinematic_position_based(),
            BodyKind::KinematicVelocityBased => RigidBodyBuilder::kinematic_velocity_based(),
        }
        .translation(b.position.vector())
        .rotation(b.rotation.vector())
        .linvel(b.linvel.vector())
        .angvel(b.angvel.vector());
        let handle = self.world.physics.insert_body(builder);
        for (ci, c) in b.colliders.iter().enumerate() {
            self.add_collider(handle, format!("bodies[{bi}].colliders[{ci}].shape"), c)?;
        }
        Ok(handle)
    }

    /// Inserts collider `c` on `body` (its shape's errors name `field`) and records its name.
    fn add_collider(
        &mut self,
        body: RigidBodyHandle,
        field: String,
        c: &ColliderDesc,
    ) -> Result<(), SceneError> {
        let shape = c
            .shape
            .build(self.base_dir)
            .map_err(|m| self.invalid(field, m))?;
        let mut cb = ColliderBuilder::new(shape)
            .position(crate::math::Pose::from_parts(
                c.position.vector(),
                Rotation::from_scaled_axis(c.rotation.vector()),
            ))
            .sensor(c.sensor);
        if let Some(d) = c.density {
            cb = cb.density(d.0);
        }
        if let Some(f) = c.friction {
            cb = cb.friction(f.0);
        }
        if let Some(r) = c.restitution {
            cb = cb.restitution(r.0);
        }
        let ch = self.world.physics.insert_collider(cb, Some(body));
        if let Some(n) = &c.name {
            self.named_colliders.push((n.0.clone(), ch));
        }
        Ok(())
    }

    /// Builds fluid `fi` (its blocks, particles, emitters, sinks and capacity) and inserts it;
    /// returns its handle. Sinks may name any collider of the file (bodies come first).
    fn add_fluid(&mut self, fi: usize, f: &FluidDesc) -> Result<FluidHandle, SceneError> {
        let field = |name: &str| format!("fluids[{fi}]{name}");
        let params = f
            .params()
            .map_err(|e| self.invalid(field(""), e.to_string()))?;
        let mut fluid = Fluid::new(params).map_err(|e| self.invalid(field(""), e.to_string()))?;
        for (k, b) in f.blocks.iter().enumerate() {
            fluid
                .add_block(b.min.vector(), b.size.vector())
                .map_err(|e| self.invalid(field(&format!(".blocks[{k}]")), e.to_string()))?;
        }
        let points: Vec<Vector> = f.particles.iter().map(|p| p.vector()).collect();
        fluid
            .add_particles(&points)
            .map_err(|e| self.invalid(field(".particles"), e.to_string()))?;
        for (k, fill) in f.fill.iter().enumerate() {
            self.add_fill(&mut fluid, fill)
                .map_err(|m| self.invalid(field(&format!(".fill[{k}]")), m))?;
        }
        if let Some(fractions) = f.mixture.as_ref().and_then(|m| m.fractions.as_ref()) {
            fluid
                .set_fractions(fractions)
                .map_err(|e| self.invalid(field(".mixture.fractions"), e.to_string()))?;
        }
        self.add_sources(fi, f, &mut fluid)?;
        if f.capacity.is_some() {
            fluid
                .set_capacity(f.capacity)
                .map_err(|e| self.invalid(field(".capacity"), e.to_string()))?;
        }
        Ok(self.world.fluids.insert(fluid))
    }

    /// The collider named `name`, among those inserted so far.
    fn collider(&self, name: &str) -> Option<ColliderHandle> {
        self.named_colliders
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, h)| *h)
    }

    /// Fills `fluid` with the particles of `fill`; the error is the message.
    fn add_fill(&self, fluid: &mut Fluid, fill: &FillDesc) -> Result<(), String> {
        match fill {
            FillDesc::Collider { name } => {
                let handle = self
                    .collider(&name.0)
                    .ok_or_else(|| format!("no collider is named `{}`", name.0))?;
                fluid.fill_collider(handle, &self.world.physics.colliders)
            }
            FillDesc::Shape {
                shape,
                position,
                rotation,
            } => {
                let shape = shape.build(self.base_dir)?;
                let pose = crate::math::Pose::from_parts(
                    position.vector(),
                    Rotation::from_scaled_axis(rotation.vector()),
                );
                fluid.fill_shape(&*shape, &pose)
            }
        }
        .map(|_| ())
        .map_err(|e| e.to_string())
    }

    /// Adds fluid `fi`'s emitters (at the fluid's spacing, attached to their carriers) and
    /// sinks (their collider names resolved against the colliders inserted so far) to `fluid`.
    fn add_sources(&self, fi: usize, f: &FluidDesc, fluid: &mut Fluid) -> Result<(), SceneError> {
        let spacing = fluid.params().particle_spacing;
        let physics = &self.world.physics;
        for (k, e) in f.emitters.iter().enumerate() {
            let field = format!("fluids[{fi}].emitters[{k}]");
            let emitter = e
                .emitter(spacing)
                .map_err(|m| self.invalid(field.clone(), m))?;
            let handle = fluid
                .add_emitter(emitter)
                .map_err(|e| self.invalid(field.clone(), e.to_string()))?;
            if let Some(a) = &e.attached_to {
                let field = format!("{field}.attached_to");
                let to = a
                    .attachment(|n| self.collider(n), &physics.colliders)
                    .map_err(|m| self.invalid(field.clone(), m))?;
                fluid
                    .attach_emitter(handle, to, &physics.bodies, &physics.colliders)
                    .map_err(|e| self.invalid(field, e.to_string()))?;
            }
        }
        for (k, s) in f.sinks.iter().enumerate() {
            let field = format!("fluids[{fi}].sinks[{k}]");
            let sink = s
                .sink(|name| self.collider(name))
                .map_err(|m| self.invalid(field.clone(), m))?;
            fluid
                .add_sink(sink)
                .map_err(|e| self.invalid(field, e.to_string()))?;
        }
        Ok(())
    }
}

/// A scene ready to run.
pub struct BuiltScene {
    /// The world: rapier bodies and colliders, the fluids; gravity and dt set.
    pub world: FluidWorld,
    /// Handles of the fluids, in file order.
    pub fluids: Vec<FluidHandle>,
    /// Handles of the bodies, in file order.
    pub bodies: Vec<RigidBodyHandle>,
    /// The colliders that have a name, with their handles, in file order.
    pub named_colliders: Vec<(String, ColliderHandle)>,
    /// The time step (s).
    pub dt: Real,
    /// Steps per frame.
    pub steps_per_frame: usize,
    /// Frames in the scene's duration.
    pub frames: usize,
    /// The camera.
    pub camera: CameraDesc,
}

impl BuiltScene {
    /// The box around the scene's colliders at their current poses (sensors and half-spaces
    /// left out), open against gravity: along each axis gravity points down, the box has no
    /// top. `None` when the scene has no such collider.
    pub fn collider_bounds(&self) -> Option<(Vector, Vector)> {
        let mut lo = Vector::splat(Real::INFINITY);
        let mut hi = Vector::splat(Real::NEG_INFINITY);
        for (_, c) in self.world.physics.colliders.iter() {
            if c.is_sensor() || c.shape().as_halfspace().is_some() {
                continue;
            }
            let aabb = c.compute_aabb();
            lo = lo.min(aabb.mins);
            hi = hi.max(aabb.maxs);
        }
        if !(lo.is_finite() && hi.is_finite()) {
            return None;
        }
        let g = self.world.physics.gravity;
        for k in 0..3 {
            if g[k] < 0.0 {
                hi[k] = Real::INFINITY;
            } else if g[k] > 0.0 {
                lo[k] = Real::NEG_INFINITY;
            }
        }
        Some((lo, hi))
    }

    /// Particles that left the scene's geometry: outside [`Self::collider_bounds`] by more
    /// than the largest particle spacing (over the rim of an open box, off the edge of a
    /// floor: such particles fall for ever). 0 when the scene has no bounded collider.
    pub fn particles_outside_colliders(&self) -> usize {
        let Some((lo, hi)) = self.collider_bounds() else {
            return 0;
        };
        let margin = self
            .world
            .fluids
            .iter()
            .map(|(_, f)| f.params().particle_spacing)
            .fold(0.0, Real::max);
        let (lo, hi) = (lo - Vector::splat(margin), hi + Vector::splat(margin));
        self.world
            .fluids
            .iter()
            .flat_map(|(_, f)| f.positions())
            .filter(|p| !(p.cmpge(lo).all() && p.cmple(hi).all()))
            .count()
    }
}

impl CameraDesc {
    /// Degrees the camera turns per simulated second.
    pub fn degrees_per_second(&self) -> Real {
        match self {
            CameraDesc::Auto {
                degrees_per_second, ..
            }
            | CameraDesc::Orbit {
                degrees_per_second, ..
            } => degrees_per_second.0,
            CameraDesc::LookAt { .. } => 0.0,
        }
    }
}

#[cfg(feature = "render")]
#[cfg_attr(docsrs, doc(cfg(feature = "render")))]
impl CameraDesc {
    /// The render camera at simulated time `t` (s); `world` is used by [`CameraDesc::Auto`]
    /// to frame the scene (call it once on the initial world and turn the result with
    /// [`crate::render::Camera::rotated`] so the framing does not follow splashes).
    pub fn camera_at(&self, world: &FluidWorld, t: Real) -> crate::render::Camera {
        use crate::render::Camera;
        match self {
            CameraDesc::Auto {
                azimuth,
                elevation,
                degrees_per_second,
            } => {
                let (lo, hi) = scene_bounds(world);
                Camera::framing(lo, hi, azimuth.0, elevation.0).rotated(degrees_per_second.0 * t)
            }
            CameraDesc::LookAt {
                eye,
                target,
                fov_y_degrees,
            } => Camera {
                fov_y_degrees: fov_y_degrees.0,
                ..Camera::look_at(eye.vector(), target.vector())
            },
            CameraDesc::Orbit {
                target,
                distance,
                azimuth,
                elevation,
                degrees_per_second,
                fov_y_degrees,
            } => Camera {
                fov_y_degrees: fov_y_degrees.0,
                ..Camera::orbit(target.vector(), distance.0, azimuth.0, elevation.0)
            }
            .rotated(degrees_per_second.0 * t),
        }
    }
}

/// Bounding box of the particles and the finite colliders of a world.
#[cfg(feature = "render")]
#[cfg_attr(docsrs, doc(cfg(feature = "render")))]
pub fn scene_bounds(world: &FluidWorld) -> (Vector, Vector) {
    let mut lo = Vector::splat(Real::INFINITY);
    let mut hi = Vector::splat(Real::NEG_INFINITY);
    for (_, f) in world.fluids.iter() {
        for p in f.positions() {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
    }
    for (_, c) in world.physics.colliders.iter() {
        if c.shape().as_halfspace().is_some() {
            continue;
        }
        let aabb = c.compute_aabb();
        lo = lo.min(aabb.mins);
        hi = hi.max(aabb.maxs);
    }
    if !lo.is_finite() {
        return (Vector::splat(-1.0), Vector::splat(1.0));
    }
    (lo, hi)
}
