//! Kernel properties, for every kernel: normalisation, derivative, compact support, finiteness.

use super::*;

const H: Real = 0.1;

/// `∫ 4π d² f(d) dd` over `[0, h]` by the midpoint rule in f64 (200 000 intervals).
fn radial_integral(h: Real, f: impl Fn(Real) -> Real) -> f64 {
    let n = 200_000;
    let dd = h as f64 / n as f64;
    (0..n)
        .map(|k| {
            let d = (k as f64 + 0.5) * dd;
            4.0 * std::f64::consts::PI * d * d * f(d as Real) as f64 * dd
        })
        .sum()
}

#[test]
fn normalised_kernels_integrate_to_one() {
    for kind in KernelKind::ALL {
        if kind == KernelKind::PaperPoly6 {
            continue;
        }
        for h in [0.01, H, 0.4, 2.0] {
            let integral = radial_integral(h, |d| kind.w(d, h));
            assert!(
                (integral - 1.0).abs() < 1e-3,
                "{} with h = {h}: ∫W = {integral}",
                kind.name()
            );
        }
    }
}

#[test]
fn paper_poly6_integrates_to_its_documented_value() {
    // ∫W = 315/(64π h⁹) · 4π h^(9.4) · ∫₀¹ u²(1 − u^1.6)⁴ du = (315/16)·h^0.4·I,
    // I computed independently in f64 from the formula, not from the kernel code.
    let n = 200_000;
    let i: f64 = (0..n)
        .map(|k| {
            let u = (k as f64 + 0.5) / n as f64;
            u * u * (1.0 - u.powf(1.6)).powi(4) / n as f64
        })
        .sum();
    for h in [0.1f32, 0.4, 1.0] {
        let expected = 315.0 / 16.0 * (h as f64).powf(0.4) * i;
        let integral = radial_integral(h, |d| KernelKind::PaperPoly6.w(d, h));
        assert!(
            (integral / expected - 1.0).abs() < 1e-3,
            "h = {h}: {integral} vs {expected}"
        );
        // And it is visibly not normalised: that is the paper's kernel, reproduced as printed.
        assert!((integral - 1.0).abs() > 0.05);
    }
}

#[test]
fn derivative_matches_finite_difference() {
    for kind in KernelKind::ALL {
        for h in [H, 0.4] {
            let max_dw = (0..1000)
                .map(|k| kind.dw(h * k as Real / 1000.0, h).abs())
                .fold(0.0, Real::max);
            let eps = 1e-3 * h;
            for k in 1..200 {
                let d = h * k as Real / 200.0;
                if (d - h).abs() < 2.0 * eps || (d - 0.5 * h).abs() < 2.0 * eps {
                    continue; // the cubic spline's knots: one-sided derivatives differ at C2 level only
                }
                let fd =
                    (kind.w(d + eps, h) as f64 - kind.w(d - eps, h) as f64) / (2.0 * eps as f64);
                let dw = kind.dw(d, h) as f64;
                assert!(
                    (fd - dw).abs() <= 2e-3 * max_dw as f64,
                    "{} h={h} d={d}: dW={dw} finite difference={fd}",
                    kind.name()
                );
            }
        }
    }
}

#[test]
fn zero_at_and_beyond_support() {
    for kind in KernelKind::ALL {
        for d in [H, H * 1.0001, 2.0 * H, 1e6] {
            assert_eq!(kind.w(d, H), 0.0, "{} W({d})", kind.name());
            assert_eq!(kind.dw(d, H), 0.0, "{} dW({d})", kind.name());
        }
        // Continuous at the edge: just inside, it is already tiny.
        let inside = kind.w(H * 0.999, H) / kind.w(0.0, H);
        assert!(
            inside < 1e-4,
            "{} not continuous at h: {inside}",
            kind.name()
        );
    }
    let lap = ViscosityLaplacian::new(H);
    assert_eq!(lap.laplacian(H), 0.0);
    assert_eq!(lap.laplacian(3.0 * H), 0.0);
}

#[test]
fn finite_at_zero_and_gradient_defined_for_coincident_particles() {
    for kind in KernelKind::ALL {
        let w0 = kind.w(0.0, H);
        assert!(w0.is_finite() && w0 > 0.0, "{} W(0) = {w0}", kind.name());
        assert!(kind.dw(0.0, H).is_finite());
        crate::with_kernel!(kind, K => {
            let k = K::new(H);
            let g = k.gradient(Vector::ZERO, 0.0, 3, 7);
            let g_rev = k.gradient(Vector::ZERO, 0.0, 7, 3);
            assert!(crate::math::is_finite(g));
            assert_eq!(g, -g_rev, "{}: coincident gradient must be antisymmetric", K::NAME);
        });
    }
    // Spiky's derivative does not vanish at 0: coincident particles do get pushed apart.
    let g = Spiky::new(H).gradient(Vector::ZERO, 0.0, 0, 1);
    assert!(g.length() > 0.0);
    assert!(ViscosityLaplacian::new(H).laplacian(0.0).is_finite());
}

#[test]
fn gradient_is_antisymmetric_and_points_along_separation() {
    let r = Vector::new(0.03, -0.01, 0.02);
    let d = r.length();
    for kind in KernelKind::ALL {
        crate::with_kernel!(kind, K => {
            let k = K::new(H);
            let g = k.gradient(r, d, 0, 1);
            let g_rev = k.gradient(-r, d, 1, 0);
            assert!((g + g_rev).length() <= 1e-6 * g.length().max(1e-30));
            // Kernels decrease outward, so the gradient points against r.
            assert!(g.dot(r) <= 0.0, "{}", K::NAME);
        });
    }
}

#[test]
fn viscosity_laplacian_matches_numerical_laplacian_of_its_kernel() {
    // ∇²W = (1/d²) d/dd (d² dW/dd), evaluated by finite differences in f64 on the f32 kernel.
    let h = 1.0;
    let lap = ViscosityLaplacian::new(h);
    // Step 5e-3: the f32 kernel's round-off (~1e-7·W) divided by eps² stays near 1e-2,
    // while the truncation error O(eps²·W⁗) is smaller still away from the singular d = 0.
    let eps = 5e-3f64;
    let w = |d: f64| lap.w(d as Real) as f64;
    for k in 20..95 {
        let d = k as f64 / 100.0;
        let dw = |x: f64| (w(x + eps) - w(x - eps)) / (2.0 * eps);
        let num = ((d + eps).powi(2) * dw(d + eps) - (d - eps).powi(2) * dw(d - eps))
            / (2.0 * eps)
            / (d * d);
        let exact = lap.laplacian(d as Real) as f64;
        assert!(
            (num - exact).abs() < 2e-2 * lap.laplacian(0.0) as f64,
            "d={d}: {num} vs {exact}"
        );
    }
    // Positive on the whole support: viscosity only damps.
    assert!((0..100).all(|k| lap.laplacian(k as Real / 100.0) > 0.0));
}

/// The walls' viscosity integral: `∫ ∇²W dV` over the half-space `z ≥ d` matches a direct
/// quadrature over the support (cylindrical shells, f64), is half the whole at `d = 0`, the
/// whole (`15/h²`) for `d ≤ −h` and zero for `d ≥ h`.
#[test]
fn viscosity_half_space_integral_matches_quadrature() {
    let h = 0.04;
    let lap = ViscosityLaplacian::new(h);
    let full = 15.0 / (h * h);
    assert!((lap.half_space_integral(0.0) - 0.5 * full).abs() < 1e-4 * full);
    assert_eq!(lap.half_space_integral(h), 0.0);
    assert_eq!(lap.half_space_integral(-h), full);
    let n = 400;
    for k in -9..=9 {
        let d = k as f64 / 10.0 * h as f64;
        // ∫_{z=d}^{h} ∫_0^{√(h²−z²)} ∇²W(√(ρ²+z²)) 2πρ dρ dz, midpoint rule.
        let (hz, mut sum) = (h as f64, 0.0f64);
        let dz = (hz - d) / n as f64;
        for iz in 0..n {
            let z = d + (iz as f64 + 0.5) * dz;
            let rmax = (hz * hz - z * z).max(0.0).sqrt();
            let dr = rmax / n as f64;
            for ir in 0..n {
                let r = (ir as f64 + 0.5) * dr;
                let dist = (r * r + z * z).sqrt();
                sum +=
                    lap.laplacian(dist as Real) as f64 * 2.0 * std::f64::consts::PI * r * dr * dz;
            }
        }
        let exact = lap.half_space_integral(d as Real) as f64;
        assert!(
            (sum - exact).abs() < 2e-3 * full as f64,
            "d = {d}: quadrature {sum} vs {exact}"
        );
    }
}
