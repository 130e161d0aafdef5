//! The 3D Taylor–Green vortex in a periodic box, against the kinetic-energy decay of a
//! grid-based reference (JAX-Fluids, 64³ cells, shipped by jax-sph; `tgv3d_jaxfluids/`).
//!
//! Setup (the reference's): the periodic cube `[0, 2π]³` ([`crate::Domain::Periodic`]), no
//! walls, no gravity, `ρ0 = 1`, initial velocity `u = sin x·cos y·cos z`,
//! `v = −cos x·sin y·cos z`, `w = 0` (so `E_kin(0) = 0.125`), kinematic viscosity
//! `ν = 1/Re`. The reference has Re = 10, 20, 50 and 100; the report runs Re = 100
//! ([`REYNOLDS`]). Re = 1000 has no reference in the data and is not run.
//!
//! Particles: `resolution³` on the cubic lattice filling the box (spacing `2π/resolution`,
//! `h = 2·spacing`, cubic spline, mass `ρ0·spacing³`: the lattice's own kernel density is
//! `ρ0` to 0.003 %). The water preset's other choices are kept except: Tait with
//! `c = 10` (ten times the peak speed 1, the usual weakly-compressible choice, Mach 0.1)
//! and no pressure clamp (the vortex's pressure is negative at its cores).
//!
//! **Viscosity mapping.** The crate's viscosity is Müller's
//! `a_i = (ε/ρ_i) Σ_j m (v_j − v_i)/ρ_j ∇²W_visc(r_ij)` with `∇²W_visc = 45/(π h⁶)(h − r)`.
//! For a smooth field, `Σ_j V_j (v_j − v_i) L(r_ij) → ½·(1/3)·∫ r² L(r) dV · ∇²v`, and
//! `∫₀ʰ r²·45/(π h⁶)(h − r)·4π r² dr = 180·(1/5 − 1/6) = 6`, so the force is `(ε/ρ)·∇²v`: the
//! kinematic viscosity is `ν = ε/ρ0`. The scene sets `ε = ρ0/Re`. The test
//! `taylor_green_initial_dissipation_matches_viscosity` checks the initial decay rate
//! `−dE/dt = 0.75·ν` (`2ν|k|²E` with `|k|² = 3`) against the run.
//!
//! Errors (relative, fractions):
//! - `ekin_rms`: RMS over the samples `t > 0` of `(E(t) − E_ref(t))/E_ref(t)`;
//! - `dissipation_t0`: the initial dissipation rate `(E(0) − E(t₁))/t₁` over the first
//!   sample interval against the reference's over the same interval, relative;
//! - `ekin_end`: `(E − E_ref)/E_ref` at the end of the run.
//!
//! `E = Σ ½ m|v|² / (2π)³`, as jax-sph computes it from its particles.

use super::{DriveSpec, Method, Metric, RunRecord, RunSetup, SimCurve, TimePolicy, drive, metrics};
use crate::error::{SphError, SphResult};
use crate::math::{Real, Vector};
use crate::params::{EquationOfState, FluidParamsBuilder};
use crate::world::FluidWorld;

/// The Reynolds number the report runs (the highest the reference has).
pub const REYNOLDS: u32 = 100;

/// Simulated time of a report run (dimensionless, `U = L = 1`): half of the reference's
/// range, where `E` has fallen by about a quarter at Re = 100.
pub const DURATION: Real = 5.0;

/// Sampling interval of `E(t)` (ten reference rows).
pub const SAMPLE_DT: Real = 0.1;

/// Speed of sound (ten times the peak speed).
pub const SPEED_OF_SOUND: Real = 10.0;

/// Edge of the periodic cube, `2π`.
pub const BOX: Real = std::f32::consts::TAU;

/// The reference curve `E_kin(t)` at Reynolds number `re` (10, 20, 50 or 100).
pub fn reference(re: u32) -> SphResult<super::Curve> {
    super::data::read_curve(
        "tgv3d_jaxfluids",
        "data.csv",
        "t",
        "Ekin",
        Some(("Re", &re.to_string())),
        &format!("JAX-Fluids 64³, Re = {re}"),
    )
}

/// Linear interpolation of the reference at `t` (`E(0) = 0.125`, the reference's own
/// initial value, before its first row at `t = 0.01`).
pub fn reference_at(curve: &super::Curve, t: f64) -> f64 {
    let pts = &curve.points;
    let mut prev = (0.0, 0.125);
    for &p in pts {
        if p.0 >= t {
            let f = if p.0 > prev.0 {
                (t - prev.0) / (p.0 - prev.0)
            } else {
                1.0
            };
            return prev.1 + f * (p.1 - prev.1);
        }
        prev = p;
    }
    prev.1
}

/// The parameters of a run: `resolution` particles across the box, Reynolds number `re`.
pub fn params(method: &Method, resolution: usize, re: u32) -> SphResult<crate::FluidParams> {
    let s = BOX / resolution as Real;
    let rho0 = 1.0;
    FluidParamsBuilder::water(s)
        .rest_density(rho0)
        .equation_of_state(EquationOfState::Tait {
            speed_of_sound: SPEED_OF_SOUND,
            exponent: 7.0,
        })
        .clamp_negative_pressure(false)
        // ν = ε/ρ0 (see the module docs).
        .viscosity(rho0 / re as Real)
        .solver(method.solver)
        .wall_density(method.wall_density)
        .wcsph_pressure(method.wcsph_pressure)
        .wcsph_density(method.wcsph_density)
        .periodic(Vector::ZERO, Vector::splat(BOX))
        .build()
}

/// The world of a run: the lattice with the initial velocity field, no gravity, no colliders.
pub fn world(
    method: &Method,
    resolution: usize,
    re: u32,
) -> SphResult<(FluidWorld, crate::FluidHandle)> {
    if resolution < 8 {
        return Err(SphError::InvalidParameter {
            field: "resolution",
            value: resolution as f64,
            reason: "at least 8 particles across the box (its edge must hold more than 3 smoothing lengths)",
        });
    }
    let params = params(method, resolution, re)?;
    let s = params.particle_spacing;
    let mut pts = Vec::with_capacity(resolution.pow(3));
    let mut vel = Vec::with_capacity(resolution.pow(3));
    for k in 0..resolution {
        for j in 0..resolution {
            for i in 0..resolution {
                // In f64, then rounded: the lattice is exact to f32 round-off.
                let c = |n: usize| (n as f64 + 0.5) * std::f64::consts::TAU / resolution as f64;
                let (x, y, z) = (c(i), c(j), c(k));
                pts.push(Vector::new(x as Real, y as Real, z as Real));
                vel.push(Vector::new(
                    (x.sin() * y.cos() * z.cos()) as Real,
                    (-x.cos() * y.sin() * z.cos()) as Real,
                    0.0,
                ));
            }
        }
    }
    debug_assert!((s - BOX / resolution as Real).abs() < 1e-6);
    let mut world = FluidWorld::new();
    world.physics.gravity = Vector::ZERO;
    let mut fluid = crate::Fluid::new(params)?;
    fluid.add_particles_with_velocities(&pts, Some(&vel))?;
    let handle = world.fluids.insert(fluid);
    Ok((world, handle))
}

/// Volume-averaged kinetic energy `Σ ½ m|v|² / (2π)³`.
pub fn kinetic_energy(fluid: &crate::Fluid) -> f64 {
    fluid.kinetic_energy() / (BOX as f64).powi(3)
}

/// Runs the vortex once at Re = [`REYNOLDS`] for [`DURATION`] (see [`super::Scene::run`]).
pub fn run(
    method: &Method,
    resolution: usize,
    policy: TimePolicy,
    progress: &mut dyn FnMut(Real),
) -> SphResult<RunRecord> {
    run_with(method, resolution, REYNOLDS, DURATION, policy, progress)
}

/// Runs the vortex at Reynolds number `re` (10, 20, 50 or 100) for `duration`.
pub fn run_with(
    method: &Method,
    resolution: usize,
    re: u32,
    duration: Real,
    policy: TimePolicy,
    progress: &mut dyn FnMut(Real),
) -> SphResult<RunRecord> {
    let curve = reference(re)?;
    let (mut world, fluid) = world(method, resolution, re)?;
    let params = world.fluids[fluid].params().clone();
    let particles = world.fluids[fluid].len();
    let e0 = kinetic_energy(&world.fluids[fluid]);
    // Peak speed 1: the adaptive step at that speed.
    let dt_ref = super::reference_step(&params, 1.0, 0.0);
    // The vortex only decays; 10 % above the start is energy created (an instability), far
    // beyond the Mach-0.1 exchange with compression (~Ma² = 1 %).
    let energy_bound = 1.1 * world.fluids[fluid].kinetic_energy();
    let inside = |p: Vector| p.cmpge(Vector::ZERO).all() && p.cmplt(Vector::splat(BOX)).all();
    let mut samples: Vec<(f64, f64)> = Vec::new();
    let driven = drive(
        &mut world,
        fluid,
        &DriveSpec {
            duration,
            sample_dt: SAMPLE_DT,
            dt_ref,
            policy,
            energy_bound,
            gravity: 0.0,
            inside: &inside,
        },
        &mut |t, world| samples.push((t as f64, kinetic_energy(&world.fluids[fluid]))),
        progress,
    )?;
    let setup = RunSetup {
        scene: super::Scene::TaylorGreen.name(),
        method: method.name,
        resolution,
        spacing: params.particle_spacing,
        particles,
        policy,
        dt_ref,
        duration,
    };
    let errors = errors(&samples, &curve, e0);
    Ok(setup.record(
        driven,
        errors,
        vec![SimCurve {
            name: "ekin",
            points: samples,
        }],
    ))
}

/// The errors of the sampled kinetic energy `samples` (`(t, E)`, starting at `E(0) = e0`)
/// against the reference `curve`: RMS of the relative error over the samples after `t = 0`,
/// relative error of the initial dissipation rate (first sampling interval; the reference
/// starts at `E = 1/8`), and the last sample's relative error. NaN where there is no sample.
fn errors(samples: &[(f64, f64)], curve: &super::Curve, e0: f64) -> Vec<Metric> {
    let rel: Vec<f64> = samples
        .iter()
        .filter(|s| s.0 > 0.0)
        .map(|&(t, e)| {
            let r = reference_at(curve, t);
            (e - r) / r
        })
        .collect();
    let nan = f64::NAN;
    let ekin_rms = if rel.is_empty() {
        nan
    } else {
        (rel.iter().map(|e| e * e).sum::<f64>() / rel.len() as f64).sqrt()
    };
    let dissipation_t0 = match samples.get(1) {
        Some(&(t1, e1)) if t1 > 0.0 => {
            let sim = (e0 - e1) / t1;
            let r = (0.125 - reference_at(curve, t1)) / t1;
            (sim - r) / r
        }
        _ => nan,
    };
    let ekin_end = rel.last().copied().unwrap_or(nan);
    metrics([
        ("ekin_rms", ekin_rms),
        ("dissipation_t0", dissipation_t0),
        ("ekin_end", ekin_end),
    ])
}
