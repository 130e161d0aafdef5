//! Stage 2: density by kernel summation (Müller et al. 2003, eq. 3; the Unity paper's eq. 9):
//! `ρ_i = Σ_j m·W(|x_i − x_j|, h)`, the particle itself included.

use crate::domain::Separation;
use crate::kernel::Kernel;
use crate::math::{Real, Vector};
use crate::neighbors::NeighborLists;
use crate::par::{CHUNK, LANES, lane_sum};
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Computes `densities[i]` for every particle, plus `wall[i]` (the walls' density, see
/// [`crate::boundary::wall`]) when given, and `inv_densities[i] = 1/ρ_i` (the force
/// stages multiply by it instead of dividing once per pair). The separations are formed by
/// `sep` (see [`crate::domain`]). With AVX2 in an open domain the neighbour blocks run in
/// explicit 8-lane code (module `avx` below: the same operations per lane, the same bits).
///
/// Kept with 8 arguments: with its inputs in a `neighbors::Pairs` (as the viscosity pass
/// takes them) the density stage measured 101 [100-102], 103 and 105 µs against main's 99
/// [97-101], 100 and 103; in this form 97 [96-99] against 96 [94-99] (`cargo run --release
/// --example stage_medians -- 2500 1500 1`, 6-8 runs alternated with main's build on one
/// core).
#[allow(clippy::too_many_arguments)]
pub fn compute<K: Kernel, S: Separation>(
    positions: &[Vector],
    neighbors: &NeighborLists,
    mass: Real,
    h: Real,
    wall: Option<&[Real]>,
    densities: &mut [Real],
    inv_densities: &mut [Real],
    sep: S,
) {
    let kernel = K::new(h);
    let self_term = mass * kernel.w(0.0);
    let n = positions.len();
    assert!(neighbors.len() == n && wall.is_none_or(|w| w.len() == n));
    let packed = avx::usable::<S>(n);
    crate::par_chunks_mut!(densities, CHUNK)
        .zip(crate::par_chunks_mut!(inv_densities, CHUNK))
        .enumerate()
        .for_each(|(c, (out, inv_out))| {
            if packed {
                // SAFETY: `avx::usable` checked AVX2 at run time, an open domain and the
                // index range; the lists' length is asserted above.
                #[cfg(target_arch = "x86_64")]
                unsafe {
                    avx::chunk(
                        &kernel,
                        (positions, neighbors),
                        c,
                        (out, inv_out),
                        (self_term, mass, wall),
                    )
                }
            } else {
                crate::par::wide(
                    #[inline(always)]
                    || {
                        let base = c * CHUNK;
                        for (k, (rho, inv)) in out.iter_mut().zip(inv_out.iter_mut()).enumerate() {
                            let i = base + k;
                            let sum = kernel_sum(&kernel, (positions, neighbors), i, sep);
                            *rho = self_term + mass * sum + wall.map_or(0.0, |w| w[i]);
                            *inv = 1.0 / *rho;
                        }
                    },
                );
            }
        });
}

/// `Σ_j W(|x_i − x_j|)` over the neighbours of particle `i`: [`LANES`] neighbours per
/// iteration, each stage a loop over plain lane arrays (LLVM turns the square roots and
/// kernel polynomials into packed SIMD), then the rest one by one.
#[inline(always)]
fn kernel_sum<K: Kernel, S: Separation>(
    kernel: &K,
    (positions, neighbors): (&[Vector], &NeighborLists),
    i: usize,
    sep: S,
) -> Real {
    let xi = positions[i];
    let mut acc = [0.0; LANES];
    let mut blocks = neighbors.of(i).chunks_exact(LANES);
    for block in &mut blocks {
        let mut d = [0.0; LANES];
        for l in 0..LANES {
            d[l] = sep.sep(xi, positions[block[l] as usize]).length_squared();
        }
        for l in 0..LANES {
            acc[l] += kernel.w(d[l].sqrt());
        }
    }
    remainder(
        kernel,
        positions,
        (i, blocks.remainder()),
        lane_sum(acc),
        sep,
    )
}

/// Adds the neighbours `rest` (after the full blocks) of particle `i` to its lane sum one
/// by one.
#[inline(always)]
fn remainder<K: Kernel, S: Separation>(
    kernel: &K,
    positions: &[Vector],
    (i, rest): (usize, &[u32]),
    mut sum: Real,
    sep: S,
) -> Real {
    let xi = positions[i];
    for &j in rest {
        sum += kernel.w(sep.sep(xi, positions[j as usize]).length());
    }
    sum
}

/// The density pass with AVX2 (open domains): [`kernel_sum`]'s blocks in 8-lane registers,
/// the neighbours' positions by 4-float loads transposed in registers (as
/// `pressure::fused`); the same operations per lane in the same order, so the same bits.
mod avx {
    use super::*;
    #[cfg(target_arch = "x86_64")]
    use crate::par::avx::{gather_xyz, lanes, load_xyz, padded_block};
    #[cfg(target_arch = "x86_64")]
    use std::arch::x86_64::*;

    /// Whether the AVX2 pass runs: AVX2 detected, an open domain, gather offsets within `i32`.
    pub(super) fn usable<S: Separation>(n: usize) -> bool {
        cfg!(target_arch = "x86_64")
            && !S::PERIODIC
            && crate::par::packed_level() >= 1
            && n.checked_mul(3).is_some_and(|m| m <= i32::MAX as usize)
    }

    /// The densities and their inverses of chunk `c` (see [`super::compute`]).
    ///
    /// # Safety
    /// The CPU must run AVX2, [`usable`] must hold and the lists be built for `positions`.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn chunk<K: Kernel>(
        kernel: &K,
        (positions, neighbors): (&[Vector], &NeighborLists),
        c: usize,
        (out, inv_out): (&mut [Real], &mut [Real]),
        (self_term, mass, wall): (Real, Real, Option<&[Real]>),
    ) {
        let base = c * CHUNK;
        for (k, (rho, inv)) in out.iter_mut().zip(inv_out.iter_mut()).enumerate() {
            let i = base + k;
            // SAFETY: as the caller promised.
            let sum = unsafe { kernel_sum(kernel, (positions, neighbors), i) };
            *rho = self_term + mass * sum + wall.map_or(0.0, |w| w[i]);
            *inv = 1.0 / *rho;
        }
    }

    /// [`super::kernel_sum`] in 8-lane registers.
    ///
    /// # Safety
    /// As [`chunk`].
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn kernel_sum<K: Kernel>(
        kernel: &K,
        (positions, neighbors): (&[Vector], &NeighborLists),
        i: usize,
    ) -> Real {
        let xi = positions[i];
        let (blocks, rest) = neighbors.of(i).as_chunks::<LANES>();
        // SAFETY: AVX2 (the caller's).
        let acc = unsafe {
            let x = (
                _mm256_set1_ps(xi.x),
                _mm256_set1_ps(xi.y),
                _mm256_set1_ps(xi.z),
            );
            let mut acc = _mm256_setzero_ps();
            for block in blocks {
                acc = _mm256_add_ps(acc, block_w(kernel, positions, x, block));
            }
            lanes(acc)
        };
        // SAFETY: as above.
        unsafe { self::rest(kernel, positions, i, rest, lane_sum(acc)) }
    }

    /// [`super::remainder`] with the kernel values formed in lanes: the neighbours `rest`
    /// (fewer than [`LANES`]) of particle `i` padded with `i` to a block, `W(|x_i − x_j|)`
    /// of each with the same operations as that loop, then added to `sum` one by one in
    /// list order, as it adds them (so the same bits; the scalar loop, a square root and a
    /// kernel per pair, took about a third of the pass at 27.8 neighbours).
    ///
    /// # Safety
    /// As [`chunk`].
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn rest<K: Kernel>(
        kernel: &K,
        positions: &[Vector],
        i: usize,
        rest: &[u32],
        mut sum: Real,
    ) -> Real {
        if rest.is_empty() {
            return sum;
        }
        let xi = positions[i];
        // SAFETY: AVX2 (the caller's).
        let w = unsafe {
            let block = padded_block(rest, i as u32);
            let x = (
                _mm256_set1_ps(xi.x),
                _mm256_set1_ps(xi.y),
                _mm256_set1_ps(xi.z),
            );
            lanes(block_w(kernel, positions, x, &block))
        };
        for wl in &w[..rest.len()] {
            sum += wl;
        }
        sum
    }

    /// `W(|x_i − x_j|)` in lanes for the 8 neighbours `block` of a particle at `x` (its
    /// coordinates in every lane): each index checked below the length (a panic
    /// otherwise), the positions by 4-float loads, or by gathers when the block holds the
    /// last particle (whose 4-float load would pass the end).
    ///
    /// # Safety
    /// The CPU must run AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn block_w<K: Kernel>(
        kernel: &K,
        positions: &[Vector],
        (x, y, z): (__m256, __m256, __m256),
        block: &[u32; LANES],
    ) -> __m256 {
        let px = positions.as_ptr() as *const f32;
        let last = _mm256_set1_epi32((positions.len() - 1) as i32);
        // SAFETY: `block` holds 8 indices.
        let idx = unsafe { _mm256_loadu_si256(block.as_ptr() as *const __m256i) };
        let inside = _mm256_cmpeq_epi32(_mm256_max_epu32(idx, last), last);
        assert!(
            _mm256_movemask_epi8(inside) == -1,
            "neighbour index out of range"
        );
        // SAFETY: AVX2 (this function's); every index is below the length (checked above).
        let (qx, qy, qz) = unsafe {
            if _mm256_movemask_epi8(_mm256_cmpeq_epi32(idx, last)) != 0 {
                gather_xyz(px, _mm256_add_epi32(_mm256_add_epi32(idx, idx), idx))
            } else {
                load_xyz(px, block)
            }
        };
        let (rx, ry, rz) = (
            _mm256_sub_ps(x, qx),
            _mm256_sub_ps(y, qy),
            _mm256_sub_ps(z, qz),
        );
        let d2 = _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(rx, rx), _mm256_mul_ps(ry, ry)),
            _mm256_mul_ps(rz, rz),
        );
        // SAFETY: AVX2 (this function's).
        unsafe { kernel.w_avx(_mm256_sqrt_ps(d2)) }
    }
}

/// Largest and mean relative compression `max(ρ − ρ0, 0)/ρ0`, reduced chunk by chunk and then
/// serially so the figure does not depend on the thread count.
///
/// Only compression counts: particles at a free surface or in a splash have fewer
/// neighbours and a kernel-summed density below `ρ0` without being stretched, so counting
/// `|ρ − ρ0|` would report every droplet as a huge error. This is the error incompressible
/// solvers bound (Bender & Koschier 2017; Ihmsen et al. 2014).
pub fn density_error(
    densities: &[Real],
    rest_density: Real,
    partials: &mut Vec<(f64, Real)>,
) -> (Real, Real) {
    if densities.is_empty() {
        return (0.0, 0.0);
    }
    partials.resize(densities.len().div_ceil(CHUNK), (0.0, 0.0));
    let inv = 1.0 / rest_density;
    crate::par_iter_mut!(partials)
        .enumerate()
        .for_each(|(c, out)| {
            let chunk = &densities[c * CHUNK..((c + 1) * CHUNK).min(densities.len())];
            let mut sum = 0.0f64;
            let mut max: Real = 0.0;
            for &rho in chunk {
                let e = ((rho - rest_density) * inv).max(0.0);
                sum += e as f64;
                max = max.max(e);
            }
            *out = (sum, max);
        });
    let sum: f64 = partials.iter().map(|p| p.0).sum();
    let max = partials.iter().map(|p| p.1).fold(0.0, Real::max);
    (max, (sum / densities.len() as f64) as Real)
}
