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

    /// `∇²W(d)`; zero for `d >= h`, finite at `d = 0`.
    #[inline(always)]
    pub fn laplacian(&self, d: Real) -> Real {
        if d >= self.h {
            0.0
        } else {
            self.coef * (self.h - d)
        }
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
