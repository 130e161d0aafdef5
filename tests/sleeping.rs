//! Sleeping fluids (`rapier_sph::sleep`): still water falls asleep, stays bitwise still,
//! and wakes on everything that can move it.

mod common;

use common::on_threads;
use rapier_sph::prelude::*;
use rapier_sph::rapier3d::prelude::{ActiveEvents, ColliderBuilder, RigidBodyBuilder};
use rapier_sph::rapier3d::prelude::{ColliderHandle, RigidBodyHandle};

const SPACING: Real = 0.05;

/// A closed 0.6 × 0.5 × 0.6 m box (walls 5 cm thick) holding a 0.4 × 0.2 × 0.4 m block of
/// water (256 particles), sleeping allowed after `time` s at rest, under `gravity`.
fn tank(gravity: Vector, sleep: Option<Sleep>) -> (FluidWorld, FluidHandle, Vec<ColliderHandle>) {
    let mut world = FluidWorld::new();
    world.physics.gravity = gravity;
    let ground = world.physics.insert_body(RigidBodyBuilder::fixed());
    let (x, y, t) = (0.3, 0.25, 0.05);
    let walls = [
        (Vector::new(x, -t, x), Vector::new(x + t, t, x + t)),
        (Vector::new(-t, y, x), Vector::new(t, y + t, x + t)),
        (Vector::new(2.0 * x + t, y, x), Vector::new(t, y + t, x + t)),
        (Vector::new(x, y, -t), Vector::new(x + t, y + t, t)),
        (Vector::new(x, y, 2.0 * x + t), Vector::new(x + t, y + t, t)),
        (Vector::new(x, 2.0 * y + t, x), Vector::new(x + t, t, x + t)),
    ];
    let handles = walls
        .iter()
        .map(|(c, h)| {
            let co = ColliderBuilder::cuboid(h.x, h.y, h.z)
                .translation(*c)
                .active_events(ActiveEvents::CONTACT_FORCE_EVENTS);
            world.physics.insert_collider(co, Some(ground))
        })
        .collect();
    let params = FluidParamsBuilder::water(SPACING)
        .sleep(sleep)
        .build()
        .unwrap();
    let mut water = Fluid::new(params).unwrap();
    let s = SPACING;
    water
        .add_block(
            Vector::new(0.1 + 0.5 * s, 0.5 * s, 0.1 + 0.5 * s),
            Vector::new(0.4, 0.2, 0.4),
        )
        .unwrap();
    let water = world.fluids.insert(water);
    (world, water, handles)
}

fn quick() -> Sleep {
    Sleep {
        time: 0.1,
        ..Sleep::default()
    }
}

/// Thresholds that put water to sleep after 0.2 s whatever it does.
fn loose() -> Sleep {
    Sleep {
        time: 0.2,
        mean_drift: 100.0,
        max_drift: 100.0,
        density_error: 1.0,
    }
}

/// Steps until the water sleeps; the frames it took.
fn until_asleep(world: &mut FluidWorld, water: FluidHandle, limit: usize) -> usize {
    for frame in 1..=limit {
        world.step().unwrap();
        if world.fluids[water].is_sleeping() {
            return frame;
        }
    }
    panic!("the water did not fall asleep in {limit} frames");
}

fn ball(world: &mut FluidWorld, at: Vector, velocity: Vector) -> RigidBodyHandle {
    let b = world
        .physics
        .insert_body(RigidBodyBuilder::dynamic().translation(at).linvel(velocity));
    world
        .physics
        .insert_collider(ColliderBuilder::ball(0.06).density(800.0), Some(b));
    b
}

#[test]
fn still_water_falls_asleep_and_stays_bitwise_still() {
    let (mut world, water, _) = tank(Vector::ZERO, Some(quick()));
    // 0.1 s at rest at 1/60 s: 6 frames, plus the first frame that measures the speeds.
    let frames = until_asleep(&mut world, water, 8);
    assert!(frames <= 8);
    let n = world.fluids[water].len();
    let hash = world.fluids[water].state_hash();
    for _ in 0..60 {
        let report = world.step().unwrap();
        assert_eq!((report.sleeping, report.substeps), (1, 1));
    }
    assert_eq!(world.fluids[water].state_hash(), hash);
    assert_eq!(world.fluids[water].len(), n);
    let info = world.fluids[water].sleep_info();
    assert!(info.asleep && info.times_asleep == 1);
    // Nothing moved before: nothing was dropped.
    assert_eq!(info.dropped_kinetic_energy, 0.0);
}

/// Water under gravity left alone jitters in place (DFSPH's at a few cm/s) but stops
/// flowing: with the default thresholds it falls asleep, and then stays bitwise still.
#[test]
fn still_water_under_gravity_falls_asleep_with_the_defaults() {
    let (mut world, water, _) = tank(Vector::new(0.0, -9.81, 0.0), Some(Sleep::default()));
    let n = world.fluids[water].len();
    let frames = until_asleep(&mut world, water, 900);
    let info = world.fluids[water].sleep_info();
    println!("asleep after {frames} frames: {info:?}");
    let hash = world.fluids[water].state_hash();
    for _ in 0..30 {
        world.step().unwrap();
    }
    assert_eq!(world.fluids[water].state_hash(), hash);
    assert_eq!(world.fluids[water].len(), n);
    assert!(info.density_error_at_sleep <= Sleep::default().density_error);
}

/// Motion the particles' own threshold (`max_drift`) lets through, and that a mean over the
/// whole fluid would cancel, keeps the water awake: two layers of the zero-gravity block
/// sliding past each other, the top two particle layers at +v along x and the bottom two
/// at −v, `v` twice the speed `mean_drift` allows (0.2 spacings per window, a fifth of
/// `max_drift`). Each layer pair fills its own row of cells of one kernel support, so the
/// cell-averaged drift is the layers' own.
#[test]
fn counter_flowing_layers_keep_the_water_awake() {
    let sleep = quick();
    let (mut world, water, _) = tank(Vector::ZERO, Some(sleep));
    let speed = 2.0 * sleep.mean_drift * SPACING / sleep.time;
    let ys: Vec<Real> = world.fluids[water]
        .positions()
        .iter()
        .map(|x| x.y)
        .collect();
    let split = 2.0 * SPACING;
    for (v, y) in world.fluids[water].velocities_mut().iter_mut().zip(ys) {
        *v = Vector::new(if y > split { speed } else { -speed }, 0.0, 0.0);
    }
    // 0.25 s, 2.5 windows; the block's ends still a kernel support from the walls.
    for _ in 0..15 {
        world.step().unwrap();
        assert!(!world.fluids[water].is_sleeping());
    }
}

#[test]
fn exact_results_without_sleep() {
    let (mut a, wa, _) = tank(Vector::ZERO, None);
    for _ in 0..30 {
        assert_eq!(a.step().unwrap().sleeping, 0);
    }
    assert!(!a.fluids[wa].is_sleeping());
}

/// A ball thrown into sleeping water wakes it in the frame it comes near, and the splash is
/// the splash into water that never slept: this water was exactly at rest when it fell
/// asleep (no velocity dropped), so the two runs see the same particles.
#[test]
fn a_ball_wakes_the_water_and_splashes_as_into_awake_water() {
    let run = |sleep: Option<Sleep>| {
        let (mut world, water, _) = tank(Vector::ZERO, sleep);
        for _ in 0..20 {
            world.step().unwrap();
        }
        assert_eq!(world.fluids[water].is_sleeping(), sleep.is_some());
        let b = ball(
            &mut world,
            Vector::new(0.3, 0.42, 0.3),
            Vector::new(0.0, -1.5, 0.0),
        );
        let mut woke = None;
        for frame in 0..40 {
            world.step().unwrap();
            if woke.is_none() && !world.fluids[water].is_sleeping() {
                woke = Some(frame);
            }
        }
        let f = &world.fluids[water];
        (
            f.kinetic_energy(),
            world.physics.bodies[b].translation(),
            woke,
            f.len(),
        )
    };
    let (e_slept, x_slept, woke, n) = run(Some(quick()));
    let (e_awake, x_awake, _, n_awake) = run(None);
    // The ball starts 0.12 m above the water's level (0.2 m + half a spacing), at 1.5 m/s:
    // it reaches the margin (h + r = 0.125 m) at once.
    assert_eq!(woke, Some(0));
    assert!(e_slept > 1e-3, "the splash moved the water: {e_slept} J");
    assert_eq!(n, n_awake);
    // Same particles at rest, same ball: stepping water exactly at rest changes nothing, so
    // sleeping through those frames gives bitwise the same splash.
    assert_eq!(e_slept, e_awake);
    assert_eq!(x_slept, x_awake);
}

#[test]
fn a_paddle_that_starts_moving_wakes_the_water() {
    let (mut world, water, _) = tank(Vector::ZERO, Some(quick()));
    let paddle = world.physics.insert_body(
        RigidBodyBuilder::kinematic_position_based().translation(Vector::new(0.08, 0.15, 0.3)),
    );
    world
        .physics
        .insert_collider(ColliderBuilder::cuboid(0.01, 0.1, 0.2), Some(paddle));
    until_asleep(&mut world, water, 30);
    for _ in 0..10 {
        world.step().unwrap();
        assert!(world.fluids[water].is_sleeping());
    }
    for k in 1..=5 {
        let x = 0.08 + 0.01 * k as Real; // 0.6 m/s into the water
        world.physics.bodies[paddle].set_next_kinematic_translation(Vector::new(x, 0.15, 0.3));
        world.step().unwrap();
        assert!(!world.fluids[water].is_sleeping());
    }
    assert!(world.fluids[water].kinetic_energy() > 0.0);
}

#[test]
fn an_emitter_wakes_the_water() {
    let (mut world, water, _) = tank(Vector::ZERO, Some(quick()));
    until_asleep(&mut world, water, 30);
    let n = world.fluids[water].len();
    let nozzle = Nozzle::Disk { radius: 0.05 };
    let down = Vector::new(0.0, -1.0, 0.0);
    let emitter = Emitter::new(nozzle, Vector::new(0.3, 0.42, 0.3), down, 0.5, 200.0);
    world.fluids[water].add_emitter(emitter).unwrap();
    world.step().unwrap();
    world.step().unwrap();
    assert!(world.fluids[water].len() > n);
    assert!(!world.fluids[water].is_sleeping());
}

#[test]
fn edits_gravity_and_removed_walls_wake_the_water() {
    type Edit = fn(&mut FluidWorld, FluidHandle, &[ColliderHandle]);
    let edits: [(&str, Edit); 5] = [
        ("velocities_mut", |w, f, _| {
            w.fluids[f].velocities_mut()[0].y = 0.1;
        }),
        ("set_params", |w, f, _| {
            let p = w.fluids[f].params().clone();
            w.fluids[f].set_params(p).unwrap();
        }),
        ("wake_up", |w, f, _| w.fluids[f].wake_up()),
        ("gravity", |w, _, _| {
            w.physics.gravity = Vector::new(0.0, -1.0, 0.0)
        }),
        ("a wall removed", |w, _, walls| {
            w.physics.remove_collider(walls[1]);
        }),
    ];
    for (name, edit) in edits {
        let (mut world, water, walls) = tank(Vector::ZERO, Some(quick()));
        until_asleep(&mut world, water, 30);
        world.step().unwrap();
        edit(&mut world, water, &walls);
        let report = world.step().unwrap();
        assert_eq!(report.sleeping, 0, "{name} did not wake the water");
    }
}

/// A sleeping fluid keeps pressing on the walls: the recorded forces stay those of the last
/// frame it was awake (not zero). A loose speed threshold puts this water to sleep while it
/// still sloshes a little.
#[test]
fn forces_on_watched_colliders_persist_while_asleep() {
    let loose = loose();
    let (mut world, water, walls) = tank(Vector::new(0.0, -9.81, 0.0), Some(loose));
    let mut last_awake = None;
    for _ in 0..60 {
        world.step().unwrap();
        if world.fluids[water].is_sleeping() {
            break;
        }
        last_awake = Some(world.pipeline.collider_force(walls[0]).unwrap().force);
    }
    assert!(world.fluids[water].is_sleeping());
    let info = world.fluids[water].sleep_info();
    assert!(info.dropped_kinetic_energy >= 0.0 && info.dropped_max_speed > 0.0);
    // The frame it fell asleep in was stepped: its force is that frame's.
    let at_sleep = world.pipeline.collider_force(walls[0]).unwrap().force;
    assert!(last_awake.is_some());
    // Water of 0.4 × 0.2 × 0.4 m weighs 314 N: the floor carries it (more while the water
    // still sloshes, as here after 0.2 s).
    let weight = 1000.0 * 0.4 * 0.2 * 0.4 * 9.81;
    assert!(at_sleep.y < -0.5 * weight, "{at_sleep:?}");
    for _ in 0..20 {
        world.step().unwrap();
        assert!(world.fluids[water].is_sleeping());
        assert_eq!(
            world.pipeline.collider_force(walls[0]).unwrap().force,
            at_sleep
        );
    }
}

#[test]
fn sleeping_is_the_same_on_one_and_two_threads() {
    let run = |threads: usize| {
        on_threads(threads, || {
            let (mut world, water, _) = tank(Vector::new(0.0, -9.81, 0.0), Some(loose()));
            let mut hashes = Vec::new();
            for frame in 0..60 {
                if frame == 30 {
                    ball(
                        &mut world,
                        Vector::new(0.3, 0.42, 0.3),
                        Vector::new(0.0, -1.5, 0.0),
                    );
                }
                world.step().unwrap();
                hashes.push((
                    world.fluids[water].state_hash(),
                    world.fluids[water].is_sleeping(),
                ));
            }
            hashes
        })
    };
    let one = run(1);
    assert!(one.iter().any(|h| h.1), "it never slept");
    assert!(!one.last().unwrap().1, "the ball did not wake it");
    assert_eq!(one, run(2));
}

/// A box floating on water that falls asleep sleeps with it in rapier (one island): it stays
/// where its buoyancy held it, and a ball falling near wakes both.
#[test]
fn a_floating_body_sleeps_with_the_water_and_wakes_with_it() {
    let (mut world, water, _) = tank(Vector::new(0.0, -9.81, 0.0), Some(loose()));
    let float = world
        .physics
        .insert_body(RigidBodyBuilder::dynamic().translation(Vector::new(0.3, 0.2, 0.3)));
    world.physics.insert_collider(
        ColliderBuilder::cuboid(0.08, 0.04, 0.08).density(500.0),
        Some(float),
    );
    until_asleep(&mut world, water, 60);
    assert!(world.physics.bodies[float].is_sleeping());
    let at = *world.physics.bodies[float].position();
    for _ in 0..60 {
        world.step().unwrap();
        assert!(world.fluids[water].is_sleeping());
    }
    assert!(world.physics.bodies[float].is_sleeping());
    assert_eq!(*world.physics.bodies[float].position(), at);
    ball(
        &mut world,
        Vector::new(0.15, 0.45, 0.15),
        Vector::new(0.0, -1.5, 0.0),
    );
    for _ in 0..10 {
        world.step().unwrap();
    }
    assert!(!world.fluids[water].is_sleeping());
}

/// A snapshot carries the sleep state: restored, the water sleeps on, and a ball thrown in
/// splashes as in the run that never stopped.
#[cfg(feature = "snapshot")]
#[test]
fn a_snapshot_carries_the_sleep_state() {
    let (mut world, water, _) = tank(Vector::ZERO, Some(quick()));
    until_asleep(&mut world, water, 30);
    let bytes = rapier_sph::snapshot::to_bytes(&world).unwrap();
    let mut restored = rapier_sph::snapshot::from_bytes(&bytes).unwrap();
    let (_, again) = restored.fluids.iter().next().unwrap();
    assert!(again.is_sleeping());
    assert_eq!(again.sleep_info(), world.fluids[water].sleep_info());
    let mut hashes = Vec::new();
    for w in [&mut world, &mut restored] {
        ball(w, Vector::new(0.3, 0.42, 0.3), Vector::new(0.0, -1.5, 0.0));
        for _ in 0..20 {
            w.step().unwrap();
        }
        let (_, f) = w.fluids.iter().next().unwrap();
        hashes.push(f.state_hash());
    }
    assert_eq!(hashes[0], hashes[1]);
}

/// The game pool (`scenes::WavePool`, 2,604 particles at 5.8 cm, the water preset) with its
/// paddle still and, unless `hull`, its hull removed and the water it displaced put back;
/// the water may sleep with the default thresholds.
fn still_pool(hull: bool) -> rapier_sph::scenes::WavePool {
    use rapier_sph::scenes::{WavePool, WavePoolConfig};
    let config = WavePoolConfig {
        particles: 2500,
        params: |s| FluidParamsBuilder::water(s).sleep(Sleep::default()).build(),
        paddle: (0.0, 1.5),
        ..Default::default()
    };
    let mut pool = WavePool::new(config).unwrap();
    if !hull {
        pool.remove_hull().unwrap();
    }
    pool
}

/// Frames until the pool's water falls asleep (at most `limit`; `None`: it did not).
fn pool_asleep_after(pool: &mut rapier_sph::scenes::WavePool, limit: usize) -> Option<usize> {
    (1..=limit).find(|_| {
        pool.frame().unwrap();
        pool.world.fluids[pool.water].is_sleeping()
    })
}

/// The still game pool without its hull settles (the start's slosh dies out) and falls
/// asleep with the default thresholds (after about 4 s here, docs/performance.md); a ball
/// dropped from 0.3 m above it wakes it before it reaches the water (within the margin the
/// wake test looks around the fluid: a kernel support, a particle radius and a frame's
/// fall), not earlier: the water sleeps through every frame before.
#[test]
fn the_still_game_pool_falls_asleep_and_a_falling_ball_wakes_it() {
    let mut pool = still_pool(false);
    let frames = pool_asleep_after(&mut pool, 20 * 60);
    assert!(frames.is_some(), "the pool did not fall asleep in 20 s");
    let info = pool.world.fluids[pool.water].sleep_info();
    assert!(info.density_error_at_sleep <= Sleep::default().density_error);
    let (r, s) = (0.05, pool.spacing);
    let top = |pool: &rapier_sph::scenes::WavePool| {
        let f = &pool.world.fluids[pool.water];
        f.positions().iter().map(|x| x.y).fold(Real::MIN, Real::max)
    };
    let surface = top(&pool);
    let at = Vector::new(1.0, surface + 0.3 + r, 0.35);
    let ball = pool
        .world
        .physics
        .insert_body(RigidBodyBuilder::dynamic().translation(at));
    let collider = ColliderBuilder::ball(r).density(500.0);
    pool.world.physics.insert_collider(collider, Some(ball));
    let p = pool.world.fluids[pool.water].params().clone();
    let dt: Real = 1.0 / 60.0;
    let margin = p.smoothing_length + p.particle_radius + 9.81 * dt * dt;
    let mut woke = None;
    for frame in 1..=60 {
        pool.frame().unwrap();
        if !pool.world.fluids[pool.water].is_sleeping() {
            woke = Some(frame);
            break;
        }
        // Asleep: its particles have not moved.
        assert_eq!(top(&pool), surface);
    }
    assert!(woke.is_some(), "the ball did not wake the pool");
    // rapier moved the ball before the fluid's step: its bottom at the frame it woke the
    // water is above the water and within the margin (plus one frame's fall at most).
    let bottom = pool.world.physics.bodies[ball].translation().y - r;
    let speed = pool.world.physics.bodies[ball].linvel().length();
    assert!(
        bottom > surface - 0.5 * s && bottom - surface <= margin + speed * dt,
        "woke with the ball's bottom {:.3} m above the top particle (margin {margin:.3})",
        bottom - surface
    );
}

/// The same pool with its hull floating settles too (nothing does work on it) and falls
/// asleep with the default thresholds (after about 5 s, as without the hull;
/// docs/performance.md, "Sleeping water"). It did not while the coupling's exchange gave the
/// water under the hull the fluid's lift of the hull every substep without the fall rapier
/// gave it (`Coupling::exchange`): the water's kinetic energy stayed at about 2 J and the
/// water kept moving (0.5–0.6 spacings root-mean-square over 0.5 s).
#[test]
fn the_still_game_pool_with_its_floating_hull_falls_asleep() {
    let mut pool = still_pool(true);
    assert!(
        pool_asleep_after(&mut pool, 20 * 60).is_some(),
        "the pool with its hull did not fall asleep in 20 s"
    );
}

/// Nothing does work on the still pool with its floating hull (the paddle stands still), so
/// once the start's slosh has spread through it the water's kinetic energy can only fall:
/// its mean over seconds 8–10 is below its mean over seconds 4–6 (sleep off). A coupling
/// that feeds the water (the exchange giving the particles under the hull a velocity the
/// hull never had, every substep) holds it flat or rising instead: 1.8–2.0 J from 5 to 10
/// s, while without that pump it falls from 0.82 J at 5 s to 0.52 J at 10 s
/// (`cargo run --release --example pool_energy`).
#[test]
fn the_floating_hull_does_not_pump_energy_into_the_still_pool() {
    use rapier_sph::scenes::{WavePool, WavePoolConfig};
    let config = WavePoolConfig {
        particles: 2500,
        params: |s| FluidParamsBuilder::water(s).build(),
        paddle: (0.0, 1.5),
        ..Default::default()
    };
    let mut pool = WavePool::new(config).unwrap();
    let (mut early, mut late) = (0.0f64, 0.0f64);
    for frame in 1..=600 {
        pool.frame().unwrap();
        let ke = pool.world.fluids[pool.water].kinetic_energy();
        match frame {
            241..=360 => early += ke / 120.0,
            481..=600 => late += ke / 120.0,
            _ => {}
        }
    }
    eprintln!("water kinetic energy: {early:.4} J over 4-6 s, {late:.4} J over 8-10 s");
    assert!(
        late < early,
        "the still pool gained kinetic energy: {early:.4} J over 4-6 s, {late:.4} J over 8-10 s"
    );
}

/// The still game pool with its floating hull (2,556 particles, the water preset, default
/// thresholds) falls asleep with its hull asleep in rapier (one island), and stays so; a
/// ball dropped from 0.3 m beside the hull wakes the water before it reaches it, and the
/// water's push wakes the hull. Three seconds after the drop the ball and the hull float
/// as high as they float in the same pool never put to sleep (sleep off, the ball dropped at
/// the same frame), within one spacing (the resolution of the water's surface): falling
/// asleep froze every particle within `max_drift` (one spacing) of where the awake water had
/// it over the window, and dropped only the jitter's velocities (docs/performance.md,
/// "Sleeping water", has the measured differences). Heights, not positions: where on the
/// surface the ball drifts after its splash is not determined by the water's jitter-level
/// state (one second after the drop the two balls were 7 cm apart).
#[test]
fn the_pool_and_its_hull_sleep_together_and_a_ball_wakes_both() {
    use rapier_sph::scenes::{WavePool, WavePoolConfig};
    let mut pool = still_pool(true);
    let asleep = pool_asleep_after(&mut pool, 20 * 60).expect("the pool did not fall asleep");
    assert!(pool.world.physics.bodies[pool.hull].is_sleeping());
    let hull_at = *pool.world.physics.bodies[pool.hull].position();
    for _ in 0..30 {
        pool.frame().unwrap();
        assert!(pool.world.fluids[pool.water].is_sleeping());
    }
    assert!(pool.world.physics.bodies[pool.hull].is_sleeping());
    assert_eq!(*pool.world.physics.bodies[pool.hull].position(), hull_at);
    let drop_frame = asleep + 30;

    // The same pool, never asleep, to the same frame.
    let config = WavePoolConfig {
        particles: 2500,
        params: |s| FluidParamsBuilder::water(s).build(),
        paddle: (0.0, 1.5),
        ..Default::default()
    };
    let mut awake = WavePool::new(config).unwrap();
    for _ in 0..drop_frame {
        awake.frame().unwrap();
    }

    let r = 0.05;
    let at = Vector::new(0.7, WavePool::DEPTH + 0.3 + r, 0.35);
    let drop = |pool: &mut WavePool| {
        let ball = pool
            .world
            .physics
            .insert_body(RigidBodyBuilder::dynamic().translation(at));
        let collider = ColliderBuilder::ball(r).density(500.0);
        pool.world.physics.insert_collider(collider, Some(ball));
        ball
    };
    let (ball, awake_ball) = (drop(&mut pool), drop(&mut awake));
    let (mut water_woke, mut hull_woke) = (None, None);
    for frame in 1..=180 {
        pool.frame().unwrap();
        awake.frame().unwrap();
        if water_woke.is_none() && !pool.world.fluids[pool.water].is_sleeping() {
            water_woke = Some(frame);
        }
        if hull_woke.is_none() && !pool.world.physics.bodies[pool.hull].is_sleeping() {
            hull_woke = Some(frame);
        }
    }
    let (water_woke, hull_woke) = (water_woke.unwrap(), hull_woke.expect("the hull slept on"));
    assert!(water_woke <= hull_woke, "{water_woke} {hull_woke}");
    let s = pool.spacing;
    let y = |p: &WavePool, b: RigidBodyHandle| p.world.physics.bodies[b].translation().y;
    let (ball_gap, hull_gap) = (
        (y(&pool, ball) - y(&awake, awake_ball)).abs(),
        (y(&pool, pool.hull) - y(&awake, awake.hull)).abs(),
    );
    eprintln!(
        "asleep after {asleep} frames; after the drop the water woke at frame {water_woke}, the hull at {hull_woke}; 3 s after: the ball {:.6} m, the hull {:.6} m higher or lower than in the awake run (spacing {s:.4} m)",
        ball_gap, hull_gap
    );
    assert!(ball_gap <= s && hull_gap <= s, "{ball_gap} {hull_gap}");
}
