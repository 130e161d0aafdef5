//! Müller et al. (2003) viscosity, eq. 14 (the Unity paper's eq. 17–18):
//! `f_i = ε Σ_j m (v_j − v_i)/ρ_j ∇²W_visc(|x_i − x_j|)`, acceleration `a_i = f_i/ρ_i`,
//! with `∇²W_visc = 45/(πh⁶)(h − d)`.
//!
//! Pair terms are antisymmetric, so linear momentum is conserved; the Laplacian is positive,
//! so the force only damps relative motion.

use crate::domain::Separation;
use crate::kernel::ViscosityLaplacian;
use crate::math::{Real, Vector};
use crate::neighbors::Pairs;
use crate::par::{LANES, lane_sum};
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Adds the viscous acceleration of viscosity `viscosity` (ε) to `accelerations`.
pub fn add_accelerations<S: Separation>(
    pairs: &Pairs<'_, S>,
    velocities: &[Vector],
    inv_densities: &[Real],
    viscosity: Real,
    accelerations: &mut [Vector],
) {
    let lap = ViscosityLaplacian::new(pairs.h);
    let em = viscosity * pairs.mass;
    crate::par_chunks_mut!(accelerations, crate::par::CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            crate::par::wide(
                #[inline(always)]
                || {
                    let base = c * crate::par::CHUNK;
                    for (k, a) in out.iter_mut().enumerate() {
                        let i = base + k;
                        let f = pair_sum(pairs, &lap, velocities, inv_densities, i);
                        *a += f * (em * inv_densities[i]);
                    }
                },
            );
        });
}

/// `Σ_j (v_j − v_i)/ρ_j ∇²W_visc(|x_i − x_j|)` over the neighbours of particle `i`: [`LANES`]
/// neighbours at a time in lane arrays (packed sqrt and Laplacian), then the rest one by one.
#[inline(always)]
fn pair_sum<S: Separation>(
    pairs: &Pairs<'_, S>,
    lap: &ViscosityLaplacian,
    velocities: &[Vector],
    inv_densities: &[Real],
    i: usize,
) -> Vector {
    let (positions, sep) = (pairs.positions, &pairs.sep);
    let xi = positions[i];
    let vi = velocities[i];
    let (mut fx, mut fy, mut fz) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
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
            fx[l] += dvx[l] * d[l];
            fy[l] += dvy[l] * d[l];
            fz[l] += dvz[l] * d[l];
        }
    }
    let mut f = Vector::new(lane_sum(fx), lane_sum(fy), lane_sum(fz));
    for &j in blocks.remainder() {
        let ju = j as usize;
        let d = sep.sep(xi, positions[ju]).length();
        f += (velocities[ju] - vi) * (lap.laplacian(d) * inv_densities[ju]);
    }
    f
}
