//! The effective surface tension `σ` (N/m) of Akinci's `γ` (`FluidParams::surface_tension`),
//! measured on a droplet in zero gravity, reported in `rapier_sph::forces::surface_tension`'s
//! docs and used by `tests/surface_tension.rs`.
//!
//! A lattice ball of radius `--radius` spacings (water at `--spacing`, DFSPH, frames of 1 ms)
//! settles for `--settle` s at viscosity 0.5 Pa·s; then, at `--viscosity`, it is given the
//! l = 2 mode's potential flow `v = A(−x, −y, 2z)` (pole speed `--speed`), and its quadrupole
//! `Q = ⟨z² − (x² + y²)/2⟩` is recorded every frame for `--seconds`. A damped sinusoid fitted
//! to `Q(t)` after `--skip` s (`tests/surface_tension_fit`) gives `ω`, and Rayleigh's
//! `ω0² = 8σ/(ρR³)` with `ω0² = ω² + λ²` gives `σ`, `R` the volume radius. It also prints
//! the core's pressure (particles within `R/2` of the centre) averaged over the recorded
//! frames, for the Laplace pressure `2σ/R`; with `--speed 0` (no kick) only that, with the
//! mean's standard error from ten block means.
//!
//! `cargo run --release --example rayleigh_probe -- --radius 10 --seconds 1.5`

#[path = "../tests/surface_tension_fit/mod.rs"]
mod fit;

use clap::Parser;
use fit::{centre, quadrupole};
use rapier_sph::math::{Real, Vector};
use rapier_sph::rapier3d::prelude::{BroadPhaseBvh, ColliderSet, RigidBodySet};
use rapier_sph::{Fluid, FluidParamsBuilder, FluidPipeline, FluidSet};
use std::f64::consts::PI;
use std::time::Instant;

#[derive(Parser)]
struct Args {
    /// The droplet's radius in spacings.
    #[arg(long, default_value_t = 10.0)]
    radius: Real,
    /// Particle spacing (m); h = 2 spacings.
    #[arg(long, default_value_t = 0.01)]
    spacing: Real,
    /// Akinci's γ.
    #[arg(long, default_value_t = 1.0)]
    gamma: Real,
    /// He et al. 2014's `κ` (N): when positive, the droplet holds by this surface tension
    /// instead of Akinci's (`--gamma` is then ignored).
    #[arg(long, default_value_t = 0.0)]
    he: Real,
    /// WCSPH with negative pressures kept (the bulk carries tension) instead of DFSPH.
    #[arg(long)]
    wcsph_tension: bool,
    /// Frame length (s).
    #[arg(long, default_value_t = 1e-3)]
    dt: Real,
    /// The adaptive substep's Courant number.
    #[arg(long, default_value_t = 0.4)]
    courant: Real,
    /// Settling time (s) at viscosity 0.5.
    #[arg(long, default_value_t = 0.5)]
    settle: Real,
    /// Recorded time (s) after the kick.
    #[arg(long, default_value_t = 1.5)]
    seconds: Real,
    /// Time (s) after the kick left out of the fit.
    #[arg(long, default_value_t = 0.0)]
    skip: Real,
    /// The kick's pole speed (m/s).
    #[arg(long, default_value_t = 0.1)]
    speed: Real,
    /// Viscosity (Pa·s) while recorded.
    #[arg(long, default_value_t = 0.1)]
    viscosity: Real,
    /// Write `t Q` lines to this file.
    #[arg(long)]
    out: Option<String>,
}

fn core_pressure(f: &Fluid, r: f64) -> f64 {
    let c = centre(f.positions());
    let (mut sum, mut k) = (0.0f64, 0);
    for (p, pr) in f.positions().iter().zip(f.pressures()) {
        if ((*p - c).length() as f64) < 0.5 * r {
            sum += *pr as f64;
            k += 1;
        }
    }
    sum / k.max(1) as f64
}

/// He et al.'s surface energy `(κ/2) Σ_i V_i |∇C_i|²` (J) of the fluid's particles, by
/// direct sums over all pairs (cubic spline, as the water preset's density kernel).
fn he_energy(f: &Fluid, kappa: f64) -> f64 {
    let p = f.params();
    if std::env::var_os("RAPIER_SPH_HE_EXACT").is_some() {
        // (κ/2) V Σ |G_i|², G_i = V Σ_j ∇W_ij, V = m/ρ0.
        let (h, x) = (p.smoothing_length, f.positions());
        let v = (p.particle_mass / p.rest_density) as f64;
        let k = rapier_sph::KernelKind::CubicSpline;
        return x
            .iter()
            .map(|xi| {
                let g = x.iter().fold(Vector::ZERO, |g, xj| {
                    let r = *xi - *xj;
                    let d = r.length();
                    if d > 0.0 && d < h {
                        g + r * (k.dw(d, h) / d)
                    } else {
                        g
                    }
                });
                0.5 * kappa * v * v * v * g.length_squared() as f64
            })
            .sum();
    }
    let (h, m) = (p.smoothing_length, p.particle_mass as f64);
    let x = f.positions();
    let rho = f.densities();
    let n = x.len();
    let k = rapier_sph::KernelKind::CubicSpline;
    let near = |i: usize| (0..n).filter(move |&j| j != i && (x[i] - x[j]).length() < h);
    let colour: Vec<f64> = (0..n)
        .map(|i| {
            let own = k.w(0.0, h) as f64 / rho[i] as f64;
            m * near(i).fold(own, |c, j| {
                c + k.w((x[i] - x[j]).length(), h) as f64 / rho[j] as f64
            })
        })
        .collect();
    (0..n)
        .map(|i| {
            let g = near(i).fold(Vector::ZERO, |g, j| {
                let r = x[i] - x[j];
                let d = r.length();
                g + r * (k.dw(d, h) / d / rho[j] * colour[j] as Real)
            }) * (m / colour[i]) as Real;
            0.5 * kappa * m / rho[i] as f64 * g.length_squared() as f64
        })
        .sum()
}

fn main() {
    let a = Args::parse();
    let dt_frame = a.dt;
    let s = a.spacing;
    let params = |viscosity: Real| {
        let b = FluidParamsBuilder::water(s);
        let b = if a.he > 0.0 {
            b.surface_tension_he(a.he)
        } else {
            b.surface_tension(a.gamma)
        };
        let b = if a.wcsph_tension {
            b.solver(rapier_sph::Solver::Wcsph)
                .clamp_negative_pressure(false)
        } else {
            b
        };
        b.viscosity(viscosity).build().unwrap()
    };
    let mut fluid = Fluid::new(params(0.5)).unwrap();
    let k = a.radius.ceil() as i32;
    let mut ball = Vec::new();
    for i in -k..=k {
        for j in -k..=k {
            for l in -k..=k {
                let p = Vector::new(i as Real, j as Real, l as Real);
                if p.length() <= a.radius {
                    ball.push(p * s);
                }
            }
        }
    }
    fluid.add_particles(&ball).unwrap();
    let n = ball.len();
    let r = (3.0 * n as f64 / (4.0 * PI)).cbrt() * s as f64;
    let mut set = FluidSet::new();
    let h = set.insert(fluid);
    let mut pipeline = FluidPipeline::with_time_stepping(rapier_sph::TimeStepping::Adaptive {
        courant: a.courant,
        max_substeps: 64,
    });
    let (mut bodies, colliders, bvh) = (
        RigidBodySet::new(),
        ColliderSet::new(),
        BroadPhaseBvh::new(),
    );
    let clock = Instant::now();
    let mut step = |set: &mut FluidSet| {
        pipeline
            .step(Vector::ZERO, dt_frame, set, &mut bodies, &colliders, &bvh)
            .expect("step");
    };
    for _ in 0..(a.settle / dt_frame).round() as usize {
        step(&mut set);
    }
    set[h].set_params(params(a.viscosity)).unwrap();
    let x = set[h].positions().to_vec();
    let c = centre(&x);
    let amp = a.speed / (2.0 * r as Real);
    for (v, p) in set[h].velocities_mut().iter_mut().zip(&x) {
        let d = *p - c;
        *v += Vector::new(-d.x, -d.y, 2.0 * d.z) * amp;
    }
    let (mut q, mut pc) = (Vec::new(), Vec::new());
    let frames = (a.seconds / dt_frame).round() as usize;
    let energy = |f: &Fluid| {
        let e = if a.he > 0.0 {
            he_energy(f, a.he as f64)
        } else {
            0.0
        };
        (f.kinetic_energy(), e)
    };
    let report = |k: usize, (kin, e): (f64, f64)| {
        println!(
            "t {:.3} s: kinetic {kin:.4e} J, surface {e:.6e} J, sum {:.6e} J",
            k as f64 * dt_frame as f64,
            kin + e
        )
    };
    report(0, energy(&set[h]));
    let every = (frames / 10).max(1);
    for k in 0..frames {
        step(&mut set);
        q.push(quadrupole(set[h].positions()));
        pc.push(core_pressure(&set[h], r));
        if (k + 1) % every == 0 {
            report(k + 1, energy(&set[h]));
        }
    }
    // Particles shed: farther than R + 2 spacings from the centre.
    let c = centre(set[h].positions());
    let shed = set[h]
        .positions()
        .iter()
        .filter(|p| ((**p - c).length() as f64) > r + 2.0 * s as f64)
        .count();
    println!("shed (beyond R + 2 spacings): {shed}");
    let mut radii: Vec<f64> = set[h]
        .positions()
        .iter()
        .map(|p| (*p - c).length() as f64 / s as f64)
        .collect();
    radii.sort_by(f64::total_cmp);
    let at = |q: f64| radii[((radii.len() - 1) as f64 * q) as usize];
    let core: Vec<Real> = set[h]
        .positions()
        .iter()
        .zip(set[h].densities())
        .filter(|(p, _)| ((**p - c).length() as f64) < 0.5 * r)
        .map(|(_, d)| *d)
        .collect();
    println!(
        "radii (spacings): median {:.2}, 90 % {:.2}, 99 % {:.2}, max {:.2}; core density {:.1}",
        at(0.5),
        at(0.9),
        at(0.99),
        at(1.0),
        core.iter().sum::<Real>() / core.len() as Real
    );
    let wall = clock.elapsed().as_secs_f64();
    if let Some(path) = &a.out {
        let text: String = q
            .iter()
            .enumerate()
            .map(|(k, v)| format!("{:.4} {v:.6e}\n", (k + 1) as f64 * dt_frame as f64))
            .collect();
        std::fs::write(path, text).unwrap();
    }
    let m = pc.len() as f64;
    let mean = pc.iter().sum::<f64>() / m;
    let sd = (pc.iter().map(|p| (p - mean).powi(2)).sum::<f64>() / (m - 1.0)).sqrt();
    // The mean's standard error from ten block means (the frames are correlated).
    let blocks: Vec<f64> = pc
        .chunks(pc.len() / 10)
        .take(10)
        .map(|b| b.iter().sum::<f64>() / b.len() as f64)
        .collect();
    let bm = blocks.iter().sum::<f64>() / 10.0;
    let se = (blocks.iter().map(|b| (b - bm).powi(2)).sum::<f64>() / 90.0).sqrt();
    if a.speed == 0.0 {
        println!(
            "N {n} R {r:.4} m: core pressure {mean:.2} ± {se:.2} Pa (sd {sd:.1}); {wall:.1} s wall"
        );
        return;
    }
    let skip = (a.skip / dt_frame).round() as usize;
    let rho = 1000.0;
    // Scan periods from 0.05 s to the window's length.
    let span = (q.len() - skip) as f64 * dt_frame as f64;
    let f = fit::fit(
        &q[skip..],
        dt_frame as f64,
        2.0 * PI / span,
        2.0 * PI / 0.05,
    )
    .expect("fit");
    let w0 = (f.omega * f.omega + f.decay * f.decay).sqrt();
    let sigma = rho * r.powi(3) * w0 * w0 / 8.0;
    println!(
        "N {n} R {r:.4} m: T {:.4} s (ω {:.3} ± {:.3} rad/s, λ {:.3}/s, amplitude {:.3e} m², \
         residual {:.2e}, correlation {:.0} frames): σ {sigma:.3} ± {:.3} N/m; \
         core pressure {mean:.1} Pa (sd {sd:.1}); {wall:.1} s wall",
        2.0 * PI / f.omega,
        f.omega,
        f.omega_err,
        f.decay,
        f.amplitude,
        f.rms,
        f.correlation,
        2.0 * sigma * f.omega_err / f.omega,
    );
}
