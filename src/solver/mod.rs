//! Pressure solvers: how a fluid keeps its density. Chosen per fluid with
//! [`crate::FluidParams::solver`]; all solvers share the particles, the neighbour search, the
//! kernels, the walls' density contributions and collider contact.
//!
//! | solver | idea | cost per step | use it for |
//! |---|---|---|---|
//! | [`Solver::Wcsph`] | pressure from an equation of state (Müller et al. 2003; the Unity paper) | 3 neighbour passes, small time steps (`dt ≤ 0.4·h/c`) | reproducing the paper (the paper preset's default) |
//! | [`Solver::Dfsph`] | pressure solved for: divergence-free and constant-density (Bender & Koschier 2017) | 1 + 2 per iteration, large time steps | accuracy: the water preset's default |
//! | [`Solver::Clavet`] | double-density relaxation of predicted positions (Clavet et al. 2005) | 2 + viscosity, acoustic time steps | games wanting cohesive, splashy liquid; the paper's future work |
//! | [`Solver::Pbf`] | incompressibility as a position constraint, a fixed number of Jacobi iterations (Macklin & Müller 2013) | 2 per iteration (default 4 iterations) + viscosity, any time step | games: fixed cost, never diverges |

pub mod clavet;
pub mod dfsph;
pub(crate) mod pairs;
pub mod pbf;
pub mod springs;

pub use clavet::Clavet;

use crate::math::Real;

/// Most halvings of a fluid's Jacobi relaxation `ω` (down to 1/8), shared by DFSPH and PBF:
/// both halve `ω` when their iteration diverges and keep the count on the fluid (one count per
/// fluid, saved in snapshots, reported as [`crate::StepReport::solver_relaxation_halvings`]).
/// Why and when, per solver: [`dfsph::MAX_RELAXATION_HALVINGS`], [`pbf::MAX_RELAXATION_HALVINGS`].
pub const MAX_RELAXATION_HALVINGS: u32 = 3;

/// The relaxation `ω = 0.5^halvings` after `halvings` halvings.
#[inline]
pub(crate) fn relaxation(halvings: u32) -> Real {
    Real::powi(0.5, halvings as i32)
}
pub use dfsph::{Dfsph, HYDROSTATIC_WALL_MIRROR, WALL_MIRROR};
pub use pbf::Pbf;
pub use springs::Springs;

/// Which pressure solver a fluid uses.
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
