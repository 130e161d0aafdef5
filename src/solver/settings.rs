//! The solver a fluid uses and its settings: plain data the game sets through
//! [`crate::FluidParams::solver`]. Each solver's settings live in its own folder
//! (`solver/<name>/settings.rs`); this file names them together.

pub use super::clavet::settings::{Clavet, Springs};
pub use super::dfsph::settings::Dfsph;
pub use super::pbf::settings::Pbf;

use crate::math::Real;

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

/// How WCSPH ([`Solver::Wcsph`]) turns its pressures into forces, in the fluid and at the
/// walls ([`crate::FluidParams::wcsph_pressure`]; other solvers ignore it).
///
/// # Examples
///
/// ```
/// use rapier_sph::{FluidParamsBuilder, Solver, SphError, WcsphPressure};
/// // WCSPH whose pressures next to walls and in the bulk read `ρ0·g·depth` at rest.
/// let params = FluidParamsBuilder::water(0.02)
///     .solver(Solver::Wcsph)
///     .wcsph_pressure(WcsphPressure::Adami)
///     .build()?;
/// assert_eq!(params.wcsph_pressure, WcsphPressure::Adami);
/// // Adami's wall pressure acts through the walls' density: it needs them.
/// let err = FluidParamsBuilder::water(0.02)
///     .solver(Solver::Wcsph)
///     .wall_density(false)
///     .wcsph_pressure(WcsphPressure::Adami)
///     .build()
///     .unwrap_err();
/// assert!(matches!(err, SphError::InvalidParameter { field: "wcsph_pressure", .. }));
/// # Ok::<(), SphError>(())
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub enum WcsphPressure {
    /// The Unity paper's forces as printed (the default): Müller et al. (2003)'s
    /// `−Σ m (p_i + p_j)/(2ρ_j) ∇W`, which is half the SPH pressure gradient (a settled
    /// column's pressures read twice `ρ0·g·depth`), and with wall density a wall term of half
    /// the particle's own pressure, `−p_i/(2ρ_i²)·∇ρ_wall`.
    #[default]
    Paper,
    /// The symmetric SPH pressure force `−Σ m (p_i/ρ_i² + p_j/ρ_j²) ∇W` (Monaghan 1992;
    /// Becker & Teschner 2007, eq. 6), whose pressures are the ones that act, with Adami et
    /// al. (2012)'s wall pressure: the wall's pressure is its fluid-side neighbours' carried
    /// to the wall plus `ρ0·g·(x_b − x_i)`, as DFSPH's hydrostatic walls
    /// ([`crate::Dfsph::hydrostatic_walls`], the same wall terms). Needs
    /// [`crate::FluidParams::wall_density`]. A settled column's bottom pressure reads within
    /// a few per cent of `ρ0·g·depth` instead of +116 to +132 % (docs/solvers.md).
    Adami,
}

/// How WCSPH ([`Solver::Wcsph`]) gets its densities ([`crate::FluidParams::wcsph_density`];
/// other solvers ignore it).
///
/// # Examples
///
/// ```
/// use rapier_sph::{FluidParamsBuilder, Solver, SphError, WcsphDensity, WcsphPressure};
/// // δ-SPH: the continuity equation with density diffusion, on Adami's walls.
/// let params = FluidParamsBuilder::water(0.02)
///     .solver(Solver::Wcsph)
///     .wcsph_pressure(WcsphPressure::Adami)
///     .wcsph_density(WcsphDensity::DELTA_SPH)
///     .build()?;
/// assert_eq!(params.wcsph_density, WcsphDensity::Continuity { delta: 0.1 });
/// // The diffusion coefficient is checked, naming the field.
/// let err = FluidParamsBuilder::water(0.02)
///     .wcsph_density(WcsphDensity::Continuity { delta: -1.0 })
///     .build()
///     .unwrap_err();
/// assert!(matches!(err, SphError::InvalidParameter { field: "wcsph_density", .. }));
/// # Ok::<(), SphError>(())
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub enum WcsphDensity {
    /// Kernel summation `ρ_i = Σ_j m·W_ij` (plus the walls' density) every substep: the
    /// Unity paper's (the default).
    #[default]
    Summation,
    /// The continuity equation `dρ_i/dt = ρ_i Σ_j V_j (v_i − v_j)·∇W_ij` integrated from
    /// step to step (from each pair's relative move over the substep, contact's pushes
    /// included), with the δ-SPH density diffusion of Molteni & Colagrossi (2009) /
    /// Antuono et al. (2010) in the hydrostatic-consistent form of Fourtakas et al. (2019):
    /// `δ·ĥ·c0 Σ_j 2(ρ_j − ρ_i − ρ^H_ji)(r_ji·∇W_ij)/|r_ij|² V_j`, `ĥ` half the crate's
    /// support radius (δ-SPH's smoothing length), `ρ^H_ji = ρ0·g·(x_j − x_i)/c0²`. The walls'
    /// share of the density is summed every substep as with summation (`crate::delta_sph`).
    /// A particle's first density is its summed one, at least `ρ0` (free-surface particles
    /// start at rest density). Not for interacting fluids. Best with
    /// [`WcsphPressure::Adami`]: a settled column's bottom pressure then reads within 1.4 % of
    /// `ρ0·g·depth` (N = 8 and 12, `tests/delta_sph.rs`). It does not lower impact pressure
    /// peaks (docs/validation.md, "Impact pressure").
    Continuity {
        /// The diffusion coefficient δ (0.1 in the δ-SPH papers; 0: the continuity equation
        /// alone). Within `0..=1`.
        delta: Real,
    },
}

impl WcsphDensity {
    /// The continuity equation with δ = 0.1 (Antuono et al. 2010's value).
    pub const DELTA_SPH: Self = WcsphDensity::Continuity { delta: 0.1 };
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
