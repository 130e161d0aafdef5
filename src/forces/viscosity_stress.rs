//! An implicit viscosity solve on the viscous stress (`crate::ViscositySolve::Stress`), the
//! formulation of Takahashi, Dobashi, Fujishiro, Nishita & Lin (2015), "Implicit Formulation
//! for SPH-based Viscous Fluids" (Computer Graphics Forum 34(2), 493–502), solved matrix-free
//! by conjugate gradient with the product taken in two passes over the one-ring neighbours
//! (as SPlisHSPlasH's `Viscosity_Takahashi2015` does, instead of the paper's two-ring matrix).
//!
//! **The model.** The viscous acceleration is the SPH divergence of the stress `σ = 2μ D`,
//! `D = sym(∇v)`, in the symmetric (momentum-conserving) form
//!
//! `a_i = Σ_j m (σ_i/ρ_i² + σ_j/ρ_j²) ∇W_ij`,  `∇v_i = (m/ρ_i) Σ_j (v_j − v_i) ⊗ ∇W_ij`,
//!
//! cubic spline `∇W_ij = W'(r) x_ij/r`, `x_ij = x_i − x_j`, all particles of the same mass
//! `m`. A particle's stress is its own, so across a free surface the stress drops to zero
//! (nothing outside carries one) and the surface layer feels the traction `σ·n`, where Weiler
//! et al.'s operator (`forces::viscosity_implicit`) sums central pair forces. Integrated
//! implicitly over the substep, `v − dt L v = v*` (`v*` the velocities the solver left, `L`
//! the linear map `v ↦ a` above).
//!
//! **Why conjugate gradient holds.** With `⟨u, w⟩ = Σ_i u_i·w_i` and equal masses,
//! `⟨L u, w⟩ = −2μ Σ_i (m/ρ_i) D_i(u) : D_i(w)` (the divergence's symmetric form is minus the
//! adjoint of the gradient's difference form: swap `i` and `j` in the `σ_j` term, `∇W_ji =
//! −∇W_ij`), so `A = I − dt L` is symmetric with every eigenvalue at least 1: the solve
//! exists at any `dt μ`, never raises the kinetic energy and keeps the momentum (the pair
//! terms are antisymmetric). It does not damp every mode: a velocity field whose SPH gradient
//! vanishes at every particle (the stencil's zero-energy modes) is left as it is, and a rigid
//! rotation is damped where the gradient's quadrature is not isotropic (near a surface).
//!
//! **The solve.** `A v` in two passes: per particle the stress over its density squared
//! (`2μ m/ρ_i³ sym Σ_j (v_j − v_i) ⊗ ∇W_ij`, six numbers), then per particle the divergence.
//! Preconditioner: the exact 3×3 diagonal blocks of `A`,
//!
//! `A_ii = I + dt μ m² [ (|c_i|² I + c_i c_iᵀ)/ρ_i³ + Σ_j (|∇W_ij|² I + ∇W_ij ∇W_ijᵀ)/ρ_j³ ]`,
//!
//! `c_i = Σ_j ∇W_ij` (zero in a full neighbourhood, the surface's normal otherwise). Warm
//! start, stopping rule, iteration cap and the fixed-order dot products (the same bits on any
//! number of threads) are those of the Laplacian solve; the warm start is kept under its own
//! attribute names ([`WARM`]).

use crate::domain::Separation;
use crate::fluid::Attributes;
use crate::forces::viscosity_implicit::{
    Cg, Implicit, SolveStats, conjugate_gradient, inverse_symmetric, warm_started,
};
use crate::kernel::{CubicSpline, Kernel};
use crate::math::{Real, Vector};
use crate::neighbors::{NeighborLists, Pairs};
use crate::par::CHUNK;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Names of the warm-start attributes: the velocity change of the last solve, per axis.
pub(crate) const WARM: [&str; 3] = [
    "viscosity.stress.dvx",
    "viscosity.stress.dvy",
    "viscosity.stress.dvz",
];

/// The solve's buffers (held inside the Laplacian solve's scratch, in the fluid's workspace).
#[derive(Clone, Debug, Default)]
pub(crate) struct Scratch {
    /// `∇W_ij` of every listed pair, per chunk, in the order of the chunk's neighbour lists.
    grads: Vec<Vec<Vector>>,
    /// Per particle `dt·σ_i/ρ_i²` of the vector the product is taken of (xx, yy, zz, xy, xz, yz).
    stress: Vec<[Real; 6]>,
    /// The conjugate gradient's vectors and preconditioner.
    cg: Cg,
}

impl Scratch {
    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        let v = std::mem::size_of::<Vector>();
        let six = 6 * std::mem::size_of::<Real>();
        self.grads.iter().map(|c| c.capacity() * v).sum::<usize>()
            + self.stress.capacity() * six
            + self.cg.heap_bytes()
    }
}

/// The operator's data: `2 dt μ m` for the stress pass, `m` for the divergence pass.
#[derive(Copy, Clone)]
struct Operator<'a> {
    lists: &'a NeighborLists,
    inv_densities: &'a [Real],
    stress_coef: Real,
    mass: Real,
}

/// Solves `(I − dt L) v = v*` (see the module docs) for the fluid's `velocities` in place,
/// warm started from and updating the attributes [`WARM`].
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
    build_gradients(pairs, scratch);
    let diag = c.dt * c.viscosity * pairs.mass * pairs.mass;
    build_preconditioner(pairs.neighbors, inv_densities, diag, scratch);
    let op = Operator {
        lists: pairs.neighbors,
        inv_densities,
        stress_coef: 2.0 * c.dt * c.viscosity * pairs.mass,
        mass: pairs.mass,
    };
    let Scratch { grads, stress, cg } = scratch;
    stress.resize(n, [0.0; 6]);
    warm_started(attributes, &WARM, velocities, cg, |x, cg| {
        conjugate_gradient(c.settings, x, cg, |v, av| apply(op, grads, v, stress, av))
    })
}

/// `∇W_ij` of every listed pair (zero for the particle itself), per chunk.
fn build_gradients<S: Separation>(pairs: &Pairs<'_, S>, s: &mut Scratch) {
    let lists = pairs.neighbors;
    let chunks = lists.len().div_ceil(CHUNK);
    s.grads.resize_with(chunks, Vec::new);
    let kernel = CubicSpline::new(pairs.h);
    let (x, sep) = (pairs.positions, &pairs.sep);
    crate::par_chunks_mut!(s.grads[..chunks], 1)
        .enumerate()
        .for_each(|(c, out)| {
            let out = &mut out[0];
            let (offsets, indices) = lists.chunk(c);
            out.clear();
            let base = c * CHUNK;
            for k in 0..(lists.len() - base).min(CHUNK) {
                let i = base + k;
                for &j in &indices[offsets[k] as usize..offsets[k + 1] as usize] {
                    let d = sep.sep(x[i], x[j as usize]);
                    let r = d.length();
                    let g = if r > 0.0 {
                        d * (kernel.dw(r) / r)
                    } else {
                        Vector::ZERO
                    };
                    out.push(g);
                }
            }
        });
}

/// The inverses of `A`'s diagonal blocks (module docs), `coef = dt μ m²`.
fn build_preconditioner(lists: &NeighborLists, inv_rho: &[Real], coef: Real, s: &mut Scratch) {
    s.cg.inv_diag.resize(lists.len(), [0.0; 6]);
    let grads = &s.grads;
    crate::par_chunks_mut!(s.cg.inv_diag, CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            let (offsets, indices) = lists.chunk(c);
            let g = &grads[c];
            for (k, inv) in out.iter_mut().enumerate() {
                let i = c * CHUNK + k;
                let mut m = [0.0; 6];
                let mut ci = Vector::ZERO;
                for t in offsets[k] as usize..offsets[k + 1] as usize {
                    let w = inv_rho[indices[t] as usize].powi(3);
                    add_outer(&mut m, g[t], w);
                    ci += g[t];
                }
                add_outer(&mut m, ci, inv_rho[i].powi(3));
                let mut a = m.map(|x| x * coef);
                a[0] += 1.0;
                a[1] += 1.0;
                a[2] += 1.0;
                *inv = inverse_symmetric(a);
            }
        });
}

/// `m += w (|g|² I + g gᵀ)`.
fn add_outer(m: &mut [Real; 6], g: Vector, w: Real) {
    let gg = g.length_squared();
    m[0] += w * (gg + g.x * g.x);
    m[1] += w * (gg + g.y * g.y);
    m[2] += w * (gg + g.z * g.z);
    m[3] += w * g.x * g.y;
    m[4] += w * g.x * g.z;
    m[5] += w * g.y * g.z;
}

/// `out = A v = v − dt L v` (module docs), `stress` the first pass's buffer.
fn apply(
    op: Operator<'_>,
    grads: &[Vec<Vector>],
    v: &[Vector],
    stress: &mut [[Real; 6]],
    out: &mut [Vector],
) {
    crate::par_chunks_mut!(stress, CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            let (offsets, indices) = op.lists.chunk(c);
            let g = &grads[c];
            for (k, st) in out.iter_mut().enumerate() {
                let i = c * CHUNK + k;
                let vi = v[i];
                // Σ_j (v_j − v_i) ⊗ ∇W_ij, symmetrised.
                let mut e = [0.0; 6];
                for t in offsets[k] as usize..offsets[k + 1] as usize {
                    let (dv, gt) = (v[indices[t] as usize] - vi, g[t]);
                    e[0] += dv.x * gt.x;
                    e[1] += dv.y * gt.y;
                    e[2] += dv.z * gt.z;
                    e[3] += 0.5 * (dv.x * gt.y + dv.y * gt.x);
                    e[4] += 0.5 * (dv.x * gt.z + dv.z * gt.x);
                    e[5] += 0.5 * (dv.y * gt.z + dv.z * gt.y);
                }
                let f = op.stress_coef * op.inv_densities[i].powi(3);
                *st = e.map(|x| x * f);
            }
        });
    let stress = &*stress;
    crate::par_chunks_mut!(out, CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            let (offsets, indices) = op.lists.chunk(c);
            let g = &grads[c];
            for (k, o) in out.iter_mut().enumerate() {
                let i = c * CHUNK + k;
                let si = stress[i];
                let mut acc = Vector::ZERO;
                for t in offsets[k] as usize..offsets[k + 1] as usize {
                    let sj = stress[indices[t] as usize];
                    let s: [Real; 6] = std::array::from_fn(|a| si[a] + sj[a]);
                    let gt = g[t];
                    acc += Vector::new(
                        s[0] * gt.x + s[3] * gt.y + s[4] * gt.z,
                        s[3] * gt.x + s[1] * gt.y + s[5] * gt.z,
                        s[4] * gt.x + s[5] * gt.y + s[2] * gt.z,
                    );
                }
                // `stress` holds dt σ/ρ²: dt L v = m Σ_j (…) ∇W_ij.
                *o = v[i] - acc * op.mass;
            }
        });
}
