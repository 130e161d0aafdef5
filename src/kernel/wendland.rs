use super::Kernel;
use crate::math::Real;
use std::f32::consts::PI;

/// Wendland's C2 kernel in 3D (Wendland 1995; normalisation from Dehnen & Aly 2012,
/// "Improving convergence in SPH simulations without pairing instability"):
/// `W = 21/(2πh³)·(1−q)⁴(1+4q)`, `q = d/h`. Free of the pairing instability.
#[derive(Copy, Clone, Debug)]
pub struct WendlandC2 {
    h: Real,
    inv_h: Real,
    k: Real,
}

impl Kernel for WendlandC2 {
    const NAME: &'static str = "wendland-c2";
    fn new(h: Real) -> Self {
        Self {
            h,
            inv_h: 1.0 / h,
            k: 21.0 / (2.0 * PI * h * h * h),
        }
    }
    #[inline(always)]
    fn support(&self) -> Real {
        self.h
    }
    #[inline(always)]
    fn w(&self, d: Real) -> Real {
        let q = d * self.inv_h;
        let x = (1.0 - q).max(0.0);
        let x2 = x * x;
        self.k * x2 * x2 * (1.0 + 4.0 * q)
    }
    #[inline(always)]
    fn dw(&self, d: Real) -> Real {
        let q = d * self.inv_h;
        let x = (1.0 - q).max(0.0);
        -20.0 * self.k * self.inv_h * q * x * x * x
    }
}
