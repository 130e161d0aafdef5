//! Floating boxes with every solver: how deep they float and how calm they are.
//!
//! ```text
//! cargo run --release --example buoyancy                      # WCSPH, densities 250/500/750
//! cargo run --release --example buoyancy -- --solver pbf --spacing 0.03 --seconds 5
//! cargo run --release --example buoyancy --features render -- --render out/  # PNG + GIF per box
//! ```
//!
//! A tank of water (walls counting in the density) and a box 1.5 times as wide as it is tall
//! (it floats upright at these densities), placed at its expected depth. Over the last second
//! it prints the submerged volume fraction (expected: density / 1000), the RMS acceleration and
//! speed of the box's corners from its poses frame to frame, and the RMS speed of the water
//! next to it. The same measurement as `tests/buoyancy.rs`, for longer runs and other solvers.

use rapier_sph::rapier3d::prelude::*;
use rapier_sph::{Fluid, FluidWorld, Solver};

fn main() {
    let mut solver = Solver::Wcsph;
    let (mut s, mut seconds) = (0.04, 3.0);
    let mut densities = vec![250.0, 500.0, 750.0];
    let mut render: Option<std::path::PathBuf> = None;
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i < args.len() {
        let value = args.get(i + 1).cloned().unwrap_or_default();
        match args[i].as_str() {
            "--solver" => {
                solver = match value.as_str() {
                    "wcsph" => Solver::Wcsph,
                    "dfsph" => Solver::dfsph(),
                    "pbf" => Solver::Pbf(Default::default()),
                    other => exit(&format!("unknown solver {other} (wcsph, dfsph, pbf)")),
                }
            }
            "--spacing" => s = parse(&value, "--spacing"),
            "--seconds" => seconds = parse(&value, "--seconds"),
            "--density" => densities = vec![parse(&value, "--density")],
            "--render" => render = Some(value.into()),
            other => exit(&format!(
                "unknown argument {other} (--solver, --spacing, --seconds, --density, --render)"
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
        let f = float(solver, s, density, seconds, dir.as_deref());
        println!(
            "density {density}: submerged {:.3} (expected {:.3}), corners: RMS acceleration \
             {:.3} g, RMS speed {:.4} m/s (water next to it {:.4}); {:.1} s",
            f.0,
            (density / 1000.0).min(1.0),
            f.1 / 9.81,
            f.2,
            f.3,
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

/// `(submerged volume fraction, corners' RMS acceleration, corners' RMS speed, water's RMS
/// speed next to the box)` over the last second.
/// Pictures of one run (`--render DIR`): every 4th frame, the tank seen from above the water.
#[cfg(feature = "render")]
fn recorder(dir: &std::path::Path, tank: Real, top: Real) -> rapier_sph::render::Recorder {
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

fn float(
    solver: Solver,
    s: Real,
    density: Real,
    seconds: Real,
    render: Option<&std::path::Path>,
) -> (Real, Real, Real, Real) {
    let (tank, depth, hw, hh) = (0.72, 0.3, 0.15, 0.1);
    let mut world = FluidWorld::new();
    let dt = 1.0 / 60.0;
    world.physics.integration_parameters.dt = dt;
    let top = depth + 2.0 * hh + 0.1;
    rapier_sph::scenes::add_closed_box(
        &mut world,
        Vector::ZERO,
        Vector::new(tank, top, tank),
        0.05,
    );
    let params = rapier_sph::FluidParamsBuilder::water(s)
        .wall_density(true)
        .solver(solver)
        .build()
        .unwrap_or_else(|e| exit(&e.to_string()));
    let mut fluid = Fluid::new(params).unwrap();
    let c = 0.5 * tank;
    let half = Vector::new(hw, hh, hw);
    let centre = Vector::new(
        c,
        depth + hh * (1.0 - 2.0 * density.min(1000.0) / 1000.0),
        c,
    );
    let n = (tank / s) as usize;
    let pts: Vec<Vector> =
        rapier_sph::fluid::lattice(Vector::splat(0.5 * s), n, (depth / s) as usize, n, s)
            .into_iter()
            .filter(|p| ((*p - centre).abs() - half - Vector::splat(0.5 * s)).max_element() > 0.0)
            .collect();
    fluid.add_particles(&pts).unwrap();
    let fluid = world.fluids.insert(fluid);
    let body = world
        .physics
        .insert_body(RigidBodyBuilder::dynamic().translation(centre));
    world.physics.insert_collider(
        ColliderBuilder::cuboid(hw, hh, hw).density(density),
        Some(body),
    );
    world.physics.step();
    #[cfg(feature = "render")]
    let mut pictures = render.map(|dir| recorder(dir, tank, top));
    #[cfg(not(feature = "render"))]
    let _ = render;
    let frames = (seconds * 60.0) as usize;
    let corner = half.length();
    let (mut sum, mut water, mut count) = (0.0f64, 0.0f64, 0usize);
    let mut poses = Vec::new();
    for frame in 0..frames {
        world.step().unwrap_or_else(|e| exit(&e.to_string()));
        #[cfg(feature = "render")]
        if let Some(p) = pictures.as_mut()
            && frame % 4 == 0
        {
            p.frame(&world).unwrap_or_else(|e| exit(&e.to_string()));
        }
        if frame + 62 < frames {
            continue;
        }
        let pose = *world.physics.bodies[body].position();
        poses.push(pose);
        if frame + 60 < frames {
            continue;
        }
        let f = &world.fluids[fluid];
        let (mut w2, mut wn) = (0.0f64, 0usize);
        for (x, v) in f.positions().iter().zip(f.velocities()) {
            if (pose.inverse_transform_point(*x).abs() - half).max_element() < 2.0 * s {
                w2 += v.length_squared() as f64;
                wn += 1;
            }
        }
        water += w2 / wn.max(1) as f64;
        // Water surface: the topmost 5 % of the particles two spacings clear of the box.
        let mut tops: Vec<Real> = f
            .positions()
            .iter()
            .filter(|p| (p.x - c).abs() > hw + 2.0 * s || (p.z - c).abs() > hw + 2.0 * s)
            .map(|p| p.y)
            .collect();
        tops.sort_by(|a, b| b.total_cmp(a));
        let k = (tops.len() / 20).max(1);
        let surface = tops[..k].iter().sum::<Real>() / k as Real + 0.5 * s;
        sum += submerged_fraction(&pose, half, surface) as f64;
        count += 1;
    }
    let vel: Vec<(Vector, Vector)> = poses
        .windows(2)
        .map(|w| {
            (
                (w[1].translation - w[0].translation) / dt,
                (w[1].rotation * w[0].rotation.inverse()).to_scaled_axis() / dt,
            )
        })
        .collect();
    let (mut a2, mut v2) = (0.0f64, 0.0f64);
    for w in vel.windows(2) {
        let a = (w[1].0 - w[0].0).length() / dt + (w[1].1 - w[0].1).length() / dt * corner;
        a2 += (a as f64).powi(2);
    }
    for (v, w) in &vel {
        v2 += ((v.length() + w.length() * corner) as f64).powi(2);
    }
    #[cfg(feature = "render")]
    if let Some(p) = pictures {
        let (dir, frames) = (render.unwrap_or(std::path::Path::new(".")), p.frames());
        p.finish().unwrap_or_else(|e| exit(&e.to_string()));
        println!("  {frames} frames and buoyancy.gif in {}", dir.display());
    }
    (
        (sum / count as f64) as Real,
        (a2 / (vel.len() - 1) as f64).sqrt() as Real,
        (v2 / vel.len() as f64).sqrt() as Real,
        (water / count as f64).sqrt() as Real,
    )
}

/// Fraction of the box's volume below `surface` (32 × 32 columns along the box's own y axis,
/// each exact).
fn submerged_fraction(pose: &Pose, half: Vector, surface: Real) -> Real {
    const N: usize = 32;
    let mut sum = 0.0;
    for i in 0..N {
        for k in 0..N {
            let u = (i as Real + 0.5) / N as Real * 2.0 - 1.0;
            let w = (k as Real + 0.5) / N as Real * 2.0 - 1.0;
            let y0 = pose
                .transform_point(Vector::new(u * half.x, -half.y, w * half.z))
                .y;
            let y1 = pose
                .transform_point(Vector::new(u * half.x, half.y, w * half.z))
                .y;
            let (lo, hi) = (y0.min(y1), y0.max(y1));
            sum += if hi - lo < 1e-9 {
                (lo < surface) as u8 as Real
            } else {
                ((surface - lo) / (hi - lo)).clamp(0.0, 1.0)
            };
        }
    }
    sum / (N * N) as Real
}
