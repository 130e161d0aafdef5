//! Kernel integrals over a half-space: the density a wall contributes to a particle near it.
//!
//! For a particle at signed distance `d` from a plane (positive on the fluid side), the part of
//! its kernel support lying beyond the plane is
//!
//! ```text
//! Φ(d) = ∫_{z > d} A(z) dz,      A(z) = 2π ∫_{|z|}^{h} W(r) r dr,
//! ```
//!
//! where `A(z)` is the kernel integrated over the disc at height `z`. A solid of rest density
//! `ρ0` filling that half-space contributes `ρ0·Φ(d)` to the particle's density, and its
//! gradient `∇Φ = −A(d)·n` (with `n` the plane's normal pointing into the fluid): this is the
//! density-map boundary of Koschier & Bender (2017, "Density maps for improved SPH boundary
//! handling", SCA), with the collider's surface taken as locally planar at the closest point
//! instead of pre-integrated on a grid. It needs nothing but a point projection, so it works
//! for every parry shape of any size, static or moving.
//!
//! **Ghost rows.** The fluid's own density is a *sum* over particles, and with the usual
//! `h = 2·spacing` a sum over a half lattice differs from the integral over the half-space by
//! about 4 % of `ρ0` (the midpoint rule is coarse at two rows per kernel radius). Added to the
//! exact `Φ`, a lattice resting half a spacing from a wall would start 4 % over-dense and be
//! kicked off the wall. So, for the fluid's spacing `s`, the wall is integrated as the rows of
//! a lattice continuing behind it, its first row half a spacing behind the surface:
//!
//! ```text
//! Φ_s(d) = Σ_{k ≥ 0} s·A(d + s/2 + k·s),
//! ```
//!
//! each row's plane integrated exactly. A particle half a spacing from a flat wall inside a
//! resting lattice then gets exactly the full lattice's density (tested), and `Φ_s` stays
//! smooth in `d`, as the boundary particles of Akinci et al. (2012) would be if they were laid
//! out as the fluid's own lattice.
//!
//! **Registration.** Integrating each ghost row exactly in its plane is the lattice's in-plane
//! sum averaged over where the particle sits relative to the ghost sites. The fluid's own
//! lattice continued behind the wall (sites aligned with the particle) differs from that
//! average: for the cubic spline at `h = 2s`, half a spacing from the wall, its density is
//! 0.21 % lower and its gradient 2.0 % higher than the table's, the same 2.0 % by which the
//! lattice's own first moment exceeds the identity (1.020; tested below, and printed for
//! every kernel by `examples/wall_calibration.rs`). Aligned tables measured no consistent
//! difference in the hydrostatic scene's bottom pressure, so the average is used: it is the
//! one right for a fluid that is not a lattice.
//!
//! Both `Φ_s` and `−dΦ_s/dd` are tabulated once per kernel, support radius and spacing (512
//! intervals over `d ∈ [−h, h]`, linear interpolation; the integrals use Simpson's rule in
//! double precision).

use super::Kernel;
use crate::math::Real;

/// Intervals of the tables over `[−h, h]`.
const INTERVALS: usize = 512;

/// Tabulated `Φ(d)` and `A(d) = −dΦ/dd` for one kernel and support radius.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HalfSpaceTable {
    h: Real,
    inv_step: Real,
    phi: Vec<Real>,
    area: Vec<Real>,
    moment: Vec<Real>,
}

impl HalfSpaceTable {
    /// Tabulates the wall integrals of kernel `K` with support `h`, for a fluid of particle
    /// spacing `spacing` (see the module docs).
    pub fn new<K: Kernel>(h: Real, spacing: Real) -> Self {
        let kernel = K::new(h);
        let hf = h as f64;
        let s = spacing as f64;
        // Radial integral R(z) = ∫_{z}^{h} W(r) r dr, by Simpson on a fine grid.
        let radial = |z: f64| -> f64 {
            let z = z.abs();
            if z >= hf {
                return 0.0;
            }
            let m = 256;
            let step = (hf - z) / m as f64;
            let f = |r: f64| kernel.w(r as Real) as f64 * r;
            let mut sum = f(z) + f(hf);
            for k in 1..m {
                let r = z + step * k as f64;
                sum += f(r) * if k % 2 == 1 { 4.0 } else { 2.0 };
            }
            sum * step / 3.0
        };
        // A(z): the kernel integrated over the plane at height z.
        let area_at = |z: f64| 2.0 * std::f64::consts::PI * radial(z);
        // N(z) = ∫_plane |W'(r)|·z²/r dA = 2π·z²·W(|z|): the plane's share of the normal
        // component of the first moment (see `moment` below).
        let normal_at = |z: f64| {
            if z.abs() >= hf {
                0.0
            } else {
                2.0 * std::f64::consts::PI * z * z * kernel.w(z.abs() as Real) as f64
            }
        };
        let moment_at = |d: f64| -> f64 {
            let mut sum = 0.0;
            let mut z = d + 0.5 * s;
            while z < hf {
                sum += s * normal_at(z);
                z += s;
            }
            sum
        };
        // Φ_s(d): ghost rows at d + s/2 + k·s behind the wall, each a plane integral.
        let phi_at = |d: f64| -> f64 {
            let mut sum = 0.0;
            let mut z = d + 0.5 * s;
            while z < hf {
                sum += s * area_at(z);
                z += s;
            }
            sum
        };
        let step = 2.0 * hf / INTERVALS as f64;
        let d_at = |k: usize| -hf + step * k as f64;
        let phi: Vec<f64> = (0..=INTERVALS).map(|k| phi_at(d_at(k))).collect();
        // −dΦ/dd by central differences of the exact sum (one-sided at the table's ends).
        let e = 1e-4 * hf;
        let area: Vec<f64> = (0..=INTERVALS)
            .map(|k| {
                let d = d_at(k);
                -(phi_at(d + e) - phi_at(d - e)) / (2.0 * e)
            })
            .collect();
        let moment = (0..=INTERVALS)
            .map(|k| moment_at(d_at(k)) as Real)
            .collect();
        Self {
            h,
            inv_step: (1.0 / step) as Real,
            phi: phi.into_iter().map(|v| v as Real).collect(),
            area: area.into_iter().map(|v| v as Real).collect(),
            moment,
        }
    }

    /// Support radius the table was made for.
    pub fn support(&self) -> Real {
        self.h
    }

    /// `(Φ(d), A(d))`: the kernel mass beyond a plane at signed distance `d`, and minus its
    /// derivative. `Φ = 0` and `A = 0` for `d ≥ h`; for `d ≤ −h` (deep inside) `Φ` is the whole
    /// kernel's integral and `A = 0`.
    #[inline]
    pub fn eval(&self, d: Real) -> (Real, Real) {
        self.lookup(d, &self.area)
    }

    /// `(Φ(d), v(d))` for the table `v`, linearly interpolated; zeros for an empty table or
    /// a NaN distance.
    #[inline]
    fn lookup(&self, d: Real, v: &[Real]) -> (Real, Real) {
        let Some((k, t)) = self.interval(d) else {
            return (0.0, 0.0);
        };
        let lerp = |v: &[Real]| v[k] + (v[k + 1] - v[k]) * t;
        (lerp(&self.phi), lerp(v))
    }

    /// The interval `k` of `d` and the position `t ∈ [0, 1]` in it; `None` for an empty
    /// table or a NaN distance.
    #[inline(always)]
    fn interval(&self, d: Real) -> Option<(usize, Real)> {
        if self.phi.is_empty() {
            return None;
        }
        let x = ((d + self.h) * self.inv_step).clamp(0.0, INTERVALS as Real);
        if x.is_nan() {
            return None;
        }
        let k = (x as usize).min(INTERVALS - 1);
        Some((k, x - k as Real))
    }

    /// `(Φ(d), A(d), M(d))`: [`Self::eval`] and [`Self::eval_moment`] in one look-up (the
    /// same values to the last bit, the interval found once).
    #[inline]
    pub fn eval_with_moment(&self, d: Real) -> (Real, Real, Real) {
        let Some((k, t)) = self.interval(d) else {
            return (0.0, 0.0, 0.0);
        };
        let lerp = |v: &[Real]| v[k] + (v[k + 1] - v[k]) * t;
        (lerp(&self.phi), lerp(&self.area), lerp(&self.moment))
    }

    /// `(Φ(d), M(d))`: the wall's share of the kernel's first moment. The moment
    /// `Σ_b V_b (x_b − x_i) ⊗ ∇W_ib` over the wall's ghost rows (the identity over the whole
    /// space) is `M·n⊗n + Φ·(I − n⊗n)` for a wall of normal `n`: its tangential part equals
    /// `Φ` (per plane, `π∫|W'|(r² − z²)dr = 2π∫W r dr`), its normal part is
    /// `M(d) = Σ_k s·2π z_k² W(z_k)` over the rows `z_k = d + s/2 + k·s`. The wall's
    /// hydrostatic pressure acts through it (see `src/boundary/wall/`).
    #[inline]
    pub fn eval_moment(&self, d: Real) -> (Real, Real) {
        self.lookup(d, &self.moment)
    }

    /// The whole kernel's integral `Φ(−h)` (1 for a normalised kernel).
    pub fn full(&self) -> Real {
        self.phi.first().copied().unwrap_or(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::{CubicSpline, Poly6, Spiky, WendlandC2};

    fn check<K: Kernel>() {
        let h = 0.1;
        let t = HalfSpaceTable::new::<K>(h, 0.5 * h);
        // Deep inside, the ghost rows cover the whole kernel: a normalised kernel's sum over
        // rows two per support radius is within 3 % of one (cubic spline 0.01 %, Wendland 0.8 %, spiky 2.7 %).
        assert!((t.full() - 1.0).abs() < 3e-2, "{}: {}", K::NAME, t.full());
        assert!(t.eval(0.0).0 > 0.3 && t.eval(0.0).0 < 0.7, "{}", K::NAME);
        assert_eq!(t.eval(h).0, 0.0);
        assert_eq!(t.eval(2.0 * h), (0.0, 0.0));
        // A is minus the derivative of Φ: compare with a central difference.
        for k in 1..20 {
            let d = -h + 2.0 * h * k as Real / 20.0;
            let e = 1e-3 * h;
            let fd = -(t.eval(d + e).0 - t.eval(d - e).0) / (2.0 * e);
            let a = t.eval(d).1;
            // Linear interpolation of Φ makes the difference quotient the slope of one table
            // interval: it differs from A by about A'·interval/2, a few per cent of A's peak.
            let peak = (0..=40)
                .map(|k| t.eval(-h + 2.0 * h * k as Real / 40.0).1)
                .fold(0.0, Real::max);
            assert!(
                (fd - a).abs() < 0.03 * peak,
                "{} d={d}: {fd} vs {a}",
                K::NAME
            );
        }
        // Φ decreases from the whole kernel to zero (up to the ripple of the ghost rows'
        // sampling deep inside, under 1 % of the whole).
        let mut last = Real::MAX;
        for k in 0..=100 {
            let v = t.eval(-h + 2.0 * h * k as Real / 100.0).0;
            assert!(
                v <= last + 0.01 * t.full(),
                "{}: not decreasing at {k}",
                K::NAME
            );
            last = v;
        }
        // On the fluid side it decreases strictly.
        let mut last = Real::MAX;
        for k in 0..=50 {
            let v = t.eval(h * k as Real / 50.0).0;
            assert!(v <= last);
            last = v;
        }
    }

    /// The one-look-up `eval_with_moment` gives `eval` and `eval_moment` to the last bit,
    /// across the table, at its ends, beyond them and for a NaN distance.
    #[test]
    fn eval_with_moment_matches_the_separate_lookups() {
        let h: Real = 0.075;
        let t = HalfSpaceTable::new::<CubicSpline>(h, 0.5 * h);
        let mut ds: Vec<Real> = (-1200..=1200).map(|k| k as Real * 1e-3 * h).collect();
        ds.extend([
            -h,
            h,
            0.0,
            -0.0,
            Real::NAN,
            Real::INFINITY,
            Real::NEG_INFINITY,
        ]);
        for d in ds {
            let (phi, area, moment) = t.eval_with_moment(d);
            let (phi1, area1) = t.eval(d);
            let (phi2, moment2) = t.eval_moment(d);
            assert_eq!(phi.to_bits(), phi1.to_bits(), "Φ at {d}");
            assert_eq!(phi.to_bits(), phi2.to_bits(), "Φ at {d}");
            assert_eq!(area.to_bits(), area1.to_bits(), "A at {d}");
            assert_eq!(moment.to_bits(), moment2.to_bits(), "M at {d}");
        }
        let empty = HalfSpaceTable::default();
        assert_eq!(empty.eval_with_moment(0.0), (0.0, 0.0, 0.0));
    }

    #[test]
    fn half_space_integrals() {
        check::<CubicSpline>();
        check::<WendlandC2>();
        check::<Poly6>();
        check::<Spiky>();
    }

    #[test]
    fn wall_moment_completes_the_lattice_moment() {
        // The first moment Σ V (x_j − x_i) ⊗ ∇W_ij of a full lattice is about the identity. A
        // particle half a spacing above a wall has the lattice only on its side: the wall's
        // normal moment M(s/2) and tangential moment Φ(s/2) must stand in for the missing
        // half, component by component.
        let s: Real = 0.05;
        let h = 2.0 * s;
        let k = CubicSpline::new(h);
        let t = HalfSpaceTable::new::<CubicSpline>(h, s);
        let (mut full_n, mut full_t, mut half_n, mut half_t) = (0.0, 0.0, 0.0, 0.0);
        for i in -4i32..=4 {
            for j in -4i32..=4 {
                for l in -4i32..=4 {
                    let p = [i as Real * s, j as Real * s, l as Real * s];
                    let d = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                    if d == 0.0 {
                        continue;
                    }
                    // |∇W|·r_a²/r, per component (V = s³).
                    let g = -k.dw(d) / d * s * s * s;
                    let (n, tan) = (g * p[2] * p[2], g * p[0] * p[0]);
                    full_n += n;
                    full_t += tan;
                    if l >= 0 {
                        half_n += n;
                        half_t += tan;
                    }
                }
            }
        }
        let (phi, m) = t.eval_moment(0.5 * s);
        // Two rows per support radius: the lattice's moment is the identity within a few per
        // cent (1.020 for the cubic spline).
        assert!((full_n - 1.0).abs() < 0.03, "lattice moment {full_n}");
        assert!(
            (half_n + m - full_n).abs() < 0.01 * full_n,
            "normal: {half_n} + {m} vs {full_n}"
        );
        assert!(
            (half_t + phi - full_t).abs() < 0.01 * full_t,
            "tangential: {half_t} + {phi} vs {full_t}"
        );
        // Deep inside the wall the ghost rows hold the whole moment; beyond h nothing.
        assert!(
            (t.eval_moment(-h).1 - 1.0).abs() < 0.03,
            "{}",
            t.eval_moment(-h).1
        );
        assert_eq!(t.eval_moment(h).1, 0.0);
    }

    #[test]
    fn lattice_sum_matches_the_integral() {
        // A particle half a spacing from a wall, with the fluid side filled by a lattice: the
        // lattice sum plus ρ0·Φ must be close to the full-space lattice sum (the wall stands in
        // for the missing lattice half).
        let s: Real = 0.05;
        let h = 2.0 * s;
        let k = CubicSpline::new(h);
        let t = HalfSpaceTable::new::<CubicSpline>(h, s);
        let mut full = 0.0;
        let mut half = 0.0;
        for i in -4i32..=4 {
            for j in -4i32..=4 {
                for l in -4i32..=4 {
                    let p = [i as Real * s, j as Real * s, l as Real * s];
                    let d = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                    let w = k.w(d) * s * s * s;
                    full += w;
                    // Particle at z = s/2 above a wall at 0: lattice rows at z = s/2 + l·s ≥ s/2.
                    if l >= 0 {
                        half += w;
                    }
                }
            }
        }
        let walled = half + t.eval(0.5 * s).0;
        // The in-plane sums are discrete here and integrals in the table: they agree to a few
        // per mille at this resolution (the full lattice sum itself is 1 within 1e-4).
        assert!((walled - full).abs() < 0.005 * full, "{walled} vs {full}");
    }
}

#[cfg(test)]
mod lattice_calibration {
    use super::*;
    use crate::kernel::CubicSpline;

    /// `(Σ V·W, Σ V·|∂W/∂z|)` over the ghost rows `z_b = −s/2 − k·s` of a lattice continuing
    /// behind a wall at 0, seen from a particle at height `z` whose in-plane offset from the
    /// ghost lattice's sites is `(ox, oy)·s`.
    fn ghost_sums(k: &CubicSpline, s: f64, z: f64, ox: f64, oy: f64) -> (f64, f64) {
        let v = s * s * s;
        let (mut rho, mut grad) = (0.0, 0.0);
        for i in -5i32..=5 {
            for j in -5i32..=5 {
                for l in 0..4 {
                    let (dx, dy) = ((i as f64 + ox) * s, (j as f64 + oy) * s);
                    let dz = z + 0.5 * s + l as f64 * s;
                    let d = (dx * dx + dy * dy + dz * dz).sqrt();
                    rho += v * k.w(d as Real) as f64;
                    grad += v * -(k.dw(d as Real) as f64) * dz / d;
                }
            }
        }
        (rho, grad)
    }

    #[test]
    fn wall_is_the_lattice_averaged_over_its_registration() {
        // The table integrates each ghost row exactly in its plane: that is the lattice's
        // in-plane sum averaged over where the particle sits relative to the ghost lattice's
        // sites. A lattice continuing the fluid's own sites (aligned) differs from the average
        // by the same factor as the lattice's own first moment (1.020 for the cubic spline at
        // h = 2s): the wall's |∇ρ| at s/2 is 1.96 % below the aligned lattice's, and the
        // fluid's pressure gradient on that lattice 2 % steeper than the continuum's.
        let s = 0.0125f64;
        let h = 2.0 * s;
        let k = CubicSpline::new(h as Real);
        let t = HalfSpaceTable::new::<CubicSpline>(h as Real, s as Real);
        let (phi, area) = t.eval((0.5 * s) as Real);
        let n = 8;
        let (mut rho_avg, mut grad_avg) = (0.0, 0.0);
        for a in 0..n {
            for b in 0..n {
                let (r, g) = ghost_sums(&k, s, 0.5 * s, a as f64 / n as f64, b as f64 / n as f64);
                rho_avg += r / (n * n) as f64;
                grad_avg += g / (n * n) as f64;
            }
        }
        assert!(
            (phi as f64 / rho_avg - 1.0).abs() < 2e-3,
            "{phi} vs {rho_avg}"
        );
        assert!(
            (area as f64 / grad_avg - 1.0).abs() < 2e-3,
            "{area} vs {grad_avg}"
        );
        // Aligned: the fluid's own lattice continued.
        let (_, aligned) = ghost_sums(&k, s, 0.5 * s, 0.0, 0.0);
        let mut moment = 0.0;
        for i in -4i32..=4 {
            for j in -4i32..=4 {
                for l in -4i32..=4 {
                    let p = [i as f64 * s, j as f64 * s, l as f64 * s];
                    let d = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                    if d > 0.0 {
                        moment += s * s * s * -(k.dw(d as Real) as f64) / d * p[2] * p[2];
                    }
                }
            }
        }
        let ratio = aligned / area as f64;
        assert!((ratio - 1.0200).abs() < 1e-3, "aligned / table {ratio}");
        assert!(
            (ratio - moment).abs() < 1e-3,
            "{ratio} vs lattice moment {moment}"
        );
    }
}
