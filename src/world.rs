//! [`FluidWorld`]: a rapier world and its fluids in one value, for the simple case.

use crate::diagnostics::StepReport;
use crate::error::SphResult;
use crate::fluid::FluidSet;
use crate::pipeline::FluidPipeline;
use rapier3d::pipeline::PhysicsWorld;

/// A rapier [`PhysicsWorld`] plus fluids, stepped together: rapier first, then the fluids,
/// with the world's gravity and time step (`physics.integration_parameters.dt`).
///
/// Every field is public, so you can reach into rapier as usual.
#[derive(Default)]
pub struct FluidWorld {
    /// The rapier world (bodies, colliders, broad-phase, ...).
    pub physics: PhysicsWorld,
    /// The fluids.
    pub fluids: FluidSet,
    /// The fluid pipeline (holds the last step report).
    pub pipeline: FluidPipeline,
}

impl FluidWorld {
    /// An empty world with rapier's defaults (gravity −9.81 m/s² along y, dt = 1/60 s).
    pub fn new() -> Self {
        Self::default()
    }

    /// Steps rapier, then the fluids, by `physics.integration_parameters.dt`.
    pub fn step(&mut self) -> SphResult<&StepReport> {
        self.physics.step();
        self.step_fluids()
    }

    /// Steps only the fluids, with the world's gravity and time step, against the rapier
    /// world as it is (for a world stepped elsewhere, or static geometry after rapier has
    /// stepped once).
    pub fn step_fluids(&mut self) -> SphResult<&StepReport> {
        let p = &mut self.physics;
        self.pipeline.rapier_substeps = p.integration_parameters.num_solver_iterations;
        self.pipeline.step(
            p.gravity,
            p.integration_parameters.dt,
            &mut self.fluids,
            &mut p.bodies,
            &p.colliders,
            &p.broad_phase,
        )
    }
}
