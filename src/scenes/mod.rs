//! Reference scenes, built with the public API only, shared by the examples, the tests and
//! the benchmarks so each scene is defined in exactly one place.

#![cfg_attr(docsrs, doc(cfg(feature = "validation")))]

use crate::error::{SphError, SphResult};
use crate::fluid::{Fluid, FluidHandle, try_lattice};
use crate::math::{Real, Vector};
use crate::params::FluidParams;
use crate::world::FluidWorld;
use rapier3d::prelude::{ColliderBuilder, RigidBodyBuilder};

/// A closed box of six cuboid colliders whose **interior** is `[min, max]`, walls `thickness`
/// thick, on one fixed rapier body.
pub fn add_closed_box(world: &mut FluidWorld, min: Vector, max: Vector, thickness: Real) {
    let body = world.physics.insert_body(RigidBodyBuilder::fixed());
    let c = (min + max) * 0.5;
    let he = (max - min) * 0.5;
    let t = thickness * 0.5;
    let slabs = [
        // (center, half extents) of floor, lid, and the four walls
        (
            Vector::new(c.x, min.y - t, c.z),
            Vector::new(he.x + 2.0 * t, t, he.z + 2.0 * t),
        ),
        (
            Vector::new(c.x, max.y + t, c.z),
            Vector::new(he.x + 2.0 * t, t, he.z + 2.0 * t),
        ),
        (
            Vector::new(min.x - t, c.y, c.z),
            Vector::new(t, he.y + 2.0 * t, he.z + 2.0 * t),
        ),
        (
            Vector::new(max.x + t, c.y, c.z),
            Vector::new(t, he.y + 2.0 * t, he.z + 2.0 * t),
        ),
        (
            Vector::new(c.x, c.y, min.z - t),
            Vector::new(he.x + 2.0 * t, he.y + 2.0 * t, t),
        ),
        (
            Vector::new(c.x, c.y, max.z + t),
            Vector::new(he.x + 2.0 * t, he.y + 2.0 * t, t),
        ),
    ];
    for (center, half) in slabs {
        world.physics.insert_collider(
            ColliderBuilder::cuboid(half.x, half.y, half.z).translation(center),
            Some(body),
        );
    }
}

/// The dam break: a column of `nx × ny × nz` particles at rest in the corner of a closed
/// tank. The Unity paper's tower is 10 × 25 × 10 (2,500 particles).
#[derive(Clone, Debug)]
pub struct DamBreakConfig {
    /// Fluid parameters (the spacing sets the column's size).
    pub params: FluidParams,
    /// Particles along x (the direction the column collapses in), y (up) and z.
    pub counts: [usize; 3],
    /// Tank length as a multiple of the column's width (x). Default 4.
    pub tank_length_ratio: Real,
    /// Tank height as a multiple of the column's height. Default 1.5.
    pub tank_height_ratio: Real,
}

impl DamBreakConfig {
    /// The paper's 10 × 25 × 10 tower scaled by `scale` along each axis
    /// (`scale = 2` gives 20 × 50 × 20 = 20,000 particles).
    pub fn tower(params: FluidParams, scale: Real) -> Self {
        Self {
            params,
            counts: Self::tower_counts(scale),
            tank_length_ratio: 4.0,
            tank_height_ratio: 1.5,
        }
    }

    /// The scale that gives about `particles` particles with the tower's 10:25:10 shape.
    pub fn scale_for(particles: usize) -> Real {
        (particles as Real / 2500.0).cbrt()
    }

    /// The smallest scale from [`Self::scale_for`] up (in steps of 0.1 %) whose tower holds
    /// at least `particles` particles (the rounding of the tower's sides can leave the plain
    /// scale short: 98,260 particles for 100,000, where this gives 105,350).
    pub fn scale_for_at_least(particles: usize) -> Real {
        let mut scale = Self::scale_for(particles);
        let count = |s| {
            Self::tower_counts(s)
                .iter()
                .fold(1usize, |a, &b| a.saturating_mul(b))
        };
        while count(scale) < particles {
            scale *= 1.001;
        }
        scale
    }

    /// Particles along x, y and z of the 10:25:10 tower at `scale`.
    fn tower_counts(scale: Real) -> [usize; 3] {
        let n = |k: Real| ((k * scale).round() as usize).max(1);
        [n(10.0), n(25.0), n(10.0)]
    }
}

/// A built dam break.
pub struct DamBreak {
    /// The world: tank colliders and the fluid.
    pub world: FluidWorld,
    /// The fluid's handle.
    pub fluid: FluidHandle,
    /// Interior of the tank (particles must stay inside).
    pub tank_min: Vector,
    /// Interior of the tank.
    pub tank_max: Vector,
    /// Initial column height (m).
    pub column_height: Real,
    /// Initial column width along x (m).
    pub column_width: Real,
}

impl DamBreak {
    /// Number of particles outside the tank interior (they escaped through a wall).
    pub fn escaped(&self) -> usize {
        let eps = 1e-4 * (self.tank_max - self.tank_min).max_element();
        self.world.fluids[self.fluid]
            .positions()
            .iter()
            .filter(|p| {
                !(p.cmpge(self.tank_min - Vector::splat(eps)).all()
                    && p.cmple(self.tank_max + Vector::splat(eps)).all())
            })
            .count()
    }

    /// Position of the surge front: the largest x reached by the fluid along the floor,
    /// measured from the tank's back wall (m). Particles within two spacings of the floor
    /// count, and the front is the 99th percentile of their x so a lone droplet does not
    /// move it.
    pub fn front(&self) -> Real {
        let f = &self.world.fluids[self.fluid];
        let s = f.params().particle_spacing;
        let mut xs: Vec<Real> = f
            .positions()
            .iter()
            .filter(|p| p.y - self.tank_min.y < 2.0 * s)
            .map(|p| p.x - self.tank_min.x)
            .collect();
        if xs.is_empty() {
            return 0.0;
        }
        xs.sort_by(|a, b| a.total_cmp(b));
        xs[((xs.len() - 1) as Real * 0.99) as usize]
    }
}

/// Builds a dam break.
pub fn dam_break(config: &DamBreakConfig) -> SphResult<DamBreak> {
    let p = &config.params;
    let [nx, ny, nz] = config.counts;
    if nx == 0 || ny == 0 || nz == 0 {
        return Err(SphError::InvalidParameter {
            field: "counts",
            value: 0.0,
            reason: "every count must be at least 1",
        });
    }
    if !(config.tank_length_ratio >= 1.0 && config.tank_length_ratio.is_finite()) {
        return Err(SphError::InvalidParameter {
            field: "tank_length_ratio",
            value: config.tank_length_ratio as f64,
            reason: "the tank must be at least as long as the column",
        });
    }
    if !(config.tank_height_ratio >= 1.0 && config.tank_height_ratio.is_finite()) {
        return Err(SphError::InvalidParameter {
            field: "tank_height_ratio",
            value: config.tank_height_ratio as f64,
            reason: "the tank must be at least as tall as the column",
        });
    }
    let s = p.particle_spacing;
    let (w, hgt, d) = (nx as Real * s, ny as Real * s, nz as Real * s);
    let tank_min = Vector::ZERO;
    let tank_max = Vector::new(
        w * config.tank_length_ratio,
        hgt * config.tank_height_ratio,
        d,
    );
    let mut world = FluidWorld::new();
    add_closed_box(&mut world, tank_min, tank_max, (4.0 * s).max(0.05));
    let mut fluid = Fluid::new(p.clone())?;
    fluid.add_particles(&try_lattice(Vector::splat(0.5 * s), nx, ny, nz, s)?)?;
    let handle = world.fluids.insert(fluid);
    Ok(DamBreak {
        world,
        fluid: handle,
        tank_min,
        tank_max,
        column_height: hgt,
        column_width: w,
    })
}

/// A hydrostatic tank: a closed box holding a block of fluid at rest, `counts` particles along
/// x, y (up) and z, filling the box's floor exactly. Reference: `p = ρ0·g·depth`.
pub struct HydrostaticTank {
    /// The world: box colliders and the fluid (gravity −9.81 m/s² along y).
    pub world: FluidWorld,
    /// The fluid's handle.
    pub fluid: FluidHandle,
    /// Height of the free surface for the fluid's volume at rest density, `N·s³/area` (m).
    pub fluid_height: Real,
}

/// A world holding a closed box from the origin, `size` wide and deep and twice `size.y`
/// tall, walls `max(4s, 5 cm)` thick, with rapier stepped once so its broad-phase holds them:
/// the tank of [`HydrostaticTank`] and [`LayeredTank`] for a column `size` at spacing `s`.
fn hydrostatic_world(size: Vector, s: Real) -> FluidWorld {
    let mut world = FluidWorld::new();
    add_closed_box(
        &mut world,
        Vector::ZERO,
        Vector::new(size.x, 2.0 * size.y, size.z),
        (4.0 * s).max(0.05),
    );
    world.physics.step();
    world
}

impl HydrostaticTank {
    /// Builds the tank. The box is twice as tall as the fluid.
    pub fn new(params: FluidParams, counts: [usize; 3]) -> SphResult<Self> {
        let [nx, ny, nz] = counts;
        if nx == 0 || ny == 0 || nz == 0 {
            return Err(SphError::InvalidParameter {
                field: "counts",
                value: 0.0,
                reason: "every count must be at least 1",
            });
        }
        let s = params.particle_spacing;
        let size = Vector::new(nx as Real, ny as Real, nz as Real) * s;
        let mut world = hydrostatic_world(size, s);
        let mut fluid = Fluid::new(params)?;
        fluid.add_particles(&try_lattice(Vector::splat(0.5 * s), nx, ny, nz, s)?)?;
        let fluid = world.fluids.insert(fluid);
        Ok(Self {
            world,
            fluid,
            fluid_height: size.y,
        })
    }

    /// Relative error of the pressure of the particles in the bottom layer (centers within one
    /// spacing of the floor) against `ρ0·g·depth`, depth measured from the free surface at
    /// [`Self::fluid_height`]: `(mean measured − mean expected)/mean expected`.
    pub fn bottom_pressure_error(&self) -> Real {
        Self::bottom_pressure_error_of(&self.world, self.fluid, self.fluid_height)
    }

    /// [`Self::bottom_pressure_error`] of `fluid` in `world` with its free surface at
    /// `fluid_height` (for callers that hold the world apart from the tank).
    pub fn bottom_pressure_error_of(
        world: &FluidWorld,
        fluid: FluidHandle,
        fluid_height: Real,
    ) -> Real {
        let f = &world.fluids[fluid];
        let p = f.params();
        let g = world.physics.gravity.length();
        let (mut measured, mut expected) = (0.0f64, 0.0f64);
        for (x, pr) in f.positions().iter().zip(f.pressures()) {
            if x.y < p.particle_spacing {
                measured += *pr as f64;
                expected += (p.rest_density * g * (fluid_height - x.y)) as f64;
            }
        }
        if expected == 0.0 {
            return Real::INFINITY;
        }
        ((measured - expected) / expected) as Real
    }

    /// RMS over depth of the relative pressure error, in layers one spacing thick (the top
    /// layer, where the expected pressure goes to zero, left out).
    pub fn pressure_profile_rms(&self) -> Real {
        Self::pressure_profile_rms_of(&self.world, self.fluid, self.fluid_height)
    }

    /// [`Self::pressure_profile_rms`] of `fluid` in `world` with its free surface at
    /// `fluid_height`.
    pub fn pressure_profile_rms_of(
        world: &FluidWorld,
        fluid: FluidHandle,
        fluid_height: Real,
    ) -> Real {
        let f = &world.fluids[fluid];
        let p = f.params();
        let s = p.particle_spacing;
        let g = world.physics.gravity.length();
        let layers = (fluid_height / s).round() as usize;
        let mut sums = vec![(0.0f64, 0.0f64); layers];
        for (x, pr) in f.positions().iter().zip(f.pressures()) {
            let k = (x.y / s).floor();
            // In float: a particle thrown far up (or to infinity) must not wrap the index.
            if k >= 0.0 && k + 1.0 < layers as Real {
                let e = &mut sums[k as usize];
                e.0 += *pr as f64;
                e.1 += (p.rest_density * g * (fluid_height - x.y)) as f64;
            }
        }
        let errs: Vec<f64> = sums
            .iter()
            .filter(|e| e.1 > 0.0)
            .map(|e| (e.0 - e.1) / e.1)
            .collect();
        if errs.is_empty() {
            return Real::INFINITY;
        }
        (errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt() as Real
    }
}

/// The largest spacing, in 1 % steps down from the cube root of the volume per particle,
/// whose lattice in `size` holds at least `n` particles.
fn lattice_spacing(size: Vector, n: usize) -> SphResult<Real> {
    if n == 0 || n > crate::fluid::MAX_PARTICLES {
        return Err(SphError::InvalidParameter {
            field: "particles",
            value: n as f64,
            reason: "must be between 1 and MAX_PARTICLES",
        });
    }
    let mut spacing = (size.x * size.y * size.z / n as Real).cbrt();
    let fits = |s: Real| {
        (0..3)
            .map(|k| (size[k] / s).floor() as usize)
            .product::<usize>()
    };
    while fits(spacing) < n {
        spacing *= 0.99;
    }
    Ok(spacing)
}

#[cfg(test)]
mod tests {
    use super::DamBreakConfig;

    /// The bench's towers: at least the count asked for, the paper's tower exactly.
    #[test]
    fn scale_for_at_least_never_falls_short() {
        let count = |n| {
            DamBreakConfig::tower_counts(DamBreakConfig::scale_for_at_least(n))
                .iter()
                .fold(1usize, |a, &b| a.saturating_mul(b))
        };
        assert_eq!(count(2_500), 2_500);
        assert_eq!(count(20_000), 20_000);
        assert_eq!(count(100_000), 105_350);
        for n in [0, 1, 7, 999, 4_000, 64_000, 250_000, usize::MAX] {
            assert!(count(n) >= n, "{n}: {}", count(n));
        }
    }
}

mod floating;
mod layered;
mod mixed;
mod obstacle_course;
mod wave_pool;
pub use floating::{Floating, FloatingBox, FloatingBoxConfig, submerged_fraction};
pub use layered::{LayeredTank, Start as LayeredStart};
pub use mixed::{MixedTank, Start as MixedStart};
pub use obstacle_course::{ObstacleCourse, ObstacleCourseConfig, obstacle_course};
pub use wave_pool::{WavePool, WavePoolConfig};
