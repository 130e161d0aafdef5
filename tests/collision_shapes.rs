//! Particles thrown at every parry shape, at 1, 10 and 50 m/s, with and without gravity:
//! after every step no particle is inside the solid (or across a sheet / under a terrain),
//! no particle is lost, and every particle keeps one contact radius off the surfaces.
//!
//! Fluid: water at 4 cm spacing (contact radius 2 cm, h = 8 cm), stepped at the
//! acoustic time step (≈1.07 ms), so at 50 m/s a particle moves 5.3 cm per step: more than
//! its radius, and much more than the thickness of the thin shapes.

mod common;

use common::*;
use rand::Rng;
use rand_pcg::Pcg64;
use rapier_sph::FluidWorld;
use rapier_sph::rapier3d::prelude::*;

const SPACING: Real = 0.04;
const SPEEDS: [Real; 3] = [1.0, 10.0, 50.0];
/// Simulated time of each throw: long enough for the 1 m/s particles (started ~4 cm off the
/// surface) to hit and then sit on the surface for most of the run.
const DURATION: Real = 0.15;

fn pose(t: [Real; 3], axis_angle: [Real; 3]) -> Pose {
    Pose::new(Vector::from(t), Vector::from(axis_angle))
}

fn random_in(rng: &mut Pcg64, center: Vector, spread: Vector) -> Vector {
    center
        + Vector::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        ) * spread
}

/// `n` shots from random directions at random points of the box `center ± spread`, a cloud
/// with every other one.
fn random_shots(rng: &mut Pcg64, n: usize, center: Vector, spread: Vector) -> Vec<Shot> {
    (0..n)
        .map(|k| Shot {
            dir: random_unit(rng),
            target: random_in(rng, center, spread),
            cloud: k % 2 == 0,
        })
        .collect()
}

/// Runs the six throws of a shape (3 speeds × {no gravity, gravity}) and checks every step
/// (see `common::Tracker::check`). Clearance violations are gathered over all throws and
/// reported together at the end, after the (stronger) no-penetration checks have all passed.
fn throw_at(
    name: &str,
    colliders: impl Fn() -> Vec<ColliderBuilder>,
    regions_of: impl Fn(&FluidWorld, &[ColliderHandle]) -> Vec<Region>,
    shots: impl Fn(&mut Pcg64) -> Vec<Shot>,
    seed: u64,
) {
    let params = water(SPACING);
    let mut clearance_failures = Vec::new();
    let mut total_contacts = 0;
    for (k, &speed) in SPEEDS.iter().enumerate() {
        for (g, gravity) in [Vector::ZERO, Vector::new(0.0, -9.81, 0.0)]
            .into_iter()
            .enumerate()
        {
            let run_seed = seed * 100 + (k * 2 + g) as u64;
            let mut rng = rng(run_seed);
            let throw = Throw {
                label: format!("{name} at {speed} m/s, gravity {gravity}"),
                speed,
                gravity,
                shots: shots(&mut rng),
                duration: DURATION,
                stream_len: 6,
            };
            let tracker = run_throw(&params, colliders(), &regions_of, &throw, run_seed);
            // The throw must actually have hit something, or it tested nothing.
            assert!(
                tracker.contacts > 0,
                "{}: no particle touched the shape",
                throw.label
            );
            total_contacts += tracker.contacts;
            eprintln!(
                "{}: {} steps, {} contacts, {} fallbacks, min clearance {} (radius {})",
                throw.label,
                tracker.steps,
                tracker.contacts,
                tracker.fallbacks,
                tracker.min_clearance,
                params.particle_radius
            );
            if tracker.clearance_violations > 0 {
                clearance_failures.push(format!(
                    "{} particle-steps too close (min clearance {} for radius {}); first: {}",
                    tracker.clearance_violations,
                    tracker.min_clearance,
                    params.particle_radius,
                    tracker.first_violation.clone().unwrap_or_default()
                ));
            }
        }
    }
    assert!(
        total_contacts > 50,
        "{name}: only {total_contacts} contacts"
    );
    assert!(
        clearance_failures.is_empty(),
        "{name}: particles closer to the surface than the contact radius:\n{}",
        clearance_failures.join("\n")
    );
}

fn solid(_: &FluidWorld, h: &[ColliderHandle]) -> Vec<Region> {
    h.iter().map(|&h| Region::Solid(h)).collect()
}

#[test]
fn cuboid() {
    let p = pose([0.1, -0.05, 0.02], [0.5, -0.8, 0.3]);
    let half = Vector::new(0.3, 0.2, 0.25);
    throw_at(
        "cuboid",
        || vec![ColliderBuilder::cuboid(half.x, half.y, half.z).position(p)],
        solid,
        |rng| {
            let mut s = random_shots(rng, 10, p.translation, half);
            // Straight at a corner, and along an edge.
            let corner = p.transform_point(half);
            s.push(Shot {
                dir: -p.rotation.mul_vec3(Vector::ONE).normalize(),
                target: corner,
                cloud: true,
            });
            s.push(Shot {
                dir: -p.rotation.mul_vec3(Vector::new(1.0, 1.0, 0.0)).normalize(),
                target: p.transform_point(Vector::new(half.x, half.y, 0.0)),
                cloud: false,
            });
            s
        },
        1,
    );
}

#[test]
fn ball() {
    let c = Vector::new(0.2, 0.1, -0.1);
    throw_at(
        "ball",
        || vec![ColliderBuilder::ball(0.3).translation(c)],
        solid,
        |rng| random_shots(rng, 12, c, Vector::splat(0.25)),
        2,
    );
}

#[test]
fn capsule() {
    let p = pose([0.0, 0.1, 0.0], [0.0, 0.3, 1.1]);
    throw_at(
        "capsule",
        || vec![ColliderBuilder::capsule_y(0.25, 0.15).position(p)],
        solid,
        |rng| {
            let mut s = random_shots(rng, 10, p.translation, Vector::splat(0.2));
            // At a hemispherical end cap, along the axis.
            let axis = p.rotation.mul_vec3(Vector::Y);
            s.push(Shot {
                dir: -axis,
                target: p.translation + axis * 0.4,
                cloud: true,
            });
            s
        },
        3,
    );
}

#[test]
fn cylinder() {
    let p = pose([-0.1, 0.0, 0.1], [0.9, 0.2, -0.4]);
    throw_at(
        "cylinder",
        || vec![ColliderBuilder::cylinder(0.2, 0.3).position(p)],
        solid,
        |rng| {
            let mut s = random_shots(rng, 10, p.translation, Vector::splat(0.25));
            // At the rim (edge between cap and side), diagonally.
            s.push(Shot {
                dir: -p.rotation.mul_vec3(Vector::new(1.0, 1.0, 0.0)).normalize(),
                target: p.transform_point(Vector::new(0.3, 0.2, 0.0)),
                cloud: true,
            });
            s
        },
        4,
    );
}

#[test]
fn cone() {
    let p = pose([0.0, 0.0, 0.0], [-0.6, 0.0, 0.7]);
    throw_at(
        "cone",
        || vec![ColliderBuilder::cone(0.25, 0.3).position(p)],
        solid,
        |rng| {
            let mut s = random_shots(rng, 10, p.translation, Vector::splat(0.25));
            // Down onto the apex along the axis, and at the base rim.
            s.push(Shot {
                dir: -p.rotation.mul_vec3(Vector::Y),
                target: p.transform_point(Vector::new(0.0, 0.25, 0.0)),
                cloud: true,
            });
            s.push(Shot {
                dir: p.rotation.mul_vec3(Vector::new(-1.0, 1.0, 0.0)).normalize(),
                target: p.transform_point(Vector::new(0.3, -0.25, 0.0)),
                cloud: false,
            });
            s
        },
        5,
    );
}

#[test]
fn convex_polyhedron() {
    let mut r = rng(77);
    let points: Vec<Vector> = (0..24)
        .map(|_| random_in(&mut r, Vector::ZERO, Vector::new(0.35, 0.25, 0.3)))
        .collect();
    let p = pose([0.05, 0.0, -0.05], [0.3, 1.2, -0.2]);
    throw_at(
        "convex polyhedron",
        || {
            vec![
                ColliderBuilder::convex_hull(&points)
                    .expect("hull")
                    .position(p),
            ]
        },
        solid,
        |rng| {
            let mut s = random_shots(rng, 10, p.translation, Vector::splat(0.2));
            // Straight at a hull vertex (the input point farthest from the center).
            let far = points
                .iter()
                .copied()
                .max_by(|a, b| a.length().total_cmp(&b.length()))
                .unwrap();
            s.push(Shot {
                dir: -p.rotation.mul_vec3(far).normalize(),
                target: p.transform_point(far),
                cloud: true,
            });
            s
        },
        6,
    );
}

#[test]
fn box_mesh_is_wound_outward() {
    // The oriented-trimesh test relies on outward winding: check it once.
    let (v, idx) = box_mesh(Vector::new(0.3, 0.2, 0.25));
    for t in idx {
        let [a, b, c] = t.map(|i| v[i as usize]);
        let n = (b - a).cross(c - a);
        let center = (a + b + c) / 3.0;
        assert!(n.dot(center) > 0.0, "triangle {t:?} faces inward");
    }
}

fn closed_trimesh(flags: TriMeshFlags, name: &str, seed: u64) {
    let half = Vector::new(0.3, 0.2, 0.25);
    let p = pose([0.0, 0.05, 0.0], [-0.4, 0.9, 0.5]);
    let oriented = flags.contains(TriMeshFlags::ORIENTED);
    throw_at(
        name,
        || {
            let (v, i) = box_mesh(half);
            vec![
                ColliderBuilder::trimesh_with_flags(v, i, flags)
                    .expect("mesh")
                    .position(p),
            ]
        },
        |_, h| {
            let mut r = vec![Region::LocalBox { pose: p, half }];
            if oriented {
                // With pseudo-normals parry knows the inside too.
                r.push(Region::Solid(h[0]));
            }
            r
        },
        |rng| {
            let mut s = random_shots(rng, 10, p.translation, half);
            s.push(Shot {
                dir: -p.rotation.mul_vec3(Vector::ONE).normalize(),
                target: p.transform_point(half),
                cloud: true,
            });
            s
        },
        seed,
    );
}

#[test]
fn trimesh_closed_box() {
    closed_trimesh(TriMeshFlags::empty(), "closed trimesh box", 7);
}

#[test]
fn trimesh_closed_box_oriented() {
    closed_trimesh(TriMeshFlags::ORIENTED, "closed oriented trimesh box", 8);
}

/// A single square sheet `|x|, |z| ≤ 1` in the plane y = 0 (two triangles sharing the
/// diagonal x = z), zero thickness.
fn sheet() -> ColliderBuilder {
    let v = vec![
        Vector::new(-1.0, 0.0, -1.0),
        Vector::new(1.0, 0.0, -1.0),
        Vector::new(1.0, 0.0, 1.0),
        Vector::new(-1.0, 0.0, 1.0),
    ];
    ColliderBuilder::trimesh(v, vec![[0, 1, 2], [0, 2, 3]]).expect("sheet")
}

/// Shots at a sheet of pose `p` from both faces: random directions on each side, plus
/// streams straight down and up onto the shared diagonal edge and the center vertex.
fn sheet_shots(rng: &mut Pcg64, p: Pose) -> Vec<Shot> {
    let mut s = Vec::new();
    for k in 0..12 {
        let mut d = random_unit(rng);
        // Half from above, half from below; not grazing (|d.y| ≥ 0.3).
        let sign: Real = if k % 2 == 0 { -1.0 } else { 1.0 };
        d.y = sign * d.y.abs().max(0.3);
        let target = Vector::new(
            rng.random_range(-0.6..0.6),
            0.0,
            rng.random_range(-0.6..0.6),
        );
        s.push(Shot {
            dir: p.rotation.mul_vec3(d.normalize()),
            target: p.transform_point(target),
            cloud: k < 4,
        });
    }
    for sign in [-1.0, 1.0] {
        for target in [Vector::new(0.3, 0.0, 0.3), Vector::ZERO] {
            s.push(Shot {
                dir: p.rotation.mul_vec3(Vector::new(0.0, sign, 0.0)),
                target: p.transform_point(target),
                cloud: false,
            });
        }
    }
    s
}

#[test]
fn trimesh_open_sheet_both_faces() {
    let p = Pose::IDENTITY;
    throw_at(
        "open trimesh sheet",
        || vec![sheet()],
        |_, _| {
            vec![Region::Sheet {
                pose: p,
                hx: 1.0,
                hz: 1.0,
            }]
        },
        |rng| sheet_shots(rng, p),
        9,
    );
}

#[test]
fn trimesh_open_sheet_rotated_both_faces() {
    let p = pose([0.1, 0.2, -0.1], [0.7, -0.3, 0.4]);
    throw_at(
        "rotated open trimesh sheet",
        || vec![sheet().position(p)],
        |_, _| {
            vec![Region::Sheet {
                pose: p,
                hx: 1.0,
                hz: 1.0,
            }]
        },
        |rng| sheet_shots(rng, p),
        10,
    );
}

#[test]
fn heightfield() {
    // 4 m × 4 m terrain with bumps of ±15 cm, 20 × 20 cells, turned about y.
    let (nrows, ncols) = (21, 21);
    let mut data = vec![0.0; nrows * ncols];
    for j in 0..ncols {
        for i in 0..nrows {
            let x = -2.0 + 4.0 * j as Real / (ncols - 1) as Real;
            let z = -2.0 + 4.0 * i as Real / (nrows - 1) as Real;
            data[i + j * nrows] = 0.15 * (3.0 * x).sin() * (2.0 * z).cos();
        }
    }
    let p = pose([0.1, -0.2, 0.0], [0.0, 0.5, 0.0]);
    throw_at(
        "heightfield",
        || {
            vec![
                ColliderBuilder::heightfield(
                    Array2::new(nrows, ncols, data.clone()),
                    Vector::new(4.0, 1.0, 4.0),
                )
                .position(p),
            ]
        },
        |_, h| {
            vec![Region::Height {
                collider: h[0],
                hx: 2.0,
                hz: 2.0,
            }]
        },
        |rng| {
            (0..12)
                .map(|k| {
                    let mut d = random_unit(rng);
                    d.y = -d.y.abs().max(0.3);
                    Shot {
                        dir: d.normalize(),
                        target: p.transform_point(Vector::new(
                            rng.random_range(-0.8..0.8),
                            0.0,
                            rng.random_range(-0.8..0.8),
                        )),
                        cloud: k % 2 == 0,
                    }
                })
                .collect()
        },
        11,
    );
}

#[test]
fn compound() {
    // An L of two boxes plus a ball half sunk into the long box: concave edges and corners.
    let parts = || {
        vec![
            (Pose::IDENTITY, SharedShape::cuboid(0.4, 0.1, 0.3)),
            (
                Pose::from_translation(Vector::new(0.3, 0.3, 0.0)),
                SharedShape::cuboid(0.1, 0.3, 0.3),
            ),
            (
                Pose::from_translation(Vector::new(-0.25, 0.1, 0.05)),
                SharedShape::ball(0.15),
            ),
        ]
    };
    let p = pose([0.0, -0.1, 0.05], [0.2, -0.5, 0.35]);
    throw_at(
        "compound",
        || vec![ColliderBuilder::compound(parts()).position(p)],
        solid,
        |rng| {
            let mut s = random_shots(rng, 10, p.translation, Vector::new(0.35, 0.25, 0.25));
            // Into the concave edge between the long box's top and the upright box's side.
            s.push(Shot {
                dir: p.rotation.mul_vec3(Vector::new(1.0, -1.0, 0.0)).normalize(),
                target: p.transform_point(Vector::new(0.2, 0.1, 0.0)),
                cloud: true,
            });
            // Into the concave corner where the three meet the z face.
            s.push(Shot {
                dir: p
                    .rotation
                    .mul_vec3(Vector::new(1.0, -1.0, -1.0))
                    .normalize(),
                target: p.transform_point(Vector::new(0.2, 0.1, 0.3)),
                cloud: false,
            });
            s
        },
        12,
    );
}

/// A fluid *inside* a closed box mesh (no orientation flags, so the mesh is just surfaces):
/// a tilted container, so gravity piles the water into a corner where three faces meet
/// (a concave corner), with an initial sloshing velocity that slams it into the walls.
/// Every particle must stay inside, one contact radius off every face.
#[test]
fn trimesh_container_holds_fluid() {
    let params = water(SPACING);
    let half = Vector::new(0.3, 0.3, 0.3);
    let p = pose([0.0, 0.2, 0.0], [0.35, 0.0, -0.3]);
    let (v, i) = box_mesh(half);
    let (mut world, fluid, _) = world_with(
        params.clone(),
        vec![ColliderBuilder::trimesh(v, i).expect("mesh").position(p)],
    );
    // A 0.4 m cube of water in the box's frame, lower half.
    let local = rapier_sph::fluid::lattice(Vector::new(-0.2, -0.26, -0.2), 10, 6, 10, SPACING);
    let pos: Vec<Vector> = local.iter().map(|&l| p.transform_point(l)).collect();
    let vel = vec![Vector::new(2.0, 0.5, -1.0); pos.len()];
    world.fluids[fluid]
        .add_particles_with_velocities(&pos, Some(&vel))
        .unwrap();
    let n = pos.len();
    let r = params.particle_radius;
    let keep = half - Vector::splat(r - clearance_tolerance(r));
    let dt = params.acoustic_time_step();
    let steps = (0.4 / dt).ceil() as usize;
    let mut contacts = 0;
    for step in 0..steps {
        let report = step_fluid(&mut world, Vector::new(0.0, -9.81, 0.0), dt);
        contacts += report.contacts;
        let f = &world.fluids[fluid];
        assert_eq!(f.len(), n);
        for (x, id) in f.positions().iter().zip(f.ids()) {
            let l = p.inverse_transform_point(*x);
            assert!(
                l.is_finite() && l.abs().cmple(keep).all(),
                "step {step}: particle {id} at local {l}: not inside the container kept {} off \
                 its faces (half extents {half})",
                r - clearance_tolerance(r)
            );
        }
    }
    assert!(contacts > 1000, "{contacts} contacts");
}

// The checks themselves must be able to fail: with collision groups that exclude every
// collider, particles fly into / through the shapes and each check must catch it.

fn ghost_throw(
    colliders: Vec<ColliderBuilder>,
    regions: impl Fn(&[ColliderHandle]) -> Vec<Region>,
    shots: Vec<Shot>,
) {
    let params = rapier_sph::FluidParamsBuilder::water(SPACING)
        .collision_groups(InteractionGroups::none())
        .build()
        .unwrap();
    let throw = Throw {
        label: "ghost".into(),
        speed: 10.0,
        gravity: Vector::ZERO,
        shots,
        duration: DURATION,
        stream_len: 6,
    };
    run_throw(&params, colliders, |_, h| regions(h), &throw, 99);
}

#[test]
#[should_panic(expected = "inside the solid")]
fn check_catches_particles_inside_a_solid() {
    ghost_throw(
        vec![ColliderBuilder::ball(0.3)],
        |h| vec![Region::Solid(h[0])],
        vec![Shot {
            dir: Vector::X,
            target: Vector::ZERO,
            cloud: true,
        }],
    );
}

#[test]
#[should_panic(expected = "crossed the sheet")]
fn check_catches_particles_crossing_a_sheet() {
    ghost_throw(
        vec![sheet()],
        |_| {
            vec![Region::Sheet {
                pose: Pose::IDENTITY,
                hx: 1.0,
                hz: 1.0,
            }]
        },
        vec![Shot {
            dir: Vector::NEG_Y,
            target: Vector::new(0.2, 0.0, 0.1),
            cloud: true,
        }],
    );
}

#[test]
#[should_panic(expected = "inside the box mesh")]
fn check_catches_particles_inside_a_box_mesh() {
    let half = Vector::new(0.3, 0.2, 0.25);
    let (v, i) = box_mesh(half);
    ghost_throw(
        vec![ColliderBuilder::trimesh(v, i).unwrap()],
        |_| {
            vec![Region::LocalBox {
                pose: Pose::IDENTITY,
                half,
            }]
        },
        vec![Shot {
            dir: Vector::NEG_Z,
            target: Vector::ZERO,
            cloud: true,
        }],
    );
}
