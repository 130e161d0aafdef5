//! A boat in a wave pool: a 500 kg/m³ hull floats in a pool whose kinematic paddle makes
//! waves (`rapier_sph::scenes::WavePool`, the scene of `cargo bench --bench game`). Every
//! half second it prints the hull's draft against Archimedes', its roll and pitch, and the
//! water's vertical force on it (`FluidPipeline::body_force`, averaged over the half second)
//! against its weight: a floating hull's mean is 1.
//!
//! ```text
//! cargo run --release --example boat                          # 10,000 particles, 6 s, headless
//! cargo run --release --example boat -- --particles 2500 --seconds 3
//! cargo run --release --example boat -- --render out/boat     # also PNG frames and a GIF
//! cargo run --release --example boat -- --render out/boat --spheres   # the same frames, spheres
//! ```
//!
//! The pictures draw screen-space water with foam (`FluidStyle::ScreenSpace`); `--spheres`
//! draws the particles as speed-coloured spheres instead.

use rapier_sph::math::{Real, Vector};
use rapier_sph::render::{Camera, FluidStyle, Recorder, RenderOptions};
use rapier_sph::scenes::{WavePool, WavePoolConfig};
use rapier_sph::visual::DiffuseSettings;
use std::path::PathBuf;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse()?;
    let mut pool = WavePool::new(WavePoolConfig {
        particles: args.particles,
        watch_hull: true,
        ..Default::default()
    })?;
    let n0 = pool.world.fluids[pool.water].len();
    println!(
        "boat: {n0} particles of water (spacing {:.1} mm, DFSPH), a 40 × 10 × 24 cm hull of \
         500 kg/m³, a paddle swinging 8 cm every 1.5 s; {} s of 1/60 s frames",
        pool.spacing * 1e3,
        args.seconds
    );
    println!(
        "{:>6} {:>14} {:>9} {:>9} {:>15} {:>16} {:>9}",
        "t (s)",
        "draft/expected",
        "roll (°)",
        "pitch (°)",
        "water level (m)",
        "water force/weight",
        "substeps"
    );
    let mut pictures = args
        .render
        .as_ref()
        .map(|dir| pictures(dir, "boat", args.spheres))
        .transpose()?;
    let frames = (args.seconds * 60.0).round() as usize;
    let weight = {
        let hull = &pool.world.physics.bodies[pool.hull];
        hull.mass() * pool.world.physics.gravity.length()
    };
    let mut lift = 0.0;
    let start = Instant::now();
    for frame in 1..=frames {
        pool.frame()?;
        if let Some(p) = pictures.as_mut() {
            p.step(&pool.world)?;
            if frame % 6 == 0 {
                p.frame(&pool.world)?;
            }
        }
        // The water's vertical force on the hull, averaged over the half second.
        lift += pool.world.pipeline.body_force(pool.hull)?.force.y / 30.0;
        if frame % 30 == 0 {
            let (roll, pitch) = pool.roll_pitch();
            println!(
                "{:>6.2} {:>14.2} {:>9.2} {:>9.2} {:>15.3} {:>16.3} {:>9}",
                frame as Real / 60.0,
                pool.draft_ratio(),
                roll,
                pitch,
                pool.water_level(),
                lift / weight,
                pool.world.pipeline.report().substeps
            );
            lift = 0.0;
        }
    }
    let wall = start.elapsed().as_secs_f64();
    let n = pool.world.fluids[pool.water].len();
    println!(
        "particles {n} (started with {n0}), {} outside the pool; {:.1} ms per frame on average \
         (pictures included)",
        pool.outside(),
        wall * 1e3 / frames as f64
    );
    if let (Some(p), Some(dir)) = (pictures, args.render.as_ref()) {
        p.finish()?;
        println!(
            "pictures  {}/frame_*.png and boat.gif (10 frames a second)",
            dir.display()
        );
    }
    Ok(())
}

struct Args {
    particles: usize,
    seconds: Real,
    render: Option<PathBuf>,
    spheres: bool,
}

impl Args {
    fn parse() -> Result<Self, String> {
        let mut args = Self {
            particles: 10_000,
            seconds: 6.0,
            render: None,
            spheres: false,
        };
        let mut it = std::env::args().skip(1);
        while let Some(a) = it.next() {
            let mut value = |name: &str| it.next().ok_or(format!("{name} needs a value"));
            match a.as_str() {
                "--particles" => {
                    args.particles = value("--particles")?
                        .parse()
                        .map_err(|_| "--particles needs a count")?
                }
                "--seconds" => {
                    args.seconds = value("--seconds")?
                        .parse()
                        .map_err(|_| "--seconds needs a number")?
                }
                "--render" => args.render = Some(PathBuf::from(value("--render")?)),
                "--spheres" => args.spheres = true,
                other => return Err(format!("unknown argument {other}")),
            }
        }
        Ok(args)
    }
}

/// Pictures of every sixth frame (10 a second): `DIR/frame_*.png` and `DIR/boat.gif`;
/// screen-space water with foam, or speed-coloured spheres.
fn pictures(
    dir: &PathBuf,
    name: &str,
    spheres: bool,
) -> Result<Recorder, Box<dyn std::error::Error>> {
    let options = RenderOptions {
        width: 480,
        height: 270,
        style: if spheres {
            FluidStyle::Spheres
        } else {
            FluidStyle::ScreenSpace
        },
        ..RenderOptions::default()
    };
    let camera = Camera::framing(Vector::ZERO, Vector::new(2.0, 0.6, 0.7), 25.0, 32.0);
    let recorder = Recorder::create(dir, name, options, camera, 0.0, 10)?;
    Ok(if spheres {
        recorder
    } else {
        recorder.with_diffuse(DiffuseSettings::default())?
    })
}
