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
    /// Interacting fluids stepped together (`crate::fluid::interaction`): each particle's
    /// factors on the reference fluid's accelerations and viscosity. `None` for one fluid.
    pub phases: Option<Phases<'a>>,
}

impl<'a> StepContext<'a> {
    /// Each particle's mass: the fluid's, or with [`StepContext::phases`] the reference mass
    /// over each particle's ratio (what its impulses on bodies count).
    pub fn masses(&self) -> crate::boundary::bodies::ParticleMass<'a> {
        crate::boundary::bodies::ParticleMass {
            mass: self.params.particle_mass,
            ratio: self.phases.map(|p| p.ratio),
        }
    }
}

/// Per-particle factors of a group of interacting fluids stepped as one
/// (`crate::fluid::interaction`), indexed like the sorted particles.
#[derive(Copy, Clone)]
pub(crate) struct Phases<'a> {
    /// `r_i = m_ref/m_i = ρ_ref/ρ0_i`: the factor on every pair acceleration of particle `i`.
    pub ratio: &'a [Real],
    /// `√(ε_i/ε)`, `ε` the group's (largest) viscosity: a pair's viscosity is `ε` times the
    /// two particles' weights, `√(ε_i·ε_j)`.
    pub viscosity: &'a [Real],
}

impl Phases<'_> {
    /// Multiplies each acceleration by its particle's ratio.
    pub fn scale(&self, accelerations: &mut [Vector]) {
        for (a, &r) in accelerations.iter_mut().zip(self.ratio) {
            *a *= r;
        }
    }

    /// `1/ρ_j` weighted by the viscosity weights, into `out` (the viscosity stages read it in
    /// place of `1/ρ`, which gives each pair `√(ε_i·ε_j)`).
    pub fn viscous_inv_densities(&self, inv_densities: &[Real], out: &mut Vec<Real>) {
        out.clear();
        out.extend(
            inv_densities
                .iter()
                .zip(self.viscosity)
                .map(|(&d, &w)| d * w),
        );
    }
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
