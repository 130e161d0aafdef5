//! Touch events in rapier's style: a collider with `ActiveEvents::COLLISION_EVENTS` is told
//! when a fluid starts and stops touching it, with the count and the ids of the particles;
//! a collider without the flag is told nothing; a particle that touches and is drained by a
//! sink in the same frame counts; bad handles are typed errors.

mod common;

use common::*;
use rapier_sph::rapier3d::prelude::*;
use rapier_sph::{FluidContactKind, Region, Sink, SphError};

const S: Real = 0.05;

/// A particle thrown along +x at a wall (x = 0.5) with restitution 0.5, without gravity.
fn thrown_at_wall(
    flags: ActiveEvents,
) -> (
    rapier_sph::FluidWorld,
    rapier_sph::FluidHandle,
    ColliderHandle,
) {
    let params = rapier_sph::FluidParamsBuilder::water(S)
        .restitution(0.5)
        .build()
        .unwrap();
    let wall = ColliderBuilder::cuboid(0.05, 1.0, 1.0)
        .translation(Vector::new(0.55, 0.0, 0.0))
        .active_events(flags);
    let (mut world, fluid, handles) = world_with(params, vec![wall]);
    world.physics.gravity = Vector::ZERO;
    world.fluids[fluid]
        .add_particles_with_velocities(&[Vector::ZERO], Some(&[Vector::new(3.0, 0.0, 0.0)]))
        .unwrap();
    (world, fluid, handles[0])
}

#[test]
fn a_bouncing_particle_starts_then_stops_touching() {
    let (mut world, fluid, wall) = thrown_at_wall(ActiveEvents::COLLISION_EVENTS);
    let mut kinds = Vec::new();
    let mut touching_frames = 0;
    let id = world.fluids[fluid].ids()[0];
    for _ in 0..30 {
        world.step().unwrap();
        for e in world.pipeline.contact_events() {
            assert_eq!((e.fluid, e.collider), (fluid, wall));
            kinds.push((e.kind, e.particles));
        }
        let ids = world.pipeline.touching(fluid, wall).unwrap();
        if !ids.is_empty() {
            assert_eq!(ids, [id]);
            touching_frames += 1;
        }
    }
    // 0.475 m at 3 m/s: it reaches the wall in the 10th frame, bounces back at 1.5 m/s.
    assert_eq!(
        kinds,
        [
            (FluidContactKind::Started, 1),
            (FluidContactKind::Stopped, 0)
        ]
    );
    // Within the touch distance (one spacing, 0.05 m, of the face) for the frame it arrives,
    // the frame it bounces and at most one more (0.025 m a frame going back).
    assert!((1..=3).contains(&touching_frames), "{touching_frames}");
    assert!(world.fluids[fluid].velocities()[0].x < 0.0);
}

#[test]
fn colliders_without_the_flag_are_told_nothing() {
    let (mut world, fluid, wall) = thrown_at_wall(ActiveEvents::empty());
    for _ in 0..30 {
        world.step().unwrap();
        assert!(world.pipeline.contact_events().is_empty());
    }
    assert!(matches!(
        world.pipeline.touching(fluid, wall),
        Err(SphError::UnknownHandle {
            argument: "collider",
            ..
        })
    ));
    // The force flag alone gives forces, not touch events.
    assert!(world.pipeline.collider_force(wall).is_err());
}

#[test]
fn a_particle_drained_in_the_frame_it_touches_still_counts() {
    let (mut world, fluid, wall) = thrown_at_wall(ActiveEvents::COLLISION_EVENTS);
    // A sink over the layer within the touch distance of the wall's face (x = 0.5): the
    // particle is drained at the end of the substep it first touched in.
    let reach = rapier_sph::boundary_forces::touch_distance(world.fluids[fluid].params());
    let _ = world.fluids[fluid].add_sink(Sink::new(Region::Aabb {
        min: Vector::new(0.5 - reach, -1.0, -1.0),
        max: Vector::new(0.5, 1.0, 1.0),
    }));
    let id = world.fluids[fluid].ids()[0];
    let mut started = 0;
    for _ in 0..30 {
        let drained = world.step().unwrap().drained;
        let events = world.pipeline.contact_events().to_vec();
        if drained > 0 {
            assert_eq!(world.fluids[fluid].len(), 0);
            assert_eq!(events.len(), 1);
            assert_eq!(
                (events[0].kind, events[0].particles),
                (FluidContactKind::Started, 1)
            );
            assert_eq!(world.pipeline.touching(fluid, wall).unwrap(), [id]);
            started += 1;
        }
    }
    assert_eq!(started, 1);
}

#[test]
fn water_resting_on_a_floor_keeps_touching_it() {
    let floor = ColliderBuilder::cuboid(1.0, 0.1, 1.0)
        .translation(Vector::new(0.0, -0.1, 0.0))
        .active_events(ActiveEvents::COLLISION_EVENTS | ActiveEvents::CONTACT_FORCE_EVENTS);
    // Walls without the flag around it: the water rests in a 0.4 m square.
    let wall = |x: Real, z: Real, hx: Real, hz: Real| {
        ColliderBuilder::cuboid(hx, 0.5, hz).translation(Vector::new(x, 0.5, z))
    };
    let colliders = vec![
        floor,
        wall(-0.25, 0.0, 0.05, 0.3),
        wall(0.25, 0.0, 0.05, 0.3),
        wall(0.0, -0.25, 0.3, 0.05),
        wall(0.0, 0.25, 0.3, 0.05),
    ];
    let (mut world, fluid, handles) = world_with(water(S), colliders);
    let floor = handles[0];
    world.fluids[fluid]
        .add_block(Vector::new(-0.2, 0.1, -0.2), Vector::new(0.4, 0.2, 0.4))
        .unwrap();
    let mut events = Vec::new();
    for _ in 0..60 {
        world.step().unwrap();
        events.extend(world.pipeline.contact_events().iter().map(|e| e.kind));
    }
    // It fell 0.1 m, touched, and rests: one event (the walls are told nothing).
    assert_eq!(events, [FluidContactKind::Started]);
    // Every particle within the touch distance of the floor at the frame's end is among the
    // frame's (others may have touched earlier in the frame), at least the 8 × 8 of the
    // bottom layer, not all 4 layers; the count `collider_force` carries.
    let n = world.pipeline.touching(fluid, floor).unwrap().len();
    let f = &world.fluids[fluid];
    let reach = rapier_sph::boundary_forces::touch_distance(f.params());
    let at_end = f.positions().iter().filter(|x| x.y <= reach).count();
    assert!(
        at_end >= 64 && n >= at_end && n < f.len(),
        "{n} touched, {at_end} at the end"
    );
    assert_eq!(world.pipeline.collider_force(floor).unwrap().touching, n);
    // Bad handles are typed errors: a fluid removed before the last step.
    let gone = world
        .fluids
        .insert(rapier_sph::Fluid::new(water(S)).unwrap());
    world.fluids.remove(gone).unwrap();
    world.step().unwrap();
    assert!(world.pipeline.contact_events().is_empty());
    assert!(matches!(
        world.pipeline.touching(gone, floor),
        Err(SphError::UnknownFluid)
    ));
    world.physics.remove_collider(floor);
    world.step().unwrap();
    // Removed: no longer watched, and its fluid was told it stopped.
    assert_eq!(
        world
            .pipeline
            .contact_events()
            .iter()
            .map(|e| e.kind)
            .collect::<Vec<_>>(),
        [FluidContactKind::Stopped]
    );
    assert!(matches!(
        world.pipeline.touching(fluid, floor),
        Err(SphError::UnknownHandle { .. })
    ));
    assert!(matches!(
        world.pipeline.collider_force(floor),
        Err(SphError::UnknownHandle { .. })
    ));
}
