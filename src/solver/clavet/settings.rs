//! The double-density relaxation's settings and its springs': what the game sets (a variant of [`crate::Solver`] carries it). Plain data with
//! defaults; the algorithm is the folder's other files.

use crate::math::Real;

/// Settings of the double-density relaxation.
///
/// # Examples
/// ```
/// use rapier_sph::{Clavet, Fluid, FluidParamsBuilder, Solver, math::Vector};
/// // A stiffer relaxation (1.5 × the default stiffness) for a splashy, cheap liquid.
/// let solver = Solver::Clavet(Clavet { stiffness: 1.5, ..Clavet::default() });
/// let mut goo = Fluid::new(FluidParamsBuilder::water(0.05).solver(solver))?;
/// goo.add_block(Vector::ZERO, Vector::splat(0.2))?;
/// assert!(goo.params().wall_density); // the water preset's walls count in its densities
/// let bad = Solver::Clavet(Clavet { stiffness: -1.0, ..Clavet::default() });
/// assert!(Fluid::new(FluidParamsBuilder::water(0.05).solver(bad)).is_err());
/// # Ok::<(), rapier_sph::SphError>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub struct Clavet {
    /// Stiffness `k`, as a multiple of `c²/(h·ρ0)` (default 1).
    pub stiffness: Real,
    /// Cohesion `k_c`: the stiffness of the tension that pulls in particles sparser than a
    /// flat free surface of the rest lattice (its top layer's density,
    /// [`super::cohesion_threshold`]: edges, corners and curved parts of a surface, sheets,
    /// threads, droplets), same units (default 1, the default stiffness). It holds the liquid
    /// together (the method's surface tension) without holding its bulk: at rest and in
    /// the bulk there is no tension (the module's "Cohesion" says why). 0: no cohesion.
    #[cfg_attr(feature = "snapshot", serde(default = "default_cohesion"))]
    pub cohesion: Real,
    /// Near stiffness `k_near`, same units: the short-range push against near densities
    /// above what the particle's density gives in the rest lattice (clumps, compression; the
    /// module's "Near pressure"). `None` (default): `cohesion`, so a fluid without cohesion has
    /// no near pressure.
    pub near_stiffness: Option<Real>,
    /// Viscoelastic springs between neighbours (section 5 of the paper; see
    /// `solver/springs.rs`). `None` (default): a plain liquid, and the spring stage is skipped.
    #[cfg_attr(feature = "snapshot", serde(default))]
    pub springs: Option<Springs>,
}

impl Default for Clavet {
    fn default() -> Self {
        Self {
            stiffness: 1.0,
            cohesion: 1.0,
            near_stiffness: None,
            springs: None,
        }
    }
}

impl Clavet {
    /// Checks the settings (and the springs'); returns the first problem, naming its field.
    ///
    /// # Errors
    /// [`crate::SphError::InvalidParameter`] naming the first bad field.
    pub fn validate(&self) -> crate::SphResult<()> {
        let non_negative = |field, v: Real| {
            if !v.is_finite() || v < 0.0 {
                Err(crate::SphError::InvalidParameter {
                    field,
                    value: v as f64,
                    reason: "must be finite and non-negative",
                })
            } else {
                Ok(())
            }
        };
        non_negative("stiffness", self.stiffness)?;
        non_negative("cohesion", self.cohesion)?;
        if let Some(k) = self.near_stiffness {
            non_negative("near_stiffness", k)?;
        }
        if let Some(sp) = &self.springs {
            non_negative("spring_stiffness", sp.stiffness)?;
            non_negative("yield_ratio", sp.yield_ratio)?;
            non_negative("plasticity", sp.plasticity)?;
        }
        Ok(())
    }
}

#[cfg(feature = "snapshot")]
fn default_cohesion() -> Real {
    1.0
}

/// Settings of the viscoelastic springs ([`super::Clavet::springs`]).
///
/// # Examples
/// ```
/// use rapier_sph::{Clavet, FluidParamsBuilder, Solver, Springs};
/// // Slime: Clavet's relaxation with springs that forget a deformation in about 0.5 s.
/// let slime = Solver::Clavet(Clavet {
///     springs: Some(Springs { plasticity: 2.0, ..Springs::default() }),
///     ..Clavet::default()
/// });
/// let params = FluidParamsBuilder::water(0.05).solver(slime).build()?;
/// assert!(matches!(params.solver, Solver::Clavet(c) if c.springs.is_some()));
/// let bad = Solver::Clavet(Clavet {
///     springs: Some(Springs { yield_ratio: -0.1, ..Springs::default() }),
///     ..Clavet::default()
/// });
/// assert!(FluidParamsBuilder::water(0.05).solver(bad).build().is_err());
/// # Ok::<(), rapier_sph::SphError>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub struct Springs {
    /// Spring stiffness `k`, as a multiple of `c²/(h²·N)` (see the module docs; default 0.3).
    pub stiffness: Real,
    /// Yield ratio `γ`: the relative deformation a spring takes before its rest length starts
    /// to flow (default 0.1).
    pub yield_ratio: Real,
    /// Plasticity `α` (1/s): how fast a rest length flows once past the yield band (default
    /// 5/s: a deformation is forgotten in about 0.2 s).
    pub plasticity: Real,
}

impl Default for Springs {
    fn default() -> Self {
        Self {
            stiffness: 0.3,
            yield_ratio: 0.1,
            plasticity: 5.0,
        }
    }
}
