//! Wavefront OBJ: written here (the format is a few lines of text), read with `tobj`.

use super::{ExportError, TriangleMesh, check_mesh};
use crate::math::Vector;
use std::io::Write;
use std::path::Path;

/// Writes a triangle mesh as OBJ text (`v x y z` lines, then `f a b c` with 1-based indices).
/// Floats are printed with Rust's shortest round-trip representation, so reading the file
/// back gives bitwise the same vertices.
///
/// # Errors
/// [`super::ExportError::Io`] naming the file when it cannot be created or written;
/// [`super::ExportError::Format`] with the format library's message.
pub fn write_mesh_obj(path: impl AsRef<Path>, mesh: &TriangleMesh) -> Result<(), ExportError> {
    let path = path.as_ref();
    check_mesh(mesh, path)?;
    let file = std::fs::File::create(path).map_err(|e| ExportError::io(path, e))?;
    let mut w = std::io::BufWriter::new(file);
    let mut write = || -> std::io::Result<()> {
        writeln!(
            w,
            "# rapier-sph mesh: {} vertices, {} triangles",
            mesh.vertices.len(),
            mesh.triangles.len()
        )?;
        for v in &mesh.vertices {
            writeln!(w, "v {:?} {:?} {:?}", v.x, v.y, v.z)?;
        }
        for t in &mesh.triangles {
            writeln!(w, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1)?;
        }
        w.flush()
    };
    write().map_err(|e| ExportError::io(path, e))
}

/// Reads every model of an OBJ file into one triangle mesh (polygons are triangulated by
/// `tobj`). Files beyond [`super::MAX_FILE_BYTES`], and what is not a regular file, are
/// refused before they are read.
///
/// # Errors
/// [`super::ExportError::Io`] naming the file when it cannot be read (missing, too large, not a
/// regular file); [`super::ExportError::Format`] or [`super::ExportError::Inconsistent`] when
/// its contents are not what the writer above writes.
pub fn read_mesh_obj(path: impl AsRef<Path>) -> Result<TriangleMesh, ExportError> {
    let path = path.as_ref();
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ..Default::default()
    };
    let bytes = super::read_bytes(path)?;
    // Materials are not read (the mesh is geometry only).
    let (models, _materials) = tobj::load_obj_buf(&mut &bytes[..], &options, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| ExportError::format(path, "obj", e))?;
    let mut mesh = TriangleMesh::default();
    for m in models {
        let base = mesh.vertices.len() as u32;
        mesh.vertices.extend(
            m.mesh
                .positions
                .chunks_exact(3)
                .map(|c| Vector::new(c[0], c[1], c[2])),
        );
        for t in m.mesh.indices.chunks_exact(3) {
            mesh.triangles.push([t[0] + base, t[1] + base, t[2] + base]);
        }
    }
    check_mesh(&mesh, path)?;
    Ok(mesh)
}
