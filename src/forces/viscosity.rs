//! Müller et al. (2003) viscosity, eq. 14 (the Unity paper's eq. 17–18):
//! `f_i = ε Σ_j m (v_j − v_i)/ρ_j ∇²W_visc(|x_i − x_j|)`, acceleration `a_i = f_i/ρ_i`,
//! with `∇²W_visc = 45/(πh⁶)(h − d)`.
//!
//! Pair terms are antisymmetric, so linear momentum is conserved; the Laplacian is positive,
//! so the force only damps relative motion.

use crate::kernel::ViscosityLaplacian;
use crate::math::{Real, Vector};
use crate::neighbors::NeighborLists;
use crate::par::CHUNK;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Adds the viscous acceleration to `accelerations`.
#[allow(clippy::too_many_arguments)]
pub fn add_accelerations(
    positions: &[Vector],
    velocities: &[Vector],
    inv_densities: &[Real],
    neighbors: &NeighborLists,
    mass: Real,
    viscosity: Real,
    h: Real,
    accelerations: &mut [Vector],
) {
    let lap = ViscosityLaplacian::new(h);
    let em = viscosity * mass;
    crate::par_chunks_mut!(accelerations, CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            let base = c * CHUNK;
            for (k, a) in out.iter_mut().enumerate() {
                let i = base + k;
                let xi = positions[i];
                let vi = velocities[i];
                let mut f = Vector::ZERO;
                for &j in neighbors.of(i) {
                    let ju = j as usize;
                    let d = (xi - positions[ju]).length();
                    f += (velocities[ju] - vi) * (lap.laplacian(d) * inv_densities[ju]);
                }
                *a += f * (em * inv_densities[i]);
            }
        });
}
