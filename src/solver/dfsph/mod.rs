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
//! zero-mean pressure (see `SolveContext::closed`).
//!
//! The solver uses the fluid's *density* kernel for every gradient, so the factor is exact for
//! the forces it predicts (the pressure-kernel setting is used by WCSPH only).

use super::pairs::{Block, KernelSums, PairGradients, PairSink, kernel_sums, reduce_partials};
use crate::boundary::WallWorkspace;
use crate::domain::Separation;
use crate::kernel::{Kernel, ViscosityLaplacian};
use crate::math::{Real, Vector};
use crate::neighbors::{NeighborLists, Pairs};
use crate::par::{CHUNK, LANES};
use rapier3d::glamx::Vec3A;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Weight `γ` of the wall's pressure force, `a_i −= γ·π_i·∇ρ_wall`, by default. `γ = 1` is the
/// energy-consistent (variational) choice: the force is the gradient of the same internal
/// energy whose fluid part gives `(π_i + π_j)`. Full mirroring (`γ = 2`) without the
/// hydrostatic part of the wall's pressure makes a column at rest in a closed tank slosh
/// (kinetic energy 9e-3 J on a 10 × 20 × 10 column at 1 cm, against 2e-4 J with `γ = 1`):
/// nothing then holds the fluid next to the side walls up. [`Dfsph::hydrostatic_walls`]
/// adds that part and mirrors fully ([`HYDROSTATIC_WALL_MIRROR`]).
pub const WALL_MIRROR: Real = 1.0;

/// Total weight of the wall's pressure with [`Dfsph::hydrostatic_walls`]: the wall
/// "particle" term `π_i + π_b` with the wall's pressure `π_b` equal to the fluid's carried
/// to the particle, plus the hydrostatic difference `ρ0·g·(x_b − x_i)` of Adami et al. (2012),
/// applied with gravity (`boundary::WallWorkspace::hydrostatic`). The particle's
/// own value counts once ([`WALL_MIRROR`]); `π_b` is the average of its fluid-side
/// neighbours' values carried back to it (`boundary::WallWorkspace::neighbour_pressure`),
/// as Adami et al. take the wall's pressure from the fluid around it. In a linear
/// hydrostatic field the two are equal (total weight 2): the zeroth-order term
/// `2π_i Σ_j m∇W_ij` the missing neighbours leave next to a wall is cancelled, and the
/// hydrostatic part supplies the wall's share of the first-order term (the kernel's first
/// moment), vertical support next to side walls included. Mirroring the particle's own
/// value twice instead leaves its distance to the wall tied to nothing (a bottom layer whose
/// pressure fell below the layer above was pressed into the floor and held by contact, which
/// then carried 10 % of a resting column's weight) and keeps a resting column moving (see
/// docs/solvers.md).
pub const HYDROSTATIC_WALL_MIRROR: Real = 2.0;

/// Accumulators of the solves' pair sums (pair `t` of a particle goes to `t % ACC`), summed
/// as `(a0 + a1) + (a2 + a3)`: independent add chains, and a fixed order.
const ACC: usize = 4;

/// What one solve did.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub(crate) struct SolveStats {
    /// Iterations run.
    pub iterations: u32,
    /// Average error reached (density: fraction of `ρ0`; divergence: `|Dρ/Dt|·dt/ρ0`).
    pub error: Real,
    /// `true` when the iteration cap stopped the solve before the target was reached.
    pub capped: bool,
    /// With hydrostatic walls: `true` when the solve diverged and went on without the
    /// neighbours' part of the wall pressure (see [`DfsphBuffers::applied_neighbour`]).
    pub neighbour_dropped: bool,
}

/// Arrays the solver needs during a step (indexed like the sorted particles).
#[derive(Clone, Debug, Default)]
pub(crate) struct DfsphBuffers {
    /// DFSPH factor `α_i`.
    pub alpha: Vec<Real>,
    /// Pressure values `π_i` of the current iteration.
    pub pi: Vec<Real>,
    /// Per-chunk partial sums.
    pub partials: Vec<(f64, Real)>,
    /// The velocities being corrected, 16 bytes wide (copied in and out by each solve; the
    /// pair passes load a neighbour's velocity in one instruction). Also the scratch copy
    /// of [`viscosity`].
    pub velocities: Vec<Vec3A>,
    /// The fluid's relaxation state for this step (see [`MAX_RELAXATION_HALVINGS`]): the
    /// solves' increments are scaled by `0.5^relaxation_halvings`.
    pub relaxation_halvings: u32,
    /// With hydrostatic walls ([`crate::boundary::WallWorkspace::neighbour_pressure`]): the
    /// pressure values each particle's wall has taken its neighbours' part from over this
    /// substep, warm starts included, so that the bodies receive the reaction of what was
    /// applied. Equal to the solves' summed values unless a solve dropped that part.
    ///
    /// Why a solve drops it: the neighbours' average couples a particle next to a wall to its
    /// neighbours' current increments, which DFSPH's diagonal factor does not account for.
    /// Next to the strongly non-uniform pressure that follows the overlap relaxation (a
    /// block spawned at half spacing, particles pushed out of a body) the Jacobi iteration
    /// kept with it diverges, stops at its cap and throws the fluid (stability cases 6 and 7
    /// at full size, `cargo run --release --example stability -- --case spawn --solver dfsph`
    /// and `--case immersed`: KE 3.2× the initial energy). So once a solve's error grows
    /// from one iteration to the next, the rest of that solve runs with the particle's own
    /// pressure mirrored, as without hydrostatic walls; the next solve starts with it again.
    /// A settling column stays within 2 % (bottom error −0.1 / +1.5 / +0.3 % at N = 6 / 8 /
    /// 12, against −0.1 / +0.9 / +0.3 % with the coupling kept in every iteration: while it
    /// settles, a solve diverges now and then and finishes without it).
    pub applied_neighbour: Vec<Real>,
}

/// Most halvings of the Jacobi relaxation `ω` (down to 1/8). Jacobi with DFSPH's diagonal
/// factor converges while `ω·λ_max < 2`, `λ_max` the largest eigenvalue of the diagonally
/// scaled system; at the presets' support of 2 spacings `ω = 1` is inside that bound, but
/// `λ_max` grows with the neighbour count and, with walls counting in the density, a support
/// of 3 spacings goes past it (without the halving a column at rest is thrown within a
/// frame: stability case 12, `cargo run --release --example stability -- --case "support 3"
/// --solver dfsph`). So when a solve's average error grows from one iteration to the next (the
/// iteration diverging), the fluid's `ω` is halved, for good: letting it creep back
/// (× 1.1 or × 1.01 per solve) let the blow-up return. At 2 spacings it did not trigger in
/// the runs checked (the salva scene and 5,000-particle dam breaks: final-state hashes
/// unchanged; the hydrostatic scene and the square-column front: the same errors to the
/// printed digit; the test `dfsph_column_with_a_wide_support_stays_at_rest` checks a column);
/// the step report says when it did ([`crate::StepReport::solver_relaxation_halvings`]).
#[doc(inline)]
pub use super::MAX_RELAXATION_HALVINGS;

pub(crate) mod settings;
mod step;
pub use settings::Dfsph;
pub(crate) use step::DfsphState;

impl DfsphBuffers {
    /// Sizes every array for `n` particles (no allocation once warm).
    pub fn resize(&mut self, n: usize) {
        self.alpha.resize(n, 0.0);
        self.pi.resize(n, 0.0);
        self.partials.resize(n.div_ceil(CHUNK), (0.0, 0.0));
        self.velocities.resize(n, Vec3A::ZERO);
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        (self.alpha.capacity() + self.pi.capacity()) * 4
            + self.applied_neighbour.capacity() * 4
            + self.partials.capacity() * 16
            + self.velocities.capacity() * std::mem::size_of::<Vec3A>()
    }
}

/// `out[l] = (x[l], y[l], z[l])` for the [`LANES`] lanes of a block: a 4×4 transpose of
/// shuffles on x86-64 (built lane by lane, the vectors went through the stack and stalled
/// on store forwarding).
#[inline(always)]
fn to_vectors(x: &[Real; LANES], y: &[Real; LANES], z: &[Real; LANES], out: &mut [Vec3A]) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        for (h, out) in out.chunks_exact_mut(4).enumerate() {
            let o = 4 * h;
            // SAFETY: the loads read lanes `o..o + 4` of arrays of LANES = 8 (o is 0 or 4);
            // SSE is part of every x86-64 CPU.
            let v = unsafe {
                let xv = _mm_loadu_ps(x.as_ptr().add(o));
                let yv = _mm_loadu_ps(y.as_ptr().add(o));
                let zv = _mm_loadu_ps(z.as_ptr().add(o));
                let xy_lo = _mm_unpacklo_ps(xv, yv); // x0 y0 x1 y1
                let xy_hi = _mm_unpackhi_ps(xv, yv); // x2 y2 x3 y3
                let zz_lo = _mm_unpacklo_ps(zv, zv); // z0 z0 z1 z1
                let zz_hi = _mm_unpackhi_ps(zv, zv); // z2 z2 z3 z3
                [
                    _mm_movelh_ps(xy_lo, zz_lo),
                    _mm_movehl_ps(zz_lo, xy_lo),
                    _mm_movelh_ps(xy_hi, zz_hi),
                    _mm_movehl_ps(zz_hi, xy_hi),
                ]
            };
            for (o, v) in out.iter_mut().zip(v) {
                *o = Vec3A::from(v);
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    for l in 0..LANES {
        out[l] = Vec3A::new(x[l], y[l], z[l]);
    }
}

/// The divergence solve's warm start, applied by [`density_and_factors`] in its pass over
/// the neighbours (it needs only the pairs' gradients, which that pass computes), which
/// saves the solve one pass; see [`divergence_warm_start`].
#[derive(Copy, Clone, Debug)]
pub(crate) struct WarmPush<'a> {
    /// Pressure values `π` to apply (the previous step's divergence values, halved).
    pub pi: &'a [Real],
    /// Velocities before the push.
    pub velocities: &'a [Vector],
    /// Time step.
    pub dt: Real,
    /// Interacting fluids: each particle's factor on its pushes (see [`Pusher::ratio`]).
    pub ratio: Option<&'a [Real]>,
}

impl<'a> WarmPush<'a> {
    /// How the warm start pushes particles of mass `mass` (walls' neighbour part included).
    fn pusher(&self, mass: Real, wall: Option<&'a WallWorkspace>) -> Pusher<'a> {
        Pusher {
            mass,
            wall,
            neighbour: true,
            dt: self.dt,
            ratio: self.ratio,
        }
    }
}

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
    let grad_chunks = grads.chunks_mut(n);
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
                    gc.grad.resize(in_chunk, Vec3A::ZERO);
                    gc.laplacian.resize(viscosity.map_or(0, |_| in_chunk), 0.0);
                    for k in 0..dens.len() {
                        let i = base + k;
                        let (s, e) = (offsets[k] as usize, offsets[k + 1] as usize);
                        let nb = &indices[s..e];
                        let out = &mut gc.grad[s..e];
                        let lap_out: &mut [Real] = match viscosity {
                            Some(_) => &mut gc.laplacian[s..e],
                            None => &mut [],
                        };
                        let mut store = StorePairs {
                            grad: &mut *out,
                            lap: lap_out,
                            viscosity,
                        };
                        let KernelSums { w: wsum, g, g2 } =
                            kernel_sums(pairs, &kernel, i, nb, &mut store);
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
                            pushed[k] = v - pusher.push(nb, out, push.pi, i);
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
                for (&j, &gij) in indices[s..e].iter().zip(&gc[s..e]) {
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

/// The density pass's pair values of one particle: gradients (16 bytes wide) and, for a
/// viscous fluid, the viscosity Laplacians.
struct StorePairs<'a> {
    grad: &'a mut [Vec3A],
    lap: &'a mut [Real],
    viscosity: Option<ViscosityLaplacian>,
}

impl PairSink for StorePairs<'_> {
    #[inline(always)]
    fn block(&mut self, o: usize, b: &Block) {
        to_vectors(&b.gx, &b.gy, &b.gz, &mut self.grad[o..o + LANES]);
        if let Some(l) = &self.viscosity {
            let lap: &mut [Real; LANES] = (&mut self.lap[o..o + LANES]).try_into().unwrap();
            for (o, &d) in lap.iter_mut().zip(&b.d) {
                *o = l.laplacian(d);
            }
        }
    }

    #[inline(always)]
    fn one(&mut self, t: usize, gradient: Vector, d: Real) {
        self.grad[t] = Vec3A::from(gradient);
        if let Some(l) = &self.viscosity {
            self.lap[t] = l.laplacian(d);
        }
    }
}

/// `Σ_t term(nb[t], values[t])` over a particle's pairs, pair `t` into accumulator
/// `t % ACC`, summed as `(a0 + a1) + (a2 + a3)`: independent add chains, and a fixed order,
/// so the result depends on the data only. The terms run over 16-byte vectors (one packed
/// operation per component-wise step).
#[inline(always)]
fn pair_sum<T: Copy>(nb: &[u32], values: &[T], term: impl Fn(usize, T) -> Vec3A) -> Vec3A {
    let mut acc = [Vec3A::ZERO; ACC];
    let full = nb.len() / ACC * ACC;
    for (j, v) in nb[..full]
        .chunks_exact(ACC)
        .zip(values[..full].chunks_exact(ACC))
    {
        for l in 0..ACC {
            acc[l] += term(j[l] as usize, v[l]);
        }
    }
    for (l, (&j, &v)) in nb[full..].iter().zip(&values[full..]).enumerate() {
        acc[l] += term(j as usize, v);
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

/// Pass A of an iteration: the rate of change of every particle's density under the current
/// velocities, `Dρ_i/Dt = Σ_j m (v_i − v_j)·∇W_ij + (v_i − v_wall)·∇ρ_wall,i` (eq. 6), handed to
/// `finish(i, rate)`, which returns `(π_i, error_i)`. Writes `π`; returns the per-chunk error
/// sums into `partials`.
fn rate_pass<F: Fn(usize, Real) -> (Real, Real) + Sync>(
    ctx: &SolveContext<'_>,
    velocities: &[Vec3A],
    pi: &mut [Real],
    partials: &mut [(f64, Real)],
    finish: F,
) {
    let (mass, wall) = (ctx.mass, ctx.wall);
    crate::par_chunks_mut!(pi, CHUNK)
        .zip(crate::par_iter_mut!(partials))
        .enumerate()
        .for_each(|(c, (pi, partial))| {
            crate::par::wide(
                #[inline(always)]
                || {
                    let (offsets, indices) = ctx.neighbors.chunk(c);
                    let gc = &ctx.gradients.chunk(c).grad;
                    let mut err_sum = 0.0f64;
                    let mut err_max: Real = 0.0;
                    for k in 0..pi.len() {
                        let i = c * CHUNK + k;
                        let vi = velocities[i];
                        let (s, e) = (offsets[k] as usize, offsets[k + 1] as usize);
                        let a =
                            pair_sum(&indices[s..e], &gc[s..e], |j, g| (vi - velocities[j]) * g);
                        let mut rate = (a.x + a.y + a.z) * mass;
                        if let Some(wall) = wall {
                            let vi = Vector::from(vi);
                            rate += vi.dot(wall.gradient[i]) - wall.motion[i];
                        }
                        let (p, e) = finish(i, rate);
                        pi[k] = p;
                        err_sum += e as f64;
                        err_max = err_max.max(e);
                    }
                    *partial = (err_sum, err_max);
                },
            );
        });
}

/// How pressure values push a particle: particle mass, walls, whether the walls take their
/// pressure from the neighbours (hydrostatic walls, unless the solve dropped that part), and
/// the time step.
struct Pusher<'a> {
    mass: Real,
    wall: Option<&'a WallWorkspace>,
    neighbour: bool,
    dt: Real,
    /// Interacting fluids (`crate::fluid::interaction`): `m_ref/m_i`, the factor on particle
    /// `i`'s push (the same pair force on a lighter particle). `None` for one fluid.
    ratio: Option<&'a [Real]>,
}

impl Pusher<'_> {
    /// `dt·(Σ_j m (π_i + π_j) ∇W_ij + γ π_i ∇ρ_wall,i)`: how much the pressure values `pi`
    /// change particle `i`'s velocity over `dt` (subtracted), from its neighbours `nb` and
    /// their gradients `g`.
    #[inline(always)]
    fn push(&self, nb: &[u32], g: &[Vec3A], pi: &[Real], i: usize) -> Vec3A {
        let pii = pi[i];
        let f = pair_sum(nb, g, |j, g| g * (pii + pi[j]));
        let mut dv = Vector::from(f) * (self.dt * self.mass);
        if let Some(wall) = self.wall {
            let gw = wall.gradient[i];
            let mut wall_pi = wall.mirror * pii;
            if self.neighbour && wall.neighbour_pressure {
                wall_pi += neighbour_average(nb, g, gw, |j| pi[j]);
            }
            dv += gw * (wall_pi * self.dt);
        }
        if let Some(r) = self.ratio {
            dv *= r[i];
        }
        Vec3A::from(dv)
    }
}

/// The wall's pressure value `π̂_i` with hydrostatic walls: the average of the neighbours'
/// values `pi(j)` weighted by `max(0, ∇W_ij·û)`, `û = −∇ρ_wall/|∇ρ_wall|` pointing away from
/// the walls (the neighbours on the fluid side of the particle; on a lattice at `h = 2s`
/// next to a flat wall, the row one spacing further from it). 0 without wall or weight.
#[inline(always)]
fn neighbour_average(nb: &[u32], g: &[Vec3A], gw: Vector, pi: impl Fn(usize) -> Real) -> Real {
    if gw == Vector::ZERO {
        return 0.0;
    }
    let away = Vec3A::from(-gw.normalize());
    let (mut sw, mut swp) = (0.0, 0.0);
    for (&j, &g) in nb.iter().zip(g) {
        let w = g.dot(away).max(0.0);
        sw += w;
        swp += w * pi(j as usize);
    }
    if sw > 0.0 { swp / sw } else { 0.0 }
}

/// With hydrostatic walls ([`WallWorkspace::neighbour_pressure`]), the wall's pressure
/// value of sorted particle `i` for the pressure values `pi(j)` (see
/// [`WallWorkspace::neighbour_pressure`]), from the neighbour lists and the pair gradients
/// of the current substep: the body coupling passes the wall's force on to the bodies with
/// it. 0 when the walls do not take their pressure from the neighbours.
pub(crate) fn wall_neighbour_pressure(
    neighbors: &NeighborLists,
    grads: &PairGradients,
    wall: &WallWorkspace,
    i: usize,
    pi: impl Fn(usize) -> Real,
) -> Real {
    if !wall.neighbour_pressure {
        return 0.0;
    }
    let (c, k) = (i / CHUNK, i % CHUNK);
    let (offsets, indices) = neighbors.chunk(c);
    let (s, e) = (offsets[k] as usize, offsets[k + 1] as usize);
    neighbour_average(
        &indices[s..e],
        &grads.chunk(c).grad[s..e],
        wall.gradient[i],
        pi,
    )
}

/// Pass B of an iteration: `v_i −= dt·(Σ_j m (π_i + π_j) ∇W_ij + π_i ∇ρ_wall,i)` (the walls'
/// neighbour part with `neighbour`).
fn apply_pressure(ctx: &SolveContext<'_>, neighbour: bool, pi: &[Real], velocities: &mut [Vec3A]) {
    let pusher = Pusher {
        mass: ctx.mass,
        wall: ctx.wall,
        neighbour,
        dt: ctx.dt,
        ratio: ctx.ratio,
    };
    crate::par_chunks_mut!(velocities, CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            crate::par::wide(
                #[inline(always)]
                || {
                    let (offsets, indices) = ctx.neighbors.chunk(c);
                    let gc = &ctx.gradients.chunk(c).grad;
                    for (k, v) in out.iter_mut().enumerate() {
                        let (s, e) = (offsets[k] as usize, offsets[k + 1] as usize);
                        *v -= pusher.push(&indices[s..e], &gc[s..e], pi, c * CHUNK + k);
                    }
                },
            );
        });
}

/// Adds the viscosity acceleration (Müller et al. 2003, as
/// [`crate::forces::viscosity::add_accelerations`]) to `accelerations`,
/// `a_i += ε m/ρ_i Σ_j (v_j − v_i)/ρ_j ∇²W_v(|x_i − x_j|)` (`em` = `ε·m`), from the
/// Laplacians stored by [`density_and_factors`] (with viscosity) in `pairs`: a gather of
/// velocities and densities, with no distance or kernel evaluated; limited where the explicit
/// update over the substep `dt` would overshoot (`forces::viscosity`, "The explicit limit").
/// `wide` is scratch for a 16-byte copy of the velocities. Returns how many particles were
/// limited.
pub(crate) fn viscosity(
    (neighbors, pairs): (&NeighborLists, &PairGradients),
    (velocities, inv_densities): (&[Vector], &[Real]),
    (em, dt): (Real, Real),
    wide: &mut Vec<Vec3A>,
    accelerations: &mut [Vector],
) -> usize {
    use crate::forces::viscosity::{AtomicMax, MAX_EXCHANGE, limit};
    wide.clear();
    wide.extend(velocities.iter().map(|&v| Vec3A::from(v)));
    let wv: &[Vec3A] = wide;
    let largest = AtomicMax::default();
    crate::par_chunks_mut!(accelerations, CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            let most = crate::par::wide(
                #[inline(always)]
                || {
                    let (offsets, indices) = neighbors.chunk(c);
                    let lap = &pairs.chunk(c).laplacian;
                    let mut most: Real = 0.0;
                    for (k, a) in out.iter_mut().enumerate() {
                        let i = c * CHUNK + k;
                        let vi = wv[i];
                        let (s, e) = (offsets[k] as usize, offsets[k + 1] as usize);
                        let f = pair_sum(&indices[s..e], &lap[s..e], |j, lap| {
                            (wv[j] - vi) * (lap * inv_densities[j])
                        });
                        *a += Vector::from(f) * (em * inv_densities[i]);
                        let w: Real = (indices[s..e].iter().zip(&lap[s..e]))
                            .map(|(&j, &l)| l * inv_densities[j as usize])
                            .sum();
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
    let weights = StoredWeights { neighbors, pairs };
    limit(
        &weights,
        (velocities, inv_densities),
        em * dt,
        em,
        accelerations,
    )
}

/// The Laplacians [`density_and_factors`] stored, as the viscosity limit's weights.
struct StoredWeights<'a> {
    neighbors: &'a NeighborLists,
    pairs: &'a PairGradients,
}

impl crate::forces::viscosity::PairWeights for StoredWeights<'_> {
    fn each(&self, i: usize, mut f: impl FnMut(usize, Real)) {
        let (c, k) = (i / CHUNK, i % CHUNK);
        let (offsets, indices) = self.neighbors.chunk(c);
        let lap = &self.pairs.chunk(c).laplacian;
        let (s, e) = (offsets[k] as usize, offsets[k + 1] as usize);
        for (&j, &l) in indices[s..e].iter().zip(&lap[s..e]) {
            f(j as usize, l);
        }
    }
}

/// Inputs shared by both solves.
pub(crate) struct SolveContext<'a> {
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
    /// Interacting fluids: each particle's factor `m_ref/m_i` on its pushes (`None` for one
    /// fluid; see `crate::fluid::interaction`).
    pub ratio: Option<&'a [Real]>,
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
    /// the box fix the true density at `ρ0`), and the one-sided solve can remove that mean
    /// only through the near-null mode: it runs to its iteration cap and piles up a uniform
    /// pressure (measured in the Taylor–Green vortex, N = 12, dt = 0.02: 180 → 890 within
    /// four steps, where the vortex's own pressure is ±0.4), which then turns the particles'
    /// disorder into kinetic energy (E: 0.03 → 1.3 in two steps; the warm start carries 75 %
    /// of it into each next step). So the conditions are the incompressible ones of a
    /// periodic pressure Poisson problem: the residual's mean is its compatibility part, which
    /// no pressure corrects, and is left out; the pressure's level (the gauge) is fixed at
    /// zero mean; both signs are solved for (the one-sided clamp exists for free surfaces,
    /// and there is none). The warm start carries every value (the solve can take back what
    /// over-corrects).
    pub closed: bool,
    /// A particle's own share of its density, `m·W(0)` (for
    /// [`WallWorkspace::pinched`]).
    pub self_density: Real,
}

/// `true` when a fluid of `n` particles of `mass` in `domain` has no free surface: the domain
/// is periodic, no wall term is present (`walls = false`), and the particles' rest volume
/// `n·m/ρ0` is the box's volume to within `tolerance` (the density solve's own
/// `max_density_error`). Such a fluid is enclosed by its own periodic images.
pub(crate) fn fills_periodic_box(
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
    /// Already applied by [`density_and_factors`] (see [`divergence_warm_start`]); `true` when
    /// something was pushed, `buffers.velocities` then holds the pushed velocities.
    Pushed(bool),
    /// This fraction of the values of particles that compress without pressure, zero for
    /// the others ([`Dfsph::warm_start`]).
    WhereCompressing(Real),
    /// Every particle's whole value ([`Dfsph::full_warm_start`]); what over-corrects is taken
    /// back by the iterations ([`Solve::projected`]). Pinched particles start from zero.
    Full,
}

/// What a solve asks of [`jacobi`].
struct Solve {
    /// How the previous step's values are reused.
    warm_start: WarmStart,
    /// Iterations run at least, and at most.
    iterations: (u32, u32),
    /// Average error to reach.
    target: Real,
    /// Turns `Σ error_i / n` into the error compared with `target`.
    error_scale: Real,
    /// `1/dt²` (density) or `1/dt` (divergence): a closed box's increments
    /// ([`closed_increments`]).
    gain: Real,
    /// Signed increments, each clamped so that the particle's summed value stays `≥ 0`
    /// (projected Jacobi, [`Dfsph::full_warm_start`]); `false`: `finish` decides.
    projected: bool,
}

/// The Jacobi loop both solves share: warm start from the previous pressure values (section
/// 4.4) as `solve.warm_start` says (never all of them while the increments are never
/// negative, since the whole value could then only grow; a closed box and a projected solve
/// carry all of them, see [`SolveContext::closed`] and `Solve::projected`), then rate pass → error check → velocity update until the
/// average error, `Σ error_i / n` times `error_scale`, is at most `target` (after the least
/// number of iterations), or the cap binds. `finish(α, i, Dρ_i/Dt) = (π increment,
/// error_i)`. `warm` ends as this step's summed pressure.
fn jacobi<F: Fn(&[Real], usize, Real) -> (Real, Real) + Sync>(
    ctx: &SolveContext<'_>,
    solve: Solve,
    buffers: &mut DfsphBuffers,
    warm: &mut [Real],
    velocities: &mut [Vector],
    finish: F,
) -> SolveStats {
    let n = ctx.positions.len();
    buffers.resize(n);
    // Hydrostatic walls: track what the walls' neighbour part is applied with.
    let track = ctx.wall.is_some_and(|w| w.neighbour_pressure);
    if track {
        buffers.applied_neighbour.resize(n, 0.0);
    }
    let DfsphBuffers {
        alpha,
        pi,
        partials,
        velocities: wide,
        relaxation_halvings,
        applied_neighbour,
    } = buffers;
    // The passes work on a 16-byte copy of the velocities (see [`PairGradients`]).
    if !matches!(solve.warm_start, WarmStart::Pushed(true)) {
        for (w, &v) in wide.iter_mut().zip(velocities.iter()) {
            *w = Vec3A::from(v);
        }
    }
    let mut it = Jacobi {
        ctx,
        alpha,
        pi,
        partials,
        wide,
        applied: track.then_some(&mut applied_neighbour[..]),
        finish,
    };
    it.warm_start(solve.warm_start, warm);
    let stats = it.iterate(&solve, relaxation_halvings, warm);
    for (v, &w) in velocities.iter_mut().zip(it.wide.iter()) {
        *v = Vector::from(w);
    }
    stats
}

/// One solve's iteration state: the context, the factors, the iteration's values `π`, the
/// per-chunk partial sums, the 16-byte velocities being corrected, and with hydrostatic walls
/// the values the walls' neighbour part has been applied with.
struct Jacobi<'a, F> {
    ctx: &'a SolveContext<'a>,
    alpha: &'a [Real],
    pi: &'a mut [Real],
    partials: &'a mut [(f64, Real)],
    wide: &'a mut [Vec3A],
    applied: Option<&'a mut [Real]>,
    finish: F,
}

impl<F: Fn(&[Real], usize, Real) -> (Real, Real) + Sync> Jacobi<'_, F> {
    /// Pass A into `π` (see [`rate_pass`]).
    fn rate(&mut self) {
        let (alpha, finish) = (self.alpha, &self.finish);
        rate_pass(self.ctx, self.wide, self.pi, self.partials, |i, r| {
            finish(alpha, i, r)
        });
    }

    /// Pass B with the previous step's `values` (the walls' neighbour part included).
    fn apply_warm(&mut self, values: &[Real]) {
        apply_pressure(self.ctx, true, values, self.wide);
        if let Some(a) = self.applied.as_deref_mut() {
            add_to(a, values);
        }
    }

    /// The warm start (see [`WarmStart`]), applied to the velocities.
    fn warm_start(&mut self, warm_start: WarmStart, warm: &mut [Real]) {
        match warm_start {
            // Applied with the density pass (a closed box's mean removed before it).
            WarmStart::Pushed(_) => {}
            // Closed: the solve takes back what over-corrects, so every value is carried.
            WarmStart::WhereCompressing(fraction) if self.ctx.closed => {
                for w in warm.iter_mut() {
                    *w *= fraction;
                }
                remove_mean(warm);
                if warm.iter().any(|&w| w != 0.0) {
                    self.apply_warm(warm);
                }
            }
            WarmStart::Full if self.ctx.closed => {
                self.warm_start(WarmStart::WhereCompressing(1.0), warm)
            }
            WarmStart::Full => {
                if let Some(wall) = self.ctx.wall {
                    // Left out of the solve (see `WallWorkspace::pinched`): nothing would
                    // take their value back.
                    let (s, rho0) = (self.ctx.self_density, self.ctx.rest_density);
                    for (i, w) in warm.iter_mut().enumerate() {
                        if wall.pinched(i, s, rho0) {
                            *w = 0.0;
                        }
                    }
                }
                if warm.iter().any(|&w| w != 0.0) {
                    self.apply_warm(warm);
                }
            }
            WarmStart::WhereCompressing(fraction) => {
                if warm.iter().any(|&w| w != 0.0) {
                    // One rate pass without any pressure: which particles still compress.
                    self.rate();
                    for (w, &p) in warm.iter_mut().zip(self.pi.iter()) {
                        *w = if p > 0.0 { *w * fraction } else { 0.0 };
                    }
                    if warm.iter().any(|&w| w != 0.0) {
                        self.apply_warm(warm);
                    }
                }
            }
        }
    }

    /// Rate pass → error check → velocity update until the target or the cap (see
    /// [`jacobi`]); `halvings` is the fluid's relaxation count, `warm` sums the values.
    fn iterate(&mut self, solve: &Solve, halvings: &mut u32, warm: &mut [Real]) -> SolveStats {
        let ctx = self.ctx;
        let n = ctx.positions.len();
        let mut stats = SolveStats::default();
        let mut previous = Real::INFINITY;
        let mut neighbour = true;
        loop {
            self.rate();
            let sum = if ctx.closed {
                closed_increments(self.pi, self.alpha, solve.gain)
            } else {
                reduce_partials(self.partials).0
            };
            stats.error = (sum / n as f64) as Real * solve.error_scale;
            // A closed box's update is relaxed already (`CLOSED_RELAXATION`).
            if !ctx.closed {
                let diverging = stats.error > previous;
                previous = stats.error;
                // Diverging with hydrostatic walls: the rest of the solve without the walls'
                // neighbour part (see `DfsphBuffers::applied_neighbour`).
                if diverging && self.applied.is_some() && neighbour {
                    neighbour = false;
                    stats.neighbour_dropped = true;
                }
                self.relax(diverging, halvings);
            }
            let done = stats.error <= solve.target;
            let (min_iterations, max_iterations) = solve.iterations;
            if (done && stats.iterations >= min_iterations) || stats.iterations >= max_iterations {
                stats.capped = !done;
                break;
            }
            if solve.projected {
                for (p, &w) in self.pi.iter_mut().zip(warm.iter()) {
                    *p = p.max(-w);
                }
            }
            apply_pressure(ctx, neighbour, self.pi, self.wide);
            for (w, p) in warm.iter_mut().zip(self.pi.iter()) {
                *w += p;
            }
            if neighbour && let Some(a) = self.applied.as_deref_mut() {
                add_to(a, self.pi);
            }
            stats.iterations += 1;
        }
        stats
    }

    /// The iteration diverging: halve the relaxation (see `MAX_RELAXATION_HALVINGS`); the
    /// increments `π` scaled by the relaxation.
    fn relax(&mut self, diverging: bool, halvings: &mut u32) {
        if diverging && *halvings < MAX_RELAXATION_HALVINGS {
            *halvings += 1;
        }
        if *halvings > 0 {
            let omega = super::relaxation(*halvings);
            for p in self.pi.iter_mut() {
                *p *= omega;
            }
        }
    }
}

/// `sum[i] += values[i]`.
fn add_to(sum: &mut [Real], values: &[Real]) {
    for (s, v) in sum.iter_mut().zip(values) {
        *s += v;
    }
}

/// Halves the previous step's divergence pressure values `warm` (the divergence solve's
/// warm start, section 4.4: its values are small and noisy), removes their mean in a fluid
/// that fills a periodic box (`closed`, see [`SolveContext::closed`]), and says whether any
/// is left to apply, i.e. whether [`density_and_factors`] should be given a [`WarmPush`].
pub(crate) fn divergence_warm_start(warm: &mut [Real], closed: bool) -> bool {
    for w in warm.iter_mut() {
        *w *= 0.5;
    }
    if closed {
        remove_mean(warm);
    }
    warm.iter().any(|&w| w != 0.0)
}

/// Divergence solve (Alg. 2): corrects `velocities` until `Dρ/Dt ≈ 0`. `warm` holds the
/// warm start on entry, already applied (see [`divergence_warm_start`]; `pushed` is its
/// result, and then `buffers.velocities` holds the pushed velocities), and this step's sum
/// on exit.
pub(crate) fn divergence_solve(
    ctx: &SolveContext<'_>,
    settings: &Dfsph,
    buffers: &mut DfsphBuffers,
    pushed: bool,
    warm: &mut [Real],
    velocities: &mut [Vector],
) -> SolveStats {
    let dt = ctx.dt;
    let coverage = ctx.wall.map(|w| &w.coverage[..]);
    let expected = ctx.expected_neighbours;
    let solve = Solve {
        warm_start: WarmStart::Pushed(pushed),
        iterations: (settings.min_divergence_iterations, settings.max_iterations),
        target: settings.max_divergence_error,
        error_scale: dt / ctx.rest_density,
        gain: 1.0 / dt,
        projected: false,
    };
    jacobi(ctx, solve, buffers, warm, velocities, |alpha, i, rate| {
        if ctx.closed {
            return (rate, rate);
        }
        // Surface particles (few neighbours, walls counted by their coverage) are left
        // out: their density deficit is not compression.
        let count = ctx.neighbors.of(i).len() as Real + coverage.map_or(0.0, |c| c[i] * expected);
        // Pinched particles (see `WallWorkspace::pinched`) are left out too.
        let pinched = ctx
            .wall
            .is_some_and(|w| w.pinched(i, ctx.self_density, ctx.rest_density));
        let r = if count < 0.6 * expected || pinched {
            0.0
        } else {
            rate.max(0.0)
        };
        (r * alpha[i] / dt, r)
    })
}

/// Constant-density solve (Alg. 3): corrects the predicted `velocities` until the density they
/// lead to after `dt` is `ρ0` on average to within `max_density_error`. `warm` holds the
/// previous step's pressure values on entry (applied as [`Dfsph::warm_start`] and
/// [`Dfsph::full_warm_start`] say) and this step's sum on exit (the pressure).
///
/// With `full_warm_start` the iteration is projected Jacobi on the free surface's
/// complementarity condition (pressure `π_i ≥ 0`, and `ρ_i = ρ0` where `π_i > 0`), as IISPH
/// clamps its pressure (Ihmsen et al. 2014): a particle predicted under-dense gets a negative
/// increment, clamped so that its summed value stays `≥ 0`; the error counted is compression
/// only. Without it (Bender & Koschier's form) the source is clamped instead, increments are
/// never negative, and a warm start cannot be taken back: hence the partial, masked one.
pub(crate) fn density_solve(
    ctx: &SolveContext<'_>,
    settings: &Dfsph,
    buffers: &mut DfsphBuffers,
    warm: &mut [Real],
    velocities: &mut [Vector],
) -> SolveStats {
    let (dt, rho0, densities) = (ctx.dt, ctx.rest_density, ctx.densities);
    let inv_dt2 = 1.0 / (dt * dt);
    let projected = settings.full_warm_start && !ctx.closed;
    let solve = Solve {
        warm_start: if settings.full_warm_start {
            WarmStart::Full
        } else {
            WarmStart::WhereCompressing(settings.warm_start)
        },
        iterations: (settings.min_iterations, settings.max_iterations),
        target: settings.max_density_error,
        error_scale: 1.0 / rho0,
        gain: inv_dt2,
        projected,
    };
    jacobi(ctx, solve, buffers, warm, velocities, |alpha, i, rate| {
        if ctx.closed {
            let e = densities[i] + dt * rate - rho0;
            return (e, e);
        }
        // A pinched particle (see `WallWorkspace::pinched`) is left out.
        if ctx
            .wall
            .is_some_and(|w| w.pinched(i, ctx.self_density, rho0))
        {
            return (0.0, 0.0);
        }
        // Predicted density. Only compression is an error (a free surface is allowed to be
        // under-dense); projected, under-density lowers the pressure (not below zero, see
        // `Solve::projected`), else only compression is corrected.
        let predicted = densities[i] + dt * rate - rho0;
        if projected {
            return (predicted * alpha[i] * inv_dt2, predicted.max(0.0));
        }
        let excess = predicted.max(0.0);
        (excess * alpha[i] * inv_dt2, excess)
    })
}

/// Relaxation `ω` of the closed-box Jacobi update (see `SolveContext::closed`). With signed
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
