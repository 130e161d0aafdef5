//! Limits: every allocation sized by user input is checked first (a typed error naming the
//! argument, never an abort or a hang), and every setting that asks for unbounded work is
//! refused.

use rapier_sph::math::{Real, Vector};
use rapier_sph::scenes::{DamBreakConfig, dam_break};
use rapier_sph::{FluidParamsBuilder, Solver};

/// Heap bytes per particle once a fluid has stepped: the figure behind
/// `rapier_sph::fluid::BYTES_PER_PARTICLE`. Prints; run with `--ignored --nocapture`.
#[test]
#[ignore]
fn bytes_per_particle() {
    for solver in [
        Solver::dfsph(),
        Solver::Wcsph,
        Solver::pbf(),
        Solver::clavet(),
        Solver::Clavet(rapier_sph::solver::Clavet {
            springs: Some(Default::default()),
            ..Default::default()
        }),
    ] {
        let h: Real = std::env::var("H").map_or(2.0, |v| v.parse().unwrap());
        let params = FluidParamsBuilder::water(0.05)
            .solver(solver)
            .smoothing_length(h * 0.05)
            .build()
            .unwrap();
        let config = DamBreakConfig::tower(
            params,
            DamBreakConfig::scale_for(std::env::var("N").map_or(5000, |v| v.parse().unwrap())),
        );
        let mut d = dam_break(&config).unwrap();
        let mut most: f64 = 0.0;
        for _ in 0..20 {
            d.world.step().unwrap();
            let f = &d.world.fluids[d.fluid];
            most = most.max(f.heap_bytes() as f64 / f.len() as f64);
        }
        let f = &d.world.fluids[d.fluid];
        println!(
            "{}{}: {} particles, {:.1} neighbours expected, {:.0} bytes per particle (largest over 20 frames)",
            solver.name(),
            if matches!(solver, Solver::Clavet(c) if c.springs.is_some()) {
                " + springs"
            } else {
                ""
            },
            f.len(),
            f.params().expected_neighbours(),
            most
        );
    }
    let _: Real = 0.0;
    let _ = Vector::ZERO;
}
