//! A mixture of liquids in one fluid: every particle carries the volume fractions of several
//! phases (oil and water, a slurry, a dressing), and the phases separate by drifting
//! through the particles, not by particles passing each other.
//!
//! Opt-in per fluid with [`FluidParams::mixture`](crate::FluidParams::mixture) (DFSPH only for now); a fluid without it
//! pays one check per substep. The fractions are read and written with
//! [`crate::Fluid::fractions`], [`crate::Fluid::fractions_mut`] and
//! [`crate::Fluid::set_fractions`]; new particles (added, emitted) are pure phase 0.
//!
//! # The model
//!
//! Ren, Li, Yan, Lin & Hu 2014, "Multiple-fluid SPH simulation using a mixture model" (ACM
//! TOG 33(5)), the mixture model of multiphase flow (Manninen et al. 1996) on particles:
//! particle `i` holds fractions `α_k,i` of phases `k` (`Σ_k α_k,i = 1`), each phase with its
//! rest density `ρ_k` and viscosity `ε_k`. Its rest density is `ρ0_i = Σ_k α_k,i ρ_k`, its
//! viscosity `Σ_k α_k,i ε_k`, and its volume is the fluid's particle volume
//! `V = particle_mass/rest_density` whatever its fractions, so its mass is `V·ρ0_i`. The
//! solver holds every particle at its own rest density with the number-density form of
//! interacting liquids (`crate::fluid::interaction`: Solenthaler & Pajarola 2008; each
//! particle's factor `r_i = ρ_ref/ρ0_i` on its pair accelerations, `√(ε_i/ε)` on its
//! viscosity), recomputed from the fractions at every substep.
//!
//! Relative to the particle, phase `k` drifts with (Ren et al. eq. 9, the diffusion term
//! written as a diffusivity):
//!
//! ```text
//! u_k = τ·(ρ_k − ρ0_i)·(g − a_i)  −  D·∇α_k/α_k
//! ```
//!
//! `τ` ([`Mixture::drift`], m³·s/kg) the phases' mobility, `a_i` the particle's acceleration
//! over the substep (`g − a` is what the pressure gradient holds up: a denser phase sinks
//! along it, in a spun tank outwards), `D` ([`Mixture::diffusivity`], m²/s; Ren et al.'s
//! `τ·σ`) the phases' mutual diffusion. For droplets of diameter `d` of one liquid in
//! another of viscosity `μ`, Stokes' law gives `τ = d²/(18μ)`: oil droplets of 1 mm in
//! water, `τ` = 5.6·10⁻⁵ m³·s/kg, drift at `τ·Δρ·g` = 0.11 m/s against the water.
//!
//! One departure from the paper: the drift is taken relative to the particle's
//! volume-averaged velocity (`Σ_k α_k u_k = 0`, since `Σ_k α_k (ρ_k − ρ0_i) = 0`), not the
//! mass average. The solver holds each particle's volume, so what phases exchange between
//! two particles is then a swap of equal volumes: no particle's volume changes, and no
//! pressure correction of the fractions is needed (Ren et al. correct the pressure after
//! their transport for the volume it moves).
//!
//! # The transport, conservative pair by pair
//!
//! `∂α_k/∂t = −∇·(α_k u_k)`. The drift flux `α_k u_k = τ·g·Σ_l α_k α_l (ρ_k − ρ_l)` is a
//! sum of swaps between phase pairs `(k, l)`: `k` moves along `τ(ρ_k − ρ_l)(g − a)`, `l`
//! the other way, at the rate `α_k α_l`. Between particles `i` and `j` (`e_ij` from `i` to
//! `j`, `|∇W_ij|` the pressure kernel's gradient), with `c = τ(ρ_k − ρ_l)·ḡ_ij·e_ij` and
//! `ḡ_ij` the pair's mean `g − a`, the phase `k` moves downwind and `l` upwind in the
//! volume fraction
//!
//! ```text
//! s = 2·V·|∇W_ij|·dt·|c|·α_k,donor·α_l,receiver      (donor: i when c > 0, j when c < 0)
//! ```
//!
//! (upwinded: a particle gives only the phase it holds, and receives only against a phase
//! the other holds; with uniform fractions it is SPH's symmetric divergence
//! `Σ_j V (J_i + J_j)·∇W_ij` of the flux). Every swap is one number added to one particle
//! and taken from the other, computed from the same operands in the same order in both
//! particles' loops, so each phase's total volume `V·Σ_i α_k,i` is conserved to round-off
//! and every particle keeps `Σ_k α_k = 1`. No swap crosses a wall or the free surface (there
//! is no particle there): closed tanks hold their phases.
//!
//! **Bounded.** A particle gives at most `α_k,i·T_i` of phase `k` per substep, `T_i = R_i +
//! Σ_j D·V·dt·∇²W_ij` with `R_i = Σ_j 2V|∇W_ij|·dt·τ·(ρ_max − ρ_min)·|ḡ_ij|` (the drift's
//! share) and the diffusion's share (`D·∇²α_k`, SPH's Laplacian with the viscosity kernel's,
//! the same weights for every phase, so `Σ_k α_k` stays 1); every pair's drift swaps and
//! diffusion exchange are scaled by `1/max(1, 2T_i, 2T_j)` (symmetric, so still
//! conservative), so a particle keeps at least half of each phase it holds: fractions stay
//! in `[0, 1]` without clipping, at any setting. The drift and the diffusion of a pair are
//! one net flux per phase, `φ_k`, computed in one pass from the substep's fractions. Last,
//! each particle's fractions are divided by their sum: exact arithmetic keeps it at 1, and
//! this takes off the round-off, which otherwise wanders (to 1.7·10⁻⁵ after 6 s of the tank
//! below); it moves each fraction by about one rounding, as the transport's own do.
//!
//! **Momentum.** A particle's mass `V·ρ0_i` follows its fractions, and what moves carries its
//! momentum: a pair's flux `φ_k` of phase `k` brings `V·ρ_k·φ_k` of mass at its donor's
//! velocity (upwind: `j`'s when `φ_k > 0` flows into `i`, `i`'s otherwise), the same bits
//! taken from the donor in its own loop; each particle's velocity becomes its new momentum
//! over its new mass, `v' = (ρ0_i·v_i + Σ_j Σ_k ρ_k φ_k v_up)/ρ0'_i`. So the transport
//! conserves the fluid's momentum to round-off, and it can only lose kinetic energy: a
//! particle's new velocity is a mass-weighted mean of its own (for what it keeps) and its
//! donors' (for what it receives), and by convexity `½m'|v'|²` is at most the sum of their
//! energies. The densities the fluid reports are each particle's own (`ρ0_i·V·δ_i`).
//!
//! # Measured
//!
//! A closed tank 0.1 m wide, 8 × 16 × 8 particles at 1.25 cm, the water preset (DFSPH,
//! ε = 0.5 for both phases), water (1000) and oil (800) at half each, `τ` = 5.56·10⁻⁵ m³·s/kg
//! (1 mm droplets: `w = τΔρg` = 0.109 m/s), `D` = 10⁻⁵ m²/s (`cargo test --release --test
//! mixture -- --nocapture`; the time series from `cargo run --release --example
//! mixture_probe`). A 50/50 mix separates in `H/w` (the mixed layer closes from both ends
//! at `w`): 1.83 s for the 0.2 m column.
//! - Every particle at 0.5: the oil fraction's slab profile rises through 0.5 at 0.0989 m
//!   after 2.75 s (1.5 `H/w`) and 0.0997 m at 5 s, for 0.1000 m from the volumes; from a
//!   checkerboard of pure particles (which interacting fluids leave at 0.19 m): 0.0981 and
//!   0.0982 m. With the drift off the uniform mix stays at 0.5 everywhere, and the
//!   checkerboard only diffuses (its profile crosses 0.5 at 0.008 m: noise).
//! - Each phase's volume changed by at most 2.2·10⁻⁸ of itself (over the first 2.75 s,
//!   1155 substeps, and over the next 945); `|Σ_k α_k − 1|` ≤ 6·10⁻⁸, the smallest fraction
//!   3·10⁻¹⁵ at 5 s (none below 0).
//! - The bottom pressure averaged from 1 s to 5 s against `ρ_oil·g·h_oil +
//!   ρ_water·g·h_water`: +0.44 % from the uniform start, −1.13 % from the checkerboard; the
//!   same tank without drift (one liquid of 900 kg/m³ in effect): +1.76 ± 0.95 % over five
//!   runs perturbed at round-off. The mixture adds no error of its own to DFSPH's.
//! - The interface's thickness (between the heights where the oil fraction's slab profile
//!   crosses 0.1 and 0.9): 0.019–0.021 m at 2.75 s, 0.018–0.019 m (1.5 spacings) at 5 s.
//!   Before the transport carried momentum (not re-measured since): 0.0175 m with `D` = 0,
//!   0.024–0.026 m with `D` = 10⁻⁴; one slab of particles across the interface holds both
//!   phases (0.21 oil at `D` = 10⁻⁵): the interface is as sharp as the particles resolve.
//! - Momentum, recorded over every substep's transport (`cargo test --release --lib
//!   the_transport_conserves_momentum -- --nocapture`): in a closed box without gravity (the
//!   checkerboard, 8 × 8 × 8, thrown at a wall at 1 m/s, 151 substeps) and in this tank
//!   (1 s, 420 substeps), `Σ m v` changes by at most 1.4·10⁻⁴ and 2.0·10⁻⁴ of the f32
//!   round-off bound the test derives; the kinetic energy does not grow beyond it. Keeping
//!   the velocities while the mass moves exceeds that bound 18× and 5.3×.
//! - 1 and 2 threads give the same bits.
//! - Cost: two pair passes per substep (the bounds, then the fluxes and their momentum),
//!   plain scalar loops that recompute each pair's distance; the solver's are vectorised.
//!   About half the step's time in this tank (`mixture_probe` prints it; docs/solvers.md
//!   has the figures).
//!
//! # What it does not do
//!
//! - No surface tension between the phases, and no sharp interface: the phases are miscible
//!   at the particle scale, and the interface is as thick as the drift against the
//!   diffusion (and the particles' spacing) makes it; a mixture is the model for emulsions
//!   and suspensions that separate, not for two liquids that keep a sharp interface (use
//!   interacting fluids, `crate::fluid::interaction`, for those).
//! - The drift is Stokes' dilute one at every fraction (no hindered settling).
//! - A fluid asleep ([`crate::Sleep`], off by default) does not drift: the sleep test
//!   watches the particles, not their fractions.
//! - DFSPH only (WCSPH, PBF and Clavet read the same per-particle factors but were not
//!   tested with it: refused); not in a group of interacting fluids; the explicit viscosity
//!   only; scalars are not carried by the phases (they stay with the particles).

use crate::domain::Separation;
use crate::error::{SphError, SphResult};
use crate::kernel::{Kernel, ViscosityLaplacian};
use crate::math::{Real, Vector};
use crate::neighbors::Pairs;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// The most phases a mixture may have.
pub const MAX_PHASES: usize = 8;

/// How far a particle's fractions may sum from 1, and each lie outside `[0, 1]` (the
/// fractions a game writes, and round-off over a long run: the transport keeps the sum to
/// a few 10⁻⁷ over hundreds of substeps).
pub const FRACTION_SUM_TOLERANCE: Real = 1e-3;

/// The prefix of the fractions' attribute names (`crate::fluid::Attributes`).
pub(crate) const PREFIX: &str = "mixture:";

/// The names of the fractions' attributes, `mixture:0` … (no allocation for the step).
const NAMES: [&str; MAX_PHASES] = ["0", "1", "2", "3", "4", "5", "6", "7"];

/// One phase of a [`Mixture`].
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub struct Phase {
    /// Rest density (kg/m³, positive).
    pub rest_density: Real,
    /// Viscosity `ε` of the explicit viscosity force (Pa·s, ≥ 0; see
    /// [`FluidParams::viscosity`](crate::FluidParams::viscosity)): a particle's is `Σ_k α_k ε_k`. At most the fluid's
    /// [`FluidParams::viscosity`](crate::FluidParams::viscosity), which sets the solvers' explicit limit
    /// ([`crate::FluidParamsBuilder::mixture`] sets it to the largest phase's).
    pub viscosity: Real,
}

/// Phases mixed in every particle of a fluid ([`FluidParams::mixture`](crate::FluidParams::mixture); see the module's
/// docs for the model).
///
/// # Examples
/// ```
/// use rapier_sph::mixture::{Mixture, Phase};
/// use rapier_sph::prelude::*;
/// let emulsion = Mixture {
///     phases: vec![
///         Phase { rest_density: 1000.0, viscosity: 0.5 }, // water
///         Phase { rest_density: 800.0, viscosity: 0.5 },  // oil
///     ],
///     drift: 5.6e-5,      // oil droplets of 1 mm in water: d²/(18μ)
///     diffusivity: 1e-5,
/// };
/// let params = FluidParamsBuilder::water(0.0125).mixture(emulsion).build()?;
/// let mut fluid = Fluid::new(params)?;
/// fluid.add_block(Vector::ZERO, Vector::splat(0.05))?;
/// fluid.set_fractions(&[0.5, 0.5])?; // every particle half oil
/// assert_eq!(fluid.fractions(1).unwrap()[0], 0.5);
/// # Ok::<(), rapier_sph::SphError>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub struct Mixture {
    /// The phases (2 to [`MAX_PHASES`]); phase 0 is what new particles are made of.
    pub phases: Vec<Phase>,
    /// The mobility `τ` (m³·s/kg, ≥ 0): a phase drifts at `τ·(ρ_k − ρ0_i)·(g − a)` relative
    /// to its particle; `d²/(18μ)` for droplets of diameter `d` in a liquid of viscosity `μ`.
    /// 0 switches the drift off (the phases only diffuse).
    pub drift: Real,
    /// The phases' mutual diffusivity `D` (m²/s, ≥ 0; Ren et al.'s `τ·σ`).
    pub diffusivity: Real,
}

fn invalid(field: &'static str, value: Real, reason: &'static str) -> SphError {
    SphError::InvalidParameter {
        field,
        value: value as f64,
        reason,
    }
}

impl Mixture {
    /// Oil (800 kg/m³) in water (1000 kg/m³), phases 1 and 0, both at the water preset's
    /// viscosity ε = 0.5 Pa·s ([`crate::FluidParamsBuilder::water`]), with the mobility
    /// `drift` (m³·s/kg; `d²/(18μ)` = 5.56·10⁻⁵ for droplets of 1 mm in water) and the
    /// `diffusivity` (m²/s).
    ///
    /// # Examples
    /// ```
    /// use rapier_sph::mixture::Mixture;
    /// use rapier_sph::prelude::*;
    /// let params = FluidParamsBuilder::water(0.0125)
    ///     .mixture(Mixture::oil_in_water(1e-6 / 18e-3, 1e-5))
    ///     .build()?;
    /// assert_eq!(params.mixture.unwrap().phases[1].rest_density, 800.0);
    /// # Ok::<(), rapier_sph::SphError>(())
    /// ```
    pub fn oil_in_water(drift: Real, diffusivity: Real) -> Self {
        Self {
            phases: vec![
                Phase {
                    rest_density: 1000.0,
                    viscosity: 0.5,
                },
                Phase {
                    rest_density: 800.0,
                    viscosity: 0.5,
                },
            ],
            drift,
            diffusivity,
        }
    }

    /// The number of phases.
    pub fn len(&self) -> usize {
        self.phases.len()
    }

    /// `false`: a mixture has at least two phases once validated.
    pub fn is_empty(&self) -> bool {
        self.phases.is_empty()
    }

    /// A particle's rest density from its fractions.
    pub fn rest_density(&self, fractions: &[Real]) -> Real {
        self.phases
            .iter()
            .zip(fractions)
            .map(|(p, a)| p.rest_density * a)
            .sum()
    }

    /// The largest phase viscosity.
    pub fn max_viscosity(&self) -> Real {
        self.phases.iter().map(|p| p.viscosity).fold(0.0, Real::max)
    }

    /// Checks the mixture against the fluid's rest density (the reference the solver's
    /// factors are taken from) and viscosity.
    ///
    /// # Errors
    /// [`SphError::InvalidParameter`] naming `mixture.phases` (fewer than two or more than
    /// [`MAX_PHASES`]), `mixture.rest_density` (not finite and positive, or a ratio of more
    /// than [`crate::fluid::interaction::MAX_DENSITY_RATIO`] between any two phases or a
    /// phase and the fluid), `mixture.viscosity` (negative, or above the fluid's),
    /// `mixture.drift` or `mixture.diffusivity` (negative or not finite).
    pub fn validate(&self, rest_density: Real, viscosity: Real) -> SphResult<()> {
        let n = self.phases.len();
        if !(2..=MAX_PHASES).contains(&n) {
            return Err(invalid(
                "mixture.phases",
                n as Real,
                "a mixture has 2 to MAX_PHASES (8) phases",
            ));
        }
        let (mut lo, mut hi) = (rest_density, rest_density);
        for p in &self.phases {
            if !(p.rest_density.is_finite() && p.rest_density > 0.0) {
                return Err(invalid(
                    "mixture.rest_density",
                    p.rest_density,
                    "a phase's rest density must be finite and positive",
                ));
            }
            if !(p.viscosity.is_finite() && p.viscosity >= 0.0) || p.viscosity > viscosity {
                return Err(invalid(
                    "mixture.viscosity",
                    p.viscosity,
                    "a phase's viscosity must be finite, non-negative and at most the fluid's",
                ));
            }
            lo = lo.min(p.rest_density);
            hi = hi.max(p.rest_density);
        }
        if hi > crate::fluid::interaction::MAX_DENSITY_RATIO * lo {
            return Err(invalid(
                "mixture.rest_density",
                hi / lo,
                "the phases' and the fluid's rest densities differ by more than MAX_DENSITY_RATIO (10)",
            ));
        }
        for (field, v) in [
            ("mixture.drift", self.drift),
            ("mixture.diffusivity", self.diffusivity),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(invalid(field, v, "must be finite and non-negative"));
            }
        }
        Ok(())
    }
}

/// The name of phase `k`'s attribute, after [`PREFIX`].
pub(crate) fn name(k: usize) -> &'static str {
    NAMES[k]
}

/// Checks one particle's fractions: each in `[0, 1]` and their sum 1, within
/// [`FRACTION_SUM_TOLERANCE`] (the transport's round-off leaves a fraction of 1 at
/// `1 + 2⁻²³` at times).
///
/// # Errors
/// [`SphError::InvalidParameter`] naming `mixture.fractions`.
pub(crate) fn check_fractions(fractions: impl Iterator<Item = Real>) -> SphResult<()> {
    let mut sum = 0.0;
    let range = -FRACTION_SUM_TOLERANCE..=1.0 + FRACTION_SUM_TOLERANCE;
    for a in fractions {
        if !range.contains(&a) {
            return Err(invalid(
                "mixture.fractions",
                a,
                "a volume fraction must be in [0, 1]",
            ));
        }
        sum += a;
    }
    if !((sum - 1.0).abs() <= FRACTION_SUM_TOLERANCE) {
        return Err(invalid(
            "mixture.fractions",
            sum,
            "a particle's volume fractions must sum to 1",
        ));
    }
    Ok(())
}

/// What the transport reads besides the fractions.
pub(crate) struct Transport<'a, S> {
    /// The neighbour pairs at the current positions (`mass`/`h` the fluid's).
    pub pairs: Pairs<'a, S>,
    /// The particle volume `V` (m³).
    pub volume: Real,
    /// The substep (s).
    pub dt: Real,
    /// Each particle's `g − a` over the substep.
    pub effective_gravity: &'a [Vector],
}

/// Scratch of the mixture's stage, held in the fluid's workspace.
#[derive(Clone, Debug, Default)]
pub(crate) struct Scratch {
    /// Velocities at the substep's start (sorted order).
    pub start_velocities: Vec<Vector>,
    /// `g − a` per particle.
    pub effective_gravity: Vec<Vector>,
    /// Each particle's bound `R_i`.
    pub rows: Vec<Real>,
    /// The fraction changes, `phases` per particle.
    pub changes: Vec<Real>,
    /// The diffusion's scratch (`crate::scalars::diffuse`).
    pub diffusion: (Vec<Real>, Vec<Real>),
}

impl Scratch {
    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        let v = std::mem::size_of::<Vector>();
        let r = std::mem::size_of::<Real>();
        (self.start_velocities.capacity() + self.effective_gravity.capacity()) * v
            + (self.rows.capacity()
                + self.changes.capacity()
                + self.diffusion.0.capacity()
                + self.diffusion.1.capacity())
                * r
    }
}

/// What one pair's weights are made of: the pressure kernel (the drift) and the viscosity
/// kernel's Laplacian (the diffusion), with the substep's constant factors.
struct Weights<K> {
    kernel: K,
    laplacian: ViscosityLaplacian,
    /// `2V·dt·τ·(ρ_max − ρ_min)`: times `|∇W_ij|·|ḡ_ij|`, the drift's bound.
    bound: Real,
    /// `2V·dt`: times `|∇W_ij|`, the drift's swap weight `β` before the limit.
    drift: Real,
    /// `D·V·dt`: times `∇²W_ij`, the diffusion's weight.
    diffusion: Real,
}

impl<K: Kernel> Weights<K> {
    fn new<S>(mixture: &Mixture, t: &Transport<'_, S>, spread: Real) -> Self {
        let h = t.pairs.h;
        let drift = if mixture.drift > 0.0 && spread > 0.0 {
            2.0 * t.volume * t.dt
        } else {
            0.0
        };
        Self {
            kernel: K::new(h),
            laplacian: ViscosityLaplacian::new(h),
            bound: drift * mixture.drift * spread,
            drift,
            diffusion: mixture.diffusivity * t.volume * t.dt,
        }
    }

    /// `|∇W|` (0 at `r = 0`: the drift has no direction there) and the diffusion's weight.
    #[inline(always)]
    fn at(&self, r: Real) -> (Real, Real) {
        let grad = if r > 0.0 {
            (-self.kernel.dw(r)).max(0.0)
        } else {
            0.0
        };
        let lap = if self.diffusion > 0.0 {
            self.diffusion * self.laplacian.laplacian(r)
        } else {
            0.0
        };
        (grad, lap)
    }
}

/// Each particle's bound `T_i = R_i + Σ_j D·V·dt·∇²W_ij` (the drift's and the diffusion's
/// shares of what it may give per substep, see the module's docs) into `rows`.
fn row_bounds<K: Kernel, S: Separation>(
    t: &Transport<'_, S>,
    w: &Weights<K>,
    rows: &mut Vec<Real>,
) {
    let n = t.pairs.positions.len();
    rows.clear();
    rows.resize(n, 0.0);
    crate::par_chunks_mut!(rows, crate::par::CHUNK)
        .enumerate()
        .for_each(|(chunk, out)| {
            for (k, row) in out.iter_mut().enumerate() {
                let i = chunk * crate::par::CHUNK + k;
                let xi = t.pairs.positions[i];
                let gi = t.effective_gravity[i];
                let mut sum = 0.0;
                for &j in t.pairs.neighbors.of(i) {
                    let j = j as usize;
                    let r = t.pairs.sep.sep(xi, t.pairs.positions[j]).length();
                    let (grad, lap) = w.at(r);
                    if w.bound > 0.0 {
                        let g = (gi + t.effective_gravity[j]) * 0.5;
                        sum += w.bound * grad * g.length() + lap;
                    } else {
                        sum += lap;
                    }
                }
                *row = sum;
            }
        });
}

/// The phases' net volume fractions `φ_k` that flow from particle `j` into particle `i`
/// (drift swaps, then diffusion), `scale` = `1/max(1, 2T_i, 2T_j)` (see the module's docs).
/// Computed from the same operands in the same order in `j`'s loop, where every term is
/// exactly negated: `φ_k` of `j` from `i` is `−φ_k` bit for bit.
#[inline(always)]
fn pair_flux<K: Kernel, S: Separation>(
    (mixture, rho): (&Mixture, &[Real]),
    t: &Transport<'_, S>,
    w: &Weights<K>,
    (i, j, scale): (usize, usize, Real),
    fractions: &[&[Real]],
    phi: &mut [Real; MAX_PHASES],
) {
    let np = rho.len();
    let d = t.pairs.sep.sep(t.pairs.positions[i], t.pairs.positions[j]);
    let r = d.length();
    let (grad, lap) = w.at(r);
    // The whole array (a fixed size: stores, not a call to `memset` per pair).
    *phi = [0.0; MAX_PHASES];
    if w.drift > 0.0 && grad > 0.0 {
        // `ḡ·e_ij` with `e_ij = −d/r` from i to j, exactly negated in j's loop.
        let g = (t.effective_gravity[i] + t.effective_gravity[j]) * 0.5;
        let weighted = w.drift * grad * scale * (-g.dot(d) / r);
        for k in 0..np {
            for l in k + 1..np {
                let c = mixture.drift * (rho[k] - rho[l]) * weighted;
                // c > 0: k moves from i to j, l from j to i; c < 0 the other way.
                let (donor, receiver, sign) = if c > 0.0 { (i, j, -1.0) } else { (j, i, 1.0) };
                let s = c.abs() * (fractions[k][donor] * fractions[l][receiver]);
                phi[k] += sign * s;
                phi[l] -= sign * s;
            }
        }
    }
    if lap != 0.0 {
        let weight = lap * scale;
        for k in 0..np {
            phi[k] += weight * (fractions[k][j] - fractions[k][i]);
        }
    }
}

/// The transport's changes of one substep into `changes`, `phases + 3` per particle: each
/// phase's fraction change, then the momentum per unit volume that the phases carry in
/// (kg/m³ · m/s): each pair's flux `φ_k` brings `ρ_k·φ_k` at its donor's velocity (upwind).
fn changes<K: Kernel, S: Separation>(
    mixture: &Mixture,
    t: &Transport<'_, S>,
    w: &Weights<K>,
    (fractions, velocities): (&[&[Real]], &[Vector]),
    rows: &[Real],
    changes: &mut Vec<Real>,
) {
    let np = mixture.phases.len();
    let stride = np + 3;
    let n = t.pairs.positions.len();
    let mut rho = [0.0; MAX_PHASES];
    for (r, p) in rho.iter_mut().zip(&mixture.phases) {
        *r = p.rest_density;
    }
    let rho = &rho[..np];
    changes.clear();
    changes.resize(n * stride, 0.0);
    crate::par_chunks_mut!(changes, crate::par::CHUNK * stride)
        .enumerate()
        .for_each(|(chunk, out)| {
            for (k, row) in out.chunks_mut(stride).enumerate() {
                let i = chunk * crate::par::CHUNK + k;
                let mut momentum = Vector::ZERO;
                let mut phi = [0.0; MAX_PHASES];
                for &j in t.pairs.neighbors.of(i) {
                    let j = j as usize;
                    let scale = 1.0 / (2.0 * rows[i].max(rows[j])).max(1.0);
                    pair_flux((mixture, rho), t, w, (i, j, scale), fractions, &mut phi);
                    for p in 0..np {
                        row[p] += phi[p];
                        let up = if phi[p] > 0.0 {
                            velocities[j]
                        } else {
                            velocities[i]
                        };
                        momentum += up * (rho[p] * phi[p]);
                    }
                }
                row[np..].copy_from_slice(&momentum.to_array());
            }
        });
}

/// One substep of the phases' drift and diffusion: `fractions` (one vector per phase,
/// sorted like the particles) change in place, and `velocities` so that each particle's
/// momentum `m_i·v_i` changes by what the phases carry in and out (see the module's docs).
/// `scratch` holds the buffers.
pub(crate) fn transport<K: Kernel, S: Separation>(
    mixture: &Mixture,
    t: &Transport<'_, S>,
    fractions: &mut [&mut Vec<Real>],
    velocities: &mut [Vector],
    scratch: &mut Scratch,
) {
    let n = t.pairs.positions.len();
    let (lo, hi) = mixture
        .phases
        .iter()
        .fold((Real::INFINITY, 0.0 as Real), |(lo, hi), p| {
            (lo.min(p.rest_density), hi.max(p.rest_density))
        });
    let w = Weights::<K>::new(mixture, t, hi - lo);
    if w.drift > 0.0 || w.diffusion > 0.0 {
        row_bounds(t, &w, &mut scratch.rows);
        let view: Vec<&[Real]> = fractions.iter().map(|f| &f[..]).collect();
        let operands = (&view[..], &*velocities);
        changes(
            mixture,
            t,
            &w,
            operands,
            &scratch.rows,
            &mut scratch.changes,
        );
        apply(mixture, &scratch.changes, fractions, velocities);
    } else {
        for i in 0..n {
            renormalize(fractions, i);
        }
    }
}

/// Adds the changes to the fractions, renormalises them ([`renormalize`]), and sets each
/// velocity to the particle's new momentum over its new mass:
/// `v' = (ρ0_i·v + Σ_j Σ_k ρ_k φ_k v_up)/ρ0'_i` (the volume `V` cancels).
fn apply(
    mixture: &Mixture,
    changes: &[Real],
    fractions: &mut [&mut Vec<Real>],
    velocities: &mut [Vector],
) {
    let np = fractions.len();
    let rho = |fractions: &[&mut Vec<Real>], i: usize| -> Real {
        mixture
            .phases
            .iter()
            .zip(fractions)
            .map(|(p, f)| p.rest_density * f[i])
            .sum()
    };
    for (i, row) in changes.chunks_exact(np + 3).enumerate() {
        let old = rho(fractions, i);
        for (f, c) in fractions.iter_mut().zip(row) {
            f[i] += c;
        }
        renormalize(fractions, i);
        let carried = Vector::new(row[np], row[np + 1], row[np + 2]);
        velocities[i] = (velocities[i] * old + carried) / rho(fractions, i);
    }
}

/// Fractions below this are set to 0 after each substep: the drift multiplies fractions,
/// and a phase leaving a particle decays geometrically (to 1.5·10⁻¹⁹ within 6 s in the
/// test's tank without this), so their products would reach the subnormal range of `f32`
/// (below 1.2·10⁻³⁸), where floating-point operations are slow on common CPUs. What is
/// dropped is below the sum's own rounding (`2⁻²⁴` of 1) by eight orders of magnitude.
const NEGLIGIBLE: Real = 1e-15;

/// Particle `i`'s fractions below [`NEGLIGIBLE`] set to 0, then divided by their sum (when
/// it is not 1): the transport keeps the sum exactly in exact arithmetic, and this takes
/// off its round-off, which would otherwise wander as a random walk (1.7·10⁻⁵ after 6 s of
/// the test's tank, about 2500 substeps). It changes each fraction by a rounding or so, as
/// the transport's own do.
fn renormalize(fractions: &mut [&mut Vec<Real>], i: usize) {
    for f in fractions.iter_mut() {
        if f[i] < NEGLIGIBLE {
            f[i] = 0.0;
        }
    }
    let sum: Real = fractions.iter().map(|f| f[i]).sum();
    if sum != 1.0 && sum > 0.0 {
        for f in fractions.iter_mut() {
            f[i] /= sum;
        }
    }
}
