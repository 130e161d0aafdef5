//! The symmetric pressure force of Müller et al. (2003), eq. 10 (the Unity paper's eq. 13):
//! `f_i = −Σ_j m (p_i + p_j)/(2ρ_j) ∇W(x_i − x_j)`, acceleration `a_i = f_i/ρ_i`.
//!
//! The pair terms are antisymmetric (`m·a_i` from `j` is minus `m·a_j` from `i`), so the pressure
//! force conserves linear momentum exactly up to round-off.

use crate::kernel::Kernel;
use crate::math::{Real, Vector};
use crate::neighbors::NeighborLists;
use crate::par::CHUNK;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Overwrites `accelerations[i]` with the pressure acceleration of particle `i`.
pub fn pressure_accelerations<K: Kernel>(
    positions: &[Vector],
    inv_densities: &[Real],
    pressures: &[Real],
    neighbors: &NeighborLists,
    mass: Real,
    h: Real,
    accelerations: &mut [Vector],
) {
    let kernel = K::new(h);
    let half_m = 0.5 * mass;
    crate::par_chunks_mut!(accelerations, CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            let base = c * CHUNK;
            for (k, a) in out.iter_mut().enumerate() {
                let i = base + k;
                let xi = positions[i];
                let pi = pressures[i];
                let mut f = Vector::ZERO;
                for &j in neighbors.of(i) {
                    let ju = j as usize;
                    let r = xi - positions[ju];
                    let d = r.length();
                    let grad = kernel.gradient(r, d, i as u32, j);
                    f -= grad * ((pi + pressures[ju]) * inv_densities[ju]);
                }
                *a = f * (half_m * inv_densities[i]);
            }
        });
}
