use super::Kernel;
use crate::math::Real;
use std::f32::consts::PI;

/// Müller et al. (2003), eq. 21: `W(d) = 15/(πh⁶)·(h−d)³`, with
/// `dW/dd = −45/(πh⁶)·(h−d)²`.
///
/// Its gradient does not vanish at `d = 0`, so the pressure force keeps particles apart
/// under compression (the reason Müller introduced it). The Unity paper prints the gradient
/// as `45/(πh⁶)(h−d)³` (its eq. 15); that is a typo, see the [module docs](super).
#[derive(Copy, Clone, Debug)]
pub struct Spiky {
    h: Real,
    coef: Real,
}

impl Kernel for Spiky {
    const NAME: &'static str = "spiky";
    fn new(h: Real) -> Self {
        Self {
            h,
            coef: 15.0 / (PI * h.powi(6)),
        }
    }
    #[inline(always)]
    fn support(&self) -> Real {
        self.h
    }
    #[inline(always)]
    fn w(&self, d: Real) -> Real {
        let x = (self.h - d).max(0.0);
        self.coef * x * x * x
    }
    #[inline(always)]
    fn dw(&self, d: Real) -> Real {
        let x = (self.h - d).max(0.0);
        -3.0 * self.coef * x * x
    }
}
