//! The water's surface seen from above: height and depth at a horizontal point, and how much of
//! a collider is under it (boats, swimming, splashes).

use crate::error::{SphError, SphResult};
use crate::fluid::Fluid;
use crate::math::{Real, Vector, is_finite};
use parry3d::query::Ray;
use rapier3d::geometry::{ColliderHandle, ColliderSet};
use std::collections::HashMap;

/// The fluid's columns seen from above (`+y` up): per square cell of side `h` (the kernel
/// support, 2 spacings for the presets) the highest and lowest particle. Build it once per
/// frame (one pass over the particles, `O(N)`), then each height is four hash look-ups.
///
/// A column's surface is its highest particle's center plus half a spacing (the layer that
/// particle stands for), its bottom the lowest one's minus half a spacing; between cell
/// centers the heights are interpolated bilinearly over the cells that hold fluid. A pool at
/// rest on a lattice reads its fill height exactly; a moving surface is smoothed over one
/// kernel support; a drop in the air over a pool counts as the column's top (the surface is
/// the topmost fluid, as a splash seen from above).
///
/// # Examples
/// ```
/// use rapier_sph::prelude::*;
/// use rapier_sph::query::WaterSurface;
///
/// let mut fluid = Fluid::new(FluidParamsBuilder::water(0.05).build()?)?;
/// fluid.add_block(Vector::ZERO, Vector::new(1.0, 0.4, 1.0))?; // a pool 0.4 m deep
/// let surface = WaterSurface::new(&fluid); // once per frame
/// let column = surface.column(0.5, 0.5)?.unwrap();
/// assert!((column.surface - 0.4).abs() < 1e-4 && (column.depth() - 0.4).abs() < 1e-4);
/// // A swimmer's head 0.1 m under the surface:
/// assert!((surface.depth_below_surface(Vector::new(0.5, 0.3, 0.5))?.unwrap() - 0.1).abs() < 1e-4);
/// assert!(surface.column(5.0, 5.0)?.is_none()); // no water there
/// assert!(surface.column(Real::NAN, 0.0).is_err()); // refused, naming `x`
/// # Ok::<(), rapier_sph::SphError>(())
/// ```
#[derive(Clone, Debug)]
pub struct WaterSurface {
    cell: Real,
    half_layer: Real,
    /// `(top, bottom)` particle centers per cell `(i, k)`.
    columns: HashMap<(i32, i32), (Real, Real)>,
    spacing: Real,
}

/// The fluid's column at a horizontal point (see [`WaterSurface::column`]).
///
/// # Examples
/// ```
/// use rapier_sph::{Fluid, FluidParamsBuilder, WaterSurface, math::Vector};
/// let mut pool = Fluid::new(FluidParamsBuilder::water(0.05))?;
/// pool.add_block(Vector::ZERO, Vector::new(1.0, 0.3, 1.0))?; // 6 layers, 0.3 m deep
/// let column = WaterSurface::new(&pool).column(0.5, 0.5)?.expect("water there");
/// // A splash or a boat reads the surface and the depth under it.
/// assert!((column.surface - 0.3).abs() < 1e-4);
/// assert!((column.depth() - 0.3).abs() < 1e-4);
/// # Ok::<(), rapier_sph::SphError>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct WaterColumn {
    /// Height of the water's surface (m).
    pub surface: Real,
    /// Height of the column's bottom (m): the floor the fluid rests on, or a drop's underside.
    pub bottom: Real,
}

impl WaterColumn {
    /// The column's depth, `surface − bottom` (m).
    pub fn depth(&self) -> Real {
        self.surface - self.bottom
    }
}

fn finite(argument: &'static str, v: Real) -> SphResult<()> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(SphError::InvalidParameter {
            field: argument,
            value: v as f64,
            reason: "must be finite",
        })
    }
}

impl WaterSurface {
    /// Indexes `fluid`'s particles by column (non-finite positions are skipped).
    pub fn new(fluid: &Fluid) -> Self {
        let p = fluid.params();
        let cell = p.smoothing_length;
        let mut columns: HashMap<(i32, i32), (Real, Real)> = HashMap::new();
        for x in fluid.positions().iter().filter(|x| is_finite(**x)) {
            let key = ((x.x / cell).floor() as i32, (x.z / cell).floor() as i32);
            let e = columns.entry(key).or_insert((x.y, x.y));
            e.0 = e.0.max(x.y);
            e.1 = e.1.min(x.y);
        }
        Self {
            cell,
            half_layer: 0.5 * p.particle_spacing,
            columns,
            spacing: p.particle_spacing,
        }
    }

    /// The column of water at `(x, z)`, or `None` where no fluid is within a cell of it.
    ///
    /// # Errors
    /// [`SphError::InvalidParameter`] naming `x` or `z` when it is not finite.
    pub fn column(&self, x: Real, z: Real) -> SphResult<Option<WaterColumn>> {
        finite("x", x)?;
        finite("z", z)?;
        // Bilinear over the four cell centers around the point, renormalised over those
        // holding fluid.
        let (u, v) = (x / self.cell - 0.5, z / self.cell - 0.5);
        let (i0, k0) = (u.floor(), v.floor());
        let (fu, fv) = (u - i0, v - k0);
        let (mut w_sum, mut top, mut bottom) = (0.0, 0.0, 0.0);
        for (di, dk, w) in [
            (0, 0, (1.0 - fu) * (1.0 - fv)),
            (1, 0, fu * (1.0 - fv)),
            (0, 1, (1.0 - fu) * fv),
            (1, 1, fu * fv),
        ] {
            let key = (i0 as i32 + di, k0 as i32 + dk);
            if let Some(&(t, b)) = self.columns.get(&key)
                && w > 0.0
            {
                w_sum += w;
                top += t * w;
                bottom += b * w;
            }
        }
        if w_sum <= 0.0 {
            // On a cell center line next to empty cells: the point's own cell.
            let key = (
                (x / self.cell).floor() as i32,
                (z / self.cell).floor() as i32,
            );
            return Ok(self.columns.get(&key).map(|&(t, b)| self.of(t, b)));
        }
        Ok(Some(self.of(top / w_sum, bottom / w_sum)))
    }

    fn of(&self, top: Real, bottom: Real) -> WaterColumn {
        WaterColumn {
            surface: top + self.half_layer,
            bottom: bottom - self.half_layer,
        }
    }

    /// The water's surface height at `(x, z)` (see [`WaterSurface::column`]).
    ///
    /// # Errors
    /// As [`WaterSurface::column`].
    pub fn height(&self, x: Real, z: Real) -> SphResult<Option<Real>> {
        Ok(self.column(x, z)?.map(|c| c.surface))
    }

    /// How far `point` is under the surface above or below it (negative: above the water;
    /// `None`: no water in its column).
    ///
    /// # Errors
    /// [`SphError::InvalidParameter`] naming `point` when it is not finite.
    pub fn depth_below_surface(&self, point: Vector) -> SphResult<Option<Real>> {
        if !is_finite(point) {
            return Err(SphError::InvalidParameter {
                field: "point",
                value: point.length() as f64,
                reason: "must be finite",
            });
        }
        Ok(self.height(point.x, point.z)?.map(|h| h - point.y))
    }

    /// The volume of `collider` under the water (m³): its footprint sampled on a grid of
    /// pitch `min(spacing, footprint/8)`, each sample's vertical chord through the shape
    /// (two ray casts) clipped to the water's column there. Exact for a convex shape under
    /// a flat surface, to the sampling of its outline; for a concave one the chord spans its
    /// hull in each column. Costs `O(samples)`, independent of the particle count: 64 to a
    /// few hundred samples for a boat.
    ///
    /// # Errors
    /// [`SphError::UnknownHandle`] (argument `"collider"`) when `collider` names no collider of
    /// `colliders`.
    ///
    /// # Examples
    /// ```
    /// use rapier_sph::prelude::*;
    /// use rapier_sph::query::WaterSurface;
    /// use rapier_sph::rapier3d::prelude::{ColliderBuilder, ColliderSet};
    ///
    /// let mut fluid = Fluid::new(FluidParamsBuilder::water(0.05).build()?)?;
    /// fluid.add_block(Vector::ZERO, Vector::new(1.0, 0.4, 1.0))?;
    /// let mut colliders = ColliderSet::new();
    /// // A 0.2 m cube half under the 0.4 m surface.
    /// let boat = colliders.insert(ColliderBuilder::cuboid(0.1, 0.1, 0.1).translation(Vector::new(0.5, 0.4, 0.5)));
    /// let v = WaterSurface::new(&fluid).submerged_volume(boat, &colliders)?;
    /// assert!((v - 0.004).abs() < 1e-4);
    /// # Ok::<(), rapier_sph::SphError>(())
    /// ```
    pub fn submerged_volume(
        &self,
        collider: ColliderHandle,
        colliders: &ColliderSet,
    ) -> SphResult<Real> {
        let co = colliders.get(collider).ok_or(SphError::UnknownHandle {
            argument: "collider",
            reason: "no collider of this set has this handle",
        })?;
        let (shape, pose) = (co.shape(), co.position());
        let aabb = co.compute_aabb();
        let size = aabb.maxs - aabb.mins;
        let pitch = self
            .spacing
            .min(size.x / 8.0)
            .min(size.z / 8.0)
            .max(Real::EPSILON);
        let (nx, nz) = (
            (size.x / pitch).ceil() as usize,
            (size.z / pitch).ceil() as usize,
        );
        let (px, pz) = (size.x / nx as Real, size.z / nz as Real);
        let reach = size.y + 2.0 * self.spacing;
        let mut volume = 0.0f64;
        for i in 0..nx {
            for k in 0..nz {
                let x = aabb.mins.x + (i as Real + 0.5) * px;
                let z = aabb.mins.z + (k as Real + 0.5) * pz;
                let Some(water) = self.column(x, z)? else {
                    continue;
                };
                let below = Vector::new(x, aabb.mins.y - self.spacing, z);
                let above = Vector::new(x, aabb.maxs.y + self.spacing, z);
                let up = Ray::new(below, Vector::Y);
                let down = Ray::new(above, -Vector::Y);
                let (Some(t0), Some(t1)) = (
                    shape.cast_ray(pose, &up, reach, true),
                    shape.cast_ray(pose, &down, reach, true),
                ) else {
                    continue;
                };
                let (lo, hi) = (below.y + t0, above.y - t1);
                let chord = hi.min(water.surface) - lo.max(water.bottom);
                if chord > 0.0 {
                    volume += (chord * px * pz) as f64;
                }
            }
        }
        Ok(volume as Real)
    }
}
