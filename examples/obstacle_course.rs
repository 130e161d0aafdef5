//! The obstacle course: water from an emitter runs down a ramp, through pegs, a
//! funnel, over heightfield terrain under a rotating paddle wheel, around a compound
//! obstacle and floating crates, into a bucket whose fill is read through the fluid query.
//! The scene is `rapier_sph::scenes::obstacle_course`, shared with the tests.
//!
//! ```text
//! cargo run --release --example obstacle_course                        # headless, plain lines
//! cargo run --release --example obstacle_course -- --spacing 0.02      # finer (more particles)
//! cargo run --release --example obstacle_course --features cli         # with a progress bar
//! cargo run --release --example obstacle_course --features render -- --render out/
//! ```

use clap::Parser;
use rapier_sph::scenes::{ObstacleCourseConfig, obstacle_course};
use rapier_sph::{FluidParamsBuilder, StageTimings};
use std::time::Instant;

#[derive(Parser, Debug)]
#[command(about = "SPH water running down an obstacle course of rapier colliders into a bucket")]
struct Args {
    /// Particle spacing (m): the particle count grows as 1/spacing³ (0.03 gives a few
    /// thousand particles over 8 s, 0.02 about three times more).
    #[arg(long, default_value_t = 0.03)]
    spacing: f32,
    /// Emission rate as a fraction of the nozzle's blocking rate.
    #[arg(long, default_value_t = 0.8)]
    rate_fraction: f32,
    /// Simulated seconds.
    #[arg(long, default_value_t = 8.0)]
    seconds: f32,
    /// Paddle wheel speed (rad/s).
    #[arg(long, default_value_t = 4.0)]
    wheel_speed: f32,
    /// Rayon threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Print a line every this many frames when there is no progress bar (0: never).
    #[arg(long, default_value_t = 60)]
    every: usize,
    /// Write PNG frames and `obstacle_course.gif` into this folder (needs the `render`
    /// feature).
    #[arg(long, value_name = "DIR")]
    render: Option<std::path::PathBuf>,
    /// Frames between rendered pictures.
    #[arg(long, default_value_t = 6)]
    frame_every: usize,
    /// Picture size.
    #[arg(long, default_value = "640x360")]
    size: String,
    /// Draw the particles as spheres coloured by speed (the renderer's older style) instead
    /// of screen-space water with foam.
    #[arg(long)]
    spheres: bool,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    if let Some(t) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build_global()?;
    }
    let params = FluidParamsBuilder::water(args.spacing).build()?;
    let mut config = ObstacleCourseConfig::new(params);
    config.rate_fraction = args.rate_fraction;
    config.wheel_speed = args.wheel_speed;
    let mut course = obstacle_course(&config)?;
    let frames = (args.seconds * 60.0).round() as usize;

    #[cfg(feature = "render")]
    let mut pictures = match &args.render {
        Some(dir) => {
            use rapier_sph::render::{
                Camera, FluidStyle, GifWriter, RenderOptions, Renderer, WorldDiffuse,
            };
            let (w, h) = args
                .size
                .split_once('x')
                .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
                .ok_or("--size must look like 640x360")?;
            std::fs::create_dir_all(dir)?;
            let options = RenderOptions {
                width: w,
                height: h,
                speed_range: Some((0.0, 4.0)),
                style: if args.spheres {
                    FluidStyle::Spheres
                } else {
                    FluidStyle::ScreenSpace
                },
                ..RenderOptions::default()
            };
            let diffuse = if args.spheres {
                None
            } else {
                Some(WorldDiffuse::new(Default::default())?)
            };
            // From above the near side, looking down the course.
            let camera = Camera::orbit(
                rapier_sph::math::Vector::new(1.9, 0.8, 0.0),
                5.2,
                20.0,
                35.0,
            );
            Some((
                dir.clone(),
                Renderer::new(options),
                camera,
                GifWriter::create(dir.join("obstacle_course.gif"), w, h, 10)?,
                0usize,
                diffuse,
            ))
        }
        None => None,
    };
    #[cfg(not(feature = "render"))]
    if args.render.is_some() {
        return Err("--render needs the `render` feature: cargo run --release --example obstacle_course --features render -- --render DIR".into());
    }

    #[cfg(feature = "cli")]
    let bar = {
        let bar = indicatif::ProgressBar::new(frames as u64);
        bar.set_style(indicatif::ProgressStyle::with_template(
            "{bar:40} {pos}/{len} frames {msg}",
        )?);
        bar
    };

    let mut timings = StageTimings::default();
    let (mut emitted, mut drained, mut quarantined, mut substeps, mut blocked) = (0, 0, 0, 0u64, 0);
    let mut sim_seconds = 0.0f64;
    let mut max_fill = 0.0f32;
    for frame in 1..=frames {
        let t = Instant::now();
        let report = course.world.step()?.clone();
        sim_seconds += t.elapsed().as_secs_f64();
        timings.accumulate(&report.timings);
        emitted += report.emitted;
        drained += report.drained;
        quarantined += report.quarantined;
        blocked += report.emitter_blocked;
        substeps += report.substeps as u64;
        let (bucket, fill) = course.bucket();
        max_fill = max_fill.max(fill);
        let line = format!(
            "t = {:5.2} s  particles {:6}  emitted {:6}  in bucket {:5} (fill {:5.1} mm)  drained {:4}",
            frame as f32 / 60.0,
            report.particles,
            emitted,
            bucket.particles,
            fill * 1e3,
            drained
        );
        #[cfg(feature = "cli")]
        {
            bar.set_position(frame as u64);
            bar.set_message(line);
        }
        #[cfg(not(feature = "cli"))]
        if args.every > 0 && frame % args.every == 0 {
            println!("{line}");
        }
        #[cfg(feature = "render")]
        if let Some((_, _, _, _, _, Some(diffuse))) = &mut pictures {
            diffuse.step(&course.world)?;
        }
        #[cfg(feature = "render")]
        if let Some((dir, renderer, camera, gif, n, diffuse)) = &mut pictures
            && frame % args.frame_every.max(1) == 0
        {
            let layers = diffuse.as_ref().map(|d| d.layers()).unwrap_or_default();
            let image = renderer.render_world_with(camera, &course.world, None, &layers);
            image.save_png(dir.join(format!("frame_{:04}.png", *n)))?;
            gif.add_frame(&image)?;
            *n += 1;
        }
    }
    #[cfg(feature = "cli")]
    bar.finish();
    let _ = args.every;

    let f = &course.world.fluids[course.fluid];
    let live = f.len();
    let lost = emitted as i64 - live as i64 - drained as i64 - quarantined as i64;
    let (bucket, fill) = course.bucket();
    let crates: Vec<String> = course
        .crates
        .iter()
        .map(|&b| {
            let x = course.world.physics.bodies[b].translation();
            format!("({:.2}, {:.2}, {:.2})", x.x, x.y, x.z)
        })
        .collect();
    println!();
    println!(
        "obstacle course, spacing {} m, {} frames of 1/60 s ({} fluid substeps)",
        args.spacing, frames, substeps
    );
    println!("  emitted      {emitted} (blocked at the nozzle: {blocked})");
    println!("  live         {live}");
    println!(
        "  in bucket    {} particles, {:.2} L, fill {:.1} mm of {:.0} mm",
        bucket.particles,
        bucket.volume * 1e3,
        fill * 1e3,
        course.bucket_depth * 1e3
    );
    println!("  drained      {drained}");
    println!("  quarantined  {quarantined}");
    println!("  lost         {lost}");
    println!("  crates at    {}", crates.join(" "));
    println!(
        "  wall time    {:.2} s for the world steps (rapier + fluid): {:.1} frames/s, {:.0} fluid substeps/s",
        sim_seconds,
        frames as f64 / sim_seconds,
        substeps as f64 / sim_seconds
    );
    println!("  fluid stages (whole run):");
    println!("{timings}");
    #[cfg(feature = "render")]
    if let Some((dir, _, _, _, n, _)) = pictures {
        println!("  rendered {n} frames to {}", dir.display());
    }
    if lost != 0 {
        return Err(format!("{lost} particles unaccounted for").into());
    }
    Ok(())
}
