//! Müller et al. (2003) viscosity, eq. 14 (the Unity paper's eq. 17–18):
//! `f_i = ε Σ_j m (v_j − v_i)/ρ_j ∇²W_visc(|x_i − x_j|)`, acceleration `a_i = f_i/ρ_i`,
//! with `∇²W_visc = 45/(πh⁶)(h − d)`.
//!
//! Pair terms are antisymmetric, so linear momentum is conserved; the Laplacian is positive,
//! so the force only damps relative motion.
//!
//! **The explicit limit, and what holds beyond it.** Over a substep `dt` the term is the
//! update `v_i' = v_i + Σ_j c_ij (v_j − v_i)`, `c_ij = dt·ε·m·∇²W_ij/(ρ_i ρ_j)`, symmetric in
//! `i, j`. Call `S_i = Σ_j c_ij` its row sum. The update is `v' = (I − L)v` with `L` the graph
//! Laplacian of the weights `c`, whose eigenvalues lie in `[0, 2·max S]` (Gershgorin): with
//! every `S_i ≤ 1/2` ([`MAX_EXCHANGE`]) they lie in `[0, 1]`, so every mode of relative motion
//! decays without reversing, the kinetic energy never grows, and each `v_i'` is a convex
//! combination of `v_i` and its neighbours' velocities (no speed grows). In a lattice at rest
//! density `S ≈ dt·ε/ρ0 · ∫∇²W dV = 15·dt·ε/(ρ0 h²)` (`∫ 4πr² 45/(πh⁶)(h − r) dr = 15/h²`),
//! so the bound is `dt ≤ ρ0 h²/(30 ε)`: the viscous limit of the adaptive time step
//! (`pipeline::time_stepping`). Beyond it (the substep cap binds: 10⁴ Pa·s at 5 cm spacing
//! asks for 500 substeps of a 1/60 s frame; or a particle with almost no neighbours, whose
//! `1/ρ` is large, as Clavet's densities, which do not count the particle itself, give at a
//! pair's support edge) the explicit update overshoots: relative velocities reverse and grow
//! each substep (at 10⁴–10⁶ Pa·s 86–94 % of the particles were quarantined, some 10²⁹ m away;
//! Clavet lost up to 118 of 512 particles to NaN at 20–50 m/s). There every pair's
//! coefficient is scaled by `1/max(1, 2S_i, 2S_j)` (symmetric, so momentum stays exact), which
//! brings every row sum back to at most 1/2: viscosity then brings two particles at most half
//! way to their common velocity in one substep, whatever its setting. [`add_accelerations`]
//! returns how many particles it limited (reported as
//! [`crate::StepReport::viscosity_limited`]); below the bound it costs one addition per pair
//! and changes nothing.

use crate::domain::Separation;
use crate::kernel::ViscosityLaplacian;
use crate::math::{Real, Vector};
use crate::neighbors::Pairs;
use crate::par::{LANES, lane_sum};
#[cfg(feature = "parallel")]
use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering};

/// Largest row sum `S_i` of the explicit viscous exchange over one substep (see the module
/// docs): 1/2, the bound under which no relative velocity reverses.
pub const MAX_EXCHANGE: Real = 0.5;

/// The largest of non-negative reals written from several threads (exact: the maximum does
/// not depend on the order, so results stay the same across thread counts). The bits of
/// non-negative `f32`s order as the numbers do.
#[derive(Default)]
pub(crate) struct AtomicMax(AtomicU32);

impl AtomicMax {
    /// Raises the maximum to `x` (a NaN counts as above every number).
    pub fn raise(&self, x: Real) {
        let bits = if x.is_nan() {
            u32::MAX
        } else {
            x.max(0.0).to_bits()
        };
        self.0.fetch_max(bits, Ordering::Relaxed);
    }

    /// Whether the maximum exceeds `bound`.
    pub fn exceeds(&self, bound: Real) -> bool {
        self.0.load(Ordering::Relaxed) > bound.to_bits()
    }
}

/// Adds the viscous acceleration of viscosity `viscosity` (ε) over a substep `dt` to
/// `accelerations`, limited where the explicit update would overshoot (see the module
/// docs). Returns how many particles were limited.
pub fn add_accelerations<S: Separation>(
    pairs: &Pairs<'_, S>,
    velocities: &[Vector],
    inv_densities: &[Real],
    (viscosity, dt): (Real, Real),
    accelerations: &mut [Vector],
) -> usize {
    let lap = ViscosityLaplacian::new(pairs.h);
    let em = viscosity * pairs.mass;
    let largest = AtomicMax::default();
    crate::par_chunks_mut!(accelerations, crate::par::CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            let most = crate::par::wide(
                #[inline(always)]
                || {
                    let base = c * crate::par::CHUNK;
                    let mut most: Real = 0.0;
                    for (k, a) in out.iter_mut().enumerate() {
                        let i = base + k;
                        let (f, w) = pair_sum(pairs, &lap, velocities, inv_densities, i);
                        *a += f * (em * inv_densities[i]);
                        most = most.max(w * inv_densities[i]);
                    }
                    most
                },
            );
            largest.raise(most * em * dt);
        });
    if !largest.exceeds(MAX_EXCHANGE) {
        return 0;
    }
    limit_by_distance(pairs, (velocities, inv_densities), (em, dt), accelerations)
}

/// [`limit`] with the Laplacian weights of the pairs' distances: what
/// [`add_accelerations`] runs when some row sum exceeds [`MAX_EXCHANGE`] (`em = ε·m`).
/// Returns the particles limited.
pub(crate) fn limit_by_distance<S: Separation>(
    pairs: &Pairs<'_, S>,
    (velocities, inv_densities): (&[Vector], &[Real]),
    (em, dt): (Real, Real),
    accelerations: &mut [Vector],
) -> usize {
    let lap = ViscosityLaplacian::new(pairs.h);
    let weights = DistanceWeights { pairs, lap };
    limit(
        &weights,
        (velocities, inv_densities),
        em * dt,
        em,
        accelerations,
    )
}

/// The Laplacian weights `∇²W_ij` of every pair of a particle.
pub(crate) trait PairWeights: Sync {
    /// Calls `f(j, ∇²W_ij)` for each neighbour `j` of `i`.
    fn each(&self, i: usize, f: impl FnMut(usize, Real));
}

/// Weights from the distances.
struct DistanceWeights<'a, S> {
    pairs: &'a Pairs<'a, S>,
    lap: ViscosityLaplacian,
}

impl<S: Separation> PairWeights for DistanceWeights<'_, S> {
    fn each(&self, i: usize, mut f: impl FnMut(usize, Real)) {
        let (x, sep) = (self.pairs.positions, &self.pairs.sep);
        for &j in self.pairs.neighbors.of(i) {
            let j = j as usize;
            f(j, self.lap.laplacian(sep.sep(x[i], x[j]).length()));
        }
    }
}

/// The limited exchange (see the module docs): with the row sums `S_i = coef·Σ_j ∇²W_ij/(ρ_i
/// ρ_j)` (`coef = dt·ε·m`), adds to each acceleration what scaling its pairs by `1/max(1,
/// 2S_i, 2S_j)` changes in the term [`add_accelerations`] added. Returns the particles whose
/// row sum exceeded [`MAX_EXCHANGE`]. Runs only beyond the bound (allocates its row sums).
pub(crate) fn limit<W: PairWeights>(
    weights: &W,
    (velocities, inv_densities): (&[Vector], &[Real]),
    coef: Real,
    em: Real,
    accelerations: &mut [Vector],
) -> usize {
    let mut rows = vec![0.0 as Real; velocities.len()];
    crate::par_chunks_mut!(rows, crate::par::CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            for (k, s) in out.iter_mut().enumerate() {
                let i = c * crate::par::CHUNK + k;
                let mut sum = 0.0;
                weights.each(i, |j, l| sum += l * inv_densities[j]);
                *s = coef * inv_densities[i] * sum;
            }
        });
    let rows = &rows[..];
    crate::par_chunks_mut!(accelerations, crate::par::CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            for (k, a) in out.iter_mut().enumerate() {
                let i = c * crate::par::CHUNK + k;
                let (si, vi) = (rows[i], velocities[i]);
                let mut f = Vector::ZERO;
                weights.each(i, |j, l| {
                    let m = (2.0 * si.max(rows[j])).max(1.0);
                    if m > 1.0 {
                        f += (velocities[j] - vi) * (l * inv_densities[j] * (1.0 / m - 1.0));
                    }
                });
                *a += f * (em * inv_densities[i]);
            }
        });
    rows.iter().filter(|s| !(**s <= MAX_EXCHANGE)).count()
}

/// `Σ_j (v_j − v_i)/ρ_j ∇²W_visc(|x_i − x_j|)` over the neighbours of particle `i`, and the sum
/// of the weights `Σ_j ∇²W_visc/ρ_j`: [`LANES`] neighbours at a time in lane arrays (packed
/// sqrt and Laplacian), then the rest one by one.
#[inline(always)]
fn pair_sum<S: Separation>(
    pairs: &Pairs<'_, S>,
    lap: &ViscosityLaplacian,
    velocities: &[Vector],
    inv_densities: &[Real],
    i: usize,
) -> (Vector, Real) {
    let (positions, sep) = (pairs.positions, &pairs.sep);
    let xi = positions[i];
    let vi = velocities[i];
    let (mut fx, mut fy, mut fz) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
    let mut w = [0.0; LANES];
    let mut blocks = pairs.neighbors.of(i).chunks_exact(LANES);
    for block in &mut blocks {
        let (mut dvx, mut dvy, mut dvz) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
        let (mut d, mut inv) = ([0.0; LANES], [0.0; LANES]);
        // Gathers only; the arithmetic follows in uniform loops that vectorise.
        for l in 0..LANES {
            let j = block[l] as usize;
            d[l] = sep.sep(xi, positions[j]).length_squared();
            let dv = velocities[j] - vi;
            (dvx[l], dvy[l], dvz[l]) = (dv.x, dv.y, dv.z);
            inv[l] = inv_densities[j];
        }
        for l in 0..LANES {
            d[l] = lap.laplacian(d[l].sqrt()) * inv[l];
        }
        for l in 0..LANES {
            w[l] += d[l];
            fx[l] += dvx[l] * d[l];
            fy[l] += dvy[l] * d[l];
            fz[l] += dvz[l] * d[l];
        }
    }
    let mut f = Vector::new(lane_sum(fx), lane_sum(fy), lane_sum(fz));
    let mut weight = lane_sum(w);
    for &j in blocks.remainder() {
        let ju = j as usize;
        let d = sep.sep(xi, positions[ju]).length();
        let l = lap.laplacian(d) * inv_densities[ju];
        f += (velocities[ju] - vi) * l;
        weight += l;
    }
    (f, weight)
}
