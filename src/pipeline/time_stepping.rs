//! How a frame is divided into substeps: the policy ([`TimeStepping`]) and the stability
//! limits every solver shares (CFL, explicit viscosity); each solver adds its own
//! (`PressureSolver::time_step_limit`).

use super::workspace::FluidRuntime;
use crate::error::{SphError, SphResult};
use crate::fluid::Fluid;
use crate::math::{Real, Vector};

/// How [`crate::FluidPipeline::step`] divides the caller's frame into substeps.
///
/// # Examples
/// ```
/// use rapier_sph::{FluidPipeline, TimeStepping};
/// // The default: substeps that meet every stability limit, at most 256 a frame.
/// assert_eq!(FluidPipeline::new().time_stepping, TimeStepping::default());
/// // A tighter Courant number and a lower cap (the report says when the cap binds).
/// let careful = TimeStepping::Adaptive { courant: 0.2, max_substeps: 32 };
/// assert!(careful.validate().is_ok());
/// assert!(TimeStepping::Adaptive { courant: 0.0, max_substeps: 32 }.validate().is_err());
/// ```
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub enum TimeStepping {
    /// One substep of exactly the frame's `dt`: the caller is responsible for stability
    /// (benchmarks and convergence studies use this).
    Fixed,
    /// Substeps from the CFL condition, recomputed before each substep from the fluids'
    /// current maximum speed:
    ///
    /// - every solver: `dt ≤ courant · spacing / (v_max + |g|·dt)` (a particle moves at
    ///   most `courant` spacings per substep; `v_max` is at least the fastest surface of a
    ///   moving body near the fluid, whose walls sweep into it), and the explicit viscosity
    ///   limit `dt ≤ ρ0·h²/(30·ε)`;
    /// - WCSPH also the acoustic limit `dt ≤ courant · h / (c + v_max)`, Clavet the same with
    ///   `c·√k` (its stiffness `k` is in units of `c²/(h·ρ0)`, its springs' in `c²/(h²·N)`);
    /// - DFSPH under gravity also `g·dt² ≤ K·max_density_error·spacing`, `K` its
    ///   [`gravity_substep`](crate::Dfsph::gravity_substep) (default 5): gravity's
    ///   compression within one substep stays a few times the solve's error target;
    /// - with surface tension (`γ > 0`) the capillary limit `dt ≤ courant · 2√(ρ0Δx³/(π³σ))`,
    ///   `σ` the cohesion's mean-field surface tension (`forces::surface_tension`).
    ///
    /// The frame is split into equal substeps that meet the limits; at most `max_substeps`
    /// of them. When the cap binds the substeps are longer than the limits ask and the report
    /// says so (`substep_cap_hit`); contact still keeps every particle out of every solid.
    Adaptive {
        /// Courant number (default 0.4).
        courant: Real,
        /// Cap on substeps per frame (default 256).
        max_substeps: u32,
    },
}

impl Default for TimeStepping {
    fn default() -> Self {
        TimeStepping::Adaptive {
            courant: 0.4,
            max_substeps: 256,
        }
    }
}

/// The shortest frame [`crate::FluidPipeline::step`] accepts, in seconds (1 ns).
///
/// Why: the pressure solvers divide by the squared substep (DFSPH's `1/dt²`), and a frame is
/// split into as many as [`MAX_SUBSTEPS`] substeps; at 1 ns per frame the squared substep is
/// still ≈ 2·10⁻²⁸ s², far inside single precision's normal range (a frame of 10⁻³⁸ s made
/// `1/dt²` infinite and the reported pressures NaN). No simulation needs shorter frames: the
/// acoustic step of a 1 mm particle is about 10 µs, four orders above this floor.
pub const MIN_TIME_STEP: Real = 1e-9;

/// The strongest gravity [`crate::FluidPipeline::step`] accepts, in m/s² (10⁶, about
/// 10⁵ g; a game in centimetres has g = 981, in millimetres 9,810).
///
/// Why: gravity is integrated in single precision, and each frame's velocity change `g·dt`
/// feeds the pressure solve's `1/dt²` terms; a gravity of 10³⁸ m/s² overflowed the reported
/// pressures to infinity. Under this bound a 1/60 s frame adds at most 1.7·10⁴ m/s, which
/// the adaptive substeps and the quarantine handle.
pub const MAX_GRAVITY: Real = 1e6;

/// Most substeps [`TimeStepping::Adaptive`] may divide a frame into (`max_substeps`).
///
/// Why 2^16 = 65,536: 256 times the default cap (256), so a frame costs at most 256 times
/// the worst frame of the default settings; and the substeps of a frame are summed in single
/// precision (`Real`), whose rounding over `N` equal substeps can reach `N·2^−24` of the frame:
/// 2^−8 (0.4 %) at this cap, more beyond it.
pub const MAX_SUBSTEPS: u32 = 1 << 16;

impl TimeStepping {
    /// Checks the policy: a positive finite Courant number, between 1 and [`MAX_SUBSTEPS`]
    /// substeps. [`crate::FluidPipeline::step`] calls it first.
    ///
    /// # Errors
    /// [`SphError::InvalidParameter`] naming `courant` or `max_substeps`.
    ///
    /// # Examples
    /// ```
    /// use rapier_sph::TimeStepping;
    /// assert!(TimeStepping::default().validate().is_ok());
    /// let endless = TimeStepping::Adaptive { courant: 1e-9, max_substeps: u32::MAX };
    /// assert!(endless.validate().is_err());
    /// ```
    pub fn validate(&self) -> SphResult<()> {
        if let TimeStepping::Adaptive {
            courant,
            max_substeps,
        } = *self
        {
            if !(courant.is_finite() && courant > 0.0) {
                return Err(SphError::InvalidParameter {
                    field: "courant",
                    value: courant as f64,
                    reason: "must be positive and finite",
                });
            }
            if max_substeps == 0 {
                return Err(SphError::InvalidParameter {
                    field: "max_substeps",
                    value: 0.0,
                    reason: "must be at least 1",
                });
            }
            if max_substeps > MAX_SUBSTEPS {
                return Err(SphError::InvalidParameter {
                    field: "max_substeps",
                    value: max_substeps as f64,
                    reason: "more than MAX_SUBSTEPS (65,536) substeps per frame",
                });
            }
        }
        Ok(())
    }
}

/// The next substep of a frame with `remaining` seconds left after `taken` substeps:
/// `(length, last, cap_hit)`.
pub(super) fn next_substep<'a>(
    policy: TimeStepping,
    remaining: Real,
    taken: u32,
    fluids: impl Iterator<Item = (&'a Fluid, &'a mut FluidRuntime)>,
    gravity: Vector,
) -> (Real, bool, bool) {
    let TimeStepping::Adaptive {
        courant,
        max_substeps,
    } = policy
    else {
        return (remaining, true, false);
    };
    let limit = fluids
        .map(|(f, rt)| stable_time_step(f, rt, gravity, courant, remaining))
        .fold(Real::MAX, Real::min);
    let left = max_substeps.saturating_sub(taken).max(1);
    let needed = (remaining / limit).ceil().max(1.0);
    let cap_hit = needed > left as Real;
    let count = needed.min(left as Real);
    if count <= 1.0 {
        (remaining, true, cap_hit)
    } else {
        (remaining / count, false, cap_hit)
    }
}

/// The longest stable substep for `fluid` (see [`TimeStepping::Adaptive`]), at most
/// `remaining`.
fn stable_time_step(
    fluid: &Fluid,
    rt: &mut FluidRuntime,
    gravity: Vector,
    courant: Real,
    remaining: Real,
) -> Real {
    if fluid.is_empty() || fluid.is_sleeping() {
        return remaining;
    }
    let p = fluid.params();
    // A moving body's surface sweeps into the particles ahead of it as a particle would:
    // it must move at most `courant` spacings per substep too.
    let v = rt.ws.max_speed.max(rt.ws.bodies_near.fastest);
    let g = gravity.length();
    // courant·s = v·dt + g·dt², solved for dt.
    let cs = courant * p.particle_spacing;
    let mut limit = if g > 0.0 {
        2.0 * cs / (v + (v * v + 4.0 * g * cs).sqrt())
    } else if v > 0.0 {
        cs / v
    } else {
        remaining
    };
    if p.explicit_viscosity() > 0.0 {
        let h = p.smoothing_length;
        limit = limit.min(p.rest_density * h * h / (30.0 * p.explicit_viscosity()));
    }
    limit = limit.min(rt.solver.time_step_limit(p, v, gravity, courant));
    if p.surface_tension > 0.0 {
        limit = limit.min(crate::forces::surface_tension::capillary_time_step(
            p.surface_tension,
            p.rest_density,
            p.smoothing_length,
            p.particle_spacing,
            courant,
        ));
    }
    limit.min(remaining)
}
