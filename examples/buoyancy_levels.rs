//! How deep `tests/buoyancy.rs`'s boxes float against two readings of the water's level:
//! the top particles' height plus half a spacing (the scene's and the test's), and the level
//! the water's mass gives (the level at the start, on the lattice, scaled by the particles
//! found away from the box now against then: the pressure under the box is the weight of the
//! water above it). The free surface's layers close up as the water settles, so the first
//! level falls below the second (docs/coupling.md, "Buoyancy").
//!
//! ```text
//! cargo run --release --example buoyancy_levels -- dfsph 500
//! cargo run --release --example buoyancy_levels -- wcsph 250 0.04
//! ```
//!
//! Arguments: the solver (`dfsph`, `wcsph`, `pbf`; default DFSPH), the box's density (500
//! kg/m³) and the spacing (0.04 m). The scene is the test's: a 0.72 m tank, 0.3 m of water,
//! a 0.3 × 0.2 × 0.3 m box, measured over the 3rd second.

use rapier_sph::math::{Real, Vector};
use rapier_sph::scenes::{FloatingBox, FloatingBoxConfig, submerged_fraction};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let solver = match args.get(1).map(|s| s.as_str()) {
        Some("wcsph") => rapier_sph::Solver::Wcsph,
        Some("pbf") => rapier_sph::Solver::pbf(),
        _ => rapier_sph::Solver::dfsph(),
    };
    let density: Real = args.get(2).and_then(|v| v.parse().ok()).unwrap_or(500.0);
    let s: Real = args.get(3).and_then(|v| v.parse().ok()).unwrap_or(0.04);
    let (tank, hw, hh) = (0.72, 0.15, 0.1);
    let mut scene = FloatingBox::new(FloatingBoxConfig {
        spacing: s,
        tank,
        depth: 0.3,
        half_width: hw,
        half_height: hh,
        density,
        solver,
    })
    .unwrap();
    let mid = 0.5 * tank;
    // Away from the box, as the scene reads the level.
    let open = |p: &Vector| (p.x - mid).abs() > hw + 2.0 * s || (p.z - mid).abs() > hw + 2.0 * s;
    // The top particles' level (the scene's reading) and the particles counted.
    let measure = |scene: &FloatingBox| {
        let f = &scene.world.fluids[scene.fluid];
        let mut tops: Vec<Real> = f
            .positions()
            .iter()
            .filter(|p| open(p))
            .map(|p| p.y)
            .collect();
        let n = tops.len();
        tops.sort_by(|a, b| b.total_cmp(a));
        let k = (tops.len() / 20).max(1);
        (tops[..k].iter().sum::<Real>() / k as Real + 0.5 * s, n)
    };
    let (level0, n0) = measure(&scene);
    let half = Vector::new(hw, hh, hw);
    let (mut top, mut mass, mut gap, mut count) = (0.0, 0.0, 0.0, 0);
    for frame in 0..180 {
        scene.world.step().unwrap();
        if frame < 120 {
            continue;
        }
        let (level, n) = measure(&scene);
        let mass_level = level0 * n as Real / n0 as Real;
        let pose = *scene.world.physics.bodies[scene.body].position();
        top += submerged_fraction(&pose, half, level);
        mass += submerged_fraction(&pose, half, mass_level);
        gap += (mass_level - level) / s;
        count += 1;
    }
    let k = count as Real;
    println!(
        "{} {density} kg/m³ at {s} m: submerged {:.3} against the top particles' level, {:.3} \
         against the mass level (expected {:.3}); the mass level {:.3} spacings above the other",
        solver.name(),
        top / k,
        mass / k,
        density / 1000.0,
        gap / k
    );
}
