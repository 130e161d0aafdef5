//! The stress-based implicit viscosity (`ViscositySolve::Stress`, Takahashi et al. 2015,
//! `src/forces/viscosity_stress.rs`) against the Laplacian one (`ViscositySolve::Implicit`,
//! Weiler et al. 2018) on a free viscous column stretched along its axis in zero gravity.

mod common;

use common::on_each;
use rapier_sph::math::{Real, Vector};
use rapier_sph::prelude::*;

fn settings() -> ImplicitViscosity {
    ImplicitViscosity {
        tolerance: 1e-5,
        max_iterations: 400,
    }
}

/// What one stretching run measured, per frame after the first `skip`.
#[derive(Debug)]
struct Stretch {
    /// Tension at the mid-plane over `μ A ε̇` there (Trouton's ratio: 3 in a Newtonian liquid).
    ratio: Vec<f64>,
    /// Mid-plane strain rate (1/s).
    rate: Vec<f64>,
    /// Mid-plane cross-section over the initial one.
    area: Vec<f64>,
    /// Largest relative residual the solve left.
    residual: Real,
    /// CG iterations, all frames.
    iterations: usize,
}

/// Least-squares slope of `w` against `z`.
fn slope(pts: &[(f64, f64)]) -> f64 {
    let n = pts.len() as f64;
    let (mz, mw) = pts
        .iter()
        .fold((0.0, 0.0), |(a, b), (z, w)| (a + z / n, b + w / n));
    let (szz, szw) = pts.iter().fold((0.0, 0.0), |(a, b), (z, w)| {
        (a + (z - mz) * (z - mz), b + (z - mz) * (w - mw))
    });
    szw / szz
}

/// A column of radius `4s`, `32s` long, centred on the origin along z, zero gravity, DFSPH,
/// `μ` = `mu`, released with the uniform extension `v = ε̇0 (−x/2, −y/2, z)`, one 1/60 s
/// substep a frame. Each frame: the momentum of the half `z > 0` (`P`), the slope of `v_z`
/// against `z` over the band `|z| < 4s` (`ε̇`) and the band's volume over its length (`A`).
/// Nothing but the mid-plane's tension acts on the upper half (no gravity; at `z = 0`, `v_z
/// ≈ 0`, so no momentum crosses it), so `F = −ΔP/Δt`; backward Euler's force is the one at the
/// end of the step, so the ratio is `F/(μ A ε̇)` with `A ε̇` taken after the step.
fn stretch(solve: ViscositySolve, mu: Real, rate0: Real, frames: usize, skip: usize) -> Stretch {
    let s: Real = 0.01;
    let params = FluidParamsBuilder::water(s)
        .solver(Solver::dfsph())
        .viscosity(mu)
        .viscosity_solve(solve)
        .build()
        .unwrap();
    let mut fluid = Fluid::new(params).unwrap();
    let (r, half) = (4.0 * s, 16.0 * s);
    let pos: Vec<Vector> =
        rapier_sph::fluid::lattice(Vector::new(-r, -r, -half + 0.5 * s), 9, 9, 32, s)
            .into_iter()
            .filter(|p| p.x * p.x + p.y * p.y <= r * r + 1e-6)
            .collect();
    let vel: Vec<Vector> = pos
        .iter()
        .map(|p| rate0 * Vector::new(-0.5 * p.x, -0.5 * p.y, p.z))
        .collect();
    fluid
        .add_particles_with_velocities(&pos, Some(&vel))
        .unwrap();
    let mass = fluid.params().particle_mass as f64;
    let mut fluids = FluidSet::new();
    let h = fluids.insert(fluid);
    let (mut bodies, colliders, bp) = <(
        rapier_sph::rapier3d::prelude::RigidBodySet,
        rapier_sph::rapier3d::prelude::ColliderSet,
        rapier_sph::rapier3d::prelude::DefaultBroadPhase,
    )>::default();
    let mut pipeline = FluidPipeline::with_time_stepping(TimeStepping::Fixed);
    let dt: Real = 1.0 / 60.0;
    let band = 4.0 * s as f64;
    let measure = |f: &Fluid| {
        let p_top: f64 = f
            .positions()
            .iter()
            .zip(f.velocities())
            .filter(|(p, _)| p.z > 0.0)
            .map(|(_, v)| mass * v.z as f64)
            .sum();
        let mid: Vec<(f64, f64)> = f
            .positions()
            .iter()
            .zip(f.velocities())
            .filter(|(p, _)| (p.z as f64).abs() < band)
            .map(|(p, v)| (p.z as f64, v.z as f64))
            .collect();
        // Particles per unit length at z = 0, weighted by the hat `1 − |z|/band` (smooth
        // as the lattice's layers cross the band's ends), times a particle's rest volume.
        let line: f64 = mid.iter().map(|(z, _)| 1.0 - z.abs() / band).sum::<f64>() / band;
        let area = line * (s as f64).powi(3);
        (p_top, slope(&mid), area)
    };
    let (mut p0, _, a_init) = measure(&fluids[h]);
    let mut out = Stretch {
        ratio: vec![],
        rate: vec![],
        area: vec![],
        residual: 0.0,
        iterations: 0,
    };
    for frame in 0..frames {
        let rep = pipeline
            .step(Vector::ZERO, dt, &mut fluids, &mut bodies, &colliders, &bp)
            .unwrap();
        out.iterations += rep.viscosity_iterations;
        out.residual = out.residual.max(rep.viscosity_residual);
        let (p1, rate, area) = measure(&fluids[h]);
        let force = -(p1 - p0) / dt as f64;
        if frame >= skip {
            out.ratio.push(force / (mu as f64 * area * rate));
            out.rate.push(rate);
            out.area.push(area / a_init);
        }
        p0 = p1;
    }
    out
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// Trouton's ratio of the column (see [`stretch`]) with both solves, stretched and squeezed
/// at 1/s, `μ` = 10 Pa·s: a measurement, printed (docs/solvers.md, "Rope coiling", has the
/// figures; a Newtonian liquid gives 3 with either sign). Neither solve gives 3 on this
/// column, so nothing is asserted about it beyond each run's solve converging:
/// `cargo test --release --test viscosity_stress -- --ignored --nocapture`.
#[test]
#[ignore = "a measurement (prints Trouton's ratio of both solves), 10 s"]
fn stretching_column_trouton_ratio() {
    let mu = 10.0;
    for rate0 in [1.0, -1.0] {
        for (name, solve) in [
            ("stress", ViscositySolve::Stress(settings())),
            ("laplacian", ViscositySolve::Implicit(settings())),
        ] {
            let m = stretch(solve, mu, rate0, 12, 2);
            println!(
                "{name} ε̇0 {rate0}: ratio {:.3} ({:.3?}), rate {:.3?}, area {:.3?}, residual {:.1e}, {} iterations",
                mean(&m.ratio),
                m.ratio,
                m.rate,
                m.area,
                m.residual,
                m.iterations
            );
            assert!(m.residual <= 1e-5, "{name}: residual {}", m.residual);
        }
    }
}

/// Zero gravity, no walls: only internal forces act, and the stress form's pair terms
/// `m (σ_i/ρ_i² + σ_j/ρ_j²)·∇W_ij` are antisymmetric, so the column's momentum stays what
/// it was to the `f32` round-off of the sums (relative 1e-4 of `Σ m|v|` over 30 frames), and
/// the kinetic energy never rises (the solve's operator is `I` plus a positive semidefinite
/// part; the pressure solver does no work on a fluid that starts at its rest density and is
/// stretched apart).
#[test]
fn momentum_is_kept_and_energy_never_rises() {
    let s: Real = 0.01;
    let params = FluidParamsBuilder::water(s)
        .solver(Solver::dfsph())
        .viscosity(10.0)
        .viscosity_solve(ViscositySolve::Stress(settings()))
        .build()
        .unwrap();
    let mut fluid = Fluid::new(params).unwrap();
    let pos = rapier_sph::fluid::lattice(Vector::ZERO, 6, 6, 12, s);
    // A drift, a shear and a stretch.
    let vel: Vec<Vector> = pos
        .iter()
        .map(|p| Vector::new(0.1 + 2.0 * p.z, 0.05 - 0.5 * p.y, p.z))
        .collect();
    fluid
        .add_particles_with_velocities(&pos, Some(&vel))
        .unwrap();
    let mut fluids = FluidSet::new();
    let h = fluids.insert(fluid);
    let (mut bodies, colliders, bp) = <(
        rapier_sph::rapier3d::prelude::RigidBodySet,
        rapier_sph::rapier3d::prelude::ColliderSet,
        rapier_sph::rapier3d::prelude::DefaultBroadPhase,
    )>::default();
    let mut pipeline = FluidPipeline::with_time_stepping(TimeStepping::Fixed);
    let momentum = |f: &Fluid| {
        f.velocities().iter().fold([0.0f64; 4], |a, v| {
            [
                a[0] + v.x as f64,
                a[1] + v.y as f64,
                a[2] + v.z as f64,
                a[3] + v.length() as f64,
            ]
        })
    };
    let p0 = momentum(&fluids[h]);
    let mut ke = fluids[h].kinetic_energy();
    for frame in 0..30 {
        let rep = pipeline
            .step(
                Vector::ZERO,
                1.0 / 60.0,
                &mut fluids,
                &mut bodies,
                &colliders,
                &bp,
            )
            .unwrap();
        assert!(rep.viscosity_residual <= 1e-5, "frame {frame}: residual");
        let k = fluids[h].kinetic_energy();
        assert!(k <= ke * (1.0 + 1e-5), "frame {frame}: KE {ke} -> {k}");
        ke = k;
        let p = momentum(&fluids[h]);
        for a in 0..3 {
            assert!(
                (p[a] - p0[a]).abs() <= 1e-4 * p0[3],
                "frame {frame}: {p:?} vs {p0:?}"
            );
        }
    }
}

/// The solve's sums run in a fixed order: 1 and 2 threads give the same bits.
#[test]
fn one_and_two_threads_give_the_same_bits() {
    let run = || {
        let m = stretch(ViscositySolve::Stress(settings()), 10.0, 1.0, 6, 0);
        m.ratio.iter().map(|r| r.to_bits()).collect::<Vec<_>>()
    };
    let results = on_each(&[1, 2], run);
    assert!(results[0] == results[1], "1 and 2 threads differ");
}

/// Bad settings of the solve are typed errors naming the field.
#[test]
fn bad_settings_are_typed_errors() {
    let field = |v: ViscositySolve| match FluidParamsBuilder::water(0.05).viscosity_solve(v).build()
    {
        Err(SphError::InvalidParameter { field, .. }) => field,
        other => panic!("{other:?}"),
    };
    let with = |tolerance, max_iterations| {
        ViscositySolve::Stress(ImplicitViscosity {
            tolerance,
            max_iterations,
        })
    };
    for t in [0.0, 1.0, Real::NAN] {
        assert_eq!(field(with(t, 10)), "viscosity_solve.tolerance");
    }
    for n in [0, 1_000_000] {
        assert_eq!(field(with(1e-3, n)), "viscosity_solve.max_iterations");
    }
}
