//! Triangle meshes: of rapier colliders (every parry shape, through parry's own
//! `to_trimesh`), of reconstructed liquid surfaces, and of files. Shared by the `render`,
//! `io`, `scene` and `surface` features; compiled only when one of them is on.

#![cfg_attr(docsrs, doc(cfg(any(feature = "io", feature = "render"))))]

use crate::math::{Pose, Real, Vector};
use parry3d::shape::{Shape, TypedShape};
use rapier3d::geometry::{ColliderHandle, ColliderSet};

/// An indexed triangle mesh (counter-clockwise triangles seen from outside, for closed
/// meshes).
///
/// # Examples
///
/// ```
/// use rapier_sph::math::Vector;
/// use rapier_sph::mesh::{TessellationOptions, TriangleMesh};
/// use rapier_sph::rapier3d::prelude::{ColliderBuilder, ColliderSet};
///
/// // The meshes of a scene's colliders, in world space (e.g. to draw or export them).
/// let mut colliders = ColliderSet::new();
/// colliders.insert(ColliderBuilder::cuboid(0.5, 0.25, 0.1).translation(Vector::Y));
/// let meshes = TriangleMesh::from_colliders(&colliders, &TessellationOptions::default());
/// let (_, box_mesh) = &meshes[0];
/// assert!(box_mesh.is_closed());
/// assert!((box_mesh.signed_volume() - 0.1).abs() < 1e-6); // 1 m × 0.5 m × 0.2 m
/// // Or one built by hand: an open triangle of 0.5 m².
/// let corners = vec![Vector::ZERO, Vector::X, Vector::Y];
/// let triangle = TriangleMesh::from_parts(corners, vec![[0, 1, 2]]);
/// assert_eq!(triangle.area(), 0.5);
/// assert!(!triangle.is_closed());
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleMesh {
    /// Vertex positions (m).
    pub vertices: Vec<Vector>,
    /// Triangles as three indices into `vertices`.
    pub triangles: Vec<[u32; 3]>,
}

/// How finely curved shapes are tessellated, and how far infinite ones are drawn.
///
/// # Examples
///
/// ```
/// use rapier_sph::mesh::{TessellationOptions, TriangleMesh};
/// use rapier_sph::rapier3d::parry::shape::Ball;
///
/// let ball = Ball::new(0.5);
/// let coarse = TessellationOptions { subdivisions: 8, ..Default::default() };
/// let coarse = TriangleMesh::from_shape(&ball, &coarse).expect("a ball has an area");
/// let fine = TriangleMesh::from_shape(&ball, &TessellationOptions::default()).unwrap();
/// assert!(coarse.triangles.len() < fine.triangles.len());
/// // The finer mesh encloses more of the ball's 4/3·π·0.5³ m³.
/// let exact = 4.0 / 3.0 * std::f64::consts::PI * 0.125;
/// assert!(coarse.signed_volume() < fine.signed_volume() && fine.signed_volume() < exact);
/// ```
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct TessellationOptions {
    /// Subdivisions around balls, capsules, cylinders and cones. Default 24.
    pub subdivisions: u32,
    /// Half extent (m) of the square drawn for a half-space (an infinite plane). Default 10.
    pub half_space_extent: Real,
}

impl Default for TessellationOptions {
    fn default() -> Self {
        Self {
            subdivisions: 24,
            half_space_extent: 10.0,
        }
    }
}

impl TriangleMesh {
    /// A mesh from parry's `(vertices, indices)` pair.
    pub fn from_parts(vertices: Vec<Vector>, triangles: Vec<[u32; 3]>) -> Self {
        Self {
            vertices,
            triangles,
        }
    }

    /// `true` when the mesh has no triangle.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// Appends `other`, transformed by `pose`.
    pub fn append_transformed(&mut self, other: &TriangleMesh, pose: &Pose) {
        let base = self.vertices.len() as u32;
        self.vertices
            .extend(other.vertices.iter().map(|v| pose.transform_point(*v)));
        self.triangles.extend(
            other
                .triangles
                .iter()
                .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
        );
    }

    /// Transforms every vertex by `pose`.
    pub fn transform(&mut self, pose: &Pose) {
        for v in &mut self.vertices {
            *v = pose.transform_point(*v);
        }
    }

    /// Signed enclosed volume (m³) by the divergence theorem, summed in f64: positive for a
    /// closed mesh with outward (counter-clockwise) triangles. Meaningless for open meshes.
    pub fn signed_volume(&self) -> f64 {
        let mut v = 0.0f64;
        for t in &self.triangles {
            let a = self.vertices[t[0] as usize].as_dvec3();
            let b = self.vertices[t[1] as usize].as_dvec3();
            let c = self.vertices[t[2] as usize].as_dvec3();
            v += a.dot(b.cross(c));
        }
        v / 6.0
    }

    /// Total surface area (m²).
    pub fn area(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let a = self.vertices[t[0] as usize].as_dvec3();
                let b = self.vertices[t[1] as usize].as_dvec3();
                let c = self.vertices[t[2] as usize].as_dvec3();
                0.5 * (b - a).cross(c - a).length()
            })
            .sum()
    }

    /// Number of undirected edges not shared by exactly two triangles (0 for a closed,
    /// watertight, manifold mesh). Edges are keyed by vertex index, so duplicated vertices
    /// at the same position count as distinct.
    pub fn non_manifold_edges(&self) -> usize {
        let mut edges: Vec<(u32, u32)> = Vec::with_capacity(self.triangles.len() * 3);
        for t in &self.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                edges.push((a.min(b), a.max(b)));
            }
        }
        edges.sort_unstable();
        let mut bad = 0;
        let mut i = 0;
        while i < edges.len() {
            let mut j = i + 1;
            while j < edges.len() && edges[j] == edges[i] {
                j += 1;
            }
            if j - i != 2 {
                bad += 1;
            }
            i = j;
        }
        bad
    }

    /// `true` when every edge is shared by exactly two triangles.
    pub fn is_closed(&self) -> bool {
        !self.triangles.is_empty() && self.non_manifold_edges() == 0
    }

    /// The mesh of one parry shape in its own frame, or `None` for shapes with no area
    /// (segments, polylines) and custom shapes. Rounded shapes are drawn as their inner shape
    /// pushed out by the border radius along the vertex normals (an approximation).
    pub fn from_shape(shape: &dyn Shape, options: &TessellationOptions) -> Option<Self> {
        let n = options.subdivisions.max(3);
        let m = |(v, t): (Vec<Vector>, Vec<[u32; 3]>)| Some(TriangleMesh::from_parts(v, t));
        match shape.as_typed_shape() {
            TypedShape::Ball(s) => m(s.to_trimesh(n, n / 2)),
            TypedShape::Cuboid(s) => m(s.to_trimesh()),
            TypedShape::Capsule(s) => m(s.to_trimesh(n, n / 2)),
            TypedShape::Cylinder(s) => m(s.to_trimesh(n)),
            TypedShape::Cone(s) => m(s.to_trimesh(n)),
            TypedShape::ConvexPolyhedron(s) => m(s.to_trimesh()),
            TypedShape::HeightField(s) => m(s.to_trimesh()),
            TypedShape::Voxels(s) => m(s.to_trimesh()),
            TypedShape::TriMesh(s) => m((s.vertices().to_vec(), s.indices().to_vec())),
            TypedShape::Triangle(s) => m((vec![s.a, s.b, s.c], vec![[0, 1, 2]])),
            TypedShape::HalfSpace(s) => {
                let nrm = s.normal;
                let (u, v) = nrm.any_orthonormal_pair();
                let e = options.half_space_extent;
                m((
                    vec![(-u - v) * e, (u - v) * e, (u + v) * e, (v - u) * e],
                    vec![[0, 1, 2], [0, 2, 3]],
                ))
            }
            TypedShape::Compound(c) => {
                let mut out = TriangleMesh::default();
                for (pose, sub) in c.shapes() {
                    if let Some(sm) = Self::from_shape(sub.as_ref(), options) {
                        out.append_transformed(&sm, pose);
                    }
                }
                Some(out)
            }
            TypedShape::RoundCuboid(s) => rounded(m(s.inner_shape.to_trimesh()), s.border_radius),
            TypedShape::RoundCylinder(s) => {
                rounded(m(s.inner_shape.to_trimesh(n)), s.border_radius)
            }
            TypedShape::RoundCone(s) => rounded(m(s.inner_shape.to_trimesh(n)), s.border_radius),
            TypedShape::RoundConvexPolyhedron(s) => {
                rounded(m(s.inner_shape.to_trimesh()), s.border_radius)
            }
            TypedShape::RoundTriangle(s) => {
                let t = &s.inner_shape;
                m((vec![t.a, t.b, t.c], vec![[0, 1, 2]]))
            }
            TypedShape::Segment(_) | TypedShape::Polyline(_) | TypedShape::Custom(_) => None,
        }
    }

    /// Meshes of every non-sensor collider of `colliders`, in world space, with their
    /// handles. Shapes with no area are left out.
    pub fn from_colliders(
        colliders: &ColliderSet,
        options: &TessellationOptions,
    ) -> Vec<(ColliderHandle, TriangleMesh)> {
        let mut out = Vec::new();
        for (handle, c) in colliders.iter() {
            if c.is_sensor() {
                continue;
            }
            if let Some(mut mesh) = Self::from_shape(c.shape(), options) {
                mesh.transform(c.position());
                out.push((handle, mesh));
            }
        }
        out
    }

    /// The mesh's feature edges: edges of one triangle only (borders) and edges whose two
    /// triangles' normals differ by more than `min_cos` in cosine (creases). Vertices are
    /// matched by position, so meshes with duplicated corners (parry's cuboids) work too.
    pub fn feature_edges(&self, min_cos: Real) -> Vec<(Vector, Vector)> {
        let key = |v: Vector| (v.x.to_bits(), v.y.to_bits(), v.z.to_bits());
        let mut map: std::collections::HashMap<_, (Vector, Vector, Vec<Vector>)> =
            std::collections::HashMap::new();
        for t in &self.triangles {
            let p = t.map(|i| self.vertices[i as usize]);
            let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
            for k in 0..3 {
                let (a, b) = (p[k], p[(k + 1) % 3]);
                let (ka, kb) = (key(a), key(b));
                let (lo, hi, va, vb) = if ka <= kb {
                    (ka, kb, a, b)
                } else {
                    (kb, ka, b, a)
                };
                map.entry((lo, hi))
                    .or_insert_with(|| (va, vb, Vec::new()))
                    .2
                    .push(n);
            }
        }
        let mut out: Vec<(Vector, Vector)> = map
            .into_values()
            .filter(|(_, _, normals)| {
                normals.len() == 1 || normals.iter().any(|n| n.dot(normals[0]).abs() < min_cos)
            })
            .map(|(a, b, _)| (a, b))
            .collect();
        // A fixed order (the map's is random): the same picture on every run.
        out.sort_by(|x, y| {
            let k = |v: &(Vector, Vector)| [v.0.x, v.0.y, v.0.z, v.1.x, v.1.y, v.1.z];
            k(x).partial_cmp(&k(y)).unwrap_or(std::cmp::Ordering::Equal)
        });
        out
    }

    /// Area-weighted vertex normals (unit length; zero for isolated vertices).
    pub fn vertex_normals(&self) -> Vec<Vector> {
        let mut n = vec![Vector::ZERO; self.vertices.len()];
        for t in &self.triangles {
            let a = self.vertices[t[0] as usize];
            let b = self.vertices[t[1] as usize];
            let c = self.vertices[t[2] as usize];
            let f = (b - a).cross(c - a);
            for &i in t {
                n[i as usize] += f;
            }
        }
        for v in &mut n {
            *v = v.normalize_or_zero();
        }
        n
    }
}

fn rounded(mesh: Option<TriangleMesh>, radius: Real) -> Option<TriangleMesh> {
    let mut mesh = mesh?;
    // parry's polyhedral meshes duplicate vertices per face; weld by position first so the
    // normals average over the faces that meet at a corner.
    let normals = {
        let mut welded = mesh.clone();
        let mut map: Vec<u32> = (0..mesh.vertices.len() as u32).collect();
        for i in 0..mesh.vertices.len() {
            for j in 0..i {
                if (mesh.vertices[i] - mesh.vertices[j]).length_squared() < 1e-12 {
                    map[i] = map[j];
                    break;
                }
            }
        }
        for t in &mut welded.triangles {
            for i in t.iter_mut() {
                *i = map[*i as usize];
            }
        }
        let n = welded.vertex_normals();
        map.iter().map(|&k| n[k as usize]).collect::<Vec<_>>()
    };
    for (v, n) in mesh.vertices.iter_mut().zip(normals) {
        *v += n * radius;
    }
    Some(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;
    use parry3d::shape::{Ball, Cuboid};

    #[test]
    fn cuboid_mesh_is_closed_with_its_volume() {
        let m = TriangleMesh::from_shape(
            &Cuboid::new(Vector::new(1.0, 2.0, 3.0)),
            &TessellationOptions::default(),
        )
        .unwrap();
        assert!(m.is_closed());
        assert!((m.signed_volume() - 48.0).abs() < 1e-4);
    }

    #[test]
    fn ball_mesh_is_closed_and_close_to_the_ball_volume() {
        let m = TriangleMesh::from_shape(&Ball::new(1.0), &TessellationOptions::default()).unwrap();
        assert!(m.is_closed());
        let exact = 4.0 / 3.0 * std::f64::consts::PI;
        // An inscribed polyhedron with 24 × 12 subdivisions loses a few per cent.
        assert!(m.signed_volume() < exact && m.signed_volume() > 0.95 * exact);
    }
}
