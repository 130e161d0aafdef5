//! Double-density relaxation: Clavet, Beaudoin & Poulin, "Particle-based Viscoelastic Fluid
//! Simulation", SCA 2005 (the Unity paper's future work). Algorithm numbers are that paper's.
//!
//! Positions are predicted (`x += dt·v` after gravity), then relaxed once (Alg. 2) with two
//! densities of the kernels `(1 − q)²` and `(1 − q)³`, `q = r/h`:
//!
//! ```text
//! ρ_i = Σ_j (1 − q_ij)²      ρ_i^near = Σ_j (1 − q_ij)³                          (eqs. 1, 4)
//! P_i = k (ρ_i − ρ0) where ρ_i ≥ ρ0, k_c·min(ρ_i − ρ_t, 0) below     (eq. 2; "Cohesion")
//! P_i^near = k_near·max(ρ_i^near − α·ρ_i, 0)                    (eq. 5; "Near pressure")
//! Δx_i = −½ dt² Σ_j [ (P̃_i + P̃_j)(1 − q_ij) + (P_i^near + P_j^near)(1 − q_ij)² ] r̂_ij
//!        with P̃ = P − ⅔·α·P^near
//! ```
//!
//! and the velocity is `(x − x_old)/dt`. The paper displaces both particles of a pair by `D/2`
//! in a sequential loop; here every particle gathers the displacement its pairs give it in one
//! Jacobi pass (the `P_i + P_j` above is the sum of the two half-displacements the sequential
//! loop applies to the pair), so it runs in parallel, deterministically, and conserves
//! momentum pair by pair. The pressure may be negative (the fluid holds together: surface
//! tension), the near pressure is a short-range repulsion that keeps particles apart.
//!
//! Units: the paper's `k` and `ρ0` are in its own units. Here `ρ0` is the value of `Σ(1 − q)²`
//! in the fluid's rest lattice (spacing `s`, support `h`), and the stiffnesses are multiples of
//! `c²/(h·ρ0)`, `c` the fluid's speed of sound, so that a relative compression `δ` pushes with
//! an acceleration of about `c²·δ/h`, like an equation of state with that speed of sound; the
//! time step obeys the same acoustic limit as WCSPH.
//!
//! **Why not the paper's pressures.** With the paper's `P = k(ρ − ρ0)` and
//! `P^near = k_near·ρ^near` the near pressure pushes everywhere, the bulk too, so the fluid
//! rests where its negative pressure balances it: under `ρ0` (at `h = 2s` and the near
//! stiffness that balanced a flat surface, 1.07·k, at 0.884·ρ0, 3.3 % wider spacing: the bulk
//! minimum of the relaxation's energy; measured 0.87–0.91·ρ0 in tanks). Two consequences. A
//! block spawned on the lattice is far from it and throws itself (a column at rest in a
//! closed tank, 8 × 16 × 8 at 1.25 cm: largest kinetic energy 0.60 of its potential energy
//! with contact-only walls, 2.1 with walls in the densities; stability case 18 failed on it).
//! And the fluid is a soft solid: every particle sits between a tension and a near pressure of
//! the size of the stiffness that cancel, which holds its neighbours in place; a 2,000 kg/m³
//! box rested on a two-layer film that carried 5.1 kPa against 1.4 kPa hydrostatic, and hung
//! at the surface of water 0.44 m deep (a yield stress of a few kPa times the cohesion).
//!
//! **Cohesion.** Here both pressures vanish in the rest lattice, as the other solvers'
//! pressures do at rest, and the cohesion acts only where a particle has fewer neighbours than
//! a flat free surface of the lattice gives its top layer: `ρ_t` ([`cohesion_threshold`]
//! times `ρ0`, 0.751·ρ0 at `h = 2s`, 0.684 at `3s`). Between `ρ_t` and `ρ0` the pressure is
//! zero (a liquid under its rest density has no pressure there, as WCSPH's clamped and PBF's
//! one-sided constraint); below it the tension `k_c·(ρ − ρ_t)` pulls the particle in: the
//! edges, corners and curved parts of a free surface, thin sheets and threads, droplets and
//! spray. So the flat faces of a block spawned on the lattice are at rest, its edges and
//! corners round off, and the bulk carries no stress: a liquid, not a soft solid. The tension
//! has its own stiffness `k_c` ([`Clavet::cohesion`], default 1, the default `k`), so a
//! stiffer (less compressible) fluid is not also a more cohesive one. Measured on the column
//! above (`cargo run --release --example column -- --solver clavet[-walls] --n 8 --spacing
//! 0.0125 --seconds 2 --support S`): largest kinetic energy 0.0013 / 0.0016 of the potential
//! energy with walls in the densities (2 / 3 spacings; none of the faces is free but the top),
//! 0.058 / 0.46 with contact-only walls (non-wetting for the cohesion: the column rounds off
//! the tank's vertical edges, at 3 spacings most of its 8 × 8 section). The 2,000 kg/m³ box
//! lands on one layer (0.0400 m) and sinks through the 0.44 m of water in 1–2.5 s
//! (`tests/light_bodies.rs`). A block thrown apart in zero gravity at 1–3 m/s stays one group
//! (`tests/solvers.rs`, `clavet_cohesion_holds_a_thrown_blob_together`).
//!
//! **Near pressure.** The paper's near pressure keeps particles apart where the tension pulls
//! them together. Here it counts only the near density in excess of what the particle's
//! density gives in the lattice, `α = ρ0^near/ρ0` ([`lattice_near_density`] over
//! [`lattice_rest_density`], 0.4006 at `h = 2s`): zero in the rest lattice and under a uniform
//! expansion, positive under compression and where the neighbours sit closer than the
//! lattice's on average (a clump). A near density measured against the lattice's own
//! (`max(ρ^near − ρ0^near, 0)`) never pushed in a droplet of a few particles, which collapsed
//! to clumps (in the dam break of 5,239 particles at 2.5 cm, 96–206 particles with a
//! neighbour closer than half a spacing; none with `α·ρ`). Its energy `G(ρ^near − α·ρ)`
//! depends on `ρ` too, which gives the `−⅔·α·P^near` in `P̃` (the displacement stays the
//! gradient of one energy, see "Walls"). `k_near` defaults to `k_c`: without cohesion there is
//! no near pressure, and the relaxation is the same as before this form.
//!
//! **Interacting fluids** (`crate::fluid::interaction`, `ClavetContext::ratio`): the pair's
//! displacement is split by inverse mass, `r_i/(r_i + r_j)` of it to `i` (`r = m_ref/m`) in
//! place of one half, which conserves momentum; the densities count neighbours, not masses,
//! and need no change.
//!
//! Viscosity is the fluid's own viscosity
//! stage (the paper's pairwise viscosity impulses are not implemented); its viscoelastic
//! springs are an option ([`Clavet::springs`], [`super::springs`]).
//!
//! **Walls.** By default (the water preset's [`crate::FluidParams::wall_density`], on with
//! every solver) the static and kinematic colliders count in both densities (`boundary::WallWorkspace::update_clavet`: the solid as
//! the fluid's lattice continued behind its surface, so a particle half a spacing from a flat
//! wall in a resting lattice has `ρ0` again: 0.4 % short at `h = 2s`, 0.07 % at `3s`), and push
//! with the energy-consistent weight. The relaxation is a gradient step on the potential
//! `E = Σ_i F(ρ_i) + G(ρ_i^near − α·ρ_i)`, `∂E/∂ρ = h·P̃/4`, `∂E/∂ρ^near = h·P^near/6` (the pair
//! terms above are exactly `−dt²·∇_i E`); a wall's density enters only its particle's own
//! `E_i`, so its term is `Δx_i = −dt²·h·(P̃_i/4·∇ρ_wall + P_i^near/6·∇ρ^near_wall)`, half of
//! what mirroring
//! the particle's pressures into the wall would give. Mirrored fully, a column at rest in a
//! closed tank gains energy and never settles (no cohesion: still 1.0 m/s after 2 s at
//! `h = 2s`, 5.3 m/s at `3s`), as WCSPH's walls do with the full pressure
//! (`src/pressure/wcsph.rs`). Dynamic bodies do not count: they meet the water through
//! contact only (the swept contact's reflection and damping, whose impulses go to the body,
//! with the added-mass solve). Counted as the other walls (their share of the wall term
//! reacted on them as `−m·Δx_b/dt`), they held a 16 cm box of 1,400 kg/m³ released at the
//! surface of water 0.44 m deep (4 cm spacing) in the water: at the default cohesion above
//! its boat depth (lowest corner 0.237 → 0.217 m over 4 s), without cohesion 3.5 spacings
//! above the floor (0.138–0.140 m from 2 to 8 s), where DFSPH, PBF and WCSPH land it; the
//! hold grew with depth, not with the stiffness, as a jammed solid's would (docs/coupling.md,
//! "Known limits"). Contact only, it lands on the last layer (lowest corner 0.0400 m within
//! 1 s without cohesion; 0.030 m at 3.5 s at the default cohesion; `tests/light_bodies.rs`,
//! `examples/clavet_heavy_probe.rs`). Walls counted in the densities are *neutral* for the cohesion
//! (a contact angle of 90°: the liquid next to them lacks no density, so it has no surface
//! energy there; contact-only walls, dynamic bodies among them, are non-wetting, 180°). A column at rest in a closed tank
//! with them stays at rest with or without cohesion (largest kinetic energy 0.0013, 0.0047
//! and 0.0067 of its potential energy at cohesion 1, 0.1 and 0, `h = 2s`; docs/solvers.md).
//! [`crate::FluidParamsBuilder::wall_density`]`(false)` is the cheap opt-out: walls then take
//! part through contact only, and are non-wetting for the cohesion (a particle in a tank's
//! corner has 0.384·ρ0 against the threshold 0.751·ρ0), so a block spawned in a tank throws
//! its corners (up to 1.4–2.0 times the column's potential energy as kinetic energy in the
//! validation report's tank; `examples/clavet_probe.rs`) and bodies are non-wetting.
//! Wall viscosity
//! is refused with Clavet: with it the momentum of fluid + bodies drifted by 1.6 % over 5 s
//! in `tests/moving_bodies.rs`'s sloshing box (PBF with the same walls: 0.003 %), not
//! understood yet.

use crate::boundary::WallWorkspace;
use crate::domain::Separation;
use crate::kernel::Kernel;
use crate::math::{Real, Vector};
use crate::neighbors::NeighborLists;
use crate::par::CHUNK;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

pub(crate) mod settings;
mod step;
pub use settings::{Clavet, Springs};
pub(crate) use step::ClavetState;

/// Densities `(Σ(1 − q)², Σ(1 − q)³)` of a lattice particle `depth` layers below a flat free
/// surface (`depth ≥ h/s`: the interior value).
fn layer_densities(h: Real, s: Real, depth: i32) -> (Real, Real) {
    let r = (h / s).ceil() as i32;
    let (mut rho, mut near) = (0.0, 0.0);
    for x in -r..=r {
        for y in -r..=r {
            for z in -r..=r {
                if y > depth {
                    continue; // above the surface
                }
                let d = Vector::new(x as Real, y as Real, z as Real).length() * s;
                if d > 0.0 && d < h {
                    let a = 1.0 - d / h;
                    rho += a * a;
                    near += a * a * a;
                }
            }
        }
    }
    (rho, near)
}

/// The cohesion threshold `ρ_t/ρ0`: the density, relative to the rest lattice's, of a particle
/// in the top layer of a flat free surface of the rest lattice (spacing `s`, support `h`; the
/// lowest of the layers under the surface). 0.751 at `h = 2s`, 0.684 at `3s`. The cohesion
/// pulls only particles sparser than that (see "Cohesion" in the module docs), so the flat
/// faces of a block spawned on the lattice are at rest.
pub fn cohesion_threshold(h: Real, s: Real) -> Real {
    layer_densities(h, s, 0).0 / lattice_rest_density(h, s)
}

/// `Σ (1 − q)³` over the neighbours of a particle in a full lattice of spacing `s` (the rest
/// near density).
pub fn lattice_near_density(h: Real, s: Real) -> Real {
    layer_densities(h, s, (h / s).ceil() as i32 + 1).1
}

/// Buffers of the relaxation (indexed like the sorted particles).
#[derive(Clone, Debug, Default)]
pub(crate) struct ClavetBuffers {
    /// `(P_i, P_i^near)`.
    pub pressure: Vec<(Real, Real)>,
    /// Displacements.
    pub displacement: Vec<Vector>,
    /// Per-chunk partial sums.
    pub partials: Vec<f64>,
}

impl ClavetBuffers {
    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.pressure.capacity() * 8
            + self.displacement.capacity() * 12
            + self.partials.capacity() * 8
    }
}

/// `Σ (1 − q)²` over the neighbours of a particle in a full lattice of spacing `s` (the rest
/// density `ρ0` of the method).
pub fn lattice_rest_density(h: Real, s: Real) -> Real {
    let r = (h / s).ceil() as i32;
    let mut rho = 0.0;
    for x in -r..=r {
        for y in -r..=r {
            for z in -r..=r {
                let d = Vector::new(x as Real, y as Real, z as Real).length() * s;
                if d > 0.0 && d < h {
                    let a = 1.0 - d / h;
                    rho += a * a;
                }
            }
        }
    }
    rho
}

/// Clavet's kernels `(1 − q)^P` as a [`Kernel`] (not normalised: their sums over the
/// neighbours are the method's densities), for the walls' half-space tables
/// ([`crate::boundary::WallWorkspace::update_clavet`]).
#[derive(Copy, Clone, Debug)]
pub(crate) struct Power<const P: i32> {
    h: Real,
}

/// The density kernel `(1 − q)²`.
pub(crate) type Quadratic = Power<2>;
/// The near-density kernel `(1 − q)³`.
pub(crate) type Cubic = Power<3>;

impl<const P: i32> Kernel for Power<P> {
    const NAME: &'static str = if P == 2 {
        "Clavet (1 - q)^2"
    } else {
        "Clavet (1 - q)^3"
    };
    fn new(h: Real) -> Self {
        Self { h }
    }
    fn support(&self) -> Real {
        self.h
    }
    fn w(&self, d: Real) -> Real {
        (1.0 - d / self.h).max(0.0).powi(P)
    }
    fn dw(&self, d: Real) -> Real {
        -(P as Real) * (1.0 - d / self.h).max(0.0).powi(P - 1) / self.h
    }
}

/// Inputs of one relaxation.
pub(crate) struct ClavetContext<'a> {
    /// Neighbour lists of the predicted positions.
    pub neighbors: &'a NeighborLists,
    /// Support radius.
    pub h: Real,
    /// Particle spacing.
    pub spacing: Real,
    /// Speed of sound of the fluid (m/s).
    pub speed_of_sound: Real,
    /// Time step.
    pub dt: Real,
    /// Walls that count in the densities ([`WallWorkspace::clavet`], filled by
    /// [`WallWorkspace::update_clavet`]), or `None`: walls by contact only.
    pub wall: Option<&'a WallWorkspace>,
    /// The factor of the rest density the fluid is held at (see `StepContext::hold`).
    pub hold: Real,
    /// Interacting fluids (`crate::fluid::interaction`): each particle's inverse mass in units
    /// of the reference's, `r_i = m_ref/m_i`, which splits each pair's displacement (see
    /// "Interacting fluids" in the module docs); `None` for one fluid (halves).
    pub ratio: Option<&'a [Real]>,
}

/// The double-density relaxation with the separations formed by `sep` (see [`crate::domain`]).
pub(crate) fn relax_in<S: Separation>(
    ctx: &ClavetContext<'_>,
    settings: &Clavet,
    buffers: &mut ClavetBuffers,
    positions: &mut [Vector],
    relative_density: &mut [Real],
    sep: S,
) -> Real {
    let n = positions.len();
    let ClavetBuffers {
        pressure,
        displacement,
        partials,
    } = buffers;
    pressure.resize(n, (0.0, 0.0));
    displacement.resize(n, Vector::ZERO);
    partials.resize(n.div_ceil(CHUNK), 0.0);
    let stiffness = Stiffness::new(ctx, settings);
    pressures(
        ctx,
        &stiffness,
        (positions, sep),
        (pressure, relative_density, partials),
    );
    let error = (partials.iter().sum::<f64>() / n.max(1) as f64) as Real;
    match ctx.ratio {
        None => displacements(ctx, (positions, sep), pressure, displacement, |_, _| 1.0),
        // The pair's displacement split by inverse mass: `r_i/(r_i + r_j)` of it to `i` in
        // place of one half.
        Some(r) => displacements(ctx, (positions, sep), pressure, displacement, |i, j| {
            2.0 * r[i] / (r[i] + r[j])
        }),
    }
    let displacement: &[Vector] = displacement;
    crate::par_chunks_mut!(positions, CHUNK)
        .enumerate()
        .for_each(|(c, x)| {
            let base = c * CHUNK;
            for (k_, x) in x.iter_mut().enumerate() {
                *x += displacement[base + k_];
            }
        });
    error
}

/// The relaxation's rest density `ρ0`, its cohesion threshold `ρ_t`, the near density's share
/// `α` and its stiffnesses: `k` (compression), `k_c` (tension: the cohesion) and `k_near`, in
/// units of `c²/(h·ρ0)`.
struct Stiffness {
    rho0: Real,
    rho_t: Real,
    alpha: Real,
    k: Real,
    k_c: Real,
    k_near: Real,
}

impl Stiffness {
    fn new(ctx: &ClavetContext<'_>, settings: &Clavet) -> Self {
        let (h, s) = (ctx.h, ctx.spacing);
        let lattice = lattice_rest_density(h, s);
        let rho0 = lattice * ctx.hold;
        let unit = ctx.speed_of_sound * ctx.speed_of_sound / (h * rho0);
        let near = settings.near_stiffness.unwrap_or(settings.cohesion);
        Self {
            rho0,
            rho_t: cohesion_threshold(h, s) * rho0,
            alpha: lattice_near_density(h, s) / lattice,
            k: settings.stiffness * unit,
            k_c: settings.cohesion * unit,
            k_near: near * unit,
        }
    }

    /// `(P, P^near)` of a particle with densities `rho`, `near`: `P` is `∂E/∂ρ` (the near
    /// term's share included, see "Near pressure" in the module docs) in the units of the
    /// pair formula.
    fn pressures(&self, rho: Real, near: Real) -> (Real, Real) {
        let p = if rho >= self.rho0 {
            self.k * (rho - self.rho0)
        } else {
            self.k_c * (rho - self.rho_t).min(0.0)
        };
        let pn = self.k_near * (near - self.alpha * rho).max(0.0);
        (p - (2.0 / 3.0) * self.alpha * pn, pn)
    }
}

/// The two densities of every particle (walls included) and its pressures `(P, P^near)`
/// into `pressure`, its density relative to `ρ0` into `relative`, and the per-chunk sums of
/// the relative compression into `partials`.
fn pressures<S: Separation>(
    ctx: &ClavetContext<'_>,
    stiffness: &Stiffness,
    (positions, sep): (&[Vector], S),
    (pressure, relative, partials): (&mut [(Real, Real)], &mut [Real], &mut [f64]),
) {
    let inv_h = 1.0 / ctx.h;
    let rho0 = stiffness.rho0;
    crate::par_chunks_mut!(pressure, CHUNK)
        .zip(crate::par_chunks_mut!(relative, CHUNK))
        .zip(crate::par_iter_mut!(partials))
        .enumerate()
        .for_each(|(c, ((pr, rel), sum))| {
            let base = c * CHUNK;
            let mut s = 0.0f64;
            for k_ in 0..pr.len() {
                let i = base + k_;
                let xi = positions[i];
                let (mut rho, mut near) = (0.0, 0.0);
                for &j in ctx.neighbors.of(i) {
                    let d = sep.sep(xi, positions[j as usize]).length();
                    let a = (1.0 - d * inv_h).max(0.0);
                    rho += a * a;
                    near += a * a * a;
                }
                if let Some(w) = ctx.wall {
                    let [wr, wn] = w.clavet[i];
                    rho += wr;
                    near += wn;
                }
                pr[k_] = stiffness.pressures(rho, near);
                rel[k_] = rho / rho0;
                s += (rho / rho0 - 1.0).max(0.0) as f64;
            }
            *sum = s;
        });
}

/// The displacement `−½dt²·Σ_j s_ij·[(P_i + P_j)(1 − q) + (P_i^near + P_j^near)(1 − q)²] r̂_ij`
/// of every particle (and the walls' term) into `displacement`, `s_ij = share(i, j)` twice
/// particle `i`'s share of the pair's displacement (1 for one fluid: the paper's halves).
fn displacements<S: Separation>(
    ctx: &ClavetContext<'_>,
    (positions, sep): (&[Vector], S),
    pressure: &[(Real, Real)],
    displacement: &mut [Vector],
    share: impl Fn(usize, usize) -> Real + Sync,
) {
    let h = ctx.h;
    let inv_h = 1.0 / h;
    let half_dt2 = 0.5 * ctx.dt * ctx.dt;
    crate::par_chunks_mut!(displacement, CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            let base = c * CHUNK;
            for (k_, dx) in out.iter_mut().enumerate() {
                let i = base + k_;
                let xi = positions[i];
                let (p, pn) = pressure[i];
                let mut acc = Vector::ZERO;
                for &j in ctx.neighbors.of(i) {
                    let r = sep.sep(positions[j as usize], xi);
                    let d = r.length();
                    if d <= 1e-6 * h {
                        // Coincident: no direction to push along; the neighbours around
                        // them separate them over the next steps.
                        continue;
                    }
                    let a = (1.0 - d * inv_h).max(0.0);
                    let (pj, pnj) = pressure[j as usize];
                    let s = share(i, j as usize);
                    acc += r * (((p + pj) * a + (pn + pnj) * a * a) / d * s);
                }
                if let Some(w) = ctx.wall {
                    // The walls' term, energy-consistent (see "Walls" in the module docs):
                    // `Σ_b r̂_ib (1 − q)·P = ½P·h·∇ρ_wall`, `Σ_b r̂_ib (1 − q)²·P_near =
                    // ⅓P_near·h·∇ρ^near_wall` (`∇_i (1 − q)^k = k(1 − q)^(k−1) r̂_ib/h`).
                    let [g, gn] = w.clavet_gradient[i];
                    acc += (g * (0.5 * p) + gn * (pn / 3.0)) * h;
                }
                *dx = acc * -half_dt2;
            }
        });
}

/// Power iterations of [`stiffest_rest_mode`].
const POWER_ITERATIONS: usize = 200;

/// The stiffness `λ` (1/s², per unit mass) of the stiffest mode of the relaxation about a rest
/// lattice of spacing `spacing`, support `h` and speed of sound `speed_of_sound`, with
/// `settings`' stiffnesses. With the forces taken at the predicted positions, a mode of
/// stiffness `λ` evolves over a substep `dt` as `x' = (1 − θ)(x + dt·v)`, `θ = λ·dt²`, which
/// is bounded iff `θ ≤ 4/3` (the adaptive substep keeps `θ` inside that; see
/// `pipeline::time_stepping::stable_time_step`).
///
/// Found by power iteration on the linearised relaxation (finite differences of
/// `relax_in` with `dt = 1`, which returns the displacement `a·dt²`) of a periodic lattice
/// spanning at least `2h + 2s`, from a fixed start vector in which every wavelength is
/// present; deterministic. It costs 200 relaxations of a lattice of `n³` particles, `n =
/// max(8, ⌈2h/s⌉ + 2)` (512 particles up to h = 3s, 1,000 at 4s: tens of milliseconds; the cost
/// grows as `(h/s)⁶`), so the pipeline computes it once per parameter set and keeps it.
pub fn stiffest_rest_mode(settings: &Clavet, h: Real, spacing: Real, speed_of_sound: Real) -> Real {
    use crate::domain::MinimumImage;
    use crate::neighbors::NeighborGrid;
    // The lattice 0.1 % compressed: at rest both pressures sit at a kink (no pressure under
    // ρ0, no near pressure under `α·ρ`), so a linearisation there would see them on one side
    // of a mode's oscillation only; compressed, every particle has both, the stiffest state a
    // mode passes through (as stiff as the rest lattice of the paper's pressures at `k = k_c`).
    let s = spacing * (1.0 - 1e-3);
    let n = ((2.0 * h / s).ceil() as usize + 2).max(8);
    let box_len = n as Real * s;
    let domain = MinimumImage::new(Vector::ZERO, Vector::splat(box_len));
    let mut x0 = crate::fluid::lattice(Vector::splat(0.5 * s), n, n, n, s);
    let mut grid = NeighborGrid::default();
    if grid.sort_periodic(&x0, h, &domain) {
        let mut scratch = Vec::new();
        crate::par::permute(&mut x0, &mut scratch, grid.permutation());
    }
    grid.build_cells();
    let mut neighbors = NeighborLists::default();
    neighbors.build_periodic(&grid, &x0, h, domain);
    let ctx = ClavetContext {
        neighbors: &neighbors,
        h,
        spacing,
        speed_of_sound,
        dt: 1.0,
        wall: None,
        hold: 1.0,
        ratio: None,
    };
    // The springs are not part of the relaxation (their stiffness bounds the substep
    // separately, through the acoustic limit). The compressed lattice sees `k`; a cohesion
    // stiffer than it acts in tension, so the stiffer of the two stands for both.
    let settings = Clavet {
        springs: None,
        stiffness: settings.stiffness.max(settings.cohesion),
        ..*settings
    };
    let mut buffers = ClavetBuffers::default();
    let mut rel = vec![0.0; x0.len()];
    let mut displacement = |x: &[Vector]| -> Vec<Vector> {
        let mut y = x.to_vec();
        relax_in(&ctx, &settings, &mut buffers, &mut y, &mut rel, domain);
        y.iter().zip(x).map(|(a, b)| *a - *b).collect()
    };
    let d0 = displacement(&x0);
    // A fixed, mixed start vector (every wavelength present).
    let mut v: Vec<Vector> = (0..x0.len())
        .map(|i| {
            let f = |m: usize| ((i * m) % 17) as Real - 8.0;
            Vector::new(f(37), f(11), f(5))
        })
        .collect();
    let eps = 1e-4 * s;
    let mut lambda = 0.0f64;
    for _ in 0..POWER_ITERATIONS {
        let norm = v
            .iter()
            .map(|a| a.length_squared() as f64)
            .sum::<f64>()
            .sqrt();
        if norm == 0.0 || !norm.is_finite() {
            break;
        }
        for a in &mut v {
            *a /= norm as Real;
        }
        let xp: Vec<Vector> = x0.iter().zip(&v).map(|(x, a)| *x + *a * eps).collect();
        let kv: Vec<Vector> = displacement(&xp)
            .iter()
            .zip(&d0)
            .map(|(a, b)| -(*a - *b) / eps)
            .collect();
        lambda = kv.iter().zip(&v).map(|(a, b)| a.dot(*b) as f64).sum();
        v = kv;
    }
    lambda.max(0.0) as Real
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Walls in the densities: a particle of a resting lattice half a spacing from a flat
    /// wall has its fluid neighbours on one side and the wall's two densities
    /// (`HalfSpaceTable` of each kernel over the lattice's rows continued behind the wall, per
    /// volume `1/s³`) on the other, and together they must give the interior's densities
    /// back, or the lattice would start pushed off (or pulled onto) its walls. The table
    /// integrates each ghost row in its plane, which averages the lattice's in-plane sum over
    /// where the particle sits; that is the whole difference (see `kernel::half_space`,
    /// "Registration"). Measured: −0.39 % and +0.05 % (density, near density) at `h = 2s`,
    /// −0.07 % and −0.04 % at `3s`; tolerances 0.5 % and 0.1 %.
    #[test]
    fn wall_densities_complete_the_lattice_half_a_spacing_from_a_wall() {
        use crate::kernel::HalfSpaceTable;
        for (ratio, tol) in [(2.0, 5e-3), (3.0, 1e-3)] {
            let s = 0.0125;
            let h = ratio * s;
            let per_volume = 1.0 / (s * s * s);
            let interior = layer_densities(h, s, 10);
            assert!((interior.0 - lattice_rest_density(h, s)).abs() < 1e-5);
            // The floor's layer: neighbours on one side only (the layer under a free surface,
            // turned over).
            let layer = layer_densities(h, s, 0);
            let wall = (
                HalfSpaceTable::new::<Quadratic>(h, s).eval(0.5 * s).0 * per_volume,
                HalfSpaceTable::new::<Cubic>(h, s).eval(0.5 * s).0 * per_volume,
            );
            let rel = (
                (layer.0 + wall.0) / interior.0 - 1.0,
                (layer.1 + wall.1) / interior.1 - 1.0,
            );
            println!(
                "h = {ratio} s: density {:+.4} %, near {:+.4} %",
                rel.0 * 100.0,
                rel.1 * 100.0
            );
            assert!(
                rel.0.abs() < tol && rel.1.abs() < tol,
                "h = {ratio} s: {rel:?}"
            );
        }
    }

    /// The stability limit quoted in `pipeline::time_stepping::stable_time_step`. With the
    /// forces taken at the predicted positions a mode of stiffness λ evolves as
    /// `x' = (1 − θ)(x + dt·v)`, `θ = λ·dt²`, bounded iff `θ ≤ 4/3`. Power iteration on the
    /// linearised relaxation (finite differences of `relax_in` with `dt = 1`, which returns the
    /// displacement `a·dt²`) of a periodic lattice of 8³ particles, 0.1 % compressed (both
    /// pressures on), finds its stiffest mode; at the acoustic substep `0.4·h/(c·√k)` (k = k_c
    /// = 1 here; the bound scales with √k) θ must be inside 4/3, and the documented 0.656
    /// (to 5 %); Courant 0.6 would give 1.48, outside (the margin is finite: the bound is met
    /// at Courant 0.57).
    #[test]
    fn the_acoustic_substep_is_inside_the_relaxations_linear_stability_limit() {
        let s = 0.05;
        let h = 2.0 * s;
        let c = 30.0;
        let lambda = stiffest_rest_mode(&Clavet::default(), h, s, c) as f64;
        let theta = |courant: f64| lambda * (courant * h as f64 / c as f64).powi(2);
        eprintln!(
            "λ = {lambda:.1} /s², θ(0.4) = {:.3}, θ(0.6) = {:.3}",
            theta(0.4),
            theta(0.6)
        );
        assert!(
            (theta(0.4) - 0.656).abs() < 0.05 * 0.656 && theta(0.4) < 4.0 / 3.0,
            "θ at Courant 0.4 = {} (λ = {lambda})",
            theta(0.4)
        );
        assert!(theta(0.6) > 4.0 / 3.0, "θ at Courant 0.6 = {}", theta(0.6));
    }
}
