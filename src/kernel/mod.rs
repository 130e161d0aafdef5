//! Smoothing kernels.
//!
//! All kernels here use the convention of Müller et al. (2003): `h` is the **support radius**,
//! the kernel and its derivative vanish for `d >= h`. (Monaghan's papers use a smoothing
//! length that is half of this for the cubic spline; the formulas below are written for the
//! support radius.)
//!
//! | kernel | used for | formula (3D, `q = d/h`) | source |
//! |---|---|---|---|
//! | [`Poly6`] | density | `315/(64πh⁹)·(h²−d²)³` | Müller et al. 2003, eq. 20 |
//! | [`PaperPoly6`] | density (paper reproduction) | `315/(64πh⁹)·(h^1.6−d^1.6)^4` | Wong, eq. 10 (not normalised) |
//! | [`Spiky`] | pressure gradient | `W = 15/(πh⁶)(h−d)³`, `∇W = −45/(πh⁶)(h−d)² r̂` | Müller et al. 2003, eq. 21 |
//! | [`CubicSpline`] | density and gradient | `8/(πh³)·{6q³−6q²+1, 2(1−q)³}` | Monaghan 1992 |
//! | [`WendlandC2`] | density and gradient | `21/(2πh³)·(1−q)⁴(1+4q)` | Wendland 1995; Dehnen & Aly 2012 |
//! | [`ViscosityLaplacian`] | viscosity | `∇²W = 45/(πh⁶)(h−d)` | Müller et al. 2003, eq. 22 |
//!
//! **About the spiky gradient.** The Unity paper prints `∇W_spiky = 45/(πh⁶)(h−d)³` (its eq. 15).
//! That is the derivative of nothing sensible: differentiating Müller's spiky kernel
//! `15/(πh⁶)(h−d)³` gives `−45/(πh⁶)(h−d)²`, which is what Müller et al. (2003) give and what
//! this crate implements. The sign is carried by the direction: the pressure force uses
//! `∇W(r_ij) = dW/dd · r_ij/|r_ij|`.
//!
//! **About the paper's density kernel.** The paper's tuned poly6 keeps Müller's normalisation
//! constant but changes the exponents, so it no longer integrates to 1 (its integral is
//! `(315/16)·h^0.4·0.02507 ≈ 0.494·h^0.4`, see the tests); densities computed with it are on the paper's own scale.
//! It is offered only to reproduce the paper.

mod cubic_spline;
pub mod half_space;
mod paper_poly6;
mod poly6;
mod spiky;
mod viscosity;
mod wendland;

pub use cubic_spline::CubicSpline;
pub use half_space::HalfSpaceTable;
pub use paper_poly6::PaperPoly6;
pub use poly6::Poly6;
pub use spiky::Spiky;
pub use viscosity::ViscosityLaplacian;
pub use wendland::WendlandC2;

use crate::math::{Real, Vector, coincident_direction};

/// A radially symmetric smoothing kernel with compact support `h`.
///
/// Implementations precompute their normalisation constants in [`Kernel::new`], so the
/// hot loops only evaluate polynomials. Kernels are resolved at compile time (the pipeline
/// matches [`KernelKind`] once per stage, not once per pair).
pub trait Kernel: Copy + Send + Sync + 'static {
    /// Human-readable name.
    const NAME: &'static str;
    /// Below `COINCIDENT_FRACTION · h` two particles count as coincident: the gradient's
    /// direction then comes from [`coincident_direction`] instead of the separation.
    const COINCIDENT_FRACTION: Real = Real::EPSILON;
    /// Builds the kernel for support radius `h` (> 0).
    fn new(h: Real) -> Self;
    /// Support radius `h`.
    fn support(&self) -> Real;
    /// Kernel value `W(d)`; zero for `d >= h`.
    fn w(&self, d: Real) -> Real;
    /// Radial derivative `dW/dd`; zero for `d >= h`.
    fn dw(&self, d: Real) -> Real;

    /// [`Kernel::w`] on eight lanes at once, the same arithmetic per lane (so the same bits):
    /// by default lane by lane through [`Kernel::w`]; kernels on the hot paths override it.
    ///
    /// # Safety
    /// As [`Kernel::dw_avx`].
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn w_avx(&self, d: std::arch::x86_64::__m256) -> std::arch::x86_64::__m256 {
        use std::arch::x86_64::*;
        let mut lanes: [Real; 8] = [0.0; 8];
        // SAFETY: the caller runs with AVX; `lanes` holds 8 floats.
        unsafe {
            _mm256_storeu_ps(lanes.as_mut_ptr(), d);
            for x in &mut lanes {
                *x = self.w(*x);
            }
            _mm256_loadu_ps(lanes.as_ptr())
        }
    }

    /// [`Kernel::dw`] on eight lanes at once, the same arithmetic per lane (so the same bits):
    /// by default lane by lane through [`Kernel::dw`]; kernels on the hot paths override it
    /// with packed arithmetic.
    ///
    /// # Safety
    /// Only from code compiled with AVX enabled (inlined into a `#[target_feature]`
    /// function, after run-time detection).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn dw_avx(&self, d: std::arch::x86_64::__m256) -> std::arch::x86_64::__m256 {
        use std::arch::x86_64::*;
        let mut lanes: [Real; 8] = [0.0; 8];
        // SAFETY: the caller runs with AVX; `lanes` holds 8 floats.
        unsafe {
            _mm256_storeu_ps(lanes.as_mut_ptr(), d);
            for x in &mut lanes {
                *x = self.dw(*x);
            }
            _mm256_loadu_ps(lanes.as_ptr())
        }
    }

    /// Gradient `∇_i W(x_i − x_j)` for the separation `r = x_i − x_j` of length `d`.
    ///
    /// For coincident particles (`d == 0`) the direction is taken from
    /// [`coincident_direction`], a deterministic, antisymmetric choice, so kernels whose
    /// derivative does not vanish at 0 (spiky) still push coincident particles apart.
    #[inline(always)]
    fn gradient(&self, r: Vector, d: Real, i: u32, j: u32) -> Vector {
        let dw = self.dw(d);
        if d > Self::COINCIDENT_FRACTION * self.support() {
            r * (dw / d)
        } else {
            coincident_direction(i, j) * dw
        }
    }
}

/// Which kernel a stage uses. Chosen per fluid in [`crate::FluidParams`].
///
/// # Examples
/// ```
/// use rapier_sph::{FluidParamsBuilder, KernelKind};
/// let params = FluidParamsBuilder::water(0.05)
///     .density_kernel(KernelKind::WendlandC2)
///     .build()?;
/// assert_eq!(params.density_kernel, KernelKind::WendlandC2);
/// // Every kernel vanishes at its support radius h.
/// let h = params.smoothing_length;
/// assert!(KernelKind::ALL.iter().all(|k| k.w(h, h).abs() < 1e-6));
/// # Ok::<(), rapier_sph::SphError>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub enum KernelKind {
    /// Müller's poly6 (density).
    Poly6,
    /// The Unity paper's tuned poly6 (density; paper reproduction only, not normalised).
    PaperPoly6,
    /// Müller's spiky kernel (pressure gradient).
    Spiky,
    /// Monaghan's cubic B-spline.
    CubicSpline,
    /// Wendland's C2 kernel. At a support of 2 particle spacings its sum over a cubic
    /// lattice is 3.4 % above `1/s³` (the cubic spline's: 1.000), so a fluid sampled on a
    /// lattice with the default mass `ρ0·s³` starts compressed.
    WendlandC2,
}

impl KernelKind {
    /// All kernels, for tests and sweeps.
    pub const ALL: [KernelKind; 5] = [
        KernelKind::Poly6,
        KernelKind::PaperPoly6,
        KernelKind::Spiky,
        KernelKind::CubicSpline,
        KernelKind::WendlandC2,
    ];

    /// The kernel's name.
    pub fn name(self) -> &'static str {
        crate::with_kernel!(self, K => K::NAME)
    }

    /// `W(d)` for support radius `h` (convenience; the hot loops use the typed kernels).
    pub fn w(self, d: Real, h: Real) -> Real {
        crate::with_kernel!(self, K => K::new(h).w(d))
    }

    /// `dW/dd` for support radius `h` (convenience).
    pub fn dw(self, d: Real, h: Real) -> Real {
        crate::with_kernel!(self, K => K::new(h).dw(d))
    }
}

/// Runs `$body` with the type alias `$K` bound to the kernel type named by `$kind`.
///
/// This is how the pipeline turns the runtime choice into a monomorphised loop.
#[doc(hidden)]
#[macro_export]
macro_rules! with_kernel {
    ($kind:expr, $K:ident => $body:expr) => {
        match $kind {
            $crate::kernel::KernelKind::Poly6 => {
                type $K = $crate::kernel::Poly6;
                $body
            }
            $crate::kernel::KernelKind::PaperPoly6 => {
                type $K = $crate::kernel::PaperPoly6;
                $body
            }
            $crate::kernel::KernelKind::Spiky => {
                type $K = $crate::kernel::Spiky;
                $body
            }
            $crate::kernel::KernelKind::CubicSpline => {
                type $K = $crate::kernel::CubicSpline;
                $body
            }
            $crate::kernel::KernelKind::WendlandC2 => {
                type $K = $crate::kernel::WendlandC2;
                $body
            }
        }
    };
}

#[cfg(test)]
mod tests;
