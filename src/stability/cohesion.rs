//! The potential energy of Akinci et al. (2013)'s cohesion and adhesion
//! (`crate::forces::surface_tension`), for the verdict of the surface-tension cases.
//!
//! Without its correction `K_ij` the cohesion is a central pair force, `m·a_i = −γ m² C(r) x̂_ij`,
//! the gradient of the pair potential `γ m² φ(r)`, `φ(r) = −∫_r^h C(s) ds` (zero at the
//! support, lowest at `h/2`). The adhesion to a flat wall, `a_i = −β ρ0 G(d) n_w`, is the
//! gradient of `ψ(d) = −β ρ0 ∫_d^h G(s) ds` per unit mass (`n_w = ∇d`). Neither the
//! correction `K_ij = 2ρ0/(ρ_i + ρ_j)` nor the curvature term `n_i − n_j` is counted: they
//! have no potential, so what they create or destroy is what the verdict sees.

use crate::boundary::wall::surface_near;
use crate::forces::surface_tension::AdhesionTable;
use crate::math::{Real, Vector};
use crate::world::FluidWorld;
use crate::{Fluid, FluidHandle};
use std::collections::HashMap;

/// `∫_s^1 c(t) dt` of the dimensionless cohesion spline (`C(r) = 32/(π h³)·c(r/h)`,
/// `c = t³(1 − t)³` on `(½, 1]`, `2t³(1 − t)³ − 1/64` on `[0, ½]`), exactly.
fn spline_tail(s: f64) -> f64 {
    // P' = t³(1 − t)³.
    let p = |t: f64| t.powi(4) / 4.0 - 3.0 * t.powi(5) / 5.0 + t.powi(6) / 2.0 - t.powi(7) / 7.0;
    if s >= 1.0 {
        0.0
    } else if s > 0.5 {
        p(1.0) - p(s)
    } else {
        p(1.0) - p(0.5) + 2.0 * (p(0.5) - p(s)) - (0.5 - s) / 64.0
    }
}

/// The cohesion's pair potential `γ m² φ(r)` summed over the fluid's pairs (J).
pub(super) fn cohesion_energy(fluid: &Fluid) -> f64 {
    let p = fluid.params();
    let gamma = p.surface_tension as f64;
    if gamma <= 0.0 {
        return 0.0;
    }
    let (h, m) = (p.smoothing_length, p.particle_mass as f64);
    let scale = 32.0 / (std::f64::consts::PI * (h as f64) * (h as f64));
    let x = fluid.positions();
    let cell = |v: Vector| {
        let c = (v / h).floor();
        (c.x as i64, c.y as i64, c.z as i64)
    };
    let mut grid: HashMap<(i64, i64, i64), Vec<usize>> = HashMap::new();
    for (i, &v) in x.iter().enumerate() {
        grid.entry(cell(v)).or_default().push(i);
    }
    let mut sum = 0.0f64;
    for (i, &xi) in x.iter().enumerate() {
        let (cx, cy, cz) = cell(xi);
        for d in 0..27i64 {
            let key = (cx + d % 3 - 1, cy + (d / 3) % 3 - 1, cz + d / 9 - 1);
            for &j in grid.get(&key).map_or(&[][..], |v| &v[..]) {
                if j <= i {
                    continue;
                }
                let r = (xi - x[j]).length();
                if r < h {
                    sum -= scale * spline_tail((r / h) as f64);
                }
            }
        }
    }
    gamma * m * m * sum
}

/// The adhesion's potential `Σ_i m Σ_walls ψ(d_i)` (J) over the world's colliders.
pub(super) fn adhesion_energy(world: &FluidWorld, handle: FluidHandle) -> f64 {
    let fluid = &world.fluids[handle];
    let p = fluid.params();
    let beta_rest = (p.adhesion * p.rest_density) as f64;
    if beta_rest <= 0.0 {
        return 0.0;
    }
    let h = p.smoothing_length;
    let table = AdhesionTable::new(h);
    // ψ(d)/(−βρ0) = ∫_d^h G on 256 midpoint steps, then linear in between.
    let n = 256;
    let ds = h as f64 / n as f64;
    let mut tail = vec![0.0f64; n + 1];
    for k in (0..n).rev() {
        tail[k] = tail[k + 1] + table.eval(((k as f64 + 0.5) * ds) as Real) as f64 * ds;
    }
    let psi = |d: Real| {
        let t = (d.abs() as f64 / ds).min(n as f64);
        let k = (t as usize).min(n - 1);
        let f = t - k as f64;
        -beta_rest * (tail[k] * (1.0 - f) + tail[k + 1] * f)
    };
    let m = p.particle_mass as f64;
    let colliders = &world.physics.colliders;
    fluid
        .positions()
        .iter()
        .map(|&x| {
            colliders
                .iter()
                .filter_map(|(_, co)| surface_near(co, co.position(), x, h))
                .map(|(d, _, _)| m * psi(d))
                .sum::<f64>()
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `spline_tail` is the integral of the spline `apply` uses (a midpoint sum of
    /// `forces::surface_tension::cohesion`), on both branches.
    #[test]
    fn spline_tail_integrates_the_cohesion_spline() {
        let h = 1.0;
        for s in [0.0, 0.2, 0.5, 0.7, 0.95] {
            let n = 200_000;
            let ds = (1.0 - s) / n as f64;
            let sum: f64 = (0..n)
                .map(|k| {
                    let r = s + (k as f64 + 0.5) * ds;
                    crate::forces::surface_tension::cohesion(r as Real, h) as f64 * ds
                })
                .sum();
            let exact = 32.0 / std::f64::consts::PI * spline_tail(s);
            assert!((sum - exact).abs() <= 1e-5, "s = {s}: {sum} vs {exact}");
        }
    }
}
