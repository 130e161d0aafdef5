use super::Kernel;
use crate::math::Real;
use std::f32::consts::PI;

/// The Unity paper's tuned density kernel (Wong, "Smoothed Particle Hydrodynamics: A Real
/// Time Implementation in the Unity Game Engine", eq. 10):
/// `W(d) = 315/(64πh⁹)·(h^1.6 − d^1.6)^4`.
///
/// It keeps poly6's constant but changes the exponents, so it is **not normalised** (it does
/// not integrate to 1) and not dimensionally consistent. It exists only so the paper's
/// scenes can be reproduced; prefer [`super::Poly6`] or [`super::CubicSpline`].
#[derive(Copy, Clone, Debug)]
pub struct PaperPoly6 {
    h: Real,
    h16: Real,
    coef: Real,
}

impl Kernel for PaperPoly6 {
    const NAME: &'static str = "paper-poly6";
    fn new(h: Real) -> Self {
        Self {
            h,
            h16: h.powf(1.6),
            coef: 315.0 / (64.0 * PI * h.powi(9)),
        }
    }
    #[inline(always)]
    fn support(&self) -> Real {
        self.h
    }
    #[inline(always)]
    fn w(&self, d: Real) -> Real {
        if d >= self.h {
            return 0.0;
        }
        let x = self.h16 - d.powf(1.6);
        let x2 = x * x;
        self.coef * x2 * x2
    }
    #[inline(always)]
    fn dw(&self, d: Real) -> Real {
        if d >= self.h || d <= 0.0 {
            return 0.0;
        }
        let x = self.h16 - d.powf(1.6);
        self.coef * 4.0 * x * x * x * (-1.6 * d.powf(0.6))
    }
}
