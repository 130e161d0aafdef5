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
/// `sep` (see [`crate::domain`]).
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
    crate::par_chunks_mut!(densities, CHUNK)
        .zip(crate::par_chunks_mut!(inv_densities, CHUNK))
        .enumerate()
        .for_each(|(c, (out, inv_out))| {
            crate::par::wide(
                #[inline(always)]
                || {
                    let base = c * CHUNK;
                    for (k, (rho, inv)) in out.iter_mut().zip(inv_out.iter_mut()).enumerate() {
                        let i = base + k;
                        let xi = positions[i];
                        let nb = neighbors.of(i);
                        // LANES neighbours per iteration, each stage a loop over plain lane arrays:
                        // LLVM turns the square roots and kernel polynomials into packed SIMD.
                        let mut acc = [0.0; LANES];
                        let mut blocks = nb.chunks_exact(LANES);
                        for block in &mut blocks {
                            let mut d = [0.0; LANES];
                            for l in 0..LANES {
                                d[l] = sep.sep(xi, positions[block[l] as usize]).length_squared();
                            }
                            for l in 0..LANES {
                                acc[l] += kernel.w(d[l].sqrt());
                            }
                        }
                        let mut sum = lane_sum(acc);
                        for &j in blocks.remainder() {
                            sum += kernel.w(sep.sep(xi, positions[j as usize]).length());
                        }
                        *rho = self_term + mass * sum + wall.map_or(0.0, |w| w[i]);
                        *inv = 1.0 / *rho;
                    }
                },
            );
        });
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
