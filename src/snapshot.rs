//! Save and restore the whole simulation (feature `snapshot`): every fluid's particles,
//! parameters and solver warm-start values, the pipeline's time-stepping policy, and the rapier `PhysicsWorld` through
//! rapier's own `serde-serialize` support, in one binary file (postcard).
//!
//! Restoring and stepping on gives bitwise the same state as never having stopped (tested
//! in `tests/snapshot.rs`, with a dynamic rapier body in the scene), so snapshots serve as
//! game save files and replay checkpoints.
//!
//! ```no_run
//! # use rapier_sph::FluidWorld;
//! # let world = FluidWorld::new();
//! rapier_sph::snapshot::save(&world, "state.bin")?;
//! let restored = rapier_sph::snapshot::load("state.bin")?;
//! # Ok::<(), rapier_sph::snapshot::SnapshotError>(())
//! ```
//!
//! Fluids come back in the set's iteration order with fresh handles: the handles equal the
//! old ones when no fluid was ever removed from the set (handles hold generations, which are
//! not stored). The file starts with a format tag and version; a file from another version
//! of the format is refused with [`SnapshotError::Version`].

#![cfg_attr(docsrs, doc(cfg(feature = "snapshot")))]

use crate::error::SphError;
use crate::fluid::snapshot::FluidState;
use crate::math::{Real, Vector};
use crate::pipeline::{FluidPipeline, TimeStepping};
use crate::solver::SolverMemory;
use crate::world::FluidWorld;
use rapier3d::pipeline::PhysicsWorld;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::{Path, PathBuf};

const MAGIC: &[u8; 16] = b"rapier-sph snap\0";
/// The snapshot format's version, stored in every file (3: fluids carry their emitters,
/// sinks, emitted/drained counters and capacity; 4: the coupling's memory of the velocity
/// each dynamic body was left with; 5: per-particle attributes, and the solvers' memory
/// beside the fluids).
pub const FORMAT_VERSION: u32 = 5;

/// A body handle's raw parts and a linear velocity.
type BodyVelocity = ((u32, u32), [Real; 3]);

#[derive(Serialize)]
struct SnapshotRef<'a> {
    time_stepping: TimeStepping,
    coupling: Vec<BodyVelocity>,
    fluids: Vec<FluidState>,
    solvers: Vec<SolverMemory>,
    physics: &'a PhysicsWorld,
}

#[derive(Deserialize)]
struct SnapshotOwned {
    time_stepping: TimeStepping,
    coupling: Vec<BodyVelocity>,
    fluids: Vec<FluidState>,
    solvers: Vec<SolverMemory>,
    physics: PhysicsWorld,
}

/// Errors of saving and restoring.
#[derive(Debug)]
#[non_exhaustive]
pub enum SnapshotError {
    /// The file could not be read or written.
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// Not a snapshot file (no format tag).
    NotASnapshot,
    /// A snapshot of another format version.
    Version {
        /// The version found in the file.
        found: u32,
    },
    /// The data could not be encoded or decoded (truncated or corrupt file).
    Encoding(String),
    /// The decoded fluid data is invalid (bad parameters, non-finite particles, arrays of
    /// different lengths).
    Invalid(SphError),
}

impl fmt::Display for SnapshotError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SnapshotError::Io { path, source } => write!(f, "{}: {source}", path.display()),
            SnapshotError::NotASnapshot => write!(f, "not a rapier-sph snapshot"),
            SnapshotError::Version { found } => write!(
                f,
                "snapshot format version {found}; this build reads version {FORMAT_VERSION}"
            ),
            SnapshotError::Encoding(m) => write!(f, "corrupt snapshot: {m}"),
            SnapshotError::Invalid(e) => write!(f, "invalid snapshot data: {e}"),
        }
    }
}

impl std::error::Error for SnapshotError {}

/// The whole state as bytes.
pub fn to_bytes(world: &FluidWorld) -> Result<Vec<u8>, SnapshotError> {
    let data = SnapshotRef {
        time_stepping: world.pipeline.time_stepping,
        coupling: world
            .pipeline
            .coupling_memory()
            .iter()
            .map(|(h, v)| (h.into_raw_parts(), v.to_array()))
            .collect(),
        fluids: world
            .fluids
            .iter()
            .map(|(_, f)| FluidState::capture(f))
            .collect(),
        solvers: world
            .fluids
            .iter()
            .map(|(h, _)| world.pipeline.solver_memory(h))
            .collect(),
        physics: &world.physics,
    };
    let mut out = MAGIC.to_vec();
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    postcard::to_extend(&data, out).map_err(|e| SnapshotError::Encoding(e.to_string()))
}

/// The state back from [`to_bytes`].
pub fn from_bytes(bytes: &[u8]) -> Result<FluidWorld, SnapshotError> {
    if bytes.len() < MAGIC.len() + 4 || &bytes[..MAGIC.len()] != MAGIC {
        return Err(SnapshotError::NotASnapshot);
    }
    let v = &bytes[MAGIC.len()..MAGIC.len() + 4];
    let found = u32::from_le_bytes([v[0], v[1], v[2], v[3]]);
    if found != FORMAT_VERSION {
        return Err(SnapshotError::Version { found });
    }
    let data: SnapshotOwned = postcard::from_bytes(&bytes[MAGIC.len() + 4..])
        .map_err(|e| SnapshotError::Encoding(e.to_string()))?;
    let mut world = FluidWorld {
        physics: data.physics,
        pipeline: FluidPipeline::with_time_stepping(data.time_stepping),
        ..FluidWorld::default()
    };
    world.pipeline.set_coupling_memory(
        data.coupling
            .into_iter()
            .map(|((i, g), v)| {
                (
                    rapier3d::dynamics::RigidBodyHandle::from_raw_parts(i, g),
                    Vector::from_array(v),
                )
            })
            .collect(),
    );
    if data.solvers.len() != data.fluids.len() {
        return Err(SnapshotError::Encoding(
            "solver states and fluids differ in number".into(),
        ));
    }
    for (state, memory) in data.fluids.into_iter().zip(data.solvers) {
        if !memory.springs.is_consistent() {
            return Err(SnapshotError::Invalid(SphError::InvalidParticle {
                index: 0,
                reason: "snapshot springs are malformed",
            }));
        }
        let fluid = state.restore().map_err(SnapshotError::Invalid)?;
        let handle = world.fluids.insert(fluid);
        world
            .pipeline
            .restore_solver_memory(handle, &world.fluids, memory);
    }
    Ok(world)
}

/// Writes the whole state to `path`.
pub fn save(world: &FluidWorld, path: impl AsRef<Path>) -> Result<(), SnapshotError> {
    let path = path.as_ref();
    let bytes = to_bytes(world)?;
    std::fs::write(path, bytes).map_err(|source| SnapshotError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Reads a state written by [`save`].
pub fn load(path: impl AsRef<Path>) -> Result<FluidWorld, SnapshotError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| SnapshotError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    from_bytes(&bytes)
}
