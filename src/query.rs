//! Queries for game logic: how much fluid is in a region (a box, a ball, a collider or
//! sensor), the fluid's density and velocity at a point, and how many particles entered or
//! left a region since the last frame.
//!
//! - [`Fluid::amount_in`]: particles, volume and mass inside a [`Region`]; one pass over the
//!   particles with a bounding-box test first (a parry point query only for particles inside
//!   the region's box).
//! - [`FluidSampler`]: SPH interpolation at any point through a hashed grid of cells of size
//!   `h`: density `ρ(x) = Σ m W(x − x_j)` with the fluid's density kernel, velocity
//!   `v(x) = Σ (m/ρ_j) v_j W / Σ (m/ρ_j) W` (Shepard-normalised, so a uniform flow is returned
//!   exactly). Build it once per frame (`O(N log N)` on positions that the step has already
//!   sorted by cell), then each sample costs 27 cell look-ups.
//! - [`RegionTracker`]: the ids inside a region, frame to frame: entered, left, inside.
//!   Particles removed by sinks while inside count as having left.
//! - [`check_container`]: whether a collider meant to hold fluid is a solid to parry (a
//!   triangle mesh built with `TriMeshFlags::ORIENTED` with the fluid inside it).

mod surface;

pub use crate::region::Region;

pub use surface::{WaterColumn, WaterSurface};

use crate::fluid::Fluid;
use crate::math::{Real, Vector, is_finite};
use rapier3d::geometry::ColliderSet;

/// How much fluid a region holds ([`Fluid::amount_in`]).
///
/// # Examples
/// ```
/// use rapier_sph::{Fluid, FluidParamsBuilder, Region, math::Vector};
/// use rapier_sph::rapier3d::prelude::ColliderSet;
/// let mut fluid = Fluid::new(FluidParamsBuilder::water(0.1))?;
/// fluid.add_block(Vector::ZERO, Vector::new(1.0, 0.5, 1.0))?; // 500 particles of 1 kg
/// let tank = Region::Aabb { min: Vector::ZERO, max: Vector::ONE };
/// let amount = fluid.amount_in(&tank, &ColliderSet::new());
/// // A fill-level readout: 0.5 m³, 500 kg.
/// assert_eq!(amount.particles, 500);
/// assert!((amount.volume - 0.5).abs() < 1e-4 && (amount.mass - 500.0).abs() < 1e-2);
/// # Ok::<(), rapier_sph::SphError>(())
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct FluidAmount {
    /// Particles inside.
    pub particles: usize,
    /// Their volume at rest density, `particles · m/ρ0` (m³).
    pub volume: Real,
    /// Their mass (kg).
    pub mass: Real,
}

impl Fluid {
    /// Particles, volume and mass of this fluid inside `region` (empty for a collider
    /// handle that names nothing).
    ///
    /// # Examples
    ///
    /// ```
    /// use rapier_sph::{Fluid, FluidParamsBuilder, Region};
    /// use rapier_sph::math::Vector;
    /// use rapier_sph::rapier3d::prelude::{ColliderBuilder, ColliderSet};
    ///
    /// let mut fluid = Fluid::new(FluidParamsBuilder::water(0.1).build()?)?;
    /// fluid.add_block(Vector::ZERO, Vector::new(1.0, 0.5, 1.0))?; // 10 × 5 × 10 particles
    /// let mut colliders = ColliderSet::new();
    /// // A sensor over the left half: a bucket, a trigger volume.
    /// let sensor = colliders.insert(
    ///     ColliderBuilder::cuboid(0.25, 1.0, 0.5).translation(Vector::new(0.25, 0.0, 0.5)).sensor(true),
    /// );
    /// let left = fluid.amount_in(&Region::Collider(sensor), &colliders);
    /// assert_eq!(left.particles, 250);
    /// assert!((left.volume - 0.25).abs() < 1e-4); // m³: 250 particles of 0.1³ m³
    /// let all = fluid.amount_in(&Region::Aabb { min: Vector::ZERO, max: Vector::ONE }, &colliders);
    /// assert_eq!(all.particles, 500);
    /// # Ok::<(), rapier_sph::SphError>(())
    /// ```
    pub fn amount_in(&self, region: &Region, colliders: &ColliderSet) -> FluidAmount {
        let spacing = self.params().particle_spacing;
        let Some((aabb, inside)) = region.resolve(colliders, spacing) else {
            return FluidAmount::default();
        };
        let particles = self
            .positions()
            .iter()
            .filter(|x| aabb.contains_local_point(**x) && inside(**x))
            .count();
        let p = self.params();
        FluidAmount {
            particles,
            volume: particles as Real * p.particle_mass / p.rest_density,
            mass: particles as Real * p.particle_mass,
        }
    }
}

/// SPH interpolation of a fluid's fields at arbitrary points (see the [module docs](self)).
///
/// # Examples
///
/// ```
/// use rapier_sph::{Fluid, FluidParamsBuilder, FluidSampler};
/// use rapier_sph::math::Vector;
///
/// let mut fluid = Fluid::new(FluidParamsBuilder::water(0.1).build()?)?;
/// fluid.add_block(Vector::ZERO, Vector::ONE)?; // 10 × 10 × 10 particles
/// fluid.velocities_mut().fill(Vector::new(1.0, 0.0, 0.0));
/// let sampler = FluidSampler::new(&fluid); // once per frame
/// let inside = sampler.sample(Vector::splat(0.5)).unwrap();
/// assert!((inside.velocity.x - 1.0).abs() < 1e-5); // a uniform flow comes back exactly
/// assert!(sampler.sample(Vector::splat(5.0)).is_none()); // no particle near
/// # Ok::<(), rapier_sph::SphError>(())
/// ```
pub struct FluidSampler<'a> {
    fluid: &'a Fluid,
    h: Real,
    /// `(cell key, particle index)`, sorted.
    cells: Vec<(u64, u32)>,
}

fn cell_key(c: [i64; 3]) -> u64 {
    // 21 bits per axis (cells of size h: ±10⁶ cells), wrapping: a collision only adds
    // candidates, which the distance test removes.
    let m = (1u64 << 21) - 1;
    ((c[0] as u64) & m) | (((c[1] as u64) & m) << 21) | (((c[2] as u64) & m) << 42)
}

fn cell_of(x: Vector, h: Real) -> [i64; 3] {
    let c = (x / h).floor();
    [c.x as i64, c.y as i64, c.z as i64]
}

/// What [`FluidSampler::sample`] returns (its example reads one).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Sample {
    /// Interpolated density (kg/m³): near `ρ0` inside the fluid, falling to 0 across its
    /// surface.
    pub density: Real,
    /// Interpolated velocity (m/s).
    pub velocity: Vector,
    /// Particles within the kernel support.
    pub neighbours: usize,
}

impl<'a> FluidSampler<'a> {
    /// Indexes the fluid's current positions.
    pub fn new(fluid: &'a Fluid) -> Self {
        let h = fluid.params().smoothing_length;
        let mut cells: Vec<(u64, u32)> = fluid
            .positions()
            .iter()
            .enumerate()
            .filter(|(_, x)| is_finite(**x))
            .map(|(i, x)| (cell_key(cell_of(*x, h)), i as u32))
            .collect();
        cells.sort_unstable();
        Self { fluid, h, cells }
    }

    /// The fluid's velocity at `point` (Shepard-normalised, as [`FluidSampler::sample`]), or
    /// `None` when no particle is within the kernel support: what a swimmer or a floating
    /// prop is carried by. 27 cell look-ups and the particles in them.
    ///
    /// # Errors
    /// [`crate::SphError::InvalidParameter`] naming `point` when it is not finite.
    ///
    /// # Examples
    /// ```
    /// use rapier_sph::prelude::*;
    ///
    /// let mut fluid = Fluid::new(FluidParamsBuilder::water(0.1).build()?)?;
    /// fluid.add_block(Vector::ZERO, Vector::ONE)?;
    /// fluid.velocities_mut().fill(Vector::new(0.0, 0.0, 2.0)); // a current along z
    /// let sampler = FluidSampler::new(&fluid);
    /// let v = sampler.velocity_at(Vector::splat(0.5))?.unwrap();
    /// assert!((v.z - 2.0).abs() < 1e-5);
    /// assert!(sampler.velocity_at(Vector::splat(Real::NAN)).is_err());
    /// # Ok::<(), rapier_sph::SphError>(())
    /// ```
    pub fn velocity_at(&self, point: Vector) -> crate::SphResult<Option<Vector>> {
        if !is_finite(point) {
            return Err(crate::SphError::InvalidParameter {
                field: "point",
                value: point.length() as f64,
                reason: "must be finite",
            });
        }
        Ok(self.sample(point).map(|s| s.velocity))
    }

    /// Density and velocity at `x`, or `None` when no particle is within the kernel support.
    pub fn sample(&self, x: Vector) -> Option<Sample> {
        let p = self.fluid.params();
        let (pos, vel, rho) = (
            self.fluid.positions(),
            self.fluid.velocities(),
            self.fluid.densities(),
        );
        let m = p.particle_mass;
        let c = cell_of(x, self.h);
        let (mut density, mut wsum, mut vsum, mut count) = (0.0, 0.0, Vector::ZERO, 0usize);
        crate::with_kernel!(p.density_kernel, K => {
            use crate::kernel::Kernel;
            let kernel = K::new(self.h);
            for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let key = cell_key([c[0] + dx, c[1] + dy, c[2] + dz]);
                        let start = self.cells.partition_point(|e| e.0 < key);
                        for &(k, j) in &self.cells[start..] {
                            if k != key {
                                break;
                            }
                            let j = j as usize;
                            let d = (x - pos[j]).length();
                            if d >= self.h {
                                continue;
                            }
                            let w = kernel.w(d);
                            density += m * w;
                            let vol = m / rho[j].max(Real::MIN_POSITIVE);
                            wsum += vol * w;
                            vsum += vel[j] * (vol * w);
                            count += 1;
                        }
                    }
                }
            }
        });
        (count > 0).then(|| Sample {
            density,
            velocity: if wsum > 0.0 {
                vsum / wsum
            } else {
                Vector::ZERO
            },
            neighbours: count,
        })
    }
}

/// Counts particles entering and leaving a region from one call of
/// [`RegionTracker::update`] to the next.
///
/// # Examples
///
/// ```
/// use rapier_sph::{Fluid, FluidParamsBuilder, Region, RegionTracker};
/// use rapier_sph::math::Vector;
/// use rapier_sph::rapier3d::prelude::ColliderSet;
///
/// let mut fluid = Fluid::new(FluidParamsBuilder::water(0.1).build()?)?;
/// fluid.add_particles(&[Vector::new(0.5, 0.5, 0.5), Vector::new(2.0, 0.5, 0.5)])?;
/// let colliders = ColliderSet::new();
/// let mut goal = RegionTracker::new(Region::Aabb { min: Vector::ZERO, max: Vector::ONE });
/// let first = goal.update(&fluid, &colliders);
/// assert_eq!((first.entered, first.left, first.inside), (1, 0, 1));
/// let next = goal.update(&fluid, &colliders); // nothing moved
/// assert_eq!((next.entered, next.left, next.inside), (0, 0, 1));
/// # Ok::<(), rapier_sph::SphError>(())
/// ```
#[derive(Clone, Debug)]
pub struct RegionTracker {
    region: Region,
    inside: Vec<u32>,
    scratch: Vec<u32>,
}

/// What a region saw since the last update ([`RegionTracker::update`]; the tracker's
/// example reads one).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct RegionEvents {
    /// Particles inside now that were not at the last update.
    pub entered: usize,
    /// Particles inside at the last update that are not now (moved out or removed).
    pub left: usize,
    /// Particles inside now.
    pub inside: usize,
}

impl RegionTracker {
    /// A tracker of `region`; the first update counts every particle inside as entered.
    pub fn new(region: Region) -> Self {
        Self {
            region,
            inside: Vec::new(),
            scratch: Vec::new(),
        }
    }

    /// Compares the particles of `fluid` inside the region now with the last update.
    pub fn update(&mut self, fluid: &Fluid, colliders: &ColliderSet) -> RegionEvents {
        self.scratch.clear();
        let spacing = fluid.params().particle_spacing;
        if let Some((aabb, inside)) = self.region.resolve(colliders, spacing) {
            for (x, id) in fluid.positions().iter().zip(fluid.ids()) {
                if aabb.contains_local_point(*x) && inside(*x) {
                    self.scratch.push(*id);
                }
            }
        }
        self.scratch.sort_unstable();
        // Merge the two sorted id lists.
        let (a, b) = (&self.inside, &self.scratch);
        let (mut i, mut j, mut entered, mut left) = (0, 0, 0, 0);
        while i < a.len() || j < b.len() {
            if j == b.len() || (i < a.len() && a[i] < b[j]) {
                left += 1;
                i += 1;
            } else if i == a.len() || b[j] < a[i] {
                entered += 1;
                j += 1;
            } else {
                i += 1;
                j += 1;
            }
        }
        std::mem::swap(&mut self.inside, &mut self.scratch);
        RegionEvents {
            entered,
            left,
            inside: self.inside.len(),
        }
    }
}

/// Checks that none of `positions` lies inside `collider` as parry's solid semantics see it,
/// where the collider is a triangle mesh built with `TriMeshFlags::ORIENTED`: call it on a tank before spawning water in it, with the
/// positions to spawn or [`Fluid::positions`].
///
/// A triangle mesh is a surface to parry unless it is built with `ORIENTED`; then the side
/// its normals face away from is solid. A closed mesh with outward normals (the usual
/// export) is then a solid block: particles inside it are "in a solid", and collider contact
/// pushes every one of them out through the nearest wall at the next step, silently. Build a
/// tank without `ORIENTED` (as scene files do), or with its normals facing the fluid.
/// Other shapes are not checked (a particle inside a ball is inside a ball).
///
/// # Errors
/// [`crate::SphError::InsideOrientedTriMesh`] with the number of positions inside.
///
/// # Examples
/// ```
/// use rapier_sph::math::Vector;
/// use rapier_sph::query::check_container;
/// use rapier_sph::rapier3d::prelude::*;
/// # use rapier_sph::rapier3d::parry::shape::TriMeshFlags;
/// // A closed unit cube with outward normals.
/// let v = vec![
///     Vector::new(0.0, 0.0, 0.0), Vector::new(1.0, 0.0, 0.0), Vector::new(1.0, 1.0, 0.0),
///     Vector::new(0.0, 1.0, 0.0), Vector::new(0.0, 0.0, 1.0), Vector::new(1.0, 0.0, 1.0),
///     Vector::new(1.0, 1.0, 1.0), Vector::new(0.0, 1.0, 1.0),
/// ];
/// let t = vec![
///     [0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
///     [2, 3, 7], [2, 7, 6], [1, 2, 6], [1, 6, 5], [0, 4, 7], [0, 7, 3],
/// ];
/// let water = [Vector::splat(0.5)];
/// let tank = ColliderBuilder::trimesh(v.clone(), t.clone()).unwrap().build();
/// assert!(check_container(&tank, &water).is_ok()); // a surface: holds the water
/// let solid = ColliderBuilder::trimesh_with_flags(v, t, TriMeshFlags::ORIENTED).unwrap().build();
/// assert!(check_container(&solid, &water).is_err()); // a solid: would eject it
/// ```
pub fn check_container(
    collider: &rapier3d::geometry::Collider,
    positions: &[Vector],
) -> crate::SphResult<()> {
    use parry3d::query::PointQuery;
    // (A compound cannot hold a triangle mesh: parry refuses nested composite shapes.)
    let Some(mesh) = collider.shape().as_trimesh() else {
        return Ok(());
    };
    if mesh.pseudo_normals_if_oriented().is_none() {
        return Ok(());
    }
    let pose = collider.position();
    let inside = positions
        .iter()
        .filter(|x| is_finite(**x) && mesh.contains_point(pose, **x))
        .count();
    if inside > 0 {
        return Err(crate::SphError::InsideOrientedTriMesh {
            inside,
            positions: positions.len(),
        });
    }
    Ok(())
}
