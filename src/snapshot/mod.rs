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
//! not stored).
//!
//! ## The file, and what loading checks
//!
//! A file is a 16-byte tag, the format version (`u32`), the payload's length (`u64`) and its
//! CRC-32 (`u32`, IEEE 802.3), all little-endian, then the payload (postcard). Loading refuses,
//! each with its own [`SnapshotError`]:
//! - a file that is not a regular file or is larger than the limit ([`MAX_SNAPSHOT_BYTES`] for
//!   [`load`], any for [`load_with_limit`]): [`SnapshotError::Io`], before it is read;
//! - another tag ([`SnapshotError::NotASnapshot`]) or version ([`SnapshotError::Version`]);
//! - a payload of another length or checksum (a truncated or corrupted file:
//!   [`SnapshotError::Encoding`], [`SnapshotError::Checksum`]): a random corruption passes the
//!   CRC-32 with probability 2^−32;
//! - a payload that does not decode ([`SnapshotError::Encoding`]);
//! - decoded data that is not a valid state ([`SnapshotError::Invalid`]): every fluid's
//!   parameters (and solver settings) valid, its arrays of one length, every value finite,
//!   ids unique and below the next id, springs well formed and naming handed-out ids,
//!   emitters and sinks valid (nozzles within [`crate::emitter::MAX_NOZZLE_SLOTS`] slots),
//!   the capacity reservable; the time stepping valid ([`TimeStepping::validate`]); the
//!   coupling's velocities finite; rapier's gravity, time step and settings (finite, its
//!   iteration counts at most [`crate::params::MAX_SOLVER_ITERATIONS`]), body poses and velocities,
//!   collider poses and bounding boxes finite, every collider's parent a body of the set, the
//!   narrow phase's pairs naming colliders of the set and the joints bodies of the set;
//!   rapier's broad-phase tree and the trees of colliders' triangle meshes, polylines and
//!   compounds well formed (every child, parent link, leaf and free slot inside its array,
//!   no cycle, leaf counts the sums of their children's, boxes finite, at most
//!   `MAX_TREE_DEPTH` = 1,024 levels deep, as parry's refit and pair search recurse once per
//!   level), a mesh's or polyline's vertex indices inside its vertices, a mesh's
//!   pseudo-normals, topology and connected components of its sizes; rapier's islands
//!   consistent with its bodies (each body's place in the active set and in its persistent
//!   island where the islands list it, both ways; the awake island, free island ids and the
//!   pending split existing; every contact and joint link where its location table says);
//!   each body's colliders attached to it and every attached collider in its body's list;
//!   the narrow phase's contact and intersection graphs well formed (every edge in its
//!   source's outgoing and its target's incoming list once, back links matching, no cycle)
//!   and its collider → node map consistent with the nodes; the joint sets (the impulse
//!   joints' graph, handle → edge arena and body → node map, each joint's bodies its edge's;
//!   the multibodies' arena, body → link map, links in order with their degrees of freedom
//!   the next ones of the multibody's vectors, couplings, connectivity graph; each
//!   multibody's vectors, Jacobians, mass matrices and Coriolis workspaces of its links' and
//!   degrees of freedom's sizes where rapier does not size them again); the body and
//!   collider arenas' counts and free lists (the next insertion follows them); the narrow
//!   phase's solver caches (the solver contact graph's 130 buckets, each entry a rigid pair's
//!   solver manifold whose `graph_pos` names it back and the other way round while the graph
//!   is valid, the solver-body ids stamped on its members awake bodies' while it is current,
//!   every pair's solver colour a colour, the force-event list and its back links naming each
//!   other, every solver contact's index a point of its manifold).
//!   Parry and rapier follow these without bounds checks and keep them private, so they are
//!   read through mirrors of their serde layouts (the `bvh`, `islands`, `graphs`, `joints`,
//!   `multibodies` and `caches` modules); rebuilding them instead would change the order in
//!   which rapier finds pairs and solves bodies, and with it the bitwise equality of a
//!   restored run. A cache rapier has marked for rebuilding (a solver contact graph not
//!   valid, or of another epoch) is not read where rapier does not read it.
//!
//! Not checked beyond the references above: soft bodies, and the trees inside voxel shapes
//! (private in parry): the checksum guards them against corruption, not against a file
//! crafted to pass it. Values in range but inconsistent with the rest (a solver-body id of
//! another awake body, one parallel solver colour shared by two pairs of one body) are not
//! looked for: the solver indexes with them within its arrays, and that step's contact forces
//! are wrong. `RigidBodySet`'s list of modified bodies needs no check:
//! rapier looks each of its handles up (`get`, `contains`) before use, so a stale or foreign
//! handle is skipped.

#![cfg_attr(docsrs, doc(cfg(feature = "snapshot")))]

mod bvh;
mod caches;
mod graphs;
mod islands;
mod joints;
mod multibodies;

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
/// beside the fluids; 6: the payload's length and CRC-32 in the header; 7: the scalars the
/// particles carry; 8: the fluid's viscosity solve, `FluidParams::viscosity_solve`, whose
/// warm start rides with the per-particle attributes; 9: each fluid's `fluid_groups`; 10: the
/// fluids' sleep state, see [`crate::sleep`]; 11: PBF's `artificial_pressure_dt_scaling`;
/// 12: `FluidParams::wcsph_pressure`; 13: `FluidParams::mixture`; 14:
/// `FluidParams::wcsph_density`; 15: DFSPH's `chebyshev`).
pub const FORMAT_VERSION: u32 = 15;

/// Bytes before the payload: tag, version, length, checksum.
const HEADER: usize = 16 + 4 + 8 + 4;

/// Largest file [`load`] reads: 4 GiB, about 70 million particles (a snapshot stores about 60
/// bytes a particle, plus rapier's world). [`load_with_limit`] takes another limit.
pub const MAX_SNAPSHOT_BYTES: u64 = 1 << 32;

/// CRC-32 (IEEE 802.3, reflected, polynomial `0xEDB88320`), as zlib and PNG compute it.
fn crc32(bytes: &[u8]) -> u32 {
    const TABLE: [u32; 256] = {
        let mut table = [0u32; 256];
        let mut i = 0;
        while i < 256 {
            let mut c = i as u32;
            let mut k = 0;
            while k < 8 {
                c = if c & 1 != 0 {
                    0xEDB8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
                k += 1;
            }
            table[i] = c;
            i += 1;
        }
        table
    };
    let mut c = !0u32;
    for &b in bytes {
        c = TABLE[((c ^ b as u32) & 0xFF) as usize] ^ (c >> 8);
    }
    !c
}

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
    /// The payload's CRC-32 is not the one stored in the header: the file was corrupted.
    Checksum {
        /// The checksum stored in the file.
        stored: u32,
        /// The checksum of the payload as read.
        computed: u32,
    },
    /// The decoded data is not a valid state (bad parameters, non-finite particles, arrays of
    /// different lengths; in rapier's world, e.g. field `"broad_phase"`: a malformed
    /// broad-phase tree, the wide node concerned as the value).
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
            SnapshotError::Checksum { stored, computed } => write!(
                f,
                "corrupt snapshot: its checksum is {computed:08x}, the file says {stored:08x}"
            ),
            SnapshotError::Invalid(e) => write!(f, "invalid snapshot data: {e}"),
        }
    }
}

impl std::error::Error for SnapshotError {}

/// The whole state as bytes.
///
/// # Errors
/// [`SnapshotError::Encoding`] when the state cannot be encoded.
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
    out.extend_from_slice(&[0; 12]); // length and checksum, written below
    let mut out =
        postcard::to_extend(&data, out).map_err(|e| SnapshotError::Encoding(e.to_string()))?;
    let length = (out.len() - HEADER) as u64;
    let crc = crc32(&out[HEADER..]);
    out[20..28].copy_from_slice(&length.to_le_bytes());
    out[28..32].copy_from_slice(&crc.to_le_bytes());
    Ok(out)
}

/// The state back from [`to_bytes`], checked (see the [module docs](self)).
///
/// # Errors
/// [`SnapshotError::NotASnapshot`], [`SnapshotError::Version`], [`SnapshotError::Checksum`],
/// [`SnapshotError::Encoding`] (truncated, or not decodable) and [`SnapshotError::Invalid`]
/// (decoded, but not a valid state).
pub fn from_bytes(bytes: &[u8]) -> Result<FluidWorld, SnapshotError> {
    if bytes.len() < MAGIC.len() + 4 || &bytes[..MAGIC.len()] != MAGIC {
        return Err(SnapshotError::NotASnapshot);
    }
    let v = &bytes[MAGIC.len()..MAGIC.len() + 4];
    let found = u32::from_le_bytes([v[0], v[1], v[2], v[3]]);
    if found != FORMAT_VERSION {
        return Err(SnapshotError::Version { found });
    }
    if bytes.len() < HEADER {
        return Err(SnapshotError::Encoding("truncated header".into()));
    }
    let length = u64::from_le_bytes(bytes[20..28].try_into().expect("8 bytes"));
    let stored = u32::from_le_bytes(bytes[28..32].try_into().expect("4 bytes"));
    let payload = &bytes[HEADER..];
    if payload.len() as u64 != length {
        return Err(SnapshotError::Encoding(format!(
            "the payload is {} bytes long, the header says {length} (truncated or extended file)",
            payload.len()
        )));
    }
    let computed = crc32(payload);
    if computed != stored {
        return Err(SnapshotError::Checksum { stored, computed });
    }
    let data: SnapshotOwned =
        postcard::from_bytes(payload).map_err(|e| SnapshotError::Encoding(e.to_string()))?;
    data.time_stepping
        .validate()
        .map_err(SnapshotError::Invalid)?;
    check_physics(&data.physics).map_err(SnapshotError::Invalid)?;
    if let Some(k) = data
        .coupling
        .iter()
        .position(|(_, v)| v.iter().any(|x| !x.is_finite()))
    {
        return Err(SnapshotError::Invalid(SphError::InvalidParameter {
            field: "coupling",
            value: k as f64,
            reason: "a body's remembered velocity is not finite",
        }));
    }
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
        let fluid = state.restore().map_err(SnapshotError::Invalid)?;
        if !memory.springs.is_consistent() || !memory.springs.ids_below(fluid.next_id()) {
            return Err(SnapshotError::Invalid(SphError::InvalidParticle {
                index: 0,
                reason: "snapshot springs are malformed",
            }));
        }
        let handle = world.fluids.insert(fluid);
        world
            .pipeline
            .restore_solver_memory(handle, &world.fluids, memory);
    }
    Ok(world)
}

/// Checks what of rapier's world the fluid step and rapier's own step read as numbers:
/// gravity and time step, body poses and velocities, collider poses and bounding boxes finite,
/// and every collider's parent a body of the set.
fn check_physics(p: &PhysicsWorld) -> Result<(), SphError> {
    if !crate::math::is_finite(p.gravity) {
        return bad("gravity", p.gravity.length() as f64, "must be finite");
    }
    check_integration(&p.integration_parameters)?;
    check_bodies(p)?;
    check_colliders(p)?;
    // The graphs first: listing the intersection pairs follows their edges' endpoints.
    graphs::check_narrow_phase(&p.narrow_phase, &p.colliders)?;
    check_references(p)?;
    islands::check_islands(p)?;
    joints::check_joints(p)?;
    joints::check_set_arenas(p)?;
    caches::check_solver_caches(p)?;
    bvh::check_broad_phase(&p.broad_phase)?;
    bvh::check_collider_shapes(&p.colliders)
}

/// The error of a field of rapier's world.
fn bad(field: &'static str, value: f64, reason: &'static str) -> Result<(), SphError> {
    Err(SphError::InvalidParameter {
        field,
        value,
        reason,
    })
}

/// Rapier's integration parameters: a positive finite time step, iteration counts within
/// [`crate::params::MAX_SOLVER_ITERATIONS`], and its settings ([`check_settings`]).
fn check_integration(ip: &rapier3d::dynamics::IntegrationParameters) -> Result<(), SphError> {
    if !(ip.dt.is_finite() && ip.dt > 0.0) {
        return bad(
            "dt",
            ip.dt as f64,
            "rapier's time step must be positive and finite",
        );
    }
    // Rapier's iteration counts bound its step's work: at most MAX_SOLVER_ITERATIONS, as the
    // fluid solvers' (rapier's defaults are 4, 1, 1 and 1).
    let most = crate::params::MAX_SOLVER_ITERATIONS as usize;
    for (field, n) in [
        ("num_solver_iterations", ip.num_solver_iterations),
        (
            "num_internal_pgs_iterations",
            ip.num_internal_pgs_iterations,
        ),
        (
            "num_internal_stabilization_iterations",
            ip.num_internal_stabilization_iterations,
        ),
        ("max_ccd_substeps", ip.max_ccd_substeps),
        (
            "soft_bodies.max_extra_substeps",
            ip.soft_bodies.max_extra_substeps,
        ),
    ] {
        if n > most {
            return bad(
                field,
                n as f64,
                "more than MAX_SOLVER_ITERATIONS (2048) iterations or substeps",
            );
        }
    }
    check_settings(ip)
}

/// Rapier's settings finite, and where rapier needs it, non-negative or positive.
fn check_settings(ip: &rapier3d::dynamics::IntegrationParameters) -> Result<(), SphError> {
    for (field, v) in [
        ("min_ccd_dt", ip.min_ccd_dt),
        ("warmstart_coefficient", ip.warmstart_coefficient),
        ("length_unit", ip.length_unit),
        (
            "normalized_allowed_linear_error",
            ip.normalized_allowed_linear_error,
        ),
        (
            "normalized_max_corrective_velocity",
            ip.normalized_max_corrective_velocity,
        ),
        (
            "normalized_prediction_distance",
            ip.normalized_prediction_distance,
        ),
        (
            "contact_softness.natural_frequency",
            ip.contact_softness.natural_frequency,
        ),
        (
            "contact_softness.damping_ratio",
            ip.contact_softness.damping_ratio,
        ),
    ] {
        if !v.is_finite() {
            return bad(field, v as f64, "rapier's setting must be finite");
        }
    }
    for (field, v) in [
        (
            "normalized_allowed_linear_error",
            ip.normalized_allowed_linear_error,
        ),
        (
            "normalized_max_corrective_velocity",
            ip.normalized_max_corrective_velocity,
        ),
        (
            "normalized_prediction_distance",
            ip.normalized_prediction_distance,
        ),
        ("min_ccd_dt", ip.min_ccd_dt),
    ] {
        if v < 0.0 {
            return bad(field, v as f64, "rapier's setting must not be negative");
        }
    }
    if !(ip.length_unit > 0.0) {
        return bad(
            "length_unit",
            ip.length_unit as f64,
            "rapier's length unit must be positive",
        );
    }
    Ok(())
}

/// Body poses, velocities and masses finite.
fn check_bodies(p: &PhysicsWorld) -> Result<(), SphError> {
    for (k, (_, b)) in p.bodies.iter().enumerate() {
        let pose = b.position();
        let finite = crate::math::is_finite(pose.translation)
            && pose.rotation.is_finite()
            && crate::math::is_finite(b.linvel())
            && crate::math::is_finite(b.angvel())
            && b.mass().is_finite();
        if !finite {
            return bad(
                "bodies",
                k as f64,
                "a body's pose, velocity or mass is not finite",
            );
        }
    }
    Ok(())
}

/// Collider poses, bounding boxes and contact skins finite, parents bodies of the set.
fn check_colliders(p: &PhysicsWorld) -> Result<(), SphError> {
    for (k, (_, c)) in p.colliders.iter().enumerate() {
        let pose = c.position();
        let aabb = c.compute_aabb();
        let finite = crate::math::is_finite(pose.translation)
            && pose.rotation.is_finite()
            && c.contact_skin().is_finite()
            && c.contact_skin() >= 0.0
            && (c.shape().as_halfspace().is_some()
                || crate::math::is_finite(aabb.mins) && crate::math::is_finite(aabb.maxs));
        if !finite {
            return bad(
                "colliders",
                k as f64,
                "a collider's pose, bounding box or contact skin is not finite (or the skin is negative)",
            );
        }
        if let Some(parent) = c.parent()
            && p.bodies.get(parent).is_none()
        {
            return bad(
                "colliders",
                k as f64,
                "a collider's parent is not a body of the set",
            );
        }
    }
    Ok(())
}

/// The narrow phase's pairs and the joints name colliders and bodies of the sets.
fn check_references(p: &PhysicsWorld) -> Result<(), SphError> {
    let collider = |h| p.colliders.get(h).is_some();
    if let Some(k) = p
        .narrow_phase
        .contact_pairs()
        .position(|pair| !collider(pair.collider1) || !collider(pair.collider2))
    {
        return bad(
            "narrow_phase",
            k as f64,
            "a contact pair names a collider that is not in the set",
        );
    }
    if let Some(k) = p
        .narrow_phase
        .intersection_pairs()
        .position(|(a, b, _)| !collider(a) || !collider(b))
    {
        return bad(
            "narrow_phase",
            k as f64,
            "an intersection pair names a collider that is not in the set",
        );
    }
    if let Some(k) = p
        .impulse_joints
        .iter()
        .position(|(_, j)| p.bodies.get(j.body1()).is_none() || p.bodies.get(j.body2()).is_none())
    {
        return bad(
            "impulse_joints",
            k as f64,
            "a joint names a body that is not in the set",
        );
    }
    Ok(())
}

/// Writes the whole state to `path`.
///
/// # Errors
/// [`SnapshotError::Io`] naming the file when it cannot be written; [`to_bytes`]'s errors.
pub fn save(world: &FluidWorld, path: impl AsRef<Path>) -> Result<(), SnapshotError> {
    let path = path.as_ref();
    let bytes = to_bytes(world)?;
    std::fs::write(path, bytes).map_err(|source| SnapshotError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Reads a state written by [`save`]: a regular file of at most [`MAX_SNAPSHOT_BYTES`],
/// checked as [`from_bytes`] does.
///
/// # Errors
/// [`SnapshotError::Io`] when the file cannot be read, is not a regular file (a device, a
/// pipe) or is larger than the limit; then [`from_bytes`]'s errors.
pub fn load(path: impl AsRef<Path>) -> Result<FluidWorld, SnapshotError> {
    load_with_limit(path, MAX_SNAPSHOT_BYTES)
}

/// [`load`] with another size limit (bytes).
///
/// # Errors
/// As [`load`].
pub fn load_with_limit(
    path: impl AsRef<Path>,
    max_bytes: u64,
) -> Result<FluidWorld, SnapshotError> {
    let path = path.as_ref();
    let bytes =
        crate::error::read_regular_file(path, max_bytes).map_err(|source| SnapshotError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    from_bytes(&bytes)
}

#[cfg(test)]
mod tests {
    #[test]
    fn crc32_of_the_check_string() {
        // The standard check value of CRC-32/ISO-HDLC.
        assert_eq!(super::crc32(b"123456789"), 0xCBF4_3926);
        assert_eq!(super::crc32(b""), 0);
    }
}
