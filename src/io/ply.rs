//! Stanford PLY (binary little-endian) through `ply-rs-bw` (the maintained fork of `ply-rs`; the original 0.1.3 writes wrong list lengths in binary files).

use super::{ExportError, ParticleData, TriangleMesh, check_mesh};
use crate::math::Vector;
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{
    Addable, DefaultElement, ElementDef, Encoding, Ply, Property, PropertyDef, PropertyType,
    ScalarType,
};
use ply_rs_bw::writer::Writer;
use std::path::Path;

const PARTICLE_FLOATS: [&str; 8] = ["x", "y", "z", "vx", "vy", "vz", "density", "pressure"];
const PARTICLE_UINTS: [&str; 2] = ["fluid_id", "id"];

fn write(path: &Path, mut ply: Ply<DefaultElement>) -> Result<(), ExportError> {
    let file = std::fs::File::create(path).map_err(|e| ExportError::io(path, e))?;
    let mut w = std::io::BufWriter::new(file);
    Writer::new()
        .write_ply(&mut w, &mut ply)
        .map_err(|e| ExportError::format(path, "ply", e))?;
    std::io::Write::flush(&mut w).map_err(|e| ExportError::io(path, e))
}

fn read(path: &Path) -> Result<Ply<DefaultElement>, ExportError> {
    let bytes = super::read_bytes(path)?;
    let mut r = &bytes[..];
    Parser::<DefaultElement>::new()
        .read_ply(&mut r)
        .map_err(|e| ExportError::format(path, "ply", e))
}

fn new_ply(comment: &str) -> Ply<DefaultElement> {
    let mut ply = Ply::<DefaultElement>::new();
    ply.header.encoding = Encoding::BinaryLittleEndian;
    ply.header.comments.push(comment.to_string());
    ply
}

fn float(e: &DefaultElement, key: &str, path: &Path) -> Result<f32, ExportError> {
    match e.get(key) {
        Some(Property::Float(v)) => Ok(*v),
        Some(Property::Double(v)) => Ok(*v as f32),
        _ => Err(ExportError::bad(
            path,
            format!("vertex property `{key}` missing or not a float"),
        )),
    }
}

fn uint(e: &DefaultElement, key: &str, path: &Path) -> Result<u32, ExportError> {
    match e.get(key) {
        Some(Property::UInt(v)) => Ok(*v),
        Some(Property::Int(v)) if *v >= 0 => Ok(*v as u32),
        _ => Err(ExportError::bad(
            path,
            format!("vertex property `{key}` missing or not an unsigned int"),
        )),
    }
}

/// Writes particles as PLY vertices with properties `x y z vx vy vz density pressure`
/// (float) and `fluid_id id` (uint).
///
/// # Errors
/// [`super::ExportError::Io`] naming the file when it cannot be created or written;
/// [`super::ExportError::Inconsistent`] when the data's attributes differ in length
/// ([`super::ParticleData::check`]), [`super::ExportError::Format`] with the format library's
/// message.
pub fn write_particles_ply(path: impl AsRef<Path>, data: &ParticleData) -> Result<(), ExportError> {
    let path = path.as_ref();
    data.check()?;
    let mut ply = new_ply("rapier-sph particles");
    let mut vertex = ElementDef::new("vertex".to_string());
    for name in PARTICLE_FLOATS {
        vertex.properties.add(PropertyDef::new(
            name.to_string(),
            PropertyType::Scalar(ScalarType::Float),
        ));
    }
    for name in PARTICLE_UINTS {
        vertex.properties.add(PropertyDef::new(
            name.to_string(),
            PropertyType::Scalar(ScalarType::UInt),
        ));
    }
    ply.header.elements.add(vertex);
    let mut elements = Vec::with_capacity(data.len());
    for i in 0..data.len() {
        let (p, v) = (data.positions[i], data.velocities[i]);
        let floats = [
            p.x,
            p.y,
            p.z,
            v.x,
            v.y,
            v.z,
            data.densities[i],
            data.pressures[i],
        ];
        let mut e = DefaultElement::new();
        for (name, value) in PARTICLE_FLOATS.iter().zip(floats) {
            e.insert(name.to_string(), Property::Float(value));
        }
        e.insert("fluid_id".to_string(), Property::UInt(data.fluid_ids[i]));
        e.insert("id".to_string(), Property::UInt(data.ids[i]));
        elements.push(e);
    }
    ply.payload.insert("vertex".to_string(), elements);
    write(path, ply)
}

/// Reads particles written by [`write_particles_ply`].
///
/// Files beyond [`super::MAX_FILE_BYTES`], and what is not a regular file (a device, a pipe),
/// are refused with [`ExportError::Io`] before they are read.
///
/// # Errors
/// [`super::ExportError::Io`] naming the file when it cannot be read (missing, too large, not a
/// regular file); [`super::ExportError::Format`] or [`super::ExportError::Inconsistent`] when
/// its contents are not what the writer above writes.
pub fn read_particles_ply(path: impl AsRef<Path>) -> Result<ParticleData, ExportError> {
    let path = path.as_ref();
    let ply = read(path)?;
    let vertices = ply
        .payload
        .get("vertex")
        .ok_or_else(|| ExportError::bad(path, "no `vertex` element"))?;
    let mut d = ParticleData::default();
    for e in vertices {
        let f = |k| float(e, k, path);
        d.positions.push(Vector::new(f("x")?, f("y")?, f("z")?));
        d.velocities.push(Vector::new(f("vx")?, f("vy")?, f("vz")?));
        d.densities.push(f("density")?);
        d.pressures.push(f("pressure")?);
        d.fluid_ids.push(uint(e, "fluid_id", path)?);
        d.ids.push(uint(e, "id", path)?);
    }
    Ok(d)
}

/// Writes a triangle mesh as PLY (`vertex` with `x y z`, `face` with `vertex_indices`).
///
/// # Errors
/// [`super::ExportError::Io`] naming the file when it cannot be created or written;
/// [`super::ExportError::Format`] with the format library's message.
pub fn write_mesh_ply(path: impl AsRef<Path>, mesh: &TriangleMesh) -> Result<(), ExportError> {
    let path = path.as_ref();
    check_mesh(mesh, path)?;
    let mut ply = new_ply("rapier-sph mesh");
    let mut vertex = ElementDef::new("vertex".to_string());
    for name in ["x", "y", "z"] {
        vertex.properties.add(PropertyDef::new(
            name.to_string(),
            PropertyType::Scalar(ScalarType::Float),
        ));
    }
    ply.header.elements.add(vertex);
    let mut face = ElementDef::new("face".to_string());
    face.properties.add(PropertyDef::new(
        "vertex_indices".to_string(),
        PropertyType::List(ScalarType::UChar, ScalarType::UInt),
    ));
    ply.header.elements.add(face);
    let vertices = mesh
        .vertices
        .iter()
        .map(|v| {
            let mut e = DefaultElement::new();
            e.insert("x".to_string(), Property::Float(v.x));
            e.insert("y".to_string(), Property::Float(v.y));
            e.insert("z".to_string(), Property::Float(v.z));
            e
        })
        .collect();
    let faces = mesh
        .triangles
        .iter()
        .map(|t| {
            let mut e = DefaultElement::new();
            e.insert("vertex_indices".to_string(), Property::ListUInt(t.to_vec()));
            e
        })
        .collect();
    ply.payload.insert("vertex".to_string(), vertices);
    ply.payload.insert("face".to_string(), faces);
    write(path, ply)
}

/// Reads a triangle mesh from PLY (faces must be triangles).
///
/// Files beyond [`super::MAX_FILE_BYTES`], and what is not a regular file (a device, a pipe),
/// are refused with [`ExportError::Io`] before they are read.
///
/// # Errors
/// [`super::ExportError::Io`] naming the file when it cannot be read (missing, too large, not a
/// regular file); [`super::ExportError::Format`] or [`super::ExportError::Inconsistent`] when
/// its contents are not what the writer above writes.
pub fn read_mesh_ply(path: impl AsRef<Path>) -> Result<TriangleMesh, ExportError> {
    let path = path.as_ref();
    let ply = read(path)?;
    let mut mesh = TriangleMesh::default();
    for e in ply
        .payload
        .get("vertex")
        .map(|v| v.as_slice())
        .unwrap_or(&[])
    {
        let f = |k| float(e, k, path);
        mesh.vertices.push(Vector::new(f("x")?, f("y")?, f("z")?));
    }
    for e in ply.payload.get("face").map(|v| v.as_slice()).unwrap_or(&[]) {
        let idx: Vec<u32> = match e.get("vertex_indices").or_else(|| e.get("vertex_index")) {
            Some(Property::ListUInt(v)) => v.clone(),
            Some(Property::ListInt(v)) => v.iter().map(|&i| i as u32).collect(),
            _ => return Err(ExportError::bad(path, "face without `vertex_indices`")),
        };
        if idx.len() != 3 {
            return Err(ExportError::bad(path, "a face is not a triangle"));
        }
        mesh.triangles.push([idx[0], idx[1], idx[2]]);
    }
    check_mesh(&mesh, path)?;
    Ok(mesh)
}
