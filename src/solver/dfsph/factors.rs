//! The density and the DFSPH factor of every particle (eq. 9 with the wall term), in one pass
//! over the pairs, with the pair gradients kept for the solves.

use super::super::pairs::{Block, KernelSums, PairGradients, PairSink, kernel_sums};
use super::{WarmPush, wall_weights};
use crate::boundary::WallWorkspace;
use crate::domain::Separation;
use crate::kernel::{Kernel, ViscosityLaplacian};
use crate::math::{Real, Vector};
use crate::neighbors::{NeighborLists, Pairs};
use crate::par::{CHUNK, LANES};
use rapier3d::glamx::Vec3A;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// What [`density_and_factors`] reads besides the pairs.
pub(crate) struct FactorInput<'a> {
    /// Wall contributions, if any wall is near.
    pub wall: Option<&'a WallWorkspace>,
    /// The viscosity Laplacian, when the fluid is viscous (its pair values are stored).
    pub viscosity: Option<ViscosityLaplacian>,
    /// The divergence solve's warm start, when there is one to apply.
    pub push: Option<WarmPush<'a>>,
}

/// What [`density_and_factors`] writes (indexed like the sorted particles).
pub(crate) struct Factors<'a> {
    /// Densities.
    pub densities: &'a mut [Real],
    /// `1/ρ`.
    pub inv_densities: &'a mut [Real],
    /// DFSPH factors `α`.
    pub alpha: &'a mut [Real],
    /// Kernel gradients (and Laplacians) of every neighbour pair.
    pub grads: &'a mut PairGradients,
    /// The velocities after the warm start's push (16 bytes wide; written only with a push).
    pub pushed: &'a mut [Vec3A],
}

/// Density, `1/ρ` and the DFSPH factor `α` of every particle, the kernel gradients (and,
/// for a viscous fluid, the viscosity Laplacians) of every pair, and the divergence solve's
/// warm start applied to the velocities (`input.push`), in one pass over the neighbours.
pub(crate) fn density_and_factors<K: Kernel, S: Separation>(
    pairs: &Pairs<'_, S>,
    input: &FactorInput<'_>,
    out: Factors<'_>,
) {
    let (positions, neighbors, mass, h) = (pairs.positions, pairs.neighbors, pairs.mass, pairs.h);
    let (wall, viscosity) = (input.wall, input.viscosity);
    let Factors {
        densities,
        inv_densities,
        alpha,
        grads,
        pushed,
    } = out;
    let push = input.push.map(|push| (push, push.pusher(mass, wall)));
    let kernel = K::new(h);
    let self_term = mass * kernel.w(0.0);
    let n = positions.len();
    assert_eq!(pushed.len(), n, "one pushed velocity per particle");
    if let Some(push) = input.push {
        // Every neighbour index is below the lists' particle count (`NeighborLists::len`).
        assert_eq!(
            neighbors.len(),
            push.pi.len(),
            "one pressure value per particle"
        );
    }
    let grad_chunks = grads.chunks_mut(n);
    // Hydrostatic walls: the pairs' weights of the wall's pressure value, once per substep.
    let averaged = wall.is_some_and(|w| w.neighbour_pressure);
    crate::par_chunks_mut!(densities, CHUNK)
        .zip(crate::par_chunks_mut!(inv_densities, CHUNK))
        .zip(crate::par_chunks_mut!(alpha, CHUNK))
        .zip(crate::par_iter_mut!(grad_chunks))
        .zip(crate::par_chunks_mut!(pushed, CHUNK))
        .enumerate()
        .for_each(|(c, ((((dens, inv), alpha), gc), pushed))| {
            crate::par::wide(
                #[inline(always)]
                || {
                    let base = c * CHUNK;
                    let (offsets, indices) = neighbors.chunk(c);
                    let in_chunk = offsets[dens.len()] as usize;
                    gc.grad.resize(in_chunk);
                    gc.laplacian.resize(viscosity.map_or(0, |_| in_chunk), 0.0);
                    gc.wall_weight
                        .resize(if averaged { in_chunk } else { 0 }, 0.0);
                    gc.wall_weight_sum
                        .resize(if averaged { dens.len() } else { 0 }, 0.0);
                    for k in 0..dens.len() {
                        let i = base + k;
                        let (s, e) = (offsets[k] as usize, offsets[k + 1] as usize);
                        let nb = &indices[s..e];
                        let lap_out: &mut [Real] = match viscosity {
                            Some(_) => &mut gc.laplacian[s..e],
                            None => &mut [],
                        };
                        let mut store = StorePairs {
                            grad: gc.grad.range_mut(s, e),
                            lap: lap_out,
                            viscosity,
                        };
                        let KernelSums { w: wsum, g, g2 } =
                            kernel_sums(pairs, &kernel, i, nb, &mut store);
                        let out = gc.grad.range(s, e);
                        let sw = match wall {
                            Some(w) if averaged => {
                                wall_weights(out, w.gradient[i], &mut gc.wall_weight[s..e])
                            }
                            _ => 0.0,
                        };
                        if averaged {
                            gc.wall_weight_sum[k] = sw;
                        }
                        let mut rho = self_term + mass * wsum;
                        let grad = g * mass;
                        // Own pressure's effect on own density: the push Σm∇W + γ∇ρ_wall dotted with the
                        // density gradient Σm∇W + ∇ρ_wall (γ = `wall.mirror`).
                        let mut denom = grad.length_squared() + mass * mass * g2;
                        if let Some(wall) = wall {
                            rho += wall.density[i];
                            let gw = wall.gradient[i];
                            denom = (grad + gw * wall.mirror).dot(grad + gw) + mass * mass * g2;
                        }
                        if let Some((push, pusher)) = &push {
                            let v = Vec3A::from(push.velocities[i]);
                            let weights = (&gc.wall_weight[..], sw);
                            let weights = match averaged {
                                true => (&weights.0[s..e], sw),
                                false => (&[][..], 0.0),
                            };
                            // SAFETY: a list of `neighbors`, built for `push.pi.len()`
                            // particles (asserted above).
                            pushed[k] = v - unsafe { pusher.push((nb, out), weights, push.pi, i) };
                        }
                        dens[k] = rho;
                        inv[k] = 1.0 / rho;
                        // An isolated particle has no neighbour to push: no pressure.
                        alpha[k] = if denom > 1e-12 * rho * rho / (h * h) {
                            1.0 / denom
                        } else {
                            0.0
                        };
                    }
                },
            );
        });
}

/// Interacting fluids (`crate::fluid::interaction`): the factors `α` of
/// [`density_and_factors`] again, with each push weighted by its particle's ratio `r`
/// (`m_ref/m`): `1/α_i = r_i·(Σm∇W + γ∇ρ_wall)·(Σm∇W + ∇ρ_wall) + m²·Σ_j r_j|∇W_ij|²`, from
/// the pair gradients the pass stored. A light neighbour moves `r_j` times more under the
/// same pressure; leaving that out of the diagonal overshoots the heavy particles next to
/// it (with water under a liquid ten times lighter the bottom pressure swung by ±50 %).
pub(crate) fn phase_factors(
    (neighbors, grads): (&NeighborLists, &PairGradients),
    (mass, h): (Real, Real),
    (wall, ratio): (Option<&WallWorkspace>, &[Real]),
    densities: &[Real],
    alpha: &mut [Real],
) {
    crate::par_chunks_mut!(alpha, CHUNK)
        .enumerate()
        .for_each(|(c, alpha)| {
            let (offsets, indices) = neighbors.chunk(c);
            let gc = &grads.chunk(c).grad;
            for (k, a) in alpha.iter_mut().enumerate() {
                let i = c * CHUNK + k;
                let (s, e) = (offsets[k] as usize, offsets[k + 1] as usize);
                let (mut g, mut g2r) = (Vec3A::ZERO, 0.0);
                let grads = gc.range(s, e);
                for (t, &j) in indices[s..e].iter().enumerate() {
                    let gij = grads.at(t);
                    g += gij;
                    g2r += ratio[j as usize] * gij.length_squared();
                }
                let grad = Vector::from(g) * mass;
                let own = match wall {
                    Some(w) => (grad + w.gradient[i] * w.mirror).dot(grad + w.gradient[i]),
                    None => grad.length_squared(),
                };
                let denom = ratio[i] * own + mass * mass * g2r;
                let rho = densities[i];
                *a = if denom > 1e-12 * rho * rho / (h * h) {
                    1.0 / denom
                } else {
                    0.0
                };
            }
        });
}

/// The density pass's pair values of one particle: gradients (packed `x, y, z`, see
/// [`PackedGradients`](super::super::pairs::PackedGradients)) and, for a viscous fluid, the
/// viscosity Laplacians.
struct StorePairs<'a> {
    grad: &'a mut [Real],
    lap: &'a mut [Real],
    viscosity: Option<ViscosityLaplacian>,
}

impl PairSink for StorePairs<'_> {
    #[inline(always)]
    fn block(&mut self, o: usize, b: &Block) {
        let out: &mut [Real; 3 * LANES] =
            (&mut self.grad[3 * o..3 * (o + LANES)]).try_into().unwrap();
        for l in 0..LANES {
            out[3 * l] = b.gx[l];
            out[3 * l + 1] = b.gy[l];
            out[3 * l + 2] = b.gz[l];
        }
        if let Some(l) = &self.viscosity {
            let lap: &mut [Real; LANES] = (&mut self.lap[o..o + LANES]).try_into().unwrap();
            for (o, &d) in lap.iter_mut().zip(&b.d) {
                *o = l.laplacian(d);
            }
        }
    }

    #[inline(always)]
    fn one(&mut self, t: usize, gradient: Vector, d: Real) {
        self.grad[3 * t..3 * t + 3].copy_from_slice(&[gradient.x, gradient.y, gradient.z]);
        if let Some(l) = &self.viscosity {
            self.lap[t] = l.laplacian(d);
        }
    }
}
