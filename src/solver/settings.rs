//! The solver a fluid uses and its settings: plain data the game sets through
//! [`crate::FluidParams::solver`]. Each solver's settings live in its own folder
//! (`solver/<name>/settings.rs`); this file names them together.

pub use super::clavet::settings::{Clavet, Springs};
pub use super::dfsph::settings::Dfsph;
pub use super::pbf::settings::Pbf;

/// Which pressure solver a fluid uses.
///
/// # Examples
///
/// ```
/// use rapier_sph::{Dfsph, Fluid, FluidParamsBuilder, SphError, Solver};
/// // DFSPH held to 0.05 % density error instead of the default 0.1 %.
/// let tight = Solver::Dfsph(Dfsph { max_density_error: 0.0005, ..Dfsph::default() });
/// let fluid = Fluid::new(FluidParamsBuilder::water(0.05).solver(tight).build()?)?;
/// assert_eq!(fluid.params().solver.name(), "DFSPH");
/// // Settings are checked when the parameters are built, naming the field.
/// let none = Solver::Dfsph(Dfsph { max_iterations: 0, ..Dfsph::default() });
/// let err = FluidParamsBuilder::water(0.05).solver(none).build().unwrap_err();
/// assert!(matches!(err, SphError::InvalidParameter { field: "max_iterations", .. }));
/// # Ok::<(), SphError>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub enum Solver {
    /// Weakly-compressible SPH: pressure from the fluid's equation of state, symplectic Euler.
    /// The Unity paper's method.
    Wcsph,
    /// Divergence-free SPH with the given settings.
    Dfsph(Dfsph),
    /// Position-based fluids with the given settings.
    Pbf(Pbf),
    /// Clavet et al.'s double-density relaxation with the given settings.
    Clavet(Clavet),
}

impl Solver {
    /// The solver's short name, as printed in reports.
    pub fn name(&self) -> &'static str {
        match self {
            Solver::Wcsph => "WCSPH",
            Solver::Dfsph(_) => "DFSPH",
            Solver::Pbf(_) => "PBF",
            Solver::Clavet(_) => "Clavet",
        }
    }

    /// DFSPH with default settings (0.1 % density error, 1 % divergence error).
    pub fn dfsph() -> Self {
        Solver::Dfsph(Dfsph::default())
    }

    /// PBF with default settings (4 iterations, artificial pressure k = 0.1, n = 4, Δq = 0.2h).
    pub fn pbf() -> Self {
        Solver::Pbf(Pbf::default())
    }

    /// Double-density relaxation with default settings (stiffness 1 in units of `c²/(h·ρ0)`,
    /// near stiffness balancing a flat free surface).
    pub fn clavet() -> Self {
        Solver::Clavet(Clavet::default())
    }
}
