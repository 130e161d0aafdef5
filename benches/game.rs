//! Game benchmark: a pool of water in 1/60 s frames, as a game steps it (rapier's step and
//! the fluid's adaptive substeps in each frame), at 2,500, 10,000 and 40,000 particles, on 1
//! and 2 threads, with the water preset (`FluidParamsBuilder::water`, DFSPH at 0.1 %) and
//! the game preset (`FluidParamsBuilder::game_water`, DFSPH at 0.5 %) side by side. Reports the milliseconds per frame (wall and CPU), the substeps per frame,
//! the solver's iterations per substep, the most halvings of its relaxation (see
//! `StepReport::solver_relaxation_halvings`), the per-stage breakdown, the density error, the particles that left the pool and how deep
//! the hull floats.
//!
//! ```text
//! cargo bench --bench game                  # all cases
//! cargo bench --bench game -- --quick       # 2,500 and 10,000 only, fewer frames
//! cargo bench --bench game -- --particles 10000 --threads 2
//! cargo bench --bench game -- --warm-start 0.9 --min-iterations 1 --hydrostatic-walls false
//! cargo bench --bench game -- --full-warm-start true
//! cargo bench --bench game -- --preset game --modes moving,still --max-density-error 0.005
//! cargo bench --bench game -- --particles 10000 --threads 2 --sleep-drift 0.1,3
//! cargo bench --bench game -- --preset game --modes still --gravity-substep inf --regions
//! cargo bench --bench game -- --preset game --particle-radius 0.4
//! cargo bench --bench game -- --preset game --gravity-substep inf --predict-walls true
//! cargo bench --bench game -- --preset game --full-warm-start true --chebyshev 0.8
//! ```
//!
//! `--preset water`, `--preset game` or `--preset water,game` (default) picks the presets,
//! `--modes` the rows (default `moving,still,asleep`). The DFSPH flags (`--warm-start`,
//! `--min-iterations`, `--min-divergence-iterations`, `--hydrostatic-walls`,
//! `--full-warm-start`, `--max-density-error`, `--gravity-substep`, which takes `inf` to
//! lift DFSPH's gravity bound on the substep, `--predict-walls`, `--carry-density-error`,
//! `--chebyshev`, which takes `none` or the spectral radius estimate `ρ`) change
//! the given field of `Dfsph` in every preset's settings; `--particle-radius F` sets the
//! contact radius (`FluidParams::particle_radius`) to `F` spacings; `--courant C` sets the
//! pipeline's adaptive Courant number (`TimeStepping::Adaptive`, default 0.4). `--regions` prints, after each row,
//! where the compression is (see `Regions`).
//!
//! The scene (`rapier_sph::scenes::WavePool`): a closed pool 2.0 × 0.8 × 0.7 m (inside),
//! water 0.45 m deep (the preset's water; the spacing chosen for the particle count), a 40 × 10 × 24 cm hull of 500 kg/m³ floating in it, and, in the `moving`
//! rows, a kinematic paddle at one end swinging 8 cm each way every 1.5 s (a wave maker). The
//! `still` rows are the same pool with the paddle still: what most of a game's water does
//! most of the time.
//!
//! The `asleep` rows are the still pool with sleeping on (`rapier_sph::sleep`,
//! `Sleep::default()` but for its drift thresholds: `--sleep-drift mean,max` in spacings,
//! default 0.1,1): it runs untimed until the water falls asleep (at most 20 s; the row says
//! "never slept" otherwise), then `--seconds` of frames are timed as the others. The row
//! gives when it fell asleep and what falling asleep dropped (the particles' kinetic energy,
//! the fastest particle's speed) and the density error it froze; after its timed frames a
//! ball of 5 cm radius is dropped, its center 0.3 m above the water's rest level
//! (`WavePool::DEPTH`), and the row says after how many frames the water woke and how far
//! above the rest level the ball's bottom was then.
//!
//! `--hull none` runs every row without the hull (the water it displaced put back): the
//! pool a floating hull does not keep moving (see docs/performance.md, "Sleeping water").
//!
//! Each case settles for 0.5 s (not timed), then runs `--seconds` (default 2 s) of frames.
//! "mean density error" is the frames' mean compression (`StepReport::mean_density_error`)
//! averaged, with the worst frame's in brackets; "largest particle compression" the largest
//! single particle's over all frames (`StepReport::max_density_error`); "water KE" the
//! particles' kinetic energy averaged over the first and the second half of the timed frames
//! (in the still rows a pool whose jitter grows shows a larger second half).
//! "hull draft / expected" is how deep the hull's bottom lies under the water's level over
//! its expected draft (density ratio × height: 1 is Archimedes), averaged over the frames.
//! "ms/frame" is the median wall time of a frame, with its 10th and 90th percentiles;
//! "CPU ms" the processor time of all threads per frame (Linux `/proc/self/stat`, 10 ms ticks
//! summed over the run), which other jobs on a shared machine inflate less than wall time;
//! "CPU µs per particle-substep" that divided by the substeps and particles (the cost a
//! faster substep must cut). "near walls / in contact" are the shares of the particles, per
//! substep, with a collider within their kernel support (the walls' terms are computed for
//! them) and touched by collider contact.
//! Stages are the fluid pipeline's own timings (ms per frame, summed over substeps); rapier's
//! step is in "rapier".

use rapier_sph::StageTimings;
use rapier_sph::math::Real;
use rapier_sph::prelude::*;
use rapier_sph::scenes::{WavePool, WavePoolConfig};
use std::time::Duration;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    println!(
        "game pool: DFSPH, 1/60 s frames, {} s timed after 0.5 s settling, {}",
        args.seconds,
        std::env::consts::ARCH
    );
    println!();
    print!(
        "| preset | particles | spacing (mm) | paddle | threads | ms/frame [p10–p90] | CPU ms/frame | \
         CPU µs per particle-substep | substeps/frame | near walls / in contact (per substep) | iterations/substep (density, divergence) | relaxation halvings | mean density error [worst frame] | largest particle compression | water KE (J) 1st / 2nd half | left the pool | hull draft / expected | rapier (ms) |"
    );
    for s in Stage::ALL {
        print!(" {} |", s.name());
    }
    println!();
    print!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for _ in Stage::ALL {
        print!("---|");
    }
    println!();
    let mut slept = Vec::new();
    for &n in &args.particles {
        for &preset in &args.presets {
            for &mode in &args.modes {
                for &threads in &args.threads {
                    let pool = rayon::ThreadPoolBuilder::new()
                        .num_threads(threads)
                        .build()?;
                    let row = pool.install(|| run(n, preset, mode, &args))?;
                    row.print(threads);
                    if let Some(s) = row.slept {
                        slept.push((preset.name(), row.particles, threads, s, row.woke));
                    }
                }
            }
        }
    }
    println!();
    println!(
        "asleep rows (drift thresholds {:?} spacings, {}): | preset | particles | threads | fell asleep after (s) | kinetic energy dropped (J) | fastest particle stopped (m/s) | density error frozen | a ball dropped in woke it after (frames; its bottom above the rest level, m) |",
        args.sleep_drift,
        if args.hull {
            "with the hull"
        } else {
            "no hull"
        }
    );
    for (preset, n, threads, s, woke) in slept {
        match s {
            Some((t, info)) => println!(
                "| {preset} | {n} | {threads} | {t:.2} | {:.3e} | {:.3} | {:.3} % | {} ({:+.3}) |",
                info.dropped_kinetic_energy,
                info.dropped_max_speed,
                100.0 * info.density_error_at_sleep,
                woke.map_or(0, |w| w.0),
                woke.map_or(Real::NAN, |w| w.1),
            ),
            None => {
                println!("| {preset} | {n} | {threads} | never slept in {SLEEP_WAIT} s | | | | |")
            }
        }
    }
    Ok(())
}

/// The parameter presets compared.
#[derive(Copy, Clone, PartialEq)]
enum Preset {
    /// `FluidParamsBuilder::water`.
    Water,
    /// `FluidParamsBuilder::game_water`.
    Game,
}

impl Preset {
    fn name(self) -> &'static str {
        match self {
            Preset::Water => "water",
            Preset::Game => "game",
        }
    }
}

/// The pool's three cases.
#[derive(Copy, Clone, PartialEq)]
enum Mode {
    /// The paddle swings.
    Moving,
    /// The paddle stands still.
    Still,
    /// The paddle stands still and the water may sleep.
    Asleep,
}

/// Longest the `asleep` rows wait for the water to fall asleep (simulated seconds).
const SLEEP_WAIT: Real = 20.0;

/// The DFSPH settings the water preset's cases run with (its own unless the command line
/// changes them).
static WATER: std::sync::OnceLock<Dfsph> = std::sync::OnceLock::new();
/// The same for the game preset.
static GAME: std::sync::OnceLock<Dfsph> = std::sync::OnceLock::new();

/// `--particle-radius`: the contact radius as a fraction of the spacing (the presets' own
/// when not given).
static RADIUS: std::sync::OnceLock<Option<Real>> = std::sync::OnceLock::new();

/// A preset's builder at `spacing`, with the command line's contact radius.
fn with_radius(b: FluidParamsBuilder, spacing: Real) -> FluidParamsBuilder {
    match RADIUS.get().copied().flatten() {
        Some(f) => b.particle_radius(f * spacing),
        None => b,
    }
}

/// The DFSPH settings of a preset's parameters.
fn dfsph_of(params: SphResult<FluidParams>) -> Dfsph {
    match params.map(|p| p.solver) {
        Ok(Solver::Dfsph(d)) => d,
        _ => panic!("the presets run DFSPH"),
    }
}

struct Args {
    presets: Vec<Preset>,
    modes: Vec<Mode>,
    particles: Vec<usize>,
    threads: Vec<usize>,
    seconds: Real,
    /// `Sleep::mean_drift` and `Sleep::max_drift` of the `asleep` rows.
    sleep_drift: (Real, Real),
    /// `false` with `--hull none`: the pool without its hull (water in its place).
    hull: bool,
    /// `--regions`: print where the compression is (see [`Regions`]).
    regions: bool,
    /// `--courant C`: the pipeline's adaptive Courant number (default 0.4, `TimeStepping`).
    courant: Option<Real>,
}

impl Args {
    fn parse() -> Self {
        let argv: Vec<String> = std::env::args().collect();
        let quick = argv.iter().any(|a| a == "--quick");
        let value = |name: &str| argv.windows(2).find(|w| w[0] == name).map(|w| w[1].clone());
        let list =
            |s: String| -> Vec<usize> { s.split(',').filter_map(|x| x.parse().ok()).collect() };
        let settings = |mut dfsph: Dfsph| {
            if let Some(w) = value("--warm-start").and_then(|s| s.parse().ok()) {
                dfsph.warm_start = w;
            }
            if let Some(m) = value("--min-iterations").and_then(|s| s.parse().ok()) {
                dfsph.min_iterations = m;
            }
            if let Some(m) = value("--min-divergence-iterations").and_then(|s| s.parse().ok()) {
                dfsph.min_divergence_iterations = m;
            }
            if let Some(h) = value("--hydrostatic-walls").and_then(|s| s.parse().ok()) {
                dfsph.hydrostatic_walls = h;
            }
            if let Some(f) = value("--full-warm-start").and_then(|s| s.parse().ok()) {
                dfsph.full_warm_start = f;
            }
            if let Some(e) = value("--max-density-error").and_then(|s| s.parse().ok()) {
                dfsph.max_density_error = e;
            }
            if let Some(k) = value("--gravity-substep").and_then(|s| s.parse().ok()) {
                dfsph.gravity_substep = k;
            }
            if let Some(w) = value("--predict-walls").and_then(|s| s.parse().ok()) {
                dfsph.predict_walls = w;
            }
            if let Some(c) = value("--carry-density-error").and_then(|s| s.parse().ok()) {
                dfsph.carry_density_error = c;
            }
            if let Some(r) = value("--chebyshev") {
                dfsph.chebyshev = match r.as_str() {
                    "none" => None,
                    r => r.parse().ok(),
                };
            }
            dfsph
        };
        let _ = RADIUS.set(value("--particle-radius").and_then(|s| s.parse().ok()));
        let _ = WATER.set(settings(dfsph_of(FluidParamsBuilder::water(0.04).build())));
        let _ = GAME.set(settings(dfsph_of(
            FluidParamsBuilder::game_water(0.04).build(),
        )));
        let names = |s: String| -> Vec<String> { s.split(',').map(str::to_owned).collect() };
        Self {
            presets: value("--preset")
                .map(names)
                .unwrap_or(vec!["water".into(), "game".into()])
                .iter()
                .filter_map(|p| match p.as_str() {
                    "water" => Some(Preset::Water),
                    "game" => Some(Preset::Game),
                    _ => None,
                })
                .collect(),
            modes: value("--modes")
                .map(names)
                .unwrap_or(vec!["moving".into(), "still".into(), "asleep".into()])
                .iter()
                .filter_map(|m| match m.as_str() {
                    "moving" => Some(Mode::Moving),
                    "still" => Some(Mode::Still),
                    "asleep" => Some(Mode::Asleep),
                    _ => None,
                })
                .collect(),
            particles: value("--particles").map(list).unwrap_or(if quick {
                vec![2_500, 10_000]
            } else {
                vec![2_500, 10_000, 40_000]
            }),
            threads: value("--threads").map(list).unwrap_or(vec![1, 2]),
            seconds: value("--seconds")
                .and_then(|s| s.parse().ok())
                .unwrap_or(if quick { 1.0 } else { 2.0 }),
            sleep_drift: value("--sleep-drift")
                .and_then(|s| {
                    let (a, b) = s.split_once(',')?;
                    Some((a.parse().ok()?, b.parse().ok()?))
                })
                .unwrap_or((Sleep::default().mean_drift, Sleep::default().max_drift)),
            hull: value("--hull").as_deref() != Some("none"),
            regions: argv.iter().any(|a| a == "--regions"),
            courant: value("--courant").and_then(|s| s.parse().ok()),
        }
    }
}

struct Row {
    preset: Preset,
    particles: usize,
    spacing: Real,
    mode: Mode,
    /// The `asleep` rows: when the water fell asleep and what that dropped (`None`: never).
    slept: Option<Option<(Real, SleepInfo)>>,
    /// The `asleep` rows that slept: see [`ball_wakes`].
    woke: Option<(usize, Real)>,
    frame_ms: (f64, f64, f64),
    cpu_ms: f64,
    substeps: f64,
    /// Per substep, the shares of the particles with a collider within their support
    /// (`StepReport::particles_near_walls`) and touched by contact (`StepReport::contacts`).
    near: (f64, f64),
    iterations: (f64, f64),
    halvings: u32,
    density_error: f64,
    worst_error: Real,
    largest_compression: Real,
    kinetic_energy: (f64, f64),
    outside: usize,
    draft: Real,
    rapier_ms: f64,
    stages: StageTimings,
    frames: usize,
}

fn run(n: usize, preset: Preset, mode: Mode, args: &Args) -> SphResult<Row> {
    let seconds = args.seconds;
    let params: fn(Real) -> SphResult<FluidParams> = match preset {
        Preset::Water => |s| {
            let dfsph = WATER.get().copied().expect("set by Args::parse");
            with_radius(FluidParamsBuilder::water(s), s)
                .solver(Solver::Dfsph(dfsph))
                .build()
        },
        Preset::Game => |s| {
            let dfsph = GAME.get().copied().expect("set by Args::parse");
            with_radius(FluidParamsBuilder::game_water(s), s)
                .solver(Solver::Dfsph(dfsph))
                .build()
        },
    };
    let mut config = WavePoolConfig {
        particles: n,
        params,
        ..Default::default()
    };
    if mode != Mode::Moving {
        config.paddle.0 = 0.0;
    }
    let mut pool = WavePool::new(config)?;
    if let Some(courant) = args.courant
        && let rapier_sph::pipeline::TimeStepping::Adaptive { courant: c, .. } =
            &mut pool.world.pipeline.time_stepping
    {
        *c = courant;
    }
    if !args.hull {
        pool.remove_hull()?;
    }
    for _ in 0..30 {
        pool.frame()?;
    }
    let slept = (mode == Mode::Asleep)
        .then(|| fall_asleep(&mut pool, args.sleep_drift))
        .transpose()?;
    let frames = (seconds * 60.0).round() as usize;
    let (mut times, mut rapier) = (Vec::with_capacity(frames), Duration::ZERO);
    let (mut stages, mut substeps, mut error) = (StageTimings::default(), 0u64, 0.0f64);
    let mut iterations = (0u64, 0u64);
    let mut near = (0u64, 0u64);
    let mut halvings = 0;
    let mut draft = 0.0;
    let (mut worst_error, mut largest_compression) = (0.0 as Real, 0.0 as Real);
    let mut kinetic_energy = (0.0, 0.0);
    let mut regions = Regions::default();
    let cpu0 = cpu_seconds();
    for frame in 0..frames {
        let start = std::time::Instant::now();
        rapier += pool.frame()?;
        times.push(start.elapsed().as_secs_f64() * 1e3);
        let report = pool.world.pipeline.report();
        stages.accumulate(&report.timings);
        substeps += report.substeps as u64;
        iterations.0 += report.solver_iterations as u64;
        iterations.1 += report.divergence_iterations as u64;
        near.0 += report.particles_near_walls as u64;
        near.1 += report.contacts as u64;
        error += report.mean_density_error as f64;
        halvings = halvings.max(report.solver_relaxation_halvings);
        worst_error = worst_error.max(report.mean_density_error);
        largest_compression = largest_compression.max(report.max_density_error);
        let ke = pool.world.fluids[pool.water].kinetic_energy();
        if frame < frames / 2 {
            kinetic_energy.0 += ke / (frames / 2) as f64;
        } else {
            kinetic_energy.1 += ke / (frames - frames / 2) as f64;
        }
        if args.regions {
            regions.add(&pool);
        }
        draft += if args.hull {
            pool.draft_ratio()
        } else {
            Real::NAN
        };
    }
    let cpu = cpu_seconds() - cpu0;
    if args.regions {
        regions.print(preset.name(), mode);
    }
    let outside = pool.outside();
    let woke = match slept {
        Some(Some(_)) => Some(ball_wakes(&mut pool)?),
        _ => None,
    };
    times.sort_by(f64::total_cmp);
    let pick = |q: f64| times[((times.len() - 1) as f64 * q).round() as usize];
    let particles = pool.world.fluids[pool.water].len();
    let per_particle_substep = (substeps.max(1) * particles.max(1) as u64) as f64;
    Ok(Row {
        preset,
        particles,
        spacing: pool.spacing,
        mode,
        slept,
        woke,
        frame_ms: (pick(0.1), pick(0.5), pick(0.9)),
        cpu_ms: cpu * 1e3 / frames as f64,
        substeps: substeps as f64 / frames as f64,
        near: (
            near.0 as f64 / per_particle_substep,
            near.1 as f64 / per_particle_substep,
        ),
        iterations: (
            iterations.0 as f64 / substeps.max(1) as f64,
            iterations.1 as f64 / substeps.max(1) as f64,
        ),
        halvings,
        density_error: error / frames as f64,
        worst_error,
        largest_compression,
        kinetic_energy,
        outside,
        draft: draft / frames as Real,
        rapier_ms: rapier.as_secs_f64() * 1e3 / frames as f64,
        stages,
        frames,
    })
}

/// Drops a ball of 5 cm radius (500 kg/m³), its center 0.3 m above the sleeping water's rest
/// level: the frames until the water woke, and how far the ball's bottom was above the rest
/// level then (m).
fn ball_wakes(pool: &mut WavePool) -> SphResult<(usize, Real)> {
    use rapier_sph::rapier3d::prelude::{ColliderBuilder, RigidBodyBuilder};
    let (r, at) = (0.05, Vector::new(1.0, WavePool::DEPTH + 0.3, 0.35));
    let ball = pool
        .world
        .physics
        .insert_body(RigidBodyBuilder::dynamic().translation(at));
    let collider = ColliderBuilder::ball(r).density(500.0);
    pool.world.physics.insert_collider(collider, Some(ball));
    for frame in 1..=120 {
        pool.frame()?;
        if !pool.world.fluids[pool.water].is_sleeping() {
            let y = pool.world.physics.bodies[ball].translation().y;
            return Ok((frame, y - r - WavePool::DEPTH));
        }
    }
    Ok((0, Real::NAN))
}

/// Lets the pool's water sleep (drift thresholds `drift`) and steps it until it does, at
/// most [`SLEEP_WAIT`] seconds: when it fell asleep and what that dropped.
fn fall_asleep(pool: &mut WavePool, drift: (Real, Real)) -> SphResult<Option<(Real, SleepInfo)>> {
    let water = &mut pool.world.fluids[pool.water];
    let mut params = water.params().clone();
    params.sleep = Some(Sleep {
        mean_drift: drift.0,
        max_drift: drift.1,
        ..Sleep::default()
    });
    water.set_params(params)?;
    let frames = (SLEEP_WAIT * 60.0) as usize;
    for frame in 1..=frames {
        pool.frame()?;
        let water = &pool.world.fluids[pool.water];
        if water.is_sleeping() {
            return Ok(Some((frame as Real / 60.0, water.sleep_info())));
        }
    }
    Ok(None)
}

impl Row {
    fn print(&self, threads: usize) {
        let (p10, p50, p90) = self.frame_ms;
        print!(
            "| {} | {} | {:.1} | {} | {threads} | {p50:.3} [{p10:.3}–{p90:.3}] | {:.1} | {:.3} | {:.2} | {:.1} % / {:.1} % | {:.1}, {:.1} | {} | {:.3} % [{:.3} %] | {:.2} % | {:.3} / {:.3} | {} | {:.2} | {:.2} |",
            self.preset.name(),
            self.particles,
            self.spacing * 1e3,
            match self.mode {
                Mode::Moving => "moving",
                Mode::Still => "still",
                Mode::Asleep => "asleep",
            },
            self.cpu_ms,
            1e3 * self.cpu_ms / (self.substeps * self.particles as f64).max(1.0),
            self.substeps,
            100.0 * self.near.0,
            100.0 * self.near.1,
            self.iterations.0,
            self.iterations.1,
            self.halvings,
            100.0 * self.density_error,
            100.0 * self.worst_error,
            100.0 * self.largest_compression,
            self.kinetic_energy.0,
            self.kinetic_energy.1,
            self.outside,
            self.draft,
            self.rapier_ms,
        );
        for s in Stage::ALL {
            print!(
                " {:.2} |",
                self.stages.get(s).as_secs_f64() * 1e3 / self.frames as f64
            );
        }
        println!();
    }
}

/// Where the compression is (`--regions`): every particle of every timed frame is put in
/// the first region it is in, and each region's share of the particles, mean compression
/// and largest compression are printed. Compression is `max(ρ − ρ0, 0)/ρ0` of the densities
/// the last substep of the frame computed (those `StepReport::mean_density_error` averages).
#[derive(Default)]
struct Regions {
    /// Per region: particles counted, summed compression, largest compression.
    sums: [(u64, f64, Real); 6],
}

impl Regions {
    const NAMES: [&str; 6] = [
        "hull (2 spacings)",
        "paddle (2 spacings)",
        "floor (1.5 spacings)",
        "side walls (1.5 spacings)",
        "surface (top 2 spacings)",
        "interior",
    ];

    fn add(&mut self, pool: &WavePool) {
        let f = &pool.world.fluids[pool.water];
        let (s, rho0) = (pool.spacing, f.params().rest_density);
        let hull = pool
            .world
            .physics
            .bodies
            .get(pool.hull)
            .map(|b| *b.position());
        let paddle_x = pool.world.physics.bodies[pool.paddle].translation().x;
        let level = WavePool::DEPTH - 2.0 * s;
        for (x, &rho) in f.positions().iter().zip(f.densities()) {
            let near_hull = hull.is_some_and(|pose| {
                let local = pose.inverse_transform_point(*x).abs() - WavePool::HULL_HALF;
                local.max_element() < 2.0 * s
            });
            let size = WavePool::SIZE;
            let k = if near_hull {
                0
            } else if (x.x - paddle_x).abs() < 0.01 + 2.0 * s {
                1
            } else if x.y < 1.5 * s {
                2
            } else if x.x.min(size.x - x.x).min(x.z).min(size.z - x.z) < 1.5 * s {
                3
            } else if x.y > level {
                4
            } else {
                5
            };
            let e = ((rho - rho0) / rho0).max(0.0);
            let r = &mut self.sums[k];
            r.0 += 1;
            r.1 += e as f64;
            r.2 = r.2.max(e);
        }
    }

    fn print(&self, preset: &str, mode: Mode) {
        let total: u64 = self.sums.iter().map(|r| r.0).sum();
        let all: f64 = self.sums.iter().map(|r| r.1).sum();
        let mode = match mode {
            Mode::Moving => "moving",
            Mode::Still => "still",
            Mode::Asleep => "asleep",
        };
        println!(
            "regions ({preset}, {mode}): | region | share of particles | mean compression | share of the summed compression | largest |"
        );
        for (name, r) in Self::NAMES.iter().zip(&self.sums) {
            println!(
                "| {name} | {:.1} % | {:.3} % | {:.1} % | {:.2} % |",
                100.0 * r.0 as f64 / total.max(1) as f64,
                100.0 * r.1 / r.0.max(1) as f64,
                100.0 * r.1 / all.max(1e-30),
                100.0 * r.2,
            );
        }
    }
}

/// Processor time (user + system) of this process so far, in seconds (Linux; 0 elsewhere).
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // Fields after the command name (which is in parentheses and may hold spaces).
    let Some(rest) = stat.rsplit_once(')').map(|(_, r)| r) else {
        return 0.0;
    };
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |k: usize| {
        fields
            .get(k)
            .and_then(|f| f.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    // utime and stime are fields 14 and 15 of the line, 12 and 13 after the name.
    (ticks(11) + ticks(12)) / 100.0
}
