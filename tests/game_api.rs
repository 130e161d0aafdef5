//! The calls a game reaches for: filling any parry shape with an exact particle count,
//! removing particles by id with honest accounting, clearing and resetting a fluid in a live
//! pipeline (a reset level runs bit for bit as a new one), emitters carried by bodies and
//! colliders, stepping with rapier's own parameters, and the collision checks. Each refuses
//! bad input with a typed error naming the argument.

use rapier_sph::check;
use rapier_sph::fluid::shape_lattice;
use rapier_sph::math::{Pose, Real, Rotation, Vector};
use rapier_sph::prelude::*;
use rapier_sph::rapier3d::parry::query::PointQuery;
use rapier_sph::rapier3d::parry::shape::{Ball, Capsule, Cuboid, Cylinder, HalfSpace, Shape};
use rapier_sph::rapier3d::prelude::*;

fn field_of<T: std::fmt::Debug>(r: SphResult<T>) -> &'static str {
    match r {
        Err(SphError::InvalidParameter { field, .. }) => field,
        other => panic!("expected an invalid parameter, got {other:?}"),
    }
}

/// A box of side `n·s` gets `n` particles per axis at any position and spacing, even where
/// `side/s` rounds below `n` in single precision; the particles are those `add_block` places.
#[test]
fn a_box_gets_exactly_n_per_axis() {
    for &s in &[0.013 as Real, 0.02, 0.05, 0.1, 0.3] {
        for n in 1..=9u32 {
            for &c in &[
                Vector::ZERO,
                Vector::new(1.3, -0.7, 2.9),
                Vector::new(-123.4, 56.7, 8.9),
                Vector::new(1000.1, 0.0, -999.9),
            ] {
                let half = Vector::new(n as Real, (n + 1) as Real, (2 * n) as Real) * (0.5 * s);
                let pts = shape_lattice(&Cuboid::new(half), &Pose::from_translation(c), s).unwrap();
                assert_eq!(
                    pts.len(),
                    (n * (n + 1) * 2 * n) as usize,
                    "spacing {s}, n {n}, at {c}"
                );
            }
        }
    }
    // The same particles as `add_block` (to rounding of the box's corner).
    let s = 0.05;
    let mut a = Fluid::new(FluidParamsBuilder::water(s)).unwrap();
    let mut b = a.clone();
    let (min, size) = (Vector::new(0.2, 0.1, -0.3), Vector::new(0.5, 0.3, 0.4));
    a.add_block(min, size).unwrap();
    let ids = b
        .fill_shape(
            &Cuboid::new(size * 0.5),
            &Pose::from_translation(min + size * 0.5),
        )
        .unwrap();
    assert_eq!(ids.len(), a.len());
    for (p, q) in a.positions().iter().zip(b.positions()) {
        assert!((*p - *q).abs().max_element() < 1e-6, "{p} vs {q}");
    }
}

/// A lattice point inside a shape owns the cube of side `s` around it, so the count lies
/// between the volumes of the shape shrunk and grown by half the cube's diagonal, over `s³`
/// (for a ball: radii `R ∓ √3/2·s`); every point returned is inside the shape (a ball, a
/// turned cylinder, a capsule).
#[test]
fn round_shapes_get_the_lattice_points_inside_them() {
    let s = 0.05 as Real;
    let ball_volume = |r: Real| 4.0 / 3.0 * std::f64::consts::PI * (r.max(0.0) as f64).powi(3);
    for &r in &[0.1 as Real, 0.17, 0.25, 0.4] {
        let n = shape_lattice(&Ball::new(r), &Pose::IDENTITY, s)
            .unwrap()
            .len() as f64;
        let d = 0.5 * (3.0 as Real).sqrt() * s;
        let (lo, hi) = (ball_volume(r - d), ball_volume(r + d));
        let cell = (s as f64).powi(3);
        assert!(
            n >= lo / cell && n <= hi / cell,
            "ball {r}: {n} not in [{}, {}]",
            lo / cell,
            hi / cell
        );
        let pts = shape_lattice(&Ball::new(r), &Pose::IDENTITY, s).unwrap();
        assert!(pts.iter().all(|p| p.length() <= r));
    }
    // A turned cylinder: every point inside it.
    let cyl = Cylinder::new(0.3, 0.12);
    let pose = Pose::from_parts(Vector::new(0.4, 0.5, -0.2), Rotation::from_rotation_z(0.7));
    let pts = shape_lattice(&cyl, &pose, s).unwrap();
    assert!(!pts.is_empty());
    for p in &pts {
        let l = pose.inverse_transform_point(*p);
        assert!(
            l.y.abs() <= 0.3 && (l.x * l.x + l.z * l.z).sqrt() <= 0.12,
            "{l}"
        );
    }
    let cap = Capsule::new_y(0.2, 0.1);
    let pts = shape_lattice(&cap, &Pose::IDENTITY, s).unwrap();
    assert!(pts.iter().all(|p| cap.contains_local_point(*p)));
}

#[test]
fn fill_refuses_bad_input_and_adds_nothing() {
    let mut f = Fluid::new(FluidParamsBuilder::water(0.05)).unwrap();
    let ball = Ball::new(0.2);
    let nan = Pose::from_translation(Vector::new(Real::NAN, 0.0, 0.0));
    assert_eq!(field_of(f.fill_shape(&ball, &nan)), "pose");
    let half_space = HalfSpace::new(Vector::Y);
    assert_eq!(
        field_of(f.fill_shape(&half_space, &Pose::IDENTITY)),
        "shape"
    );
    let huge = Cuboid::new(Vector::splat(1.0e4)); // 4·10^17 lattice points
    assert_eq!(field_of(f.fill_shape(&huge, &Pose::IDENTITY)), "shape");
    assert_eq!(
        field_of(shape_lattice(&ball, &Pose::IDENTITY, -1.0)),
        "spacing"
    );
    assert_eq!(
        field_of(shape_lattice(&ball, &Pose::IDENTITY, Real::NAN)),
        "spacing"
    );
    let mut world = PhysicsWorld::new();
    let h = world.insert_collider(ColliderBuilder::ball(0.2).sensor(true), None);
    world.remove_collider(h);
    assert_eq!(field_of(f.fill_collider(h, &world.colliders)), "collider");
    assert!(f.is_empty());
    // The capacity holds: a fill beyond it is refused whole.
    f.set_capacity(Some(10)).unwrap();
    assert!(f.fill_shape(&ball, &Pose::IDENTITY).is_err());
    assert!(f.is_empty());
}

/// A tank (floor and four walls) with a sink under a hole, an emitter, and a block of water.
fn tank_world(solver: Solver) -> (FluidWorld, FluidHandle) {
    let mut world = FluidWorld::new();
    let tank = world.physics.insert_body(RigidBodyBuilder::fixed());
    for (center, half) in [
        (Vector::new(0.3, -0.05, 0.3), Vector::new(0.4, 0.05, 0.4)),
        (Vector::new(-0.05, 0.4, 0.3), Vector::new(0.05, 0.4, 0.4)),
        (Vector::new(0.65, 0.4, 0.3), Vector::new(0.05, 0.4, 0.4)),
        (Vector::new(0.3, 0.4, -0.05), Vector::new(0.4, 0.4, 0.05)),
        (Vector::new(0.3, 0.4, 0.65), Vector::new(0.4, 0.4, 0.05)),
    ] {
        world.physics.insert_collider(
            ColliderBuilder::cuboid(half.x, half.y, half.z).translation(center),
            Some(tank),
        );
    }
    let mut water = Fluid::new(FluidParamsBuilder::water(0.05).solver(solver)).unwrap();
    water
        .add_emitter(Emitter::new(
            Nozzle::Disk { radius: 0.05 },
            Vector::new(0.3, 0.6, 0.3),
            Vector::NEG_Y,
            1.0,
            100.0,
        ))
        .unwrap();
    world.physics.step();
    let h = world.fluids.insert(water);
    (world, h)
}

fn fill(world: &mut FluidWorld, h: FluidHandle) {
    let block = Cuboid::new(Vector::new(0.15, 0.15, 0.3));
    let at = Pose::from_translation(Vector::new(0.15, 0.15, 0.3));
    assert_eq!(world.fluids[h].fill_shape(&block, &at).unwrap().len(), 432);
}

/// A level reset in the same pipeline runs bit for bit as a fresh fluid in a fresh pipeline,
/// for every solver (DFSPH's warm starts, PBF's and Clavet's state, Clavet's springs); a fluid
/// cleared mid-run and filled again steps on without trouble.
#[test]
fn a_reset_level_replays_bit_for_bit() {
    let springs = Solver::Clavet(rapier_sph::Clavet {
        springs: Some(Springs::default()),
        ..Default::default()
    });
    for solver in [
        Solver::dfsph(),
        Solver::Wcsph,
        Solver::pbf(),
        Solver::clavet(),
        springs,
    ] {
        let (mut fresh, hf) = tank_world(solver);
        fill(&mut fresh, hf);
        for _ in 0..12 {
            fresh.step().unwrap();
        }
        let (mut reused, hr) = tank_world(solver);
        fill(&mut reused, hr);
        for _ in 0..20 {
            reused.step().unwrap();
        }
        // Restart the level: the rapier world is rebuilt, the fluid and pipeline are kept.
        let (world, _) = tank_world(solver);
        reused.physics = world.physics;
        reused.fluids[hr].reset();
        let f = &reused.fluids[hr];
        assert_eq!(
            (f.len(), f.emitted(), f.removed(), f.drained()),
            (0, 0, 0, 0)
        );
        fill(&mut reused, hr);
        for _ in 0..12 {
            reused.step().unwrap();
        }
        assert_eq!(
            reused.fluids[hr].state_hash(),
            fresh.fluids[hf].state_hash(),
            "{solver:?}: the reset level differs from a fresh one"
        );
        // A clear mid-run: the particles go (counted), the solver state starts afresh, the
        // fluid is filled again and steps on.
        reused.fluids[hr].clear();
        assert_eq!(
            reused.fluids[hr].removed(),
            432 + reused.fluids[hr].emitted()
        );
        fill(&mut reused, hr);
        for _ in 0..5 {
            let r = reused.step().unwrap();
            assert_eq!((r.non_finite, r.quarantined), (0, 0));
        }
        check::no_particle_in_solids(&reused.fluids[hr], &reused.physics.colliders).unwrap();
    }
}

/// Removing by id: the named particles go, the others stay, repeats and already-removed ids
/// are skipped, unknown ids are refused whole; over a run with an emitter and a sink every
/// particle ever added is live, drained, quarantined or removed.
#[test]
fn removal_by_id_keeps_the_books() {
    let (mut world, h) = tank_world(Solver::dfsph());
    fill(&mut world, h);
    let sink = Sink::new(Region::Aabb {
        min: Vector::new(0.0, 0.0, 0.0),
        max: Vector::new(0.6, 0.06, 0.1),
    });
    world.fluids[h].add_sink(sink).unwrap();
    let mut added = world.fluids[h].len();
    for frame in 0..30 {
        added += world.step().unwrap().emitted;
        let f = &mut world.fluids[h];
        let ids: Vec<u32> = f
            .ids()
            .iter()
            .copied()
            .filter(|id| id % 7 == frame % 7)
            .collect();
        let before = f.len();
        let removed_before = f.removed();
        let repeated: Vec<u32> = ids.iter().chain(ids.iter().take(3)).copied().collect();
        assert_eq!(f.remove_particles(&repeated).unwrap(), ids.len());
        assert_eq!(f.len(), before - ids.len());
        assert!(f.ids().iter().all(|id| !ids.contains(id)));
        assert_eq!(f.remove_particles(&ids).unwrap(), 0);
        assert_eq!(f.removed(), removed_before + ids.len());
        let next = f.ids().iter().max().copied().unwrap_or(0) + 1_000_000;
        let live = f.ids()[0];
        assert_eq!(field_of(f.remove_particles(&[live, next])), "ids");
        assert!(f.ids().contains(&live)); // nothing removed on error
        assert_eq!(
            f.len() + f.removed() + f.drained() + f.quarantined(),
            added,
            "frame {frame}"
        );
    }
    assert!(world.fluids[h].drained() > 0, "the sink drained nothing");
}

/// A kinematic body moving and turning carries an emitter: every particle leaves from the
/// nozzle's disk in the body's frame (the body's pose at the frame's end), along the body's
/// turned direction, with the jet's velocity plus the body's at its slot.
#[test]
fn an_attached_emitter_follows_its_body() {
    let mut world = FluidWorld::new();
    world.physics.gravity = Vector::ZERO;
    let (v, w) = (Vector::new(0.8, 0.0, -0.3), Vector::new(0.0, 0.0, 1.5));
    let body = world.physics.insert_body(
        RigidBodyBuilder::kinematic_velocity_based()
            .translation(Vector::new(0.0, 1.0, 0.0))
            .linvel(v)
            .angvel(w),
    );
    let (local, dir, speed, radius) = (Vector::new(0.0, 0.3, 0.0), Vector::X, 2.0, 0.06);
    let mut water = Fluid::new(FluidParamsBuilder::water(0.03)).unwrap();
    let hose = water
        .add_emitter(Emitter::new(
            Nozzle::Disk { radius },
            local,
            dir,
            speed,
            600.0,
        ))
        .unwrap();
    let p = &world.physics;
    water
        .attach_emitter(hose, Attachment::Body(body), &p.bodies, &p.colliders)
        .unwrap();
    assert_eq!(
        water.emitter(hose).unwrap().attachment(),
        Some(Attachment::Body(body))
    );
    let h = world.fluids.insert(water);
    let dt = world.physics.integration_parameters.dt;
    let mut seen = 0;
    for _ in 0..20 {
        let emitted = world.step().unwrap().emitted;
        assert!(emitted > 0);
        let f = &world.fluids[h];
        let b = &world.physics.bodies[body];
        let pose = *b.position();
        // The frame's new particles are the last ones appended (not stepped yet).
        let n = f.len();
        for k in n - emitted..n {
            let (x, u) = (f.positions()[k], f.velocities()[k]);
            let l = pose.inverse_transform_point(x) - local;
            let along = l.dot(dir);
            let across = (l - dir * along).length();
            assert!(across <= radius + 1e-4, "{across} off the axis");
            assert!(
                (-1e-4..=speed * dt + 1e-4).contains(&along),
                "{along} along"
            );
            let from = pose.transform_point(local + (l - dir * along));
            let expected = pose.rotation * dir * speed + b.velocity_at_point(from);
            assert!(
                (u - expected).length() < 1e-4,
                "velocity {u}, expected {expected}"
            );
        }
        seen += emitted;
    }
    assert_eq!(
        world.fluids[h].emitter(hose).unwrap().emitted() as usize,
        seen
    );
    // The body goes: its emitter's due particles are blocked, nothing panics.
    world.physics.remove_body(body);
    let r = world.step().unwrap();
    assert_eq!(r.emitted, 0);
    assert!(r.emitter_blocked > 0);
    // Detached, it emits from where it is in world space.
    let p = &world.physics;
    let f = &mut world.fluids[h];
    assert_eq!(
        f.detach_emitter(hose, &p.bodies, &p.colliders).unwrap(),
        Some(Attachment::Body(body))
    );
    assert!(world.step().unwrap().emitted > 0);
}

/// An emitter attached to a collider of a dynamic body takes the collider's pose and the body's
/// velocity; bad handles are refused naming the argument.
#[test]
fn attaching_refuses_unknown_handles() {
    let mut world = FluidWorld::new();
    let body = world.physics.insert_body(RigidBodyBuilder::dynamic());
    let co = world.physics.insert_collider(
        ColliderBuilder::ball(0.1).translation(Vector::new(0.0, 0.5, 0.0)),
        Some(body),
    );
    let mut water = Fluid::new(FluidParamsBuilder::water(0.05)).unwrap();
    let e = water
        .add_emitter(Emitter::new(
            Nozzle::Square { half_width: 0.05 },
            Vector::new(0.2, 0.0, 0.0),
            Vector::X,
            1.0,
            50.0,
        ))
        .unwrap();
    let p = &world.physics;
    let (bodies, colliders) = (&p.bodies, &p.colliders);
    let mut other = RigidBodySet::new();
    other.insert(RigidBodyBuilder::fixed());
    let stranger = other.insert(RigidBodyBuilder::fixed());
    let r = water.attach_emitter(e, Attachment::Body(stranger), bodies, colliders);
    assert_eq!(field_of(r), "body");
    let mut other_colliders = ColliderSet::new();
    other_colliders.insert(ColliderBuilder::ball(1.0));
    let stranger_co = other_colliders.insert(ColliderBuilder::ball(1.0));
    let r = water.attach_emitter(e, Attachment::Collider(stranger_co), bodies, colliders);
    assert_eq!(field_of(r), "collider");
    let gone = water
        .add_emitter(water.emitter(e).unwrap().clone())
        .unwrap();
    water.remove_emitter(gone);
    let r = water.attach_emitter(gone, Attachment::Collider(co), bodies, colliders);
    assert_eq!(field_of(r), "emitter");
    assert_eq!(water.emitter(e).unwrap().attachment(), None);
    water
        .attach_emitter(e, Attachment::Collider(co), bodies, colliders)
        .unwrap();
    let h = world.fluids.insert(water);
    world.physics.gravity = Vector::ZERO;
    world.physics.bodies[body].set_linvel(Vector::new(0.0, 0.0, 0.5), true);
    let r = world.step().unwrap();
    assert!(r.emitted > 0);
    let f = &world.fluids[h];
    assert!(
        f.velocities()
            .iter()
            .all(|u| (u.z - 0.5).abs() < 1e-4 && (u.x - 1.0).abs() < 1e-4)
    );
}

/// How a test steps rapier and the fluid each frame.
#[derive(Copy, Clone)]
enum Stepping {
    /// `FluidWorld::step_with_events`.
    WorldWithEvents,
    /// rapier's `PhysicsWorld::step`, then `FluidPipeline::step_world`.
    StepWorld,
    /// rapier's step, then `FluidPipeline::step` with `rapier_substeps` set to this.
    Explicit(usize),
    /// rapier's step, then `FluidPipeline::step_with_parameters`.
    WithParameters,
}

/// The tank with a floating crate, rapier at 2 substeps, stepped 15 frames as `how` says.
fn run_crate_scene(how: Stepping) -> (FluidWorld, FluidHandle, FluidPipeline) {
    let (mut w, h) = tank_world(Solver::dfsph());
    w.physics.integration_parameters.num_solver_iterations = 2;
    let crate_body = w
        .physics
        .insert_body(RigidBodyBuilder::dynamic().translation(Vector::new(0.45, 0.5, 0.3)));
    w.physics.insert_collider(
        ColliderBuilder::cuboid(0.08, 0.08, 0.08).density(500.0),
        Some(crate_body),
    );
    fill(&mut w, h);
    let mut pipeline = FluidPipeline::new();
    for _ in 0..15 {
        if let Stepping::WorldWithEvents = how {
            w.step_with_events(&(), &()).unwrap();
            continue;
        }
        let p = &mut w.physics;
        p.step();
        let (g, dt, fluids) = (p.gravity, p.integration_parameters.dt, &mut w.fluids);
        let (bodies, colliders, bp) = (&mut p.bodies, &p.colliders, &p.broad_phase);
        match how {
            Stepping::StepWorld => pipeline.step_world(p, fluids).map(|_| ()),
            Stepping::Explicit(n) => {
                pipeline.rapier_substeps = n;
                pipeline
                    .step(g, dt, fluids, bodies, colliders, bp)
                    .map(|_| ())
            }
            Stepping::WithParameters => {
                let ip = &p.integration_parameters;
                pipeline
                    .step_with_parameters(g, ip, fluids, bodies, colliders, bp)
                    .map(|_| ())
            }
            Stepping::WorldWithEvents => unreachable!(),
        }
        .unwrap();
    }
    (w, h, pipeline)
}

/// Stepping with rapier's own parameters gives bitwise the results of the explicit step with
/// the same substep count, through `step_world`, `step_with_parameters` and `FluidWorld` (with
/// events), for a scene with a floating body and rapier at 2 substeps; the default 4 substeps
/// give other results (the count matters). Rapier at 0 substeps is refused, naming its field.
#[test]
fn stepping_with_rapiers_parameters_matches_the_explicit_step() {
    let (a, h, _) = run_crate_scene(Stepping::WorldWithEvents);
    let hash = a.fluids[h].state_hash();
    let (b, _, _) = run_crate_scene(Stepping::StepWorld);
    assert_eq!(hash, b.fluids[h].state_hash());
    let (c, _, _) = run_crate_scene(Stepping::Explicit(2));
    assert_eq!(hash, c.fluids[h].state_hash());
    let (mut d, _, mut pipeline) = run_crate_scene(Stepping::WithParameters);
    assert_eq!(hash, d.fluids[h].state_hash());
    assert_eq!(pipeline.rapier_substeps, 2);
    let (e, _, _) = run_crate_scene(Stepping::Explicit(4));
    assert_ne!(hash, e.fluids[h].state_hash());
    // Rapier at 0 substeps: refused, naming its field; nothing changes.
    let p = &mut d.physics;
    p.integration_parameters.num_solver_iterations = 0;
    let r = pipeline.step_with_parameters(
        p.gravity,
        &p.integration_parameters,
        &mut d.fluids,
        &mut p.bodies,
        &p.colliders,
        &p.broad_phase,
    );
    assert_eq!(field_of(r.map(|_| ())), "num_solver_iterations");
    assert_eq!(pipeline.rapier_substeps, 2);
    assert_eq!(d.fluids[h].state_hash(), hash);
}

/// The checks find exactly the particles put inside a solid or outside the container, by id.
#[test]
fn the_checks_name_the_offending_particles() {
    let (mut world, h) = tank_world(Solver::dfsph());
    fill(&mut world, h);
    for _ in 0..10 {
        world.step().unwrap();
    }
    let cavity = Cuboid::new(Vector::new(0.3, 0.4, 0.3));
    let at = Pose::from_translation(Vector::new(0.3, 0.4, 0.3));
    let colliders = &world.physics.colliders;
    check::no_particle_in_solids(&world.fluids[h], colliders).unwrap();
    check::all_inside(&world.fluids[h], &cavity, &at).unwrap();
    // One particle put into the floor, one outside the tank.
    let ids = world.fluids[h]
        .add_particles(&[Vector::new(0.3, -0.05, 0.3), Vector::new(2.0, 0.2, 0.3)])
        .unwrap();
    let f = &world.fluids[h];
    let floor = check::particles_in_solids(f, colliders);
    assert_eq!(floor.len(), 1);
    assert_eq!(floor[0].0, ids.start);
    assert_eq!(
        check::particles_outside(f, &cavity, &at),
        vec![ids.start, ids.start + 1]
    );
    match check::no_particle_in_solids(f, colliders) {
        Err(SphError::ParticlesInSolid { particles }) => assert_eq!(particles, floor),
        other => panic!("{other:?}"),
    }
    match check::all_inside(f, &cavity, &at) {
        Err(SphError::ParticlesOutside { ids: out }) => assert_eq!(out.len(), 2),
        other => panic!("{other:?}"),
    }
    let nan = Pose::from_translation(Vector::splat(Real::NAN));
    assert_eq!(field_of(check::all_inside(f, &cavity, &nan)), "pose");
    let _: &dyn Shape = &cavity;
}

/// A snapshot keeps an emitter's attachment and the removed count, and the restored world
/// steps on bit for bit as the original.
#[cfg(feature = "snapshot")]
#[test]
fn a_snapshot_keeps_attachments_and_removals() {
    use rapier_sph::snapshot;
    let mut world = FluidWorld::new();
    let can = world.physics.insert_body(
        RigidBodyBuilder::kinematic_velocity_based()
            .translation(Vector::new(0.0, 1.0, 0.0))
            .linvel(Vector::new(0.5, 0.0, 0.0)),
    );
    let mut water = Fluid::new(FluidParamsBuilder::water(0.04)).unwrap();
    let spout = water
        .add_emitter(Emitter::new(
            Nozzle::Disk { radius: 0.04 },
            Vector::new(0.2, 0.0, 0.0),
            Vector::NEG_Y,
            1.0,
            300.0,
        ))
        .unwrap();
    let p = &world.physics;
    water
        .attach_emitter(spout, Attachment::Body(can), &p.bodies, &p.colliders)
        .unwrap();
    let ids = water
        .fill_shape(
            &Ball::new(0.1),
            &Pose::from_translation(Vector::new(0.0, 0.3, 0.0)),
        )
        .unwrap();
    water.remove_particles(&[ids.start, ids.start + 1]).unwrap();
    let h = world.fluids.insert(water);
    for _ in 0..5 {
        world.step().unwrap();
    }
    let mut restored = snapshot::from_bytes(&snapshot::to_bytes(&world).unwrap()).unwrap();
    let f = &restored.fluids[h];
    assert_eq!(f.removed(), 2);
    assert_eq!(
        f.emitter(spout).unwrap().attachment(),
        Some(Attachment::Body(can))
    );
    for _ in 0..5 {
        world.step().unwrap();
        restored.step().unwrap();
    }
    assert_eq!(
        world.fluids[h].state_hash(),
        restored.fluids[h].state_hash()
    );
}
