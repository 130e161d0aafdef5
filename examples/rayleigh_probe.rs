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

const DT: Real = 1e-3;

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

fn main() {
    let a = Args::parse();
    let s = a.spacing;
    let params = |viscosity: Real| {
        FluidParamsBuilder::water(s)
            .surface_tension(a.gamma)
            .viscosity(viscosity)
            .build()
            .unwrap()
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
    let mut pipeline = FluidPipeline::new();
    let (mut bodies, colliders, bvh) = (
        RigidBodySet::new(),
        ColliderSet::new(),
        BroadPhaseBvh::new(),
    );
    let clock = Instant::now();
    let mut step = |set: &mut FluidSet| {
        pipeline
            .step(Vector::ZERO, DT, set, &mut bodies, &colliders, &bvh)
            .expect("step");
    };
    for _ in 0..(a.settle / DT).round() as usize {
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
    for _ in 0..(a.seconds / DT).round() as usize {
        step(&mut set);
        q.push(quadrupole(set[h].positions()));
        pc.push(core_pressure(&set[h], r));
    }
    let wall = clock.elapsed().as_secs_f64();
    if let Some(path) = &a.out {
        let text: String = q
            .iter()
            .enumerate()
            .map(|(k, v)| format!("{:.4} {v:.6e}\n", (k + 1) as f64 * DT as f64))
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
    let skip = (a.skip / DT).round() as usize;
    let rho = 1000.0;
    // Scan periods from 0.05 s to the window's length.
    let span = (q.len() - skip) as f64 * DT as f64;
    let f = fit::fit(&q[skip..], DT as f64, 2.0 * PI / span, 2.0 * PI / 0.05).expect("fit");
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
