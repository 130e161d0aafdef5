//! Typed errors. The library never panics on user input: every bad value is reported here.

use std::fmt;

/// Everything that can go wrong when building parameters, adding particles or stepping.
///
/// # Examples
/// ```
/// use rapier_sph::{Fluid, FluidParamsBuilder, SphError};
/// match Fluid::new(FluidParamsBuilder::water(0.05).viscosity(-1.0)) {
///     Err(SphError::InvalidParameter { field, value, .. }) => {
///         assert_eq!((field, value), ("viscosity", -1.0));
///     }
///     other => panic!("expected a typed error, got {other:?}"),
/// }
/// ```
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum SphError {
    /// A parameter is NaN, infinite, out of range, or inconsistent with another one.
    InvalidParameter {
        /// The parameter's field name, e.g. `"smoothing_length"`.
        field: &'static str,
        /// The offending value, as given.
        value: f64,
        /// Why it was refused.
        reason: &'static str,
    },
    /// A particle given to the library has a non-finite position or velocity.
    InvalidParticle {
        /// The index of the particle in the slice that was given.
        index: usize,
        /// Why it was refused.
        reason: &'static str,
    },
    /// The time step is NaN, infinite, or below [`crate::pipeline::MIN_TIME_STEP`] (zero and
    /// negative included).
    InvalidTimeStep {
        /// The time step that was given.
        dt: f64,
    },
    /// A handle does not name a live fluid of this set.
    UnknownFluid,
    /// The rapier broad-phase holds no collider although the collider set is not empty.
    ///
    /// Collider contact finds colliders through rapier's broad-phase BVH, which rapier fills
    /// when it steps. Step the rapier world (or `FluidWorld`, which does it for you) at least
    /// once after inserting colliders, before stepping the fluid.
    BroadPhaseNotUpdated {
        /// Number of colliders in the `ColliderSet`.
        colliders: usize,
    },
    /// Positions lie inside a triangle mesh built with `TriMeshFlags::ORIENTED`, which parry
    /// treats as a solid: fluid there would be pushed out through the mesh at the next step
    /// (see [`crate::query::check_container`]).
    InsideOrientedTriMesh {
        /// How many of the positions are inside.
        inside: usize,
        /// How many positions were checked.
        positions: usize,
    },
    /// Particles are inside a solid collider ([`crate::check::no_particle_in_solids`]).
    ParticlesInSolid {
        /// `(particle id, collider)` of each, sorted by id.
        particles: Vec<(u32, rapier3d::geometry::ColliderHandle)>,
    },
    /// Particles are outside the container that should hold them
    /// ([`crate::check::all_inside`]).
    ParticlesOutside {
        /// Their ids, sorted.
        ids: Vec<u32>,
    },
    /// A collider or body handle names nothing the call can answer for: no such collider or
    /// body, one removed since, or one that did not ask for what is read (see `reason`).
    UnknownHandle {
        /// The argument, e.g. `"collider"`.
        argument: &'static str,
        /// Why it was refused.
        reason: &'static str,
    },
    /// Reference data of a validation scene could not be read (the `validation` feature).
    ReferenceData {
        /// The file or folder.
        path: String,
        /// What went wrong.
        reason: String,
    },
}

impl fmt::Display for SphError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SphError::InvalidParameter {
                field,
                value,
                reason,
            } => {
                write!(f, "invalid parameter `{field}` = {value}: {reason}")
            }
            SphError::InvalidParticle { index, reason } => {
                write!(f, "invalid particle #{index}: {reason}")
            }
            SphError::InvalidTimeStep { dt } => {
                write!(
                    f,
                    "invalid time step {dt}: it must be finite and at least {} s",
                    crate::pipeline::MIN_TIME_STEP
                )
            }
            SphError::UnknownFluid => write!(f, "the fluid handle does not name a live fluid"),
            SphError::BroadPhaseNotUpdated { colliders } => write!(
                f,
                "the rapier broad-phase is empty but the collider set holds {colliders} colliders: \
                 step the rapier world once after inserting colliders"
            ),
            SphError::InsideOrientedTriMesh { inside, positions } => write!(
                f,
                "{inside} of {positions} positions are inside a triangle mesh built with \
                 TriMeshFlags::ORIENTED: parry treats it as a solid, so fluid there is pushed \
                 out through its surface; build a tank without ORIENTED (a surface) or with \
                 its normals facing the fluid"
            ),
            SphError::ParticlesInSolid { particles } => {
                let first: Vec<u32> = particles.iter().take(8).map(|p| p.0).collect();
                write!(
                    f,
                    "{} particles inside solid colliders (first ids: {first:?})",
                    particles.len()
                )
            }
            SphError::ParticlesOutside { ids } => {
                let first = &ids[..ids.len().min(8)];
                write!(
                    f,
                    "{} particles outside the container (first ids: {first:?})",
                    ids.len()
                )
            }
            SphError::UnknownHandle { argument, reason } => {
                write!(f, "unknown `{argument}`: {reason}")
            }
            SphError::ReferenceData { path, reason } => {
                write!(f, "reference data {path}: {reason}")
            }
        }
    }
}

impl std::error::Error for SphError {}

/// Shorthand for results of this crate.
///
/// # Examples
/// ```
/// use rapier_sph::{Fluid, FluidParamsBuilder, SphResult};
/// fn level(spacing: f32) -> SphResult<Fluid> {
///     Fluid::new(FluidParamsBuilder::water(spacing))
/// }
/// assert!(level(0.05).is_ok());
/// assert!(level(0.0).is_err()); // names `particle_spacing`
/// ```
pub type SphResult<T> = Result<T, SphError>;

/// Reads a whole file of at most `max_bytes`: refuses what is not a regular file (a device
/// such as `/dev/zero`, a pipe, a folder) before reading it, refuses a larger file, reserves
/// the buffer with `try_reserve` and never reads more than `max_bytes + 1` bytes (a file that
/// grows while it is read is refused too).
#[cfg(any(feature = "io", feature = "scene", feature = "snapshot"))]
pub(crate) fn read_regular_file(
    path: &std::path::Path,
    max_bytes: u64,
) -> std::io::Result<Vec<u8>> {
    use std::io::{Error, ErrorKind, Read};
    let file = std::fs::File::open(path)?;
    let meta = file.metadata()?;
    if !meta.is_file() {
        return Err(Error::new(
            ErrorKind::InvalidInput,
            "not a regular file (a device, a pipe or a folder)",
        ));
    }
    let too_big = || {
        Error::new(
            ErrorKind::InvalidData,
            format!("larger than the {max_bytes}-byte limit for this kind of file"),
        )
    };
    if meta.len() > max_bytes {
        return Err(too_big());
    }
    let mut bytes = Vec::new();
    bytes
        .try_reserve_exact(meta.len() as usize)
        .map_err(|_| Error::new(ErrorKind::OutOfMemory, "cannot reserve memory for the file"))?;
    file.take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max_bytes {
        return Err(too_big());
    }
    Ok(bytes)
}
