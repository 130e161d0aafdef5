//! Still water and sleeping (`rapier_sph::sleep`): a 0.6 × 0.3 × 0.6 m block of water in a
//! closed tank, left alone. Prints, every 0.5 s, how much the particles jitter (speeds, and
//! how far they went over the last 0.5 s in spacings), and with `--sleep` when the water fell
//! asleep and what that dropped.
//!
//! ```text
//! cargo run --release --example still_water -- --spacing 0.03 --seconds 10
//! cargo run --release --example still_water -- --spacing 0.03 --seconds 10 --sleep
//! ```

use rapier_sph::prelude::*;
use rapier_sph::rapier3d::prelude::{ColliderBuilder, RigidBodyBuilder};
use std::collections::HashMap;

fn main() -> SphResult<()> {
    let argv: Vec<String> = std::env::args().collect();
    let value = |name: &str| argv.windows(2).find(|w| w[0] == name).map(|w| w[1].clone());
    let s: Real = value("--spacing")
        .and_then(|v| v.parse().ok())
        .unwrap_or(0.03);
    let seconds: Real = value("--seconds")
        .and_then(|v| v.parse().ok())
        .unwrap_or(10.0);
    let sleep = argv.iter().any(|a| a == "--sleep").then(Sleep::default);
    let mut world = FluidWorld::new();
    let ground = world.physics.insert_body(RigidBodyBuilder::fixed());
    let (x, y, t) = (0.3, 0.25, 0.05);
    for (c, h) in [
        (Vector::new(x, -t, x), Vector::new(x + t, t, x + t)),
        (Vector::new(-t, y, x), Vector::new(t, y + t, x + t)),
        (Vector::new(2.0 * x + t, y, x), Vector::new(t, y + t, x + t)),
        (Vector::new(x, y, -t), Vector::new(x + t, y + t, t)),
        (Vector::new(x, y, 2.0 * x + t), Vector::new(x + t, y + t, t)),
    ] {
        let wall = ColliderBuilder::cuboid(h.x, h.y, h.z).translation(c);
        world.physics.insert_collider(wall, Some(ground));
    }
    let mut water = Fluid::new(FluidParamsBuilder::water(s).sleep(sleep))?;
    let size = Vector::new(0.6 - s, 0.3, 0.6 - s);
    water.add_block(Vector::splat(0.5 * s), size)?;
    let water = world.fluids.insert(water);
    println!(
        "{} particles at {s} m, sleep {:?}",
        world.fluids[water].len(),
        sleep
    );
    let mut anchor: HashMap<u32, Vector> = HashMap::new();
    let frames = (seconds * 60.0) as usize;
    for frame in 1..=frames {
        let ms = std::time::Instant::now();
        world.step()?;
        let ms = ms.elapsed().as_secs_f64() * 1e3;
        if frame % 30 != 0 {
            continue;
        }
        let f = &world.fluids[water];
        let mut speeds: Vec<Real> = f.velocities().iter().map(|v| v.length()).collect();
        speeds.sort_by(Real::total_cmp);
        let mut drift: Vec<Real> = f
            .ids()
            .iter()
            .zip(f.positions())
            .filter_map(|(id, x)| Some((*x - *anchor.get(id)?).length() / s))
            .collect();
        drift.sort_by(Real::total_cmp);
        let q = |v: &[Real], p: f64| v.get(((v.len().max(1) - 1) as f64 * p) as usize).copied();
        println!(
            "{:5.1} s | speed p50 {:.4} max {:.4} m/s | 0.5 s drift p50 {:.3} p99 {:.3} max {:.3} spacings | KE {:.3e} J/kg | {} | frame {ms:.2} ms | {:?}",
            frame as Real / 60.0,
            q(&speeds, 0.5).unwrap_or(0.0),
            q(&speeds, 1.0).unwrap_or(0.0),
            q(&drift, 0.5).unwrap_or(0.0),
            q(&drift, 0.99).unwrap_or(0.0),
            q(&drift, 1.0).unwrap_or(0.0),
            f.kinetic_energy() / f.total_mass() as f64,
            if f.is_sleeping() { "asleep" } else { "awake" },
            f.sleep_info(),
        );
        anchor = f
            .ids()
            .iter()
            .copied()
            .zip(f.positions().iter().copied())
            .collect();
    }
    Ok(())
}
