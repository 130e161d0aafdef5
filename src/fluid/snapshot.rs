//! A fluid's complete state as plain serde data (feature `snapshot`): every per-particle
//! array and counter the step reads. The workspace (grid, neighbour lists, scratch) is
//! rebuilt from the particles by the next step, so it is not stored.

use super::{Fluid, Workspace};
use crate::error::SphResult;
use crate::math::{Real, Vector};
use crate::params::FluidParams;
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Serialize, Deserialize)]
pub(crate) struct FluidState {
    params: FluidParams,
    positions: Vec<Vector>,
    velocities: Vec<Vector>,
    accelerations: Vec<Vector>,
    densities: Vec<Real>,
    pressures: Vec<Real>,
    ids: Vec<u32>,
    warm_density: Vec<Real>,
    warm_divergence: Vec<Real>,
    #[serde(default)]
    springs: crate::solver::springs::SpringSet,
    next_id: u32,
    quarantined: usize,
    needs_depenetration: bool,
    #[serde(default)]
    relax_pending: bool,
    #[serde(default)]
    solver_relaxation: u32,
    emitted: usize,
    drained: usize,
    sources: crate::emitter::Sources,
    capacity: Option<usize>,
}

impl FluidState {
    pub(crate) fn capture(f: &Fluid) -> Self {
        Self {
            params: f.params.clone(),
            positions: f.positions.clone(),
            velocities: f.velocities.clone(),
            accelerations: f.accelerations.clone(),
            densities: f.densities.clone(),
            pressures: f.pressures.clone(),
            ids: f.ids.clone(),
            warm_density: f.warm_density.clone(),
            warm_divergence: f.warm_divergence.clone(),
            springs: f.springs.clone(),
            next_id: f.next_id,
            quarantined: f.quarantined,
            needs_depenetration: f.needs_depenetration,
            relax_pending: f.relax_pending,
            solver_relaxation: f.solver_relaxation,
            emitted: f.emitted,
            drained: f.drained,
            sources: f.sources.clone(),
            capacity: f.capacity,
        }
    }

    /// The fluid back, checked: parameters valid, every array of the same length, positions
    /// and velocities finite.
    pub(crate) fn restore(self) -> SphResult<Fluid> {
        let mut f = Fluid::new(self.params)?;
        let n = self.positions.len();
        let lens = [
            self.velocities.len(),
            self.accelerations.len(),
            self.densities.len(),
            self.pressures.len(),
            self.ids.len(),
            self.warm_density.len(),
            self.warm_divergence.len(),
        ];
        if lens.iter().any(|&l| l != n) {
            return Err(crate::SphError::InvalidParticle {
                index: lens.iter().copied().min().unwrap_or(0).min(n),
                reason: "snapshot arrays differ in length",
            });
        }
        // Reuse the checks of `add_particles` on positions and velocities.
        f.add_particles_with_velocities(&self.positions, Some(&self.velocities))?;
        f.accelerations = self.accelerations;
        f.densities = self.densities;
        f.pressures = self.pressures;
        f.ids = self.ids;
        f.warm_density = self.warm_density;
        f.warm_divergence = self.warm_divergence;
        if !self.springs.is_consistent() {
            return Err(crate::SphError::InvalidParticle {
                index: 0,
                reason: "snapshot springs are malformed",
            });
        }
        f.springs = self.springs;
        f.next_id = self.next_id;
        f.quarantined = self.quarantined;
        f.needs_depenetration = self.needs_depenetration;
        f.relax_pending = self.relax_pending;
        f.solver_relaxation = self
            .solver_relaxation
            .min(crate::solver::MAX_RELAXATION_HALVINGS);
        f.emitted = self.emitted;
        f.drained = self.drained;
        for e in self.sources.emitters.iter() {
            e.1.validate()?;
        }
        for s in self.sources.sinks.iter() {
            s.1.validate()?;
        }
        f.sources = self.sources;
        f.set_capacity(self.capacity)?;
        f.workspace = Workspace::default();
        Ok(f)
    }
}
