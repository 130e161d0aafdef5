//! Water added to a closed tank that is already moving (a kinematic body translating at
//! 2 m/s, or spinning at 5 and 20 rad/s) stays in it: after every frame every particle is
//! inside the tank's interior (in the tank's frame), none is NaN, none is lost; water added
//! again later, while it moves, too. Every solver.

mod common;

use rapier_sph::rapier3d::prelude::*;
use rapier_sph::{Fluid, FluidParamsBuilder, FluidWorld, Solver};

const SPACING: Real = 0.04;
/// Half the tank's inner width (m) and its walls' thickness.
const INNER: Real = 0.2;
const WALL: Real = 0.02;

fn solvers() -> [(&'static str, Solver); 4] {
    [
        ("dfsph", Solver::dfsph()),
        ("wcsph", Solver::Wcsph),
        ("pbf", Solver::pbf()),
        ("clavet", Solver::clavet()),
    ]
}

/// A closed tank on a kinematic body moving with `linvel` and `angvel` about its center.
fn tank(world: &mut FluidWorld, linvel: Vector, angvel: Vector) -> RigidBodyHandle {
    let body = world.physics.insert_body(
        RigidBodyBuilder::kinematic_velocity_based()
            .linvel(linvel)
            .angvel(angvel),
    );
    let (a, t) = (INNER + 2.0 * WALL, INNER + WALL);
    for axis in 0..3 {
        for side in [-1.0, 1.0] {
            let mut half = Vector::splat(a);
            half[axis] = WALL;
            let mut c = Vector::ZERO;
            c[axis] = side * t;
            world.physics.insert_collider(
                ColliderBuilder::cuboid(half.x, half.y, half.z).translation(c),
                Some(body),
            );
        }
    }
    body
}

/// Particles at rest filling the lower `layers` layers of the tank's interior, placed at its
/// current pose.
fn fill(
    world: &mut FluidWorld,
    fluid: rapier_sph::FluidHandle,
    body: RigidBodyHandle,
    layers: usize,
) {
    let pose = *world.physics.bodies[body].position();
    let n = ((2.0 * INNER) / SPACING).round() as usize;
    let mut points = Vec::new();
    for i in 0..n {
        for j in 0..layers {
            for k in 0..n {
                let local = Vector::new(
                    -INNER + (i as Real + 0.5) * SPACING,
                    -INNER + (j as Real + 0.5) * SPACING,
                    -INNER + (k as Real + 0.5) * SPACING,
                );
                points.push(pose.transform_point(local));
            }
        }
    }
    world.fluids[fluid].add_particles(&points).unwrap();
}

/// Moves the tank for 20 frames, adds water at frame 2 and again at frame 10 (on top), and
/// checks after every frame that none was lost or NaN. Returns the most particles outside the
/// tank after a frame, and the first frame with some outside.
fn run(label: &str, solver: Solver, linvel: Vector, angvel: Vector) -> (usize, Option<usize>) {
    let (mut worst, mut first) = (0, None);
    let mut world = FluidWorld::new();
    let body = tank(&mut world, linvel, angvel);
    world.physics.step();
    let params = FluidParamsBuilder::water(SPACING)
        .solver(solver)
        .build()
        .unwrap();
    let fluid = world.fluids.insert(Fluid::new(params).unwrap());
    for frame in 0..20 {
        if frame == 2 {
            fill(&mut world, fluid, body, 4);
        }
        if frame == 10 {
            // On top of the water already there, 2 layers higher up.
            let pose = *world.physics.bodies[body].position();
            let n = ((2.0 * INNER) / SPACING).round() as usize;
            let mut points = Vec::new();
            for i in 0..n {
                for k in 0..n {
                    for j in 6..8 {
                        let local = Vector::new(
                            -INNER + (i as Real + 0.5) * SPACING,
                            -INNER + (j as Real + 0.5) * SPACING,
                            -INNER + (k as Real + 0.5) * SPACING,
                        );
                        points.push(pose.transform_point(local));
                    }
                }
            }
            world.fluids[fluid].add_particles(&points).unwrap();
        }
        let n_before = world.fluids[fluid].len();
        let report = world.step().unwrap().clone();
        let f = &world.fluids[fluid];
        assert_eq!(report.quarantined, 0, "{label}: frame {frame}: NaN");
        assert_eq!(f.len(), n_before, "{label}: frame {frame}: particles lost");
        let pose = *world.physics.bodies[body].position();
        let out = f
            .positions()
            .iter()
            .filter(|p| pose.inverse_transform_point(**p).abs().max_element() > INNER)
            .count();
        if out > 0 {
            first = first.or(Some(frame));
        }
        worst = worst.max(out);
    }
    eprintln!("{label}: at most {worst} particles outside, first in frame {first:?}");
    (worst, first)
}

#[test]
fn water_added_to_a_translating_tank_stays_in() {
    for (name, s) in solvers() {
        let label = format!("{name} 2 m/s");
        let (out, _) = run(&label, s, Vector::new(2.0, 0.0, 0.0), Vector::ZERO);
        assert_eq!(out, 0, "{label}: {out} particles left the tank");
    }
}

#[test]
fn water_added_to_a_spinning_tank_stays_in() {
    for (name, s) in solvers() {
        for w in [5.0, 20.0] {
            let label = format!("{name} {w} rad/s");
            let (out, _) = run(&label, s, Vector::ZERO, Vector::new(0.0, 0.0, w));
            assert_eq!(out, 0, "{label}: {out} particles left the tank");
        }
    }
}
