//! # rapier-sph
//!
//! Smoothed-particle hydrodynamics (SPH) liquids that run alongside a [rapier3d] world.
//! Particles interact with each other through SPH forces and with every collider of a
//! rapier `ColliderSet` (every parry shape) through swept parry queries, so no particle ever
//! crosses a wall.
//!
//! The starting point is Wong's "Smoothed Particle Hydrodynamics: A Real Time Implementation
//! in the Unity Game Engine" (Müller et al. 2003 forces), reproduced faithfully, with its
//! future work (an unbounded hashed grid) included.
//!
//! ## One step
//!
//! ```text
//! FluidPipeline::step (pipeline/mod.rs)   a frame is split into CFL substeps (pipeline/time_stepping.rs)
//!   per substep and fluid, the stages of pipeline/substep.rs:
//!   ├─ 0 overlap relaxation  pipeline/relax.rs    only after particles were added or pushed out of a solid
//!   ├─ 1 prediction          integrate.rs         PBF, Clavet: gravity, then x += dt·v
//!   ├─ 2 neighbour search    neighbors/           sort by cell, hashed grid, flat neighbour lists
//!   ├─ 3 wall density        boundary/wall/       colliders within h add ρ0·Φ (if enabled)
//!   ├─ 4 the solver          solver/              one `PressureSolver` per fluid:
//!   │    WCSPH (solver/wcsph.rs, the paper)   density.rs, pressure/eos.rs, pressure/wcsph.rs,
//!   │                                         forces/viscosity.rs, forces/external.rs, integrate.rs
//!   │    DFSPH (solver/dfsph/)                density and factors, divergence solve, viscosity,
//!   │                                         gravity, constant-density solve, particle update
//!   │    PBF (solver/pbf/), Clavet (solver/clavet/)   position solve, velocities, viscosity
//!   ├─ 5 wall viscosity      forces/wall_viscosity.rs   (skipped if ε_w = 0)
//!   ├─ 6 wall reaction       boundary/bodies.rs   the solver's wall term pushes dynamic bodies back
//!   ├─ 7 collider contact    boundary/contact.rs  swept parry queries, reflection + friction,
//!   │                                             moving bodies in their own frame
//!   └─ 8 sinks               emitter/             particles in drains are removed
//! the fluid's impulses on dynamic bodies (contact, and each solver's wall term) change their
//! velocities at once, so bodies move with the substeps (boundary/bodies.rs);
//! after the substeps: emitters add the frame's particles (emitter/); the impulses go to
//! rapier and the bodies are moved by the drift they made
//! ```
//!
//! ARCHITECTURE.md lists the stages with who owns which data and how to add a stage or a
//! solver.
//!
//! Each stage is timed ([`StepReport::timings`]); see [`pipeline`]. Game logic reads the
//! fluid through [`query`] (amount in a region or sensor, SPH samples, enter/leave counts). Particles whose state
//! becomes NaN or infinite are quarantined (removed and counted in the report).
//!
//! ## In a rapier game loop
//!
//! ```
//! use rapier3d::prelude::*;
//! use rapier_sph::{Fluid, FluidParamsBuilder, FluidPipeline, FluidSet};
//!
//! // A rapier world with a floor...
//! let mut world = PhysicsWorld::default();
//! let floor = world.insert_body(RigidBodyBuilder::fixed());
//! world.insert_collider(ColliderBuilder::cuboid(2.0, 0.1, 2.0), Some(floor));
//!
//! // ...and a block of water above it (the builder goes straight in: one fallible call).
//! let mut fluid = Fluid::new(FluidParamsBuilder::water(0.05))?;
//! fluid.add_block(Vector::new(-0.25, 0.2, -0.25), Vector::new(0.5, 0.5, 0.5))?;
//! let mut fluids = FluidSet::new();
//! let water = fluids.insert(fluid);
//! let mut pipeline = FluidPipeline::new();
//!
//! world.integration_parameters.dt = 1.0 / 60.0;
//! for _frame in 0..10 {
//!     world.step(); // rapier first (it fills the broad-phase the fluid queries)
//!     // The fluid follows with rapier's gravity, dt and substep count, split into stable
//!     // substeps (CFL and acoustic limits).
//!     let report = pipeline.step_world(&mut world, &mut fluids)?;
//!     assert!(report.substeps >= 1 && !report.substep_cap_hit);
//! }
//! // Nothing fell through the floor.
//! assert!(fluids[water].positions().iter().all(|p| p.y > 0.1));
//! # Ok::<(), rapier_sph::SphError>(())
//! ```
//!
//! `world.step_with_events(&hooks, &events)` (rapier's events) works the same way; a game that
//! keeps rapier's sets itself calls [`FluidPipeline::step_with_parameters`].
//!
//! [`FluidWorld`] bundles the rapier world, the fluids and the pipeline for the simple case.
//!
//! ## Cargo features
//!
//! | feature | default | what it does |
//! |---|---|---|
//! | `parallel` | yes | runs every per-particle stage on rayon; the serial build gives bitwise the same results |
//! | `io` | no | `io`: particles to VTK/PLY, meshes to OBJ/PLY/VTK, and readers (vtkio, ply-rs-bw, tobj) |
//! | `render` | no | `render`: headless PNG frames and GIFs, own software rasteriser (png, gif) |
//! | `scene` | no | `scene_file`: RON scene files with file:line errors (serde, ron, tobj) |
//! | `snapshot` | no | `snapshot`: save/restore fluids + rapier world, bitwise continuation (postcard) |
//! | `surface` | no | `surface`: liquid surface meshes (splashsurf_lib) |
//! | `viewer` | no | `examples/viewer.rs`: a kiss3d window for scene files |
//! | `cli` | no | the `rapier-sph` binary: `run` and `validate` scene files (clap, indicatif) |
//! | `validation` | no | `validation`, `stability`, `scenes`: the validation scenes, the stability suite and the reference scenes the crate's own tests, examples and benches use |
//! | `report` | no | `examples/error_vs_runtime.rs`: the error-vs-run-time report's plots (plotters, resvg) and progress bar (indicatif) |
//!
//! None of the optional features changes the simulation; the default build pulls none of
//! their dependencies.
//!
//! ## FAQ
//!
//! - *Particles fall through my colliders.* Contact finds colliders through rapier's
//!   broad-phase, which rapier fills when it steps: step rapier once after adding colliders
//!   (the step returns [`SphError::BroadPhaseNotUpdated`] if the broad-phase is empty).
//! - *The fluid explodes.* Weakly-compressible SPH needs `dt ≤ 0.4·h/c`
//!   ([`FluidParams::acoustic_time_step`]); the default [`TimeStepping::Adaptive`] substeps
//!   the frame for you, and the report says when its substep cap bound.
//! - *Particle order changed.* Particles are sorted by grid cell every step; use
//!   [`Fluid::ids`] to follow one particle.

#![warn(missing_docs)]
#![cfg_attr(docsrs, feature(doc_cfg))]

pub(crate) mod boundary;
pub mod check;
pub(crate) mod delta_sph;
pub(crate) mod density;
pub mod diagnostics;
pub mod domain;
pub mod emitter;
pub mod error;
pub mod fluid;
pub(crate) mod forces;
#[doc = include_str!("../docs/guide.md")]
pub mod guide {}
pub(crate) mod integrate;
#[cfg(feature = "io")]
pub mod io;
pub mod kernel;
pub mod math;
#[cfg(any(feature = "io", feature = "render"))]
pub mod mesh;
pub mod mixture;
pub mod neighbors;
pub(crate) mod par;
pub mod params;
pub mod pipeline;
pub(crate) mod pressure;
pub mod query;
pub(crate) mod region;
#[cfg(feature = "render")]
pub mod render;
pub mod scalars;
#[cfg(feature = "scene")]
pub mod scene_file;
#[cfg(feature = "validation")]
pub mod scenes;
pub mod sleep;
#[cfg(feature = "snapshot")]
pub mod snapshot;
pub mod solver;
#[cfg(feature = "validation")]
pub mod stability;
#[cfg(feature = "surface")]
pub mod surface;
#[cfg(feature = "validation")]
pub mod validation;
pub mod visual;
pub mod world;

pub use boundary::forces as boundary_forces;
pub use boundary::forces::{ColliderForce, FluidContactEvent, FluidContactKind};
pub use diagnostics::{Stage, StageTimings, StepReport};
pub use domain::Domain;
#[allow(deprecated)]
pub use emitter::SinkRegion;
pub use emitter::{Attachment, Emitter, EmitterHandle, Nozzle, Sink, SinkHandle};
pub use error::{SphError, SphResult};
pub use fluid::{Fluid, FluidHandle, FluidSet, IntoFluidParams};
pub use kernel::KernelKind;
pub use params::{
    EquationOfState, FluidParams, FluidParamsBuilder, ImplicitViscosity, ViscositySolve,
};
pub use pipeline::{FluidPipeline, TimeStepping};
pub use query::{FluidAmount, FluidSampler, Region, RegionTracker, WaterColumn, WaterSurface};
pub use sleep::{Sleep, SleepInfo};
pub use solver::{Clavet, Dfsph, Pbf, Solver, Springs, WcsphDensity, WcsphPressure};
pub use world::FluidWorld;

/// Re-export of the rapier version this crate is built on.
pub use rapier3d;

/// The common types in one import.
pub mod prelude {
    pub use crate::math::{Pose, Real, Vector};
    pub use crate::{
        Clavet, ColliderForce, Dfsph, Domain, Emitter, EquationOfState, Fluid, FluidContactEvent,
        FluidContactKind, FluidHandle, FluidParams, FluidParamsBuilder, FluidPipeline,
        FluidSampler, FluidSet, FluidWorld, KernelKind, Nozzle, Pbf, Region, RegionTracker, Sink,
        Solver, SphError, SphResult, Springs, Stage, StepReport, TimeStepping, WaterColumn,
        WaterSurface,
    };
    // Emitters carried by bodies, handles, and the one-call `Fluid::new(builder)`.
    pub use crate::{Attachment, EmitterHandle, IntoFluidParams, SinkHandle};
    // The implicit viscosity solve's settings.
    pub use crate::{ImplicitViscosity, ViscositySolve};
    // Sleeping water (off unless set in the parameters).
    pub use crate::{Sleep, SleepInfo};
    // WCSPH's pressure force and wall pressure, and its density (summation or δ-SPH).
    pub use crate::{WcsphDensity, WcsphPressure};
}
