//! Floating boxes with every solver: how deep they float and how calm they are.
//!
//! ```text
//! cargo run --release --example buoyancy                      # WCSPH, densities 250/500/750
//! cargo run --release --example buoyancy -- --solver pbf --spacing 0.03 --seconds 5
//! cargo run --release --example buoyancy -- --solver dfsph-hw   # DFSPH, hydrostatic walls
//! cargo run --release --example buoyancy -- --solver clavet     # Clavet (its default walls)
//! cargo run --release --example buoyancy -- --solver dfsph --density 250 --trace 10  # a line every 10 frames
//! cargo run --release --example buoyancy -- --solver pbf --cubes   # the cubes test's scene: 16 cm cubes, 2.5 cm, 4 s (the test runs 3)
//! cargo run --release --example buoyancy -- --cubes --depth 0.2     # the same in shallower water (0.2 m)
//! cargo run --release --example buoyancy --features render -- --render out/  # PNG + GIF per box
//! ```
//!
//! A tank of water (walls counting in the density) and a box 1.5 times as wide as it is tall
//! (it floats upright at these densities), placed at its expected depth. Over the last second
//! it prints the submerged volume fraction (expected: density / 1000), the RMS acceleration and
//! speed of the box's corners from its poses frame to frame, and the RMS speed of the water
//! next to it. The same measurement as `tests/buoyancy.rs`, for longer runs and other solvers.

use rapier_sph::Solver;
use rapier_sph::math::Real;
use rapier_sph::scenes::{Floating, FloatingBox, FloatingBoxConfig};

fn main() {
    let mut solver = Solver::Wcsph;
    let (mut s, mut seconds) = (0.04, 3.0);
    let mut densities = vec![250.0, 500.0, 750.0];
    let mut render: Option<std::path::PathBuf> = None;
    let mut trace: Option<usize> = None;
    let mut cubes = false;
    let mut depth: Option<Real> = None;
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i < args.len() {
        let value = args.get(i + 1).cloned().unwrap_or_default();
        if args[i] == "--cubes" {
            // tests/buoyancy.rs's cubes scene (a 0.5 m tank, 0.3 m of water, 16 cm cubes):
            // its defaults, which later flags may still override.
            (cubes, s, seconds) = (true, 0.025, 4.0);
            i += 1;
            continue;
        }
        match args[i].as_str() {
            "--solver" => {
                solver = match value.as_str() {
                    "wcsph" => Solver::Wcsph,
                    "dfsph" => Solver::dfsph(),
                    "dfsph-hw" => Solver::Dfsph(rapier_sph::solver::Dfsph {
                        hydrostatic_walls: true,
                        ..Default::default()
                    }),
                    "pbf" => Solver::Pbf(Default::default()),
                    "clavet" => Solver::clavet(),
                    other => exit(&format!(
                        "unknown solver {other} (wcsph, dfsph, dfsph-hw, pbf, clavet)"
                    )),
                }
            }
            "--spacing" => s = parse(&value, "--spacing"),
            "--seconds" => seconds = parse(&value, "--seconds"),
            "--density" => densities = vec![parse(&value, "--density")],
            "--render" => render = Some(value.into()),
            "--depth" => depth = Some(parse(&value, "--depth")),
            "--trace" => trace = Some(parse(&value, "--trace").max(1.0) as usize),
            other => exit(&format!(
                "unknown argument {other} (--solver, --spacing, --seconds, --density, --render, --trace N, --cubes, --depth D)"
            )),
        }
        i += 2;
    }
    #[cfg(not(feature = "render"))]
    if render.is_some() {
        exit(
            "--render needs the `render` feature: cargo run --release --example buoyancy --features render -- --render DIR",
        );
    }
    if !(s > 0.0 && seconds >= 1.0) {
        exit("--spacing must be positive and --seconds at least 1");
    }
    println!("solver {solver:?}, spacing {s} m, {seconds} s; last second:");
    for density in densities {
        let t0 = std::time::Instant::now();
        let dir = render
            .as_ref()
            .map(|d| d.join(format!("density_{density}")));
        let f = float(
            solver,
            s,
            density,
            seconds,
            dir.as_deref(),
            trace,
            cubes,
            depth,
        );
        println!(
            "density {density}: submerged {:.3} (expected {:.3}), corners: RMS acceleration \
             {:.3} g, RMS speed {:.4} m/s (water next to it {:.4}); lowest corner {:.3} m up; \
             {:.1} s",
            f.submerged,
            (density / 1000.0).min(1.0),
            f.shaking / 9.81,
            f.speed,
            f.water,
            f.bottom,
            t0.elapsed().as_secs_f64()
        );
    }
}

fn parse(v: &str, name: &str) -> Real {
    v.parse()
        .unwrap_or_else(|_| exit(&format!("{name} needs a number")))
}

fn exit(msg: &str) -> ! {
    eprintln!("{msg}");
    std::process::exit(2)
}

/// Pictures of one run (`--render DIR`): every 4th frame, the tank seen from above the water.
#[cfg(feature = "render")]
fn recorder(dir: &std::path::Path, tank: Real, top: Real) -> rapier_sph::render::Recorder {
    use rapier_sph::math::Vector;
    use rapier_sph::render::{Camera, Recorder, RenderOptions};
    let camera = Camera::framing(Vector::ZERO, Vector::new(tank, top, tank), 30.0, 35.0);
    let options = RenderOptions {
        width: 480,
        height: 360,
        speed_range: Some((0.0, 0.3)),
        ..RenderOptions::default()
    };
    Recorder::create(dir, "buoyancy", options, camera, 0.0, 7)
        .unwrap_or_else(|e| exit(&e.to_string()))
}

/// The test's scene and measurement ([`FloatingBox`]): a 0.72 m tank, 0.3 m of water, a box
/// 0.3 × 0.2 × 0.3 m (with `cubes`: a 0.5 m tank, 0.3 m of water, a 16 cm cube) at its expected depth;
/// `seconds` of 60 Hz frames, the last one measured.
#[allow(clippy::too_many_arguments)] // one argument per command-line option, passed straight on
fn float(
    solver: Solver,
    s: Real,
    density: Real,
    seconds: Real,
    render: Option<&std::path::Path>,
    trace: Option<usize>,
    cubes: bool,
    depth: Option<Real>,
) -> Floating {
    let mut scene = FloatingBox::new(FloatingBoxConfig {
        spacing: s,
        tank: if cubes { 0.5 } else { 0.72 },
        depth: depth.unwrap_or(0.3),
        half_width: if cubes { 0.08 } else { 0.15 },
        half_height: if cubes { 0.08 } else { 0.1 },
        density,
        solver,
    })
    .unwrap_or_else(|e| exit(&e.to_string()));
    let (body, fluid) = (scene.body, scene.fluid);
    #[cfg(feature = "render")]
    let mut pictures = render.map(|dir| recorder(dir, scene.config.tank, scene.tank_height()));
    #[cfg(not(feature = "render"))]
    let _ = render;
    let f = scene
        .run(seconds, |_frame, _world| {
            // `--trace N`: the box's height and angular speed, the water's kinetic energy and
            // the total mechanical energy every N frames (a body at rest should settle, the
            // water's energy decay, and the total never grow).
            if let Some(every) = trace
                && _frame % every == 0
            {
                let b = &_world.physics.bodies[body];
                let w = &_world.fluids[fluid];
                let g = _world.physics.gravity.length() as f64;
                let m = w.params().particle_mass as f64;
                // Mechanical energy of water and box (potential from y = 0, the floor).
                let water_pe: f64 = w.positions().iter().map(|x| m * g * x.y as f64).sum();
                let box_e =
                    b.kinetic_energy() as f64 + b.mass() as f64 * g * b.center_of_mass().y as f64;
                println!(
                    "  frame {_frame:4}: box center y {:.4} m, angular speed {:.3} rad/s, water \
                     kinetic energy {:.4} J, total (water + box, kinetic + potential) {:.4} J",
                    b.translation().y,
                    b.angvel().length(),
                    w.kinetic_energy(),
                    w.kinetic_energy() + water_pe + box_e
                );
            }
            #[cfg(feature = "render")]
            if let Some(p) = pictures.as_mut()
                && _frame % 4 == 0
            {
                p.frame(_world).unwrap_or_else(|e| exit(&e.to_string()));
            }
            Ok(())
        })
        .unwrap_or_else(|e| exit(&e.to_string()));
    #[cfg(feature = "render")]
    if let Some(p) = pictures {
        let (dir, frames) = (render.unwrap_or(std::path::Path::new(".")), p.frames());
        p.finish().unwrap_or_else(|e| exit(&e.to_string()));
        println!("  {frames} frames and buoyancy.gif in {}", dir.display());
    }
    f
}
