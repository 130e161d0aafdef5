//! Step benchmark: the dam break at 2,500, 20,000 and 100,000 particles on 1 and 2 threads,
//! whole step and per stage. A small harness of our own (no criterion): each case is warmed
//! up, then timed over a fixed number of steps, and the figures are printed as a Markdown
//! table (the figures in the README and docs/performance.md come from here).
//!
//! ```text
//! cargo bench --bench step                 # all cases
//! cargo bench --bench step -- --quick      # 2,500 and 20,000 only, fewer steps
//! cargo bench --bench step -- --preset paper
//! cargo bench --bench step -- --salva      # only the peer-comparison scene below
//! cargo bench --bench step -- --salva --carry-density-error   # DFSPH's options: also
//!                                          # --full-warm-start, --warm-start F,
//!                                          # --chebyshev RHO
//! ```
//!
//! The peer-comparison scene (salva3d's own benchmark): DFSPH with walls
//! counting in the density, spacing 0.05 m, h = 0.1 m, fixed dt = 0.005 s, the dam break's
//! first simulated second, reported as wall (and CPU) seconds per simulated second, with the
//! solver's iterations, the mean compression (the summed density at each step's start, as
//! the step report counts it) beside the solve's own predicted compression at its stop (what
//! its 0.1 % target bounds; the difference is the linear prediction's error over a step, see
//! docs/performance.md), and the particles that left the tank; then each row's stages (wall
//! seconds per simulated second, from the step reports' timings).
//!
//! Each case runs 3 times (2 with `--quick`) from the same initial state; the fastest run is
//! reported, because timing on a shared VM varies by ±25 % from run to run.

use rapier_sph::scenes::{DamBreakConfig, dam_break};
use rapier_sph::{FluidParamsBuilder, Solver, Stage, StageTimings};
use std::time::Instant;

struct Case {
    particles: usize,
    warmup: usize,
    steps: usize,
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    if args.iter().any(|a| a == "--salva") {
        salva_scene(quick, salva_solver(&args));
        return;
    }
    let repeats = if quick { 2 } else { 3 };
    let paper = args
        .windows(2)
        .any(|w| w[0] == "--preset" && w[1] == "paper");
    let mut cases = vec![
        Case {
            particles: 2_500,
            warmup: 50,
            steps: if quick { 200 } else { 1000 },
        },
        Case {
            particles: 20_000,
            warmup: 10,
            steps: if quick { 30 } else { 100 },
        },
    ];
    if !quick {
        cases.push(Case {
            particles: 100_000,
            warmup: 5,
            steps: 30,
        });
    }
    let threads = [1usize, 2];
    println!(
        "dam break, {} preset, fluid pipeline only (rapier's own step excluded), {}",
        if paper {
            "paper"
        } else {
            "water (spacing 0.02 m)"
        },
        std::env::consts::ARCH
    );
    println!();
    print!(
        "| particles | threads | steps/s | M particle-steps/s | ns/particle-step | neighbours | bytes/particle |"
    );
    for s in Stage::ALL {
        print!(" {} (µs) |", s.name());
    }
    println!();
    print!("|---|---|---|---|---|---|---|");
    for _ in Stage::ALL {
        print!("---|");
    }
    println!();
    for case in &cases {
        for &t in &threads {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap();
            // The VM's timing is noisy (±25 % between runs): each case runs `repeats` times
            // from the same initial state and the fastest run is reported.
            let best = (0..repeats)
                .map(|_| pool.install(|| run(case, paper)))
                .min_by(|a, b| a.wall.total_cmp(&b.wall))
                .unwrap();
            best.print(case, t);
        }
    }
    println!();
    salva_scene(quick, salva_solver(&args));
}

/// The salva scene's DFSPH settings: the defaults, or with `--full-warm-start`,
/// `--carry-density-error` (with the full warm start it needs), `--warm-start F`,
/// `--chebyshev RHO` (with the full warm start it needs) and `--min-divergence-iterations N`.
fn salva_solver(args: &[String]) -> rapier_sph::Dfsph {
    let has = |flag: &str| args.iter().any(|a| a == flag);
    let mut d = rapier_sph::Dfsph::default();
    if has("--full-warm-start") || has("--carry-density-error") {
        d.full_warm_start = true;
    }
    d.carry_density_error = has("--carry-density-error");
    if let Some(w) = args.windows(2).find(|w| w[0] == "--warm-start") {
        d.warm_start = w[1].parse().expect("--warm-start takes a fraction");
    }
    if let Some(w) = args.windows(2).find(|w| w[0] == "--chebyshev") {
        d.full_warm_start = true;
        d.chebyshev = Some(w[1].parse().expect("--chebyshev takes a spectral radius"));
    }
    if let Some(w) = args
        .windows(2)
        .find(|w| w[0] == "--min-divergence-iterations")
    {
        d.min_divergence_iterations = w[1]
            .parse()
            .expect("--min-divergence-iterations takes a count");
    }
    d
}

/// The peer-comparison scene (see the module docs) with DFSPH's settings `dfsph`, on 2
/// threads, fastest of 2 runs.
fn salva_scene(quick: bool, dfsph: rapier_sph::Dfsph) {
    use rapier_sph::TimeStepping;
    let counts: &[usize] = if quick {
        &[2_500, 20_000]
    } else {
        &[2_500, 20_000, 64_000]
    };
    println!(
        "salva3d's scene: DFSPH + wall density, spacing 0.05 m, h = 0.1 m, dt = 0.005 s fixed, first simulated second, 2 threads"
    );
    println!(
        "DFSPH: warm start {}, full warm start {}, carry density error {}, Chebyshev {:?}",
        dfsph.warm_start, dfsph.full_warm_start, dfsph.carry_density_error, dfsph.chebyshev
    );
    println!();
    println!(
        "| particles | wall s per simulated s | CPU s per simulated s | steps/s | M particle-steps/s | density iterations/step | divergence iterations/step | mean compression | solve's predicted compression | escaped |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let mut stages = Vec::new();
    let mut iteration_costs = Vec::new();
    for &n in counts {
        let run = || {
            let params = FluidParamsBuilder::water(0.05)
                .solver(Solver::Dfsph(dfsph))
                .wall_density(true)
                .build()
                .unwrap();
            let config = DamBreakConfig::tower(params, DamBreakConfig::scale_for(n));
            let mut scene = dam_break(&config).unwrap();
            scene.world.pipeline.time_stepping = TimeStepping::Fixed;
            scene.world.physics.integration_parameters.dt = 0.005;
            scene.world.physics.step();
            let steps = 200;
            let (mut it, mut div, mut err, mut predicted) = (0u64, 0u64, 0.0f64, 0.0f64);
            let mut timings = StageTimings::default();
            let mut per_iteration = Vec::with_capacity(steps);
            let t0 = Instant::now();
            let c0 = cpu_seconds();
            for _ in 0..steps {
                let r = scene.world.step_fluids().unwrap();
                timings.accumulate(&r.timings);
                if r.solver_iterations > 0 {
                    let t = r.timings.get(Stage::DensitySolve).as_secs_f64();
                    per_iteration.push(t / r.solver_iterations as f64);
                }
                it += r.solver_iterations as u64;
                div += r.divergence_iterations as u64;
                err += r.mean_density_error as f64;
                predicted += r.solver_density_error as f64;
            }
            let wall = t0.elapsed().as_secs_f64();
            let cpu = cpu_seconds() - c0;
            let particles = scene.world.fluids.num_particles();
            (
                (wall, cpu),
                particles,
                (it, div),
                (err / steps as f64, predicted / steps as f64),
                scene.escaped(),
                (steps, timings),
                per_iteration,
            )
        };
        let best = (0..2)
            .map(|_| pool.install(run))
            .min_by(|a, b| a.0.0.total_cmp(&b.0.0))
            .unwrap();
        let (
            (wall, cpu),
            particles,
            (it, div),
            (err, predicted),
            escaped,
            (steps, timings),
            per_it,
        ) = best;
        iteration_costs.push((particles, per_it));
        stages.push((particles, timings, steps as f64 * 0.005));
        let sps = steps as f64 / wall;
        println!(
            "| {} | {:.2} | {:.2} | {:.1} | {:.3} | {:.2} | {:.2} | {:.3} % | {:.3} % | {} |",
            particles,
            wall / (steps as f64 * 0.005),
            cpu / (steps as f64 * 0.005),
            sps,
            sps * particles as f64 / 1e6,
            it as f64 / steps as f64,
            div as f64 / steps as f64,
            100.0 * err,
            100.0 * predicted,
            escaped
        );
    }
    print_salva_stages(&stages);
    print_iteration_costs(&mut iteration_costs);
}

/// The density solve's time per iteration (two passes over the pairs, and the solve's
/// last rate pass and warm start spread over them), step by step: its 10th percentile and
/// median over the steps of the fastest run. On a loaded machine a step's stages are often
/// preempted; the lower percentile is the figure that compares builds.
fn print_iteration_costs(costs: &mut [(usize, Vec<f64>)]) {
    println!();
    println!(
        "| particles | density solve µs per iteration, 10th percentile of the steps | median |"
    );
    println!("|---|---|---|");
    for (n, v) in costs.iter_mut() {
        if v.is_empty() {
            continue;
        }
        v.sort_by(f64::total_cmp);
        let at = |q: f64| 1e6 * v[((v.len() - 1) as f64 * q) as usize];
        println!("| {n} | {:.0} | {:.0} |", at(0.1), at(0.5));
    }
}

/// The salva rows' stage times (the fastest run's), in wall seconds per simulated second;
/// stages that took no time are left out.
fn print_salva_stages(stages: &[(usize, StageTimings, f64)]) {
    let used: Vec<Stage> = Stage::ALL
        .into_iter()
        .filter(|&s| stages.iter().any(|(_, t, _)| t.get(s).as_secs_f64() > 0.0))
        .collect();
    println!();
    print!("| particles (stages: wall s per simulated s) |");
    for s in &used {
        print!(" {} |", s.name());
    }
    println!();
    print!("|---|");
    for _ in &used {
        print!("---|");
    }
    println!();
    for (n, t, simulated) in stages {
        print!("| {n} |");
        for &s in &used {
            print!(" {:.3} |", t.get(s).as_secs_f64() / simulated);
        }
        println!();
    }
}

struct Measurement {
    n: usize,
    wall: f64,
    timings: StageTimings,
    pairs: usize,
    bytes: usize,
}

impl Measurement {
    fn print(&self, case: &Case, threads: usize) {
        let sps = case.steps as f64 / self.wall;
        let n = self.n;
        print!(
            "| {} | {} | {:.1} | {:.2} | {:.0} | {:.1} | {:.0} |",
            n,
            threads,
            sps,
            sps * n as f64 / 1e6,
            1e9 / (sps * n as f64),
            self.pairs as f64 / (case.steps * n) as f64,
            self.bytes as f64 / n as f64
        );
        for s in Stage::ALL {
            print!(
                " {:.0} |",
                self.timings.get(s).as_secs_f64() * 1e6 / case.steps as f64
            );
        }
        println!();
    }
}

fn run(case: &Case, paper: bool) -> Measurement {
    let params = if paper {
        FluidParamsBuilder::paper().build().unwrap()
    } else {
        FluidParamsBuilder::water(0.02)
            .solver(Solver::Wcsph)
            .wall_density(false)
            .build()
            .unwrap()
    };
    let config = DamBreakConfig::tower(
        params.clone(),
        DamBreakConfig::scale_for_at_least(case.particles),
    );
    let mut scene = dam_break(&config).unwrap();
    let dt = params.acoustic_time_step().min(0.005);
    scene.world.physics.integration_parameters.dt = dt;
    // One substep per step, at the acoustic limit (the adaptive default would split each step
    // into two as soon as anything moves, and count both).
    scene.world.pipeline.time_stepping = rapier_sph::TimeStepping::Fixed;
    scene.world.physics.step(); // fills rapier's broad-phase once; the tank is static
    let w = &mut scene.world;
    let n = w.fluids.num_particles();
    for _ in 0..case.warmup {
        w.step_fluids().unwrap();
    }
    let mut timings = StageTimings::default();
    let mut pairs = 0usize;
    let t0 = Instant::now();
    for _ in 0..case.steps {
        let r = w.step_fluids().unwrap();
        timings.accumulate(&r.timings);
        pairs += r.neighbour_pairs;
    }
    let wall = t0.elapsed().as_secs_f64();
    assert_eq!(w.fluids.num_particles(), n, "particle count changed");
    let bytes =
        w.fluids.iter().map(|(_, f)| f.heap_bytes()).sum::<usize>() + w.pipeline.heap_bytes();
    Measurement {
        n,
        wall,
        timings,
        pairs,
        bytes,
    }
}

/// User + system CPU seconds of this process so far, from `/proc/self/stat` (Linux; 0
/// elsewhere, and the CPU column then reads 0): on a shared machine the CPU time holds
/// where the wall time does not.
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // After the command name (ending with ')'), utime and stime are fields 12 and 13, in
    // clock ticks (100 per second on Linux).
    let f: Vec<&str> = stat
        .rsplit_once(')')
        .map_or(vec![], |r| r.1.split_whitespace().collect());
    let tick = |k: usize| f.get(k).and_then(|s| s.parse::<u64>().ok()).unwrap_or(0);
    (tick(11) + tick(12)) as f64 / 100.0
}
