use crate::math::Real;
use std::f32::consts::PI;

/// Laplacian of Müller's viscosity kernel (Müller et al. 2003, eq. 22):
/// `∇²W(d) = 45/(πh⁶)·(h−d)`, positive on the whole support so the viscosity force can only
/// damp relative motion.
///
/// The kernel itself, `W = 15/(2πh³)(−d³/(2h³) + d²/h² + h/(2d) − 1)`, is singular at `d = 0`
/// and never evaluated; only its Laplacian is. (The Unity paper prints its constant as
/// `15/(πh³)`; Müller's is `15/(2πh³)`, the one that integrates to 1. Only the Laplacian's
/// constant matters for the force, and both papers agree on it.)
#[derive(Copy, Clone, Debug)]
pub struct ViscosityLaplacian {
    h: Real,
    coef: Real,
}

impl ViscosityLaplacian {
    /// Builds the Laplacian for support radius `h`.
    pub fn new(h: Real) -> Self {
        Self {
            h,
            coef: 45.0 / (PI * h.powi(6)),
        }
    }

    /// `∇²W(d)`; zero for `d >= h`, finite at `d = 0`. Written branch-free,
    /// `coef·max(h − d, 0)` (the same value as the two-piece form, bit for bit), so the pair
    /// loops' lanes vectorise.
    #[inline(always)]
    pub fn laplacian(&self, d: Real) -> Real {
        self.coef * (self.h - d).max(0.0)
    }

    /// [`Self::laplacian`] on eight lanes, the same arithmetic per lane (`max(x, 0)` takes
    /// the second operand when `x` is NaN, as `f32::max` returns the number).
    ///
    /// # Safety
    /// Only from code compiled with AVX enabled (see [`super::Kernel::dw_avx`]).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn laplacian_avx(
        &self,
        d: std::arch::x86_64::__m256,
    ) -> std::arch::x86_64::__m256 {
        use std::arch::x86_64::*;
        // SAFETY: the caller runs with AVX.
        unsafe {
            let x = _mm256_max_ps(
                _mm256_sub_ps(_mm256_set1_ps(self.h), d),
                _mm256_setzero_ps(),
            );
            _mm256_mul_ps(_mm256_set1_ps(self.coef), x)
        }
    }

    /// `∫ ∇²W dV` over the half-space lying `d` beyond the particle (`d < 0`: the particle is
    /// inside it): what a wall contributes to the viscosity sum in place of
    /// `Σ_j m_j/ρ_j ∇²W_ij` (see `src/boundary/wall/`). A sphere of radius `r` around
    /// the particle has the cap area `2πr(r − d)` beyond the plane, so for `0 ≤ d < h`
    /// `∫ = 90/h⁶ ∫_d^h (h − r)·r·(r − d) dr`; the whole support integrates to `15/h²`, and
    /// `d < 0` is the whole minus the mirror half-space.
    pub fn half_space_integral(&self, d: Real) -> Real {
        let h = self.h;
        let full = 15.0 / (h * h);
        if d >= h {
            return 0.0;
        }
        if d <= -h {
            return full;
        }
        let e = d.abs();
        // ∫_e^h (h − r)(r² − e·r) dr, expanded.
        let (h2, h3, h4) = (h * h, h * h * h, h * h * h * h);
        let (e2, e3, e4) = (e * e, e * e * e, e * e * e * e);
        let cap =
            h * (h3 - e3) / 3.0 - h * e * (h2 - e2) / 2.0 - (h4 - e4) / 4.0 + e * (h3 - e3) / 3.0;
        let part = 90.0 / (h4 * h2) * cap;
        if d >= 0.0 { part } else { full - part }
    }

    /// The viscosity kernel `W(d)` itself (singular at 0), for tests and documentation.
    pub fn w(&self, d: Real) -> Real {
        if d >= self.h || d <= 0.0 {
            return 0.0;
        }
        let h = self.h;
        15.0 / (2.0 * PI * h * h * h)
            * (-d * d * d / (2.0 * h * h * h) + d * d / (h * h) + h / (2.0 * d) - 1.0)
    }
}
