use super::Kernel;
use crate::math::Real;
use std::f32::consts::PI;

/// Monaghan's cubic B-spline (Monaghan 1992, "Smoothed particle hydrodynamics", ARA&A 30),
/// written for the support radius `h` as in SPlisHSPlasH:
/// `W = 8/(πh³)·(6q³ − 6q² + 1)` for `q = d/h ≤ ½`, `8/(πh³)·2(1−q)³` for `½ < q ≤ 1`.
#[derive(Copy, Clone, Debug)]
pub struct CubicSpline {
    h: Real,
    inv_h: Real,
    k: Real,
}

impl Kernel for CubicSpline {
    const NAME: &'static str = "cubic-spline";
    fn new(h: Real) -> Self {
        Self {
            h,
            inv_h: 1.0 / h,
            k: 8.0 / (PI * h * h * h),
        }
    }
    #[inline(always)]
    fn support(&self) -> Real {
        self.h
    }
    #[inline(always)]
    fn w(&self, d: Real) -> Real {
        let q = d * self.inv_h;
        if q >= 1.0 {
            0.0
        } else if q <= 0.5 {
            self.k * (6.0 * q * q * (q - 1.0) + 1.0)
        } else {
            let x = 1.0 - q;
            self.k * 2.0 * x * x * x
        }
    }
    #[inline(always)]
    fn dw(&self, d: Real) -> Real {
        let q = d * self.inv_h;
        if q >= 1.0 {
            0.0
        } else if q <= 0.5 {
            self.k * self.inv_h * q * (18.0 * q - 12.0)
        } else {
            let x = 1.0 - q;
            -6.0 * self.k * self.inv_h * x * x
        }
    }
}
