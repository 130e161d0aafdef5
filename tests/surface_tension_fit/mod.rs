//! A damped sinusoid fitted by least squares to a sampled signal, with the frequency's
//! standard error: shared by `tests/surface_tension.rs` and `examples/rayleigh_probe.rs`
//! (both include it by path).
//!
//! The model is `q(t) = e^{−λt}(a cos ωt + b sin ωt) + B + C t` (a damped mode on a slowly
//! drifting mean). For fixed `(ω, λ)` it is linear in `(a, b, B, C)`, solved exactly (normal
//! equations); the residual is then minimised over `(ω, λ)` by a scan of `ω` followed by a
//! coordinate refinement. `ω`'s standard error is the Gauss–Newton one, `s²(JᵀJ)⁻¹` over the
//! six parameters, with the residual variance `s²` inflated by the residuals' correlation
//! time (the particles' noise is not white: neighbouring frames share it), so the error is
//! that of the independent samples the window holds.

#![allow(dead_code)]

use rapier_sph::math::{Real, Vector};

/// The particles' centre (the mean position).
pub fn centre(x: &[Vector]) -> Vector {
    x.iter().fold(Vector::ZERO, |a, b| a + *b) / x.len() as Real
}

/// The droplet's l = 2 quadrupole about its centre, `Q = ⟨z² − (x² + y²)/2⟩` (m²).
pub fn quadrupole(x: &[Vector]) -> f64 {
    let c = centre(x);
    let s: f64 = x
        .iter()
        .map(|p| {
            let d = *p - c;
            (d.z * d.z - 0.5 * (d.x * d.x + d.y * d.y)) as f64
        })
        .sum();
    s / x.len() as f64
}

/// A fitted damped sinusoid.
#[derive(Clone, Copy, Debug)]
pub struct Fit {
    /// Angular frequency (rad/s).
    pub omega: f64,
    /// Its standard error (rad/s).
    pub omega_err: f64,
    /// Decay rate `λ` (1/s).
    pub decay: f64,
    /// The amplitude at the window's start.
    pub amplitude: f64,
    /// RMS of the residuals.
    pub rms: f64,
    /// The residuals' correlation length (samples) used to inflate the error.
    pub correlation: f64,
}

fn solve<const N: usize>(mut a: [[f64; N]; N], mut b: [f64; N]) -> Option<[f64; N]> {
    for c in 0..N {
        let p = (c..N).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))?;
        if a[p][c].abs() < 1e-300 {
            return None;
        }
        a.swap(c, p);
        b.swap(c, p);
        for r in 0..N {
            if r != c {
                let f = a[r][c] / a[c][c];
                let pivot = a[c];
                for (ark, ack) in a[r][c..].iter_mut().zip(&pivot[c..]) {
                    *ark -= f * ack;
                }
                b[r] -= f * b[c];
            }
        }
    }
    Some(std::array::from_fn(|i| b[i] / a[i][i]))
}

/// The basis of the linear parameters at time `t`.
fn basis(t: f64, omega: f64, decay: f64) -> [f64; 4] {
    let e = (-decay * t).exp();
    [e * (omega * t).cos(), e * (omega * t).sin(), 1.0, t]
}

/// The linear parameters and the residual sum of squares for fixed `(ω, λ)`.
fn linear(q: &[f64], dt: f64, omega: f64, decay: f64) -> ([f64; 4], f64) {
    let mut m = [[0.0; 4]; 4];
    let mut r = [0.0; 4];
    for (k, v) in q.iter().enumerate() {
        let f = basis(k as f64 * dt, omega, decay);
        for i in 0..4 {
            r[i] += f[i] * v;
            for j in 0..4 {
                m[i][j] += f[i] * f[j];
            }
        }
    }
    let Some(p) = solve(m, r) else {
        return ([0.0; 4], f64::INFINITY);
    };
    let ss = q
        .iter()
        .enumerate()
        .map(|(k, v)| {
            let f = basis(k as f64 * dt, omega, decay);
            let model: f64 = (0..4).map(|i| p[i] * f[i]).sum();
            (v - model).powi(2)
        })
        .sum();
    (p, ss)
}

/// Minimises `f` on `[lo, hi]` by golden section (80 steps).
fn golden(mut lo: f64, mut hi: f64, f: impl Fn(f64) -> f64) -> f64 {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..80 {
        let (a, b) = (hi - g * (hi - lo), lo + g * (hi - lo));
        if f(a) < f(b) {
            hi = b;
        } else {
            lo = a;
        }
    }
    0.5 * (lo + hi)
}

/// Fits `q` (sampled every `dt` from `t = 0`) with angular frequencies scanned over
/// `[omega_lo, omega_hi]`. `None` when the fit is degenerate.
pub fn fit(q: &[f64], dt: f64, omega_lo: f64, omega_hi: f64) -> Option<Fit> {
    let span = q.len() as f64 * dt;
    let decay_max = 10.0 / span;
    // Scan ω (steps of a tenth of the window's frequency resolution) at λ = 0.
    let step = 0.1 * std::f64::consts::PI / span;
    let mut best = (omega_lo, 0.0, f64::INFINITY);
    let mut w = omega_lo;
    while w <= omega_hi {
        let ss = linear(q, dt, w, 0.0).1;
        if ss < best.2 {
            best = (w, 0.0, ss);
        }
        w += step;
    }
    let (mut omega, mut decay) = (best.0, best.1);
    for _ in 0..6 {
        decay = golden(-0.5 * decay_max, decay_max, |l| linear(q, dt, omega, l).1);
        let d = decay;
        omega = golden(omega - 2.0 * step, omega + 2.0 * step, |w| {
            linear(q, dt, w, d).1
        });
    }
    let (p, ss) = linear(q, dt, omega, decay);
    if !ss.is_finite() {
        return None;
    }
    // Residuals and their correlation length 1 + 2 Σ ρ_k (summed while ρ_k > 0).
    let res: Vec<f64> = q
        .iter()
        .enumerate()
        .map(|(k, v)| {
            let f = basis(k as f64 * dt, omega, decay);
            v - (0..4).map(|i| p[i] * f[i]).sum::<f64>()
        })
        .collect();
    let n = res.len();
    let var = res.iter().map(|r| r * r).sum::<f64>() / n as f64;
    let mut corr = 1.0;
    for lag in 1..n / 4 {
        let rho = res[..n - lag]
            .iter()
            .zip(&res[lag..])
            .map(|(a, b)| a * b)
            .sum::<f64>()
            / (n as f64 * var);
        if rho <= 0.0 {
            break;
        }
        corr += 2.0 * rho;
    }
    // Gauss–Newton covariance over (ω, λ, a, b, B, C).
    let mut jtj = [[0.0; 6]; 6];
    for k in 0..n {
        let t = k as f64 * dt;
        let e = (-decay * t).exp();
        let (c, s) = ((omega * t).cos(), (omega * t).sin());
        let osc = e * (p[0] * c + p[1] * s);
        let j = [
            e * t * (-p[0] * s + p[1] * c),
            -t * osc,
            e * c,
            e * s,
            1.0,
            t,
        ];
        for a in 0..6 {
            for b in 0..6 {
                jtj[a][b] += j[a] * j[b];
            }
        }
    }
    let mut unit = [0.0; 6];
    unit[0] = 1.0;
    let col = solve(jtj, unit)?;
    let s2 = ss / (n as f64 - 6.0) * corr;
    Some(Fit {
        omega,
        omega_err: (s2 * col[0]).sqrt(),
        decay,
        amplitude: p[0].hypot(p[1]),
        rms: var.sqrt(),
        correlation: corr,
    })
}
