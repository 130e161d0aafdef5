//! Position-based fluids (PBF): Macklin & Müller, "Position Based Fluids", ACM TOG 32(4), 2013
//! (SIGGRAPH 2013). Equation numbers below are that paper's.
//!
//! Incompressibility is a constraint on positions, one per particle,
//!
//! ```text
//! C_i = ρ_i/ρ0 − 1                                     (eq. 1)
//! ```
//!
//! solved by a few Jacobi iterations of position corrections on the predicted positions:
//!
//! ```text
//! λ_i  = −C_i / ( Σ_k |∇_k C_i|² + ε )                 (eqs. 9–11; ε relaxes the constraint)
//! Δx_i = 1/ρ0 · ( Σ_j m (λ_i + λ_j + s_corr) ∇W_ij + λ_i ∇ρ_wall,i )   (eqs. 12, 14)
//! s_corr = −k · (W(x_ij) / W(Δq))^n                      (eq. 13, artificial pressure)
//! ```
//!
//! then `v = (x_new − x_old)/dt`. The constraint here is *unilateral*, `C_i = max(ρ_i/ρ0 − 1,
//! 0)`: only compression is corrected, so a free surface is not pulled together (the paper's
//! bilateral constraint needs the artificial pressure to stop that clustering; it is kept for
//! its second role, a short-range repulsion that keeps particles from stacking). Walls that
//! count in the density take part through their density and its gradient, linearised about
//! the positions where the walls were evaluated (the wall is immovable, so only the
//! particle's own constraint moves it away from the wall).
//!
//! A fixed number of iterations per step means a fixed cost and no divergence, whatever the
//! time step: the robust mode games expect. The price is compressibility: the error left
//! after the iterations is reported, not bounded.
//!
//! **Interacting fluids** (`crate::fluid::interaction`, `PbfContext::ratio`): the
//! constraint is the same for every fluid in the number form, and the corrections are
//! weighted by inverse mass as position-based dynamics does for unequal masses (Müller et al.
//! 2007; Bender, Müller & Macklin 2017): `Δx_i` above times `r_i = m_ref/m_i`, and
//! `Σ_k r_k|∇_k C_i|²` in λ's denominator, so each pair's corrections conserve momentum.

use crate::boundary::WallWorkspace;
use crate::kernel::Kernel;
use crate::math::{Real, Vector};
use crate::neighbors::NeighborLists;
use crate::par::{CHUNK, LANES, lane_sum};
#[cfg(feature = "parallel")]
use rayon::prelude::*;

use super::pairs::{Block, PairSink, gradient_block, gradient_one, kernel_sums, reduce_partials};
use crate::domain::Separation;
use crate::neighbors::Pairs;

/// Buffers of the PBF solver (indexed like the sorted particles).
#[derive(Clone, Debug, Default)]
pub(crate) struct PbfBuffers {
    /// `λ_i` of the current iteration.
    pub lambda: Vec<Real>,
    /// `Σ λ_i` over the iterations (for the reported pressure).
    pub lambda_sum: Vec<Real>,
    /// Position corrections of the current iteration.
    pub correction: Vec<Vector>,
    /// Positions at which the walls were evaluated.
    pub wall_origin: Vec<Vector>,
    /// Per-chunk partial sums.
    pub partials: Vec<(f64, Real)>,
    /// With walls: `Σ ω·λ_wall,i` over the iterations, the `λ` of the wall term (the
    /// particle's own, plus its fluid-side neighbours' average with hydrostatic walls) as the
    /// corrections applied it, relaxation `ω` included: the bodies' reaction. Without walls
    /// its values are stale (never read); it has the fluid's size so it zips by chunks.
    pub wall_lambda_sum: Vec<Real>,
    /// The fluid's relaxation state for this solve (see [`MAX_RELAXATION_HALVINGS`]): the
    /// corrections are scaled by `0.5^relaxation_halvings`. Read and updated only by solves
    /// whose context sets [`PbfContext::safeguard`].
    pub relaxation_halvings: u32,
}

/// Most halvings of the Jacobi relaxation `ω` of the position corrections (down to 1/8), as
/// DFSPH's ([`crate::solver::dfsph::MAX_RELAXATION_HALVINGS`]): Jacobi iterations on the
/// density constraints converge while `ω·λ_max < 2`, and `λ_max` grows with the neighbour
/// count. At the presets' support of 2 spacings `ω = 1` converges; at 3 spacings with walls
/// counting in the density it does not (without the halving a column at rest reaches 1.48×
/// its initial energy: stability case 12, `cargo run --release --example stability --
/// --case "support 3" --solver pbf`). When the average compression grows from one
/// iteration to the next (see [`DIVERGENCE_FLOOR`]), `ω` is halved for the fluid, for good;
/// the step report says so ([`crate::StepReport::solver_relaxation_halvings`]). At 2 spacings
/// it did not trigger in the 5,000- and 20,000-particle dam breaks (final-state hashes
/// unchanged) nor at rest (the test `pbf_column_with_a_wide_support_stays_at_rest`), but it
/// does in some runs: a jet's first particles meeting a plate (2.8e-5 → 8.7e-5 in one
/// iteration) and 500 particles spawned at one point (1.31e-5 → 1.51e-5), stability cases 8
/// and 6, which pass either way (quick jets: largest compression 0.82 → 1.8–3.0 %, KE/E0
/// 0.494 → 0.498); and 7 of the error report's 54 PBF runs (the coarsest dam breaks and the
/// Taylor–Green vortex: front errors 0.123 → 0.131 and 0.050 → 0.041, Taylor–Green's largest
/// compression 0.04–0.28 → 0.03–0.07 and its energy error a little lower). Requiring the
/// divergence in three consecutive solves would spare those, but lets case 12 diverge
/// unnoticed (solve 1 diverges, the next 150 do not, then the column blows up within a few
/// substeps).
#[doc(inline)]
pub use super::MAX_RELAXATION_HALVINGS;

pub(crate) mod settings;
mod step;
pub use settings::Pbf;
pub(crate) use step::PbfState;

/// What reads as the iteration diverging: the average compression, already above this floor
/// (a fraction of `ρ0`), grows from one iteration to the next by more than the factor
/// [`DIVERGENCE_GROWTH`]. Smaller growths are not divergence. The constraint is unilateral,
/// and the artificial pressure moves particles even where every `λ` is zero, so a correction
/// can push neighbours that were not compressed into compression: in a converging solve the
/// average can grow between iterations, from zero too (a jet meeting a plate: 0 → 5.7e-5; a
/// block spawned at half spacing: 5.0e-6 → 2.5e-5). Measured at the presets' 2 spacings
/// (5,000- and 20,000-particle PBF dam breaks, 400 steps each: `cargo run --release
/// --example dam_break -- --preset water --solver pbf --particles 5000 --steps 400`): 129
/// growths, none from an average above 4.7e-6. At 3 spacings (stability case 12) the first step's second
/// iteration grows 3.7e-4 → 4.5e-4 (+21 %). `1e-5` is a thousandth of PBF's default target
/// (`Pbf::max_density_error`, 1 %).
pub const DIVERGENCE_FLOOR: Real = 1e-5;

/// See [`DIVERGENCE_FLOOR`]: growth by more than 10 % between iterations.
pub const DIVERGENCE_GROWTH: Real = 1.1;

impl PbfBuffers {
    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        (self.lambda.capacity() + self.lambda_sum.capacity() + self.wall_lambda_sum.capacity()) * 4
            + (self.correction.capacity() + self.wall_origin.capacity()) * 12
            + self.partials.capacity() * 16
    }
}

/// What one PBF solve did.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub(crate) struct PbfStats {
    /// Iterations run.
    pub iterations: u32,
    /// Average compression `max(ρ/ρ0 − 1, 0)` measured at the start of the last iteration
    /// (before its correction).
    pub error: Real,
    /// Particles the last iteration moved (those with a violated constraint or next to one).
    pub moved: usize,
}

/// `Σ_k |∇_k C_i|²·ρ0²` of a particle inside a full lattice of spacing `s` (the scale of the
/// relaxation `ε`).
fn lattice_denominator<K: Kernel>(kernel: &K, mass: Real, s: Real) -> Real {
    let h = kernel.support();
    let r = (h / s).ceil() as i32;
    let (mut g2, mut sum_sq) = (0.0, 0.0);
    let mut g = Vector::ZERO;
    for x in -r..=r {
        for y in -r..=r {
            for z in -r..=r {
                let d = Vector::new(x as Real, y as Real, z as Real) * s;
                let len = d.length();
                if len > 0.0 && len < h {
                    let gr = kernel.gradient(d, len, 0, 1) * mass;
                    g += gr;
                    sum_sq += gr.length_squared();
                }
            }
        }
    }
    g2 += g.length_squared();
    g2 + sum_sq
}

/// Inputs of a PBF solve.
pub(crate) struct PbfContext<'a> {
    /// The solver's settings (iterations, relaxation, artificial pressure).
    pub settings: &'a Pbf,
    /// Neighbour lists of the predicted positions.
    pub neighbors: &'a NeighborLists,
    /// Walls counting in the density, evaluated at the predicted positions, if any.
    pub wall: Option<&'a WallWorkspace>,
    /// Particle mass.
    pub mass: Real,
    /// Support radius.
    pub h: Real,
    /// Particle spacing.
    pub spacing: Real,
    /// Rest density.
    pub rest_density: Real,
    /// Compression left alone: the constraint is `max(ρ/ρ0 − 1 − tolerance, 0)` (0 for the
    /// solver; the pipeline's overlap relaxation uses 1 %).
    pub tolerance: Real,
    /// Largest move of a particle per iteration (infinite for the solver).
    pub max_move: Real,
    /// Halve the relaxation when the iteration diverges (see [`MAX_RELAXATION_HALVINGS`]):
    /// `true` for the solver, `false` for the pipeline's overlap relaxation (whose blocks
    /// expand into compression by design).
    pub safeguard: bool,
    /// Interacting fluids (`crate::fluid::interaction`): each particle's inverse mass in units
    /// of the reference's, `r_i = m_ref/m_i`, which weights its corrections (see "Interacting
    /// fluids" in the module docs); `None` for one fluid (every weight 1).
    pub ratio: Option<&'a [Real]>,
}

/// Solves the density constraints on the predicted `positions` (moved in place): a fixed
/// number of Jacobi iterations of λ (pass 1, which also measures `densities` and
/// `inv_densities`) and position corrections (pass 2).
pub(crate) fn solve<K: Kernel, S: Separation>(
    ctx: &PbfContext<'_>,
    buffers: &mut PbfBuffers,
    positions: &mut [Vector],
    densities: &mut [Real],
    inv_densities: &mut [Real],
    sep: S,
) -> PbfStats {
    let n = positions.len();
    buffers.prepare(n, ctx.wall.is_some().then_some(&*positions));
    let passes = Passes::new(ctx, K::new(ctx.h), sep);
    let PbfBuffers {
        lambda,
        lambda_sum,
        correction,
        wall_origin,
        partials,
        wall_lambda_sum,
        relaxation_halvings,
    } = buffers;
    let mut stats = PbfStats::default();
    for _ in 0..ctx.settings.iterations {
        let out = LambdaOut {
            lambda,
            densities,
            inv_densities,
            lambda_sum,
            partials,
        };
        passes.lambdas(positions, wall_origin, out);
        let (sum, _) = reduce_partials(partials);
        let previous = stats.error;
        stats.error = (sum / n as f64) as Real;
        // The iteration diverging: halve the relaxation (see `MAX_RELAXATION_HALVINGS`).
        if ctx.safeguard
            && stats.iterations > 0
            && previous > DIVERGENCE_FLOOR
            && stats.error > previous * DIVERGENCE_GROWTH
            && *relaxation_halvings < MAX_RELAXATION_HALVINGS
        {
            *relaxation_halvings += 1;
        }
        let omega = if ctx.safeguard && *relaxation_halvings > 0 {
            super::relaxation(*relaxation_halvings)
        } else {
            1.0
        };
        let first = stats.iterations == 0;
        passes.corrections(
            positions,
            lambda,
            (omega, first),
            (correction, wall_lambda_sum),
        );
        stats.moved = apply_corrections(positions, correction, partials);
        stats.iterations += 1;
    }
    stats
}

impl PbfBuffers {
    /// Sizes the buffers for `n` particles; `positions`: the walls' evaluation positions,
    /// when walls count.
    fn prepare(&mut self, n: usize, positions: Option<&[Vector]>) {
        self.lambda.resize(n, 0.0);
        self.lambda_sum.clear();
        self.lambda_sum.resize(n, 0.0);
        self.correction.resize(n, Vector::ZERO);
        // Written (not read) by the first iteration's corrections where walls are: no O(n)
        // zeroing per solve, and without walls it is never read.
        self.wall_lambda_sum.resize(n, 0.0);
        self.partials.resize(n.div_ceil(CHUNK), (0.0, 0.0));
        if let Some(positions) = positions {
            self.wall_origin.clear();
            self.wall_origin.extend_from_slice(positions);
        }
    }
}

/// What pass 1 writes (indexed like the sorted particles; `partials` per chunk).
struct LambdaOut<'a> {
    lambda: &'a mut [Real],
    densities: &'a mut [Real],
    inv_densities: &'a mut [Real],
    lambda_sum: &'a mut [Real],
    partials: &'a mut [(f64, Real)],
}

/// The two passes of a PBF iteration, with the constants of the solve.
struct Passes<'a, K, S> {
    ctx: &'a PbfContext<'a>,
    kernel: K,
    sep: S,
    /// `ρ0` and `1/ρ0`.
    rho0: Real,
    inv_rho0: Real,
    /// The constraint's relaxation `ε`, absolute.
    eps: Real,
    /// A particle's own share of its density, `m·W(0)`.
    self_term: Real,
    /// Artificial pressure (eq. 13): `k` in units of λ, `1/W(Δq)`, and `n`.
    s_k: Real,
    inv_w_dq: Real,
    s_n: i32,
}

impl<'a, K: Kernel, S: Separation> Passes<'a, K, S> {
    fn new(ctx: &'a PbfContext<'a>, kernel: K, sep: S) -> Self {
        let settings = ctx.settings;
        let rho0 = ctx.rest_density;
        let lattice = lattice_denominator(&kernel, ctx.mass, ctx.spacing);
        // λ carries units (m²); the paper's artificial pressure is written in its own unit
        // system. It is taken here relative to `λ` of a lattice particle with C = 1, so `k`
        // means "a correction like that of a compression of k·(W/W(Δq))^n".
        let lambda_scale = rho0 * rho0 / lattice;
        let w_dq = kernel.w(settings.artificial_pressure_distance * ctx.h);
        Self {
            ctx,
            rho0,
            inv_rho0: 1.0 / rho0,
            eps: settings.relaxation * lattice,
            self_term: ctx.mass * kernel.w(0.0),
            s_k: if w_dq > 0.0 {
                settings.artificial_pressure * lambda_scale
            } else {
                0.0
            },
            inv_w_dq: if w_dq > 0.0 { 1.0 / w_dq } else { 0.0 },
            s_n: settings.artificial_pressure_exponent,
            kernel,
            sep,
        }
    }

    /// Pass 1: density, constraint and λ of every particle (walls linearised about the
    /// positions `wall_origin` they were evaluated at); the per-chunk sums of the constraint
    /// into `out.partials`.
    fn lambdas(&self, positions: &[Vector], wall_origin: &[Vector], out: LambdaOut<'_>) {
        let ctx = self.ctx;
        let pairs = Pairs {
            positions,
            neighbors: ctx.neighbors,
            mass: ctx.mass,
            h: ctx.h,
            sep: self.sep,
        };
        crate::par_chunks_mut!(out.lambda, CHUNK)
            .zip(crate::par_chunks_mut!(out.densities, CHUNK))
            .zip(crate::par_chunks_mut!(out.inv_densities, CHUNK))
            .zip(crate::par_chunks_mut!(out.lambda_sum, CHUNK))
            .zip(crate::par_iter_mut!(out.partials))
            .enumerate()
            .for_each(|(c, ((((lam, dens), inv), lsum), partial))| {
                crate::par::wide(
                    #[inline(always)]
                    || {
                        let mut err_sum = 0.0f64;
                        let mut err_max: Real = 0.0;
                        for k in 0..lam.len() {
                            let i = c * CHUNK + k;
                            let nb = ctx.neighbors.of(i);
                            // With interacting fluids `Σ_j r_j|∇W_ij|²` replaces `Σ_j |∇W_ij|²`.
                            let (sums, weighted) = match ctx.ratio {
                                None => (kernel_sums(&pairs, &self.kernel, i, nb, &mut ()), None),
                                Some(ratio) => {
                                    let mut sink = WeightedSquares {
                                        ratio,
                                        nb,
                                        sum: 0.0,
                                    };
                                    let sums = kernel_sums(&pairs, &self.kernel, i, nb, &mut sink);
                                    (sums, Some((ratio[i], sink.sum)))
                                }
                            };
                            let mut rho = self.self_term + ctx.mass * sums.w;
                            let mut grad = sums.g * ctx.mass;
                            if let Some(wall) = ctx.wall {
                                // Linearised about the positions the walls were evaluated at.
                                let gw = wall.gradient[i];
                                let moved = positions[i] - wall_origin[i];
                                rho += (wall.density[i] + gw.dot(moved)).max(0.0);
                                grad += gw;
                            }
                            let denom = match weighted {
                                None => grad.length_squared() + ctx.mass * ctx.mass * sums.g2,
                                Some((ri, g2)) => {
                                    ri * grad.length_squared() + ctx.mass * ctx.mass * g2
                                }
                            };
                            let constraint = self.constraint(i, rho);
                            let l = -constraint * self.rho0 * self.rho0 / (denom + self.eps);
                            lam[k] = l;
                            lsum[k] += l;
                            dens[k] = rho;
                            inv[k] = 1.0 / rho;
                            err_sum += constraint as f64;
                            err_max = err_max.max(constraint);
                        }
                        *partial = (err_sum, err_max);
                    },
                );
            });
    }

    /// The unilateral constraint `max(ρ/ρ0 − 1 − tolerance, 0)` of particle `i` at density
    /// `rho`; 0 for a pinched particle (see `WallWorkspace::pinched`), which is left out.
    #[inline(always)]
    fn constraint(&self, i: usize, rho: Real) -> Real {
        let ctx = self.ctx;
        if ctx
            .wall
            .is_some_and(|w| w.pinched(i, self.self_term, self.rho0))
        {
            0.0
        } else {
            (rho * self.inv_rho0 - 1.0 - ctx.tolerance).max(0.0)
        }
    }

    /// Pass 2: the position corrections (eqs. 12–14) of `lambda`, relaxed by `omega`, into
    /// `correction`, and what the walls applied into `wall_lambda_sum` (assigned on the
    /// `first` iteration, added to after). Per particle: `Σ_j (λ_i + λ_j + s_corr) ∇W_ij`,
    /// [`LANES`] neighbours at a time, and with hydrostatic walls the fluid-side neighbours'
    /// average λ, weighted by `max(0, ∇W_ij·û)`, `û` away from the walls (DFSPH's
    /// wall pressure value, `solver::dfsph`'s `wall_weights`, gathered in the same loop).
    fn corrections(
        &self,
        positions: &[Vector],
        lambda: &[Real],
        (omega, first): (Real, bool),
        (correction, wall_lambda_sum): (&mut [Vector], &mut [Real]),
    ) {
        crate::par_chunks_mut!(correction, CHUNK)
            .zip(crate::par_chunks_mut!(wall_lambda_sum, CHUNK))
            .enumerate()
            .for_each(|(c, (out, hat))| {
                crate::par::wide(
                    #[inline(always)]
                    || self.correct_chunk(c, (positions, lambda), (omega, first), (out, hat)),
                );
            });
    }

    /// [`Self::corrections`] of chunk `c` (`out`, `hat`: the chunk's rows). The pair sum stays
    /// in this loop: as a function of its own it measured PBF's density solve 1853
    /// [1827-1870] µs against main's 1827 [1809-1854]; in the loop 1795 [1766-1833] against
    /// 1825 [1800-1850] (`cargo run --release --example stage_medians -- 2500 1000 1 pbf
    /// true`, 8 runs each alternated with main's build on one core).
    #[inline(always)]
    fn correct_chunk(
        &self,
        c: usize,
        (positions, lambda): (&[Vector], &[Real]),
        (omega, first): (Real, bool),
        (out, hat): (&mut [Vector], &mut [Real]),
    ) {
        let ctx = self.ctx;
        let hydrostatic = ctx.wall.is_some_and(|w| w.neighbour_pressure);
        let base = c * CHUNK;
        for (k, dx) in out.iter_mut().enumerate() {
            let i = base + k;
            let li = lambda[i];
            let (kernel, sep) = (&self.kernel, &self.sep);
            let xi = positions[i];
            let hw = ctx
                .wall
                .filter(|w| hydrostatic && w.gradient[i] != Vector::ZERO);
            let away = hw.map_or(Vector::ZERO, |w| -w.gradient[i].normalize());
            let (mut sw, mut swl): (Real, Real) = (0.0, 0.0);
            let (mut fx, mut fy, mut fz) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
            let mut blocks = ctx.neighbors.of(i).chunks_exact(LANES);
            for block in &mut blocks {
                let b = gradient_block(sep, kernel, i, xi, positions, block);
                if hw.is_some() {
                    for l in 0..LANES {
                        let wgt = (b.gx[l] * away.x + b.gy[l] * away.y + b.gz[l] * away.z).max(0.0);
                        sw += wgt;
                        swl += wgt * lambda[block[l] as usize];
                    }
                }
                for l in 0..LANES {
                    let s_corr = if self.s_k > 0.0 {
                        -self.s_k * (kernel.w(b.d[l]) * self.inv_w_dq).powi(self.s_n)
                    } else {
                        0.0
                    };
                    let s = li + lambda[block[l] as usize] + s_corr;
                    fx[l] += s * b.gx[l];
                    fy[l] += s * b.gy[l];
                    fz[l] += s * b.gz[l];
                }
            }
            let mut f = Vector::new(lane_sum(fx), lane_sum(fy), lane_sum(fz));
            for &j in blocks.remainder() {
                let (g, d) = gradient_one(sep, kernel, i, xi, positions, j);
                f += g * (li + lambda[j as usize] + self.s_corr(d));
                if hw.is_some() {
                    let wgt = g.dot(away).max(0.0);
                    sw += wgt;
                    swl += wgt * lambda[j as usize];
                }
            }
            let neighbours = if sw > 0.0 { swl / sw } else { 0.0 };
            let mut d = f * ctx.mass;
            if let Some(wall) = ctx.wall {
                let lw = if hydrostatic { li + neighbours } else { li };
                // What the wall term applies, relaxation included.
                if first {
                    hat[k] = lw * omega;
                } else {
                    hat[k] += lw * omega;
                }
                d += wall.gradient[i] * lw;
            }
            let mut d = d * (self.inv_rho0 * omega);
            if let Some(ratio) = ctx.ratio {
                // Interacting fluids: weighted by the particle's inverse mass.
                d *= ratio[i];
            }
            let len = d.length();
            *dx = if len > ctx.max_move {
                d * (ctx.max_move / len)
            } else {
                d
            };
        }
    }

    /// The artificial pressure `s_corr = −k·(W(d)/W(Δq))^n` (eq. 13) at distance `d`.
    #[inline(always)]
    fn s_corr(&self, d: Real) -> Real {
        if self.s_k > 0.0 {
            -self.s_k * (self.kernel.w(d) * self.inv_w_dq).powi(self.s_n)
        } else {
            0.0
        }
    }
}

/// Gathers `Σ_j r_j|∇W_ij|²` over a particle's neighbours `nb` from [`kernel_sums`]' pairs
/// (interacting fluids: each neighbour's gradient weighted by its inverse mass).
struct WeightedSquares<'a> {
    ratio: &'a [Real],
    nb: &'a [u32],
    sum: Real,
}

impl PairSink for WeightedSquares<'_> {
    #[inline(always)]
    fn block(&mut self, o: usize, b: &Block) {
        for l in 0..LANES {
            let g2 = b.gx[l] * b.gx[l] + b.gy[l] * b.gy[l] + b.gz[l] * b.gz[l];
            self.sum += self.ratio[self.nb[o + l] as usize] * g2;
        }
    }

    #[inline(always)]
    fn one(&mut self, t: usize, gradient: Vector, _: Real) {
        self.sum += self.ratio[self.nb[t] as usize] * gradient.length_squared();
    }
}

/// Moves `positions` by `correction`; returns how many moved (`partials`: per-chunk scratch).
fn apply_corrections(
    positions: &mut [Vector],
    correction: &[Vector],
    partials: &mut [(f64, Real)],
) -> usize {
    crate::par_chunks_mut!(positions, CHUNK)
        .zip(crate::par_iter_mut!(partials))
        .enumerate()
        .for_each(|(c, (x, partial))| {
            let base = c * CHUNK;
            let mut moved = 0usize;
            for (k, x) in x.iter_mut().enumerate() {
                let d = correction[base + k];
                moved += (d != Vector::ZERO) as usize;
                *x += d;
            }
            *partial = (moved as f64, 0.0);
        });
    reduce_partials(partials).0 as usize
}
