//! Scalars carried by the particles (`rapier_sph::scalars`): they diffuse as the heat
//! equation on a resting lattice, the amount of each is conserved while the water moves, no
//! new extreme appears at any diffusivity, the values follow their particles, and bad
//! settings are typed errors.

use rapier_sph::math::{Real, Vector};
use rapier_sph::scenes::{DamBreakConfig, dam_break};
use rapier_sph::*;

/// A periodic box of `n × 8 × 8` particles at spacing `s`, exactly filled by the lattice
/// (uniform, so the particles stay at rest with gravity off), with the scalar `dye` of
/// diffusivity `d` set to `sin(k·x)`, `k = 2π/(n·s)`.
fn periodic_lattice(n: usize, s: Real, d: Real) -> (FluidWorld, FluidHandle) {
    let size = Vector::new(n as Real * s, 8.0 * s, 8.0 * s);
    let params = FluidParamsBuilder::water(s)
        .domain(Domain::Periodic {
            min: Vector::ZERO,
            max: size,
        })
        .build()
        .unwrap();
    let mut fluid = Fluid::new(params).unwrap();
    let points = rapier_sph::fluid::lattice(Vector::splat(0.5 * s), n, 8, 8, s);
    fluid.add_particles(&points).unwrap();
    assert_eq!(fluid.len(), n * 64);
    fluid.add_scalar("dye", d).unwrap();
    let k = std::f32::consts::TAU / size.x;
    let xs: Vec<Real> = fluid.positions().iter().map(|p| p.x).collect();
    for (c, x) in fluid.scalar_mut("dye").unwrap().iter_mut().zip(xs) {
        *c = (k * x).sin();
    }
    let mut world = FluidWorld::new();
    world.physics.gravity = Vector::ZERO;
    world.pipeline.time_stepping = TimeStepping::Fixed;
    let h = world.fluids.insert(fluid);
    (world, h)
}

/// The sine's amplitude: `2/N Σ C_i sin(k x_i)`.
fn amplitude(fluid: &Fluid, k: Real) -> f64 {
    let c = fluid.scalar("dye").unwrap();
    let sum: f64 = c
        .iter()
        .zip(fluid.positions())
        .map(|(&c, p)| c as f64 * (k as f64 * p.x as f64).sin())
        .sum();
    2.0 * sum / c.len() as f64
}

/// On a resting lattice the scheme is `C' = C + D·dt·L C` with `L` the lattice's discrete
/// Laplacian, so a sine of wave number `k` decays each step by exactly `1 + D·dt·λ`, `λ =
/// Σ_j V ∇²W(r_j)(cos(k x_j) − 1)` over the lattice neighbours (`V = m/ρ0`), computed below in
/// f64. The run must follow it to single-precision rounding (1e-3 over 20 steps: a wrong
/// volume, kernel or factor of two misses by 10 % or more). The continuum's rate is `D k²`;
/// `λ/(−k²)` differs from one by the operator's truncation at `k·h` (printed), which falls as
/// the wavelength grows against `h`: 32 spacings give a smaller truncation than 16.
#[test]
fn a_sine_decays_at_the_lattice_laplacians_rate() {
    let s: Real = 0.05;
    let d: Real = 2e-3;
    let dt: Real = 1.0 / 60.0;
    let mut truncations = Vec::new();
    for n in [16usize, 32] {
        let (mut world, h) = periodic_lattice(n, s, d);
        world.physics.integration_parameters.dt = dt;
        let p = world.fluids[h].params().clone();
        let k = std::f32::consts::TAU / (n as Real * s);
        let (sh, hh, v) = (
            s as f64,
            p.smoothing_length as f64,
            (p.particle_mass / p.rest_density) as f64,
        );
        let lap = |r: f64| 45.0 / (std::f64::consts::PI * hh.powi(6)) * (hh - r);
        let m = (hh / sh).ceil() as i32;
        let mut lambda = 0.0;
        for i in -m..=m {
            for j in -m..=m {
                for l in -m..=m {
                    let r = [i as f64 * sh, j as f64 * sh, l as f64 * sh];
                    let dist = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
                    if dist > 0.0 && dist < hh {
                        lambda += v * lap(dist) * ((k as f64 * r[0]).cos() - 1.0);
                    }
                }
            }
        }
        let a0 = amplitude(&world.fluids[h], k);
        let steps = 20;
        for _ in 0..steps {
            world.step().unwrap();
        }
        let f = &world.fluids[h];
        let fastest = f
            .velocities()
            .iter()
            .map(|v| v.length())
            .fold(0.0, Real::max);
        assert!(fastest < 1e-3, "the lattice moved: {fastest} m/s");
        let measured = amplitude(f, k) / a0;
        let predicted = (1.0 + d as f64 * dt as f64 * lambda).powi(steps);
        let truncation = lambda / -(k as f64 * k as f64) - 1.0;
        println!(
            "N = {n}: amplitude ratio {measured:.6}, lattice prediction {predicted:.6}, \
             continuum exp(-Dk²t) {:.6}, λ/(-k²) - 1 = {truncation:.4}",
            (-(d as f64) * (k as f64).powi(2) * dt as f64 * steps as f64).exp()
        );
        assert!(
            (measured / predicted - 1.0).abs() < 1e-3,
            "N = {n}: {measured} vs {predicted}"
        );
        assert!(world.pipeline.report().scalar_limited == 0);
        truncations.push(truncation.abs());
    }
    assert!(truncations[1] < truncations[0], "{truncations:?}");
}

/// A dam break with half its water dyed: while the water splashes, the amount of dye stays
/// what it was (to single-precision summation over 20,000 additions: 1e-4), no particle's
/// dye leaves `[0, 1]` (the limited exchange is a convex combination), including at a
/// diffusivity far beyond the explicit bound (the limiter then counts particles).
#[test]
fn dye_is_conserved_and_bounded_while_the_water_moves() {
    for d in [1e-3 as Real, 10.0] {
        let params = FluidParamsBuilder::water(0.05).build().unwrap();
        let config = DamBreakConfig::tower(params, 0.5);
        let mut scene = dam_break(&config).unwrap();
        let w = &mut scene.world;
        let h = scene.fluid;
        w.physics.integration_parameters.dt = 1.0 / 60.0;
        let fluid = &mut w.fluids[h];
        fluid.add_scalar("dye", d).unwrap();
        let ys: Vec<Real> = fluid.positions().iter().map(|p| p.y).collect();
        let mid = ys.iter().sum::<Real>() / ys.len() as Real;
        for (c, y) in fluid.scalar_mut("dye").unwrap().iter_mut().zip(ys) {
            *c = if y < mid { 1.0 } else { 0.0 };
        }
        let total = |f: &Fluid| {
            f.scalar("dye")
                .unwrap()
                .iter()
                .map(|&c| c as f64)
                .sum::<f64>()
        };
        let before = total(&w.fluids[h]);
        let mut limited = 0;
        for _ in 0..60 {
            w.step().unwrap();
            limited += w.pipeline.report().scalar_limited;
        }
        let f = &w.fluids[h];
        let after = total(f);
        let dye = f.scalar("dye").unwrap();
        let (lo, hi) = dye
            .iter()
            .fold((Real::MAX, Real::MIN), |(a, b), &c| (a.min(c), b.max(c)));
        println!("D = {d}: dye {before} -> {after}, range [{lo}, {hi}], limited {limited}");
        assert!(
            (after / before - 1.0).abs() < 1e-4,
            "D = {d}: {before} -> {after}"
        );
        assert!(lo >= -1e-6 && hi <= 1.0 + 1e-6, "D = {d}: [{lo}, {hi}]");
        assert!(lo < hi, "D = {d}: fully mixed in a second?");
        if d > 1.0 {
            assert!(
                limited > 0,
                "D = {d} is beyond the bound: the limiter must act"
            );
        } else {
            assert_eq!(limited, 0);
        }
    }
}

/// Without diffusion a particle keeps its value through the re-sorts, removals and appends
/// of the step (each particle dyed with its id); particles added later start at 0.
#[test]
fn values_follow_their_particles() {
    let params = FluidParamsBuilder::water(0.05).build().unwrap();
    let config = DamBreakConfig::tower(params, 0.5);
    let mut scene = dam_break(&config).unwrap();
    let (w, h) = (&mut scene.world, scene.fluid);
    w.physics.integration_parameters.dt = 1.0 / 60.0;
    let fluid = &mut w.fluids[h];
    fluid.add_scalar("tag", 0.0).unwrap();
    let ids: Vec<u32> = fluid.ids().to_vec();
    for (c, id) in fluid.scalar_mut("tag").unwrap().iter_mut().zip(ids) {
        *c = id as Real + 1.0;
    }
    for _ in 0..30 {
        w.step().unwrap();
    }
    let fluid = &mut w.fluids[h];
    let removed: Vec<u32> = fluid.ids()[..10].to_vec();
    fluid.remove_particles(&removed).unwrap();
    let added = fluid.add_particles(&[Vector::new(0.1, 0.9, 0.1)]).unwrap();
    w.step().unwrap();
    let f = &w.fluids[h];
    for (&id, &c) in f.ids().iter().zip(f.scalar("tag").unwrap()) {
        if added.contains(&id) {
            assert_eq!(c, 0.0);
        } else {
            assert_eq!(c, id as Real + 1.0, "particle {id}");
        }
    }
}

/// Bad settings are typed errors naming the argument; a fluid without the scalar says so.
#[test]
fn bad_scalars_are_refused() {
    let mut fluid = Fluid::new(FluidParamsBuilder::water(0.05)).unwrap();
    for d in [-1.0, Real::NAN, Real::INFINITY] {
        assert!(matches!(
            fluid.add_scalar("dye", d),
            Err(SphError::InvalidParameter {
                field: "diffusivity",
                ..
            })
        ));
    }
    assert!(matches!(
        fluid.add_scalar("", 0.1),
        Err(SphError::InvalidParameter { field: "name", .. })
    ));
    assert!(fluid.scalar("dye").is_none() && fluid.scalar_mut("dye").is_none());
    fluid.add_scalar("dye", 0.1).unwrap();
    fluid.add_scalar("dye", 0.2).unwrap(); // changes the diffusivity only
    assert_eq!(fluid.scalars().collect::<Vec<_>>(), vec![("dye", 0.2)]);
}
