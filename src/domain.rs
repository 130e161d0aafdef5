//! The space a fluid lives in: open (unbounded, the default) or a periodic box.
//!
//! In a periodic box ([`Domain::Periodic`]) a particle leaving through one face re-enters
//! through the opposite one (positions are wrapped at the end of every substep; the count is
//! conserved exactly), neighbour cells wrap around the box, and every pair term uses the
//! *minimum image* of the separation `x_i − x_j`: the shortest of its periodic copies.
//!
//! Periodicity costs the open domain nothing: every pair loop is generic over a
//! [`Separation`], chosen once per stage (`with_separation!`). [`Open`] is plain subtraction,
//! so the open path compiles to the same code as before periodic domains existed (bitwise the
//! same results); [`MinimumImage`] is the periodic path.
//!
//! All three axes are periodic (a box periodic in some axes only is not supported yet).
//! Colliders may coexist with a periodic box, but contact and the walls' density do not
//! wrap: a collider should stay clear of the box faces by the kernel support.

use crate::error::{SphError, SphResult};
use crate::math::{Real, Vector};

/// Where a fluid's particles live.
///
/// # Examples
///
/// ```
/// use rapier_sph::{Domain, FluidParamsBuilder, SphError, math::Vector};
/// // A 1 m periodic box (each edge at least 3 h = 0.3 m at a 5 cm spacing).
/// let params = FluidParamsBuilder::water(0.05).periodic(Vector::ZERO, Vector::ONE).build()?;
/// assert_eq!(params.domain, Domain::Periodic { min: Vector::ZERO, max: Vector::ONE });
/// // A box shorter than three smoothing lengths is refused.
/// let small = Domain::Periodic { min: Vector::ZERO, max: Vector::splat(0.2) };
/// assert!(small.validate(params.smoothing_length).is_err());
/// # Ok::<(), SphError>(())
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub enum Domain {
    /// Unbounded space (the default): the hashed grid needs no box.
    #[default]
    Open,
    /// The box `[min, max)`, periodic along all three axes. Each edge must be at least three
    /// smoothing lengths long (so the 27 cells around a cell are distinct and a neighbour's
    /// minimum image is unique).
    Periodic {
        /// Lower corner (m).
        min: Vector,
        /// Upper corner (m); a particle at `max` is at `min`.
        max: Vector,
    },
}

impl Domain {
    /// Checks the box against the smoothing length `h`: finite corners, each periodic length
    /// at least `3·h`. Errors name the field (`domain_min`, `domain_max`).
    ///
    /// # Errors
    /// [`SphError::InvalidParameter`] naming `domain_min` or `domain_max`.
    pub fn validate(&self, h: Real) -> SphResult<()> {
        let Domain::Periodic { min, max } = *self else {
            return Ok(());
        };
        for (field, v) in [("domain_min", min), ("domain_max", max)] {
            if !crate::math::is_finite(v) {
                return Err(SphError::InvalidParameter {
                    field,
                    value: v.length() as f64,
                    reason: "the periodic box's corners must be finite",
                });
            }
            if v.abs().max_element() > 1.0e7 {
                return Err(SphError::InvalidParameter {
                    field,
                    value: v.abs().max_element() as f64,
                    reason: "the periodic box lies beyond 10,000 km (single precision)",
                });
            }
        }
        let len = max - min;
        if len.min_element() < 3.0 * h {
            return Err(SphError::InvalidParameter {
                field: "domain_max",
                value: len.min_element() as f64,
                reason: "each periodic length (max − min) must be at least 3 smoothing lengths",
            });
        }
        Ok(())
    }

    /// The periodic separation of this domain, if it is periodic.
    pub fn minimum_image(&self) -> Option<MinimumImage> {
        match *self {
            Domain::Open => None,
            Domain::Periodic { min, max } => Some(MinimumImage::new(min, max)),
        }
    }
}

/// How a pair loop forms the separation `x_i − x_j` (see the [module docs](self)).
pub trait Separation: Copy + Send + Sync {
    /// `true` for a periodic domain.
    const PERIODIC: bool;
    /// The separation `a − b` (its minimum image in a periodic domain).
    fn sep(&self, a: Vector, b: Vector) -> Vector;
}

/// Open space: the separation is the plain difference.
#[derive(Copy, Clone, Debug, Default)]
pub struct Open;

impl Separation for Open {
    const PERIODIC: bool = false;
    #[inline(always)]
    fn sep(&self, a: Vector, b: Vector) -> Vector {
        a - b
    }
}

/// A periodic box: the separation is the minimum image `d − L·round(d/L)` per axis.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct MinimumImage {
    /// Lower corner.
    pub min: Vector,
    /// Upper corner.
    pub max: Vector,
    /// Edge lengths `max − min`.
    pub len: Vector,
    /// `1/len`.
    pub inv_len: Vector,
}

impl MinimumImage {
    /// The minimum image of the box `[min, max)`.
    pub fn new(min: Vector, max: Vector) -> Self {
        let len = max - min;
        Self {
            min,
            max,
            len,
            inv_len: Vector::ONE / len,
        }
    }

    /// `x` wrapped into `[min, max)`.
    #[inline]
    pub fn wrap(&self, x: Vector) -> Vector {
        let mut y = x - self.len * ((x - self.min) * self.inv_len).floor();
        // `x + L` of an `x` just below `min` can round up to `max` itself, which is `min`.
        for a in 0..3 {
            if y[a] >= self.max[a] || y[a] < self.min[a] {
                y[a] = self.min[a];
            }
        }
        y
    }
}

/// `1.5·2²³`: adding then subtracting it rounds an f32 of magnitude below 2²² to the nearest
/// integer (ties to even) in two plain additions, which vectorise; `f32::round` is a library
/// call per component on baseline x86-64 (measured: the periodic pair loops ran ~10× slower
/// per particle-step with it).
const ROUND: Real = 12_582_912.0;

impl Separation for MinimumImage {
    const PERIODIC: bool = true;
    /// `d − L·round(d/L)` for `|d/L| < 2²²` (positions are wrapped into the box every substep,
    /// so `|d/L|` stays near 1).
    #[inline(always)]
    fn sep(&self, a: Vector, b: Vector) -> Vector {
        let d = a - b;
        let k = (d * self.inv_len + Vector::splat(ROUND)) - Vector::splat(ROUND);
        d - self.len * k
    }
}

/// Runs `$body` with `$S` the separation type of `$domain` and `$sep` its value:
/// `with_separation!(p.domain, S, sep => f::<S>(sep))`.
#[macro_export]
#[doc(hidden)]
macro_rules! with_separation {
    ($domain:expr, $S:ident, $sep:ident => $body:expr) => {
        match $domain.minimum_image() {
            None => {
                #[allow(dead_code)]
                type $S = $crate::domain::Open;
                let $sep = $crate::domain::Open;
                $body
            }
            Some($sep) => {
                #[allow(dead_code)]
                type $S = $crate::domain::MinimumImage;
                $body
            }
        }
    };
}
