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

use super::pairs::{GradientSlice, PairGradients};
use crate::boundary::WallWorkspace;
use crate::math::{Real, Vector};
use crate::neighbors::NeighborLists;
use crate::par::CHUNK;
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
    /// Each particle's `Dρ_i/Dt` from the last rate pass (the density solve's final
    /// prediction, see [`Dfsph::carry_density_error`]).
    pub rates: Vec<Real>,
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
    /// The velocities as contact will leave them (see `SolveContext::contact_radius`).
    pub clipped: Vec<Vec3A>,
    /// With [`Dfsph::chebyshev`]: the increment each particle's value received in the
    /// density solve's last iteration (the semi-iterative update's previous step).
    pub previous: Vec<Real>,
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

mod factors;
pub(crate) mod settings;
mod solve;
mod step;
pub(crate) use factors::{FactorInput, Factors, density_and_factors, phase_factors};
pub use settings::Dfsph;
pub use solve::CLOSED_RELAXATION;
pub(crate) use solve::{
    SolveContext, density_solve, divergence_solve, divergence_warm_start, fills_periodic_box,
};
pub(crate) use step::DfsphState;

impl DfsphBuffers {
    /// Sizes every array for `n` particles (no allocation once warm).
    pub fn resize(&mut self, n: usize) {
        self.alpha.resize(n, 0.0);
        self.pi.resize(n, 0.0);
        self.rates.resize(n, 0.0);
        self.partials.resize(n.div_ceil(CHUNK), (0.0, 0.0));
        self.velocities.resize(n, Vec3A::ZERO);
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        (self.alpha.capacity() + self.pi.capacity() + self.rates.capacity()) * 4
            + (self.applied_neighbour.capacity() + self.previous.capacity()) * 4
            + self.partials.capacity() * 16
            + (self.velocities.capacity() + self.clipped.capacity()) * std::mem::size_of::<Vec3A>()
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

/// A particle's values per pair (pair `t` at `at_unchecked(t)`): a slice, or the pair
/// gradients.
trait PairValues: Copy {
    /// The value of one pair.
    type T: Copy;
    /// Number of pairs.
    fn len(&self) -> usize;
    /// The value of pair `t`, without checking `t`.
    ///
    /// # Safety
    /// `t < self.len()`.
    unsafe fn at_unchecked(&self, t: usize) -> Self::T;
}

impl<T: Copy> PairValues for &[T] {
    type T = T;
    #[inline(always)]
    fn len(&self) -> usize {
        <[T]>::len(self)
    }
    #[inline(always)]
    unsafe fn at_unchecked(&self, t: usize) -> T {
        // SAFETY: the caller keeps `t < len`.
        unsafe { *self.get_unchecked(t) }
    }
}

impl PairValues for GradientSlice<'_> {
    type T = Vec3A;
    #[inline(always)]
    fn len(&self) -> usize {
        GradientSlice::len(self)
    }
    #[inline(always)]
    unsafe fn at_unchecked(&self, t: usize) -> Vec3A {
        // SAFETY: the caller keeps `t < len`.
        unsafe { GradientSlice::at_unchecked(self, t) }
    }
}

/// What a pair pass reads of each neighbour `j`: one array's entry `a[j]`, or two arrays'
/// `(a[j], b[j])`.
trait Gather: Copy {
    /// The entries of one neighbour.
    type T: Copy;
    /// The neighbour's entries, unchecked.
    ///
    /// # Safety
    /// `j` is below the length of every array gathered from.
    unsafe fn get(&self, j: usize) -> Self::T;
}

impl<T: Copy> Gather for &[T] {
    type T = T;
    #[inline(always)]
    unsafe fn get(&self, j: usize) -> T {
        // SAFETY: the caller keeps `j < len`.
        unsafe { *self.get_unchecked(j) }
    }
}

impl<A: Copy, B: Copy> Gather for (&[A], &[B]) {
    type T = (A, B);
    #[inline(always)]
    unsafe fn get(&self, j: usize) -> (A, B) {
        // SAFETY: the caller keeps `j` below both lengths.
        unsafe { (*self.0.get_unchecked(j), *self.1.get_unchecked(j)) }
    }
}

/// `Σ_t term(gathered[nb[t]], values[t])` over a particle's pairs, pair `t` into accumulator
/// `t % ACC`, summed as `(a0 + a1) + (a2 + a3)`: independent add chains, and a fixed order,
/// so the result depends on the data only. The terms run over 16-byte vectors (one packed
/// operation per component-wise step); only their `x, y, z` lanes are meaningful. Neither
/// the pair values nor the gathered entries are bounds-checked per pair: in the solves'
/// passes the two checks were half of the inner loop's instructions (docs/performance.md,
/// "Roofline of the pair passes (measured)").
///
/// # Safety
/// Every index in `nb` is below the length of every array `gathered` reads (true of a
/// particle's list in a [`NeighborLists`] of that many particles: see
/// [`NeighborLists::len`]).
#[inline(always)]
unsafe fn pair_sum_gather<V: PairValues, G: Gather>(
    nb: &[u32],
    values: V,
    gathered: G,
    term: impl Fn(G::T, V::T) -> Vec3A,
) -> Vec3A {
    assert_eq!(values.len(), nb.len(), "one value per pair");
    // SAFETY (both reads below): `t < nb.len() = values.len()`, and the caller keeps every
    // `nb[t]` below the gathered arrays' lengths.
    let get = |t: usize, j: u32| unsafe { (gathered.get(j as usize), values.at_unchecked(t)) };
    let mut acc = [Vec3A::ZERO; ACC];
    let full = nb.len() / ACC * ACC;
    for (b, j) in nb[..full].chunks_exact(ACC).enumerate() {
        for l in 0..ACC {
            let (x, v) = get(b * ACC + l, j[l]);
            acc[l] += term(x, v);
        }
    }
    for (l, &j) in nb[full..].iter().enumerate() {
        let (x, v) = get(full + l, j);
        acc[l] += term(x, v);
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

/// Pass A of an iteration: the rate of change of every particle's density under the current
/// velocities, `Dρ_i/Dt = Σ_j m (v_i − v_j)·∇W_ij + (v_i − v_wall)·∇ρ_wall,i` (eq. 6), into
/// `rates` and handed to `finish(i, rate)`, which returns `(π_i, error_i)`. Writes `π`; returns the per-chunk error
/// sums into `partials`.
fn rate_pass<F: Fn(usize, Real) -> (Real, Real) + Sync>(
    ctx: &SolveContext<'_>,
    velocities: &[Vec3A],
    (pi, rates): (&mut [Real], &mut [Real]),
    partials: &mut [(f64, Real)],
    finish: F,
) {
    let (mass, wall) = (ctx.mass, ctx.wall);
    let predict = ctx.predict_walls.then_some(ctx.dt);
    // Every neighbour index is below the lists' particle count (`NeighborLists::len`).
    assert_eq!(
        ctx.neighbors.len(),
        velocities.len(),
        "one velocity per particle"
    );
    crate::par_chunks_mut!(pi, CHUNK)
        .zip(crate::par_iter_mut!(partials))
        .zip(crate::par_chunks_mut!(rates, CHUNK))
        .enumerate()
        .for_each(|(c, ((pi, partial), rates))| {
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
                        // SAFETY: a list of `ctx.neighbors`, built for `velocities.len()`
                        // particles (asserted above).
                        let a = unsafe {
                            pair_sum_gather(&indices[s..e], gc.range(s, e), velocities, |vj, g| {
                                (vi - vj) * g
                            })
                        };
                        let mut rate = (a.x + a.y + a.z) * mass;
                        if let Some(wall) = wall {
                            let vi = Vector::from(vi);
                            rate += match predict
                                .and_then(|dt| Some((wall.predicted_density(i, vi, dt)?, dt)))
                            {
                                Some((after, dt)) => (after - wall.density[i]) / dt,
                                None => vi.dot(wall.gradient[i]) - wall.motion[i],
                            };
                        }
                        let (p, e) = finish(i, rate);
                        pi[k] = p;
                        rates[k] = rate;
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
    /// change particle `i`'s velocity over `dt` (subtracted), from its neighbours `nb`, their
    /// gradients `g` and, with hydrostatic walls, the pairs' wall weights `weights` and
    /// their sum (see [`wall_weights`]; empty slices without).
    ///
    /// # Safety
    /// Every index in `nb` is `< pi.len()` (a list of a [`NeighborLists`] of `pi.len()`
    /// particles).
    #[inline(always)]
    unsafe fn push(
        &self,
        (nb, g): (&[u32], GradientSlice<'_>),
        weights: (&[Real], Real),
        pi: &[Real],
        i: usize,
    ) -> Vec3A {
        let pii = pi[i];
        let average = self.neighbour && self.wall.is_some_and(|w| w.neighbour_pressure);
        // SAFETY: the caller keeps every index of `nb` below `pi.len()`.
        let (f, swp) = unsafe {
            if average && weights.1 > 0.0 {
                pair_sum_weighted(nb, g, weights.0, pi, pii)
            } else {
                (pair_sum_gather(nb, g, pi, |pj, g| g * (pii + pj)), 0.0)
            }
        };
        let mut dv = Vector::from(f) * (self.dt * self.mass);
        if let Some(wall) = self.wall {
            let gw = wall.gradient[i];
            let mut wall_pi = wall.mirror * pii;
            if average {
                wall_pi += weighted_average(swp, weights.1);
            }
            dv += gw * (wall_pi * self.dt);
        }
        if let Some(r) = self.ratio {
            dv *= r[i];
        }
        Vec3A::from(dv)
    }
}

/// [`pair_sum_gather`] of `g·(π_i + π_j)` (the same accumulators and order, the same bits)
/// and, in the same loop, `Σ_t w_t·π_j` in pair order (the wall's neighbour average's
/// numerator, see [`weighted_average`]): each neighbour's value is gathered once. Unchecked
/// per pair, as [`pair_sum_gather`].
///
/// # Safety
/// Every index in `nb` is `< pi.len()`.
#[inline(always)]
unsafe fn pair_sum_weighted(
    nb: &[u32],
    g: GradientSlice<'_>,
    w: &[Real],
    pi: &[Real],
    pii: Real,
) -> (Vec3A, Real) {
    assert!(
        g.len() == nb.len() && w.len() == nb.len(),
        "one value per pair"
    );
    // SAFETY (both reads below): `t < nb.len() = g.len()`, and the caller keeps every
    // `nb[t] < pi.len()`.
    let get = |t: usize, j: u32| unsafe { (*pi.get_unchecked(j as usize), g.at_unchecked(t)) };
    let mut acc = [Vec3A::ZERO; ACC];
    let mut swp: Real = 0.0;
    let full = nb.len() / ACC * ACC;
    for (b, (j, wv)) in nb[..full]
        .chunks_exact(ACC)
        .zip(w[..full].chunks_exact(ACC))
        .enumerate()
    {
        for l in 0..ACC {
            let (p, gt) = get(b * ACC + l, j[l]);
            acc[l] += gt * (pii + p);
            swp += wv[l] * p;
        }
    }
    let rest = nb[full..].iter().zip(&w[full..]);
    for (l, (&j, &wv)) in rest.enumerate() {
        let (p, gt) = get(full + l, j);
        acc[l] += gt * (pii + p);
        swp += wv * p;
    }
    ((acc[0] + acc[1]) + (acc[2] + acc[3]), swp)
}

/// The weights of the wall's pressure value `π̂_i` with hydrostatic walls, written into `out`
/// pair by pair: `max(0, ∇W_ij·û)`, `û = −∇ρ_wall/|∇ρ_wall|` pointing away from the walls
/// (the neighbours on the fluid side of the particle; on a lattice at `h = 2s` next to a
/// flat wall, the row one spacing further from it); returns their sum, 0 without wall
/// gradient. `π̂_i` is then the neighbours' values averaged with them
/// ([`weighted_average`]). They depend on the substep's gradients only: computed once by the
/// density pass ([`density_and_factors`]), read by every iteration.
#[inline(always)]
fn wall_weights(g: GradientSlice<'_>, gw: Vector, out: &mut [Real]) -> Real {
    if gw == Vector::ZERO {
        out.fill(0.0);
        return 0.0;
    }
    let away = Vec3A::from(-gw.normalize());
    let mut sw = 0.0;
    assert_eq!(out.len(), g.len(), "one weight per pair");
    for (t, o) in out.iter_mut().enumerate() {
        let w = g.at(t).dot(away).max(0.0);
        *o = w;
        sw += w;
    }
    sw
}

/// `π̂_i = Σ_t w_t·π_j / Σ_t w_t` from the numerator `swp` and the weights' sum `sw` (see
/// [`wall_weights`]); 0 without weight.
#[inline(always)]
fn weighted_average(swp: Real, sw: Real) -> Real {
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
    let gc = grads.chunk(c);
    let mut swp: Real = 0.0;
    for (&j, &w) in indices[s..e].iter().zip(&gc.wall_weight[s..e]) {
        swp += w * pi(j as usize);
    }
    weighted_average(swp, gc.wall_weight_sum[k])
}

/// Pass B of an iteration: `v_i −= dt·(Σ_j m (π_i + π_j) ∇W_ij + π_i ∇ρ_wall,i)` (the walls'
/// neighbour part with `neighbour`), and `sum[i] += π_i` for each of `sums` given (the
/// solve's summed values, the walls' applied ones) in the same parallel pass: as serial loops
/// after it they left one thread idle.
fn apply_pressure(
    ctx: &SolveContext<'_>,
    neighbour: bool,
    pi: &[Real],
    velocities: &mut [Vec3A],
    sums: (Option<&mut [Real]>, Option<&mut [Real]>),
) {
    let pusher = Pusher {
        mass: ctx.mass,
        wall: ctx.wall,
        neighbour,
        dt: ctx.dt,
        ratio: ctx.ratio,
    };
    // Every neighbour index is below the lists' particle count (`NeighborLists::len`).
    assert_eq!(
        ctx.neighbors.len(),
        pi.len(),
        "one pressure value per particle"
    );
    let chunk = |c: usize, out: &mut [Vec3A], a: Option<&mut [Real]>, b: Option<&mut [Real]>| {
        crate::par::wide(
            #[inline(always)]
            || {
                let (offsets, indices) = ctx.neighbors.chunk(c);
                let gc = ctx.gradients.chunk(c);
                let weighted = !gc.wall_weight_sum.is_empty();
                for (k, v) in out.iter_mut().enumerate() {
                    let (s, e) = (offsets[k] as usize, offsets[k + 1] as usize);
                    let weights = match weighted {
                        true => (&gc.wall_weight[s..e], gc.wall_weight_sum[k]),
                        false => (&[][..], 0.0),
                    };
                    let pairs = (&indices[s..e], gc.grad.range(s, e));
                    // SAFETY: a list of `ctx.neighbors`, built for `pi.len()` particles
                    // (asserted above).
                    *v -= unsafe { pusher.push(pairs, weights, pi, c * CHUNK + k) };
                }
            },
        );
        let own = &pi[c * CHUNK..][..out.len()];
        for sum in [a, b].into_iter().flatten() {
            for (s, &p) in sum.iter_mut().zip(own) {
                *s += p;
            }
        }
    };
    let chunks = crate::par_chunks_mut!(velocities, CHUNK);
    match sums {
        (Some(a), Some(b)) => chunks
            .zip(crate::par_chunks_mut!(a, CHUNK))
            .zip(crate::par_chunks_mut!(b, CHUNK))
            .enumerate()
            .for_each(|(c, ((out, a), b))| chunk(c, out, Some(a), Some(b))),
        (Some(a), None) | (None, Some(a)) => chunks
            .zip(crate::par_chunks_mut!(a, CHUNK))
            .enumerate()
            .for_each(|(c, (out, a))| chunk(c, out, Some(a), None)),
        (None, None) => chunks
            .enumerate()
            .for_each(|(c, out)| chunk(c, out, None, None)),
    }
}

/// Adds the viscosity acceleration (Müller et al. 2003, as
/// [`crate::forces::viscosity::add_accelerations`]) to `accelerations`,
/// `a_i += ε m/ρ_i Σ_j (v_j − v_i)/ρ_j ∇²W_v(|x_i − x_j|)` (`em` = `ε·m`), from the
/// Laplacians stored by [`density_and_factors`] (with viscosity) in `pairs`: a gather of
/// velocities and densities (unchecked per pair, as [`pair_sum_gather`]; the lists' length
/// asserted once), with no distance or kernel evaluated; limited where the explicit
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
    // Every neighbour index is below the lists' particle count (`NeighborLists::len`).
    assert!(
        neighbors.len() == wv.len() && inv_densities.len() == wv.len(),
        "one velocity and one density per particle"
    );
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
                        let (nb, lap) = (&indices[s..e], &lap[s..e]);
                        // SAFETY: a list of `neighbors`, built for `wv.len()` =
                        // `inv_densities.len()` particles (asserted above).
                        let f = unsafe {
                            pair_sum_gather(nb, lap, (wv, inv_densities), |(vj, ij), lap| {
                                (vj - vi) * (lap * ij)
                            })
                        };
                        *a += Vector::from(f) * (em * inv_densities[i]);
                        // SAFETY: as above.
                        let w: Real = (nb.iter().zip(lap))
                            .map(|(&j, &l)| l * unsafe { *inv_densities.get_unchecked(j as usize) })
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
