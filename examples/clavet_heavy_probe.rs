//! A 16 cm box slightly denser than water released with its top at the surface of water
//! 0.44 m deep (4 cm spacing, 0.6 m tank; `tests/light_bodies.rs`'s
//! `slightly_dense_boxes_sink_once_water_covers_their_top`), with Clavet's relaxation at a
//! chosen cohesion, the tank's walls in its densities or not (the box, a dynamic body, meets
//! Clavet's water through contact either way): how it sinks.
//!
//! ```text
//! cargo run --release --example clavet_heavy_probe -- [density] [cohesion] [seconds] [walls] [solver]
//! ```
//!
//! Defaults: 1400 kg/m³, cohesion 1 (Clavet's default), 4 s, walls `true`, solver `clavet`
//! (`dfsph`, `pbf`, `wcsph` run the same box for comparison; `cohesion` is then ignored).
//! Every half second it prints the box's lowest corner, its vertical speed, the force the
//! fluid must carry beyond Archimedes for the column from the box's bottom to the water's
//! level (`(m_b − ρ_w·A·(level − bottom))·g`, N: what a meniscus pinned at the top edge
//! holds when no water is over the top face) and the number of particles over its top face
//! (within its footprint, less than a spacing and a half above it), and its tilt (the angle of
//! its up axis from the vertical).
//!
//! Environment knobs (docs/coupling.md, "Known limits", has what they measured):
//! `PROBE_LEVEL` the water's depth (m, default 0.44), `PROBE_K` Clavet's stiffness `k`
//! (default 1), `PROBE_KICK` zero-mean pseudo-random velocity kicks of that amplitude (m/s)
//! to every particle before each frame (default 0: none), and `PROBE_DUMP` (set) prints, at
//! the end, every particle of the slab one spacing thick through the box's center (`x`, `z`
//! from the box's center, height `y`, density over `ρ0`, pressure, speed).

use rapier_sph::math::{Real, Vector};
use rapier_sph::scenes::{FloatingBox, FloatingBoxConfig};
use rapier_sph::{Clavet, Pbf, Solver};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |i: usize, d: &str| args.get(i).cloned().unwrap_or_else(|| d.to_string());
    let density: Real = arg(1, "1400").parse().expect("density");
    let cohesion: Real = arg(2, "1").parse().expect("cohesion");
    let seconds: Real = arg(3, "4").parse().expect("seconds");
    let walls = arg(4, "true") == "true";
    let solver = match arg(5, "clavet").as_str() {
        "clavet" => Solver::Clavet(Clavet {
            cohesion,
            stiffness: std::env::var("PROBE_K")
                .ok()
                .map_or(1.0, |v| v.parse().expect("k")),
            ..Clavet::default()
        }),
        "dfsph" => Solver::dfsph(),
        "pbf" => Solver::Pbf(Pbf::default()),
        "wcsph" => Solver::Wcsph,
        other => panic!("unknown solver {other}"),
    };
    let level: Real = std::env::var("PROBE_LEVEL")
        .ok()
        .map_or(0.44, |v| v.parse().expect("level"));
    let (spacing, half) = (0.04, 0.08);
    let config = FloatingBoxConfig {
        spacing,
        tank: 0.6,
        depth: level,
        half_width: half,
        half_height: half,
        density,
        solver,
    };
    let mut scene = FloatingBox::new(config).expect("scene");
    if !walls {
        // `FloatingBox` asks for walls in the densities; rebuild the fluid without them.
        let f = &mut scene.world.fluids[scene.fluid];
        let mut p = f.params().clone();
        p.wall_density = false;
        f.set_params(p).expect("params");
    }
    let (body, fluid) = (scene.body, scene.fluid);
    let mass = density * (2.0 * half).powi(3);
    let area = (2.0 * half) * (2.0 * half);
    let frames = (seconds * 60.0) as usize;
    println!(
        "{} {density} kg/m³, cohesion {cohesion}, walls in the densities {walls}; boat bottom {:.4} m",
        solver.name(),
        level - density / 1000.0 * 2.0 * half
    );
    let kick: Real = std::env::var("PROBE_KICK")
        .ok()
        .map_or(0.0, |v| v.parse().expect("kick"));
    for frame in 1..=frames {
        if kick > 0.0 {
            // Zero-mean pseudo-random velocity kicks of amplitude `kick` (m/s) to every particle.
            let v = scene.world.fluids[fluid].velocities_mut();
            let n = v.len();
            let dv: Vec<Vector> = (0..n)
                .map(|i| {
                    let mut h = (i as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15)
                        ^ (frame as u64).wrapping_mul(0xBF58_476D_1CE4_E5B9);
                    let mut r = || {
                        h ^= h >> 31;
                        h = h.wrapping_mul(0x94D0_49BB_1331_11EB);
                        ((h >> 40) as Real / (1u64 << 24) as Real) * 2.0 - 1.0
                    };
                    Vector::new(r(), r(), r()) * kick
                })
                .collect();
            let mean = dv.iter().copied().fold(Vector::ZERO, |a, b| a + b) / n as Real;
            for (a, d) in v.iter_mut().zip(&dv) {
                *a += *d - mean;
            }
        }
        scene.world.step().expect("step");
        if frame % 30 != 0 {
            continue;
        }
        let b = &scene.world.physics.bodies[body];
        let pose = *b.position();
        let lowest = (0..8)
            .map(|k| {
                let sign = |bit: usize| if k & bit == 0 { -half } else { half };
                pose.transform_point(Vector::new(sign(1), sign(2), sign(4)))
                    .y
            })
            .fold(Real::MAX, Real::min);
        let over = scene.world.fluids[fluid]
            .positions()
            .iter()
            .filter(|p| {
                let l = pose.inverse_transform_point(**p);
                l.x.abs() < half && l.z.abs() < half && l.y > half && l.y < half + 1.5 * spacing
            })
            .count();
        let excess = (mass - 1000.0 * area * (level - lowest)) * 9.81;
        // The tilt: the angle of the box's own up axis from the vertical.
        let up = pose.rotation * Vector::Y;
        let tilt = up.y.clamp(-1.0, 1.0).acos().to_degrees();
        println!(
            "t {:.1} s: lowest corner {lowest:.4} m, v_y {:+.4} m/s, beyond Archimedes {excess:+.2} N, over the top {over}, tilt {tilt:.1}°",
            frame as Real / 60.0,
            b.linvel().y
        );
    }
    if std::env::var("PROBE_DUMP").is_ok() {
        let pose = *scene.world.physics.bodies[body].position();
        let c = pose.translation;
        let f = &scene.world.fluids[fluid];
        let (x, rho, pr, v) = (f.positions(), f.densities(), f.pressures(), f.velocities());
        let mut rows: Vec<usize> = (0..x.len())
            .filter(|&i| {
                (x[i].z - c.z).abs() < 0.5 * spacing
                    && (x[i].x - c.x).abs() < half + 3.0 * spacing
                    && x[i].y < c.y + half + 1.5 * spacing
            })
            .collect();
        rows.sort_by(|&a, &b| (x[a].y, x[a].x).partial_cmp(&(x[b].y, x[b].x)).unwrap());
        println!("box center {c:?}");
        for i in rows {
            println!(
                "x {:+.4} y {:.4} z {:+.4} rho/rho0 {:.4} p {:8.1} |v| {:.4}",
                x[i].x - c.x,
                x[i].y,
                x[i].z - c.z,
                rho[i] / 1000.0,
                pr[i],
                v[i].length()
            );
        }
    }
}
