use super::Kernel;
use crate::math::Real;
use std::f32::consts::PI;

/// Müller et al. (2003), "Particle-based fluid simulation for interactive applications",
/// eq. 20: `W(d) = 315/(64πh⁹)·(h²−d²)³`. Smooth, cheap (no square root needed for `W`),
/// but its gradient vanishes at `d = 0`, so it is used for density only.
#[derive(Copy, Clone, Debug)]
pub struct Poly6 {
    h: Real,
    h2: Real,
    coef: Real,
}

impl Kernel for Poly6 {
    const NAME: &'static str = "poly6";
    fn new(h: Real) -> Self {
        Self {
            h,
            h2: h * h,
            coef: 315.0 / (64.0 * PI * h.powi(9)),
        }
    }
    #[inline(always)]
    fn support(&self) -> Real {
        self.h
    }
    #[inline(always)]
    fn w(&self, d: Real) -> Real {
        let x = (self.h2 - d * d).max(0.0);
        self.coef * x * x * x
    }
    #[inline(always)]
    fn dw(&self, d: Real) -> Real {
        let x = (self.h2 - d * d).max(0.0);
        -6.0 * self.coef * d * x * x
    }
}
