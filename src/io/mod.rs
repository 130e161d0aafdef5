//! Exports for ParaView, Blender and Houdini (feature `io`): particles with their attributes
//! and triangle meshes, written and read back through well-kept crates.
//!
//! | what | VTK legacy `.vtk` ([vtkio]) | PLY `.ply` ([ply_rs_bw], binary little-endian) | OBJ `.obj` (read with [tobj]) |
//! |---|---|---|---|
//! | particles: position, velocity, density, pressure, fluid id, particle id | [`write_particles_vtk`] / [`read_particles_vtk`] | [`write_particles_ply`] / [`read_particles_ply`] | — |
//! | triangle meshes (surfaces, colliders) | [`write_mesh_vtk`] / [`read_mesh_vtk`] | [`write_mesh_ply`] / [`read_mesh_ply`] | [`write_mesh_obj`] / [`read_mesh_obj`] |
//!
//! The VTK particle file is `POLYDATA` with one vertex cell per particle, so ParaView shows
//! the points directly (or use its "Point Gaussian" representation). Attributes are point
//! data named `velocity`, `density`, `pressure`, `fluid_id` and `id`; in PLY they are the
//! vertex properties `x y z vx vy vz density pressure fluid_id id`.
//!
//! Values are written as `f32` (`u32` for the ids), exactly as the solver holds them, so a
//! round trip through VTK or PLY gives back bitwise the same numbers (tested). OBJ is text:
//! it keeps about 9 significant digits.

#![cfg_attr(docsrs, doc(cfg(feature = "io")))]

mod obj;
mod ply;
mod vtk;

/// Largest file the readers of this module read (1 GiB): a binary PLY of particles of that
/// size holds 26.8 million particles (40 bytes each), an OBJ mesh tens of millions of
/// triangles. A larger file, or one that is not a regular file (a device such as
/// `/dev/zero`, a pipe), is refused with [`ExportError::Io`] before it is read.
pub const MAX_FILE_BYTES: u64 = 1 << 30;

/// The bytes of `path`, read within [`MAX_FILE_BYTES`].
fn read_bytes(path: &Path) -> Result<Vec<u8>, ExportError> {
    crate::error::read_regular_file(path, MAX_FILE_BYTES).map_err(|e| ExportError::io(path, e))
}

pub use obj::{read_mesh_obj, write_mesh_obj};
pub use ply::{read_mesh_ply, read_particles_ply, write_mesh_ply, write_particles_ply};
pub use vtk::{read_mesh_vtk, read_particles_vtk, write_mesh_vtk, write_particles_vtk};

use crate::fluid::FluidSet;
use crate::math::Vector;
pub use crate::mesh::TriangleMesh;
use std::fmt;
use std::path::{Path, PathBuf};

/// The particles of one frame, all fluids together, one `Vec` per attribute.
///
/// # Examples
///
/// ```
/// use rapier_sph::io::{ParticleData, read_particles_vtk, write_particles_vtk};
/// use rapier_sph::math::Vector;
/// use rapier_sph::{Fluid, FluidParamsBuilder, FluidSet};
///
/// let mut fluids = FluidSet::new();
/// let mut water = Fluid::new(FluidParamsBuilder::water(0.05).build()?)?;
/// water.add_block(Vector::ZERO, Vector::splat(0.2))?;
/// let n = water.len();
/// fluids.insert(water);
/// // One frame of every fluid, e.g. each frame a game records for ParaView.
/// let data = ParticleData::from_fluids(&fluids);
/// assert_eq!(data.len(), n);
/// assert!(data.fluid_ids.iter().all(|&id| id == 0));
/// let path = std::env::temp_dir().join(format!("rapier_sph_doc_{}.vtk", std::process::id()));
/// write_particles_vtk(&path, &data)?;
/// assert_eq!(read_particles_vtk(&path)?, data); // bitwise the same values
/// std::fs::remove_file(&path)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ParticleData {
    /// Positions (m).
    pub positions: Vec<Vector>,
    /// Velocities (m/s).
    pub velocities: Vec<Vector>,
    /// Densities (kg/m³).
    pub densities: Vec<f32>,
    /// Pressures (Pa).
    pub pressures: Vec<f32>,
    /// Which fluid each particle belongs to: its rank in the [`FluidSet`]'s iteration order.
    pub fluid_ids: Vec<u32>,
    /// Stable particle ids within their fluid ([`crate::Fluid::ids`]).
    pub ids: Vec<u32>,
}

impl ParticleData {
    /// Gathers every particle of every fluid of `fluids`.
    pub fn from_fluids(fluids: &FluidSet) -> Self {
        let mut d = ParticleData::default();
        for (rank, (_, f)) in fluids.iter().enumerate() {
            d.positions.extend_from_slice(f.positions());
            d.velocities.extend_from_slice(f.velocities());
            d.densities.extend_from_slice(f.densities());
            d.pressures.extend_from_slice(f.pressures());
            d.fluid_ids
                .extend(std::iter::repeat_n(rank as u32, f.len()));
            d.ids.extend_from_slice(f.ids());
        }
        d
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// `true` when there is no particle.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Checks that every attribute has one value per particle.
    ///
    /// # Errors
    /// [`ExportError::Inconsistent`] naming the attribute whose length differs.
    pub fn check(&self) -> Result<(), ExportError> {
        let n = self.positions.len();
        let lens = [
            ("velocities", self.velocities.len()),
            ("densities", self.densities.len()),
            ("pressures", self.pressures.len()),
            ("fluid_ids", self.fluid_ids.len()),
            ("ids", self.ids.len()),
        ];
        for (name, len) in lens {
            if len != n {
                return Err(ExportError::Inconsistent {
                    path: None,
                    reason: format!("{name} has {len} values for {n} particles"),
                });
            }
        }
        Ok(())
    }
}

/// Errors of reading and writing files.
#[derive(Debug)]
#[non_exhaustive]
pub enum ExportError {
    /// The file could not be created, written or read.
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The format library refused the data or the file (its message).
    Format {
        /// The file.
        path: PathBuf,
        /// Which format: `"vtk"`, `"ply"` or `"obj"`.
        format: &'static str,
        /// The library's message.
        message: String,
    },
    /// The data or file is inconsistent (an attribute is missing or has the wrong length, an
    /// index is out of range, a face is not a triangle).
    Inconsistent {
        /// The file, when the problem is in a file.
        path: Option<PathBuf>,
        /// What is wrong.
        reason: String,
    },
}

impl ExportError {
    pub(crate) fn io(path: &Path, source: std::io::Error) -> Self {
        ExportError::Io {
            path: path.to_path_buf(),
            source,
        }
    }
    pub(crate) fn format(path: &Path, format: &'static str, message: impl fmt::Display) -> Self {
        ExportError::Format {
            path: path.to_path_buf(),
            format,
            message: message.to_string(),
        }
    }
    pub(crate) fn bad(path: &Path, reason: impl Into<String>) -> Self {
        ExportError::Inconsistent {
            path: Some(path.to_path_buf()),
            reason: reason.into(),
        }
    }
}

impl fmt::Display for ExportError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ExportError::Io { path, source } => write!(f, "{}: {source}", path.display()),
            ExportError::Format {
                path,
                format,
                message,
            } => write!(f, "{}: {format} error: {message}", path.display()),
            ExportError::Inconsistent {
                path: Some(p),
                reason,
            } => write!(f, "{}: {reason}", p.display()),
            ExportError::Inconsistent { path: None, reason } => write!(f, "{reason}"),
        }
    }
}

impl std::error::Error for ExportError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            ExportError::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}

pub(crate) fn check_mesh(mesh: &TriangleMesh, path: &Path) -> Result<(), ExportError> {
    let n = mesh.vertices.len() as u32;
    if let Some(t) = mesh.triangles.iter().find(|t| t.iter().any(|&i| i >= n)) {
        return Err(ExportError::bad(
            path,
            format!("triangle {t:?} indexes past the {n} vertices"),
        ));
    }
    Ok(())
}

pub(crate) fn flatten(v: &[Vector]) -> Vec<f32> {
    v.iter().flat_map(|p| [p.x, p.y, p.z]).collect()
}

pub(crate) fn unflatten(v: &[f32]) -> Vec<Vector> {
    v.chunks_exact(3)
        .map(|c| Vector::new(c[0], c[1], c[2]))
        .collect()
}
