//! Per-stage median step times of the water dam break (fixed acoustic dt, one thread by
//! default): medians are robust to the preemptions of a shared machine, where sums are not.
//!
//! ```text
//! cargo run --release --example stage_medians -- 2500 1000 [threads]
//! ```

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
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let params = FluidParamsBuilder::water(0.02)
            .solver(Solver::Wcsph)
            .wall_density(false)
            .build()
            .unwrap();
        let config = DamBreakConfig::tower(params.clone(), DamBreakConfig::scale_for(particles));
        let mut scene = dam_break(&config).unwrap();
        scene.world.physics.integration_parameters.dt = params.acoustic_time_step();
        scene.world.pipeline.time_stepping = rapier_sph::TimeStepping::Fixed;
        scene.world.physics.step();
        let w = &mut scene.world;
        for _ in 0..20 {
            w.step_fluids().unwrap();
        }
        let mut per_stage: Vec<Vec<f64>> = vec![Vec::new(); Stage::ALL.len()];
        let mut whole = Vec::new();
        for _ in 0..steps {
            let t0 = Instant::now();
            let r = w.step_fluids().unwrap();
            whole.push(t0.elapsed().as_secs_f64() * 1e6);
            for (k, s) in Stage::ALL.iter().enumerate() {
                per_stage[k].push(r.timings.get(*s).as_secs_f64() * 1e6);
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
    });
}
