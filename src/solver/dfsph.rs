//! Divergence-free SPH (DFSPH): Bender & Koschier, "Divergence-Free Smoothed Particle
//! Hydrodynamics" (SCA 2015) and "Divergence-Free SPH for Incompressible and Viscous Fluids"
//! (IEEE TVCG 23(3), 2017). Equation numbers below are the 2017 paper's.
//!
//! Pressure is not computed from an equation of state but solved for, twice per step:
//!
//! 1. **Divergence solve** (Alg. 2) at the start of the step: pressures that make the
//!    velocity field divergence-free, `Dρ/Dt = 0`, to within `max_divergence_error`.
//! 2. **Constant-density solve** (Alg. 3) after the non-pressure forces: pressures that bring
//!    the density predicted for the end of the step back to `ρ0`, to within
//!    `max_density_error` (average over the particles).
//!
//! Both solvers are Jacobi-style with the DFSPH factor (eq. 9, wall term included)
//!
//! ```text
//! α_i = 1 / ( |Σ_j m ∇W_ij + ∇ρ_wall,i|² + Σ_j |m ∇W_ij|² )
//! ```
//!
//! which is the exact inverse of the diagonal of the pressure system: a pressure value
//! `π_i = p_i/ρ_i²` changes particle `i`'s density over a step by `−dt²·π_i/α_i`. The pressure
//! acceleration is the symmetric, momentum-conserving form (eq. 4 with eq. 11)
//!
//! ```text
//! a_i = −Σ_j m (π_i + π_j) ∇W_ij − π_i ∇ρ_wall,i ,
//! ```
//!
//! the wall term mirroring the particle's pressure into the wall (Akinci et al. 2012). Each
//! solve's pressures are summed over its iterations and kept for the next step (warm start,
//! section 4.4); the pressure reported is both solves' sum, `p_i = (π_i + π_i^div)·ρ_i²`, all
//! the pressure the step applied (the divergence solve carries part of the load: reporting the
//! density solve alone read 5–25 % low in a settled column).
//!
//! A fluid that fills a periodic box (no free surface, no wall) is solved in the form of a
//! periodic pressure Poisson problem: both conditions as equalities about the fluid's mean,
//! zero-mean pressure (see [`SolveContext::closed`]).
//!
//! The solver uses the fluid's *density* kernel for every gradient, so the factor is exact for
//! the forces it predicts (the pressure-kernel setting is used by WCSPH only).

use super::pairs::{PairGradients, gradient_block, gradient_one, reduce_partials};
use crate::boundary::WallWorkspace;
use crate::domain::{Open, Separation};
use crate::kernel::Kernel;
use crate::math::{Real, Vector};
use crate::neighbors::NeighborLists;
use crate::par::{CHUNK, LANES, lane_sum};
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Weight `γ` of the wall's pressure force, `a_i −= γ·π_i·∇ρ_wall`. `γ = 1` is the
/// energy-consistent (variational) choice: the force is the gradient of the same internal
/// energy whose fluid part gives `(π_i + π_j)`. Full mirroring (`γ = 2`, as in IISPH) was
/// tried: it does net work over every oscillation, and a column at rest in a closed tank
/// gained kinetic energy until it sloshed.
pub const WALL_MIRROR: Real = 1.0;

/// Settings of the DFSPH solver. Defaults follow Bender & Koschier (2017): 0.1 % average
/// density error, 1 % divergence error.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub struct Dfsph {
    /// Largest accepted average density error after the constant-density solve, as a fraction
    /// of `ρ0` (default 0.001, i.e. 0.1 %).
    pub max_density_error: Real,
    /// Largest accepted average divergence error, `|Dρ/Dt|·dt/ρ0` averaged (default 0.01).
    pub max_divergence_error: Real,
    /// Iterations always run by the constant-density solve (default 2, as in Bender &
    /// Koschier's reference implementation, SPlisHSPlasH).
    pub min_iterations: u32,
    /// Iterations always run by the divergence solve (default 1, as in SPlisHSPlasH: the
    /// divergence solve only keeps the velocity field from drifting, its error target is
    /// usually met by the warm start and one correction).
    pub min_divergence_iterations: u32,
    /// Iteration cap of each solve (default 100). When it binds, the step report's
    /// `solver_capped` count says so.
    pub max_iterations: u32,
    /// Run the divergence solve (default true). Off gives "constant-density only" SPH, cheaper
    /// and less stable.
    pub divergence_solve: bool,
    /// Warm start of the constant-density solve: the fraction of the previous step's
    /// pressure applied before iterating (default 0.75), and only to particles whose density
    /// is predicted to exceed `ρ0` (the rest are separating: pressure carried over there
    /// would push fluid that is already coming apart, and the solve's increments, never
    /// negative, could not take it back). Higher values need fewer iterations, since the
    /// solve only rebuilds the remaining fraction each step; see the README for the measured
    /// trade-off (at 1.0 a column at rest in a closed tank kept jittering).
    #[cfg_attr(feature = "snapshot", serde(default = "default_warm_start"))]
    pub warm_start: Real,
}

#[cfg(feature = "snapshot")]
fn default_warm_start() -> Real {
    Dfsph::default().warm_start
}

impl Default for Dfsph {
    fn default() -> Self {
        Self {
            max_density_error: 0.001,
            max_divergence_error: 0.01,
            min_iterations: 2,
            min_divergence_iterations: 1,
            max_iterations: 100,
            divergence_solve: true,
            warm_start: 0.75,
        }
    }
}

/// What one solve did.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct SolveStats {
    /// Iterations run.
    pub iterations: u32,
    /// Average error reached (density: fraction of `ρ0`; divergence: `|Dρ/Dt|·dt/ρ0`).
    pub error: Real,
    /// `true` when the iteration cap stopped the solve before the target was reached.
    pub capped: bool,
}

/// Arrays the solver needs during a step (indexed like the sorted particles).
#[derive(Clone, Debug, Default)]
pub struct DfsphBuffers {
    /// DFSPH factor `α_i`.
    pub alpha: Vec<Real>,
    /// Pressure values `π_i` of the current iteration.
    pub pi: Vec<Real>,
    /// Per-chunk partial sums.
    pub partials: Vec<(f64, Real)>,
}

impl DfsphBuffers {
    fn resize(&mut self, n: usize) {
        self.alpha.resize(n, 0.0);
        self.pi.resize(n, 0.0);
        self.partials.resize(n.div_ceil(CHUNK), (0.0, 0.0));
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        (self.alpha.capacity() + self.pi.capacity()) * 4 + self.partials.capacity() * 16
    }
}

/// Density (fluid sum plus walls), its inverse, and the DFSPH factor of every particle, in
/// one pass over the neighbours, which also stores every pair's kernel gradient in `grads`
/// for the solves (the positions do not move until the step's end).
#[allow(clippy::too_many_arguments)]
pub fn density_and_factors<K: Kernel>(
    positions: &[Vector],
    neighbors: &NeighborLists,
    mass: Real,
    h: Real,
    wall: Option<&WallWorkspace>,
    densities: &mut [Real],
    inv_densities: &mut [Real],
    alpha: &mut [Real],
    grads: &mut PairGradients,
) {
    density_and_factors_in::<K, Open>(
        positions,
        neighbors,
        mass,
        h,
        wall,
        densities,
        inv_densities,
        alpha,
        grads,
        Open,
    );
}

/// [`density_and_factors`] with the separations formed by `sep` (see [`crate::domain`]).
#[allow(clippy::too_many_arguments)]
pub fn density_and_factors_in<K: Kernel, S: Separation>(
    positions: &[Vector],
    neighbors: &NeighborLists,
    mass: Real,
    h: Real,
    wall: Option<&WallWorkspace>,
    densities: &mut [Real],
    inv_densities: &mut [Real],
    alpha: &mut [Real],
    grads: &mut PairGradients,
    sep: S,
) {
    let kernel = K::new(h);
    let self_term = mass * kernel.w(0.0);
    let n = positions.len();
    let grad_chunks = grads.chunks_mut(n);
    crate::par_chunks_mut!(densities, CHUNK)
        .zip(crate::par_chunks_mut!(inv_densities, CHUNK))
        .zip(crate::par_chunks_mut!(alpha, CHUNK))
        .zip(crate::par_iter_mut!(grad_chunks))
        .enumerate()
        .for_each(|(c, (((dens, inv), alpha), gc))| {
            let base = c * CHUNK;
            let (offsets, indices) = neighbors.chunk(c);
            gc.resize(offsets[dens.len()] as usize);
            for k in 0..dens.len() {
                let i = base + k;
                let xi = positions[i];
                let (s, e) = (offsets[k] as usize, offsets[k + 1] as usize);
                let nb = &indices[s..e];
                let (ox, oy, oz) = (&mut gc.x[s..e], &mut gc.y[s..e], &mut gc.z[s..e]);
                let (mut w, mut sx, mut sy, mut sz, mut s2) = (
                    [0.0; LANES],
                    [0.0; LANES],
                    [0.0; LANES],
                    [0.0; LANES],
                    [0.0; LANES],
                );
                let full = nb.len() / LANES * LANES;
                for (t, block) in nb[..full].chunks_exact(LANES).enumerate() {
                    let b = gradient_block(&sep, &kernel, i, xi, positions, block);
                    let o = t * LANES;
                    ox[o..o + LANES].copy_from_slice(&b.gx);
                    oy[o..o + LANES].copy_from_slice(&b.gy);
                    oz[o..o + LANES].copy_from_slice(&b.gz);
                    for l in 0..LANES {
                        w[l] += kernel.w(b.d[l]);
                        sx[l] += b.gx[l];
                        sy[l] += b.gy[l];
                        sz[l] += b.gz[l];
                        s2[l] += b.gx[l] * b.gx[l] + b.gy[l] * b.gy[l] + b.gz[l] * b.gz[l];
                    }
                }
                let mut wsum = lane_sum(w);
                let mut g = Vector::new(lane_sum(sx), lane_sum(sy), lane_sum(sz));
                let mut g2 = lane_sum(s2);
                for t in full..nb.len() {
                    let (gr, d) = gradient_one(&sep, &kernel, i, xi, positions, nb[t]);
                    (ox[t], oy[t], oz[t]) = (gr.x, gr.y, gr.z);
                    wsum += kernel.w(d);
                    g += gr;
                    g2 += gr.length_squared();
                }
                let mut rho = self_term + mass * wsum;
                let grad = g * mass;
                // Own pressure's effect on own density: the push Σm∇W + γ∇ρ_wall dotted with the
                // density gradient Σm∇W + ∇ρ_wall (γ = WALL_MIRROR).
                let mut denom = grad.length_squared() + mass * mass * g2;
                if let Some(wall) = wall {
                    rho += wall.density[i];
                    let gw = wall.gradient[i];
                    denom = (grad + gw * WALL_MIRROR).dot(grad + gw) + mass * mass * g2;
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
        });
}

/// Pass A of an iteration: the rate of change of every particle's density under the current
/// velocities, `Dρ_i/Dt = Σ_j m (v_i − v_j)·∇W_ij + (v_i − v_wall)·∇ρ_wall,i` (eq. 6), handed to
/// `finish(i, rate)`, which returns `(π_i, error_i)`. Writes `π`; returns the per-chunk error
/// sums into `partials`.
#[allow(clippy::too_many_arguments)]
fn rate_pass<F: Fn(usize, Real) -> (Real, Real) + Sync>(
    velocities: &[Vector],
    neighbors: &NeighborLists,
    grads: &PairGradients,
    mass: Real,
    wall: Option<&WallWorkspace>,
    pi: &mut [Real],
    partials: &mut [(f64, Real)],
    finish: F,
) {
    crate::par_chunks_mut!(pi, CHUNK)
        .zip(crate::par_iter_mut!(partials))
        .enumerate()
        .for_each(|(c, (pi, partial))| {
            let base = c * CHUNK;
            let (offsets, indices) = neighbors.chunk(c);
            let gc = grads.chunk(c);
            let mut err_sum = 0.0f64;
            let mut err_max: Real = 0.0;
            for k in 0..pi.len() {
                let i = base + k;
                let vi = velocities[i];
                let (s, e) = (offsets[k] as usize, offsets[k + 1] as usize);
                let (nb, gx, gy, gz) = (&indices[s..e], &gc.x[s..e], &gc.y[s..e], &gc.z[s..e]);
                let mut acc = [0.0; LANES];
                let full = nb.len() / LANES * LANES;
                for t in (0..full).step_by(LANES) {
                    let j: &[u32; LANES] = nb[t..t + LANES].try_into().unwrap();
                    let bx: &[Real; LANES] = gx[t..t + LANES].try_into().unwrap();
                    let by: &[Real; LANES] = gy[t..t + LANES].try_into().unwrap();
                    let bz: &[Real; LANES] = gz[t..t + LANES].try_into().unwrap();
                    for l in 0..LANES {
                        let v = vi - velocities[j[l] as usize];
                        acc[l] += v.x * bx[l] + v.y * by[l] + v.z * bz[l];
                    }
                }
                let mut rate = lane_sum(acc);
                for t in full..nb.len() {
                    let v = vi - velocities[nb[t] as usize];
                    rate += v.dot(Vector::new(gx[t], gy[t], gz[t]));
                }
                rate *= mass;
                if let Some(wall) = wall {
                    rate += vi.dot(wall.gradient[i]) - wall.motion[i];
                }
                let (p, e) = finish(i, rate);
                pi[k] = p;
                err_sum += e as f64;
                err_max = err_max.max(e);
            }
            *partial = (err_sum, err_max);
        });
}

/// Pass B of an iteration: `v_i −= dt·(Σ_j m (π_i + π_j) ∇W_ij + π_i ∇ρ_wall,i)`.
fn apply_pressure(
    neighbors: &NeighborLists,
    grads: &PairGradients,
    mass: Real,
    wall: Option<&WallWorkspace>,
    pi: &[Real],
    dt: Real,
    velocities: &mut [Vector],
) {
    let dtm = dt * mass;
    crate::par_chunks_mut!(velocities, CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            let base = c * CHUNK;
            let (offsets, indices) = neighbors.chunk(c);
            let gc = grads.chunk(c);
            for (k, v) in out.iter_mut().enumerate() {
                let i = base + k;
                let pii = pi[i];
                let (s, e) = (offsets[k] as usize, offsets[k + 1] as usize);
                let (nb, gx, gy, gz) = (&indices[s..e], &gc.x[s..e], &gc.y[s..e], &gc.z[s..e]);
                let (mut fx, mut fy, mut fz) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
                let full = nb.len() / LANES * LANES;
                for t in (0..full).step_by(LANES) {
                    let j: &[u32; LANES] = nb[t..t + LANES].try_into().unwrap();
                    let bx: &[Real; LANES] = gx[t..t + LANES].try_into().unwrap();
                    let by: &[Real; LANES] = gy[t..t + LANES].try_into().unwrap();
                    let bz: &[Real; LANES] = gz[t..t + LANES].try_into().unwrap();
                    for l in 0..LANES {
                        let s = pii + pi[j[l] as usize];
                        fx[l] += s * bx[l];
                        fy[l] += s * by[l];
                        fz[l] += s * bz[l];
                    }
                }
                let mut f = Vector::new(lane_sum(fx), lane_sum(fy), lane_sum(fz));
                for t in full..nb.len() {
                    f += Vector::new(gx[t], gy[t], gz[t]) * (pii + pi[nb[t] as usize]);
                }
                let mut dv = f * dtm;
                if let Some(wall) = wall {
                    dv += wall.gradient[i] * (WALL_MIRROR * pii * dt);
                }
                *v -= dv;
            }
        });
}

/// Inputs shared by both solves.
pub struct SolveContext<'a> {
    /// Sorted positions.
    pub positions: &'a [Vector],
    /// Neighbour lists of those positions.
    pub neighbors: &'a NeighborLists,
    /// Kernel gradients of every neighbour pair (from [`density_and_factors`]).
    pub gradients: &'a PairGradients,
    /// Wall contributions, if any wall is near.
    pub wall: Option<&'a WallWorkspace>,
    /// Densities at the current positions.
    pub densities: &'a [Real],
    /// Particle mass.
    pub mass: Real,
    /// Support radius.
    pub h: Real,
    /// Rest density.
    pub rest_density: Real,
    /// Time step.
    pub dt: Real,
    /// Neighbours of a particle inside a full lattice. A particle with fewer than 60 % of
    /// that (walls counted by the fraction of the kernel they cover) is a surface particle
    /// and is left out of the divergence solve (Bender & Koschier use 20 of about 33).
    pub expected_neighbours: Real,
    /// The fluid fills a periodic box: no free surface and no wall term (see
    /// [`fills_periodic_box`]). Both solves then hold their conditions as equalities about
    /// the fluid's mean, with zero-mean pressure, in Jacobi steps relaxed by
    /// [`CLOSED_RELAXATION`]: the increment of particle `i` is `ω·α_i·(e_i − ē)/dt²` (density:
    /// `e_i` = predicted density − `ρ0`) or `ω·α_i·(e_i − ē)/dt` (divergence: `e_i = Dρ_i/Dt`),
    /// with the increments' mean removed, and the solve is held to `Σ|e_i − ē|/n`.
    ///
    /// Why: with no free surface nothing pins the pressure's level, and a uniform pressure
    /// moves a particle only through the disorder of its neighbourhood (`Σ_j ∇W_ij`, zero on a
    /// lattice): it is a near-null mode of the system. The kernel sum's mean over disordered
    /// particles reads above `ρ0` (second order in the lattice's deformation; the mass and
    /// the box fix the true density at `ρ0`), and the one-sided solve could remove that mean
    /// only through the near-null mode: it ran to its iteration cap and piled up a uniform
    /// pressure (measured in the Taylor–Green vortex, N = 12, dt = 0.02: 180 → 890 within
    /// four steps, where the vortex's own pressure is ±0.4), which then turned the particles'
    /// disorder into kinetic energy (E: 0.03 → 1.3 in two steps; the warm start carried 75 %
    /// of it into each next step). So the conditions are the incompressible ones of a
    /// periodic pressure Poisson problem: the residual's mean is its compatibility part, which
    /// no pressure corrects, and is left out; the pressure's level (the gauge) is fixed at
    /// zero mean; both signs are solved for (the one-sided clamp exists for free surfaces,
    /// and there is none). The warm start carries every value (the solve can take back what
    /// over-corrects).
    pub closed: bool,
}

/// `true` when a fluid of `n` particles of `mass` in `domain` has no free surface: the domain
/// is periodic, no wall term is present (`walls = false`), and the particles' rest volume
/// `n·m/ρ0` is the box's volume to within `tolerance` (the density solve's own
/// `max_density_error`). Such a fluid is enclosed by its own periodic images.
pub fn fills_periodic_box(
    domain: &crate::Domain,
    n: usize,
    mass: Real,
    rest_density: Real,
    walls: bool,
    tolerance: Real,
) -> bool {
    match domain.minimum_image() {
        Some(d) if !walls => {
            let box_volume = d.len.x as f64 * d.len.y as f64 * d.len.z as f64;
            n as f64 * mass as f64 / rest_density as f64 >= (1.0 - tolerance as f64) * box_volume
        }
        _ => false,
    }
}

/// How a solve reuses the previous step's pressure values.
#[derive(Copy, Clone)]
enum WarmStart {
    /// Half of every value (the divergence solve: its values are small and noisy).
    Half,
    /// This fraction of the values of particles that compress without pressure, zero for
    /// the others ([`Dfsph::warm_start`]).
    WhereCompressing(Real),
}

/// The Jacobi loop both solves share: warm start from the previous pressure values (section
/// 4.4) as `warm_start` says (never all of them: the increments are never negative, so the
/// whole value could only grow; a closed box carries all of them, see
/// [`SolveContext::closed`]), then rate pass → error check → velocity update until the average error, `Σ error_i / n` times
/// `error_scale`, is at most `target` (after at least `min_iterations`), or the cap binds.
/// `finish(i, Dρ_i/Dt) = (π increment, error_i)`. `warm` ends as this step's summed pressure.
#[allow(clippy::too_many_arguments)]
fn jacobi<F: Fn(&[Real], usize, Real) -> (Real, Real) + Sync>(
    ctx: &SolveContext<'_>,
    settings: &Dfsph,
    warm_start: WarmStart,
    min_iterations: u32,
    target: Real,
    error_scale: Real,
    buffers: &mut DfsphBuffers,
    warm: &mut [Real],
    velocities: &mut [Vector],
    gain: Real,
    finish: F,
) -> SolveStats {
    let n = ctx.positions.len();
    buffers.resize(n);
    let DfsphBuffers {
        alpha,
        pi,
        partials,
    } = buffers;
    let apply = |pi: &[Real], velocities: &mut [Vector]| {
        apply_pressure(
            ctx.neighbors,
            ctx.gradients,
            ctx.mass,
            ctx.wall,
            pi,
            ctx.dt,
            velocities,
        )
    };
    let alpha: &[Real] = alpha;
    let rate = |velocities: &[Vector], pi: &mut [Real], partials: &mut [(f64, Real)]| {
        rate_pass(
            velocities,
            ctx.neighbors,
            ctx.gradients,
            ctx.mass,
            ctx.wall,
            pi,
            partials,
            |i, r| finish(alpha, i, r),
        )
    };
    match warm_start {
        WarmStart::Half => {
            for w in warm.iter_mut() {
                *w *= 0.5;
            }
        }
        // Closed: the solve takes back what over-corrects, so every value is carried.
        WarmStart::WhereCompressing(fraction) if ctx.closed => {
            for w in warm.iter_mut() {
                *w *= fraction;
            }
        }
        WarmStart::WhereCompressing(fraction) => {
            if warm.iter().any(|&w| w != 0.0) {
                // One rate pass without any pressure: which particles still compress.
                rate(velocities, pi, partials);
                for (w, &p) in warm.iter_mut().zip(pi.iter()) {
                    *w = if p > 0.0 { *w * fraction } else { 0.0 };
                }
            }
        }
    }
    if ctx.closed {
        remove_mean(warm);
    }
    if warm.iter().any(|&w| w != 0.0) {
        apply(warm, velocities);
    }
    let mut stats = SolveStats::default();
    loop {
        rate(velocities, pi, partials);
        let sum = if ctx.closed {
            closed_increments(pi, alpha, gain)
        } else {
            reduce_partials(partials).0
        };
        stats.error = (sum / n as f64) as Real * error_scale;
        let done = stats.error <= target;
        if (done && stats.iterations >= min_iterations)
            || stats.iterations >= settings.max_iterations
        {
            stats.capped = !done;
            break;
        }
        apply(pi, velocities);
        for (w, p) in warm.iter_mut().zip(pi.iter()) {
            *w += p;
        }
        stats.iterations += 1;
    }
    stats
}

/// Divergence solve (Alg. 2): corrects `velocities` until `Dρ/Dt ≈ 0`. `warm` holds the
/// previous step's pressure values on entry (used at half weight) and this step's sum on exit.
pub fn divergence_solve(
    ctx: &SolveContext<'_>,
    settings: &Dfsph,
    buffers: &mut DfsphBuffers,
    warm: &mut [Real],
    velocities: &mut [Vector],
) -> SolveStats {
    let dt = ctx.dt;
    let coverage = ctx.wall.map(|w| &w.coverage[..]);
    let expected = ctx.expected_neighbours;
    jacobi(
        ctx,
        settings,
        WarmStart::Half,
        settings.min_divergence_iterations,
        settings.max_divergence_error,
        dt / ctx.rest_density,
        buffers,
        warm,
        velocities,
        1.0 / dt,
        |alpha, i, rate| {
            if ctx.closed {
                return (rate, rate);
            }
            // Surface particles (few neighbours, walls counted by their coverage) are left
            // out: their density deficit is not compression.
            let count =
                ctx.neighbors.of(i).len() as Real + coverage.map_or(0.0, |c| c[i] * expected);
            let r = if count < 0.6 * expected {
                0.0
            } else {
                rate.max(0.0)
            };
            (r * alpha[i] / dt, r)
        },
    )
}

/// Constant-density solve (Alg. 3): corrects the predicted `velocities` until the density they
/// lead to after `dt` is `ρ0` on average to within `max_density_error`. `warm` holds the
/// previous step's pressure values on entry (used at half weight) and this step's sum on exit
/// (the pressure).
pub fn density_solve(
    ctx: &SolveContext<'_>,
    settings: &Dfsph,
    buffers: &mut DfsphBuffers,
    warm: &mut [Real],
    velocities: &mut [Vector],
) -> SolveStats {
    let (dt, rho0, densities) = (ctx.dt, ctx.rest_density, ctx.densities);
    let inv_dt2 = 1.0 / (dt * dt);
    jacobi(
        ctx,
        settings,
        WarmStart::WhereCompressing(settings.warm_start),
        settings.min_iterations,
        settings.max_density_error,
        1.0 / rho0,
        buffers,
        warm,
        velocities,
        inv_dt2,
        |alpha, i, rate| {
            if ctx.closed {
                let e = densities[i] + dt * rate - rho0;
                return (e, e);
            }
            // Predicted density, clamped below at ρ0: only compression is corrected (a free
            // surface is allowed to be under-dense).
            let excess = (densities[i] + dt * rate - rho0).max(0.0);
            (excess * alpha[i] * inv_dt2, excess)
        },
    )
}

/// Relaxation `ω` of the closed-box Jacobi update (see [`SolveContext::closed`]). With signed
/// increments plain Jacobi (`ω = 1`) diverges on this system (measured: the Taylor–Green vortex
/// at N = 12 reached infinite energy in the second step); `ω = 0.5` is IISPH's relaxed Jacobi
/// (Ihmsen et al., "Implicit Incompressible SPH", IEEE TVCG 2014), on the same diagonal.
pub const CLOSED_RELAXATION: Real = 0.5;

/// One Jacobi update of a fluid that fills a periodic box (see [`SolveContext::closed`]). On
/// entry `e` holds every particle's signed error; on exit, its pressure increment
/// `ω·α_i·gain·(e_i − ē)` (`gain` = `1/dt²` or `1/dt`) with the increments' mean removed.
/// Returns `Σ|e_i − ē|`. Serial sums: the same bits for any thread count.
fn closed_increments(e: &mut [Real], alpha: &[Real], gain: Real) -> f64 {
    let n = e.len().max(1) as f64;
    let mean = (e.iter().map(|&x| x as f64).sum::<f64>() / n) as Real;
    let k = CLOSED_RELAXATION * gain;
    let mut error = 0.0f64;
    for (x, &a) in e.iter_mut().zip(alpha) {
        let d = *x - mean;
        error += d.abs() as f64;
        *x = k * a * d;
    }
    remove_mean(e);
    error
}

/// Subtracts the mean of `x` from every value.
fn remove_mean(x: &mut [Real]) {
    let mean = (x.iter().map(|&v| v as f64).sum::<f64>() / x.len().max(1) as f64) as Real;
    for v in x.iter_mut() {
        *v -= mean;
    }
}
