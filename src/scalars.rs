//! Scalars carried by the particles — a dye, a paint colour channel, a temperature, a
//! concentration — and their diffusion between neighbours (the stage
//! [`crate::Stage::ScalarDiffusion`], which runs only for a fluid that has scalars).
//!
//! A scalar is added to a fluid with [`crate::Fluid::add_scalar`] and read or written with
//! [`crate::Fluid::scalar`] / [`crate::Fluid::scalar_mut`]; its values follow the particles
//! through every re-sort, removal and append (new particles start at 0). Each substep it
//! diffuses with its diffusivity `D` (m²/s) by the SPH Laplacian
//!
//! `dC_i/dt = D Σ_j (m/ρ0) · (C_j − C_i) · ∇²W(|x_i − x_j|)`,
//!
//! with the kernel Laplacian of the viscosity stage, `∇²W = 45/(πh⁶)(h − r)` (Müller et al.
//! 2003). Its second moment is one (`(1/6)∫∇²W r² dV = 1`, the condition for
//! `Σ_j V_j (C_j − C_i) K(r_ij)` to approximate `∇²C` on a uniform particle distribution, as
//! Brookshaw's `2|∇W|/r` does), so on a resting lattice the scheme is the heat equation. The
//! particle volume is the rest volume `m/ρ0` (every solver's densities are not in the same
//! units: Clavet's are its kernels' own), so the pair weight is symmetric and `Σ_i C_i` (the
//! amount of dye, particles of one mass) is conserved exactly up to rounding.
//!
//! **Bounded at any setting.** Over a substep `dt` the update is `C_i' = C_i + Σ_j c_ij (C_j −
//! C_i)` with symmetric `c_ij = dt·D·(m/ρ0)·∇²W_ij`: the viscosity stage's exchange
//! with a scalar in place of a velocity (see `forces::viscosity`, "The explicit limit"). With
//! every row sum `S_i = Σ_j c_ij ≤ 1/2` each `C_i'` is a convex combination of `C_i` and its
//! neighbours' values: no new extreme (paint never goes past its own colours) and no
//! oscillation. Beyond that (a large `D`, a long substep) every pair's `c_ij` is scaled by
//! `1/max(1, 2S_i, 2S_j)` — still symmetric, so still conservative — and the scalar then
//! diffuses at most as fast as that bound allows (counted in
//! [`crate::StepReport::scalar_limited`]). On a resting lattice `S ≈ 15·dt·D/h²` (`∫∇²W dV =
//! 15/h²`), so the bound is `D·dt ≤ h²/30`: 0.02 m²/s at h = 10 cm and 1/60 s substeps, far
//! above any real dye in water (10⁻⁹ m²/s); a game wanting visible mixing over a distance `L`
//! within `T` seconds sets `D ≈ L²/T`.
//!
//! Scalars never act back on the flow (passive). Across fluids they do not mix: each fluid's
//! scalars diffuse among its own particles.

use crate::domain::Separation;
use crate::kernel::ViscosityLaplacian;
use crate::math::Real;
use crate::neighbors::Pairs;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// The prefix of a scalar's attribute name (`crate::fluid::Attributes`), so that scalars and
/// the solvers' own per-particle values never share a name.
pub(crate) const PREFIX: &str = "scalar:";

/// A scalar a fluid carries: its name and diffusivity.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub(crate) struct ScalarSpec {
    /// The name the game gave it.
    pub name: String,
    /// Diffusivity `D` (m²/s, ≥ 0).
    pub diffusivity: Real,
}

impl ScalarSpec {
    /// The attribute the values are stored under.
    pub fn attribute(&self) -> String {
        format!("{PREFIX}{}", self.name)
    }
}

/// Largest row sum of the exchange over one substep (see the module docs).
const MAX_EXCHANGE: Real = 0.5;

/// Diffuses `values` over one substep `dt` with diffusivity `diffusivity`, reading the
/// neighbour `pairs` and the rest density `rho0`; `scratch` receives the new values (and is
/// swapped in), `rows` the row sums. Returns how many particles were limited.
pub(crate) fn diffuse<S: Separation>(
    pairs: &Pairs<'_, S>,
    rho0: Real,
    (diffusivity, dt): (Real, Real),
    values: &mut Vec<Real>,
    (scratch, rows): (&mut Vec<Real>, &mut Vec<Real>),
) -> usize {
    let n = values.len();
    if diffusivity <= 0.0 || n == 0 {
        return 0;
    }
    let lap = ViscosityLaplacian::new(pairs.h);
    let coef = dt * diffusivity * pairs.mass / rho0;
    // The lists are the substep's start's; a pair that moved apart beyond `h` since weighs 0.
    let weight = |i: usize, j: usize| -> Real {
        let r = pairs
            .sep
            .sep(pairs.positions[i], pairs.positions[j])
            .length();
        coef * lap.laplacian(r)
    };
    rows.clear();
    rows.resize(n, 0.0);
    crate::par_chunks_mut!(rows, crate::par::CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            for (k, s) in out.iter_mut().enumerate() {
                let i = c * crate::par::CHUNK + k;
                *s = pairs
                    .neighbors
                    .of(i)
                    .iter()
                    .map(|&j| weight(i, j as usize))
                    .sum();
            }
        });
    let (rows, old) = (&rows[..], &values[..]);
    scratch.clear();
    scratch.resize(n, 0.0);
    crate::par_chunks_mut!(scratch, crate::par::CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            for (k, v) in out.iter_mut().enumerate() {
                let i = c * crate::par::CHUNK + k;
                let mut change = 0.0;
                for &j in pairs.neighbors.of(i) {
                    let j = j as usize;
                    let limit = (2.0 * rows[i].max(rows[j])).max(1.0);
                    change += weight(i, j) / limit * (old[j] - old[i]);
                }
                *v = old[i] + change;
            }
        });
    let limited = rows.iter().filter(|s| !(**s <= MAX_EXCHANGE)).count();
    std::mem::swap(values, scratch);
    limited
}
