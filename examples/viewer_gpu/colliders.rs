//! The rapier colliders as solid kiss3d meshes coloured by kind (the CPU renderer's palette:
//! fixed walls stone grey, fixed balls/capsules/cylinders red, fixed triangle meshes green,
//! heightfields sand, compounds violet, kinematic bodies yellow, dynamic bodies orange).
//! A fixed wall (cuboid) has one node per triangle, so that the faces whose plane separates
//! the camera from the fluid (a tank's front wall and lid) can be hidden each frame and
//! outlined instead, as the CPU renderer draws them see-through.

use kiss3d::prelude::*;
use rapier_sph::FluidWorld;
use rapier_sph::mesh::{TessellationOptions, TriangleMesh};
use rapier3d::dynamics::RigidBodyType;
use rapier3d::geometry::{ColliderHandle, ShapeType};

/// One vertex per triangle corner, so kiss3d's computed normals give flat faces.
fn unwelded(triangles: &[[Vec3; 3]]) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let v: Vec<Vec3> = triangles.iter().flatten().copied().collect();
    let t = (0..triangles.len() as u32)
        .map(|k| [3 * k, 3 * k + 1, 3 * k + 2])
        .collect();
    (v, t)
}

struct Drawn {
    handle: ColliderHandle,
    /// Triangles in the collider's frame.
    triangles: Vec<[Vec3; 3]>,
    /// A fixed wall: one node per triangle (in world space); otherwise one node.
    wall: bool,
    nodes: Vec<SceneNode3d>,
    edges: Vec<(Vec3, Vec3)>,
}

/// The colliders' scene nodes.
pub struct Colliders {
    drawn: Vec<Drawn>,
}

fn add_node(root: &mut SceneNode3d, tris: &[[Vec3; 3]], rgb: [f32; 3]) -> SceneNode3d {
    let (v, t) = unwelded(tris);
    let mesh = Rc::new(RefCell::new(GpuMesh3d::new(v, t, None, None, false)));
    root.add_mesh(mesh, Vec3::ONE)
        .set_color(Color::new(rgb[0], rgb[1], rgb[2], 1.0))
        .enable_backface_culling(false)
}

impl Colliders {
    /// Scene nodes for every collider but sensors.
    pub fn new(world: &FluidWorld, root: &mut SceneNode3d) -> Self {
        let physics = &world.physics;
        let mut drawn = Vec::new();
        for (handle, c) in physics.colliders.iter() {
            if c.is_sensor() {
                continue;
            }
            let Some(m) = TriangleMesh::from_shape(c.shape(), &TessellationOptions::default())
            else {
                continue;
            };
            if m.is_empty() {
                continue;
            }
            let body = c
                .parent()
                .and_then(|b| physics.bodies.get(b))
                .map(|b| b.body_type());
            let moving = body.is_some_and(|b| b != RigidBodyType::Fixed);
            let shape = c.shape().shape_type();
            let wall = !moving && matches!(shape, ShapeType::Cuboid | ShapeType::RoundCuboid);
            let rgb = rapier_sph::render::palette(shape, body);
            let triangles: Vec<[Vec3; 3]> = m
                .triangles
                .iter()
                .map(|t| t.map(|i| m.vertices[i as usize]))
                .collect();
            let pose = *c.position();
            let nodes = if wall {
                let world_tris: Vec<[Vec3; 3]> = triangles
                    .iter()
                    .map(|t| t.map(|p| pose.transform_point(p)))
                    .collect();
                world_tris
                    .iter()
                    .map(|t| add_node(root, &[*t], rgb))
                    .collect()
            } else {
                vec![add_node(root, &triangles, rgb)]
            };
            let edges = m.feature_edges(0.5);
            drawn.push(Drawn {
                handle,
                triangles,
                wall,
                nodes,
                edges,
            });
        }
        Self { drawn }
    }

    /// Poses the nodes, hides the wall faces between `eye` and `fluid_center`, draws their
    /// walls' outlines, and returns the triangles (world space) that hide the water.
    pub fn update(
        &mut self,
        world: &FluidWorld,
        window: &mut Window,
        (eye, fluid_center): (Vec3, Vec3),
    ) -> Vec<[f32; 3]> {
        let mut occluders = Vec::new();
        for d in &mut self.drawn {
            let Some(c) = world.physics.colliders.get(d.handle) else {
                continue;
            };
            let pose = *c.position();
            if !d.wall {
                d.nodes[0].set_pose(pose);
                for t in &d.triangles {
                    occluders.extend(t.map(|p| pose.transform_point(p).to_array()));
                }
                continue;
            }
            let mut any_hidden = false;
            for (t, node) in d.triangles.iter().zip(&mut d.nodes) {
                let p = t.map(|p| pose.transform_point(p));
                let n = (p[1] - p[0]).cross(p[2] - p[0]);
                let between = (n.dot(eye - p[0]) > 0.0) != (n.dot(fluid_center - p[0]) > 0.0);
                node.set_visible(!between);
                any_hidden |= between;
                if !between {
                    occluders.extend(p.map(|q| q.to_array()));
                }
            }
            if any_hidden {
                let ink = Color::new(0.35, 0.35, 0.38, 1.0);
                for (a, b) in &d.edges {
                    window.draw_line(
                        pose.transform_point(*a),
                        pose.transform_point(*b),
                        ink,
                        2.0,
                        false,
                    );
                }
            }
        }
        occluders
    }
}
