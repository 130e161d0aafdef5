//! Which colliders particles touch (sensors never, collision groups respected), and
//! particles spawned inside solids (pushed out on the first step).

mod common;

use common::*;
use rand::Rng;
use rapier_sph::rapier3d::prelude::*;
use rapier_sph::{FluidParamsBuilder, FluidWorld};

const SPACING: Real = 0.04;
const SPEED: Real = 10.0;

/// A wall at x = 0 (2 cm thick, |y|, |z| ≤ 1) and a solid backstop at x = 0.5
/// (faces at x = ±0.02 and x = 0.48).
fn wall() -> ColliderBuilder {
    ColliderBuilder::cuboid(0.02, 1.0, 1.0)
}

fn backstop() -> ColliderBuilder {
    ColliderBuilder::cuboid(0.02, 1.0, 1.0).translation(Vector::new(0.5, 0.0, 0.0))
}

/// Particles on a 5 × 5 lattice at x = −0.4, three spacings apart (12 cm, more than
/// h = 8 cm, so they never interact), all moving at +10 m/s along x: with no gravity and no
/// neighbour their velocity is exactly constant until a collider changes it.
fn launch(world: &mut FluidWorld, fluid: rapier_sph::FluidHandle) -> usize {
    let mut pos = Vec::new();
    for j in 0..5 {
        for k in 0..5 {
            pos.push(Vector::new(
                -0.4,
                (j as Real - 2.0) * 3.0 * SPACING,
                (k as Real - 2.0) * 3.0 * SPACING,
            ));
        }
    }
    let vel = vec![Vector::new(SPEED, 0.0, 0.0); pos.len()];
    world.fluids[fluid]
        .add_particles_with_velocities(&pos, Some(&vel))
        .unwrap();
    pos.len()
}

/// Runs 0.1 s (particles travel 1 m if unobstructed) and returns the final x of every
/// particle. After every step, a particle still more than one contact radius (plus the
/// clearance tolerance) before `face`, the first face that should stop it, has not been
/// touched by any collider: its velocity is still exactly the launch velocity.
fn run(
    mut world: FluidWorld,
    fluid: rapier_sph::FluidHandle,
    face: Real,
    label: &str,
) -> Vec<Real> {
    let n = launch(&mut world, fluid);
    let params = world.fluids[fluid].params().clone();
    let free_until = face - params.particle_radius - clearance_tolerance(params.particle_radius);
    let dt = params.acoustic_time_step();
    let steps = (0.1 / dt).ceil() as usize;
    for step in 0..steps {
        let report = step_fluid(&mut world, Vector::ZERO, dt);
        assert_eq!(report.non_finite, 0, "{label}");
        let f = &world.fluids[fluid];
        assert_eq!(f.len(), n, "{label}");
        for (x, v) in f.positions().iter().zip(f.velocities()) {
            assert!(x.is_finite() && v.is_finite(), "{label}: {x} {v}");
            if x.x < free_until {
                assert_eq!(
                    *v,
                    Vector::new(SPEED, 0.0, 0.0),
                    "{label}: particle at {x} was deflected at step {step}"
                );
            }
        }
    }
    world.fluids[fluid]
        .positions()
        .iter()
        .map(|p| p.x)
        .collect()
}

/// Every particle rests one contact radius before the face at `face` (it moved +x at constant
/// speed, and contact removes the normal velocity with restitution 0). The tolerance is the
/// contact slack (1e-3·radius) plus f32 round-off on coordinates below 1 m.
fn assert_stopped_at(xs: &[Real], face: Real, radius: Real, label: &str) {
    let tol = clearance_tolerance(radius);
    for &x in xs {
        assert!(
            (x - (face - radius)).abs() <= tol,
            "{label}: particle at x = {x}, expected to rest at {} (face {face}, radius {radius})",
            face - radius
        );
    }
}

#[test]
fn sensors_are_ignored() {
    let params = water(SPACING);
    let r = params.particle_radius;
    let (world, fluid, _) = world_with(params, vec![wall().sensor(true), backstop()]);
    let xs = run(world, fluid, 0.48, "sensor");
    // Through the sensor, stopped by the backstop.
    assert_stopped_at(&xs, 0.48, r, "sensor");
}

#[test]
fn a_sensor_alone_is_ignored_without_error() {
    // The only collider is a sensor: the step must neither fail nor touch the particles.
    let params = water(SPACING);
    let (world, fluid, _) = world_with(params, vec![wall().sensor(true)]);
    let xs = run(world, fluid, Real::MAX, "sensor alone");
    let dt = water(SPACING).acoustic_time_step();
    let steps = (0.1 / dt).ceil();
    // Constant velocity: x = −0.4 + 10·dt·steps, summed in f32 step by step (round-off of
    // `steps` additions on |x| < 1: steps·u·1 m).
    let expected = -0.4 + SPEED * dt * steps;
    for x in xs {
        assert!(
            (x - expected).abs() <= (steps as f64 * 2.0 * U32) as Real,
            "x = {x}, expected {expected}"
        );
    }
}

fn grouped(
    fluid_groups: InteractionGroups,
    wall_groups: InteractionGroups,
    face: Real,
) -> Vec<Real> {
    let params = FluidParamsBuilder::water(SPACING)
        .collision_groups(fluid_groups)
        .build()
        .unwrap();
    let (world, fluid, _) = world_with(
        params,
        vec![wall().collision_groups(wall_groups), backstop()],
    );
    run(world, fluid, face, "groups")
}

#[test]
fn collision_groups_are_respected() {
    let r = water(SPACING).particle_radius;
    let g = |m: Group, f: Group| InteractionGroups::new(m, f, InteractionTestMode::And);
    let fluid_groups = g(Group::GROUP_1, Group::GROUP_1);

    // Disjoint groups: through the wall, stopped by the backstop (default groups: all).
    let xs = grouped(fluid_groups, g(Group::GROUP_2, Group::GROUP_2), 0.48);
    assert_stopped_at(&xs, 0.48, r, "disjoint groups");

    // Wall is a member of the fluid's filter but does not accept the fluid: rapier's AND
    // test fails, so it is ignored too.
    let xs = grouped(fluid_groups, g(Group::GROUP_1, Group::GROUP_2), 0.48);
    assert_stopped_at(&xs, 0.48, r, "one-way groups");

    // Matching groups: stopped by the wall, before x = −0.02.
    let xs = grouped(fluid_groups, g(Group::GROUP_1, Group::GROUP_1), -0.02);
    assert_stopped_at(&xs, -0.02, r, "matching groups");
}

/// Spawns particles inside `collider` (`special` points, then random points of its AABB that
/// it contains, up to `count`) and far outside it, steps once and checks that exactly the
/// inside ones were pushed out, then keeps stepping and checking.
fn depenetration(
    name: &str,
    collider: ColliderBuilder,
    special: &[Vector],
    count: usize,
    seed: u64,
) {
    let params = water(SPACING);
    let (mut world, fluid, handles) = world_with(params.clone(), vec![collider]);
    let co = &world.physics.colliders[handles[0]];
    let aabb = co.compute_aabb();
    let mut rng = rng(seed);
    let mut inside: Vec<Vector> = special.to_vec();
    for p in &inside {
        assert!(co.shape().contains_point(co.position(), *p));
    }
    while inside.len() < count {
        let p = Vector::new(
            rng.random_range(aabb.mins.x..aabb.maxs.x),
            rng.random_range(aabb.mins.y..aabb.maxs.y),
            rng.random_range(aabb.mins.z..aabb.maxs.z),
        );
        // Keep them a spacing apart, as a fluid would be.
        if co.shape().contains_point(co.position(), p)
            && inside.iter().all(|q| (*q - p).length() >= SPACING)
        {
            inside.push(p);
        }
    }
    let outside: Vec<Vector> = (0..10)
        .map(|k| Vector::new(2.0 + 0.1 * k as Real, 0.0, 0.0))
        .collect();
    let mut all = inside.clone();
    all.extend(&outside);
    let ids = world.fluids[fluid].add_particles(&all).unwrap();
    let mut tracker = Tracker::new();
    tracker.spawn(ids, &all, &[]);
    let regions = vec![Region::Solid(handles[0])];
    let dt = params.acoustic_time_step();

    let report = step_fluid(&mut world, Vector::ZERO, dt);
    assert_eq!(
        report.depenetrated,
        inside.len(),
        "{name}: every particle spawned inside (and only those) is pushed out"
    );
    tracker.check(name, &world, fluid, all.len(), &regions, &handles, &report);

    // Later steps: nothing to depenetrate, nothing goes back in.
    for _ in 0..30 {
        let report = step_fluid(&mut world, Vector::ZERO, dt);
        assert_eq!(report.depenetrated, 0, "{name}");
        tracker.check(name, &world, fluid, all.len(), &regions, &handles, &report);
    }
    tracker.assert_clearance(name);
}

#[test]
fn spawned_inside_a_ball_are_pushed_out() {
    depenetration(
        "ball",
        ColliderBuilder::ball(0.3).translation(Vector::new(0.1, 0.0, -0.1)),
        &[],
        40,
        31,
    );
}

/// The center of a ball has no nearest surface point (every direction is as good): the
/// particle must still come out, in some direction, with a finite position.
#[test]
fn spawned_at_the_center_of_a_ball_is_pushed_out() {
    let c = Vector::new(0.1, 0.0, -0.1);
    depenetration(
        "ball center",
        ColliderBuilder::ball(0.3).translation(c),
        &[c],
        1,
        33,
    );
}

#[test]
fn spawned_inside_a_cuboid_are_pushed_out() {
    let p = Pose::new(Vector::new(0.0, 0.1, 0.0), Vector::new(0.4, 0.6, -0.3));
    depenetration(
        "cuboid",
        ColliderBuilder::cuboid(0.3, 0.15, 0.2).position(p),
        // The center (equidistant from two faces) first.
        &[p.translation],
        40,
        32,
    );
}

/// Points on a capsule's axis segment are equidistant from the whole surface around them.
#[test]
fn spawned_on_the_axis_of_a_capsule_are_pushed_out() {
    let p = Pose::new(Vector::new(0.0, 0.1, 0.0), Vector::new(0.0, 0.0, 0.5));
    let axis = p.rotation.mul_vec3(Vector::Y);
    depenetration(
        "capsule axis",
        ColliderBuilder::capsule_y(0.2, 0.15).position(p),
        &[p.translation, p.translation + axis * 0.1],
        2,
        34,
    );
}

/// Inside a compound whose parts overlap (a ball half sunk into a box): the nearest surface
/// point of one part can lie inside the other, and the particle must still end up outside
/// the whole compound.
#[test]
fn spawned_inside_an_overlapping_compound_are_pushed_out() {
    let parts = vec![
        (Pose::IDENTITY, SharedShape::cuboid(0.3, 0.1, 0.3)),
        (
            Pose::from_translation(Vector::new(0.0, 0.1, 0.0)),
            SharedShape::ball(0.15),
        ),
    ];
    depenetration(
        "overlapping compound",
        ColliderBuilder::compound(parts).position(Pose::new(
            Vector::new(0.05, 0.0, 0.0),
            Vector::new(0.2, 0.0, 0.3),
        )),
        &[],
        40,
        35,
    );
}

/// Inside a closed trimesh with pseudo-normals (`TriMeshFlags::ORIENTED`), which parry can
/// tell the inside of.
#[test]
fn spawned_inside_an_oriented_trimesh_are_pushed_out() {
    let h = Vector::new(0.3, 0.2, 0.25);
    let (v, idx) = box_mesh(h);
    depenetration(
        "oriented trimesh",
        ColliderBuilder::trimesh_with_flags(v, idx, TriMeshFlags::ORIENTED)
            .unwrap()
            .position(Pose::new(Vector::ZERO, Vector::new(0.3, -0.2, 0.5))),
        &[],
        40,
        36,
    );
}

/// Inside the overlap of two separate colliders: pushed out of one, the particle must not be
/// left inside the other.
#[test]
fn spawned_in_the_overlap_of_two_colliders_are_pushed_out() {
    let params = water(SPACING);
    let a = ColliderBuilder::cuboid(0.3, 0.3, 0.3);
    let b = ColliderBuilder::cuboid(0.3, 0.3, 0.3).translation(Vector::new(0.4, 0.1, 0.0));
    let (mut world, fluid, handles) = world_with(params.clone(), vec![a, b]);
    // Points of the overlap x ∈ [0.1, 0.3], y ∈ [-0.2, 0.3], |z| < 0.3, a spacing apart.
    let pts = rapier_sph::fluid::lattice(Vector::new(0.12, -0.18, -0.26), 5, 12, 13, SPACING);
    let ids = world.fluids[fluid].add_particles(&pts).unwrap();
    let mut tracker = Tracker::new();
    tracker.spawn(ids, &pts, &[]);
    let regions: Vec<Region> = handles.iter().map(|&h| Region::Solid(h)).collect();
    let dt = params.acoustic_time_step();
    for step in 0..20 {
        let report = step_fluid(&mut world, Vector::ZERO, dt);
        if step == 0 {
            assert!(report.depenetrated >= pts.len(), "{report:?}");
        }
        tracker.check(
            "overlap",
            &world,
            fluid,
            pts.len(),
            &regions,
            &handles,
            &report,
        );
    }
    tracker.assert_clearance("overlap");
}
