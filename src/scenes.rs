//! Reference scenes, built with the public API only, shared by the examples, the tests and
//! the benchmarks so each scene is defined in exactly one place.

#![cfg_attr(docsrs, doc(cfg(feature = "validation")))]

use crate::error::{SphError, SphResult};
use crate::fluid::{Fluid, FluidHandle, try_lattice};
use crate::math::{Real, Vector};
use crate::params::FluidParams;
use crate::world::FluidWorld;
use rapier3d::pipeline::PhysicsWorld;
use rapier3d::prelude::{
    ActiveEvents, Array2, ColliderBuilder, ColliderHandle, Pose, RigidBodyBuilder, RigidBodyHandle,
    SharedShape,
};

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

/// The obstacle course: water from an [`Emitter`](crate::Emitter) runs down a
/// ramp (cuboid), through a row of pegs (balls and capsules), into a funnel (open triangle
/// mesh), onto a stretch of heightfield terrain between two side walls, under a rotating
/// kinematic paddle wheel, around a compound obstacle, past floating dynamic crates, and into
/// a bucket whose fill is read through [`crate::Fluid::amount_in`] on a sensor. Everything
/// that leaves the course falls into a drain sink below it, so every particle is accounted
/// for: `emitted = live + drained + quarantined`.
///
/// The flow runs along +x and down: emitter at x ≈ 0, y = 1.9; bucket at x ∈ [3.12, 4.0],
/// y ∈ [−0.25, 0.15].
#[derive(Clone, Debug)]
pub struct ObstacleCourseConfig {
    /// Fluid parameters (the spacing sets the resolution).
    pub params: FluidParams,
    /// Emission rate as a fraction of the nozzle's blocking rate (one layer of slots per
    /// spacing of travel; see [`crate::Emitter::max_rate`]). Default 0.8.
    pub rate_fraction: Real,
    /// Nozzle radius (m). Default 0.08.
    pub nozzle_radius: Real,
    /// Jet speed (m/s). Default 1.5.
    pub jet_speed: Real,
    /// Paddle wheel angular speed (rad/s, its lower blades move downstream). Default 4.
    pub wheel_speed: Real,
}

impl ObstacleCourseConfig {
    /// The course with water at `spacing` (m) and the defaults above.
    pub fn new(params: FluidParams) -> Self {
        Self {
            params,
            rate_fraction: 0.8,
            nozzle_radius: 0.08,
            jet_speed: 1.5,
            wheel_speed: 4.0,
        }
    }
}

/// A built obstacle course.
pub struct ObstacleCourse {
    /// The world (rapier bodies and colliders, the fluid with its emitter and drain).
    pub world: FluidWorld,
    /// The fluid.
    pub fluid: FluidHandle,
    /// The sensor filling the bucket's inside (the fill query's region).
    pub bucket_sensor: rapier3d::prelude::ColliderHandle,
    /// Floor area of the bucket's inside (m²), to turn volume into fill height.
    pub bucket_area: Real,
    /// Height of the bucket's inside (m).
    pub bucket_depth: Real,
    /// The crates (dynamic bodies).
    pub crates: Vec<rapier3d::prelude::RigidBodyHandle>,
    /// The paddle wheel (kinematic body).
    pub wheel: rapier3d::prelude::RigidBodyHandle,
    /// Every fixed collider with a solid inside (no particle may ever be in one).
    pub solids: Vec<rapier3d::prelude::ColliderHandle>,
}

impl ObstacleCourse {
    /// Fluid in the bucket: particles, volume (m³) and fill height (m, volume over floor
    /// area).
    pub fn bucket(&self) -> (crate::query::FluidAmount, Real) {
        let a = self.world.fluids[self.fluid].amount_in(
            &crate::query::Region::Collider(self.bucket_sensor),
            &self.world.physics.colliders,
        );
        (a, a.volume / self.bucket_area)
    }
}

/// A funnel: a truncated cone around +y, open at both ends, `segments` around.
fn funnel_mesh(
    r_top: Real,
    r_bottom: Real,
    height: Real,
    segments: u32,
) -> (Vec<Vector>, Vec<[u32; 3]>) {
    let mut v = Vec::new();
    for k in 0..segments {
        let a = std::f32::consts::TAU * k as Real / segments as Real;
        let (s, c) = a.sin_cos();
        v.push(Vector::new(r_top * c, height, r_top * s));
        v.push(Vector::new(r_bottom * c, 0.0, r_bottom * s));
    }
    let mut idx = Vec::new();
    for k in 0..segments {
        let (t0, b0) = (2 * k, 2 * k + 1);
        let (t1, b1) = (2 * ((k + 1) % segments), 2 * ((k + 1) % segments) + 1);
        idx.push([t0, b0, b1]);
        idx.push([t0, b1, t1]);
    }
    (v, idx)
}

/// Builds the obstacle course. The rapier world is not stepped here: [`FluidWorld::step`]
/// steps rapier before the fluid, which fills rapier's broad-phase before the emitter first
/// looks for colliders (a caller that steps only the fluids must step rapier once first).
/// `scenes/obstacle_course.ron` is the same scene as a file (tested bit for bit).
pub fn obstacle_course(config: &ObstacleCourseConfig) -> SphResult<ObstacleCourse> {
    config.validate()?;
    let mut world = FluidWorld::new();
    world.physics.integration_parameters.dt = 1.0 / 60.0;
    let p = &mut world.physics;
    let mut course = Course {
        fixed: p.insert_body(RigidBodyBuilder::fixed()),
        solids: Vec::new(),
    };
    course.upper(p)?;
    course.terrain(p);
    let bucket = course.bucket(p);
    let wheel = paddle_wheel(p, config.wheel_speed);
    // Two floating crates (density 500) on the terrain, in the flow.
    let mut crates = Vec::new();
    for (x, z) in [(2.05, -0.1), (2.2, 0.1)] {
        let b = p.insert_body(RigidBodyBuilder::dynamic().translation(Vector::new(x, 0.45, z)));
        p.insert_collider(
            ColliderBuilder::cuboid(0.05, 0.05, 0.05).density(500.0),
            Some(b),
        );
        crates.push(b);
    }
    let fluid = world.fluids.insert(config.jet()?);
    Ok(ObstacleCourse {
        world,
        fluid,
        bucket_sensor: bucket.sensor,
        bucket_area: bucket.area,
        bucket_depth: bucket.depth,
        crates,
        wheel,
        solids: course.solids,
    })
}

/// Half width of the obstacle course along z (m).
const COURSE_HALF_WIDTH: Real = 0.25;

impl ObstacleCourseConfig {
    fn validate(&self) -> SphResult<()> {
        if !(self.rate_fraction > 0.0 && self.rate_fraction.is_finite()) {
            return Err(SphError::InvalidParameter {
                field: "rate_fraction",
                value: self.rate_fraction as f64,
                reason: "must be positive and finite",
            });
        }
        if !self.wheel_speed.is_finite() {
            return Err(SphError::InvalidParameter {
                field: "wheel_speed",
                value: self.wheel_speed as f64,
                reason: "must be finite",
            });
        }
        Ok(())
    }

    /// The fluid, empty, with the jet at the top of the ramp and a sink far below the course.
    fn jet(&self) -> SphResult<Fluid> {
        use crate::emitter::{Emitter, Nozzle, Region, Sink};
        let params = self.params.clone();
        let s = params.particle_spacing;
        let mut fluid = Fluid::new(params)?;
        let mut emitter = Emitter::new(
            Nozzle::Disk {
                radius: self.nozzle_radius,
            },
            Vector::new(0.05, 1.9, 0.0),
            Vector::new(1.0, -0.3, 0.0),
            self.jet_speed,
            1.0,
        );
        let rate = emitter.max_rate(s) * self.rate_fraction;
        emitter.set_rate(rate)?;
        fluid.add_emitter(emitter)?;
        fluid.add_sink(Sink::new(Region::Aabb {
            min: Vector::splat(-100.0),
            max: Vector::new(100.0, -0.6, 100.0),
        }))?;
        Ok(fluid)
    }
}

/// The fixed colliders of the obstacle course, inserted in a fixed order (their handles
/// are part of the scene's bitwise identity); `solids` are those no particle may enter.
struct Course {
    fixed: RigidBodyHandle,
    solids: Vec<ColliderHandle>,
}

/// The bucket at the end of the course: its sensor, floor area and depth.
struct Bucket {
    sensor: ColliderHandle,
    area: Real,
    depth: Real,
}

impl Course {
    fn add(&mut self, p: &mut PhysicsWorld, c: ColliderBuilder, solid: bool) -> ColliderHandle {
        let h = p.insert_collider(c, Some(self.fixed));
        if solid {
            self.solids.push(h);
        }
        h
    }

    /// The ramp with its side walls, the pegs below its end and the funnel under them.
    fn upper(&mut self, p: &mut PhysicsWorld) -> SphResult<()> {
        let w = COURSE_HALF_WIDTH;
        let tilt = Vector::new(0.0, 0.0, -0.35);
        // Ramp: 1.2 m long, tilted 20° down along +x.
        let ramp = Pose::new(Vector::new(0.55, 1.6, 0.0), tilt);
        self.add(
            p,
            ColliderBuilder::cuboid(0.6, 0.02, w).position(ramp),
            true,
        );
        // Side walls of the ramp.
        for z in [-w - 0.02, w + 0.02] {
            let side = Pose::new(Vector::new(0.55, 1.7, z), tilt);
            self.add(
                p,
                ColliderBuilder::cuboid(0.65, 0.15, 0.02).position(side),
                true,
            );
        }
        // Pegs: two balls and a capsule across the flow below the ramp's end.
        for z in [-0.12, 0.12] {
            let peg = ColliderBuilder::ball(0.04).translation(Vector::new(1.3, 1.2, z));
            self.add(p, peg, true);
        }
        let bar = ColliderBuilder::capsule_z(0.15, 0.03).translation(Vector::new(1.45, 1.05, 0.0));
        self.add(p, bar, true);
        // Funnel (open trimesh, both faces collide): top radius 0.4 at y = 1.0, bottom
        // radius 0.1 at y = 0.7, under the pegs.
        let (fv, fi) = funnel_mesh(0.4, 0.1, 0.3, 24);
        let funnel = ColliderBuilder::trimesh(fv, fi)
            .map_err(|_| SphError::InvalidParameter {
                field: "funnel",
                value: 0.0,
                reason: "degenerate funnel mesh",
            })?
            .translation(Vector::new(1.45, 0.7, 0.0));
        self.add(p, funnel, false);
        Ok(())
    }

    /// Heightfield terrain from x = 1.2 to 3.2 (2 m × 0.6 m), sloping from 0.45 m down to
    /// 0.2 m with ripples, between two side walls; a back wall upstream of where the funnel
    /// pours, and a compound obstacle (a block with a ball on top) on the terrain.
    fn terrain(&mut self, p: &mut PhysicsWorld) {
        let w = COURSE_HALF_WIDTH;
        let (nrows, ncols) = (7usize, 41usize);
        let mut data = vec![0.0; nrows * ncols];
        for j in 0..ncols {
            for i in 0..nrows {
                let u = j as Real / (ncols - 1) as Real;
                data[i + j * nrows] = 0.25 * (1.0 - u) + 0.02 * (u * 25.0).sin();
            }
        }
        let scale = Vector::new(2.0, 1.0, 2.0 * w + 0.1);
        let field = ColliderBuilder::heightfield(Array2::new(nrows, ncols, data), scale)
            .translation(Vector::new(2.2, 0.2, 0.0));
        self.add(p, field, false);
        for z in [-w - 0.02, w + 0.02] {
            let side =
                ColliderBuilder::cuboid(1.1, 0.55, 0.02).translation(Vector::new(2.2, 0.75, z));
            self.add(p, side, true);
        }
        let back =
            ColliderBuilder::cuboid(0.02, 0.55, w + 0.04).translation(Vector::new(1.18, 0.75, 0.0));
        self.add(p, back, true);
        let obstacle = ColliderBuilder::compound(vec![
            (Pose::IDENTITY, SharedShape::cuboid(0.05, 0.08, 0.08)),
            (
                Pose::from_translation(Vector::new(0.0, 0.08, 0.0)),
                SharedShape::ball(0.06),
            ),
        ])
        .translation(Vector::new(2.95, 0.33, -0.1));
        self.add(p, obstacle, true);
    }

    /// The bucket: inside x ∈ [3.12, 4.0], y ∈ [−0.25, 0.15], z ∈ [−0.4, 0.4], walls 2 cm.
    /// Its near wall stands under the terrain's end (top at y = 0.15), so what runs off the
    /// terrain falls in; the other three walls rise to y = 0.6 to catch the splash. A sensor
    /// fills its inside.
    fn bucket(&mut self, p: &mut PhysicsWorld) -> Bucket {
        let (bmin, bmax) = (Vector::new(3.12, -0.25, -0.4), Vector::new(4.0, 0.15, 0.4));
        let t = 0.02;
        let bc = (bmin + bmax) * 0.5;
        let bh = (bmax - bmin) * 0.5;
        let top = 0.6;
        let (tall_c, tall_h) = ((bmin.y + top) * 0.5, (top - bmin.y) * 0.5);
        for (c, h) in [
            (
                Vector::new(bc.x, bmin.y - t, bc.z),
                Vector::new(bh.x + 2.0 * t, t, bh.z + 2.0 * t),
            ),
            (
                Vector::new(bmin.x - t, bc.y, bc.z),
                Vector::new(t, bh.y, bh.z + 2.0 * t),
            ),
            (
                Vector::new(bmax.x + t, tall_c, bc.z),
                Vector::new(t, tall_h, bh.z + 2.0 * t),
            ),
            (
                Vector::new(bc.x, tall_c, bmin.z - t),
                Vector::new(bh.x, tall_h, t),
            ),
            (
                Vector::new(bc.x, tall_c, bmax.z + t),
                Vector::new(bh.x, tall_h, t),
            ),
        ] {
            self.add(
                p,
                ColliderBuilder::cuboid(h.x, h.y, h.z).translation(c),
                true,
            );
        }
        let sensor = ColliderBuilder::cuboid(bh.x, bh.y, bh.z)
            .translation(bc)
            .sensor(true);
        Bucket {
            sensor: self.add(p, sensor, false),
            area: (bmax.x - bmin.x) * (bmax.z - bmin.z),
            depth: bmax.y - bmin.y,
        }
    }
}

/// The paddle wheel: kinematic, axis z, four blades reaching down into the stream on the
/// terrain, lower blades moving downstream (+x).
fn paddle_wheel(p: &mut PhysicsWorld, speed: Real) -> RigidBodyHandle {
    let wheel = p.insert_body(
        RigidBodyBuilder::kinematic_velocity_based()
            .translation(Vector::new(2.5, 0.62, 0.0))
            .angvel(Vector::new(0.0, 0.0, speed)),
    );
    for k in 0..4 {
        let a = std::f32::consts::FRAC_PI_2 * k as Real;
        let d = Vector::new(a.cos(), a.sin(), 0.0);
        p.insert_collider(
            ColliderBuilder::cuboid(0.12, 0.008, COURSE_HALF_WIDTH - 0.03)
                .position(Pose::new(d * 0.15, Vector::new(0.0, 0.0, a))),
            Some(wheel),
        );
    }
    wheel
}

/// A floating box (the buoyancy test and example): a closed tank `tank` wide holding `depth`
/// of water (walls counting in the density) and a dynamic box placed at its expected floating
/// depth, the water cut out around it.
#[derive(Clone, Debug)]
pub struct FloatingBoxConfig {
    /// Particle spacing (m) of the water preset.
    pub spacing: Real,
    /// Inner width and length of the tank (m).
    pub tank: Real,
    /// Water depth (m).
    pub depth: Real,
    /// Half width (x and z) of the box (m).
    pub half_width: Real,
    /// Half height of the box (m).
    pub half_height: Real,
    /// Density of the box (kg/m³).
    pub density: Real,
    /// The water's solver.
    pub solver: crate::Solver,
}

/// The scene of [`FloatingBoxConfig`], built.
pub struct FloatingBox {
    /// The world (60 Hz frames).
    pub world: FluidWorld,
    /// The water.
    pub fluid: FluidHandle,
    /// The box.
    pub body: rapier3d::dynamics::RigidBodyHandle,
    /// The configuration it was built from.
    pub config: FloatingBoxConfig,
}

/// What a floating box did over the last second of [`FloatingBox::run`].
#[derive(Copy, Clone, Debug)]
pub struct Floating {
    /// Mean submerged fraction of the box's volume (water surface measured away from the box).
    pub submerged: Real,
    /// Lowest and highest submerged fraction.
    pub range: (Real, Real),
    /// RMS acceleration of the box's corners (m/s²), from its poses frame to frame:
    /// translation plus rotation (`α × r`).
    pub shaking: Real,
    /// RMS speed of the box's corners (m/s), from its poses frame to frame.
    pub speed: Real,
    /// RMS speed of the water within two spacings of the box (m/s).
    pub water: Real,
    /// Height of the box's lowest corner at the end (m; the tank's floor is at 0).
    pub bottom: Real,
}

/// Fraction of the volume of the box of half extents `half` at `pose` below the height
/// `surface`: the box cut into 32 × 32 columns along its own y axis, each column's fraction
/// below the surface exact (height is linear along it). Exact for an upright box, and right
/// for a tilted one too.
pub fn submerged_fraction(pose: &rapier3d::math::Pose, half: Vector, surface: Real) -> Real {
    const N: usize = 32;
    let mut sum = 0.0;
    for i in 0..N {
        for k in 0..N {
            let u = (i as Real + 0.5) / N as Real * 2.0 - 1.0;
            let w = (k as Real + 0.5) / N as Real * 2.0 - 1.0;
            let y0 = pose
                .transform_point(Vector::new(u * half.x, -half.y, w * half.z))
                .y;
            let y1 = pose
                .transform_point(Vector::new(u * half.x, half.y, w * half.z))
                .y;
            let (lo, hi) = (y0.min(y1), y0.max(y1));
            sum += if hi - lo < 1e-9 {
                (lo < surface) as u8 as Real
            } else {
                ((surface - lo) / (hi - lo)).clamp(0.0, 1.0)
            };
        }
    }
    sum / (N * N) as Real
}

impl FloatingBox {
    /// Builds the tank, the water and the box.
    pub fn new(config: FloatingBoxConfig) -> SphResult<Self> {
        let c = &config;
        for (field, v) in [
            ("tank", c.tank),
            ("depth", c.depth),
            ("half_width", c.half_width),
            ("half_height", c.half_height),
            ("density", c.density),
        ] {
            if !(v > 0.0 && v.is_finite()) {
                return Err(SphError::InvalidParameter {
                    field,
                    value: v as f64,
                    reason: "must be positive and finite",
                });
            }
        }
        let (s, tank, depth) = (c.spacing, c.tank, c.depth);
        let (hw, hh) = (c.half_width, c.half_height);
        let params = crate::FluidParamsBuilder::water(s)
            .wall_density(true)
            .solver(c.solver)
            .build()?;
        let mut world = FluidWorld::new();
        world.physics.integration_parameters.dt = 1.0 / 60.0;
        let top = depth + 2.0 * hh + 0.1;
        add_closed_box(&mut world, Vector::ZERO, Vector::new(tank, top, tank), 0.05);
        let mut fluid = Fluid::new(params)?;
        let mid = 0.5 * tank;
        let half = Vector::new(hw, hh, hw);
        let center = Vector::new(
            mid,
            depth + hh * (1.0 - 2.0 * c.density.min(1000.0) / 1000.0),
            mid,
        );
        let n = (tank / s) as usize;
        let pts: Vec<Vector> = try_lattice(Vector::splat(0.5 * s), n, (depth / s) as usize, n, s)?
            .into_iter()
            .filter(|p| ((*p - center).abs() - half - Vector::splat(0.5 * s)).max_element() > 0.0)
            .collect();
        fluid.add_particles(&pts)?;
        let fluid = world.fluids.insert(fluid);
        let body = world
            .physics
            .insert_body(RigidBodyBuilder::dynamic().translation(center));
        world.physics.insert_collider(
            ColliderBuilder::cuboid(hw, hh, hw).density(c.density),
            Some(body),
        );
        world.physics.step();
        Ok(Self {
            world,
            fluid,
            body,
            config,
        })
    }

    /// Height of the tank's lid (m): water depth, the box's height and 0.1 m of air.
    pub fn tank_height(&self) -> Real {
        self.config.depth + 2.0 * self.config.half_height + 0.1
    }

    /// Runs `seconds` of 60 Hz frames, calling `each_frame(frame, world)` after every frame,
    /// and measures the last second.
    pub fn run(
        &mut self,
        seconds: Real,
        mut each_frame: impl FnMut(usize, &FluidWorld) -> SphResult<()>,
    ) -> SphResult<Floating> {
        let frames = (seconds * 60.0) as usize;
        let (mut sum, mut lo, mut hi, mut count) = (0.0, Real::MAX, Real::MIN, 0);
        let mut poses = Vec::new();
        let mut water = 0.0f64;
        for frame in 0..frames {
            self.world.step()?;
            each_frame(frame, &self.world)?;
            if frame + 62 < frames {
                continue;
            }
            let pose = *self.world.physics.bodies[self.body].position();
            poses.push(pose);
            if frame + 60 < frames {
                continue;
            }
            water += self.water_speed_squared(&pose);
            let frac = submerged_fraction(&pose, self.half_extents(), self.water_surface());
            sum += frac;
            count += 1;
            lo = lo.min(frac);
            hi = hi.max(frac);
        }
        if poses.len() < 3 {
            return Err(SphError::InvalidParameter {
                field: "seconds",
                value: seconds as f64,
                reason: "the measurement needs at least the last second plus two frames",
            });
        }
        let (shaking, speed) = self.motion(&poses);
        Ok(Floating {
            submerged: sum / count as Real,
            range: (lo, hi),
            shaking,
            speed,
            water: (water / count as f64).sqrt() as Real,
            bottom: self.lowest_corner(),
        })
    }

    fn half_extents(&self) -> Vector {
        let (hw, hh) = (self.config.half_width, self.config.half_height);
        Vector::new(hw, hh, hw)
    }

    /// Mean squared speed of the water within two spacings of the box.
    fn water_speed_squared(&self, pose: &Pose) -> f64 {
        let (s, half) = (self.config.spacing, self.half_extents());
        let f = &self.world.fluids[self.fluid];
        let (mut w2, mut wn) = (0.0f64, 0usize);
        for (x, v) in f.positions().iter().zip(f.velocities()) {
            let l = pose.inverse_transform_point(*x).abs() - half;
            if l.max_element() < 2.0 * s {
                w2 += v.length_squared() as f64;
                wn += 1;
            }
        }
        w2 / wn.max(1) as f64
    }

    /// Water surface: mean height of the topmost 5 % of the particles more than two
    /// spacings away from the box (particle centers sit half a spacing under it).
    fn water_surface(&self) -> Real {
        let (s, mid, hw) = (
            self.config.spacing,
            0.5 * self.config.tank,
            self.config.half_width,
        );
        let f = &self.world.fluids[self.fluid];
        let mut tops: Vec<Real> = f
            .positions()
            .iter()
            .filter(|p| (p.x - mid).abs() > hw + 2.0 * s || (p.z - mid).abs() > hw + 2.0 * s)
            .map(|p| p.y)
            .collect();
        tops.sort_by(|a, b| b.total_cmp(a));
        let k = (tops.len() / 20).max(1);
        tops[..k].iter().sum::<Real>() / k as Real + 0.5 * s
    }

    /// RMS acceleration and RMS speed of the box's corners over `poses` (one per frame):
    /// frame-to-frame velocities (linear, angular) from the poses, then accelerations.
    fn motion(&self, poses: &[Pose]) -> (Real, Real) {
        let dt = 1.0 / 60.0;
        let corner = self.half_extents().length();
        let vel: Vec<(Vector, Vector)> = poses
            .windows(2)
            .map(|w| {
                (
                    (w[1].translation - w[0].translation) / dt,
                    (w[1].rotation * w[0].rotation.inverse()).to_scaled_axis() / dt,
                )
            })
            .collect();
        let (mut a2, mut v2) = (0.0f64, 0.0f64);
        for w in vel.windows(2) {
            let a = (w[1].0 - w[0].0).length() / dt;
            let alpha = (w[1].1 - w[0].1).length() / dt;
            a2 += ((a + alpha * corner) as f64).powi(2);
        }
        for (v, w) in &vel {
            v2 += ((v.length() + w.length() * corner) as f64).powi(2);
        }
        (
            (a2 / (vel.len() - 1) as f64).sqrt() as Real,
            (v2 / vel.len() as f64).sqrt() as Real,
        )
    }

    /// Height of the box's lowest corner now.
    fn lowest_corner(&self) -> Real {
        let (hw, hh) = (self.config.half_width, self.config.half_height);
        let pose = self.world.physics.bodies[self.body].position();
        let mut bottom = Real::MAX;
        for c in 0..8 {
            let sign = |b: usize| if c & b == 0 { -1.0 } else { 1.0 };
            let p = Vector::new(sign(1) * hw, sign(2) * hh, sign(4) * hw);
            bottom = bottom.min(pose.transform_point(p).y);
        }
        bottom
    }
}

/// The game pool ([`WavePool`]): a closed pool 2.0 × 0.8 × 0.7 m (inside), water 0.45 m
/// deep, a 40 × 10 × 24 cm hull floating in it and a kinematic paddle at its −x end that
/// swings back and forth (a wave maker). The game benchmark (`cargo bench --bench game`) and
/// the boat example (`cargo run --release --example boat`) run it.
#[derive(Clone, Debug)]
pub struct WavePoolConfig {
    /// About how many particles of water (the largest spacing whose lattice holds at least
    /// this many is taken).
    pub particles: usize,
    /// The water's parameters at a given spacing (default: the water preset, DFSPH).
    pub params: fn(Real) -> SphResult<FluidParams>,
    /// The hull's density (kg/m³; default 500: it floats half under).
    pub hull_density: Real,
    /// The paddle's stroke: it moves `amplitude` m each way every `period` s (default 8 cm,
    /// 1.5 s); an amplitude of 0 keeps it still.
    pub paddle: (Real, Real),
    /// Whether the hull's collider asks for the fluid's force on it
    /// (`ActiveEvents::CONTACT_FORCE_EVENTS`, read with `FluidPipeline::body_force`; default
    /// off: the benchmark measures the pool alone).
    pub watch_hull: bool,
}

impl Default for WavePoolConfig {
    fn default() -> Self {
        Self {
            particles: 10_000,
            params: |s| crate::params::FluidParamsBuilder::water(s).build(),
            hull_density: 500.0,
            paddle: (0.08, 1.5),
            watch_hull: false,
        }
    }
}

/// The game pool (see [`WavePoolConfig`]), stepped one 1/60 s frame at a time as a game
/// steps it.
pub struct WavePool {
    /// The rapier world, the water and the pipeline.
    pub world: FluidWorld,
    /// The water.
    pub water: FluidHandle,
    /// The floating hull (dynamic).
    pub hull: RigidBodyHandle,
    /// The paddle (kinematic, position-based).
    pub paddle: RigidBodyHandle,
    /// The particle spacing taken (m).
    pub spacing: Real,
    config: WavePoolConfig,
    frames: usize,
}

impl WavePool {
    /// Inside of the pool, from the origin.
    pub const SIZE: Vector = Vector::new(2.0, 0.8, 0.7);
    /// Depth of the water at rest (m).
    pub const DEPTH: Real = 0.45;
    /// Half extents of the hull (m).
    pub const HULL_HALF: Vector = Vector::new(0.2, 0.05, 0.12);
    /// The paddle's rest position along x (its plate is 2 cm thick).
    pub const PADDLE_X: Real = 0.15;

    /// Builds the pool, the water at rest (the water the hull displaces cut out), the hull
    /// at its expected draft.
    ///
    /// # Errors
    /// The parameters' errors, and [`SphError::InvalidParameter`] naming `particles` (0 or
    /// more than the fluid can hold) or `hull_density` (not positive and finite).
    pub fn new(config: WavePoolConfig) -> SphResult<Self> {
        if !(config.hull_density > 0.0 && config.hull_density.is_finite()) {
            return Err(SphError::InvalidParameter {
                field: "hull_density",
                value: config.hull_density as f64,
                reason: "must be positive and finite",
            });
        }
        let behind_paddle = Self::PADDLE_X + 0.02;
        let water = Vector::new(Self::SIZE.x - behind_paddle, Self::DEPTH, Self::SIZE.z);
        let spacing = lattice_spacing(water, config.particles)?;
        let params = (config.params)(spacing)?;
        let rest_density = params.rest_density;
        let mut world = FluidWorld::new();
        add_closed_box(&mut world, Vector::ZERO, Self::SIZE, 0.04);
        let (z, h) = (0.5 * Self::SIZE.z, Self::HULL_HALF);
        let paddle = world.physics.insert_body(
            RigidBodyBuilder::kinematic_position_based().translation(Vector::new(
                Self::PADDLE_X,
                0.4,
                z,
            )),
        );
        world
            .physics
            .insert_collider(ColliderBuilder::cuboid(0.01, 0.38, z - 0.01), Some(paddle));
        // Its bottom at the expected draft under the water's level.
        let draft = 2.0 * h.y * config.hull_density / rest_density;
        let hull_center = Vector::new(1.3, Self::DEPTH - draft + h.y, z);
        let hull = world
            .physics
            .insert_body(RigidBodyBuilder::dynamic().translation(hull_center));
        let mut hull_collider = ColliderBuilder::cuboid(h.x, h.y, h.z).density(config.hull_density);
        if config.watch_hull {
            hull_collider = hull_collider.active_events(ActiveEvents::CONTACT_FORCE_EVENTS);
        }
        world.physics.insert_collider(hull_collider, Some(hull));
        let mut fluid = Fluid::new(params)?;
        fluid.add_block(Vector::new(behind_paddle, 0.0, 0.0), water)?;
        let (lo, hi) = (hull_center - h, hull_center + h);
        let margin = 0.5 * spacing;
        fluid.remove_particles_where(|x, _, _| {
            x.x > lo.x - margin
                && x.x < hi.x + margin
                && x.z > lo.z - margin
                && x.z < hi.z + margin
                && x.y > lo.y - margin
        });
        let water = world.fluids.insert(fluid);
        Ok(Self {
            world,
            water,
            hull,
            paddle,
            spacing,
            config,
            frames: 0,
        })
    }

    /// One 1/60 s frame: the paddle's target for the frame's end, rapier's step, then the
    /// fluid's. Returns the time rapier's step took.
    ///
    /// # Errors
    /// [`crate::FluidPipeline::step`]'s.
    pub fn frame(&mut self) -> SphResult<std::time::Duration> {
        let dt = 1.0 / 60.0;
        self.frames += 1;
        let (amplitude, period) = self.config.paddle;
        if amplitude != 0.0 {
            let phase = std::f32::consts::TAU * self.frames as Real * dt / period;
            let x = Self::PADDLE_X + amplitude * phase.sin();
            self.world.physics.bodies[self.paddle].set_next_kinematic_translation(Vector::new(
                x,
                0.4,
                0.5 * Self::SIZE.z,
            ));
        }
        self.world.physics.integration_parameters.dt = dt;
        let start = std::time::Instant::now();
        self.world.physics.step();
        let rapier = start.elapsed();
        self.world.step_fluids()?;
        Ok(rapier)
    }

    /// Particles outside the pool's inside (through a wall, or over the paddle's top).
    pub fn outside(&self) -> usize {
        let f = &self.world.fluids[self.water];
        f.positions()
            .iter()
            .filter(|p| p.cmplt(Vector::ZERO).any() || p.cmpgt(Self::SIZE).any())
            .count()
    }

    /// The water's level: the median, over the columns of a grid of two spacings away from
    /// the hull and the paddle's stroke, of each column's highest particle (plus half a
    /// spacing). A median of column tops follows the mean level through waves, where the
    /// topmost particles would follow the crests.
    pub fn water_level(&self) -> Real {
        let f = &self.world.fluids[self.water];
        let hull = self.world.physics.bodies[self.hull].translation();
        let cell = 2.0 * self.spacing;
        let paddle_reach = Self::PADDLE_X + self.config.paddle.0.abs() + 0.1;
        let mut tops = std::collections::BTreeMap::<(i32, i32), Real>::new();
        for p in f.positions() {
            if (p.x - hull.x).abs() < 0.4 || p.x < paddle_reach {
                continue;
            }
            let top = tops
                .entry(((p.x / cell) as i32, (p.z / cell) as i32))
                .or_insert(Real::MIN);
            *top = top.max(p.y);
        }
        let mut tops: Vec<Real> = tops.into_values().collect();
        if tops.is_empty() {
            return Real::NAN;
        }
        tops.sort_by(|a, b| a.total_cmp(b));
        tops[tops.len() / 2] + 0.5 * self.spacing
    }

    /// How deep the hull's lowest point lies under the water's level, over its expected
    /// draft (density ratio × height): 1 is Archimedes' answer.
    pub fn draft_ratio(&self) -> Real {
        let pose = self.world.physics.bodies[self.hull].position();
        let h = Self::HULL_HALF;
        let bottom = (0..8)
            .map(|c| {
                let sign = |b: usize| if c & b == 0 { -1.0 } else { 1.0 };
                pose.transform_point(Vector::new(sign(1) * h.x, sign(2) * h.y, sign(4) * h.z))
                    .y
            })
            .fold(Real::MAX, Real::min);
        let rest_density = self.world.fluids[self.water].params().rest_density;
        let expected = 2.0 * h.y * self.config.hull_density / rest_density;
        (self.water_level() - bottom) / expected
    }

    /// The hull's roll (about the pool's long axis x) and pitch (about z), in degrees.
    pub fn roll_pitch(&self) -> (Real, Real) {
        let r = self.world.physics.bodies[self.hull].rotation();
        let up = *r * Vector::Y;
        (
            up.z.atan2(up.y).to_degrees(),
            (-up.x).atan2(up.y).to_degrees(),
        )
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

mod layered;
pub use layered::{LayeredTank, Start as LayeredStart};
