//! The Unity paper's dam break: a 10 × 25 × 10 tower of particles collapsing in a closed
//! tank made of rapier colliders. Headless; prints per-stage timings (the paper's Tables 1
//! and 2) and the run's figures. By default with the paper's own constants (`--preset
//! paper`), whose fluid rests about eleven times compressed: its density errors read in the
//! thousands of per cent. `--preset water` is SI water.
//!
//! ```text
//! cargo run --release --example dam_break                       # paper preset, 2,500 particles
//! cargo run --release --example dam_break -- --preset water --particles 20000
//! cargo run --release --example dam_break -- --help
//! cargo run --release --example dam_break --features render -- --render out/   # PNG frames + GIF
//! ```

use clap::{Parser, ValueEnum};
use rapier_sph::scenes::{DamBreakConfig, dam_break};
use rapier_sph::{FluidParamsBuilder, Solver, StageTimings, TimeStepping};
use std::time::Instant;

#[derive(Copy, Clone, Debug, ValueEnum)]
enum Preset {
    /// The paper's unit-mass constants (mass 1, ρ0 = 8, k = 3, ε = 0.02, h = 0.4): the
    /// fluid rests about 11× compressed (a particle's own density term is 2.1 ρ0).
    Paper,
    /// SI water (ρ0 = 1000 kg/m³) at --spacing.
    Water,
}

#[derive(Copy, Clone, Debug, ValueEnum)]
enum SolverArg {
    /// Weakly compressible SPH (the paper's method).
    Wcsph,
    /// Divergence-free SPH (Bender & Koschier 2017).
    Dfsph,
    /// Position-based fluids (Macklin & Müller 2013): fixed iterations, any time step.
    Pbf,
    /// Double-density relaxation (Clavet et al. 2005).
    Clavet,
    /// Double-density relaxation with viscoelastic springs (Clavet et al. 2005, section 5;
    /// default spring settings).
    ClavetSprings,
}

#[derive(Parser, Debug)]
#[command(about = "SPH dam break in a rapier tank (the Unity paper's scene)")]
struct Args {
    /// Parameter preset.
    #[arg(long, value_enum, default_value = "paper")]
    preset: Preset,
    /// Scale of the 10×25×10 tower along each axis (2 gives 20×50×20 = 20,000 particles).
    #[arg(long, default_value_t = 1.0, conflicts_with = "particles")]
    scale: f32,
    /// Approximate particle count (sets --scale).
    #[arg(long)]
    particles: Option<usize>,
    /// Particle spacing for the water preset (m).
    #[arg(long, default_value_t = 0.02)]
    spacing: f32,
    /// Number of steps.
    #[arg(long, default_value_t = 1000)]
    steps: usize,
    /// Time step (s). Default: the acoustic CFL step of the preset, at most 1/200 s.
    #[arg(long)]
    dt: Option<f32>,
    /// Rayon threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Override the preset's viscosity ε (0 switches the viscosity stage off).
    #[arg(long)]
    viscosity: Option<f32>,
    /// Pressure solver (default: the preset's: DFSPH for water, WCSPH for paper).
    #[arg(long, value_enum)]
    solver: Option<SolverArg>,
    /// Walls count in the density (`FluidParams::wall_density`): `--walls` or `--walls true`
    /// turns them on, `--walls false` off (default: the preset's: on for water, with every
    /// solver; off for paper).
    #[arg(long, num_args = 0..=1, default_missing_value = "true")]
    walls: Option<bool>,
    /// DFSPH only: walls with hydrostatic pressure (`Dfsph::hydrostatic_walls`):
    /// `--hydrostatic-walls false` turns them off (default: DFSPH's, on).
    #[arg(long, num_args = 0..=1, default_missing_value = "true")]
    hydrostatic_walls: Option<bool>,
    /// DFSPH only: carry the whole previous pressure, projected solve
    /// (`Dfsph::full_warm_start`).
    #[arg(long)]
    full_warm_start: bool,
    /// DFSPH only: carry the last prediction error (`Dfsph::carry_density_error`; implies
    /// --full-warm-start).
    #[arg(long)]
    carry_density_error: bool,
    /// DFSPH only: Chebyshev acceleration of the density solve with this spectral radius
    /// estimate (`Dfsph::chebyshev`; implies --full-warm-start).
    #[arg(long, value_name = "RHO")]
    chebyshev: Option<f32>,
    /// DFSPH only: divergence iterations always run (`Dfsph::min_divergence_iterations`;
    /// default 1; at 0 the solve stops as soon as its warm start meets its target).
    #[arg(long, value_name = "N")]
    min_divergence_iterations: Option<u32>,
    /// Akinci's surface tension `γ` (`FluidParamsBuilder::surface_tension`; default 0, off).
    #[arg(long)]
    surface_tension: Option<f32>,
    /// One substep per frame of exactly --dt (default: adaptive CFL substeps within each frame).
    #[arg(long)]
    fixed: bool,
    /// Switch gravity off (the external-forces stage is then skipped).
    #[arg(long)]
    no_gravity: bool,
    /// Print a line every this many steps (0: never).
    #[arg(long, default_value_t = 100)]
    every: usize,
    /// Write a PNG frame every --frame-every steps into this folder, and `dam_break.gif`
    /// (needs the `render` feature).
    #[arg(long, value_name = "DIR")]
    render: Option<std::path::PathBuf>,
    /// Steps between rendered frames (default: about 60 frames over the run).
    #[arg(long)]
    frame_every: Option<usize>,
    /// Frame size in pixels, WIDTHxHEIGHT.
    #[arg(long, default_value = "640x360")]
    size: String,
    /// Turn the camera by this many degrees per frame (0: fixed camera).
    #[arg(long, default_value_t = 0.0)]
    orbit: f32,
    /// Draw the particles as spheres coloured by speed (the renderer's older style) instead
    /// of screen-space water with foam.
    #[arg(long)]
    spheres: bool,
}

/// The `--render DIR` pictures: the library's [`Recorder`](rapier_sph::render::Recorder)
/// (`DIR/frame_NNNN.png` and `DIR/dam_break.gif`), with foam and spray unless `--spheres`,
/// and the wall time spent on them (left out of the step's figures).
#[cfg(feature = "render")]
struct Pictures {
    dir: std::path::PathBuf,
    recorder: rapier_sph::render::Recorder,
    seconds: f64,
}

#[cfg(feature = "render")]
impl Pictures {
    fn new(
        args: &Args,
        dir: &std::path::Path,
        scene: &rapier_sph::scenes::DamBreak,
    ) -> Result<Self, Box<dyn std::error::Error>> {
        use rapier_sph::render::{Camera, FluidStyle, Recorder, RenderOptions};
        let (width, height) = args
            .size
            .split_once('x')
            .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
            .ok_or("--size must look like 640x360")?;
        let max_speed = (2.0 * 9.81 * scene.column_height).sqrt();
        let options = RenderOptions {
            width,
            height,
            speed_range: Some((0.0, max_speed)),
            style: if args.spheres {
                FluidStyle::Spheres
            } else {
                FluidStyle::ScreenSpace
            },
            ..RenderOptions::default()
        };
        let camera = Camera::framing(scene.tank_min, scene.tank_max, 30.0, 28.0);
        let mut recorder = Recorder::create(dir, "dam_break", options, camera, args.orbit, 5)?;
        if !args.spheres {
            recorder = recorder.with_diffuse(Default::default())?;
        }
        Ok(Self {
            dir: dir.to_path_buf(),
            recorder,
            seconds: 0.0,
        })
    }

    /// After a step: foam and spray follow the liquid; a frame is drawn if `draw`.
    fn step(
        &mut self,
        world: &rapier_sph::FluidWorld,
        draw: bool,
    ) -> Result<(), Box<dyn std::error::Error>> {
        let t = Instant::now();
        self.recorder.step(world)?;
        if draw {
            self.recorder.frame(world)?;
        }
        self.seconds += t.elapsed().as_secs_f64();
        Ok(())
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    if let Some(t) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build_global()?;
    }
    let mut builder = match args.preset {
        Preset::Paper => FluidParamsBuilder::paper(),
        Preset::Water => FluidParamsBuilder::water(args.spacing),
    };
    let dfsph = match args.solver {
        Some(s) => matches!(s, SolverArg::Dfsph),
        None => matches!(args.preset, Preset::Water),
    };
    if (args.hydrostatic_walls.is_some()
        || args.full_warm_start
        || args.carry_density_error
        || args.chebyshev.is_some()
        || args.min_divergence_iterations.is_some())
        && !dfsph
    {
        return Err(
            "--hydrostatic-walls, --full-warm-start, --carry-density-error, --chebyshev \
                    and --min-divergence-iterations are DFSPH settings: add --solver dfsph"
                .into(),
        );
    }
    match args.solver {
        Some(SolverArg::Wcsph) => builder = builder.solver(Solver::Wcsph),
        Some(SolverArg::Dfsph) => {}
        Some(SolverArg::Pbf) => builder = builder.solver(Solver::pbf()),
        Some(SolverArg::Clavet) => builder = builder.solver(Solver::clavet()),
        Some(SolverArg::ClavetSprings) => {
            builder = builder.solver(Solver::Clavet(rapier_sph::solver::Clavet {
                springs: Some(rapier_sph::solver::Springs::default()),
                ..Default::default()
            }))
        }
        None => {}
    }
    if dfsph {
        let defaults = rapier_sph::solver::Dfsph::default();
        builder = builder.solver(Solver::Dfsph(rapier_sph::solver::Dfsph {
            hydrostatic_walls: args.hydrostatic_walls.unwrap_or(defaults.hydrostatic_walls),
            full_warm_start: args.full_warm_start
                || args.carry_density_error
                || args.chebyshev.is_some(),
            carry_density_error: args.carry_density_error,
            chebyshev: args.chebyshev,
            min_divergence_iterations: args
                .min_divergence_iterations
                .unwrap_or(defaults.min_divergence_iterations),
            ..defaults
        }));
    }
    if let Some(on) = args.walls {
        builder = builder.wall_density(on);
    }
    if let Some(eps) = args.viscosity {
        builder = builder.viscosity(eps);
    }
    if let Some(gamma) = args.surface_tension {
        builder = builder.surface_tension(gamma);
    }
    let params = builder.build()?;
    let scale = args
        .particles
        .map(DamBreakConfig::scale_for)
        .unwrap_or(args.scale);
    let config = DamBreakConfig::tower(params.clone(), scale);
    let mut scene = dam_break(&config)?;
    let dt = args.dt.unwrap_or_else(|| {
        // Acoustic limit 0.4 h / c, and the flow limit 0.4 h / v with v the free-fall speed
        // of the column's height.
        let v = (2.0 * 9.81 * scene.column_height).sqrt();
        params
            .acoustic_time_step()
            .min(0.4 * params.smoothing_length / v)
            .min(1.0 / 200.0)
    });
    scene.world.physics.integration_parameters.dt = dt;
    if args.fixed {
        scene.world.pipeline.time_stepping = TimeStepping::Fixed;
    }
    if args.no_gravity {
        scene.world.physics.gravity = rapier_sph::math::Vector::ZERO;
    }
    let n = scene.world.fluids.num_particles();
    if matches!(args.preset, Preset::Paper) {
        println!(
            "the paper's constants (m = 1, ρ0 = 8, h = 0.4): a particle's own density term is \
             already 2.1 ρ0, so this fluid rests about 11× compressed and its density errors \
             read in the thousands of per cent (docs/stability.md); --preset water is SI water"
        );
    }
    println!(
        "dam break: {:?} preset, {} particles ({}×{}×{}), tank {:.2}×{:.2}×{:.2} m, dt = {:.5} s, {} steps, {} threads",
        args.preset,
        n,
        config.counts[0],
        config.counts[1],
        config.counts[2],
        scene.tank_max.x,
        scene.tank_max.y,
        scene.tank_max.z,
        dt,
        args.steps,
        rayon::current_num_threads()
    );
    println!(
        "{:>7} {:>8} {:>10} {:>10} {:>12} {:>9} {:>7} {:>5} {:>4} {:>9}",
        "step",
        "t (s)",
        "max err",
        "mean err",
        "kinetic (J)",
        "max |v|",
        "escaped",
        "NaN",
        "sub",
        "iters d/v"
    );

    #[cfg(feature = "render")]
    let mut pictures = match &args.render {
        Some(dir) => Some(Pictures::new(&args, dir, &scene)?),
        None => None,
    };
    #[cfg(not(feature = "render"))]
    if args.render.is_some() {
        return Err("--render needs the `render` feature: cargo run --release --example dam_break --features render -- --render DIR".into());
    }
    let frame_every = args.frame_every.unwrap_or((args.steps / 60).max(1)).max(1);
    let _ = frame_every;
    #[cfg(feature = "render")]
    if let Some(p) = &mut pictures {
        let t = Instant::now();
        p.recorder.frame(&scene.world)?;
        p.seconds += t.elapsed().as_secs_f64();
    }

    let mut timings = StageTimings::default();
    let mut max_err: f32 = 0.0;
    let mut mean_err_sum = 0.0f64;
    let mut non_finite = 0;
    let mut fallbacks = 0;
    let (mut relaxed, mut relax_rounds, mut relax_unfinished) = (0, 0u64, 0u64);
    let (mut substeps, mut iterations, mut div_iterations) = (0u64, 0u64, 0u64);
    // The solvers' safeguards: capped solves, the largest relaxation halving, DFSPH solves
    // that finished without the hydrostatic walls' neighbour part.
    let (mut capped, mut halvings, mut dropped) = (0u64, 0u32, 0u64);
    let t0 = Instant::now();
    for step in 1..=args.steps {
        let report = scene.world.step()?;
        timings.accumulate(&report.timings);
        max_err = max_err.max(report.max_density_error);
        mean_err_sum += report.mean_density_error as f64;
        non_finite += report.non_finite;
        fallbacks += report.contact_fallbacks;
        relaxed = relaxed.max(report.relaxed);
        relax_rounds += report.relax_rounds as u64;
        relax_unfinished += report.relax_unfinished as u64;
        substeps += report.substeps as u64;
        iterations += report.solver_iterations as u64;
        div_iterations += report.divergence_iterations as u64;
        capped += report.solver_capped as u64;
        halvings = halvings.max(report.solver_relaxation_halvings);
        dropped += report.solver_wall_neighbour_dropped as u64;
        #[cfg(feature = "render")]
        if let Some(p) = &mut pictures {
            p.step(&scene.world, step % frame_every == 0)?;
        }
        if args.every > 0 && (step % args.every == 0 || step == args.steps) {
            let r = scene.world.pipeline.report();
            let f = &scene.world.fluids[scene.fluid];
            println!(
                "{:>7} {:>8.3} {:>9.2}% {:>9.2}% {:>12.4e} {:>9.3} {:>7} {:>5} {:>4} {:>4}/{:<4}",
                step,
                step as f32 * dt,
                100.0 * r.max_density_error,
                100.0 * r.mean_density_error,
                f.kinetic_energy(),
                r.max_speed,
                scene.escaped(),
                r.non_finite,
                r.substeps,
                r.solver_iterations,
                r.divergence_iterations
            );
        }
    }
    #[allow(unused_mut)]
    let mut wall = t0.elapsed().as_secs_f64();
    #[cfg(feature = "render")]
    if let Some(p) = pictures {
        wall -= p.seconds;
        let frames = p.recorder.frames();
        println!(
            "rendered {frames} frames to {}: {:.1} ms per frame (foam, drawing, PNG + GIF \
             encoding; not counted below)",
            p.dir.display(),
            1e3 * p.seconds / frames.max(1) as f64
        );
        p.recorder.finish()?;
    }
    let steps_per_s = args.steps as f64 / wall;
    println!();
    println!(
        "per-stage time, summed over {} steps (the paper's Tables 1 and 2):",
        args.steps
    );
    println!("{timings}");
    println!();
    println!("wall time            {wall:.3} s (rapier's own step included)");
    println!("steps/s              {steps_per_s:.1}");
    println!("particle-steps/s     {:.3} M", steps_per_s * n as f64 / 1e6);
    println!(
        "wall s per sim s     {:.2}",
        wall / (args.steps as f64 * dt as f64)
    );
    println!(
        "substeps             {substeps} ({:.2} per frame)",
        substeps as f64 / args.steps as f64
    );
    println!(
        "solver iterations    {:.2} density + {:.2} divergence per substep",
        iterations as f64 / substeps as f64,
        div_iterations as f64 / substeps as f64
    );
    println!(
        "solver safeguards    {capped} solves stopped by the iteration cap, relaxation halved \
         {halvings}x at most, {dropped} solves finished without the walls' neighbour pressure"
    );
    println!("max density error    {:.2} %", 100.0 * max_err);
    println!(
        "mean density error   {:.3} % (average over steps)",
        100.0 * mean_err_sum / args.steps as f64
    );
    println!(
        "mean neighbours      {:.1} (last step)",
        scene.world.pipeline.report().neighbour_pairs as f64 / n as f64
    );
    println!(
        "particles            {} (conserved: {})",
        scene.world.fluids.num_particles(),
        scene.world.fluids.num_particles() == n
    );
    println!("escaped              {}", scene.escaped());
    println!("contact fallbacks    {fallbacks}");
    println!(
        "overlap relaxation   {relaxed} particles moved at most, {relax_rounds} rounds, \
         {relax_unfinished} steps stopped by the round cap (spawn overlaps)"
    );
    println!("NaN/inf particles    {non_finite}");
    println!(
        "memory               {:.0} bytes/particle",
        (scene.world.fluids[scene.fluid].heap_bytes() + scene.world.pipeline.heap_bytes()) as f64
            / n as f64
    );
    println!(
        "state hash           {:016x} (FNV-1a of ids, positions, velocities: equal hashes, bitwise equal runs)",
        scene.world.fluids[scene.fluid].state_hash()
    );
    if scene.escaped() > 0 || non_finite > 0 {
        return Err("particles escaped or became non-finite".into());
    }
    Ok(())
}
