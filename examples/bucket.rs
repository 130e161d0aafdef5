//! Fill the bucket: a player carries a bucket (a kinematic body) under a hose on a swinging
//! pipe (an emitter attached to a kinematic body), jerks it sideways by 10 cm in one frame,
//! then the level teleports it 1 m away (`RigidBody::set_position`: the water goes with it).
//! Every half second it prints how much water is in the bucket, its fill level, the touch
//! events of the bucket's floor (rapier's `ActiveEvents::COLLISION_EVENTS`), the fastest
//! particle and the substeps.
//!
//! ```text
//! cargo run --release --example bucket                       # headless, 6 s
//! cargo run --release --example bucket -- --render out/bucket   # also a GIF and PNG frames
//! ```

use rapier_sph::math::{Real, Vector};
use rapier_sph::prelude::*;
use rapier_sph::rapier3d::prelude::{
    ActiveEvents, ColliderBuilder, ColliderHandle, RigidBodyBuilder, RigidBodyHandle,
};
use rapier_sph::render::{Camera, Recorder, RenderOptions};
use rapier_sph::{Attachment, FluidContactKind};
use std::path::PathBuf;

/// Inside of the bucket (half widths) and its wall thickness, in the bucket's frame (its
/// floor's top at y = 0).
const INNER: Real = 0.15;
const HEIGHT: Real = 0.25;
const WALL: Real = 0.015;
const SPACING: Real = 0.025;
/// When the bucket is jerked and when it is teleported (s).
const JERK_AT: Real = 3.0;
const TELEPORT_AT: Real = 4.5;
const SECONDS: Real = 6.0;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let render = parse_render()?;
    let mut scene = Scene::new()?;
    println!(
        "bucket: water at {} mm (DFSPH) from a hose on a moving pipe into a {:.0} cm bucket \
         carried at 0.3 m/s; jerked 10 cm at {JERK_AT} s, teleported 1 m at {TELEPORT_AT} s",
        SPACING * 1e3,
        2.0 * INNER * 100.0
    );
    println!(
        "{:>5} {:>9} {:>10} {:>11} {:>16} {:>12} {:>9}",
        "t (s)",
        "particles",
        "in bucket",
        "level (cm)",
        "floor touched by",
        "fastest m/s",
        "substeps"
    );
    let mut pictures = render
        .as_ref()
        .map(|dir| pictures(dir, "bucket"))
        .transpose()?;
    let (mut started, mut stopped) = (0, 0);
    let frames = (SECONDS * 60.0) as usize;
    for frame in 1..=frames {
        let t = frame as Real / 60.0;
        scene.move_bucket(t);
        let report = scene.world.step()?;
        let (fastest, substeps) = (report.max_speed, report.substeps);
        for e in scene.world.pipeline.contact_events() {
            match e.kind {
                FluidContactKind::Started => started += 1,
                FluidContactKind::Stopped => stopped += 1,
            }
        }
        if let Some(p) = pictures.as_mut()
            && frame % 6 == 0
        {
            p.frame(&scene.world)?;
        }
        if frame % 30 == 0 {
            let (inside, level) = scene.contents();
            let touching = scene
                .world
                .pipeline
                .touching(scene.water, scene.floor)?
                .len();
            println!(
                "{t:>5.2} {:>9} {inside:>10} {:>11.1} {touching:>16} {fastest:>12.2} {substeps:>9}",
                scene.world.fluids[scene.water].len(),
                level * 100.0
            );
        }
    }
    let fluid = &scene.world.fluids[scene.water];
    println!(
        "emitted {}, {} particles now, {} drained off the ground's edges ({} lost); the floor's \
         touch events: {started} started, {stopped} stopped",
        fluid.emitted(),
        fluid.len(),
        fluid.drained(),
        fluid.emitted() as i64
            - fluid.len() as i64
            - fluid.drained() as i64
            - fluid.quarantined() as i64
            - fluid.removed() as i64
    );
    if let (Some(p), Some(dir)) = (pictures, render.as_ref()) {
        p.finish()?;
        println!(
            "pictures  {}/frame_*.png and bucket.gif (10 frames a second)",
            dir.display()
        );
    }
    Ok(())
}

fn parse_render() -> Result<Option<PathBuf>, String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.as_slice() {
        [] => Ok(None),
        [flag, dir] if flag == "--render" => Ok(Some(PathBuf::from(dir))),
        _ => Err("usage: bucket [--render DIR]".into()),
    }
}

struct Scene {
    world: FluidWorld,
    water: FluidHandle,
    bucket: RigidBodyHandle,
    floor: ColliderHandle,
    /// Where the player first holds the bucket (its floor's center).
    home: Vector,
    teleported: bool,
}

impl Scene {
    fn new() -> SphResult<Self> {
        let mut world = FluidWorld::new();
        let ground = world.physics.insert_body(RigidBodyBuilder::fixed());
        world
            .physics
            .insert_collider(ColliderBuilder::cuboid(2.5, 0.05, 1.5), Some(ground));
        let home = Vector::new(-0.6, 0.3, 0.0);
        let bucket = world
            .physics
            .insert_body(RigidBodyBuilder::kinematic_position_based().translation(home));
        let floor = world.physics.insert_collider(
            ColliderBuilder::cuboid(INNER + WALL, WALL / 2.0, INNER + WALL)
                .translation(Vector::new(0.0, -WALL / 2.0, 0.0))
                .active_events(ActiveEvents::COLLISION_EVENTS),
            Some(bucket),
        );
        for (c, h) in [
            (
                Vector::X,
                Vector::new(WALL / 2.0, HEIGHT / 2.0, INNER + WALL),
            ),
            (
                Vector::NEG_X,
                Vector::new(WALL / 2.0, HEIGHT / 2.0, INNER + WALL),
            ),
            (Vector::Z, Vector::new(INNER, HEIGHT / 2.0, WALL / 2.0)),
            (Vector::NEG_Z, Vector::new(INNER, HEIGHT / 2.0, WALL / 2.0)),
        ] {
            let at = c * (INNER + WALL / 2.0) + Vector::Y * (HEIGHT / 2.0);
            world.physics.insert_collider(
                ColliderBuilder::cuboid(h.x, h.y, h.z).translation(at),
                Some(bucket),
            );
        }
        // The pipe: a kinematic body 0.55 m above the bucket, moving along with the player.
        let pipe = world.physics.insert_body(
            RigidBodyBuilder::kinematic_velocity_based()
                .translation(home + Vector::new(0.0, 0.55, 0.0))
                .linvel(Vector::new(0.3, 0.0, 0.0)),
        );
        world
            .physics
            .insert_collider(ColliderBuilder::capsule_x(0.1, 0.02), Some(pipe));
        let mut water = Fluid::new(FluidParamsBuilder::water(SPACING))?;
        let hose = water.add_emitter(Emitter::new(
            Nozzle::Disk { radius: 0.03 },
            Vector::new(0.0, -0.05, 0.0),
            Vector::NEG_Y,
            1.0,
            1.0,
        ))?;
        let rate = 0.6 * water.emitter(hose).expect("just added").max_rate(SPACING);
        water
            .emitter_mut(hose)
            .expect("just added")
            .set_rate(rate)?;
        water.attach_emitter(
            hose,
            Attachment::Body(pipe),
            &world.physics.bodies,
            &world.physics.colliders,
        )?;
        // Water thrown off the ground's edges is drained 1 m below it (and counted).
        water.add_sink(Sink::new(Region::Aabb {
            min: Vector::splat(-100.0),
            max: Vector::new(100.0, -1.0, 100.0),
        }))?;
        let water = world.fluids.insert(water);
        Ok(Self {
            world,
            water,
            bucket,
            floor,
            home,
            teleported: false,
        })
    }

    /// The player walks the bucket along x at 0.3 m/s under the pipe; at `JERK_AT` the
    /// target jumps 10 cm along z in one frame; at `TELEPORT_AT` the level puts the bucket
    /// 1 m further along z with `set_position`.
    fn move_bucket(&mut self, t: Real) {
        let walk = self.home + Vector::new(0.3 * t, 0.0, 0.0);
        let jerk = if t >= JERK_AT { 0.1 } else { 0.0 };
        let target = walk + Vector::new(0.0, 0.0, jerk);
        let body = &mut self.world.physics.bodies[self.bucket];
        if t >= TELEPORT_AT && !self.teleported {
            self.teleported = true;
            let there = walk + Vector::new(0.0, 0.0, jerk - 1.0);
            body.set_position(rapier_sph::math::Pose::from_translation(there), true);
        } else {
            let shift = if self.teleported { -1.0 } else { 0.0 };
            body.set_next_kinematic_translation(target + Vector::new(0.0, 0.0, shift));
        }
    }

    /// Particles inside the bucket (in its frame, below its rim) and the fill level (their
    /// volume at rest density over the floor's area).
    fn contents(&self) -> (usize, Real) {
        let pose = self.world.physics.bodies[self.bucket].position();
        let fluid = &self.world.fluids[self.water];
        let inside = fluid
            .positions()
            .iter()
            .map(|x| pose.inverse_transform_point(*x))
            .filter(|l| l.x.abs() < INNER && l.z.abs() < INNER && l.y > 0.0 && l.y < HEIGHT)
            .count();
        let volume = inside as Real * SPACING.powi(3);
        (inside, volume / (2.0 * INNER).powi(2))
    }
}

/// Pictures of every sixth frame (10 a second): `DIR/frame_*.png` and `DIR/bucket.gif`.
fn pictures(dir: &PathBuf, name: &str) -> Result<Recorder, Box<dyn std::error::Error>> {
    let options = RenderOptions {
        width: 480,
        height: 270,
        ..RenderOptions::default()
    };
    let camera = Camera::framing(
        Vector::new(-0.9, 0.0, -1.3),
        Vector::new(1.3, 0.9, 0.3),
        25.0,
        32.0,
    );
    Ok(Recorder::create(dir, name, options, camera, 0.0, 10)?)
}
