//! Surface tension and adhesion of Akinci, Akinci & Teschner (2013), "Versatile surface
//! tension and adhesion for SPH fluids" (ACM TOG 32(6), 182), as accelerations:
//!
//! ```text
//! a_i = −γ Σ_j K_ij [ m C(|x_ij|) x_ij/|x_ij| + (n_i − n_j) ]   −   β ρ0 G(d_i) n_w,i
//!       └──────── cohesion ───────┘   └ curvature ┘        └── adhesion ──┘
//! ```
//!
//! with `x_ij = x_i − x_j`, the correction `K_ij = 2ρ0/(ρ_i + ρ_j)` (it strengthens the pull
//! on particles short of neighbours, the surface's), the cohesion spline
//!
//! ```text
//! C(r) = 32/(π h⁹) · { (h − r)³ r³                 h/2 < r ≤ h
//!                      2(h − r)³ r³ − h⁶/64        0 < r ≤ h/2 }
//! ```
//!
//! (repulsive below `h/2`, attractive beyond, zero at `h`) and the surface normals
//! `n_i = h Σ_j m/ρ_j ∇W_ij` (density kernel, `∇W_ij` the gradient at `x_i` of `W(x_i − x_j)`),
//! which vanish inside the fluid: the `n_i − n_j` term is the paper's curvature
//! minimisation. Signs and factors are the paper's, as its authors' group implements them
//! (SPlisHSPlasH's `SurfaceTension_Akinci2013`).
//!
//! **Adhesion to colliders.** Akinci's adhesion sums over boundary particles `k` of
//! volume-weighted mass `Ψ_k = ρ0 V_k`: `a_i = −β Σ_k Ψ_k A(|x_ik|) x_ik/|x_ik|`, with the
//! adhesion spline `A(r) = 0.007/h^3.25 · (−4r²/h + 6r − 2h)^¼` on `h/2 < r ≤ h`. Our
//! colliders have no boundary particles: as the walls' density does (`ρ0·Φ`, the sum
//! `Σ_k Ψ_k W_ik` read as the integral over the solid's volume,
//! [`crate::boundary::wall`]), the sum becomes `ρ0 ∫_solid A(|x − y|) (x − y)/|x − y| dV_y`,
//! which for the half-space behind the collider's surface at distance `d` along the normal
//! `n_w` (pointing to the fluid) is `−ρ0 G(d) n_w` with
//! `G(d) = 2π ∫_d^h z ∫_max(z, h/2)^h A(r) dr dz` (the tangential parts cancel; the inner
//! integral follows from `ρ dρ = r dr` on each plane `z`). `G` is tabulated once per `h`
//! ([`AdhesionTable`]); several colliders add their terms (Akinci sums the boundary particles
//! of every solid alike). So this is Akinci's form with the boundary sampled infinitely
//! finely and `Ψ` the solid's density: no sampling ripples along a wall, and the same
//! strength per `β` whatever the boundary's sampling. It is of the same order as, not equal
//! to, the single layer of boundary particles Akinci uses (`V_k = 1/Σ W`), which puts the
//! solid's whole mass at its surface where this spreads it through the solid's depth
//! within `h`: a `β` tuned for one does not give the same contact angle in the other.
//!
//! **Units.** `γ` and `β` are the paper's constants, not SI surface energies. The cohesion term
//! reads `γ` in m⁴ kg⁻¹ s⁻² (`γ·m·C` is an acceleration), the curvature term in m/s² (`n` is
//! dimensionless): the paper's two terms do not share units, and the effective surface
//! tension `σ` (N/m) a setting gives depends on the resolution. The cohesion term alone gives,
//! in the mean-field (Kirkwood–Buff) approximation, `σ_coh = 4·(21/28160)·ρ0²·γ·h² ≈
//! 0.00298·ρ0²·γ·h²` ([`cohesion_sigma`]: 1.19 N/m per unit `γ` for water at `h` = 2 cm,
//! 29.8 at 10 cm); the curvature term adds more.
//!
//! **Measured `σ`** (`FluidParams::surface_tension_sigma`, `FluidParamsBuilder::
//! surface_tension_sigma`). The Laplace pressure of settled droplets: a droplet's core
//! pressure (particles within half its radius, averaged over 0.5 s) is `p∞ + 2σ/R`. At γ = 1,
//! h = 2 cm, DFSPH, radii 10, 13 and 16 spacings (4,169, 9,171 and 17,077 particles): 583.3,
//! 572.2 and 568.2 Pa after 0.5 s of settling (σ = 2.0 N/m by least squares), 587.2, 570.5 and
//! 564.2 Pa after 1 s (σ = 3.1 N/m, `p∞` = 524 Pa against the mean field's 493); 586.1 and
//! 575.6 Pa at 10 and 13 spacings after 2 s (2.3 N/m), the test's 10 and 13 spacings 3.9 N/m
//! ± 55 % (its drift and standard errors). The larger droplets' core pressure still wanders
//! by a few Pa from one half-second to the next (its per-frame spread is 17 Pa at 10 spacings,
//! 160–260 Pa at 13 and 16), so `σ` is known to about ±40 %: `σ ≈ 0.00675·ρ0²·γ·h²`
//! (2.7 N/m per unit γ at h = 2 cm, 2.3 times the cohesion's mean field). It scales as
//! `γh²`: at a fixed droplet size in spacings statics are self-similar, and the core pressure
//! at 10 spacings is 292, 585 and 1,172 Pa at h = 1, 2 and 4 cm (γ = 1) and at γ = 0.5, 1
//! and 2 (h = 2 cm), `∝ γh` to 0.3 % (averaged over 1.5 s of a 3 % oscillation); the `ρ0²`
//! is the cohesion's (the curvature term's share scales as `ρ0`, not measured apart). Figures: `cargo run --release --example rayleigh_probe -- --radius R
//! --speed 0 [--settle 1]` at load 12–14 on 2 shared cores.
//!
//! **Droplet oscillations.** Rayleigh's l = 2 period `2π√(ρR³/(8σ))` is *not* what a droplet
//! does at small amplitude. Kicked with the mode's potential flow (deformation about 3 %), a
//! damped sinusoid fitted to its quadrupole gives `ω0·R` = 0.728, 0.741 and 0.732 m/s at
//! R = 10, 12 and 16 spacings (`ω ∝ 1/R`, not `R^{−3/2}`), close to `√(p∞/ρ0)` = 0.765 m/s:
//! the particles, packed by the cohesion, resist shear like a soft solid with a modulus of
//! the order of `p∞`, and ring at its shear mode. Rayleigh's formula read on those periods
//! gives 6.6–10.7 N/m, rising with the radius; at larger amplitude the packing yields and
//! the period lengthens (at 10 spacings 6.6, 6.3, 5.4 and 3.2 N/m for deformations of about
//! 3, 7, 15 and 40 %). The damping (1–3 /s) is numerical, 20–40 times Lamb's viscous `5ν/R²`
//! and nearly the same without viscosity (`tests/surface_tension.rs`, the ignored Rayleigh
//! test; `cargo run --release --example rayleigh_probe -- --radius R --speed V`).
//!
//! **Time step.** The force is explicit, so the adaptive substep also resolves the fastest
//! capillary wave, two spacings long: `dt ≤ courant·2√(ρ0Δx³/(π³σ_coh))`
//! ([`capillary_time_step`], Brackbill et al. 1992's condition for a free surface). With it
//! stability case 16 (`γ` = 53.6 at `h` = 10 cm, `σ_coh` ≈ 1,600 N/m, a 1.19 ms substep at
//! courant 0.4) keeps DFSPH's and PBF's kinetic energy under their initial energy
//! (0.65× and 0.59×; 4.5× and 148× without it). WCSPH still reaches 3.4×, at any substep:
//! the cohesion's mean-field internal pressure `(2π/3)·ρ0²·γ·∫₀^h r³C(r)dr` (132 kPa there)
//! compresses its weakly compressible fluid by up to 61 %. That kinetic energy is released,
//! not created: counted with the cohesion's and the adhesion's potential energy and the
//! equation of state's, the total only falls (the suite's verdict, docs/stability.md).
//!
//! **Cost.** 6.6–6.7 ms a step at 10,240 particles, against 9.8–10.9 ms for the rest of the
//! step (2 shared cores at load 10; `cargo run --release --example dam_break -- --preset water
//! --particles 10000 --steps 100 --fixed --surface-tension 0.015`, and without the flag).
//!
//! **Where it runs.** After the solver, as a velocity change `v_i += dt·a_i` with the
//! substep's densities and neighbour lists at the particles' current positions (a kick the
//! next substep's pressure solve sees, like an external force; for WCSPH and DFSPH the
//! positions have moved by `dt·v` since the search, so a pair that came within `h` during
//! the substep is counted from the next one). The pair loops gather per particle in chunks,
//! so the sums, and the results, do not depend on the thread count.

use crate::domain::Separation;
use crate::kernel::Kernel;
use crate::math::{Real, Vector};
use crate::neighbors::Pairs;
use crate::par::CHUNK;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Akinci's cohesion spline `C(r)` (1/m³) for support `h`.
#[inline(always)]
pub(crate) fn cohesion(r: Real, h: Real) -> Real {
    if r >= h || r <= 0.0 {
        return 0.0;
    }
    // 32/(π h⁹)·(h − r)³r³ = 32/(π h³)·((h − r)/h)³(r/h)³: no h⁹ underflow at small h.
    let (a, b) = ((h - r) / h, r / h);
    let ab3 = (a * b).powi(3);
    let scale = 32.0 / (std::f32::consts::PI * h * h * h);
    if 2.0 * r > h {
        scale * ab3
    } else {
        scale * (2.0 * ab3 - 1.0 / 64.0)
    }
}

/// Akinci's adhesion spline `A(r)` (1/m³) for support `h`.
#[inline(always)]
pub(crate) fn adhesion_spline(r: Real, h: Real) -> Real {
    if r >= h || 2.0 * r <= h {
        return 0.0;
    }
    let q = (-4.0 * r * r / h + 6.0 * r - 2.0 * h) / h;
    0.007 / (h * h * h) * q.max(0.0).powf(0.25)
}

/// `G(d)` of the module docs, tabulated on `[0, h]` (dimensionless: `ρ0·β·G` is the
/// adhesion's acceleration at distance `d` from a flat wall).
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct AdhesionTable {
    h: Real,
    values: Vec<Real>,
}

impl AdhesionTable {
    const SAMPLES: usize = 128;

    /// The table for support `h` (midpoint sums over 2048 steps per integral, in `f64`).
    pub fn new(h: Real) -> Self {
        let n = 2048;
        let hf = h as f64;
        let dr = hf / n as f64;
        let spline = |r: f64| adhesion_spline(r as Real, h) as f64;
        // inner[k] = ∫_{z_k}^h A(r) dr at z_k = k·dr (A vanishes below h/2 by itself).
        let mut inner = vec![0.0f64; n + 1];
        for k in (0..n).rev() {
            inner[k] = inner[k + 1] + spline((k as f64 + 0.5) * dr) * dr;
        }
        // outer[k] = 2π ∫_{z_k}^h z·inner(z) dz.
        let mut outer = vec![0.0f64; n + 1];
        for k in (0..n).rev() {
            let z = (k as f64 + 0.5) * dr;
            let mid = 0.5 * (inner[k] + inner[k + 1]);
            outer[k] = outer[k + 1] + 2.0 * std::f64::consts::PI * z * mid * dr;
        }
        let values = (0..=Self::SAMPLES)
            .map(|s| outer[s * n / Self::SAMPLES] as Real)
            .collect();
        Self { h, values }
    }

    /// The support the table is for.
    pub fn support(&self) -> Real {
        self.h
    }

    /// `G(|d|)` (the half-space from `−|d|` to `|d|` cancels for a particle inside the
    /// solid), linear between samples; 0 at and beyond `h`.
    pub fn eval(&self, d: Real) -> Real {
        let x = d.abs() / self.h * Self::SAMPLES as Real;
        if !(x < Self::SAMPLES as Real) {
            return 0.0;
        }
        let k = x as usize;
        let t = x - k as Real;
        self.values[k] * (1.0 - t) + self.values[k + 1] * t
    }
}

/// `∫₀¹ s⁴ c(s) ds` of the dimensionless cohesion spline `c(s) = (1 − s)³s³` on `(½, 1]`,
/// `2(1 − s)³s³ − 1/64` on `[0, ½]` (`C(r) = 32/(π h³)·c(r/h)`), exactly:
/// `B(8, 4) + ∫₀^½ s⁷(1 − s)³ ds − 1/(64·5·2⁵) = 21/28160`.
const COHESION_MOMENT: f64 = 21.0 / 28160.0;

/// The surface tension `σ` (N/m) the cohesion term gives a flat surface in the mean-field
/// (Kirkwood–Buff, uniform density) approximation: a pair force `−∂u/∂r = −γ m² C(r)`
/// between particles of number density `n = ρ0/m` stores
/// `σ = (π/8) n² ∫₀^h r⁴ ∂u/∂r dr = (π/8) ρ0² γ ∫₀^h r⁴ C(r) dr = 4 ρ0² γ h² · 21/28160`,
/// about `0.00298·ρ0²·γ·h²` (1.19 N/m per unit `γ` for water at `h` = 2 cm; it does not depend
/// on the particle mass). The solver's pressure is isotropic and adds nothing to it; the
/// curvature term `n_i − n_j` is not counted (it is not a pair potential).
pub(crate) fn cohesion_sigma(gamma: Real, rest_density: Real, h: Real) -> Real {
    let (g, rho, h) = (gamma as f64, rest_density as f64, h as f64);
    (4.0 * rho * rho * g * h * h * COHESION_MOMENT) as Real
}

/// `σ` per `ρ0²·γ·h²` (dimensionless) measured from the Laplace pressure of water droplets
/// (module docs, **Units**).
const LAPLACE_SIGMA: f64 = 0.00675;

/// The SI surface tension `σ` (N/m) that `γ` gives (`FluidParams::surface_tension_sigma`):
/// `LAPLACE_SIGMA·ρ0²·γ·h²`.
pub(crate) fn sigma_for_gamma(gamma: Real, rest_density: Real, h: Real) -> Real {
    let (g, rho, h) = (gamma as f64, rest_density as f64, h as f64);
    (LAPLACE_SIGMA * rho * rho * g * h * h) as Real
}

/// The `γ` that gives the SI surface tension `sigma` (N/m), the inverse of
/// [`sigma_for_gamma`] (`FluidParamsBuilder::surface_tension_sigma`).
pub(crate) fn gamma_for_sigma(sigma: Real, rest_density: Real, h: Real) -> Real {
    let (s, rho, h) = (sigma as f64, rest_density as f64, h as f64);
    (s / (LAPLACE_SIGMA * rho * rho * h * h)) as Real
}

/// The capillary limit on the substep (s) for cohesion `γ`: the fastest capillary wave the
/// particles can carry, wavelength two spacings (`k = π/Δx`), has
/// `ω² = σ k³/ρ0` on a free surface (the dispersion relation of capillary waves, void above),
/// and the symplectic-Euler step is stable for `ω·dt < 2` (Brackbill, Kothe & Zemach 1992,
/// J. Comput. Phys. 100, 335, whose `dt < √(ρ̄Δx³/(2πσ))` is the same condition with the
/// mean density of two fluids). The pipeline scales it by its Courant number as it does its
/// other wave limits: `dt ≤ courant · 2/ω = courant · 2 √(ρ0 Δx³/(π³ σ))`, with `σ` from
/// [`cohesion_sigma`]. `Real::MAX` without cohesion, so the limit changes nothing then.
pub(crate) fn capillary_time_step(
    gamma: Real,
    rest_density: Real,
    h: Real,
    spacing: Real,
    courant: Real,
) -> Real {
    let sigma = cohesion_sigma(gamma, rest_density, h);
    if !(sigma > 0.0) {
        return Real::MAX;
    }
    let k = std::f32::consts::PI / spacing;
    let omega = (sigma * k * k * k / rest_density).sqrt();
    courant * 2.0 / omega
}

/// The settings of one application.
#[derive(Copy, Clone)]
pub(crate) struct SurfaceTension<'a> {
    /// Akinci's `γ`.
    pub gamma: Real,
    /// Akinci's `β` times `ρ0` (m/s²): the adhesion per unit `G`.
    pub beta_rest: Real,
    /// Rest density `ρ0` (for `K_ij`).
    pub rest_density: Real,
    /// The substep (s).
    pub dt: Real,
    /// Per particle `Σ_walls G(d) n_w` (empty: no adhesion this substep).
    pub adhesion: &'a [Vector],
}

/// Adds the substep's surface tension and adhesion to `velocities` (`normals`: scratch, one
/// per particle). `K` is the density kernel (for the normals).
pub(crate) fn apply<K: Kernel, S: Separation>(
    c: &SurfaceTension<'_>,
    pairs: &Pairs<'_, S>,
    (densities, inv_densities): (&[Real], &[Real]),
    normals: &mut Vec<Vector>,
    velocities: &mut [Vector],
) {
    let n = velocities.len();
    normals.resize(n, Vector::ZERO);
    if c.gamma > 0.0 {
        let kernel = K::new(pairs.h);
        let scale = pairs.h * pairs.mass;
        crate::par_chunks_mut!(normals[..], CHUNK)
            .enumerate()
            .for_each(|(k, out)| {
                for (l, ni) in out.iter_mut().enumerate() {
                    *ni = normal(pairs, &kernel, inv_densities, k * CHUNK + l) * scale;
                }
            });
    }
    let normals = &normals[..];
    crate::par_chunks_mut!(velocities, CHUNK)
        .enumerate()
        .for_each(|(k, out)| {
            for (l, v) in out.iter_mut().enumerate() {
                let i = k * CHUNK + l;
                let mut a = Vector::ZERO;
                if c.gamma > 0.0 {
                    a -= cohesion_curvature(c, pairs, densities, normals, i) * c.gamma;
                }
                if let Some(w) = c.adhesion.get(i) {
                    a -= *w * c.beta_rest;
                }
                *v += a * c.dt;
            }
        });
}

/// `Σ_j ∇W_ij/ρ_j` of particle `i`.
#[inline(always)]
fn normal<K: Kernel, S: Separation>(
    pairs: &Pairs<'_, S>,
    kernel: &K,
    inv_densities: &[Real],
    i: usize,
) -> Vector {
    let (x, sep) = (pairs.positions, &pairs.sep);
    let mut sum = Vector::ZERO;
    for &j in pairs.neighbors.of(i) {
        let ju = j as usize;
        let r = sep.sep(x[i], x[ju]);
        let d = r.length();
        if d > 0.0 && d < pairs.h {
            sum += r * (kernel.dw(d) / d * inv_densities[ju]);
        }
    }
    sum
}

/// `Σ_j K_ij [m C(|x_ij|) x̂_ij + (n_i − n_j)]` of particle `i`.
#[inline(always)]
fn cohesion_curvature<S: Separation>(
    c: &SurfaceTension<'_>,
    pairs: &Pairs<'_, S>,
    densities: &[Real],
    normals: &[Vector],
    i: usize,
) -> Vector {
    let (x, sep, h) = (pairs.positions, &pairs.sep, pairs.h);
    let two_rest = 2.0 * c.rest_density;
    let mut sum = Vector::ZERO;
    for &j in pairs.neighbors.of(i) {
        let ju = j as usize;
        let r = sep.sep(x[i], x[ju]);
        let d = r.length();
        if d >= h {
            continue;
        }
        let k = two_rest / (densities[i] + densities[ju]);
        let mut f = normals[i] - normals[ju];
        if d > 0.0 {
            f += r * (pairs.mass * cohesion(d, h) / d);
        }
        sum += f * k;
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cohesion spline is continuous at `h/2`, zero at `h`, repulsive below `h/2` and
    /// attractive above it; the adhesion spline is zero at `h/2` and `h` and positive
    /// between.
    #[test]
    fn splines_have_the_papers_shape() {
        let h = 0.04;
        let lo = cohesion(0.5 * h - 1e-6, h);
        let hi = cohesion(0.5 * h + 1e-6, h);
        assert!((lo - hi).abs() <= 1e-3 * hi.abs(), "{lo} vs {hi}");
        assert_eq!(cohesion(h, h), 0.0);
        assert!(cohesion(0.1 * h, h) < 0.0);
        assert!(cohesion(0.7 * h, h) > 0.0);
        assert!(adhesion_spline(0.5 * h, h) == 0.0 && adhesion_spline(h, h) == 0.0);
        assert!(adhesion_spline(0.75 * h, h) > 0.0);
    }

    /// The cohesion moment `∫₀¹ s⁴ c(s) ds` matches a midpoint sum of the spline itself
    /// (so `cohesion_sigma` uses the spline `apply` uses), and the capillary limit is
    /// `Real::MAX` without cohesion.
    #[test]
    fn cohesion_moment_matches_the_spline() {
        let h = 1.0;
        let n = 100_000;
        let ds = 1.0 / n as f64;
        let sum: f64 = (0..n)
            .map(|k| {
                let s = (k as f64 + 0.5) * ds;
                s.powi(4) * cohesion(s as Real, h) as f64 * ds
            })
            .sum();
        // C(r) = 32/(π h³)·c(r/h).
        let moment = sum * std::f64::consts::PI / 32.0;
        assert!(
            (moment - COHESION_MOMENT).abs() <= 1e-4 * COHESION_MOMENT,
            "{moment} vs {COHESION_MOMENT}"
        );
        assert_eq!(capillary_time_step(0.0, 1000.0, 0.02, 0.01, 0.4), Real::MAX);
    }

    /// `G` decreases from its value at the wall to 0 at `h`, and its value at 0 matches a
    /// direct 3-D sum of `A(r)·z/r` over a fine lattice filling the half-space (to the
    /// lattice's quadrature error, 1 %).
    #[test]
    fn adhesion_table_matches_a_direct_sum_over_the_half_space() {
        let h = 1.0;
        let t = AdhesionTable::new(h);
        let mut last = Real::INFINITY;
        for k in 0..=20 {
            let g = t.eval(k as Real * 0.05 * h);
            assert!(g <= last && g >= 0.0);
            last = g;
        }
        assert_eq!(t.eval(h), 0.0);
        let s = 0.02f64;
        let n = (1.0 / s) as i32;
        let mut sum = 0.0f64;
        for a in -n..=n {
            for b in -n..=n {
                for c in 0..n {
                    let (x, y, z) = (a as f64 * s, b as f64 * s, (c as f64 + 0.5) * s);
                    let r = (x * x + y * y + z * z).sqrt();
                    sum += adhesion_spline(r as Real, h) as f64 * z / r * s * s * s;
                }
            }
        }
        let g0 = t.eval(0.0) as f64;
        assert!((g0 - sum).abs() <= 0.01 * sum, "table {g0} vs sum {sum}");
    }
}
