//! What reading forces, touch events and water queries costs: a pool of water at rest in a
//! tank with four fixed pillars standing in it, stepped on one thread with nothing watched,
//! with the forces of the 9 colliders watched (`ActiveEvents::CONTACT_FORCE_EVENTS`), with
//! their touch events (`COLLISION_EVENTS`), and with both; then the queries a game makes
//! every frame. Medians of the frames (robust to a shared machine's preemptions).
//!
//! ```text
//! cargo run --release --example collider_forces_cost -- [spacing] [frames]
//! ```
//!
//! Each run prints its state hash: equal to the unwatched run's (watching reads the step and
//! changes none of it).
//!
//! Measured (2-core VM, load about 4.5, two runs): nothing watched 16.1–16.3 ms/frame; forces
//! of the 9 colliders +1.1–1.2 ms (120–130 µs per collider, ~200 ns per particle of the
//! pool); their touch events +0.6 ms; both +1.7–1.8 ms. `WaterSurface::new` 94 µs (16 ns per
//! particle), a height 80–100 ns, a boat's submerged volume 7 µs, `FluidSampler::new`
//! 100 µs, `velocity_at` about 2 µs (4 µs at load 11).

use rapier_sph::math::{Real, Vector};
use rapier_sph::prelude::*;
use rapier_sph::query::WaterSurface;
use rapier_sph::rapier3d::prelude::{ActiveEvents, ColliderBuilder, ColliderHandle};
use std::hash::{Hash, Hasher};
use std::time::Instant;

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The tank (1 × 1 m, 0.4 m of water at spacing `s`) and its pillars, every collider with
/// `flags`.
fn pool(s: Real, flags: ActiveEvents) -> (FluidWorld, FluidHandle, Vec<ColliderHandle>) {
    let mut world = FluidWorld::new();
    let t = 0.1;
    let p = &mut world.physics;
    let mut colliders = vec![p.insert_collider(
        ColliderBuilder::cuboid(0.5 + t, 0.5 * t, 0.5 + t).translation(Vector::new(
            0.5,
            -0.5 * t,
            0.5,
        )),
        None,
    )];
    for (x, z, hx, hz) in [
        (-0.5 * t, 0.5, 0.5 * t, 0.6),
        (1.0 + 0.5 * t, 0.5, 0.5 * t, 0.6),
        (0.5, -0.5 * t, 0.6, 0.5 * t),
        (0.5, 1.0 + 0.5 * t, 0.6, 0.5 * t),
    ] {
        colliders.push(p.insert_collider(
            ColliderBuilder::cuboid(hx, 0.5, hz).translation(Vector::new(x, 0.5, z)),
            None,
        ));
    }
    for (x, z) in [(0.3, 0.3), (0.7, 0.3), (0.3, 0.7), (0.7, 0.7)] {
        colliders.push(p.insert_collider(
            ColliderBuilder::cylinder(0.4, 0.06).translation(Vector::new(x, 0.4, z)),
            None,
        ));
    }
    for &c in &colliders {
        p.colliders[c].set_active_events(flags);
    }
    let mut fluid = Fluid::new(FluidParamsBuilder::water(s).build().unwrap()).unwrap();
    let n = (1.0 / s).round() as usize;
    let pillars = |x: &Vector| {
        [(0.3, 0.3), (0.7, 0.3), (0.3, 0.7), (0.7, 0.7)]
            .iter()
            .any(|&(cx, cz)| (x.x - cx).hypot(x.z - cz) < 0.06 + 0.5 * s)
    };
    let lattice: Vec<Vector> =
        rapier_sph::fluid::lattice(Vector::splat(0.5 * s), n, (0.4 / s).round() as usize, n, s)
            .into_iter()
            .filter(|x| !pillars(x))
            .collect();
    fluid.add_particles(&lattice).unwrap();
    let fluid = world.fluids.insert(fluid);
    (world, fluid, colliders)
}

/// Median frame time (ms) over `frames` frames after 30 to settle, and the end state's hash.
fn run(s: Real, frames: usize, flags: ActiveEvents) -> (f64, u64, usize) {
    let (mut world, fluid, colliders) = pool(s, flags);
    for _ in 0..30 {
        world.step().unwrap();
    }
    let mut times = Vec::new();
    let mut read = 0.0f64;
    for _ in 0..frames {
        world.physics.step();
        let t0 = Instant::now();
        world.step_fluids().unwrap();
        times.push(t0.elapsed().as_secs_f64() * 1e3);
        // What a game reads every frame: each collider's force, or its events and touches.
        for &c in &colliders {
            if let Ok(f) = world.pipeline.collider_force(c) {
                read += f.force.y as f64;
            }
            if let Ok(ids) = world.pipeline.touching(fluid, c) {
                read += ids.len() as f64;
            }
        }
    }
    let f = &world.fluids[fluid];
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for x in f.positions() {
        x.x.to_bits().hash(&mut h);
        x.y.to_bits().hash(&mut h);
        x.z.to_bits().hash(&mut h);
    }
    std::hint::black_box(read);
    (median(&mut times), h.finish(), f.len())
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let s: Real = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(0.04);
    let frames: usize = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(60);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    pool.install(|| {
        let (base, hash, n) = run(s, frames, ActiveEvents::empty());
        println!("{n} particles, 9 colliders, one thread, median of {frames} frames");
        println!("nothing watched:           {base:8.3} ms/frame  hash {hash:016x}");
        for (name, flags) in [
            ("forces of 9 colliders:", ActiveEvents::CONTACT_FORCE_EVENTS),
            ("touch events of 9:", ActiveEvents::COLLISION_EVENTS),
            ("both:", ActiveEvents::CONTACT_FORCE_EVENTS | ActiveEvents::COLLISION_EVENTS),
        ] {
            let (t, hash, _) = run(s, frames, flags);
            println!(
                "{name:26} {t:8.3} ms/frame  hash {hash:016x}  (+{:.3} ms: {:.1} µs per collider, {:.1} ns per particle)",
                t - base,
                (t - base) * 1e3 / 9.0,
                (t - base) * 1e6 / n as f64
            );
        }
        queries(s);
    });
}

/// The per-frame queries: build the surface map and the sampler, then heights, depths,
/// velocities and a boat's submerged volume.
fn queries(s: Real) {
    let (mut world, fluid, _) = pool(s, ActiveEvents::empty());
    for _ in 0..30 {
        world.step().unwrap();
    }
    let boat = world.physics.insert_collider(
        ColliderBuilder::cuboid(0.15, 0.05, 0.1).translation(Vector::new(0.5, 0.4, 0.5)),
        None,
    );
    let f = &world.fluids[fluid];
    let n = f.len();
    let time = |reps: usize, mut work: Box<dyn FnMut(usize) -> f64 + '_>| {
        let mut v: Vec<f64> = (0..7)
            .map(|_| {
                let t0 = Instant::now();
                let mut acc = 0.0;
                for k in 0..reps {
                    acc += work(k);
                }
                std::hint::black_box(acc);
                t0.elapsed().as_secs_f64() / reps as f64
            })
            .collect();
        median(&mut v)
    };
    let build = time(
        5,
        Box::new(|_| {
            WaterSurface::new(f)
                .height(0.5, 0.5)
                .unwrap()
                .unwrap_or(0.0) as f64
        }),
    );
    let surface = WaterSurface::new(f);
    let point = |k: usize| {
        (
            (k * 7919 % 1000) as Real / 1000.0,
            (k * 104729 % 1000) as Real / 1000.0,
        )
    };
    let height = time(
        100_000,
        Box::new(|k| {
            let (x, z) = point(k);
            surface.height(x, z).unwrap().unwrap_or(0.0) as f64
        }),
    );
    let volume = time(
        200,
        Box::new(|_| {
            surface
                .submerged_volume(boat, &world.physics.colliders)
                .unwrap() as f64
        }),
    );
    let sampler_build = time(
        5,
        Box::new(|_| {
            FluidSampler::new(f)
                .velocity_at(Vector::splat(0.5))
                .unwrap()
                .map_or(0.0, |v| v.x as f64)
        }),
    );
    let sampler = FluidSampler::new(f);
    let velocity = time(
        100_000,
        Box::new(|k| {
            let (x, z) = point(k);
            sampler
                .velocity_at(Vector::new(x, 0.2, z))
                .unwrap()
                .map_or(0.0, |v| v.x as f64)
        }),
    );
    println!("queries ({n} particles):");
    println!(
        "  WaterSurface::new         {:8.1} µs ({:.1} ns per particle)",
        build * 1e6,
        build * 1e9 / n as f64
    );
    println!("  height / depth at (x, z)  {:8.1} ns", height * 1e9);
    println!("  submerged_volume (boat)   {:8.1} µs", volume * 1e6);
    println!(
        "  FluidSampler::new         {:8.1} µs ({:.1} ns per particle)",
        sampler_build * 1e6,
        sampler_build * 1e9 / n as f64
    );
    println!("  velocity_at               {:8.1} ns", velocity * 1e9);
}
