//! Why a fine mix of two interacting liquids stays mixed: measurements in the closed tank
//! of `scenes::LayeredTank` (8 × 8 × 8 particles of each liquid at 1.25 cm, DFSPH unless
//! `--solver wcsph`), reported in `rapier_sph::fluid::interaction`'s docs.
//!
//! Each line printed: time (s), the interface height measured from the heavy liquid (twice
//! its particles' mean height, m), the height at rest from the volumes (m), light particles
//! more than a spacing below that height / all light particles, the blob's mean height (m,
//! `--start blob`), the largest and the RMS particle speed (m/s).
//!
//! - `--start checker --k K`: the two liquids mixed in a checkerboard of K³-particle cubes;
//! - `--start side`, `--start layered`: a lock exchange, the settled layers;
//! - `--start blob --k K --at L`: K³ particles of the light liquid swapped into the heavy one,
//!   their lowest layer at L (0: on the floor), the rest layered;
//! - `--start shear`: the effective viscosity of the explicit force (a shear wave's decay in
//!   a periodic box of 16³ particles at the same spacing), no tank.
//!
//! `cargo run --release --example layered_probe -- --start checker --k 2 --viscosity 0.05`
//! `cargo run --release --example layered_probe -- --start blob --k 1 --at 3 --eta 0.03`

use clap::Parser;
use rapier_sph::prelude::*;
use rapier_sph::scenes::{LayeredStart, LayeredTank};
use rapier_sph::{FluidParams, Solver};

#[derive(Parser)]
struct Args {
    /// checker, side, layered, blob or shear.
    #[arg(long, default_value = "checker")]
    start: String,
    /// Block edge in particles (checker) or the blob's edge (blob).
    #[arg(long, default_value_t = 2)]
    k: usize,
    /// Both liquids' viscosity ε (Pa·s; the water preset's is 0.5).
    #[arg(long, default_value_t = 0.5)]
    viscosity: Real,
    /// dfsph or wcsph.
    #[arg(long, default_value = "dfsph")]
    solver: String,
    /// The light liquid's rest density (kg/m³; the heavy one's is 1000).
    #[arg(long, default_value_t = 800.0)]
    light: Real,
    /// Simulated time (s), at 60 frames per second.
    #[arg(long, default_value_t = 5.0)]
    seconds: Real,
    /// Particles across the tank (and layers of each liquid).
    #[arg(long, default_value_t = 8)]
    n: usize,
    /// Print every this many seconds.
    #[arg(long, default_value_t = 0.1)]
    every: Real,
    /// Layers of each liquid (default: `n`).
    #[arg(long)]
    layers: Option<usize>,
    /// The blob's lowest particle layer (0: on the floor).
    #[arg(long, default_value_t = 0)]
    at: usize,
    /// DFSPH's max_density_error.
    #[arg(long, default_value_t = 0.001)]
    eta: Real,
}

/// The decay rate of a shear wave `v_x = A sin(k y)` in a periodic box of 16³ particles at
/// the tank's spacing and the given viscosity (explicit force): the effective kinematic
/// viscosity `ν = rate/k²`.
fn shear(mu: Real) {
    let s: Real = 0.1 / 8.0;
    let n = 16;
    let len = n as Real * s;
    let params = FluidParamsBuilder::water(s)
        .viscosity(mu)
        .periodic(Vector::ZERO, Vector::splat(len))
        .build()
        .unwrap();
    let mut fluid = Fluid::new(params).unwrap();
    let k = std::f32::consts::TAU / len;
    let pos = rapier_sph::fluid::lattice(Vector::splat(0.5 * s), n, n, n, s);
    let vel: Vec<Vector> = pos
        .iter()
        .map(|p| Vector::new(1e-3 * (k * p.y).sin(), 0.0, 0.0))
        .collect();
    fluid
        .add_particles_with_velocities(&pos, Some(&vel))
        .unwrap();
    let mut fluids = FluidSet::new();
    let h = fluids.insert(fluid);
    let amp = |f: &Fluid| -> f64 {
        let sum: f64 = f
            .positions()
            .iter()
            .zip(f.velocities())
            .map(|(p, v)| v.x as f64 * (k * p.y).sin() as f64)
            .sum();
        2.0 * sum / f.len() as f64
    };
    let mut pipeline = FluidPipeline::new();
    let (mut bodies, colliders, bp): (
        rapier_sph::rapier3d::prelude::RigidBodySet,
        rapier_sph::rapier3d::prelude::ColliderSet,
        rapier_sph::rapier3d::prelude::DefaultBroadPhase,
    ) = Default::default();
    let a0 = amp(&fluids[h]);
    let frames = 30;
    for _ in 0..frames {
        pipeline
            .step(
                Vector::ZERO,
                1.0 / 60.0,
                &mut fluids,
                &mut bodies,
                &colliders,
                &bp,
            )
            .unwrap();
    }
    let a1 = amp(&fluids[h]);
    let t = frames as f64 / 60.0;
    let rate = (a0 / a1).ln() / t;
    let nu = rate / (k as f64 * k as f64);
    println!(
        "shear wave eps {mu}: A {a0:.3e} -> {a1:.3e} in {t} s, rate {rate:.4}/s, \
         nu_eff {nu:.4e} m2/s, mu_eff = 1000 nu = {:.4} Pa s (ratio to eps {:.3})",
        1000.0 * nu,
        1000.0 * nu / mu as f64
    );
}

fn main() {
    let a = Args::parse();
    if a.start == "shear" {
        shear(a.viscosity);
        return;
    }
    let s: Real = 0.1 / 8.0;
    let solver = match a.solver.as_str() {
        "wcsph" => Solver::Wcsph,
        _ => Solver::Dfsph(rapier_sph::Dfsph {
            max_density_error: a.eta,
            ..Default::default()
        }),
    };
    let liquid = |rest: Real| -> FluidParams {
        FluidParamsBuilder::water(s)
            .viscosity(a.viscosity)
            .rest_density(rest)
            .solver(solver)
            .build()
            .unwrap()
    };
    let start = match a.start.as_str() {
        "side" => LayeredStart::SideBySide,
        "layered" | "blob" => LayeredStart::Layered,
        _ => LayeredStart::Checker(a.k),
    };
    let n = a.n;
    let mut t = LayeredTank::new(
        liquid(1000.0),
        liquid(a.light),
        [n, a.layers.unwrap_or(n), n],
        start,
    )
    .unwrap();
    let mut blob = 0..0;
    if a.start == "blob" {
        // Swap k³ light particles at the top centre with k³ heavy ones at the bottom centre.
        let k = a.k as Real * s;
        let c = 0.5 * n as Real * s;
        let inside = |x: &Vector, y0: Real| {
            (x.x - c).abs() < 0.5 * k && (x.z - c).abs() < 0.5 * k && x.y > y0 && x.y < y0 + k
        };
        let top = t.surface_height - k;
        let y0 = a.at as Real * s;
        let heavy: Vec<Vector> = t.world.fluids[t.heavy]
            .positions()
            .iter()
            .copied()
            .filter(|x| inside(x, y0))
            .collect();
        let light: Vec<Vector> = t.world.fluids[t.light]
            .positions()
            .iter()
            .copied()
            .filter(|x| inside(x, top))
            .collect();
        t.world.fluids[t.heavy].remove_particles_where(|x, _, _| inside(&x, y0));
        t.world.fluids[t.light].remove_particles_where(|x, _, _| inside(&x, top));
        t.world.fluids[t.heavy].add_particles(&light).unwrap();
        blob = t.world.fluids[t.light].add_particles(&heavy).unwrap();
        println!("blob of {} light particles", heavy.len());
    }
    let frames = (a.seconds * 60.0).round() as usize;
    let every = ((a.every * 60.0).round() as usize).max(1);
    let (m0h, m0l) = (
        t.world.fluids[t.heavy].total_mass(),
        t.world.fluids[t.light].total_mass(),
    );
    println!("t interface(m) target(m) light_below blob_mean_y(m) vmax");
    for f in 0..=frames {
        if f % every == 0 {
            let oil = &t.world.fluids[t.light];
            let below = oil
                .positions()
                .iter()
                .filter(|x| x.y < t.interface_height - s)
                .count();
            let (mut sum, mut cnt) = (0.0, 0);
            for (x, id) in oil.positions().iter().zip(oil.ids()) {
                if blob.contains(id) {
                    sum += x.y;
                    cnt += 1;
                }
            }
            let vmax = [t.heavy, t.light]
                .iter()
                .flat_map(|&h| t.world.fluids[h].velocities().iter().map(|v| v.length()))
                .fold(0.0, Real::max);
            let (mut e2, mut cnt2) = (0.0f64, 0usize);
            for &hd in &[t.heavy, t.light] {
                for v in t.world.fluids[hd].velocities() {
                    e2 += (v.length() as f64).powi(2);
                    cnt2 += 1;
                }
            }
            let rms = (e2 / cnt2 as f64).sqrt();
            println!(
                "{:.2} {:.4} {:.4} {}/{} {:.4} {:.3} {rms:.4}",
                f as Real / 60.0,
                t.measured_interface(),
                t.interface_height,
                below,
                oil.len(),
                if cnt > 0 { sum / cnt as Real } else { 0.0 },
                vmax
            );
        }
        if f < frames {
            t.world.step().unwrap();
        }
    }
    let (m1h, m1l) = (
        t.world.fluids[t.heavy].total_mass(),
        t.world.fluids[t.light].total_mass(),
    );
    println!("mass change heavy {} light {}", m1h - m0h, m1l - m0l);
    println!(
        "hash {:016x} {:016x}",
        t.world.fluids[t.heavy].state_hash(),
        t.world.fluids[t.light].state_hash()
    );
}
