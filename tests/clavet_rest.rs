//! Clavet's relaxation as the error-vs-run-time report runs it (`validation::methods()`):
//! a column spawned at rest in a closed tank stays at rest at every step the report takes
//! but the one beyond the stability limit on purpose (release mode; a few seconds).

use rapier_sph::Solver;
use rapier_sph::validation::{Method, TimePolicy, hydrostatic, methods};

fn clavet() -> Method {
    methods()
        .into_iter()
        .find(|m| matches!(m.solver, Solver::Clavet(_)))
        .expect("Clavet is in validation::methods()")
}

/// The report's hydrostatic tank (`N × 2N × N` particles on the lattice, 1 s) at the fixed
/// step `dt_ref/2` and at the adaptive step. Nothing in the scene moves but the lattice
/// settling onto its own rest state, so every bound comes from the spacing `s`: no particle
/// rises more than half a spacing above the lattice's top row (`max_height`, the highest
/// particle over the top row's height `(2N − ½)s`, at most `1 + ½/(2N − ½)`), and the
/// mechanical energy never exceeds the initial potential energy by more than lifting the
/// whole column by half a spacing would give (`energy_excess ≤ (s/2)/ȳ = 1/(2N)`, the column's
/// mean height `ȳ = N·s`).
///
/// With contact-only walls (the report's Clavet before it counted walls in its densities)
/// the cohesion pulled the tank's corners and edges in from the first step (the spawn
/// lattice's cohesion energy: 2.9 / 1.6 / 0.71 times the potential energy at N = 6 / 8 /
/// 12): at `dt_ref/2` the kinetic energy passed the potential energy within 3 steps (N = 6),
/// the adaptive runs rose to 1.19 of the column's height.
#[test]
fn a_clavet_column_at_rest_stays_at_rest_at_small_and_adaptive_steps() {
    let method = clavet();
    for n in [6usize, 8] {
        for policy in [TimePolicy::FixedSmall, TimePolicy::Adaptive] {
            let r = hydrostatic::run(&method, n, policy, &mut |_| {}).unwrap();
            let excess = r.error("energy_excess").unwrap();
            let height = r.error("max_height").unwrap();
            let label = format!("N = {n}, {}", policy.name());
            println!(
                "{label}: energy excess {excess:+.5}, max height {height:.5}, {}",
                r.note
            );
            assert!(r.stable, "{label}: unstable: {}", r.note);
            let height_bound = 1.0 + 0.5 / (2.0 * n as f64 - 0.5);
            assert!(
                height <= height_bound,
                "{label}: max height {height} > {height_bound}"
            );
            let energy_bound = 0.5 / n as f64;
            assert!(
                excess <= energy_bound,
                "{label}: energy excess {excess} > {energy_bound}"
            );
        }
    }
}
