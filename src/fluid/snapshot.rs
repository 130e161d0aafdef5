//! A fluid's complete state as plain serde data (feature `snapshot`): every per-particle
//! array and counter the step reads. The workspace (grid, neighbour lists, scratch) is
//! rebuilt from the particles by the next step, so it is not stored.

use super::{Attributes, Fluid};
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
    attributes: Attributes,
    next_id: u32,
    quarantined: usize,
    needs_depenetration: bool,
    #[serde(default)]
    relax_pending: bool,
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
            attributes: f.attributes.clone(),
            next_id: f.next_id,
            quarantined: f.quarantined,
            needs_depenetration: f.needs_depenetration,
            relax_pending: f.relax_pending,
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
        if !self.attributes.is_consistent(n) {
            return Err(crate::SphError::InvalidParticle {
                index: 0,
                reason: "snapshot attributes differ in length from the particles",
            });
        }
        f.attributes = self.attributes;
        f.next_id = self.next_id;
        f.quarantined = self.quarantined;
        f.needs_depenetration = self.needs_depenetration;
        f.relax_pending = self.relax_pending;
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
        Ok(f)
    }
}
