//! The step context: what one substep of one fluid reads and writes once its neighbours and
//! walls are known. The pipeline builds it (src/pipeline/substep.rs); the solver and the
//! stages after it take it instead of a dozen loose arrays. It borrows, never copies, and its
//! fields are disjoint borrows, so a stage hands each kernel exactly the arrays it uses.

use crate::boundary::WallWorkspace;
use crate::diagnostics::StepReport;
use crate::fluid::Attributes;
use crate::math::{Real, Vector};
use crate::neighbors::NeighborLists;
use crate::params::FluidParams;

/// One substep of one fluid, after the neighbour search and the walls.
pub(crate) struct StepContext<'a> {
    /// The fluid's parameters.
    pub params: &'a FluidParams,
    /// Gravity (m/s²).
    pub gravity: Vector,
    /// The substep (s).
    pub dt: Real,
    /// Particle positions (sorted by cell by the neighbour search).
    pub positions: &'a mut [Vector],
    /// Particle velocities.
    pub velocities: &'a mut [Vector],
    /// Accelerations (written by the force stages; scratch for the position-based solvers).
    pub accelerations: &'a mut [Vector],
    /// Densities (written by the density stage).
    pub densities: &'a mut [Real],
    /// Pressures (written by the solver: the pressure the substep applied).
    pub pressures: &'a mut [Real],
    /// Stable particle ids.
    pub ids: &'a [u32],
    /// Per-particle values the stages keep from one step to the next.
    pub attributes: &'a mut Attributes,
    /// `1/ρ` of every particle (written by the density stage).
    pub inv_densities: &'a mut [Real],
    /// Positions at the substep's start (written by the particle update; contact sweeps from
    /// them).
    pub previous_positions: &'a mut [Vector],
    /// Neighbour lists of the current positions.
    pub neighbors: &'a NeighborLists,
    /// The walls' contributions, when a wall is near and walls count in the density.
    pub wall: Option<&'a WallWorkspace>,
    /// The factor of the fluid's rest density the solver holds it at while its overlap
    /// relaxation is unfinished (1 otherwise; see `pipeline::relax::RelaxBudget::held`):
    /// `params.rest_density` already includes it; Clavet, whose rest density is its lattice's
    /// own, multiplies that by it.
    pub hold: Real,
    /// The step report the stages add to.
    pub report: &'a mut StepReport,
}

/// What a solver's substep reports back: particles that became non-finite, and the largest
/// speed (the next substep's CFL input).
#[derive(Copy, Clone, Debug, Default)]
pub(crate) struct Outcome {
    /// Particles whose position or velocity is not finite.
    pub non_finite: usize,
    /// Largest finite speed (m/s).
    pub max_speed: Real,
}

impl From<(usize, Real)> for Outcome {
    fn from((non_finite, max_speed): (usize, Real)) -> Self {
        Self {
            non_finite,
            max_speed,
        }
    }
}
