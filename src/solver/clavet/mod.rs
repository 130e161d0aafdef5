//! Double-density relaxation: Clavet, Beaudoin & Poulin, "Particle-based Viscoelastic Fluid
//! Simulation", SCA 2005 (the Unity paper's future work). Algorithm numbers are that paper's.
//!
//! Positions are predicted (`x += dt·v` after gravity), then relaxed once (Alg. 2) with two
//! densities of the kernels `(1 − q)²` and `(1 − q)³`, `q = r/h`:
//!
//! ```text
//! ρ_i = Σ_j (1 − q_ij)²      ρ_i^near = Σ_j (1 − q_ij)³               (eqs. 1, 4)
//! P_i = k (ρ_i − ρ0)          P_i^near = k_near ρ_i^near               (eqs. 2, 5)
//!       (k_c instead of k where ρ_i < ρ0: see "Cohesion" below)
//! Δx_i = −½ dt² Σ_j [ (P_i + P_j)(1 − q_ij) + (P_i^near + P_j^near)(1 − q_ij)² ] r̂_ij
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
//! **Cohesion.** The paper's one `k` sets both how hard the fluid resists compression and
//! how hard it holds together: where `ρ < ρ0` (a free surface, a splash) the pressure is
//! negative and pulls particles in, which is the method's surface tension. Here the tension
//! side has its own stiffness `k_c` ([`Clavet::cohesion`], default 1, the default `k`), so a
//! stiffer (less compressible) fluid is not also a more cohesive one (a real liquid's bulk
//! modulus and surface tension are independent properties). This matters because no block of
//! particles on a lattice is at rest under the relaxation: its flat faces, edges and corners
//! are pulled in and the layer under each face is pushed out (with `h = 2s`, the layer under a
//! face balanced by the default near stiffness feels `0.61·k·c²/(h·ρ0)`, the edges and corners
//! up to `1.8·k·c²/(h·ρ0)`: direct sums on an 8³ block, `k_c = k`), and the energy the block lets go of on its way to the nearest
//! equilibrium grows with the stiffnesses that make those forces: with the one `k`, a dam
//! break spawned at 100 times the default stiffness threw itself apart at once (kinetic energy
//! 7.7 times the column's potential energy after the first 1/30 s, particles at 80 m/s, with
//! shorter substeps as much or more: the energy comes from the spawn lattice, not from the
//! time step; `stability` case 4). With `k_c` at its default the same run peaks at 0.595
//! times it.
//! The near stiffness defaults to the value that balances a flat free surface against the
//! cohesion ([`surface_equilibrium_near_ratio`] times `k_c`). At `k = k_c` (the default) the
//! relaxation is the paper's.
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
//! **Walls.** By default walls take part through contact only. With
//! [`crate::FluidParamsBuilder::wall_density`]`(true)` the static and kinematic colliders also
//! count in both densities (`boundary::WallWorkspace::update_clavet`: the solid as
//! the fluid's lattice continued behind its surface, so a particle half a spacing from a flat
//! wall in a resting lattice has `ρ0` again: 0.4 % short at `h = 2s`, 0.07 % at `3s`), and push
//! with the energy-consistent weight. The relaxation is a gradient step on the potential
//! `E = Σ_i F(ρ_i) + G(ρ_i^near)`, `F' = h·P/4`, `G' = h·P^near/6` (the pair terms above are
//! exactly `−dt²·∇_i E`); a wall's density enters only its particle's own `F` and `G`, so its
//! term is `Δx_i = −dt²·h·(P_i/4·∇ρ_wall + P_i^near/6·∇ρ^near_wall)`, half of what mirroring
//! the particle's pressures into the wall would give. Mirrored fully, a column at rest in a
//! closed tank gains energy and never settles (no cohesion: still 1.0 m/s after 2 s at
//! `h = 2s`, 5.3 m/s at `3s`), as WCSPH's walls do with the full pressure
//! (`src/pressure/wcsph.rs`). Dynamic bodies count as the other walls do and take the
//! reaction of their share of the wall term, `−m·Δx_b/dt` (the velocity the displacement gave
//! the particle), through the coupling's added-mass solve. Walls counted this way are *neutral* for the cohesion
//! (a contact angle of 90°: the liquid next to them lacks no density, so it has no surface
//! energy there; contact-only walls are non-wetting, 180°). They do not remove what throws a
//! cohesive fluid spawned on a lattice (its free surface is far from the relaxation's
//! equilibrium, see "Cohesion"), and a thrown column that reaches the ceiling hangs there
//! (a column at rest in a closed tank, `h = 2s`: largest kinetic energy 0.27 of its potential
//! energy at cohesion 0.1, 2.1 at the default 1, against 0.007 without cohesion;
//! docs/solvers.md), so they suit a fluid without cohesion (`cohesion: 0.0`). Wall viscosity
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

/// `k_near/k_c` for which a particle in the top layer of the rest lattice (spacing `s`, support
/// `h`) under a flat free surface feels no net push: the surface layer's negative pressure
/// (it has fewer neighbours; stiffness `k_c`, the cohesion) pulls it in exactly as much as the
/// near pressure pushes it out.
pub fn surface_equilibrium_near_ratio(h: Real, s: Real) -> Real {
    let r = (h / s).ceil() as i32;
    let deep = layer_densities(h, s, r + 1);
    let rho0 = deep.0;
    let layer = |depth: i32| layer_densities(h, s, depth);
    let top = layer(0);
    let (mut a, mut b) = (0.0, 0.0);
    for x in -r..=r {
        for y in -r..=0 {
            for z in -r..=r {
                let d = Vector::new(x as Real, y as Real, z as Real).length() * s;
                if d == 0.0 || d >= h {
                    continue;
                }
                let q = 1.0 - d / h;
                let ry = y as Real * s / d;
                let (rj, nj) = layer(-y);
                a += ((top.0 - rho0) + (rj - rho0)) * q * ry;
                b += (top.1 + nj) * q * q * ry;
            }
        }
    }
    if b != 0.0 { (-a / b).max(0.0) } else { 0.0 }
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

/// The relaxation's rest density `ρ0` and stiffnesses: `k` (compression), `k_c` (tension:
/// the cohesion) and `k_near`, in units of `c²/(h·ρ0)`.
struct Stiffness {
    rho0: Real,
    k: Real,
    k_c: Real,
    k_near: Real,
}

impl Stiffness {
    fn new(ctx: &ClavetContext<'_>, settings: &Clavet) -> Self {
        let h = ctx.h;
        let rho0 = lattice_rest_density(h, ctx.spacing) * ctx.hold;
        let unit = ctx.speed_of_sound * ctx.speed_of_sound / (h * rho0);
        let near = settings
            .near_stiffness
            .unwrap_or_else(|| settings.cohesion * surface_equilibrium_near_ratio(h, ctx.spacing));
        Self {
            rho0,
            k: settings.stiffness * unit,
            k_c: settings.cohesion * unit,
            k_near: near * unit,
        }
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
    let Stiffness {
        rho0,
        k,
        k_c,
        k_near,
    } = *stiffness;
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
                let stiffness = if rho < rho0 { k_c } else { k };
                pr[k_] = (stiffness * (rho - rho0), k_near * near);
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
    let s = spacing;
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
        spacing: s,
        speed_of_sound,
        dt: 1.0,
        wall: None,
        hold: 1.0,
        ratio: None,
    };
    // The springs are not part of the relaxation (their stiffness bounds the substep
    // separately, through the acoustic limit).
    let settings = Clavet {
        springs: None,
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

    /// The stability limit quoted in `pipeline::time_stepping::stable_time_step`. With the forces taken at
    /// the predicted positions a mode of stiffness λ evolves as `x' = (1 − θ)(x + dt·v)`,
    /// `θ = λ·dt²`, bounded iff `θ ≤ 4/3`. Power iteration on the linearised relaxation (finite
    /// differences of `relax_in` with `dt = 1`, which returns the displacement `a·dt²`) of a
    /// periodic rest lattice of 8³ particles finds its stiffest mode; at the acoustic substep
    /// `0.4·h/(c·√k)` (k = k_c = 1 here; the bound scales with √k) θ must be inside 4/3, and
    /// the documented 1.06 (Courant 0.5 would give 1.65, outside: the margin is real, not
    /// loose).
    #[test]
    fn the_acoustic_substep_is_inside_the_relaxations_linear_stability_limit() {
        let s = 0.05;
        let h = 2.0 * s;
        let c = 30.0;
        let lambda = stiffest_rest_mode(&Clavet::default(), h, s, c) as f64;
        let theta = |courant: f64| lambda * (courant * h as f64 / c as f64).powi(2);
        eprintln!(
            "λ = {lambda:.1} /s², θ(0.4) = {:.3}, θ(0.5) = {:.3}",
            theta(0.4),
            theta(0.5)
        );
        assert!(
            theta(0.4) > 0.95 && theta(0.4) < 1.2 && theta(0.4) < 4.0 / 3.0,
            "θ at Courant 0.4 = {} (λ = {lambda})",
            theta(0.4)
        );
        assert!(theta(0.5) > 4.0 / 3.0, "θ at Courant 0.5 = {}", theta(0.5));
    }
}
