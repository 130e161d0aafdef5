//! The symmetric pressure force of Müller et al. (2003), eq. 10 (the Unity paper's eq. 13):
//! `f_i = −Σ_j m (p_i + p_j)/(2ρ_j) ∇W(x_i − x_j)`, acceleration `a_i = f_i/ρ_i`.
//!
//! The pair terms are antisymmetric (`m·a_i` from `j` is minus `m·a_j` from `i`), so the pressure
//! force conserves linear momentum exactly up to round-off.

use crate::domain::Separation;
use crate::kernel::Kernel;
use crate::math::{Real, Vector};
use crate::neighbors::NeighborLists;
use crate::par::{CHUNK, LANES, lane_sum};
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Overwrites `accelerations[i]` with the pressure acceleration of particle `i`.
///
/// With `wall = Some(∇ρ_wall)` the walls push too, through their volume's density gradient
/// (see [`crate::boundary::wall`]): `a_i −= p_i/(2ρ_i²)·∇ρ_wall,i`.
///
/// Why one half: in a uniform fluid Müller's symmetric form equals half the variational
/// force `−Σ m (p_i/ρ_i² + p_j/ρ_j²) ∇W`, i.e. it is the exact gradient of the internal
/// energy `Σ m·u(ρ)` with `u' = p/(2ρ²)`. A wall term is energy-consistent only if it is the
/// gradient of that same energy through the wall's density, which gives the factor ½.
/// Mirroring the full pressure into the wall (`p_b = p_i`) does work on the fluid over
/// every oscillation: a column at rest in a closed tank then gains kinetic energy without
/// bound (the factor ½ makes it bounded). The separations are formed by `sep` (see
/// [`crate::domain`]).
///
/// Kept whole (9 arguments, 85 lines): with its inputs in a `neighbors::Pairs` and the
/// neighbour sum as a function of its own, the pressure-force stage measured 130 [129-132] µs
/// against main's 121 [119-122]; in this form 120 [117-127] against 120 [118-133] (medians
/// \[ranges\] of 6-8 runs of `cargo run --release --example stage_medians -- 2500 1500 1`,
/// alternated with main's build on one core). The machine's code-placement effects are of
/// the same order (the same bytes at another alignment measured 125 and 133 µs), so the
/// difference is small but was seen in every run.
#[allow(clippy::too_many_arguments)]
pub fn pressure_accelerations<K: Kernel, S: Separation>(
    positions: &[Vector],
    inv_densities: &[Real],
    pressures: &[Real],
    neighbors: &NeighborLists,
    mass: Real,
    h: Real,
    wall: Option<&[Vector]>,
    accelerations: &mut [Vector],
    sep: S,
) {
    let kernel = K::new(h);
    let half_m = 0.5 * mass;
    crate::par_chunks_mut!(accelerations, CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            crate::par::wide(
                #[inline(always)]
                || {
                    let base = c * CHUNK;
                    for (k, a) in out.iter_mut().enumerate() {
                        let i = base + k;
                        let xi = positions[i];
                        let pi = pressures[i];
                        let nb = neighbors.of(i);
                        // LANES neighbours at a time in lane arrays (packed sqrt/divide/kernel); the
                        // result equals `Kernel::gradient` pair by pair, coincident pairs included.
                        let coincident = K::COINCIDENT_FRACTION * h;
                        let (mut fx, mut fy, mut fz) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
                        let mut blocks = nb.chunks_exact(LANES);
                        for block in &mut blocks {
                            let (mut rx, mut ry, mut rz, mut d) =
                                ([0.0; LANES], [0.0; LANES], [0.0; LANES], [0.0; LANES]);
                            let mut s = [0.0; LANES];
                            for l in 0..LANES {
                                let j = block[l] as usize;
                                let r = sep.sep(xi, positions[j]);
                                (rx[l], ry[l], rz[l]) = (r.x, r.y, r.z);
                                d[l] = r.length_squared();
                                s[l] = (pi + pressures[j]) * inv_densities[j];
                            }
                            // Separate uniform loops (no data-dependent branch) vectorise.
                            for d in &mut d {
                                *d = d.sqrt();
                            }
                            let mut c = [0.0; LANES];
                            for l in 0..LANES {
                                // 1/d for separated pairs, 0 for coincident ones (fixed up below).
                                let far = (d[l] > coincident) as u32 as Real;
                                c[l] = kernel.dw(d[l]) * (far / d[l].max(coincident)) * s[l];
                            }
                            for l in 0..LANES {
                                fx[l] -= rx[l] * c[l];
                                fy[l] -= ry[l] * c[l];
                                fz[l] -= rz[l] * c[l];
                            }
                            if d.iter().any(|&dl| dl <= coincident) {
                                for l in 0..LANES {
                                    if d[l] <= coincident {
                                        let g =
                                            kernel.gradient(Vector::ZERO, d[l], i as u32, block[l])
                                                * s[l];
                                        (fx[l], fy[l], fz[l]) =
                                            (fx[l] - g.x, fy[l] - g.y, fz[l] - g.z);
                                    }
                                }
                            }
                        }
                        let mut f = Vector::new(lane_sum(fx), lane_sum(fy), lane_sum(fz));
                        for &j in blocks.remainder() {
                            let ju = j as usize;
                            let r = sep.sep(xi, positions[ju]);
                            let d = r.length();
                            let grad = kernel.gradient(r, d, i as u32, j);
                            f -= grad * ((pi + pressures[ju]) * inv_densities[ju]);
                        }
                        *a = f * (half_m * inv_densities[i]);
                        if let Some(grad) = wall {
                            *a -= grad[i] * (0.5 * pi * inv_densities[i] * inv_densities[i]);
                        }
                    }
                },
            )
        });
}

/// What [`symmetric_accelerations`] reads.
pub(crate) struct SymmetricInput<'a> {
    /// Sorted particle positions.
    pub positions: &'a [Vector],
    /// `1/ρ` of every particle.
    pub inv_densities: &'a [Real],
    /// Pressures from the equation of state.
    pub pressures: &'a [Real],
    /// Neighbour lists of `positions`.
    pub neighbors: &'a NeighborLists,
    /// Particle mass and kernel support.
    pub mass: Real,
    pub h: Real,
    /// The walls' density gradient `∇ρ_wall` (into the walls), with walls that count.
    pub wall: Option<&'a [Vector]>,
}

/// Overwrites `accelerations[i]` with the symmetric SPH pressure acceleration (Monaghan
/// 1992; Becker & Teschner 2007, eq. 6), `a_i = −Σ_j m (π_i + π_j) ∇W_ij`, `π = p/ρ²`:
/// the gradient of the internal energy, so in a uniform fluid it reads `−∇p/ρ` (Müller's
/// form, [`pressure_accelerations`], reads half of it).
///
/// With walls it adds Adami et al. (2012)'s wall pressure in the form of DFSPH's hydrostatic
/// walls (`solver::dfsph`, [`crate::solver::HYDROSTATIC_WALL_MIRROR`]): the wall "particles"
/// `b` of the walls' volume push with `−Σ_b m_b (π_i + π_b) ∇W_ib = −(π_i + π̂_i)·∇ρ_wall`,
/// the wall's value `π̂_i` being the average of the fluid-side neighbours' `π_j` weighted
/// by `max(0, ∇W_ij·û)`, `û = −∇ρ_wall/|∇ρ_wall|` (DFSPH's `wall_weights`, gathered here
/// in the force's own neighbour loop); `π̂_i` goes to `wall_pi[i]` (0 without wall or
/// weight) for the walls' reaction on bodies. The hydrostatic difference `ρ0·g·(x_b − x̄_i)`
/// is the wall stage's `WallWorkspace::hydrostatic`, which the solver adds with gravity.
/// The pair terms are antisymmetric: momentum is conserved up to round-off, as with
/// Müller's form. Each neighbour's `π_j` is formed in the loop (`p_j·(1/ρ_j)²`).
pub(crate) fn symmetric_accelerations<K: Kernel, S: Separation>(
    input: &SymmetricInput<'_>,
    accelerations: &mut [Vector],
    wall_pi: &mut [Real],
    sep: S,
) {
    let kernel = K::new(input.h);
    crate::par_chunks_mut!(accelerations, CHUNK)
        .zip(crate::par_chunks_mut!(wall_pi, CHUNK))
        .enumerate()
        .for_each(|(c, (out, out_pi))| {
            crate::par::wide(
                #[inline(always)]
                || {
                    for (k, (a, wp)) in out.iter_mut().zip(out_pi.iter_mut()).enumerate() {
                        let i = c * CHUNK + k;
                        (*a, *wp) = symmetric_particle(input, &kernel, i, sep);
                    }
                },
            )
        });
}

/// The symmetric pressure acceleration of particle `i` and its wall's `π̂_i` (see
/// [`symmetric_accelerations`]).
#[inline(always)]
fn symmetric_particle<K: Kernel, S: Separation>(
    input: &SymmetricInput<'_>,
    kernel: &K,
    i: usize,
    sep: S,
) -> (Vector, Real) {
    let inv = input.inv_densities[i];
    let pi_i = input.pressures[i] * inv * inv;
    let gw = input.wall.map_or(Vector::ZERO, |w| w[i]);
    let walled = gw != Vector::ZERO;
    let away = if walled {
        -gw.normalize()
    } else {
        Vector::ZERO
    };
    let (f, sw, swp) = pair_sums(input, kernel, (i, pi_i), away, sep);
    let mut a = f * input.mass;
    if !walled {
        return (a, 0.0);
    }
    let pi_wall = if sw > 0.0 { swp / sw } else { 0.0 };
    a -= gw * (pi_i + pi_wall);
    (a, pi_wall)
}

/// Particle `i`'s pair sums, `(Σ_j −(π_i + π_j) ∇W_ij, Σ_j w_ij, Σ_j w_ij·π_j)` with
/// `w_ij = max(0, ∇W_ij·away)` (`away` zero without walls): [`LANES`] neighbours at a time,
/// as [`pressure_accelerations`].
#[inline(always)]
fn pair_sums<K: Kernel, S: Separation>(
    input: &SymmetricInput<'_>,
    kernel: &K,
    (i, pi_i): (usize, Real),
    away: Vector,
    sep: S,
) -> (Vector, Real, Real) {
    let (positions, inv, pressures) = (input.positions, input.inv_densities, input.pressures);
    let xi = positions[i];
    let coincident = K::COINCIDENT_FRACTION * input.h;
    let (mut fx, mut fy, mut fz) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
    let (mut sw, mut swp) = ([0.0; LANES], [0.0; LANES]);
    let mut blocks = input.neighbors.of(i).chunks_exact(LANES);
    for block in &mut blocks {
        let (mut rx, mut ry, mut rz, mut d) =
            ([0.0; LANES], [0.0; LANES], [0.0; LANES], [0.0; LANES]);
        let mut pj = [0.0; LANES];
        for l in 0..LANES {
            let j = block[l] as usize;
            let r = sep.sep(xi, positions[j]);
            (rx[l], ry[l], rz[l]) = (r.x, r.y, r.z);
            d[l] = r.length_squared().sqrt();
            pj[l] = pressures[j] * inv[j] * inv[j];
        }
        for l in 0..LANES {
            // ∇W_ij = r·g for separated pairs, 0 for coincident ones (fixed up below).
            let far = (d[l] > coincident) as u32 as Real;
            let g = kernel.dw(d[l]) * (far / d[l].max(coincident));
            let c = g * (pi_i + pj[l]);
            (fx[l], fy[l], fz[l]) = (fx[l] - rx[l] * c, fy[l] - ry[l] * c, fz[l] - rz[l] * c);
            let w = ((rx[l] * away.x + ry[l] * away.y + rz[l] * away.z) * g).max(0.0);
            (sw[l], swp[l]) = (sw[l] + w, swp[l] + w * pj[l]);
        }
        if d.iter().any(|&dl| dl <= coincident) {
            for l in 0..LANES {
                if d[l] <= coincident {
                    let gr = kernel.gradient(Vector::ZERO, d[l], i as u32, block[l]);
                    let f = gr * (pi_i + pj[l]);
                    (fx[l], fy[l], fz[l]) = (fx[l] - f.x, fy[l] - f.y, fz[l] - f.z);
                    let w = gr.dot(away).max(0.0);
                    (sw[l], swp[l]) = (sw[l] + w, swp[l] + w * pj[l]);
                }
            }
        }
    }
    let mut f = Vector::new(lane_sum(fx), lane_sum(fy), lane_sum(fz));
    let (mut sw, mut swp) = (lane_sum(sw), lane_sum(swp));
    for &j in blocks.remainder() {
        let ju = j as usize;
        let r = sep.sep(xi, positions[ju]);
        let gr = kernel.gradient(r, r.length(), i as u32, j);
        let pj = pressures[ju] * inv[ju] * inv[ju];
        f -= gr * (pi_i + pj);
        let w = gr.dot(away).max(0.0);
        (sw, swp) = (sw + w, swp + w * pj);
    }
    (f, sw, swp)
}
