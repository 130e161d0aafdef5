//! Every parry shape, as written in a scene file.

use super::values::{Positive, PositiveVec3, Vec3};
use crate::math::{Pose, Real, Rotation, Vector};
use parry3d::shape::SharedShape;
use parry3d::utils::Array2;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A collider shape. Every parry 3D shape has a variant; curved ones are exact (parry's own
/// shapes), not meshes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum ShapeDesc {
    /// A sphere.
    Ball {
        /// Radius (m).
        radius: Positive,
    },
    /// A box.
    Cuboid {
        /// Half extents (m).
        half_extents: PositiveVec3,
    },
    /// A box with rounded edges.
    RoundCuboid {
        /// Half extents of the inner box (m).
        half_extents: PositiveVec3,
        /// Rounding radius (m).
        border_radius: Positive,
    },
    /// A capsule between two points.
    Capsule {
        /// First end (m).
        a: Vec3,
        /// Second end (m).
        b: Vec3,
        /// Radius (m).
        radius: Positive,
    },
    /// A cylinder along y.
    Cylinder {
        /// Half height (m).
        half_height: Positive,
        /// Radius (m).
        radius: Positive,
    },
    /// A cylinder along y with rounded edges.
    RoundCylinder {
        /// Half height (m).
        half_height: Positive,
        /// Radius (m).
        radius: Positive,
        /// Rounding radius (m).
        border_radius: Positive,
    },
    /// A cone along y (apex up).
    Cone {
        /// Half height (m).
        half_height: Positive,
        /// Base radius (m).
        radius: Positive,
    },
    /// A cone with rounded edges.
    RoundCone {
        /// Half height (m).
        half_height: Positive,
        /// Base radius (m).
        radius: Positive,
        /// Rounding radius (m).
        border_radius: Positive,
    },
    /// A segment (no volume; particles bounce off it).
    Segment {
        /// First end (m).
        a: Vec3,
        /// Second end (m).
        b: Vec3,
    },
    /// A triangle.
    Triangle {
        /// Corner (m).
        a: Vec3,
        /// Corner (m).
        b: Vec3,
        /// Corner (m).
        c: Vec3,
    },
    /// A triangle with rounded border (a thick triangle).
    RoundTriangle {
        /// Corner (m).
        a: Vec3,
        /// Corner (m).
        b: Vec3,
        /// Corner (m).
        c: Vec3,
        /// Rounding radius (m).
        border_radius: Positive,
    },
    /// A polyline: `indices` are pairs of vertex indices; without them the vertices are
    /// joined in order.
    Polyline {
        /// Vertices (m).
        vertices: Vec<Vec3>,
        /// Segments as vertex index pairs.
        #[serde(default)]
        indices: Option<Vec<(u32, u32)>>,
    },
    /// A triangle mesh given inline. It is built without parry's `TriMeshFlags::ORIENTED`: a
    /// surface, not a solid, so a closed mesh holds fluid inside it (a tank) as well as
    /// keeping it out (see [`crate::query::check_container`] for meshes built in code).
    TriMesh {
        /// Vertices (m).
        vertices: Vec<Vec3>,
        /// Triangles as vertex index triples.
        indices: Vec<(u32, u32, u32)>,
    },
    /// A triangle mesh read from a Wavefront OBJ file (path relative to the scene file), at
    /// most [`super::MAX_FILE_BYTES`] long and a regular file (not a device or a pipe). Built
    /// as [`ShapeDesc::TriMesh`] is (a surface).
    TriMeshFile {
        /// The OBJ file.
        path: String,
        /// Scale applied to the vertices. Default `(1, 1, 1)`.
        #[serde(default)]
        scale: Option<PositiveVec3>,
    },
    /// The convex hull of points.
    ConvexHull {
        /// Points (m).
        points: Vec<Vec3>,
    },
    /// The convex hull of points, rounded.
    RoundConvexHull {
        /// Points (m).
        points: Vec<Vec3>,
        /// Rounding radius (m).
        border_radius: Positive,
    },
    /// A height field: `heights[i][j]` is the height of row `i` (along z) and column `j`
    /// (along x) of a grid spanning `scale.x × scale.z`, heights multiplied by `scale.y`.
    HeightField {
        /// Rows of heights, all of the same length (at least 2 × 2).
        heights: Vec<Vec<Real>>,
        /// Size of the field along x and z, and the height scale.
        scale: PositiveVec3,
    },
    /// An infinite plane through the collider's origin; solid on the side opposite the normal.
    HalfSpace {
        /// Outward normal (normalised here).
        normal: Vec3,
    },
    /// Voxels: a cube of `voxel_size` at each point's grid cell.
    Voxels {
        /// Size of a voxel (m).
        voxel_size: PositiveVec3,
        /// Points inside the voxels to fill (m).
        points: Vec<Vec3>,
    },
    /// Several shapes as one collider.
    Compound {
        /// The parts.
        parts: Vec<CompoundPart>,
    },
}

/// One part of a [`ShapeDesc::Compound`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Part")]
pub struct CompoundPart {
    /// The part's shape (not itself a compound).
    #[serde(deserialize_with = "super::values::checked")]
    pub shape: ShapeDesc,
    /// Position within the compound (m).
    #[serde(default)]
    pub position: Vec3,
    /// Rotation within the compound (rotation vector, rad).
    #[serde(default)]
    pub rotation: Vec3,
}

fn points(v: &[Vec3]) -> Vec<Vector> {
    v.iter().map(|p| p.vector()).collect()
}

fn check_indices<const N: usize>(idx: &[[u32; N]], n: usize) -> Result<(), String> {
    match idx.iter().find(|t| t.iter().any(|&i| i as usize >= n)) {
        Some(t) => Err(format!("index {t:?} is past the {n} vertices")),
        None => Ok(()),
    }
}

impl super::values::Validate for ShapeDesc {
    /// Everything [`ShapeDesc::build`] checks that needs no file: the shape is built (an
    /// inline mesh, a hull, a height field), so a bad one is reported at its own line.
    fn validate(&self) -> Result<(), String> {
        match self {
            ShapeDesc::TriMeshFile { path, .. } => {
                if path.is_empty() {
                    return Err("the mesh file's path is empty".into());
                }
                Ok(())
            }
            // Each part was checked as it was read.
            ShapeDesc::Compound { parts } => {
                if parts.is_empty() {
                    return Err("a compound needs at least one part".into());
                }
                match parts
                    .iter()
                    .position(|p| matches!(p.shape, ShapeDesc::Compound { .. }))
                {
                    Some(k) => Err(format!("part {k}: a compound cannot hold a compound")),
                    None => Ok(()),
                }
            }
            // No file is read for these.
            _ => self.build(Path::new("")).map(|_| ()),
        }
    }
}

impl ShapeDesc {
    /// Builds the parry shape; relative file paths are resolved against `base_dir`.
    ///
    /// # Errors
    /// A message when a mesh file cannot be read or a shape is degenerate (a hull of
    /// collinear points, an index past the vertices).
    pub fn build(&self, base_dir: &Path) -> Result<SharedShape, String> {
        Ok(match self {
            ShapeDesc::Ball { radius } => SharedShape::ball(radius.0),
            ShapeDesc::Cuboid { half_extents: h } => SharedShape::cuboid(h.0[0], h.0[1], h.0[2]),
            ShapeDesc::RoundCuboid {
                half_extents: h,
                border_radius,
            } => SharedShape::round_cuboid(h.0[0], h.0[1], h.0[2], border_radius.0),
            ShapeDesc::Capsule { a, b, radius } => {
                SharedShape::capsule(a.vector(), b.vector(), radius.0)
            }
            ShapeDesc::Cylinder {
                half_height,
                radius,
            } => SharedShape::cylinder(half_height.0, radius.0),
            ShapeDesc::RoundCylinder {
                half_height,
                radius,
                border_radius,
            } => SharedShape::round_cylinder(half_height.0, radius.0, border_radius.0),
            ShapeDesc::Cone {
                half_height,
                radius,
            } => SharedShape::cone(half_height.0, radius.0),
            ShapeDesc::RoundCone {
                half_height,
                radius,
                border_radius,
            } => SharedShape::round_cone(half_height.0, radius.0, border_radius.0),
            ShapeDesc::Segment { a, b } => SharedShape::segment(a.vector(), b.vector()),
            ShapeDesc::Triangle { a, b, c } => {
                SharedShape::triangle(a.vector(), b.vector(), c.vector())
            }
            ShapeDesc::RoundTriangle {
                a,
                b,
                c,
                border_radius,
            } => SharedShape::round_triangle(a.vector(), b.vector(), c.vector(), border_radius.0),
            ShapeDesc::Polyline { vertices, indices } => polyline(vertices, indices.as_deref())?,
            ShapeDesc::TriMesh { vertices, indices } => {
                let idx: Vec<[u32; 3]> = indices.iter().map(|&(a, b, c)| [a, b, c]).collect();
                check_indices(&idx, vertices.len())?;
                SharedShape::trimesh(points(vertices), idx).map_err(|e| format!("{e:?}"))?
            }
            ShapeDesc::TriMeshFile { path, scale } => trimesh_file(&base_dir.join(path), *scale)?,
            ShapeDesc::ConvexHull { points: p } => SharedShape::convex_hull(&points(p))
                .ok_or("the convex hull is degenerate (fewer than 4 points not on a plane)")?,
            ShapeDesc::RoundConvexHull {
                points: p,
                border_radius,
            } => SharedShape::round_convex_hull(&points(p), border_radius.0)
                .ok_or("the convex hull is degenerate (fewer than 4 points not on a plane)")?,
            ShapeDesc::HeightField { heights, scale } => heightfield(heights, scale)?,
            ShapeDesc::HalfSpace { normal } => {
                let n = normal.vector();
                if n.length() < 1e-6 {
                    return Err("the normal is zero".into());
                }
                SharedShape::halfspace(n.normalize())
            }
            ShapeDesc::Voxels {
                voxel_size,
                points: p,
            } => {
                if p.is_empty() {
                    return Err("voxels need at least one point".into());
                }
                SharedShape::voxels_from_points(voxel_size.vector(), &points(p))
            }
            ShapeDesc::Compound { parts } => compound(parts, base_dir)?,
        })
    }
}

/// A polyline through `vertices`, joined in order or by the segments `indices` (checked
/// against the vertex count, so a bad index is an error rather than a panic).
fn polyline(vertices: &[Vec3], indices: Option<&[(u32, u32)]>) -> Result<SharedShape, String> {
    if vertices.len() < 2 {
        return Err("a polyline needs at least 2 vertices".into());
    }
    let idx = indices.map(|v| v.iter().map(|&(a, b)| [a, b]).collect::<Vec<_>>());
    if let Some(idx) = &idx {
        check_indices(idx, vertices.len())?;
    }
    Ok(SharedShape::polyline(points(vertices), idx))
}

/// The triangle mesh of the OBJ file `file`, its vertices scaled by `scale` per axis (none:
/// as read). Errors name the file.
fn trimesh_file(file: &Path, scale: Option<PositiveVec3>) -> Result<SharedShape, String> {
    let (vertices, idx) = read_obj(file)?;
    let s = scale.map(|s| s.vector()).unwrap_or(Vector::ONE);
    let vertices = vertices.into_iter().map(|v| v * s).collect();
    SharedShape::trimesh(vertices, idx).map_err(|e| format!("{}: {e:?}", file.display()))
}

/// A height field from `heights` (rows along z, values along x; at least 2 × 2, rectangular,
/// finite), reordered into parry's column-major grid and scaled by `scale`.
fn heightfield(heights: &[Vec<Real>], scale: &PositiveVec3) -> Result<SharedShape, String> {
    let nrows = heights.len();
    let ncols = heights.first().map_or(0, |r| r.len());
    if nrows < 2 || ncols < 2 || heights.iter().any(|r| r.len() != ncols) {
        return Err(
            "heights must be at least 2 rows of at least 2 values, all rows of the same length"
                .into(),
        );
    }
    if heights.iter().flatten().any(|h| !h.is_finite()) {
        return Err("a height is not a finite number".into());
    }
    // parry's Array2 is column-major with rows along z.
    let mut data = Vec::with_capacity(nrows * ncols);
    for j in 0..ncols {
        for row in heights {
            data.push(row[j]);
        }
    }
    Ok(SharedShape::heightfield(
        Array2::new(nrows, ncols, data),
        scale.vector(),
    ))
}

/// A compound of `parts`, each built (file paths against `base_dir`) and placed at its pose;
/// at least one part and no nested compound (parry panics on nested composite shapes). Errors name the part.
fn compound(parts: &[CompoundPart], base_dir: &Path) -> Result<SharedShape, String> {
    if parts.is_empty() {
        return Err("a compound needs at least one part".into());
    }
    let mut shapes = Vec::with_capacity(parts.len());
    for (k, part) in parts.iter().enumerate() {
        if matches!(part.shape, ShapeDesc::Compound { .. }) {
            return Err(format!("part {k}: a compound cannot hold a compound"));
        }
        let s = part
            .shape
            .build(base_dir)
            .map_err(|e| format!("part {k}: {e}"))?;
        let pose = Pose::from_parts(
            part.position.vector(),
            Rotation::from_scaled_axis(part.rotation.vector()),
        );
        shapes.push((pose, s));
    }
    Ok(SharedShape::compound(shapes))
}

/// Reads the triangles of an OBJ file (all models merged) with `tobj`.
fn read_obj(path: &Path) -> Result<(Vec<Vector>, Vec<[u32; 3]>), String> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ..Default::default()
    };
    let bytes = crate::error::read_regular_file(path, super::MAX_FILE_BYTES)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    // Materials are not read (a collider is geometry only).
    let (models, _) = tobj::load_obj_buf(&mut &bytes[..], &options, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| format!("{}: {e}", path.display()))?;
    let mut vertices = Vec::new();
    let mut idx = Vec::new();
    for m in models {
        let base = vertices.len() as u32;
        vertices.extend(
            m.mesh
                .positions
                .chunks_exact(3)
                .map(|c| Vector::new(c[0], c[1], c[2])),
        );
        for t in m.mesh.indices.chunks_exact(3) {
            idx.push([t[0] + base, t[1] + base, t[2] + base]);
        }
    }
    if idx.is_empty() {
        return Err(format!("{}: no triangle", path.display()));
    }
    check_indices(&idx, vertices.len()).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok((vertices, idx))
}
