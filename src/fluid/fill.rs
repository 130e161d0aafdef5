//! Filling any parry shape with particles: a cubic lattice at the fluid's spacing over the
//! shape's bounding box, clipped by parry's point containment.

use super::{Fluid, MAX_PARTICLES, bytes_per_particle, check_particle_count};
use crate::error::{SphError, SphResult};
use crate::math::{Pose, Real, Vector, is_finite};
use parry3d::bounding_volume::Aabb;
use parry3d::shape::Shape;
use rapier3d::geometry::{ColliderHandle, ColliderSet};

/// The lattice over `aabb` at `spacing`: the points per axis and the first point.
///
/// An axis of length `L` holds `n = ⌊L/s + tol⌋` points (at least one), centered in the box:
/// the first at `min + (L − (n − 1)·s)/2`. A box of side `n·s` thus gets exactly `n` points
/// per axis, the outer ones half a spacing inside its faces, as [`Fluid::add_block`] places
/// them, even when `L/s` rounds to a hair under `n` in single precision: `tol` is 10⁻³ of a
/// spacing plus eight rounding units of the box's coordinates (in spacings).
fn lattice_over(aabb: &Aabb, s: Real) -> ([u64; 3], Vector) {
    let (min, max) = (aabb.mins, aabb.maxs);
    let magnitude = min.abs().max(max.abs()).max_element() as f64;
    let tol = 1.0e-3 + 8.0 * Real::EPSILON as f64 * magnitude / s as f64;
    let len = max - min;
    let count = |l: Real| ((l as f64 / s as f64 + tol).floor()).max(1.0) as u64;
    let n = [count(len.x), count(len.y), count(len.z)];
    let used = Vector::new((n[0] - 1) as Real, (n[1] - 1) as Real, (n[2] - 1) as Real) * s;
    (n, min + (len - used) * 0.5)
}

/// The points of a cubic lattice of spacing `spacing` that lie inside `shape` at `pose`
/// (parry's `contains_point`), x fastest. The lattice covers the shape's bounding box and is
/// centered in it (see [`Fluid::fill_shape`]).
///
/// A triangle mesh is a volume to parry only when built with `TriMeshFlags::ORIENTED` (then the
/// side its normals face away from is inside); a mesh without it contains no point.
///
/// # Errors
/// [`SphError::InvalidParameter`] naming `spacing` (not positive and finite), `pose` (not
/// finite) or `shape` (an unbounded shape such as a half-space, a negative or zero size along
/// an axis, or a bounding box holding more than [`MAX_PARTICLES`] lattice points, which would
/// take hours to scan).
///
/// # Examples
/// ```
/// use rapier_sph::{fluid::shape_lattice, math::{Pose, Vector}};
/// use rapier_sph::rapier3d::parry::shape::{Ball, Cuboid};
/// // A box of side 10 spacings: 10 per axis, whatever the rounding.
/// let cube = Cuboid::new(Vector::splat(0.25));
/// let at = Pose::from_translation(Vector::new(1.3, -0.7, 2.9));
/// assert_eq!(shape_lattice(&cube, &at, 0.05)?.len(), 1000);
/// // A ball of radius 5 spacings: the 552 lattice points inside it (its volume holds
/// // 4/3·π·5³ ≈ 524 lattice cells; the difference is the surface's share).
/// assert_eq!(shape_lattice(&Ball::new(0.25), &at, 0.05)?.len(), 552);
/// # Ok::<(), rapier_sph::SphError>(())
/// ```
pub fn shape_lattice(shape: &dyn Shape, pose: &Pose, spacing: Real) -> SphResult<Vec<Vector>> {
    if !spacing.is_finite() || spacing <= 0.0 {
        return Err(SphError::InvalidParameter {
            field: "spacing",
            value: spacing as f64,
            reason: "must be positive and finite",
        });
    }
    if !is_finite(pose.translation) || !pose.rotation.is_finite() {
        return Err(SphError::InvalidParameter {
            field: "pose",
            value: pose.translation.length() as f64,
            reason: "must be finite",
        });
    }
    let local = shape.compute_local_aabb();
    if !is_finite(local.mins) || !is_finite(local.maxs) {
        return Err(SphError::InvalidParameter {
            field: "shape",
            value: (local.maxs - local.mins).max_element() as f64,
            reason: "an unbounded shape (a half-space) or one of non-finite size cannot be filled",
        });
    }
    let size = (local.maxs - local.mins).min_element();
    if !(size > 0.0) {
        return Err(SphError::InvalidParameter {
            field: "shape",
            value: size as f64,
            reason: "a shape to fill needs a positive size along every axis (not a negative \
                     or zero radius or half extent)",
        });
    }
    let aabb = shape.compute_aabb(pose);
    let (n, first) = lattice_over(&aabb, spacing);
    let total = n[0] as f64 * n[1] as f64 * n[2] as f64;
    if total > MAX_PARTICLES as f64 {
        return Err(SphError::InvalidParameter {
            field: "shape",
            value: total,
            reason: "its bounding box holds more lattice points than a fluid can hold \
                     (MAX_PARTICLES = 2^32 - 1)",
        });
    }
    let mut out = Vec::new();
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                let x = first + Vector::new(i as Real, j as Real, k as Real) * spacing;
                if shape.contains_point(pose, x) {
                    out.push(x);
                }
            }
        }
    }
    Ok(out)
}

impl Fluid {
    /// Fills `shape` at `pose` with particles at rest on a cubic lattice at the fluid's
    /// spacing ([`shape_lattice`]): the lattice covers the shape's bounding box, centered in it,
    /// and keeps the points parry says are inside. A box of side `n·s` gets exactly `n`
    /// particles per axis (as [`Fluid::add_block`]); a ball, a capsule, a cylinder, a convex
    /// hull, a compound or an oriented triangle mesh gets the lattice points inside it. Returns
    /// the new particles' ids: their count is `ids.len()`.
    ///
    /// The shape is only a volume to fill: it need not be a collider. Fill the inside of a
    /// tank (its cavity as a cuboid), not a solid collider, whose contact would push the
    /// particles out.
    ///
    /// # Errors
    /// [`shape_lattice`]'s errors; [`SphError::InvalidParameter`] naming `shape` when the
    /// bounding box's lattice would need more memory than can be reserved for particles
    /// ([`bytes_per_particle`] each); then [`Fluid::add_particles`]'s (the capacity, positions
    /// beyond 10,000 km). Nothing is added on error.
    ///
    /// # Examples
    /// ```
    /// use rapier_sph::{Fluid, FluidParamsBuilder, math::{Pose, Vector}};
    /// use rapier_sph::rapier3d::parry::shape::{Cuboid, Cylinder};
    /// let mut fluid = Fluid::new(FluidParamsBuilder::water(0.05))?;
    /// // A barrel of water: a cylinder 0.4 m tall, radius 0.15 m, standing at (1, 0.2, 0).
    /// let barrel = fluid.fill_shape(&Cylinder::new(0.2, 0.15), &Pose::from_translation(Vector::new(1.0, 0.2, 0.0)))?;
    /// assert_eq!(barrel.len(), 8 * 32); // 8 layers of the 6 × 6 lattice points less 4 corners
    /// // A box of 0.5 m: 10 × 10 × 10, exactly.
    /// let block = fluid.fill_shape(&Cuboid::new(Vector::splat(0.25)), &Pose::IDENTITY)?;
    /// assert_eq!(block.len(), 1000);
    /// # Ok::<(), rapier_sph::SphError>(())
    /// ```
    pub fn fill_shape(
        &mut self,
        shape: &dyn Shape,
        pose: &Pose,
    ) -> SphResult<std::ops::Range<u32>> {
        let s = self.params().particle_spacing;
        if s.is_finite() {
            let aabb = shape.compute_aabb(pose);
            if is_finite(aabb.mins) && is_finite(aabb.maxs) {
                let (n, _) = lattice_over(&aabb, s);
                let total = n[0] as f64 * n[1] as f64 * n[2] as f64;
                check_particle_count(
                    total.min(MAX_PARTICLES as f64),
                    bytes_per_particle(self.params()),
                    "shape",
                )?;
            }
        }
        let points = shape_lattice(shape, pose, s)?;
        self.add_particles(&points)
    }

    /// [`Fluid::fill_shape`] with the shape and pose of a rapier collider (typically a sensor
    /// marking a pool's volume).
    ///
    /// # Errors
    /// [`SphError::InvalidParameter`] naming `collider` when the handle names no collider of
    /// `colliders` (removed, or from another set); then [`Fluid::fill_shape`]'s errors.
    ///
    /// # Examples
    /// ```
    /// use rapier_sph::{Fluid, FluidParamsBuilder, math::Vector};
    /// use rapier_sph::rapier3d::prelude::{ColliderBuilder, ColliderSet};
    /// let mut colliders = ColliderSet::new();
    /// let pool = colliders.insert(ColliderBuilder::ball(0.2).sensor(true).translation(Vector::Y));
    /// let mut fluid = Fluid::new(FluidParamsBuilder::water(0.05))?;
    /// let ids = fluid.fill_collider(pool, &colliders)?;
    /// assert_eq!(ids.len(), fluid.len());
    /// let elsewhere = ColliderSet::new(); // (or the collider was removed)
    /// assert!(fluid.fill_collider(pool, &elsewhere).is_err()); // names `collider`
    /// # Ok::<(), rapier_sph::SphError>(())
    /// ```
    pub fn fill_collider(
        &mut self,
        collider: ColliderHandle,
        colliders: &ColliderSet,
    ) -> SphResult<std::ops::Range<u32>> {
        let co = colliders
            .get(collider)
            .ok_or_else(|| unknown_collider(collider))?;
        self.fill_shape(co.shape(), co.position())
    }
}

/// The error for a collider handle that names nothing (the value is the handle's index).
pub(crate) fn unknown_collider(handle: ColliderHandle) -> SphError {
    SphError::InvalidParameter {
        field: "collider",
        value: handle.into_raw_parts().0 as f64,
        reason: "names no collider of the set (removed, or from another set)",
    }
}
