//! The two pressure solves (divergence, Alg. 2; constant density, Alg. 3): Jacobi
//! iterations with the DFSPH factor, warm starts, the relaxation safeguard, and the periodic
//! box's zero-mean form.

use super::super::pairs::{PairGradients, reduce_partials};
use super::{Dfsph, DfsphBuffers, MAX_RELAXATION_HALVINGS, SolveStats, apply_pressure, rate_pass};
use crate::boundary::WallWorkspace;
use crate::math::{Real, Vector};
use crate::neighbors::NeighborLists;
use rapier3d::glamx::Vec3A;

/// Inputs shared by both solves.
pub(crate) struct SolveContext<'a> {
    /// Sorted positions.
    pub positions: &'a [Vector],
    /// Neighbour lists of those positions.
    pub neighbors: &'a NeighborLists,
    /// Kernel gradients of every neighbour pair (from [`density_and_factors`](super::factors::density_and_factors)).
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
    /// The rate pass takes the walls' part of the rate as their predicted change over `dt`,
    /// `(ρ_wall(after dt) − ρ_wall)/dt`, from the walls' planes
    /// ([`WallWorkspace::predicted_density`], [`Dfsph::predict_walls`]); `false`: the
    /// instantaneous rate `(v_i − v_wall)·∇ρ_wall`.
    pub predict_walls: bool,
    /// With `predict_walls`: the contact radius; the rate pass then reads each particle's
    /// velocity as contact will leave it (`WallWorkspace::clip_velocities`).
    pub contact_radius: Option<Real>,
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
    /// Already applied by [`density_and_factors`](super::factors::density_and_factors) (see [`divergence_warm_start`]); `true` when
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
    /// Chebyshev semi-iterative acceleration with this spectral radius estimate
    /// ([`Dfsph::chebyshev`]; see [`Chebyshev`]).
    chebyshev: Option<Real>,
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
        rates,
        partials,
        velocities: wide,
        relaxation_halvings,
        applied_neighbour,
        clipped,
        previous,
    } = buffers;
    if solve.chebyshev.is_some() {
        previous.resize(n, 0.0);
    }
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
        rates,
        partials,
        wide,
        applied: track.then_some(&mut applied_neighbour[..]),
        clipped: Some(clipped),
        previous: solve.chebyshev.is_some().then_some(&mut previous[..]),
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
    rates: &'a mut [Real],
    partials: &'a mut [(f64, Real)],
    wide: &'a mut [Vec3A],
    applied: Option<&'a mut [Real]>,
    clipped: Option<&'a mut Vec<Vec3A>>,
    /// With Chebyshev acceleration: the last iteration's applied increments.
    previous: Option<&'a mut [Real]>,
    finish: F,
}

impl<F: Fn(&[Real], usize, Real) -> (Real, Real) + Sync> Jacobi<'_, F> {
    /// Pass A into `π` (see [`rate_pass`]).
    fn rate(&mut self) {
        let (alpha, finish) = (self.alpha, &self.finish);
        let ctx = self.ctx;
        // Predicting the walls: the velocities as contact will leave them.
        let velocities: &[Vec3A] = match (ctx.contact_radius, ctx.wall, self.clipped.as_deref_mut())
        {
            (Some(radius), Some(wall), Some(clipped)) => {
                wall.clip_velocities(self.wide, (ctx.dt, radius), clipped);
                clipped
            }
            _ => self.wide,
        };
        rate_pass(
            self.ctx,
            velocities,
            (&mut *self.pi, &mut *self.rates),
            self.partials,
            #[inline(always)]
            |i, r| finish(alpha, i, r),
        );
    }

    /// Pass B with the previous step's `values` (the walls' neighbour part included).
    fn apply_warm(&mut self, values: &[Real]) {
        apply_pressure(
            self.ctx,
            true,
            values,
            self.wide,
            (None, self.applied.as_deref_mut()),
        );
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
        let mut chebyshev = solve.chebyshev.map(Chebyshev::new);
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
                let mut diverging = stats.error > previous;
                previous = stats.error;
                // After an extrapolated step the error may grow without the iteration
                // diverging: the sequence restarts from a plain step, and only a plain step's
                // growth counts (see `Chebyshev`).
                if let Some(c) = chebyshev.as_mut()
                    && diverging
                    && c.restart()
                {
                    diverging = false;
                }
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
            if let (Some(c), Some(last)) = (chebyshev.as_mut(), self.previous.as_deref()) {
                c.extrapolate(self.pi, last);
            }
            if solve.projected {
                for (p, &w) in self.pi.iter_mut().zip(warm.iter()) {
                    *p = p.max(-w);
                }
            }
            if let Some(last) = self.previous.as_deref_mut() {
                last.copy_from_slice(self.pi);
            }
            let applied = self.applied.as_deref_mut().filter(|_| neighbour);
            apply_pressure(ctx, neighbour, self.pi, self.wide, (Some(warm), applied));
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
            let omega = super::super::relaxation(*halvings);
            for p in self.pi.iter_mut() {
                *p *= omega;
            }
        }
    }
}

/// Chebyshev semi-iterative acceleration of the Jacobi solve (Wang 2015, "A Chebyshev
/// semi-iterative approach for accelerating projective and position-based dynamics", ACM
/// TOG 34(6)): with `x_k` the summed values after iteration `k` and `x̂_{k+1} = x_k + δ_k`
/// the Jacobi update, `x_{k+1} = ω_{k+1}·(x̂_{k+1} − x_{k−1}) + x_{k−1}`, i.e. the applied
/// increment is `ω_{k+1}·δ_k + (ω_{k+1} − 1)·Δ_{k−1}` (`Δ_{k−1}` the previous applied
/// increment), with `ω_1 = 1`, `ω_2 = 2/(2 − ρ²)`, `ω_{k+1} = 4/(4 − ρ²·ω_k)` for the
/// spectral radius estimate `ρ`. The projected solve clamps the extrapolated value
/// (`x ≥ 0`) as Wang projects his. Safeguard: if the error grows after an extrapolated step,
/// the sequence restarts (`ω = 1`, a plain Jacobi step); only a plain step's growth is taken
/// as the iteration diverging (the relaxation halving, the walls' neighbour part dropped).
#[derive(Copy, Clone, Debug)]
struct Chebyshev {
    /// `ρ²`.
    rho2: Real,
    /// Steps taken in the current sequence (0: the next is a plain step).
    k: u32,
    /// The last step's `ω`.
    omega: Real,
}

impl Chebyshev {
    fn new(rho: Real) -> Self {
        Self {
            rho2: rho * rho,
            k: 0,
            omega: 1.0,
        }
    }

    /// The error grew: restarts the sequence; `true` if the last step was extrapolated.
    fn restart(&mut self) -> bool {
        let extrapolated = self.omega > 1.0;
        self.k = 0;
        self.omega = 1.0;
        extrapolated
    }

    /// Turns the Jacobi increments `pi` into this step's (see [`Chebyshev`]), `last` the
    /// previous step's applied ones.
    fn extrapolate(&mut self, pi: &mut [Real], last: &[Real]) {
        self.omega = match self.k {
            0 => 1.0,
            1 => 2.0 / (2.0 - self.rho2),
            _ => 4.0 / (4.0 - self.rho2 * self.omega),
        };
        self.k += 1;
        if self.omega > 1.0 {
            let (w, m) = (self.omega, self.omega - 1.0);
            for (p, &d) in pi.iter_mut().zip(last) {
                *p = w * *p + m * d;
            }
        }
    }
}

/// Halves the previous step's divergence pressure values `warm` (the divergence solve's
/// warm start, section 4.4: its values are small and noisy), removes their mean in a fluid
/// that fills a periodic box (`closed`, see [`SolveContext::closed`]), and says whether any
/// is left to apply, i.e. whether [`density_and_factors`](super::factors::density_and_factors) should be given a [`WarmPush`](super::WarmPush).
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
        chebyshev: None,
    };
    jacobi(
        ctx,
        solve,
        buffers,
        warm,
        velocities,
        #[inline(always)]
        |alpha, i, rate| {
            if ctx.closed {
                return (rate, rate);
            }
            // Surface particles (few neighbours, walls counted by their coverage) are left
            // out: their density deficit is not compression.
            let count =
                ctx.neighbors.of(i).len() as Real + coverage.map_or(0.0, |c| c[i] * expected);
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
        },
    )
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
    (warm, carried): (&mut [Real], Option<&[Real]>),
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
        chebyshev: settings.chebyshev.filter(|_| projected),
    };
    jacobi(
        ctx,
        solve,
        buffers,
        warm,
        velocities,
        #[inline(always)]
        |alpha, i, rate| {
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
            let mut predicted = densities[i] + dt * rate - rho0;
            if let Some(c) = carried {
                predicted += c[i];
            }
            if projected {
                return (predicted * alpha[i] * inv_dt2, predicted.max(0.0));
            }
            let excess = predicted.max(0.0);
            (excess * alpha[i] * inv_dt2, excess)
        },
    )
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
