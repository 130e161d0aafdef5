//! Per-stage median step times of the water dam break (fixed acoustic dt, one thread by
//! default): medians are robust to the preemptions of a shared machine, where sums are not.
//!
//! ```text
//! cargo run --release --example stage_medians -- 2500 1000 [threads] [solver] [walls] [box]
//! ```
//!
//! `solver` is `wcsph` (default), `dfsph`, `pbf` or `clavet`; `walls` is `true` or `false`
//! (default: false), whether the walls count in the density; `box` (`true`: a dynamic box
//! of 500 kg/m³ floats on the column and rapier steps with the fluid) runs contact with a
//! moving body. The last line is a hash of the run's end state: equal hashes, bitwise equal
//! runs.

use rapier_sph::scenes::{DamBreakConfig, dam_break};
use rapier_sph::{FluidParamsBuilder, Solver, Stage};
use std::time::Instant;

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let particles: usize = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(2500);
    let steps: usize = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(1000);
    let threads: usize = args.get(3).and_then(|a| a.parse().ok()).unwrap_or(1);
    let solver = match args.get(4).map_or("wcsph", String::as_str) {
        "wcsph" => Solver::Wcsph,
        "dfsph" => Solver::Dfsph(Default::default()),
        "pbf" => Solver::Pbf(Default::default()),
        "clavet" => Solver::Clavet(Default::default()),
        other => panic!("unknown solver {other}: wcsph, dfsph, pbf or clavet"),
    };
    let walls: bool = args.get(5).is_some_and(|a| a == "true");
    let floating_box: bool = args.get(6).is_some_and(|a| a == "true");
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let params = FluidParamsBuilder::water(0.02)
            .solver(solver)
            .wall_density(walls)
            .build()
            .unwrap();
        let config = DamBreakConfig::tower(params.clone(), DamBreakConfig::scale_for(particles));
        let mut scene = dam_break(&config).unwrap();
        if floating_box {
            use rapier_sph::rapier3d::prelude::*;
            let half = 0.25 * scene.column_width;
            let center = Vector::new(
                0.5 * scene.column_width,
                scene.column_height,
                0.5 * scene.tank_max.z,
            );
            let body = scene
                .world
                .physics
                .insert_body(RigidBodyBuilder::dynamic().translation(center));
            let half_z = half.min(0.4 * scene.tank_max.z);
            scene.world.physics.insert_collider(
                ColliderBuilder::cuboid(half, half, half_z).density(500.0),
                Some(body),
            );
        }
        scene.world.physics.integration_parameters.dt = params.acoustic_time_step();
        scene.world.pipeline.time_stepping = rapier_sph::TimeStepping::Fixed;
        scene.world.physics.step();
        let w = &mut scene.world;
        let step = |w: &mut rapier_sph::FluidWorld| {
            if floating_box {
                w.step()
            } else {
                w.step_fluids()
            }
            .map(|r| r.timings)
        };
        for _ in 0..20 {
            step(w).unwrap();
        }
        let mut per_stage: Vec<Vec<f64>> = vec![Vec::new(); Stage::ALL.len()];
        let mut whole = Vec::new();
        for _ in 0..steps {
            let t0 = Instant::now();
            let timings = step(w).unwrap();
            whole.push(t0.elapsed().as_secs_f64() * 1e6);
            for (k, s) in Stage::ALL.iter().enumerate() {
                per_stage[k].push(timings.get(*s).as_secs_f64() * 1e6);
            }
        }
        let n = w.fluids.num_particles();

        print!(
            "{n} particles, {threads} threads, median µs/step: whole {:.0}",
            median(&mut whole)
        );
        for (k, s) in Stage::ALL.iter().enumerate() {
            let m = median(&mut per_stage[k]);
            if m > 0.0 {
                print!(" | {} {:.0}", s.name(), m);
            }
        }
        println!();
        // The run's end state, to check that a change kept the results bit for bit.
        println!("state hash {:016x}", state_hash(&w.fluids[scene.fluid]));
    });
}

/// A hash of the bits of every particle's id, position and velocity, in order (std's
/// `DefaultHasher`, fixed keys): equal hashes, bitwise equal runs.
fn state_hash(fluid: &rapier_sph::Fluid) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    fluid.ids().hash(&mut h);
    for (p, v) in fluid.positions().iter().zip(fluid.velocities()) {
        [p.x, p.y, p.z, v.x, v.y, v.z]
            .map(f32::to_bits)
            .hash(&mut h);
    }
    h.finish()
}
