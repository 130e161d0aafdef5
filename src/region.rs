//! One notion of region for the queries, the trackers and the sinks.

use crate::math::{Real, Vector, is_finite};
use parry3d::bounding_volume::Aabb;
use rapier3d::geometry::{ColliderHandle, ColliderSet};

/// A region's bounding box and its containment test.
pub(crate) type Containment<'a> = (Aabb, Box<dyn Fn(Vector) -> bool + 'a>);

/// A region of space: for the queries ([`crate::Fluid::amount_in`], [`crate::RegionTracker`]) and for sinks
/// ([`crate::Sink`]), one notion for both.
///
/// # Examples
///
/// ```
/// use rapier_sph::{Fluid, FluidParamsBuilder, Region, SphError};
/// use rapier_sph::math::Vector;
/// use rapier_sph::rapier3d::prelude::ColliderSet;
///
/// let mut fluid = Fluid::new(FluidParamsBuilder::water(0.1))?;
/// fluid.add_block(Vector::ZERO, Vector::splat(1.0))?; // 10 × 10 × 10 particles
/// let colliders = ColliderSet::new();
/// // How much water is within 0.25 m of the block's middle (a splash zone, a trigger).
/// let zone = Region::Ball { center: Vector::splat(0.5), radius: 0.25 };
/// let inside = fluid.amount_in(&zone, &colliders);
/// assert!(inside.particles > 0 && inside.particles < fluid.len());
/// // A bad region is refused with the field named.
/// let inverted = Region::Aabb { min: Vector::ONE, max: Vector::ZERO };
/// assert!(matches!(inverted.validate(), Err(SphError::InvalidParameter { field: "max", .. })));
/// # Ok::<(), SphError>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub enum Region {
    /// The box `[min, max]`.
    Aabb {
        /// Lower corner (m).
        min: Vector,
        /// Upper corner (m).
        max: Vector,
    },
    /// A ball.
    Ball {
        /// Center (m).
        center: Vector,
        /// Radius (m).
        radius: Real,
    },
    /// Inside a rapier collider, solid or sensor (parry's `contains_point`: a triangle mesh
    /// counts as a volume only if built with `TriMeshFlags::ORIENTED`).
    Collider(ColliderHandle),
    /// Inside a rapier collider or within `reach` of its surface (`None`: one particle
    /// spacing of the fluid asked about). A drain plate, which contact keeps particles half a
    /// spacing off, takes what rests on it.
    NearCollider {
        /// The collider.
        handle: ColliderHandle,
        /// Distance from the surface that still counts (m).
        reach: Option<Real>,
    },
}

impl Region {
    /// Checks the region; returns the first problem, naming it.
    ///
    /// # Errors
    ///
    /// [`crate::SphError::InvalidParameter`] for a box with non-finite corners or `max` below
    /// `min` (field `max`), a ball with a non-finite center (`center`) or a radius that is not
    /// positive (`radius`), a negative or non-finite reach (`reach`).
    pub fn validate(&self) -> crate::SphResult<()> {
        let bad = |field, value: Real, reason| {
            Err(crate::SphError::InvalidParameter {
                field,
                value: value as f64,
                reason,
            })
        };
        match *self {
            Region::Aabb { min, max }
                if !is_finite(min) || !is_finite(max) || max.cmplt(min).any() =>
            {
                bad(
                    "max",
                    (max - min).min_element(),
                    "a box needs finite corners with min <= max",
                )
            }
            Region::Ball { center, .. } if !is_finite(center) => {
                bad("center", center.length(), "must be finite")
            }
            Region::Ball { radius, .. } if !radius.is_finite() || radius <= 0.0 => {
                bad("radius", radius, "must be positive and finite")
            }
            Region::NearCollider { reach: Some(r), .. } if !r.is_finite() || r < 0.0 => {
                bad("reach", r, "must be finite and non-negative")
            }
            _ => Ok(()),
        }
    }

    /// A bounding box and a containment test (`spacing`: the fluid's, for
    /// [`Region::NearCollider`] without a reach), or `None` for a collider that does not exist.
    pub(crate) fn resolve<'a>(
        &self,
        colliders: &'a ColliderSet,
        spacing: Real,
    ) -> Option<Containment<'a>> {
        Some(match *self {
            Region::Aabb { min, max } => (
                Aabb::new(min, max),
                Box::new(move |x: Vector| x.cmpge(min).all() && x.cmple(max).all()),
            ),
            Region::Ball { center, radius } => (
                Aabb::new(
                    center - Vector::splat(radius),
                    center + Vector::splat(radius),
                ),
                Box::new(move |x: Vector| (x - center).length_squared() <= radius * radius),
            ),
            Region::Collider(h) => {
                let co = colliders.get(h)?;
                let (shape, pose) = (co.shape(), co.position());
                (
                    co.compute_aabb(),
                    Box::new(move |x: Vector| shape.contains_point(pose, x)),
                )
            }
            Region::NearCollider { handle, reach } => {
                use parry3d::bounding_volume::BoundingVolume;
                let co = colliders.get(handle)?;
                let reach = reach.unwrap_or(spacing);
                let (shape, pose) = (co.shape(), co.position());
                (
                    co.compute_aabb().loosened(reach),
                    Box::new(move |x: Vector| {
                        shape
                            .project_point_with_max_dist(pose, x, true, reach)
                            .is_some()
                    }),
                )
            }
        })
    }
}
