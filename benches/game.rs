//! Game benchmark: a pool of water in 1/60 s frames, as a game steps it (rapier's step and
//! the fluid's adaptive substeps in each frame), at 2,500, 10,000 and 40,000 particles, on 1
//! and 2 threads. Reports the milliseconds per frame (wall and CPU), the substeps per frame,
//! the per-stage breakdown, the density error, the particles that left the pool and how deep
//! the hull floats.
//!
//! ```text
//! cargo bench --bench game                  # all cases
//! cargo bench --bench game -- --quick       # 2,500 and 10,000 only, fewer frames
//! cargo bench --bench game -- --particles 10000 --threads 2
//! ```
//!
//! The scene: a closed pool 2.0 × 0.8 × 0.7 m (inside), water 0.45 m deep (the water preset,
//! its default solver DFSPH; the spacing chosen for the particle count), a 40 × 10 × 24 cm
//! hull of 500 kg/m³ floating in it, and, in the `paddle` rows, a kinematic paddle at one end
//! swinging 8 cm back and forth every 1.5 s (a wave maker). The `rest` rows are the same pool
//! with the paddle still: what most of a game's water does most of the time.
//!
//! Each case settles for 0.5 s (not timed), then runs `--seconds` (default 2 s) of frames.
//! "hull draft / expected" is how deep the hull's bottom lies under the water's level over
//! its expected draft (density ratio × height: 1 is Archimedes), averaged over the frames.
//! "ms/frame" is the median wall time of a frame, with its 10th and 90th percentiles;
//! "CPU ms" the processor time of all threads per frame (Linux `/proc/self/stat`, 10 ms ticks
//! summed over the run), which other jobs on a shared machine inflate less than wall time.
//! Stages are the fluid pipeline's own timings (ms per frame, summed over substeps); rapier's
//! step is in "rapier".

use rapier_sph::math::{Real, Vector};
use rapier_sph::prelude::*;
use rapier_sph::rapier3d::prelude::{ColliderBuilder, RigidBodyBuilder, RigidBodyHandle};
use rapier_sph::scenes::add_closed_box;
use rapier_sph::{FluidWorld, StageTimings};
use std::time::{Duration, Instant};

const POOL: Vector = Vector::new(2.0, 0.8, 0.7);
const DEPTH: Real = 0.45;
const HULL_HALF: Vector = Vector::new(0.2, 0.05, 0.12);
const HULL_DENSITY: Real = 500.0;
/// The paddle's rest position along x (its plate is 2 cm thick).
const PADDLE_X: Real = 0.15;
const PADDLE_AMPLITUDE: Real = 0.08;
const PADDLE_PERIOD: Real = 1.5;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    println!(
        "game pool: water preset (DFSPH), 1/60 s frames, {} s timed after 0.5 s settling, {}",
        args.seconds,
        std::env::consts::ARCH
    );
    println!();
    print!(
        "| particles | spacing (mm) | paddle | threads | ms/frame [p10–p90] | CPU ms/frame | \
         substeps/frame | mean density error | left the pool | hull draft / expected | rapier (ms) |"
    );
    for s in Stage::ALL {
        print!(" {} |", s.name());
    }
    println!();
    print!("|---|---|---|---|---|---|---|---|---|---|---|");
    for _ in Stage::ALL {
        print!("---|");
    }
    println!();
    for &n in &args.particles {
        for paddle in [true, false] {
            for &threads in &args.threads {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()?;
                let row = pool.install(|| run(n, paddle, args.seconds))?;
                row.print(threads);
            }
        }
    }
    Ok(())
}

struct Args {
    particles: Vec<usize>,
    threads: Vec<usize>,
    seconds: Real,
}

impl Args {
    fn parse() -> Self {
        let argv: Vec<String> = std::env::args().collect();
        let quick = argv.iter().any(|a| a == "--quick");
        let value = |name: &str| argv.windows(2).find(|w| w[0] == name).map(|w| w[1].clone());
        let list =
            |s: String| -> Vec<usize> { s.split(',').filter_map(|x| x.parse().ok()).collect() };
        Self {
            particles: value("--particles").map(list).unwrap_or(if quick {
                vec![2_500, 10_000]
            } else {
                vec![2_500, 10_000, 40_000]
            }),
            threads: value("--threads").map(list).unwrap_or(vec![1, 2]),
            seconds: value("--seconds")
                .and_then(|s| s.parse().ok())
                .unwrap_or(if quick { 1.0 } else { 2.0 }),
        }
    }
}

/// The pool with its hull and paddle, and the particle count it started with.
struct Pool {
    world: FluidWorld,
    water: FluidHandle,
    hull: RigidBodyHandle,
    paddle: RigidBodyHandle,
    spacing: Real,
    particles: usize,
}

impl Pool {
    /// About `n` particles: the spacing is the cube root of the water's volume per particle.
    fn new(n: usize) -> SphResult<Self> {
        let behind_paddle = PADDLE_X + 0.02;
        let water = Vector::new(POOL.x - behind_paddle, DEPTH, POOL.z);
        // The largest spacing (in 1 % steps down from the cube root of the volume per
        // particle) whose lattice holds at least `n` particles.
        let mut spacing = (water.x * water.y * water.z / n as Real).cbrt();
        let fits = |s: Real| {
            (0..3)
                .map(|k| (water[k] / s).floor() as usize)
                .product::<usize>()
        };
        while fits(spacing) < n {
            spacing *= 0.99;
        }
        let mut world = FluidWorld::new();
        add_closed_box(&mut world, Vector::ZERO, POOL, 0.04);
        // The paddle: a plate across the pool near its -x end, moved by its kinematic target.
        let paddle = world.physics.insert_body(
            RigidBodyBuilder::kinematic_position_based()
                .translation(Vector::new(PADDLE_X, 0.4, 0.35)),
        );
        world
            .physics
            .insert_collider(ColliderBuilder::cuboid(0.01, 0.38, 0.34), Some(paddle));
        let hull_center = Vector::new(1.3, DEPTH, 0.35);
        let hull = world
            .physics
            .insert_body(RigidBodyBuilder::dynamic().translation(hull_center));
        world.physics.insert_collider(
            ColliderBuilder::cuboid(HULL_HALF.x, HULL_HALF.y, HULL_HALF.z).density(HULL_DENSITY),
            Some(hull),
        );
        let mut fluid = Fluid::new(FluidParamsBuilder::water(spacing).build()?)?;
        fluid.add_block(Vector::new(behind_paddle, 0.0, 0.0), water)?;
        // The water the floating hull displaces is cut out (it floats half under).
        let draft = HULL_HALF.y * 2.0 * HULL_DENSITY / 1000.0;
        let bottom = hull_center - Vector::new(HULL_HALF.x, HULL_HALF.y, HULL_HALF.z);
        let top = hull_center + HULL_HALF;
        fluid.remove_particles_where(|x, _, _| {
            x.x > bottom.x - 0.5 * spacing
                && x.x < top.x + 0.5 * spacing
                && x.z > bottom.z - 0.5 * spacing
                && x.z < top.z + 0.5 * spacing
                && x.y > DEPTH - draft - 0.5 * spacing
        });
        let particles = fluid.len();
        let water = world.fluids.insert(fluid);
        Ok(Self {
            world,
            water,
            hull,
            paddle,
            spacing,
            particles,
        })
    }

    /// One 1/60 s frame: the paddle's target at `t`, rapier, then the fluid.
    fn frame(&mut self, t: Real, paddle: bool) -> SphResult<(Duration, Duration)> {
        if paddle {
            let phase = std::f32::consts::TAU * t / PADDLE_PERIOD;
            let x = PADDLE_X + PADDLE_AMPLITUDE * phase.sin();
            self.world.physics.bodies[self.paddle]
                .set_next_kinematic_translation(Vector::new(x, 0.4, 0.35));
        }
        let start = Instant::now();
        self.world.physics.step();
        let rapier = start.elapsed();
        self.world.step_fluids()?;
        Ok((start.elapsed(), rapier))
    }

    /// Particles outside the pool's inside (they went through a wall or over the paddle).
    fn outside(&self) -> usize {
        let f = &self.world.fluids[self.water];
        f.positions()
            .iter()
            .filter(|p| p.cmplt(Vector::ZERO).any() || p.cmpgt(POOL).any())
            .count()
    }

    /// How deep the hull's bottom lies under the water's level, against its expected draft
    /// (density ratio × height). The level is the median, over the columns of a grid of two
    /// spacings away from the hull and the paddle, of each column's highest particle (half a
    /// spacing under the surface): a median of column tops follows the mean level through
    /// waves, where the topmost particles would follow the crests.
    fn draft_ratio(&self) -> Real {
        let f = &self.world.fluids[self.water];
        let hull = self.world.physics.bodies[self.hull].translation();
        let cell = 2.0 * self.spacing;
        let mut tops = std::collections::BTreeMap::<(i32, i32), Real>::new();
        for p in f.positions() {
            if (p.x - hull.x).abs() < 0.4 || p.x < PADDLE_X + PADDLE_AMPLITUDE + 0.1 {
                continue;
            }
            let key = ((p.x / cell) as i32, (p.z / cell) as i32);
            let top = tops.entry(key).or_insert(Real::MIN);
            *top = top.max(p.y);
        }
        let mut tops: Vec<Real> = tops.into_values().collect();
        if tops.is_empty() {
            return Real::NAN;
        }
        tops.sort_by(|a, b| a.total_cmp(b));
        let level = tops[tops.len() / 2] + 0.5 * self.spacing;
        let expected = 2.0 * HULL_HALF.y * HULL_DENSITY / 1000.0;
        (level - (hull.y - HULL_HALF.y)) / expected
    }
}

struct Row {
    particles: usize,
    spacing: Real,
    paddle: bool,
    frame_ms: (f64, f64, f64),
    cpu_ms: f64,
    substeps: f64,
    density_error: f64,
    outside: usize,
    draft: Real,
    rapier_ms: f64,
    stages: StageTimings,
    frames: usize,
}

fn run(n: usize, paddle: bool, seconds: Real) -> SphResult<Row> {
    let mut pool = Pool::new(n)?;
    let dt = 1.0 / 60.0;
    let settle = 30;
    for k in 0..settle {
        pool.frame(k as Real * dt, paddle)?;
    }
    let frames = (seconds * 60.0).round() as usize;
    let (mut times, mut rapier) = (Vec::with_capacity(frames), Duration::ZERO);
    let (mut stages, mut substeps, mut error) = (StageTimings::default(), 0u64, 0.0f64);
    let mut draft = 0.0;
    let cpu0 = cpu_seconds();
    for k in settle..settle + frames {
        let (whole, r) = pool.frame(k as Real * dt, paddle)?;
        times.push(whole.as_secs_f64() * 1e3);
        rapier += r;
        let report = pool.world.pipeline.report();
        stages.accumulate(&report.timings);
        substeps += report.substeps as u64;
        error += report.mean_density_error as f64;
        draft += pool.draft_ratio();
    }
    let cpu = cpu_seconds() - cpu0;
    times.sort_by(f64::total_cmp);
    let pick = |q: f64| times[((times.len() - 1) as f64 * q).round() as usize];
    Ok(Row {
        particles: pool.particles,
        spacing: pool.spacing,
        paddle,
        frame_ms: (pick(0.1), pick(0.5), pick(0.9)),
        cpu_ms: cpu * 1e3 / frames as f64,
        substeps: substeps as f64 / frames as f64,
        density_error: error / frames as f64,
        outside: pool.outside(),
        draft: draft / frames as Real,
        rapier_ms: rapier.as_secs_f64() * 1e3 / frames as f64,
        stages,
        frames,
    })
}

impl Row {
    fn print(&self, threads: usize) {
        let (p10, p50, p90) = self.frame_ms;
        print!(
            "| {} | {:.1} | {} | {threads} | {p50:.2} [{p10:.2}–{p90:.2}] | {:.1} | {:.2} | {:.3} % | {} | {:.2} | {:.2} |",
            self.particles,
            self.spacing * 1e3,
            if self.paddle { "moving" } else { "still" },
            self.cpu_ms,
            self.substeps,
            100.0 * self.density_error,
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
