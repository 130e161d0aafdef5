//! Validation against experiments and analytic solutions (`rapier_sph::validation`), the
//! checks that keep the error-vs-run-time report honest. Release mode; each run is a few
//! seconds (small particle counts, dam breaks stopped at T = 3 where only the front is
//! checked).
//!
//! Reference data are read from `../shared/validation/` beside the crate; a missing folder
//! fails with an error naming the path.

use rapier_sph::math::Real;
use rapier_sph::validation::{Depth, Method, RunRecord, Scene, TimePolicy, dam_break, methods};

fn method(name: &str) -> Method {
    methods()
        .into_iter()
        .find(|m| m.name == name)
        .unwrap_or_else(|| panic!("no solver named {name} in validation::methods()"))
}

/// The solver a fluid gets when nobody chooses: the water preset's.
fn default_method() -> Method {
    let solver = rapier_sph::FluidParamsBuilder::water(0.05)
        .build()
        .unwrap()
        .solver;
    methods()
        .into_iter()
        .find(|m| m.solver == solver)
        .expect("the default solver is in validation::methods()")
}

/// The solvers the committed report recommends (`report/recommended.txt`, written by
/// `examples/error_vs_runtime.rs`).
fn recommended() -> Vec<Method> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("report/recommended.txt");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (run the error_vs_runtime example to make the report)",
            path.display()
        )
    });
    let list: Vec<Method> = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(method)
        .collect();
    assert!(
        !list.is_empty(),
        "{}: no solver recommended",
        path.display()
    );
    list
}

/// Taylor–Green decay at N = 12 against the reference: the 64³ grid reference is exact to
/// well under 1 % at Re = 100, so the error is SPH's own. Its leading part at this resolution
/// is the viscosity operator's truncation, measured by
/// `taylor_green_initial_dissipation_matches_viscosity` as `|λ/3 + 1| ≈ 10 %` (the lattice
/// Laplacian of the vortex at k·h ≈ 1.8): a correct SPH at N = 12 must follow `E(t)` within
/// 10 % RMS.
const TGV_TOLERANCE: f64 = 0.10;

/// Mechanical energy a stable run may gain over `E_0`, as a fraction: 1 %. Nothing does work
/// on these fluids (a column released from rest in a closed fixed tank), so the only gain a
/// correct solver shows is the spawn lattice settling against walls that count in the
/// density (the lattice itself is at `ρ0` to 3·10⁻⁵ with the cubic spline at h = 2s, but
/// the rows next to a wall are not at the wall's rest distance): measured at most +0.25 %
/// (DFSPH, hydrostatic tank, N = 6, fixed dt/2: the column rising by 1.5 % of a spacing),
/// +1.7 % at N = 3. Clavet releases its cohesion's own energy (with walls in its densities
/// up to +45 % of `E_0`, the square column's free edge: docs/validation.md; the report's
/// `energy_excess` column); PBF gained energy before its artificial pressure was scaled with
/// the step (up to +2.1 %, Koshizuka & Oka, N = 16, fixed dt/2), and gains nothing now.
const ENERGY_TOLERANCE: f64 = 0.01;

/// The largest `energy_excess` of `m` over every scene under gravity at its default
/// resolution, at the stable policies `policies`, each run printed with its highest particle.
/// The Taylor–Green vortex has no gravity (its `energy_excess` is NaN) and is not run.
fn largest_energy_excess(m: &Method, policies: &[TimePolicy]) -> (f64, String) {
    let mut worst = (f64::MIN, String::new());
    for scene in Scene::ALL.into_iter().filter(|&s| s != Scene::TaylorGreen) {
        for &policy in policies {
            let r = scene_run(scene, m, scene.default_resolution(), policy);
            let excess = r.error("energy_excess").unwrap();
            assert!(!excess.is_nan(), "{}: no energy under gravity", r.scene);
            assert_conserved(r);
            let label = format!(
                "{} {} N={} {}",
                r.scene,
                m.name,
                r.resolution,
                policy.name()
            );
            println!(
                "{label}: mechanical energy {excess:+.5} of E_0, highest particle {:.3} × the initial top",
                r.error("max_height").unwrap()
            );
            if excess > worst.0 {
                worst = (excess, label);
            }
        }
    }
    worst
}

/// Energy in every report scene under gravity (both Martin & Moyce columns, Koshizuka & Oka,
/// Lobovský, the hydrostatic tank), WCSPH, DFSPH and PBF at the default resolution, adaptive
/// and fixed `dt/2`: the mechanical energy `E_kin + Σ m·g·y` never exceeds the column's
/// initial potential energy `E_0` by more than [`ENERGY_TOLERANCE`]. Measured at most +0.04 %
/// (DFSPH, hydrostatic, N = 8, fixed dt/2); PBF at most −0.0000 (every run loses energy).
///
/// This bounds the whole fluid. No bound holds particle by particle: pressure moves energy
/// between particles (Ritter's ideal front moves at `2·sqrt(g·H)`, a specific energy `2gH`,
/// twice the highest initial one), and the highest particle is printed as a figure (in
/// Lobovský's tank every solver's run-up reaches the lid at 2H). One test a solver, so that
/// they run side by side on the test harness's two threads.
mod mechanical_energy_never_exceeds_the_initial_potential_energy {
    #[test]
    fn wcsph() {
        super::energy_never_exceeds_e0("WCSPH");
    }

    #[test]
    fn dfsph() {
        super::energy_never_exceeds_e0("DFSPH");
    }

    #[test]
    fn pbf() {
        super::energy_never_exceeds_e0("PBF");
    }
}

/// [`mechanical_energy_never_exceeds_the_initial_potential_energy`] with the method `name`.
fn energy_never_exceeds_e0(name: &str) {
    let (excess, label) = largest_energy_excess(
        &method(name),
        &[TimePolicy::Adaptive, TimePolicy::FixedSmall],
    );
    assert!(
        excess <= ENERGY_TOLERANCE,
        "{label}: mechanical energy {excess:+.5} of E_0 above the initial potential energy"
    );
}

fn no_progress() -> impl FnMut(Real) {
    |_| {}
}

/// The record of a run keyed by `key`, computed by `run` the first time it is asked for and
/// shared after that: several tests read the same deterministic run (the hydrostatic tank
/// with the default solver at N = 8, the default solver's Martin & Moyce fronts at
/// N = 12), and the test harness runs them in one process. A test asking while another
/// computes the same run waits for it (`OnceLock::get_or_init`).
fn shared_run(key: String, run: impl FnOnce() -> RunRecord) -> &'static RunRecord {
    use std::collections::HashMap;
    use std::sync::{Mutex, OnceLock};
    static RUNS: OnceLock<Mutex<HashMap<String, &'static OnceLock<RunRecord>>>> = OnceLock::new();
    let cell: &'static OnceLock<RunRecord> = RUNS
        .get_or_init(Default::default)
        .lock()
        .unwrap()
        .entry(key)
        .or_insert_with(|| Box::leak(Box::default()));
    cell.get_or_init(run)
}

/// `scene.run(m, resolution, policy)`, shared between the tests that ask for it
/// ([`shared_run`]).
fn scene_run(
    scene: Scene,
    m: &Method,
    resolution: usize,
    policy: TimePolicy,
) -> &'static RunRecord {
    let key = format!(
        "{} {} N={resolution} {}",
        scene.name(),
        m.name,
        policy.name()
    );
    shared_run(key, || {
        scene
            .run(m, resolution, policy, &mut no_progress())
            .unwrap()
    })
}

/// A Martin & Moyce dam break at `resolution`, run only to T = `t_end` (front scaling),
/// shared between the tests that ask for it ([`shared_run`]).
fn martin_moyce(
    case: dam_break::Case,
    m: &Method,
    resolution: usize,
    t_end: Real,
) -> &'static RunRecord {
    let key = format!("{} {} N={resolution} T={t_end}", case.name, m.name);
    shared_run(key, || {
        let mut case = case;
        case.duration = t_end / (case.front_time_factor * (9.81 / case.width).sqrt());
        dam_break::run(
            &case,
            m,
            resolution,
            TimePolicy::Adaptive,
            &mut no_progress(),
        )
        .unwrap_or_else(|e| panic!("{e}"))
    })
}

fn assert_conserved(r: &RunRecord) {
    let label = format!(
        "{} {} N={} {}",
        r.scene,
        r.method,
        r.resolution,
        r.policy.name()
    );
    assert!(r.stable, "{label}: not stable: {}", r.note);
    // Mass: every particle has the same mass and nothing removes particles but a sink (none
    // here), so the mass is conserved exactly iff the count is.
    assert_eq!(r.particles_end, r.particles, "{label}: particles lost");
    assert_eq!(r.escaped, 0, "{label}: particles outside the tank");
}

/// Hydrostatic tank, default solver, default resolution: the bottom layer's pressure within
/// 2 % of `ρ0·g·depth` once settled. Met by DFSPH with its hydrostatic walls (its default;
/// measured +1.5 % at N = 8; the walls that mirror the particle's own pressure read +16 %).
///
/// Tolerance (the issue's): at rest the weakly-compressible density error is `(v/c)² ≈ 0`,
/// and the bottom layer's depth is known to a quarter of a spacing of the 16-layer column
/// (about 1.5 %), so a correct solver and wall treatment meet 2 %; a wrong wall treatment
/// (a missing half kernel at the floor) errs by tens of per cent.
#[test]
fn hydrostatic_bottom_pressure_within_2_percent() {
    let r = scene_run(
        Scene::Hydrostatic,
        &default_method(),
        Scene::Hydrostatic.default_resolution(),
        TimePolicy::Adaptive,
    );
    assert_conserved(r);
    let e = r.error("bottom_pressure").unwrap();
    assert!(e.abs() <= 0.02, "bottom pressure error {e:+.4}");
}

/// PBF with hydrostatic walls (opt-in), the same scene at N = 8 and 12: the bottom
/// pressure within 5 % of `ρ0·g·depth` (measured −4.2 % and −1.6 %; PBF with its default
/// walls reads +16.7 % and +19.3 %).
///
/// Tolerance: not the 2 % the converged DFSPH meets. PBF's pressure is the sum of the `λ` of
/// its four Jacobi iterations, which stop at a mean compression of 0.3–0.8 % in this scene;
/// what they leave uncorrected next to the floor is carried by contact. 5 % is under a third
/// of the default walls' error, and the test fails if either half of the walls goes missing
/// (measured at N = 8 / 12: without the hydrostatic part +6.2 / +7.0 %, without the
/// neighbours' `λ` +10.4 / +10.6 %).
#[test]
fn pbf_hydrostatic_walls_bring_the_bottom_pressure_within_5_percent() {
    let m = Method {
        name: "PBF (hydrostatic walls)",
        solver: rapier_sph::Solver::Pbf(rapier_sph::solver::Pbf {
            hydrostatic_walls: true,
            ..Default::default()
        }),
        wall_density: true,
        wcsph_pressure: rapier_sph::WcsphPressure::Paper,
        wcsph_density: rapier_sph::WcsphDensity::Summation,
    };
    for n in [8, 12] {
        let r = Scene::Hydrostatic
            .run(&m, n, TimePolicy::Adaptive, &mut no_progress())
            .unwrap();
        assert_conserved(&r);
        let e = r.error("bottom_pressure").unwrap();
        println!("PBF with hydrostatic walls, N = {n}: bottom pressure {e:+.4}");
        assert!(e.abs() <= 0.05, "N = {n}: bottom pressure error {e:+.4}");
    }
}

/// WCSPH with Adami's walls (`WcsphPressure::Adami`, opt-in: the symmetric pressure force
/// and the walls' pressure carried from the fluid plus `ρ0·g·(x_b − x_i)`), the same scene at
/// N = 8 and 12: the bottom pressure within 2 % of `ρ0·g·depth`, the tolerance and its
/// reasons of `hydrostatic_bottom_pressure_within_2_percent` (the column of 16 and 24
/// layers, its bottom layer's depth known to a quarter of a spacing). Measured +0.42 % and
/// +0.05 % (N = 6, a 12-layer column where a quarter spacing is 2.1 %: −2.6 %); the paper's
/// forces with the same walls read +121 % at N = 8, Müller's pressure force being half the
/// pressure gradient (docs/solvers.md).
#[test]
fn wcsph_adami_walls_bring_the_bottom_pressure_within_2_percent() {
    let m = Method {
        name: "WCSPH (Adami walls)",
        solver: rapier_sph::Solver::Wcsph,
        wall_density: true,
        wcsph_pressure: rapier_sph::WcsphPressure::Adami,
        wcsph_density: rapier_sph::WcsphDensity::Summation,
    };
    for n in [8, 12] {
        let r = Scene::Hydrostatic
            .run(&m, n, TimePolicy::Adaptive, &mut no_progress())
            .unwrap();
        assert_conserved(&r);
        let e = r.error("bottom_pressure").unwrap();
        println!("WCSPH with Adami walls, N = {n}: bottom pressure {e:+.4}");
        assert!(e.abs() <= 0.02, "N = {n}: bottom pressure error {e:+.4}");
    }
}

/// Martin & Moyce's surge front, both columns, every recommended solver at the default
/// resolution (12 particles across the column) with the adaptive step: RMS relative deviation
/// over the measured points with T ≤ 3 within 10 %, and the front never ahead of Ritter's
/// bound `Z ≤ 1 + 2T`.
///
/// Tolerance (the 10 %), from what the comparison cannot resolve: the transcribed
/// points carry 1–3 % error; Martin & Moyce's two column sizes differ by up to 4 % in scaled
/// time (scale effects the model leaves out: surface tension, floor friction, the gate's
/// opening); and the measured front is the tip particle's edge, quantised to about half a
/// spacing, 4 % of Z at Z = 1 at this resolution. A solver that gets the collapse wrong (too
/// stiff, too viscous, a front held back by the floor) is off by 20 % or more.
///
/// Ritter's bound is a theorem of the shallow-water equations for an ideal fluid on a dry
/// frictionless bed, so it holds with no tolerance: the front starts on it (Z = 1 at T = 0,
/// excess 0) and must never get ahead.
#[test]
fn dam_break_front_within_10_percent_of_martin_moyce_for_recommended_solvers() {
    let res = Scene::MartinMoyceN2.default_resolution();
    for m in recommended() {
        for case in [
            dam_break::Case::martin_moyce_square().unwrap(),
            dam_break::Case::martin_moyce_n2().unwrap(),
        ] {
            let r = martin_moyce(case, &m, res, 3.05);
            assert_conserved(r);
            let e = r.error("front_rms_t3").unwrap();
            let label = format!("{} {} N={res}", r.scene, m.name);
            assert!(e <= 0.10, "{label}: front RMS error {e:.4} over T ≤ 3");
            let excess = r.error("ritter_excess").unwrap();
            assert!(
                excess <= 0.0,
                "{label}: front ahead of Ritter's bound by {excess:.4}"
            );
        }
    }
}

/// Convergence, default solver: halving the spacing (8 → 16 particles across the column)
/// does not make the front error over T ≤ 3 grow. The square column; on the n² = 2 column the
/// error against the experiment grows (0.037 → 0.059) and convergence is tested against the
/// finest run instead (`dam_break_front_converges_at_first_order_against_the_finest_run_n2_column`).
///
/// Tolerance: the finer run may exceed the coarser run's RMS by at most 0.01 (1 % of Z), the
/// smallest error the data's own transcription carries: below that the two runs cannot be
/// ranked against these data.
///
/// Measured (DFSPH with its hydrostatic walls, its default): 0.043 → 0.031 (`cargo test --release --test validation dam_break_front -- --nocapture`).
/// With the mirrored walls it was not met (0.018 → 0.062): the square column's front, like
/// the n² = 2 column's, converges to the model's answer ahead of the experiment (see the n² = 2
/// test), so this test can fail at finer spacings than the two it runs.
#[test]
fn dam_break_front_error_does_not_grow_when_spacing_halves() {
    front_error_does_not_grow(dam_break::Case::martin_moyce_square().unwrap());
}

/// Convergence where it is defined, the n² = 2 column: the default solver's front error
/// against its own finest run (N = 32 particles across the column) falls at the expected
/// order from N = 8 to 16, T ≤ 3. The error against the experiment is printed beside it, a
/// figure and not a criterion: the model (an instant release onto a free-slip floor) runs
/// about 0.2 in T ahead of Martin & Moyce's front, so that error stops falling once the
/// discretisation error no longer hides the lead (see docs/validation.md).
///
/// Observed order: if `Z_N = Z* + C·N^−p`, the errors against the N = 32 run are
/// `e_N = |C|·(N^−p − 32^−p)`, so `e_8/e_16 = 2^p + 1` and `p = log2(e_8/e_16 − 1)` (the
/// three-grid estimate, Roache 1998).
///
/// Expected order 1, asserted within ±0.5 (0.5 ≤ p ≤ 1.5): the leading errors of this
/// discretisation are first order in the spacing — the kernel's truncation at the walls, the
/// floor and the free surface (`O(h)`, h = 2s), the front measured to a particle's edge, and
/// symplectic Euler with a step proportional to the spacing. Half an order either way is the
/// scatter of a three-grid estimate whose finest error is a few times the front's own
/// quantisation (`s/2`, 1.6 % of the column's width at N = 32, RMS-averaged over the ~60
/// samples with T ≤ 3). An order below 0.5 says the front is not converging at the rate
/// its discretisation promises; above 1.5, that the coarse run is outside the asymptotic range.
#[test]
fn dam_break_front_converges_at_first_order_against_the_finest_run_n2_column() {
    let m = default_method();
    let case = dam_break::Case::martin_moyce_n2().unwrap();
    let runs: Vec<&RunRecord> = [8, 16, 32]
        .iter()
        .map(|&n| martin_moyce(case.clone(), &m, n, 3.05))
        .collect();
    runs.iter().for_each(|r| assert_conserved(r));
    let (e8, e16) = (
        front_change(runs[2], runs[0]),
        front_change(runs[2], runs[1]),
    );
    let order = (e8 / e16 - 1.0).log2();
    for r in &runs {
        println!(
            "{} {} N = {}: front RMS against the experiment {:.4} (T ≤ 3)",
            r.scene,
            m.name,
            r.resolution,
            r.error("front_rms_t3").unwrap()
        );
    }
    println!(
        "{} {}: front RMS against N = 32: {e8:.4} (N = 8), {e16:.4} (N = 16); observed order {order:.2}",
        case.name, m.name
    );
    assert!(
        (0.5..=1.5).contains(&order),
        "{} {}: observed order {order:.2} (errors against N = 32: {e8:.4} at N = 8, {e16:.4} at N = 16), expected 1 ± 0.5",
        case.name,
        m.name
    );
}

/// Asserts that the default solver's Martin & Moyce front error over T ≤ 3 does not grow by
/// more than 0.01 from N = 8 to N = 16 on `case`.
fn front_error_does_not_grow(case: dam_break::Case) {
    let m = default_method();
    let coarse = martin_moyce(case.clone(), &m, 8, 3.05);
    let fine = martin_moyce(case, &m, 16, 3.05);
    assert_conserved(coarse);
    assert_conserved(fine);
    let (ec, ef) = (
        coarse.error("front_rms_t3").unwrap(),
        fine.error("front_rms_t3").unwrap(),
    );
    println!(
        "{} {}: front error {ec:.4} (N = 8), {ef:.4} (N = 16)",
        coarse.scene, m.name
    );
    assert!(
        ef <= ec + 0.01,
        "{} {}: front error grew from {ec:.4} (N = 8) to {ef:.4} (N = 16)",
        coarse.scene,
        m.name
    );
}

/// Every scene, every solver, every time-step policy at the quick sweep's coarsest
/// resolution: a stable run keeps its mass exactly (no particle lost) and every particle in
/// its tank; a run that became unstable stopped and says why (nothing is lost silently).
/// The solvers the report recommends must be stable at every step but `fixed 2dt`, which is
/// beyond the stability limit on purpose.
#[test]
fn every_scene_conserves_mass_and_keeps_its_particles() {
    let recommended: Vec<&str> = recommended().iter().map(|m| m.name).collect();
    for scene in Scene::ALL {
        let res = scene.resolutions(Depth::Quick)[0];
        for m in methods() {
            for policy in TimePolicy::ALL {
                let r = scene.run(&m, res, policy, &mut no_progress()).unwrap();
                let label = format!("{} {} {}", r.scene, m.name, policy.name());
                if r.stable {
                    assert_conserved(&r);
                } else {
                    assert!(
                        !r.note.is_empty() && r.simulated < r.duration,
                        "{label}: unstable without a reason"
                    );
                    assert!(
                        policy == TimePolicy::FixedLarge || !recommended.contains(&m.name),
                        "{label}: a recommended solver is unstable at a stable step: {}",
                        r.note
                    );
                }
            }
        }
    }
}

/// The front and height measurements ignore a lone droplet and a small spray cluster ahead of
/// the liquid, but follow a cluster big enough to be liquid (more than `MIN_NEIGHBOURS`
/// neighbours within h). Geometry only, no physics: exact up to f32 round-off of positions
/// of order 1 m (1e-6 m allowed).
#[test]
fn front_and_height_ignore_droplets() {
    use rapier_sph::fluid::{Fluid, lattice};
    use rapier_sph::math::Vector;
    let s = 0.01;
    let params = rapier_sph::FluidParamsBuilder::water(s).build().unwrap();
    let column = lattice(Vector::splat(0.5 * s), 10, 20, 4, s);
    let measure = |extra: &[Vector]| {
        let mut f = Fluid::new(params.clone()).unwrap();
        f.add_particles(&column).unwrap();
        f.add_particles(extra).unwrap();
        dam_break::measure(&f)
    };
    let close = |a: Real, b: Real| (a - b).abs() < 1e-6;
    let (front, height) = measure(&[]);
    assert!(close(front, 0.1) && close(height, 0.2), "{front} {height}");
    // A droplet 5 cm ahead and one 5 cm above the column's back edge.
    let (front, height) = measure(&[
        Vector::new(0.15, 0.005, 0.02),
        Vector::new(0.005, 0.25, 0.02),
    ]);
    assert!(close(front, 0.1) && close(height, 0.2), "{front} {height}");
    // A spray cluster of 4 particles (3 neighbours each) ahead: still ignored.
    let cluster = lattice(Vector::new(0.2, 0.005, 0.015), 2, 1, 2, s);
    let (front, _) = measure(&cluster);
    assert!(close(front, 0.1), "{front}");
    // A blob of 3 × 2 × 4 = 24 particles ahead is liquid: the front jumps to its edge.
    let blob = lattice(Vector::new(0.2, 0.005, 0.005), 3, 2, 4, s);
    let (front, _) = measure(&blob);
    assert!(close(front, 0.2 + 2.0 * s + 0.5 * s), "{front}");
}

/// The viscosity mapping `ν = ε/ρ0` (see `validation::taylor_green`): the Taylor–Green
/// vortex's initial decay rate is `−dE/dt = 2ν·|k|²·E = 0.75·ν` (|k|² = 3, E = 1/8).
///
/// The tolerance is derived, not tuned. On the lattice the SPH Laplacian of the vortex's
/// Fourier modes (k = (±1, ±1, ±1)) is exactly `λ·v` with
/// `λ = Σ_j V·∇²W_visc(r_j)·(cos(k·r_j) − 1)` over the lattice neighbours (computed below):
/// the continuum's −3 up to the operator's truncation at `k·h ≈ 1.8`. So the run must give
/// `−dE/dt = −2νλE` within the time-discretisation error of measuring over `t₁ = 0.05`
/// (`E` curves by `exp(2νλt)`: a mean rate off by ~`|νλ|t₁` ≈ 1.5 %, plus the compression
/// that pressure starts exchanging, O(Ma²) = 1 % at c = 10): 3 % in all. Against `0.75ν` the
/// tolerance adds the truncation `|λ/3 + 1|`. A wrong mapping (ε = ν/2, ε = 2ν, ρ0 left
/// out) misses by 50 % or more.
#[test]
fn taylor_green_initial_dissipation_matches_viscosity() {
    use rapier_sph::validation::taylor_green as tg;
    let n = 12;
    let re = 10;
    let nu = 1.0 / re as f64;
    let t1: Real = 0.05;
    // The lattice's discrete Laplacian eigenvalue for k = (1, 1, 1).
    let s = tg::BOX as f64 / n as f64;
    let h = 2.0 * s;
    let lap = |r: f64| 45.0 / (std::f64::consts::PI * h.powi(6)) * (h - r);
    let mut lambda = 0.0;
    let m = (h / s).ceil() as i32;
    for i in -m..=m {
        for j in -m..=m {
            for k in -m..=m {
                let r = [i as f64 * s, j as f64 * s, k as f64 * s];
                let d = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
                if d > 0.0 && d < h {
                    lambda += s.powi(3) * lap(d) * ((r[0] + r[1] + r[2]).cos() - 1.0);
                }
            }
        }
    }
    let predicted = -2.0 * nu * lambda * 0.125;
    let exact = 0.75 * nu;
    for name in ["WCSPH", "DFSPH"] {
        let m = method(name);
        let (mut world, fluid) = tg::world(&m, n, re).unwrap();
        let e0 = tg::kinetic_energy(&world.fluids[fluid]);
        assert!((e0 - 0.125).abs() < 1e-6, "E(0) = {e0}");
        world.pipeline.time_stepping = rapier_sph::TimeStepping::Fixed;
        let steps = 10;
        world.physics.integration_parameters.dt = t1 / steps as Real;
        for _ in 0..steps {
            world.step_fluids().unwrap();
        }
        let rate = (e0 - tg::kinetic_energy(&world.fluids[fluid])) / t1 as f64;
        println!(
            "{name}: -dE/dt = {rate:.5} (discrete prediction {predicted:.5}, 0.75ν = {exact:.5}, λ = {lambda:.4})"
        );
        assert!(
            (rate / predicted - 1.0).abs() < 0.03,
            "{name}: {rate} vs the lattice operator's {predicted}"
        );
        let truncation = (lambda / 3.0 + 1.0).abs();
        assert!(
            (rate / exact - 1.0).abs() < 0.03 + truncation,
            "{name}: {rate} vs 0.75ν = {exact} (truncation {truncation})"
        );
    }
}

/// DFSPH in the Taylor–Green vortex (Re = 100, N = 12, adaptive, t ≤ 5): stable, and its
/// kinetic energy follows the JAX-Fluids reference within [`TGV_TOLERANCE`] (the viscosity
/// operator's own truncation at N = 12). Regression test of the closed-box solve
/// (`solver::dfsph::SolveContext::closed`): before it, the one-sided solves piled up a uniform
/// pressure in the periodic box and the run created energy from t ≈ 0.6 (stopped at 1.1× the
/// initial energy).
#[test]
fn taylor_green_dfsph_is_stable_and_follows_the_reference() {
    let rms = taylor_green_n12_ekin_rms("DFSPH");
    assert!(rms < TGV_TOLERANCE, "E_kin RMS error {rms}");
}

/// The Taylor–Green vortex at N = 12, Re = 100, adaptive, t ≤ 5 with solver `name`: checks
/// mass and particles, returns the kinetic energy's RMS relative error against the reference.
fn taylor_green_n12_ekin_rms(name: &str) -> f64 {
    use rapier_sph::validation::taylor_green as tg;
    let r = tg::run_with(
        &method(name),
        12,
        100,
        tg::DURATION,
        TimePolicy::Adaptive,
        &mut no_progress(),
    )
    .unwrap();
    println!("taylor_green N=12 {name} adaptive: {:?}", r.errors);
    assert_conserved(&r);
    r.error("ekin_rms").unwrap()
}

/// The Taylor–Green decay at Re = 100 (N = 12, WCSPH, adaptive, t ≤ 5) against the
/// JAX-Fluids reference, within [`TGV_TOLERANCE`]. Not met: see docs/validation.md.
#[test]
#[ignore = "not met: measured E_kin RMS error 0.34 (WCSPH, N = 12, adaptive, Re = 100, t <= 5; 0.39 at N = 16, 0.47 at N = 20): see docs/validation.md"]
fn taylor_green_decay_against_reference() {
    let rms = taylor_green_n12_ekin_rms("WCSPH");
    assert!(rms < TGV_TOLERANCE, "E_kin RMS error {rms}");
}

/// The convergence criterion against a reference the model can converge to: the
/// front error against Koshizuka & Oka's own MPS solution of their dam break (an instant
/// release onto a free-slip floor, the model this crate solves) does not grow when the
/// spacing halves (N = 8 → 16), for the default solver and for DFSPH.
///
/// Tolerance: the finer run may exceed the coarser run's RMS by at most 0.01, as in
/// `dam_break_front_error_does_not_grow_when_spacing_halves`: the MPS curve is digitised to
/// 1–3 %. Measured (RMS over its 17 points, T ≤ 2.94): DFSPH 0.067, 0.042, 0.030, 0.019, 0.015,
/// 0.009 at N = 8, 12, 16, 24, 32, 48; WCSPH without wall density 0.107, 0.089, 0.082, 0.079 at
/// N = 8 … 24 (it stalls near 8 %: the slab's side walls missing from its density, see the
/// docs/validation.md), with wall density 0.023 at N = 16.
#[test]
fn dam_break_front_error_against_the_mps_solution_does_not_grow_when_spacing_halves() {
    let mut solvers = vec![default_method()];
    if !solvers.iter().any(|m| m.name == "DFSPH") {
        solvers.push(method("DFSPH"));
    }
    let case = dam_break::Case::koshizuka_oka_mps().unwrap();
    for m in &solvers {
        let run = |n| {
            let r = dam_break::run(&case, m, n, TimePolicy::Adaptive, &mut no_progress()).unwrap();
            assert_conserved(&r);
            r.error("front_rms").unwrap()
        };
        let (ec, ef) = (run(8), run(16));
        assert!(
            ef <= ec + 0.01,
            "{} against the MPS solution: front error grew from {ec:.4} (N = 8) to {ef:.4} (N = 16)",
            m.name
        );
    }
}

/// RMS over the samples of `fine` with `0 < T ≤ 3` of `(Z_fine − Z_coarse)/Z_coarse`, the
/// coarse front interpolated at the fine run's sample times. With `coarse` the finest run of
/// a sweep and `fine` a coarser one, the error of that run against the finest, relative to
/// the finest.
fn front_change(coarse: &RunRecord, fine: &RunRecord) -> f64 {
    let front = |r: &RunRecord| {
        r.curves
            .iter()
            .find(|c| c.name == "front")
            .expect("a dam break records its front")
            .points
            .clone()
    };
    let (c, f) = (front(coarse), front(fine));
    let (mut sum, mut n) = (0.0, 0usize);
    for &(t, z) in f.iter().filter(|p| p.0 > 0.0 && p.0 <= 3.0) {
        let zc = rapier_sph::validation::interpolate(&c, t).expect("same time span");
        sum += ((z - zc) / zc).powi(2);
        n += 1;
    }
    (sum / n as f64).sqrt()
}

/// Convergence, measured against the solver itself: when the spacing halves, the front
/// changes less than it did at the previous halving (N = 6 → 12 → 24 particles across the
/// column, T ≤ 3, both Martin & Moyce columns), for the default solver and for DFSPH.
///
/// Why against itself and not against the experiment: a consistent solver converges to the
/// model's answer, an instantly released inviscid-ish column on a free-slip floor, and that
/// answer runs ahead of Martin & Moyce's measured front by about 0.2 in T (measured, see the
/// convergence notes in docs/validation.md and `examples/dam_front.rs`: DFSPH's front converges at first
/// order, and at N = 48 it lies within 1 % RMS of Koshizuka & Oka's own MPS solution of their
/// experiment, which is itself 12 % ahead of that experiment on average). The error against the experiment
/// therefore grows once the discretisation error (a front that is too slow at coarse spacing)
/// no longer cancels part of the model's lead; it says nothing about convergence.
///
/// Tolerance: none. The change of the front between successive halvings must shrink (the
/// Cauchy criterion); measured ratios of the later change to the earlier one are 0.38–0.45
/// (WCSPH and DFSPH, both columns; first order predicts 0.5). A solver whose front keeps moving as much at every halving, or
/// more, does not converge.
#[test]
fn dam_break_front_converges_when_spacing_halves() {
    let mut solvers = vec![default_method()];
    if !solvers.iter().any(|m| m.name == "DFSPH") {
        solvers.push(method("DFSPH"));
    }
    for m in &solvers {
        for case in [
            dam_break::Case::martin_moyce_square().unwrap(),
            dam_break::Case::martin_moyce_n2().unwrap(),
        ] {
            let runs: Vec<&RunRecord> = [6, 12, 24]
                .iter()
                .map(|&n| martin_moyce(case.clone(), m, n, 3.05))
                .collect();
            runs.iter().for_each(|r| assert_conserved(r));
            let (first, second) = (
                front_change(runs[0], runs[1]),
                front_change(runs[1], runs[2]),
            );
            assert!(
                second < first,
                "{} {}: the front moved by {second:.4} (RMS, N = 12 → 24) after {first:.4} \
                 (N = 6 → 12): not converging",
                case.name,
                m.name
            );
        }
    }
}
