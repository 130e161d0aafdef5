//! How many particles fit a game's frame: each solver steps a scene in 1/60 s frames (the
//! pipeline's adaptive substeps, rapier's step included, as a game calls it) and the example
//! reports the milliseconds per frame, the substeps and the density error, for several
//! particle counts.
//!
//! Two scenes, water preset at `--spacing` (default 5 cm, h = 10 cm):
//! - `pool`: water at rest, 0.5 m deep, in a closed square tank, a 500 kg/m³ crate dropped
//!   into it (calm water with a body in it: what most of a game's water does);
//! - `dam`: the Unity paper's 10:25:10 tower collapsing in a closed tank four columns long
//!   (violent flow: the worst case for the substeps).
//!
//! ```text
//! cargo run --release --example frame_budget                                    # every solver, both scenes
//! cargo run --release --example frame_budget -- --scene pool --solver dfsph --particles 20000
//! cargo run --release --example frame_budget -- --particles 5000,10000 --seconds 1 --threads 1
//! ```
//!
//! "ms/frame" is wall time, what a frame takes on this machine as loaded as it is; "CPU ms"
//! the processor time the process used per frame over all its threads (Linux, from
//! `/proc/self/stat`, 10 ms ticks summed over the run), which another job on the machine does
//! not inflate the way it inflates wall time. After each solver's rows, "fits 60 Hz" gives the
//! particle count whose mean frame takes 16.7 ms of wall time here, and the count whose frame
//! takes 30 ms of CPU, which is 16.7 ms of wall time on two free cores at the step's
//! two-thread speed-up (1.8×, `cargo bench --bench step`); both interpolated (log-log)
//! between the two measured counts around them.

use rapier_sph::math::{Real, Vector};
use rapier_sph::prelude::*;
use rapier_sph::rapier3d::prelude::{ColliderBuilder, RigidBodyBuilder};
use rapier_sph::{Solver, solver::Clavet};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    if let Some(t) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build_global()?;
    }
    println!(
        "frame budget: water preset, spacing {} m, 1/60 s frames, {} s per run, {} threads",
        args.spacing,
        args.seconds,
        rayon::current_num_threads()
    );
    println!(
        "{:<6} {:<7} {:>9} {:>10} {:>10} {:>10} {:>9} {:>10} {:>10} {:>5}",
        "scene",
        "solver",
        "particles",
        "ms/frame",
        "slowest",
        "CPU ms",
        "substeps",
        "mean err",
        "worst err",
        "lost"
    );
    for scene in &args.scenes {
        for &(name, solver) in &args.solvers {
            let (mut rows, mut cpu_rows) = (Vec::new(), Vec::new());
            for &target in &args.particles {
                let r = run(scene, solver, target, args.spacing, args.seconds)?;
                let cpu = r.cpu_ms.map_or("—".to_string(), |c| format!("{c:.2}"));
                println!(
                    "{:<6} {:<7} {:>9} {:>10.2} {:>10.2} {:>10} {:>9.1} {:>9.3}% {:>9.3}% {:>5}",
                    scene,
                    name,
                    r.particles,
                    r.mean_ms,
                    r.slowest_ms,
                    cpu,
                    r.substeps,
                    100.0 * r.mean_error,
                    100.0 * r.worst_error,
                    r.lost
                );
                rows.push((r.particles, r.mean_ms));
                if let Some(c) = r.cpu_ms {
                    cpu_rows.push((r.particles, c));
                }
            }
            println!(
                "{scene:<6} {name:<7} fits 60 Hz: {} particles here (16.7 ms of wall time), {} \
                 on two free cores (30 ms of CPU)",
                fits(&rows, 1000.0 / 60.0),
                fits(&cpu_rows, 30.0)
            );
        }
    }
    Ok(())
}

/// What one run measured.
struct Run {
    particles: usize,
    /// Mean wall time of a frame (ms).
    mean_ms: f64,
    /// Slowest frame (ms).
    slowest_ms: f64,
    /// Mean processor time per frame over all threads (ms), where the OS reports it.
    cpu_ms: Option<f64>,
    /// Mean substeps per frame.
    substeps: f64,
    /// Mean over frames of the mean compression over all particles.
    mean_error: f64,
    /// Largest mean compression of a frame.
    worst_error: f64,
    /// Particles outside the tank at the end.
    lost: usize,
}

fn run(
    scene: &str,
    solver: Solver,
    target: usize,
    s: Real,
    seconds: Real,
) -> Result<Run, Box<dyn std::error::Error>> {
    let params = FluidParamsBuilder::water(s).solver(solver).build()?;
    let mut world = FluidWorld::new();
    world.physics.integration_parameters.dt = 1.0 / 60.0;
    let mut fluid = Fluid::new(params)?;
    let interior = match scene {
        "pool" => {
            // Water 0.5 m deep over a square floor sized for `target` particles; a crate of
            // four spacings dropped from 0.2 m above the surface.
            let layers = (0.5 / s).round().max(2.0);
            let side = ((target as Real / layers).sqrt().round().max(4.0)) * s;
            let depth = layers * s;
            let interior = Vector::new(side, 2.0 * depth + 0.3, side);
            fluid.add_block(Vector::ZERO, Vector::new(side, depth, side))?;
            let half = 2.0 * s;
            let body =
                world
                    .physics
                    .insert_body(RigidBodyBuilder::dynamic().translation(Vector::new(
                        0.5 * side,
                        depth + 0.2 + half,
                        0.5 * side,
                    )));
            world.physics.insert_collider(
                ColliderBuilder::cuboid(half, half, half).density(500.0),
                Some(body),
            );
            interior
        }
        _ => {
            // The paper's tower (10:25:10) scaled to `target`, in a tank four columns long and
            // 1.5 columns tall.
            let scale = (target as Real / 2500.0).cbrt();
            let n = |k: Real| ((k * scale).round() as usize).max(1);
            let (nx, ny, nz) = (n(10.0), n(25.0), n(10.0));
            let column = Vector::new(nx as Real, ny as Real, nz as Real) * s;
            fluid.add_block(Vector::ZERO, column)?;
            Vector::new(4.0 * column.x, 1.5 * column.y, column.z)
        }
    };
    add_tank(&mut world, interior);
    let particles = fluid.len();
    let handle = world.fluids.insert(fluid);

    let frames = (seconds * 60.0).round().max(1.0) as usize;
    let (mut total, mut slowest, mut substeps) = (0.0f64, 0.0f64, 0u64);
    let (mut error_sum, mut worst) = (0.0f64, 0.0f64);
    let cpu_start = cpu_seconds();
    for _ in 0..frames {
        let t = Instant::now();
        let report = world.step()?;
        let ms = 1e3 * t.elapsed().as_secs_f64();
        total += ms;
        slowest = slowest.max(ms);
        substeps += report.substeps as u64;
        error_sum += report.mean_density_error as f64;
        worst = worst.max(report.mean_density_error as f64);
    }
    let cpu_ms = cpu_start
        .zip(cpu_seconds())
        .map(|(a, b)| 1e3 * (b - a) / frames as f64);
    let margin = Vector::splat(1e-4);
    let lost = world.fluids[handle]
        .positions()
        .iter()
        .filter(|p| !(p.cmpge(-margin).all() && p.cmple(interior + margin).all()))
        .count();
    Ok(Run {
        particles,
        mean_ms: total / frames as f64,
        slowest_ms: slowest,
        cpu_ms,
        substeps: substeps as f64 / frames as f64,
        mean_error: error_sum / frames as f64,
        worst_error: worst,
        lost,
    })
}

/// Processor time this process has used, user + system, over all its threads (s): fields 14
/// and 15 of `/proc/self/stat`, in clock ticks of 1/100 s (Linux's `USER_HZ`). `None`
/// elsewhere.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // The fields after the command name (in parentheses, which may hold spaces).
    let rest = &stat[stat.rfind(')')? + 1..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |k: usize| fields.get(k)?.parse::<u64>().ok();
    // `rest` starts at field 3 (the state): utime is field 14, stime field 15.
    Some((ticks(11)? + ticks(12)?) as f64 / 100.0)
}

/// Six fixed cuboids, 5 cm thick, enclosing `[0, interior]`.
fn add_tank(world: &mut FluidWorld, interior: Vector) {
    let body = world.physics.insert_body(RigidBodyBuilder::fixed());
    let (c, t) = (interior * 0.5, 0.05);
    let walls = [
        (
            Vector::new(c.x, -t, c.z),
            Vector::new(c.x + 2.0 * t, t, c.z + 2.0 * t),
        ),
        (
            Vector::new(c.x, interior.y + t, c.z),
            Vector::new(c.x + 2.0 * t, t, c.z + 2.0 * t),
        ),
        (
            Vector::new(-t, c.y, c.z),
            Vector::new(t, c.y + 2.0 * t, c.z + 2.0 * t),
        ),
        (
            Vector::new(interior.x + t, c.y, c.z),
            Vector::new(t, c.y + 2.0 * t, c.z + 2.0 * t),
        ),
        (
            Vector::new(c.x, c.y, -t),
            Vector::new(c.x + 2.0 * t, c.y + 2.0 * t, t),
        ),
        (
            Vector::new(c.x, c.y, interior.z + t),
            Vector::new(c.x + 2.0 * t, c.y + 2.0 * t, t),
        ),
    ];
    for (center, half) in walls {
        let wall = ColliderBuilder::cuboid(half.x, half.y, half.z).translation(center);
        world.physics.insert_collider(wall, Some(body));
    }
}

/// The particle count whose frame takes `budget` ms, interpolated log-log between the
/// measured counts around it (or which side of the measured counts it lies on).
fn fits(rows: &[(usize, f64)], budget: f64) -> String {
    let mut rows = rows.to_vec();
    rows.sort_by_key(|r| r.0);
    let crossing = rows.windows(2).find_map(|w| {
        let ((n0, t0), (n1, t1)) = (w[0], w[1]);
        (t0 <= budget && t1 > budget).then(|| {
            let (x0, x1) = ((n0 as f64).ln(), (n1 as f64).ln());
            let f = (budget.ln() - t0.ln()) / (t1.ln() - t0.ln());
            (x0 + f * (x1 - x0)).exp()
        })
    });
    match (crossing, rows.first(), rows.last()) {
        (Some(n), _, _) => format!("about {n:.0}"),
        (None, Some(first), _) if first.1 > budget => format!("fewer than {}", first.0),
        (None, _, Some(last)) if last.1 <= budget => format!("more than {}", last.0),
        _ => "—".to_string(),
    }
}

struct Args {
    scenes: Vec<String>,
    solvers: Vec<(&'static str, Solver)>,
    particles: Vec<usize>,
    spacing: Real,
    seconds: Real,
    threads: Option<usize>,
}

impl Args {
    fn parse() -> Self {
        let all_solvers: [(&str, Solver); 4] = [
            ("DFSPH", Solver::dfsph()),
            ("PBF", Solver::pbf()),
            ("WCSPH", Solver::Wcsph),
            ("Clavet", Solver::Clavet(Clavet::default())),
        ];
        let mut a = Args {
            scenes: vec!["pool".into(), "dam".into()],
            solvers: all_solvers.to_vec(),
            particles: vec![2_500, 5_000, 10_000, 20_000, 40_000],
            spacing: 0.05,
            seconds: 2.0,
            threads: None,
        };
        let argv: Vec<String> = std::env::args().skip(1).collect();
        let mut i = 0;
        while i < argv.len() {
            let v = argv.get(i + 1).cloned().unwrap_or_default();
            match argv[i].as_str() {
                "--scene" => {
                    if v != "pool" && v != "dam" {
                        fail("--scene is pool or dam");
                    }
                    a.scenes = vec![v];
                }
                "--solver" => {
                    a.solvers = all_solvers
                        .iter()
                        .filter(|(n, _)| n.eq_ignore_ascii_case(&v))
                        .cloned()
                        .collect();
                    if a.solvers.is_empty() {
                        fail("--solver is dfsph, pbf, wcsph or clavet");
                    }
                }
                "--particles" => {
                    a.particles = v
                        .split(',')
                        .map(|n| {
                            n.trim()
                                .parse()
                                .unwrap_or_else(|_| fail("--particles N[,N...]"))
                        })
                        .collect()
                }
                "--spacing" => a.spacing = v.parse().unwrap_or_else(|_| fail("--spacing S")),
                "--seconds" => a.seconds = v.parse().unwrap_or_else(|_| fail("--seconds T")),
                "--threads" => a.threads = Some(v.parse().unwrap_or_else(|_| fail("--threads N"))),
                "--help" | "-h" => {
                    println!(
                        "frame_budget [--scene pool|dam] [--solver dfsph|pbf|wcsph|clavet] \
                         [--particles N,N,...] [--spacing S] [--seconds T] [--threads N]"
                    );
                    std::process::exit(0);
                }
                other => fail(&format!("unknown argument {other} (try --help)")),
            }
            i += 2;
        }
        if !(a.spacing > 0.0 && a.seconds > 0.0) || a.particles.is_empty() {
            fail("--spacing and --seconds must be positive, --particles not empty");
        }
        a
    }
}

fn fail(msg: &str) -> ! {
    eprintln!("{msg}");
    std::process::exit(2)
}
