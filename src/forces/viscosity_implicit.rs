//! The implicit viscosity solve of Weiler, Koschier, Brand & Bender (2018), "A Physically
//! Consistent Implicit Viscosity Solver for SPH Fluids" (Computer Graphics Forum 37(2),
//! 145–155), run after the solver's substep when the fluid asks for it
//! ([`crate::ViscositySolve::Implicit`]).
//!
//! **The model.** `dv_i/dt = (μ/ρ_i) ∇²v_i` with the paper's Laplacian (its eq. 8, after
//! Monaghan 2005), which is consistent for the whole vector field, not only its divergence:
//!
//! `∇²v_i = 2(d + 2) Σ_j (m_j/ρ_j) (v_ij · x_ij)/(|x_ij|² + 0.01 h²) ∇W_ij`, `d = 3`,
//!
//! with `v_ij = v_i − v_j`, `x_ij = x_i − x_j` and the cubic spline's gradient `∇W_ij =
//! W'(r) x_ij/r` (`W' ≤ 0`). Integrated implicitly over the substep, `v − dt (μ/ρ_i)∇²v =
//! v*` (`v*` the velocities the solver left), it reads `A v = v*` with
//!
//! `(A v)_i = v_i + Σ_j g_ij (g_ij · (v_i − v_j))`, `g_ij = x_ij √(10 dt μ m (−W'(r)) /
//! (r (r² + 0.01 h²) ρ_i ρ_j))`.
//!
//! All particles of a fluid share their mass, so `A = I + Σ_pairs` of positive semidefinite
//! 3×3 blocks `g gᵀ` is symmetric positive definite with every eigenvalue at least 1: the
//! exact solution never raises the kinetic energy (`|A⁻¹ v*| ≤ |v*|`), keeps the momentum
//! (the pair blocks cancel in `Σ_i (A v)_i`), and exists at any `dt μ`. That is what lets a
//! 1/60 s substep hold honey (10 Pa·s) and beyond, where the explicit force
//! (`forces::viscosity`) asks for `dt ≤ ρ0 h²/(30 μ)` (about 1.9·10⁻⁵ s for honey at 2 cm
//! spacing).
//!
//! **The solve.** Conjugate gradient (matrix-free: the `g_ij` of every pair are formed once
//! per substep and kept per chunk of the neighbour lists) with the 3×3 block-Jacobi
//! preconditioner `D_i = I + Σ_j g_ij g_ijᵀ`, as the paper. It starts from `v* + Δv`, `Δv`
//! the velocity change the last solve gave the particle, kept as a fluid attribute
//! ([`WARM`]) so re-sorts, sinks and snapshots move it with its particle. It stops when the
//! residual's norm is below the tolerance times `|v*|`, or after the iteration cap. Dot
//! products are summed per fixed chunk of particles and the chunks' sums added in order, so
//! the result is the same bit for bit on any number of threads.
//!
//! The walls' viscosity (`forces::wall_viscosity`, already implicit per particle) is a
//! separate stage after this one.

use crate::domain::Separation;
use crate::fluid::Attributes;
use crate::kernel::{CubicSpline, Kernel};
use crate::math::{Real, Vector};
use crate::neighbors::Pairs;
use crate::par::CHUNK;
use crate::params::ImplicitViscosity;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Names of the warm-start attributes: the velocity change of the last solve, per axis.
pub(crate) const WARM: [&str; 3] = [
    "viscosity.implicit.dvx",
    "viscosity.implicit.dvy",
    "viscosity.implicit.dvz",
];

/// What one solve did.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub(crate) struct SolveStats {
    /// Conjugate-gradient iterations run.
    pub iterations: usize,
    /// `|residual| / |v*|` at the end.
    pub residual: Real,
}

/// The solve's buffers, kept in the fluid's workspace so a warm step does not allocate.
#[derive(Clone, Debug, Default)]
pub(crate) struct Scratch {
    /// `g_ij` of every listed pair, per chunk, in the order of the chunk's neighbour lists.
    pairs: Vec<Vec<Vector>>,
    /// The conjugate gradient's vectors.
    cg: Cg,
    /// The stress-based solve's buffers (`forces::viscosity_stress`), empty unless a fluid
    /// asks for it.
    pub stress: crate::forces::viscosity_stress::Scratch,
}

impl Scratch {
    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        let v = std::mem::size_of::<Vector>();
        self.pairs.iter().map(|c| c.capacity() * v).sum::<usize>()
            + self.cg.heap_bytes()
            + self.stress.heap_bytes()
    }
}

/// The preconditioned conjugate gradient's vectors, shared by both implicit viscosity solves
/// (this module's and `forces::viscosity_stress`).
#[derive(Clone, Debug, Default)]
pub(crate) struct Cg {
    /// Inverse preconditioner blocks (symmetric: xx, yy, zz, xy, xz, yz).
    pub inv_diag: Vec<[Real; 6]>,
    /// Right-hand side `v*`.
    b: Vec<Vector>,
    /// Residual, preconditioned residual, search direction, `A p`.
    r: Vec<Vector>,
    z: Vec<Vector>,
    p: Vec<Vector>,
    ap: Vec<Vector>,
    /// Per-chunk partial dot products.
    partials: Vec<f64>,
}

impl Cg {
    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        let v = std::mem::size_of::<Vector>();
        self.inv_diag.capacity() * 6 * std::mem::size_of::<Real>()
            + (self.b.capacity()
                + self.r.capacity()
                + self.z.capacity()
                + self.p.capacity()
                + self.ap.capacity())
                * v
            + self.partials.capacity() * 8
    }
}

/// The constants of one solve.
#[derive(Copy, Clone)]
pub(crate) struct Implicit {
    /// Dynamic viscosity `μ` (Pa·s).
    pub viscosity: Real,
    /// The substep (s).
    pub dt: Real,
    /// Tolerance and iteration cap.
    pub settings: ImplicitViscosity,
}

/// Solves `A v = v*` (see the module docs) for the fluid's `velocities` in place, warm
/// started from and updating the attributes [`WARM`].
pub(crate) fn solve<S: Separation>(
    c: Implicit,
    pairs: &Pairs<'_, S>,
    inv_densities: &[Real],
    attributes: &mut Attributes,
    velocities: &mut [Vector],
    scratch: &mut Scratch,
) -> SolveStats {
    let n = velocities.len();
    if n == 0 {
        return SolveStats::default();
    }
    let coef = 10.0 * c.dt * c.viscosity * pairs.mass;
    build_pairs(pairs, inv_densities, coef, scratch);
    build_preconditioner(pairs.neighbors, scratch);
    let lists = pairs.neighbors;
    let Scratch { pairs: g, cg, .. } = scratch;
    warm_started(attributes, &WARM, velocities, cg, |x, cg| {
        conjugate_gradient(c.settings, x, cg, |v, av| apply(lists, g, v, av))
    })
}

/// Runs `solve` (`A x = v*` from the `x` given, `v*` in `cg.b`) on `velocities`, started
/// from `v*` plus the velocity change of the last solve (the attributes `names`, per axis)
/// and storing this solve's change there. A solve whose residual is not finite (a viscosity
/// so large that the pair weights overflow `f32`, 10^30 Pa·s) is dropped for this substep
/// rather than spreading the overflow.
pub(crate) fn warm_started(
    attributes: &mut Attributes,
    names: &[&str; 3],
    velocities: &mut [Vector],
    cg: &mut Cg,
    solve: impl FnOnce(&mut [Vector], &mut Cg) -> SolveStats,
) -> SolveStats {
    let n = velocities.len();
    let k = [0, 1, 2].map(|a| attributes.ensure(names[a], n));
    let mut warm = k.map(|k| std::mem::take(attributes.vec_mut(k)));
    cg.b.clear();
    cg.b.extend_from_slice(velocities);
    for (i, v) in velocities.iter_mut().enumerate() {
        *v += Vector::new(warm[0][i], warm[1][i], warm[2][i]);
    }
    let stats = solve(velocities, cg);
    if !stats.residual.is_finite() {
        velocities.copy_from_slice(&cg.b);
    }
    for (i, (v, b)) in velocities.iter().zip(&cg.b).enumerate() {
        let d = *v - *b;
        (warm[0][i], warm[1][i], warm[2][i]) = (d.x, d.y, d.z);
    }
    for (a, k) in k.into_iter().enumerate() {
        *attributes.vec_mut(k) = std::mem::take(&mut warm[a]);
    }
    stats
}

/// Preconditioned conjugate gradient on `A x = b` from the `x` given (Saad 2003, Alg. 9.1),
/// `b` and the preconditioner in `s`, `apply(v, out)` the product `out = A v`.
pub(crate) fn conjugate_gradient(
    settings: ImplicitViscosity,
    x: &mut [Vector],
    s: &mut Cg,
    mut apply: impl FnMut(&[Vector], &mut [Vector]),
) -> SolveStats {
    let n = x.len();
    for v in [&mut s.r, &mut s.z, &mut s.p, &mut s.ap] {
        v.resize(n, Vector::ZERO);
    }
    let bb = dot(&s.b, &s.b, &mut s.partials);
    let target = (settings.tolerance as f64).powi(2) * bb;
    apply(x, &mut s.ap);
    for ((r, b), ap) in s.r.iter_mut().zip(&s.b).zip(&s.ap) {
        *r = *b - *ap;
    }
    let mut rr = dot(&s.r, &s.r, &mut s.partials);
    let mut stats = SolveStats::default();
    if rr > target {
        precondition(&s.inv_diag, &s.r, &mut s.z);
        s.p.copy_from_slice(&s.z);
        let mut rz = dot(&s.r, &s.z, &mut s.partials);
        while stats.iterations < settings.max_iterations as usize {
            apply(&s.p, &mut s.ap);
            let pap = dot(&s.p, &s.ap, &mut s.partials);
            // A is positive definite: a non-positive or non-finite curvature is round-off
            // on a converged solve (or a non-finite input): stop where we are.
            if !(pap > 0.0 && pap.is_finite()) {
                break;
            }
            let alpha = (rz / pap) as Real;
            axpy(alpha, &s.p, x);
            axpy(-alpha, &s.ap, &mut s.r);
            stats.iterations += 1;
            rr = dot(&s.r, &s.r, &mut s.partials);
            if rr <= target {
                break;
            }
            precondition(&s.inv_diag, &s.r, &mut s.z);
            let rz_next = dot(&s.r, &s.z, &mut s.partials);
            let beta = (rz_next / rz) as Real;
            rz = rz_next;
            for (p, z) in s.p.iter_mut().zip(&s.z) {
                *p = *z + *p * beta;
            }
        }
    }
    stats.residual = if bb > 0.0 {
        (rr / bb).sqrt() as Real
    } else if rr.is_finite() {
        0.0
    } else {
        Real::NAN
    };
    stats
}

/// `g_ij` of every listed pair (see the module docs), per chunk of the neighbour lists.
fn build_pairs<S: Separation>(
    pairs: &Pairs<'_, S>,
    inv_densities: &[Real],
    coef: Real,
    s: &mut Scratch,
) {
    let lists = pairs.neighbors;
    let chunks = lists.len().div_ceil(CHUNK);
    s.pairs.resize_with(chunks, Vec::new);
    let kernel = CubicSpline::new(pairs.h);
    let eta2 = 0.01 * pairs.h * pairs.h;
    let (x, sep) = (pairs.positions, &pairs.sep);
    crate::par_chunks_mut!(s.pairs[..chunks], 1)
        .enumerate()
        .for_each(|(c, out)| {
            let out = &mut out[0];
            let (offsets, indices) = lists.chunk(c);
            out.clear();
            let base = c * CHUNK;
            let count = (lists.len() - base).min(CHUNK);
            for k in 0..count {
                let i = base + k;
                let range = offsets[k] as usize..offsets[k + 1] as usize;
                for &j in &indices[range] {
                    let j = j as usize;
                    let d = sep.sep(x[i], x[j]);
                    let r = d.length();
                    let dw = kernel.dw(r);
                    let w = if r > 0.0 && dw < 0.0 {
                        coef * -dw * inv_densities[i] * inv_densities[j] / (r * (r * r + eta2))
                    } else {
                        0.0
                    };
                    out.push(d * w.sqrt());
                }
            }
        });
}

/// The inverses of the preconditioner's blocks `D_i = I + Σ_j g_ij g_ijᵀ`.
fn build_preconditioner(lists: &crate::neighbors::NeighborLists, s: &mut Scratch) {
    let n = lists.len();
    s.cg.inv_diag.resize(n, [0.0; 6]);
    let pairs = &s.pairs;
    crate::par_chunks_mut!(s.cg.inv_diag, CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            let (offsets, _) = lists.chunk(c);
            let g = &pairs[c];
            for (k, inv) in out.iter_mut().enumerate() {
                let mut m = [1.0, 1.0, 1.0, 0.0, 0.0, 0.0];
                for v in &g[offsets[k] as usize..offsets[k + 1] as usize] {
                    m[0] += v.x * v.x;
                    m[1] += v.y * v.y;
                    m[2] += v.z * v.z;
                    m[3] += v.x * v.y;
                    m[4] += v.x * v.z;
                    m[5] += v.y * v.z;
                }
                *inv = inverse_symmetric(m);
            }
        });
}

/// The inverse of a symmetric 3×3 matrix `(xx, yy, zz, xy, xz, yz)` (cofactors over the
/// determinant; the blocks are at least the identity, so it is positive).
pub(crate) fn inverse_symmetric([a, d, f, b, c, e]: [Real; 6]) -> [Real; 6] {
    // [[a b c] [b d e] [c e f]]
    let (ca, cb, cc) = (d * f - e * e, c * e - b * f, b * e - c * d);
    let det = a * ca + b * cb + c * cc;
    let inv = 1.0 / det;
    [
        ca * inv,
        (a * f - c * c) * inv,
        (a * d - b * b) * inv,
        cb * inv,
        cc * inv,
        (b * c - a * e) * inv,
    ]
}

/// `z = D⁻¹ r`, block by block.
pub(crate) fn precondition(inv_diag: &[[Real; 6]], r: &[Vector], z: &mut [Vector]) {
    crate::par_chunks_mut!(z, CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            for (k, z) in out.iter_mut().enumerate() {
                let i = c * CHUNK + k;
                let ([a, d, f, b, cc, e], v) = (inv_diag[i], r[i]);
                *z = Vector::new(
                    a * v.x + b * v.y + cc * v.z,
                    b * v.x + d * v.y + e * v.z,
                    cc * v.x + e * v.y + f * v.z,
                );
            }
        });
}

/// `out = A v`: `v_i + Σ_j g_ij (g_ij · (v_i − v_j))`.
fn apply(
    lists: &crate::neighbors::NeighborLists,
    pairs: &[Vec<Vector>],
    v: &[Vector],
    out: &mut [Vector],
) {
    crate::par_chunks_mut!(out, CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            let (offsets, indices) = lists.chunk(c);
            let g = &pairs[c];
            for (k, o) in out.iter_mut().enumerate() {
                let i = c * CHUNK + k;
                let vi = v[i];
                let mut sum = vi;
                for t in offsets[k] as usize..offsets[k + 1] as usize {
                    let gij = g[t];
                    sum += gij * gij.dot(vi - v[indices[t] as usize]);
                }
                *o = sum;
            }
        });
}

/// `y += a x`.
pub(crate) fn axpy(a: Real, x: &[Vector], y: &mut [Vector]) {
    crate::par_chunks_mut!(y, CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            for (k, y) in out.iter_mut().enumerate() {
                *y += x[c * CHUNK + k] * a;
            }
        });
}

/// `a · b` summed per chunk of [`CHUNK`] particles in `f64`, then over the chunks in order:
/// the same bits on any number of threads.
pub(crate) fn dot(a: &[Vector], b: &[Vector], partials: &mut Vec<f64>) -> f64 {
    partials.resize(a.len().div_ceil(CHUNK), 0.0);
    crate::par_chunks_mut!(partials, 1)
        .enumerate()
        .for_each(|(c, out)| {
            let range = c * CHUNK..((c + 1) * CHUNK).min(a.len());
            out[0] = a[range.clone()]
                .iter()
                .zip(&b[range])
                .map(|(x, y)| x.dot(*y) as f64)
                .fold(0.0, |s, t| s + t);
        });
    partials.iter().fold(0.0, |s, t| s + t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    #[allow(clippy::needless_range_loop)] // a matrix product: the indices read as the formula
    fn symmetric_inverse_inverts() {
        let m = [2.0, 3.0, 4.0, 0.5, -0.25, 0.75];
        let inv = inverse_symmetric(m);
        let full = |m: [Real; 6]| [[m[0], m[3], m[4]], [m[3], m[1], m[5]], [m[4], m[5], m[2]]];
        let (a, b) = (full(m), full(inv));
        for i in 0..3 {
            for j in 0..3 {
                let p: Real = (0..3).map(|k| a[i][k] * b[k][j]).sum();
                let id = if i == j { 1.0 } else { 0.0 };
                assert!((p - id).abs() < 1e-6, "{i}{j}: {p}");
            }
        }
    }
}
