//! WCSPH with its densities from the continuity equation and δ-SPH density diffusion
//! (`WcsphDensity::Continuity`, `crate::delta_sph`) on Adami's walls: the report's `WCSPH-D`.
//! Hydrostatic pressure of a settled column, energy in every report scene under gravity,
//! bitwise-identical results across thread counts, the typed errors of the setting.

mod common;

use common::on_each;
use rapier_sph::math::{Real, Vector};
use rapier_sph::validation::{Method, RunRecord, Scene, TimePolicy};
use rapier_sph::{
    Fluid, FluidParamsBuilder, FluidSet, Solver, SphError, WcsphDensity, WcsphPressure,
};

/// The report's `WCSPH-D`: WCSPH, wall density, Adami's walls, δ-SPH densities (δ = 0.1).
fn wcsph_delta() -> Method {
    Method {
        name: "WCSPH-D",
        solver: Solver::Wcsph,
        wall_density: true,
        wcsph_pressure: WcsphPressure::Adami,
        wcsph_density: WcsphDensity::DELTA_SPH,
    }
}

fn no_progress() -> impl FnMut(Real) {
    |_| {}
}

/// `scene.run` with [`wcsph_delta`] at `resolution` and `policy`. The hydrostatic tank at
/// N = 8 with the adaptive step is read by both the pressure and the energy test: that run
/// is made once and shared (the harness runs the tests in one process; a test asking while
/// the other computes it waits, `OnceLock::get_or_init`).
fn delta_run(scene: Scene, resolution: usize, policy: TimePolicy) -> RunRecord {
    use std::sync::OnceLock;
    static HYDROSTATIC_8: OnceLock<RunRecord> = OnceLock::new();
    let run = || {
        scene
            .run(&wcsph_delta(), resolution, policy, &mut no_progress())
            .unwrap()
    };
    if (scene, resolution, policy) == (Scene::Hydrostatic, 8, TimePolicy::Adaptive) {
        HYDROSTATIC_8.get_or_init(run).clone()
    } else {
        run()
    }
}

/// Stable, no particle lost (each has the same mass: the mass is conserved iff the count
/// is), none outside the tank.
fn assert_conserved(r: &RunRecord) {
    let label = format!("{} N={} {}", r.scene, r.resolution, r.policy.name());
    assert!(r.stable, "{label}: not stable: {}", r.note);
    assert_eq!(r.particles_end, r.particles, "{label}: particles lost");
    assert_eq!(r.escaped, 0, "{label}: particles outside the tank");
}

/// The hydrostatic tank at N = 8 and 12: the bottom pressure within 2 % of `ρ0·g·depth`,
/// the tolerance of `tests/validation.rs`' hydrostatic tests (the bottom layer's depth is
/// known to a quarter of a spacing: 1.6 % of the 16-layer column, 1.0 % of the 24-layer
/// one, plus the weak compressibility's own `ρ0·g·H/(ρ0·c²)` < 0.1 %). The continuity
/// equation keeps no memory of the lattice: a density that drifts (Molteni & Colagrossi's
/// diffusion alone flattens the hydrostatic density profile, which Fourtakas et al.'s
/// correction prevents) moves the bottom pressure with it, so this also bounds the drift.
/// The mean density error over the settled column is printed (a figure).
#[test]
fn delta_sph_hydrostatic_bottom_pressure_within_2_percent() {
    for n in [8, 12] {
        let r = delta_run(Scene::Hydrostatic, n, TimePolicy::Adaptive);
        assert_conserved(&r);
        let e = r.error("bottom_pressure").unwrap();
        println!(
            "WCSPH-D, N = {n}: bottom pressure {e:+.4}, pressure RMS {:.4}, mean density error {:.5}",
            r.error("pressure_rms").unwrap(),
            r.error("mean_density_error").unwrap()
        );
        assert!(e.abs() <= 0.02, "N = {n}: bottom pressure error {e:+.4}");
    }
}

/// Energy in every report scene under gravity at its default resolution, adaptive and
/// fixed `dt/2`: the mechanical energy never exceeds the column's initial potential energy
/// by more than 1 % (`tests/validation.rs`' `ENERGY_TOLERANCE` and its reasons: nothing does
/// work on a column released from rest in a fixed tank; the spawn lattice settling against
/// walls that count in the density gains at most a few tenths of a per cent). The density
/// diffusion is dissipative in the continuum (it smooths the density, lowering the elastic
/// energy `Σ m·u(ρ)`), so it must not raise this bound. The highest particle is printed.
/// One test a time policy, so that the two run side by side on the test harness's two
/// threads.
mod delta_sph_mechanical_energy_never_exceeds_the_initial_potential_energy {
    use super::TimePolicy;

    #[test]
    fn adaptive() {
        super::energy_never_exceeds_e0(TimePolicy::Adaptive);
    }

    #[test]
    fn fixed_half_step() {
        super::energy_never_exceeds_e0(TimePolicy::FixedSmall);
    }
}

/// [`delta_sph_mechanical_energy_never_exceeds_the_initial_potential_energy`] at `policy`.
fn energy_never_exceeds_e0(policy: TimePolicy) {
    // The Taylor–Green vortex has no gravity (its `energy_excess` is NaN): not run.
    for scene in Scene::ALL.into_iter().filter(|&s| s != Scene::TaylorGreen) {
        let r = delta_run(scene, scene.default_resolution(), policy);
        let excess = r.error("energy_excess").unwrap();
        assert!(!excess.is_nan(), "{}: no energy under gravity", r.scene);
        assert_conserved(&r);
        let label = format!("{} N={} {}", r.scene, r.resolution, policy.name());
        println!(
            "{label}: mechanical energy {excess:+.5} of E_0, highest particle {:.3} × the initial top",
            r.error("max_height").unwrap()
        );
        assert!(excess <= 0.01, "{label}: energy {excess:+.5} of E_0");
    }
}

/// A small dam break in a closed box with δ-SPH densities gives the same bits on 1 and 3
/// threads: every loop of `delta_sph` writes one particle from its neighbours, no
/// reduction.
#[test]
fn delta_sph_is_bitwise_identical_across_thread_counts() {
    let run = || {
        let params = FluidParamsBuilder::water(0.025)
            .solver(Solver::Wcsph)
            .wcsph_pressure(WcsphPressure::Adami)
            .wcsph_density(WcsphDensity::DELTA_SPH)
            .build()
            .unwrap();
        let s = params.particle_spacing;
        let mut world = rapier_sph::FluidWorld::new();
        let max = Vector::new(0.6, 0.4, 4.0 * s);
        rapier_sph::scenes::add_closed_box(&mut world, Vector::ZERO, max, 0.05);
        world.physics.step();
        let mut fluid = Fluid::new(params).unwrap();
        let lattice = rapier_sph::fluid::try_lattice(Vector::splat(0.5 * s), 8, 10, 4, s);
        fluid.add_particles(&lattice.unwrap()).unwrap();
        let h = world.fluids.insert(fluid);
        world.physics.integration_parameters.dt = 1.0 / 120.0;
        for _ in 0..40 {
            world.step_fluids().unwrap();
        }
        let f = &world.fluids[h];
        let bits = |v: &[Vector]| -> Vec<[u32; 3]> {
            v.iter()
                .map(|v| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()])
                .collect()
        };
        let densities: Vec<u32> = f.densities().iter().map(|d| d.to_bits()).collect();
        (bits(f.positions()), bits(f.velocities()), densities)
    };
    let results = on_each(&[1, 3], run);
    assert!(results[0] == results[1], "1 vs 3 threads differ");
}

/// The setting's typed errors: a diffusion coefficient outside `0..=1` (or NaN) names
/// `wcsph_density`; two interacting WCSPH fluids with δ-SPH densities are refused naming it.
#[test]
fn delta_sph_bad_settings_are_typed_errors() {
    for delta in [-0.1, 1.5, Real::NAN] {
        let err = FluidParamsBuilder::water(0.05)
            .wcsph_density(WcsphDensity::Continuity { delta })
            .build()
            .unwrap_err();
        assert!(
            matches!(
                err,
                SphError::InvalidParameter {
                    field: "wcsph_density",
                    ..
                }
            ),
            "{delta}: {err}"
        );
    }
    let params = |rest: Real| {
        FluidParamsBuilder::water(0.05)
            .solver(Solver::Wcsph)
            .wcsph_density(WcsphDensity::DELTA_SPH)
            .rest_density(rest)
            .fluid_groups(rapier_sph::rapier3d::geometry::InteractionGroups::all())
            .build()
            .unwrap()
    };
    let mut set = FluidSet::new();
    let mut fluids = Vec::new();
    for (rest, y) in [(1000.0, 0.0), (800.0, 0.2)] {
        let mut f = Fluid::new(params(rest)).unwrap();
        f.add_particles(&[Vector::new(0.0, y, 0.0)]).unwrap();
        fluids.push(set.insert(f));
    }
    let mut world = rapier_sph::FluidWorld::new();
    world.fluids = set;
    let err = world.step_fluids().unwrap_err();
    assert!(
        matches!(
            err,
            SphError::InvalidParameter {
                field: "wcsph_density",
                ..
            }
        ),
        "{err}"
    );
}

/// The scene-file field: `wcsph_density: Continuity(delta: 0.1)` reads as
/// `WcsphDensity::DELTA_SPH` (the shipped `scenes/wcsph_delta_sph.ron`), a coefficient out
/// of range is refused naming the field.
#[cfg(feature = "scene")]
#[test]
fn delta_sph_from_a_scene_file() {
    use rapier_sph::scene_file::SceneFile;
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/wcsph_delta_sph.ron");
    let text = std::fs::read_to_string(path).unwrap();
    let scene = SceneFile::parse(&text, "wcsph_delta_sph.ron").unwrap();
    let params = scene.fluids[0].params().unwrap();
    assert_eq!(params.wcsph_density, WcsphDensity::DELTA_SPH);
    assert_eq!(params.wcsph_pressure, WcsphPressure::Adami);
    let bad = text.replace("Continuity(delta: 0.1)", "Continuity(delta: 2.0)");
    let message = match SceneFile::parse(&bad, "bad.ron") {
        Ok(s) => s.fluids[0].params().unwrap_err().to_string(),
        Err(e) => e.to_string(),
    };
    assert!(message.contains("wcsph_density"), "{message}");
}
