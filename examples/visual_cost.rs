//! Cost of the drawing data of `rapier_sph::visual` (anisotropy, interpolation, diffuse
//! particles) per particle, on a water dam break caught mid-collapse; with the `render`
//! feature also the screen-space renderer's milliseconds per frame.
//!
//! ```text
//! cargo run --release --example visual_cost -- --particles 10000
//! cargo run --release --example visual_cost -- --particles 100000 --frames 12
//! cargo run --release --example visual_cost --features render -- --particles 10000 --render
//! ```

use clap::Parser;
use rapier_sph::FluidParamsBuilder;
use rapier_sph::scenes::{DamBreakConfig, dam_break};
use rapier_sph::visual::{
    Anisotropy, AnisotropySettings, DiffuseParticles, DiffuseSettings, Interpolation,
};
use std::time::Instant;

#[derive(Parser, Debug)]
#[command(about = "Per-particle cost of anisotropy, interpolation and diffuse particles")]
struct Args {
    /// Approximate particle count of the water dam break.
    #[arg(long, default_value_t = 10_000)]
    particles: usize,
    /// Particle spacing (m).
    #[arg(long, default_value_t = 0.02)]
    spacing: f32,
    /// Frames (1/60 s) simulated before measuring (the column is collapsing by then).
    #[arg(long, default_value_t = 24)]
    frames: usize,
    /// Repetitions of each measurement (the median is printed).
    #[arg(long, default_value_t = 15)]
    repeat: usize,
    /// Rayon threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Also time the screen-space renderer at 640×360 (needs the `render` feature).
    #[arg(long)]
    render: bool,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

fn time(repeat: usize, mut f: impl FnMut()) -> (f64, f64, f64) {
    let v: Vec<f64> = (0..repeat.max(1))
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .collect();
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(0.0, f64::max);
    (median(v), lo, hi)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    if let Some(t) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build_global()?;
    }
    let params = FluidParamsBuilder::water(args.spacing).build()?;
    let scale = DamBreakConfig::scale_for_at_least(args.particles);
    let mut scene = dam_break(&DamBreakConfig::tower(params, scale))?;
    let dt = scene.world.physics.integration_parameters.dt;
    let mut lerp = Interpolation::new();
    let mut diffuse = DiffuseParticles::new(DiffuseSettings::default())?;
    let t = Instant::now();
    for _ in 0..args.frames {
        scene.world.step()?;
        let f = &scene.world.fluids[scene.fluid];
        lerp.record(f);
        diffuse.step(f, scene.world.physics.gravity, dt)?;
    }
    let sim = t.elapsed().as_secs_f64();
    let f = &scene.world.fluids[scene.fluid];
    let n = f.len();
    println!(
        "water dam break, {n} particles, spacing {} m, after {} frames ({:.1} ms per frame simulated incl. diffuse), {} rayon threads",
        args.spacing,
        args.frames,
        1e3 * sim / args.frames as f64,
        rayon::current_num_threads()
    );
    let per = |s: f64| 1e9 * s / n as f64;
    let line = |name: &str, (m, lo, hi): (f64, f64, f64)| {
        println!(
            "  {name:<44} {:8.3} ms  {:7.1} ns/particle  (min {:.1}, max {:.1})",
            1e3 * m,
            per(m),
            per(lo),
            per(hi)
        );
    };
    for radius in [2.5, 4.0] {
        let mut a = Anisotropy::new(AnisotropySettings {
            radius,
            ..Default::default()
        })?;
        a.compute(f); // warm
        line(
            &format!("anisotropy (R = {radius} spacings)"),
            time(args.repeat, || {
                a.compute(f);
            }),
        );
    }
    {
        // The same pass with every particle a sphere: the neighbour search and the
        // weighted sums without the eigen decompositions.
        let mut a = Anisotropy::new(AnisotropySettings {
            min_neighbors: usize::MAX,
            ..Default::default()
        })?;
        a.compute(f);
        line(
            "  of which search + sums (R = 2.5, no eigen)",
            time(args.repeat, || {
                a.compute(f);
            }),
        );
    }
    line(
        "interpolation (record + positions)",
        time(args.repeat, || {
            lerp.record(f);
            let _ = lerp.positions(0.5).unwrap().len();
        }),
    );
    let snapshot = diffuse.clone();
    let mut last = None;
    line(
        &format!("diffuse step ({} alive)", diffuse.len()),
        time(args.repeat, || {
            let mut d = snapshot.clone();
            last = Some(d.step(f, scene.world.physics.gravity, dt).unwrap());
        }),
    );
    println!(
        "  (the diffuse time includes cloning {} diffuse particles; last step: {:?})",
        snapshot.len(),
        last
    );

    #[cfg(feature = "render")]
    if args.render {
        use rapier_sph::render::{Camera, RenderOptions, Renderer};
        let camera = Camera::framing(scene.tank_min, scene.tank_max, 30.0, 28.0);
        for (name, options) in [
            (
                "render: screen-space fluid, 640x360",
                RenderOptions::default(),
            ),
            (
                "render: spheres (the old mode), 640x360",
                RenderOptions {
                    style: rapier_sph::render::FluidStyle::Spheres,
                    ..RenderOptions::default()
                },
            ),
        ] {
            let mut r = Renderer::new(options);
            let _ = r.render_world(&camera, &scene.world, None);
            let (m, lo, hi) = time(args.repeat.min(7), || {
                let _ = r.render_world(&camera, &scene.world, None);
            });
            println!(
                "  {name:<44} {:8.1} ms per frame (min {:.1}, max {:.1})",
                1e3 * m,
                1e3 * lo,
                1e3 * hi
            );
            let t = r.screen_space_timings();
            if t.splat > 0.0 {
                println!(
                    "    last frame: anisotropy {:.1} ms, splats {:.1} ms, depth filter {:.1} ms, foam + shading {:.1} ms",
                    1e3 * t.anisotropy,
                    1e3 * t.splat,
                    1e3 * t.filter,
                    1e3 * t.shade
                );
            }
        }
    }
    #[cfg(not(feature = "render"))]
    if args.render {
        return Err("--render needs the `render` feature".into());
    }
    Ok(())
}
