//! Surface tension of He, Wang, Zhang, Liu & Wang (2014), "Robust simulation of sparsely
//! sampled thin features in SPH-based free surface flows" (ACM TOG 34(1), 7): the surface
//! energy is that of the smoothed colour field's gradient,
//!
//! ```text
//! E = (κ/2) Σ_i V_i |∇C_i|²,   C_i = Σ_j V_j W_ij (the particle itself included),
//! ∇C_i = (1/C_i) Σ_j V_j C_j ∇W_ij,
//! ```
//!
//! (`V_j = m/ρ_j`, `∇W_ij` the gradient at `x_i` of `W(x_i − x_j)`), and the force is the
//! symmetric SPH gradient of the energy density `e = (κ/2)|∇C|²` read as a negative
//! pressure (`p = −e`, a tension in the layer within `h` of the surface):
//!
//! ```text
//! a_i = (κ/4) m Σ_j (|∇C_i|² + |∇C_j|²)/(ρ_i ρ_j) ∇W_ij
//! ```
//!
//! Each pair's force is equal and opposite along `x_ij`, so momentum and angular momentum
//! are conserved. Inside the fluid `∇C ≈ 0` and the force vanishes; a particle displaced
//! out of the surface sits where `|∇C|²` is large and is pulled back by its neighbours (an
//! isotropic tension, not a tangential stress). `κ` is in N (`e` is J/m³ and `|∇C|²` is
//! 1/m²); the surface tension it gives is `σ = (κ/2) ∫ |∇C|² dn` across the surface, of
//! order `κ/h`.
//!
//! **Where it runs.** As Akinci's stage does (`forces::surface_tension`): after the solver,
//! as a velocity change `v_i += dt·a_i` with the substep's densities and neighbour lists; the
//! three pair loops gather per particle in chunks, so the results do not depend on the
//! thread count.

use crate::domain::Separation;
use crate::kernel::Kernel;
use crate::math::{Real, Vector};
use crate::neighbors::Pairs;
use crate::par::CHUNK;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Adds the substep's surface tension (`κ`, substep `dt`) to `velocities`; `scratch` holds
/// the colour field and its squared gradient, one each per particle.
pub(crate) fn apply<K: Kernel, S: Separation>(
    (kappa, dt): (Real, Real),
    pairs: &Pairs<'_, S>,
    (_densities, inv_densities): (&[Real], &[Real]),
    scratch: &mut (Vec<Real>, Vec<Real>),
    velocities: &mut [Vector],
) {
    let n = velocities.len();
    let kernel = K::new(pairs.h);
    let (colour, grad2) = (&mut scratch.0, &mut scratch.1);
    colour.resize(n, 0.0);
    grad2.resize(n, 0.0);
    crate::par_chunks_mut!(colour[..], CHUNK)
        .enumerate()
        .for_each(|(k, out)| {
            for (l, c) in out.iter_mut().enumerate() {
                *c = colour_at(pairs, &kernel, inv_densities, k * CHUNK + l);
            }
        });
    let colour = &colour[..];
    crate::par_chunks_mut!(grad2[..], CHUNK)
        .enumerate()
        .for_each(|(k, out)| {
            for (l, g) in out.iter_mut().enumerate() {
                *g = colour_gradient(pairs, &kernel, inv_densities, colour, k * CHUNK + l)
                    .length_squared();
            }
        });
    let grad2 = &grad2[..];
    let scale = 0.25 * kappa * pairs.mass * dt;
    crate::par_chunks_mut!(velocities, CHUNK)
        .enumerate()
        .for_each(|(k, out)| {
            for (l, v) in out.iter_mut().enumerate() {
                let i = k * CHUNK + l;
                *v += tension(pairs, &kernel, inv_densities, grad2, i) * scale;
            }
        });
}

/// The exact gradient of the unnormalised energy `E = (κ/2) V Σ_i |G_i|²`,
/// `G_i = V Σ_j ∇W_ij`, `V = m/ρ0` (positions only): `a_k = −(κV²/m) Σ_j H_kj (G_k − G_j)`
/// with `H` the kernel's Hessian. EXPERIMENT.
pub(crate) fn apply_exact<K: Kernel, S: Separation>(
    (kappa, dt, rest_density): (Real, Real, Real),
    pairs: &Pairs<'_, S>,
    grads: &mut Vec<Vector>,
    velocities: &mut [Vector],
) {
    let n = velocities.len();
    let kernel = K::new(pairs.h);
    let vol = pairs.mass / rest_density;
    grads.resize(n, Vector::ZERO);
    let (x, sep) = (pairs.positions, &pairs.sep);
    crate::par_chunks_mut!(grads[..], CHUNK)
        .enumerate()
        .for_each(|(k, out)| {
            for (l, g) in out.iter_mut().enumerate() {
                let i = k * CHUNK + l;
                let mut sum = Vector::ZERO;
                for &j in pairs.neighbors.of(i) {
                    let r = sep.sep(x[i], x[j as usize]);
                    let d = r.length();
                    if d > 0.0 && d < pairs.h {
                        sum += r * (kernel.dw(d) / d);
                    }
                }
                *g = sum * vol;
            }
        });
    let grads = &grads[..];
    let eps = 1e-4 * pairs.h;
    let scale = -kappa * vol * vol / pairs.mass * dt;
    crate::par_chunks_mut!(velocities, CHUNK)
        .enumerate()
        .for_each(|(k, out)| {
            for (l, v) in out.iter_mut().enumerate() {
                let i = k * CHUNK + l;
                let mut sum = Vector::ZERO;
                for &j in pairs.neighbors.of(i) {
                    let ju = j as usize;
                    let r = sep.sep(x[i], x[ju]);
                    let d = r.length();
                    if d > 0.0 && d < pairs.h {
                        let d1 = kernel.dw(d);
                        let d2 = (kernel.dw(d + eps) - kernel.dw((d - eps).max(0.0)))
                            / (d + eps - (d - eps).max(0.0));
                        let u = grads[i] - grads[ju];
                        let rh = r / d;
                        sum += rh * ((d2 - d1 / d) * rh.dot(u)) + u * (d1 / d);
                    }
                }
                *v += sum * scale;
            }
        });
}

/// `C_i = Σ_j V_j W_ij`, the particle itself included.
#[inline(always)]
pub(crate) fn colour_at<K: Kernel, S: Separation>(
    pairs: &Pairs<'_, S>,
    kernel: &K,
    inv_densities: &[Real],
    i: usize,
) -> Real {
    let (x, sep) = (pairs.positions, &pairs.sep);
    let mut sum = kernel.w(0.0) * inv_densities[i];
    for &j in pairs.neighbors.of(i) {
        let ju = j as usize;
        let d = sep.sep(x[i], x[ju]).length();
        sum += kernel.w(d) * inv_densities[ju];
    }
    sum * pairs.mass
}

/// `∇C_i = (1/C_i) Σ_j V_j C_j ∇W_ij`.
#[inline(always)]
pub(crate) fn colour_gradient<K: Kernel, S: Separation>(
    pairs: &Pairs<'_, S>,
    kernel: &K,
    inv_densities: &[Real],
    colour: &[Real],
    i: usize,
) -> Vector {
    let (x, sep) = (pairs.positions, &pairs.sep);
    let mut sum = Vector::ZERO;
    for &j in pairs.neighbors.of(i) {
        let ju = j as usize;
        let r = sep.sep(x[i], x[ju]);
        let d = r.length();
        if d > 0.0 && d < pairs.h {
            sum += r * (kernel.dw(d) / d * inv_densities[ju] * colour[ju]);
        }
    }
    if colour[i] > 0.0 {
        sum * (pairs.mass / colour[i])
    } else {
        Vector::ZERO
    }
}

/// `Σ_j (g_i + g_j)/(ρ_i ρ_j) ∇W_ij` of particle `i` (`g = |∇C|²`).
#[inline(always)]
fn tension<K: Kernel, S: Separation>(
    pairs: &Pairs<'_, S>,
    kernel: &K,
    inv_densities: &[Real],
    grad2: &[Real],
    i: usize,
) -> Vector {
    let (x, sep) = (pairs.positions, &pairs.sep);
    let mut sum = Vector::ZERO;
    for &j in pairs.neighbors.of(i) {
        let ju = j as usize;
        let r = sep.sep(x[i], x[ju]);
        let d = r.length();
        if d > 0.0 && d < pairs.h {
            sum += r * (kernel.dw(d) / d * (grad2[i] + grad2[ju]) * inv_densities[ju]);
        }
    }
    sum * inv_densities[i]
}
