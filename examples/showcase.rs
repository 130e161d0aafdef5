//! The first thing to run: a dam of water breaks in a closed tank, floods a shallow pool and
//! throws three floating crates about; a granite block stands its ground. The crates and the
//! block are rapier bodies: the water lifts and pushes them, they push the water back.
//!
//! SI water (`FluidParamsBuilder::water`) with its default solver, DFSPH, stepped in 1/60 s
//! frames that the pipeline splits into the substeps it needs, as a game would step it.
//! Prints what happened and writes a GIF and one PNG frame.
//!
//! ```text
//! cargo run --release --example showcase                  # writes out/showcase.gif, out/showcase.png
//! cargo run --release --example showcase -- --no-render   # the simulation only
//! cargo run --release --example showcase -- --help
//! ```

use rapier_sph::math::{Real, Vector};
use rapier_sph::prelude::*;
use rapier_sph::rapier3d::prelude::{
    ColliderBuilder, ColliderHandle, RigidBodyBuilder, RigidBodyHandle,
};
use rapier_sph::render::{Camera, GifWriter, RenderOptions, Renderer};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Interior of the tank (m): 1.6 m long, 0.8 m tall, 0.6 m deep, closed on all six sides.
const TANK: Vector = Vector::new(1.6, 0.8, 0.6);
/// The dam: a column of water against the left wall, across the tank.
const DAM: Vector = Vector::new(0.4, 0.5, 0.6);
/// Depth of the pool over the rest of the floor (m).
const POOL: Real = 0.1;
/// Half extents of a crate (m) and its density (pine, kg/m³): it floats half under.
const CRATE: (Vector, Real) = (Vector::new(0.08, 0.06, 0.08), 500.0);
/// Half extents of the granite block (m) and its density (kg/m³): it stays on the floor.
const BLOCK: (Vector, Real) = (Vector::new(0.06, 0.08, 0.06), 2700.0);

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    let s = args.spacing;

    // A rapier world stepped in 60 Hz frames, a closed tank of fixed cuboids, the bodies.
    let mut world = FluidWorld::new();
    world.physics.integration_parameters.dt = 1.0 / 60.0;
    add_tank(&mut world);
    let floating = POOL; // a crate half under has its center at the water's level
    let mut boxes = Vec::new();
    for (x, z) in [(0.75, 0.17), (1.0, 0.4), (1.3, 0.2)] {
        boxes.push(add_box(&mut world, Vector::new(x, floating, z), CRATE));
    }
    boxes.push(add_box(
        &mut world,
        Vector::new(1.15, BLOCK.0.y, 0.45),
        BLOCK,
    ));

    // The water: the dam and the pool on the fluid's spawn lattice, leaving the boxes out.
    let mut water = Fluid::new(FluidParamsBuilder::water(s).build()?)?;
    water.add_particles(&lattice(Vector::ZERO, DAM, s, &boxes))?;
    let pool_min = Vector::new(DAM.x, 0.0, 0.0);
    let pool_max = Vector::new(TANK.x, POOL, TANK.z);
    water.add_particles(&lattice(pool_min, pool_max, s, &boxes))?;
    let n = water.len();
    let solver = water.params().solver.name();
    let water = world.fluids.insert(water);

    let frames = (args.seconds * 60.0).round() as usize;
    println!(
        "showcase: {n} particles of water (spacing {:.0} mm, {solver}), 3 crates and a granite \
         block in a closed {}×{}×{} m tank, {frames} frames of 1/60 s",
        s * 1000.0,
        TANK.x,
        TANK.y,
        TANK.z
    );

    let mut pictures = match &args.out {
        Some(dir) => Some(Pictures::new(dir, &boxes)?),
        None => None,
    };
    let (mut sim_seconds, mut substeps) = (0.0f64, 0u64);
    let (mut error_sum, mut error_max) = (0.0f64, 0.0 as Real);
    for frame in 1..=frames {
        let t = Instant::now();
        let report = world.step()?; // rapier's step, then the fluid's substeps
        sim_seconds += t.elapsed().as_secs_f64();
        substeps += report.substeps as u64;
        // The mean compression over all particles: what DFSPH holds near its 0.1 % target.
        error_sum += report.mean_density_error as f64;
        error_max = error_max.max(report.mean_density_error);
        let (substeps_now, fastest) = (report.substeps, report.max_speed);
        if let Some(p) = pictures.as_mut() {
            p.frame(frame, &world)?;
        }
        if frame % 60 == 0 {
            println!(
                "  t = {} s: {substeps_now} substeps in this frame, fastest particle {fastest:.2} m/s",
                frame / 60
            );
        }
    }

    // Particles lost: any particle outside the tank's interior (one that went through a wall;
    // contact's swept queries are meant to make this impossible).
    let fluid = &world.fluids[water];
    let inside = |p: &Vector| {
        let margin = Vector::splat(1e-4);
        p.cmpge(-margin).all() && p.cmple(TANK + margin).all()
    };
    let lost = n - fluid.positions().iter().filter(|p| inside(p)).count();
    let height = |i: usize| world.physics.bodies[boxes[i].body].translation().y;
    // The water's level at rest: its volume plus what the crates (half) and the block (all)
    // displace, over the floor. A floating crate's center sits at that level.
    let displaced = |(half, _): (Vector, Real)| 8.0 * half.x * half.y * half.z;
    let level = (fluid.len() as Real * s * s * s + 1.5 * displaced(CRATE) + displaced(BLOCK))
        / (TANK.x * TANK.z);

    println!();
    println!(
        "particles            {} (started with {n}), lost {lost}",
        fluid.len()
    );
    println!(
        "simulation speed     {:.0} frames per second ({:.1} ms per 1/60 s frame, {:.1} substeps \
         per frame; rapier's step included, pictures not)",
        frames as f64 / sim_seconds,
        1e3 * sim_seconds / frames as f64,
        substeps as f64 / frames as f64
    );
    println!(
        "density error        {:.2} % on average, {:.2} % in the worst frame (mean compression \
         over all particles; DFSPH's target 0.1 %)",
        100.0 * error_sum / frames as f64,
        100.0 * error_max
    );
    println!(
        "bodies               crates' centers {:.3} / {:.3} / {:.3} m above the floor, the \
         water's level at rest {level:.3} m (they float half under; the water still sloshes); \
         granite block {:.3} m ({:.3} m standing on the floor)",
        height(0),
        height(1),
        height(2),
        height(3),
        BLOCK.0.y
    );
    if let Some(p) = pictures {
        p.finish()?;
    }
    if lost > 0 || fluid.len() != n {
        return Err(format!(
            "{lost} particles left the tank, {} were removed",
            n - fluid.len()
        )
        .into());
    }
    Ok(())
}

/// A closed box of six fixed cuboids, 5 cm thick, whose interior is `[0, TANK]`.
fn add_tank(world: &mut FluidWorld) {
    let body = world.physics.insert_body(RigidBodyBuilder::fixed());
    let (c, t) = (TANK * 0.5, 0.05);
    let walls = [
        (
            Vector::new(c.x, -t, c.z),
            Vector::new(c.x + 2.0 * t, t, c.z + 2.0 * t),
        ),
        (
            Vector::new(c.x, TANK.y + t, c.z),
            Vector::new(c.x + 2.0 * t, t, c.z + 2.0 * t),
        ),
        (
            Vector::new(-t, c.y, c.z),
            Vector::new(t, c.y + 2.0 * t, c.z + 2.0 * t),
        ),
        (
            Vector::new(TANK.x + t, c.y, c.z),
            Vector::new(t, c.y + 2.0 * t, c.z + 2.0 * t),
        ),
        (
            Vector::new(c.x, c.y, -t),
            Vector::new(c.x + 2.0 * t, c.y + 2.0 * t, t),
        ),
        (
            Vector::new(c.x, c.y, TANK.z + t),
            Vector::new(c.x + 2.0 * t, c.y + 2.0 * t, t),
        ),
    ];
    for (center, half) in walls {
        let wall = ColliderBuilder::cuboid(half.x, half.y, half.z).translation(center);
        world.physics.insert_collider(wall, Some(body));
    }
}

/// A box on a dynamic body: its center, half extents and density.
struct Box3 {
    body: RigidBodyHandle,
    collider: ColliderHandle,
    center: Vector,
    half: Vector,
}

fn add_box(world: &mut FluidWorld, center: Vector, (half, density): (Vector, Real)) -> Box3 {
    let body = world
        .physics
        .insert_body(RigidBodyBuilder::dynamic().translation(center));
    let shape = ColliderBuilder::cuboid(half.x, half.y, half.z).density(density);
    let collider = world.physics.insert_collider(shape, Some(body));
    Box3 {
        body,
        collider,
        center,
        half,
    }
}

/// Lattice points at spacing `s` filling `[min, max]`, except within half a spacing of a box.
fn lattice(min: Vector, max: Vector, s: Real, boxes: &[Box3]) -> Vec<Vector> {
    let n = ((max - min) / s).floor();
    let mut points = Vec::new();
    for i in 0..n.x as usize {
        for j in 0..n.y as usize {
            for k in 0..n.z as usize {
                let p = min + (Vector::new(i as Real, j as Real, k as Real) + 0.5) * s;
                let clear = |b: &Box3| ((p - b.center).abs() - b.half).max_element() >= 0.5 * s;
                if boxes.iter().all(clear) {
                    points.push(p);
                }
            }
        }
    }
    points
}

/// A GIF of every third frame (20 frames a second: real time) and one PNG, drawn by the crate's software renderer
/// (feature `render`, on for the examples).
struct Pictures {
    dir: PathBuf,
    renderer: Renderer,
    camera: Camera,
    gif: GifWriter,
    seconds: f64,
}

impl Pictures {
    /// The frame saved as a PNG: 1/3 s in, as the surge reaches the crates.
    const STILL: usize = 20;

    fn new(dir: &Path, boxes: &[Box3]) -> Result<Self, Box<dyn std::error::Error>> {
        std::fs::create_dir_all(dir)?;
        let (width, height) = (480, 270);
        let wood = [0.60, 0.38, 0.18];
        let granite = [0.30, 0.30, 0.34];
        let options = RenderOptions {
            width,
            height,
            speed_range: Some((0.0, 3.0)),
            collider_colors: boxes
                .iter()
                .enumerate()
                .map(|(i, b)| (b.collider, if i < 3 { wood } else { granite }))
                .collect(),
            ..RenderOptions::default()
        };
        Ok(Self {
            dir: dir.to_path_buf(),
            renderer: Renderer::new(options),
            // The water's part of the tank, from the front, a little from the right and above.
            camera: Camera::framing(Vector::ZERO, Vector::new(TANK.x, 0.55, TANK.z), 25.0, 32.0),
            gif: GifWriter::create(dir.join("showcase.gif"), width, height, 5)?,
            seconds: 0.0,
        })
    }

    fn frame(
        &mut self,
        frame: usize,
        world: &FluidWorld,
    ) -> Result<(), Box<dyn std::error::Error>> {
        if !frame.is_multiple_of(3) && frame != Self::STILL {
            return Ok(());
        }
        let t = Instant::now();
        let image = self.renderer.render_world(&self.camera, world, None);
        if frame.is_multiple_of(3) {
            self.gif.add_frame(&image)?;
        }
        if frame == Self::STILL {
            image.save_png(self.dir.join("showcase.png"))?;
        }
        self.seconds += t.elapsed().as_secs_f64();
        Ok(())
    }

    fn finish(self) -> Result<(), Box<dyn std::error::Error>> {
        self.gif.finish()?;
        println!(
            "pictures             {} and {} ({:.1} s of drawing and encoding)",
            self.dir.join("showcase.gif").display(),
            self.dir.join("showcase.png").display(),
            self.seconds
        );
        Ok(())
    }
}

struct Args {
    spacing: Real,
    seconds: Real,
    out: Option<PathBuf>,
}

impl Args {
    fn parse() -> Self {
        let mut a = Args {
            spacing: 0.025,
            seconds: 4.0,
            out: Some(PathBuf::from("out")),
        };
        let argv: Vec<String> = std::env::args().skip(1).collect();
        let mut i = 0;
        while i < argv.len() {
            let next = argv.get(i + 1).map(String::as_str).unwrap_or("");
            let number = |name: &str| -> Real {
                next.parse()
                    .unwrap_or_else(|_| fail(&format!("{name} needs a number")))
            };
            match argv[i].as_str() {
                "--spacing" => a.spacing = number("--spacing"),
                "--seconds" => a.seconds = number("--seconds"),
                "--out" => a.out = Some(PathBuf::from(next)),
                "--no-render" => {
                    a.out = None;
                    i += 1;
                    continue;
                }
                "--help" | "-h" => {
                    println!(
                        "showcase: a dam break floods a pool with floating crates (rapier bodies)\n\n\
                         --spacing S   particle spacing in m (default 0.025: 11,607 particles)\n\
                         --seconds T   simulated seconds (default 4)\n\
                         --out DIR     where showcase.gif and showcase.png go (default out)\n\
                         --no-render   no pictures"
                    );
                    std::process::exit(0);
                }
                other => fail(&format!("unknown argument {other} (try --help)")),
            }
            i += 2;
        }
        if !(a.spacing >= 0.01 && a.spacing <= 0.05 && a.seconds > 0.0) {
            fail("--spacing must be within [0.01, 0.05] m and --seconds positive");
        }
        a
    }
}

fn fail(msg: &str) -> ! {
    eprintln!("{msg}");
    std::process::exit(2)
}
