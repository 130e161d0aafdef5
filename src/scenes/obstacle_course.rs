//! The obstacle course ([`obstacle_course`]): an emitter's stream through a funnel, a paddle
//! wheel, an obstacle, floating crates and into a bucket on a sensor, with a drain below.

use crate::error::{SphError, SphResult};
use crate::fluid::{Fluid, FluidHandle};
use crate::math::{Real, Vector};
use crate::params::FluidParams;
use crate::world::FluidWorld;
use rapier3d::pipeline::PhysicsWorld;
use rapier3d::prelude::{
    Array2, ColliderBuilder, ColliderHandle, Pose, RigidBodyBuilder, RigidBodyHandle, SharedShape,
};

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
