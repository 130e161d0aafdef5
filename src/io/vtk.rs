//! VTK legacy files (binary, big-endian as the format requires) through `vtkio`.

use super::{ExportError, ParticleData, TriangleMesh, check_mesh, flatten, unflatten};
use std::path::Path;
use vtkio::model::{
    Attribute, Attributes, ByteOrder, DataSet, IOBuffer, Piece, PolyDataPiece, Version,
    VertexNumbers, Vtk,
};

fn export(path: &Path, title: &str, piece: PolyDataPiece) -> Result<(), ExportError> {
    let vtk = Vtk {
        version: Version::new_legacy(4, 2),
        byte_order: ByteOrder::BigEndian,
        title: title.to_string(),
        file_path: None,
        data: DataSet::inline(piece),
    };
    let file = std::fs::File::create(path).map_err(|e| ExportError::io(path, e))?;
    vtk.write_legacy(std::io::BufWriter::new(file))
        .map_err(|e| ExportError::format(path, "vtk", e))
}

fn import(path: &Path) -> Result<PolyDataPiece, ExportError> {
    if path.extension().and_then(|e| e.to_str()) != Some("vtk") {
        return Err(ExportError::format(
            path,
            "vtk",
            "only legacy `.vtk` files are read",
        ));
    }
    let bytes = super::read_bytes(path)?;
    // What `Vtk::import` does with a `.vtk` file, on bytes read within the size limit.
    let vtk = Vtk::parse_legacy_be(&bytes[..]).map_err(|e| ExportError::format(path, "vtk", e))?;
    match vtk.data {
        DataSet::PolyData { mut pieces, .. } if pieces.len() == 1 => match pieces.remove(0) {
            Piece::Inline(p) => Ok(*p),
            _ => Err(ExportError::bad(path, "expected an inline POLYDATA piece")),
        },
        _ => Err(ExportError::bad(path, "expected POLYDATA with one piece")),
    }
}

/// Writes particles as VTK `POLYDATA`: one vertex cell per particle, point data `velocity`
/// (vectors), `density`, `pressure` (f32 scalars), `fluid_id`, `id` (u32 scalars).
///
/// # Errors
/// [`super::ExportError::Io`] naming the file when it cannot be created or written;
/// [`super::ExportError::Inconsistent`] when the data's attributes differ in length
/// ([`super::ParticleData::check`]), [`super::ExportError::Format`] with the format library's
/// message.
pub fn write_particles_vtk(path: impl AsRef<Path>, data: &ParticleData) -> Result<(), ExportError> {
    let path = path.as_ref();
    data.check()?;
    let n = data.len() as u32;
    let mut verts = Vec::with_capacity(2 * n as usize);
    for i in 0..n {
        verts.extend_from_slice(&[1, i]);
    }
    let attributes = Attributes {
        point: vec![
            Attribute::vectors("velocity").with_data(flatten(&data.velocities)),
            Attribute::scalars("density", 1).with_data(data.densities.clone()),
            Attribute::scalars("pressure", 1).with_data(data.pressures.clone()),
            Attribute::scalars("fluid_id", 1).with_data(data.fluid_ids.clone()),
            Attribute::scalars("id", 1).with_data(data.ids.clone()),
        ],
        cell: vec![],
    };
    export(
        path,
        "rapier-sph particles",
        PolyDataPiece {
            points: flatten(&data.positions).into(),
            verts: Some(VertexNumbers::Legacy {
                num_cells: n,
                vertices: verts,
            }),
            data: attributes,
            ..Default::default()
        },
    )
}

fn attribute<T: vtkio::model::Scalar>(
    piece: &PolyDataPiece,
    name: &str,
    per_point: usize,
    path: &Path,
) -> Result<Vec<T>, ExportError> {
    let n = piece.num_points();
    let data = piece
        .data
        .point
        .iter()
        .find_map(|a| match a {
            Attribute::DataArray(d) if d.name == name => Some(d.data.clone()),
            _ => None,
        })
        .ok_or_else(|| ExportError::bad(path, format!("no point attribute `{name}`")))?;
    let v: Vec<T> = data.into_vec().ok_or_else(|| {
        ExportError::bad(
            path,
            format!("point attribute `{name}` has an unexpected type"),
        )
    })?;
    if v.len() != n * per_point {
        return Err(ExportError::bad(
            path,
            format!(
                "point attribute `{name}` has {} values for {n} points",
                v.len()
            ),
        ));
    }
    Ok(v)
}

fn points(piece: &PolyDataPiece, path: &Path) -> Result<Vec<crate::math::Vector>, ExportError> {
    let p: Vec<f32> = match &piece.points {
        IOBuffer::F32(v) => v.clone(),
        other => other
            .cast_into()
            .ok_or_else(|| ExportError::bad(path, "points are not numbers"))?,
    };
    Ok(unflatten(&p))
}

/// Reads particles written by [`write_particles_vtk`].
///
/// Files beyond [`super::MAX_FILE_BYTES`], and what is not a regular file (a device, a pipe),
/// are refused with [`ExportError::Io`] before they are read.
///
/// # Errors
/// [`super::ExportError::Io`] naming the file when it cannot be read (missing, too large, not a
/// regular file); [`super::ExportError::Format`] or [`super::ExportError::Inconsistent`] when
/// its contents are not what the writer above writes.
pub fn read_particles_vtk(path: impl AsRef<Path>) -> Result<ParticleData, ExportError> {
    let path = path.as_ref();
    let piece = import(path)?;
    let d = ParticleData {
        positions: points(&piece, path)?,
        velocities: unflatten(&attribute::<f32>(&piece, "velocity", 3, path)?),
        densities: attribute(&piece, "density", 1, path)?,
        pressures: attribute(&piece, "pressure", 1, path)?,
        fluid_ids: attribute(&piece, "fluid_id", 1, path)?,
        ids: attribute(&piece, "id", 1, path)?,
    };
    d.check()?;
    Ok(d)
}

/// Writes a triangle mesh as VTK `POLYDATA` polygons.
///
/// # Errors
/// [`super::ExportError::Io`] naming the file when it cannot be created or written;
/// [`super::ExportError::Format`] with the format library's message.
pub fn write_mesh_vtk(path: impl AsRef<Path>, mesh: &TriangleMesh) -> Result<(), ExportError> {
    let path = path.as_ref();
    check_mesh(mesh, path)?;
    let mut polys = Vec::with_capacity(4 * mesh.triangles.len());
    for t in &mesh.triangles {
        polys.extend_from_slice(&[3, t[0], t[1], t[2]]);
    }
    export(
        path,
        "rapier-sph mesh",
        PolyDataPiece {
            points: flatten(&mesh.vertices).into(),
            polys: Some(VertexNumbers::Legacy {
                num_cells: mesh.triangles.len() as u32,
                vertices: polys,
            }),
            ..Default::default()
        },
    )
}

/// Reads a triangle mesh from VTK `POLYDATA` polygons (every polygon must be a triangle).
///
/// Files beyond [`super::MAX_FILE_BYTES`], and what is not a regular file (a device, a pipe),
/// are refused with [`ExportError::Io`] before they are read.
///
/// # Errors
/// [`super::ExportError::Io`] naming the file when it cannot be read (missing, too large, not a
/// regular file); [`super::ExportError::Format`] or [`super::ExportError::Inconsistent`] when
/// its contents are not what the writer above writes.
pub fn read_mesh_vtk(path: impl AsRef<Path>) -> Result<TriangleMesh, ExportError> {
    let path = path.as_ref();
    let piece = import(path)?;
    let vertices = points(&piece, path)?;
    let mut triangles = Vec::new();
    if let Some(polys) = piece.polys {
        let (num_cells, v) = polys.into_legacy();
        let mut k = 0;
        for _ in 0..num_cells {
            if v.get(k) != Some(&3) || k + 4 > v.len() {
                return Err(ExportError::bad(path, "a polygon is not a triangle"));
            }
            triangles.push([v[k + 1], v[k + 2], v[k + 3]]);
            k += 4;
        }
    }
    let mesh = TriangleMesh::from_parts(vertices, triangles);
    check_mesh(&mesh, path)?;
    Ok(mesh)
}
