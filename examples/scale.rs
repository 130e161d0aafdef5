//! The large dam break: the step bench's WCSPH scene (water preset, spacing 0.02 m, fixed
//! acoustic dt, one substep per step, rapier's own step excluded) at any particle count,
//! reporting steps per second, CPU time, heap bytes per particle and the process's peak
//! resident memory, and the wall time per step of each stage. Too slow for CI: run by hand.
//!
//! ```text
//! cargo run --release --example scale -- [particles] [steps] [threads] [warmup]
//! cargo run --release --example scale -- 1000000 30 2      # the 1,000,000-particle run
//! ```
//!
//! Defaults: 1,000,000 particles (at least: the tower's rounding gives 1,000,188), 30 timed
//! steps after 5 warm-up steps, 2 threads. The last line is a hash of the end state (equal
//! hashes, bitwise equal runs).

use rapier_sph::scenes::{DamBreakConfig, dam_break};
use rapier_sph::{FluidParamsBuilder, Solver};
use std::time::Instant;

/// A field of `/proc/self/status` in kB (Linux; `None` elsewhere).
fn status_kb(field: &str) -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(field))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// User + system CPU seconds of this process so far (Linux; `None` elsewhere).
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command name (which ends with ')'): utime and stime are the 14th
    // and 15th fields of the whole line, in clock ticks (100 per second on Linux).
    let rest = stat.rsplit_once(')')?.1;
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: u64 = f.get(11)?.parse::<u64>().ok()? + f.get(12)?.parse::<u64>().ok()?;
    Some(ticks as f64 / 100.0)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |k: usize, d: usize| args.get(k).and_then(|a| a.parse().ok()).unwrap_or(d);
    let (particles, steps, threads, warmup) = (arg(1, 1_000_000), arg(2, 30), arg(3, 2), arg(4, 5));
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
        let config = DamBreakConfig::tower(
            params.clone(),
            DamBreakConfig::scale_for_at_least(particles),
        );
        let t_build = Instant::now();
        let mut scene = dam_break(&config).unwrap();
        scene.world.physics.integration_parameters.dt = params.acoustic_time_step().min(0.005);
        scene.world.pipeline.time_stepping = rapier_sph::TimeStepping::Fixed;
        scene.world.physics.step();
        let w = &mut scene.world;
        let n = w.fluids.num_particles();
        let build = t_build.elapsed().as_secs_f64();
        for _ in 0..warmup {
            w.step_fluids().unwrap();
        }
        let (cpu0, t0) = (cpu_seconds(), Instant::now());
        let mut pairs = 0usize;
        let mut stages = rapier_sph::StageTimings::default();
        for _ in 0..steps {
            let report = w.step_fluids().unwrap();
            pairs += report.neighbour_pairs;
            stages.accumulate(&report.timings);
        }
        let wall = t0.elapsed().as_secs_f64();
        let cpu = cpu_seconds().zip(cpu0).map(|(b, a)| b - a);
        let bytes =
            w.fluids.iter().map(|(_, f)| f.heap_bytes()).sum::<usize>() + w.pipeline.heap_bytes();
        println!("particles {n}, {threads} threads, scene built in {build:.1} s");
        println!(
            "{steps} steps in {wall:.2} s: {:.2} steps/s, {:.0} ns/particle-step, CPU {} s ({:.2} cores)",
            steps as f64 / wall,
            wall * 1e9 / (steps * n) as f64,
            cpu.map_or("n/a".into(), |c| format!("{c:.2}")),
            cpu.map_or(0.0, |c| c / wall)
        );
        println!(
            "neighbours {:.1}, heap {:.1} MB = {:.0} bytes/particle, peak RSS {} MB",
            pairs as f64 / (steps * n) as f64,
            bytes as f64 / 1e6,
            bytes as f64 / n as f64,
            status_kb("VmHWM:").map_or("n/a".into(), |k| format!("{:.1}", k as f64 / 1024.0))
        );
        // Wall time per step of each stage (the pressure force stage includes the viscosity
        // where WCSPH runs the two in one pass).
        let per_step = |d: std::time::Duration| d.as_secs_f64() * 1e3 / steps as f64;
        let line: Vec<String> = rapier_sph::Stage::ALL
            .iter()
            .filter(|&&st| per_step(stages.get(st)) >= 0.005)
            .map(|&st| format!("{} {:.2}", st.name(), per_step(stages.get(st))))
            .collect();
        println!("ms per step by stage: {}", line.join(", "));
        let mut hash = 0xcbf2_9ce4_8422_2325u64;
        for (_, f) in w.fluids.iter() {
            for p in f.positions().iter().chain(f.velocities()) {
                for c in [p.x, p.y, p.z] {
                    hash = (hash ^ c.to_bits() as u64).wrapping_mul(0x0100_0000_01b3);
                }
            }
        }
        println!("state hash {hash:016x}");
    });
}
