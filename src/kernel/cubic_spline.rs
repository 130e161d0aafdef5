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
    // Written branch-free as truncated powers, `W = k·(2(1−q)₊³ − 8(½−q)₊³)`, which equals the
    // two-piece form above on each piece: the hot loops then have no unpredictable branch.
    #[inline(always)]
    fn w(&self, d: Real) -> Real {
        let q = d * self.inv_h;
        let a = (1.0 - q).max(0.0);
        let b = (0.5 - q).max(0.0);
        self.k * (2.0 * a * a * a - 8.0 * b * b * b)
    }
    #[inline(always)]
    fn dw(&self, d: Real) -> Real {
        let q = d * self.inv_h;
        let a = (1.0 - q).max(0.0);
        let b = (0.5 - q).max(0.0);
        self.k * self.inv_h * (24.0 * b * b - 6.0 * a * a)
    }
    // `w` lane by lane, the same operations in the same order (see `dw_avx`).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn w_avx(&self, d: std::arch::x86_64::__m256) -> std::arch::x86_64::__m256 {
        use std::arch::x86_64::*;
        // SAFETY: the caller runs with AVX (the trait's contract).
        unsafe {
            let q = _mm256_mul_ps(d, _mm256_set1_ps(self.inv_h));
            let zero = _mm256_setzero_ps();
            let a = _mm256_max_ps(_mm256_sub_ps(_mm256_set1_ps(1.0), q), zero);
            let b = _mm256_max_ps(_mm256_sub_ps(_mm256_set1_ps(0.5), q), zero);
            let a3 = _mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(_mm256_set1_ps(2.0), a), a), a);
            let b3 = _mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(_mm256_set1_ps(8.0), b), b), b);
            _mm256_mul_ps(_mm256_set1_ps(self.k), _mm256_sub_ps(a3, b3))
        }
    }
    // `dw` lane by lane, the same operations in the same order: `max(x, 0)` takes the
    // second operand when `x` is NaN, as `f32::max` returns the number.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn dw_avx(&self, d: std::arch::x86_64::__m256) -> std::arch::x86_64::__m256 {
        use std::arch::x86_64::*;
        // SAFETY: the caller runs with AVX (the trait's contract).
        unsafe {
            let q = _mm256_mul_ps(d, _mm256_set1_ps(self.inv_h));
            let zero = _mm256_setzero_ps();
            let a = _mm256_max_ps(_mm256_sub_ps(_mm256_set1_ps(1.0), q), zero);
            let b = _mm256_max_ps(_mm256_sub_ps(_mm256_set1_ps(0.5), q), zero);
            let bb = _mm256_mul_ps(_mm256_mul_ps(_mm256_set1_ps(24.0), b), b);
            let aa = _mm256_mul_ps(_mm256_mul_ps(_mm256_set1_ps(6.0), a), a);
            _mm256_mul_ps(_mm256_set1_ps(self.k * self.inv_h), _mm256_sub_ps(bb, aa))
        }
    }
}
