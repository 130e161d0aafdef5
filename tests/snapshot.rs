//! Save and restore: stopping, saving to a file, loading and stepping on gives bitwise the
//! same fluid and rapier state as never having stopped.
#![cfg(feature = "snapshot")]

use rapier_sph::math::Vector;
use rapier_sph::scenes::{DamBreakConfig, dam_break};
use rapier_sph::snapshot::{self, SnapshotError};
use rapier_sph::{FluidParamsBuilder, FluidWorld};
use rapier3d::prelude::{ColliderBuilder, RigidBodyBuilder};

/// A small water dam break (≈ 540 particles) with a dynamic rapier ball dropped into the
/// tank, so rapier's own state (contacts, islands, solver warm-start) is part of the test.
fn scene() -> FluidWorld {
    scene_with(FluidParamsBuilder::water(0.05))
}

fn scene_with(builder: FluidParamsBuilder) -> FluidWorld {
    let params = builder.build().unwrap();
    let mut s = dam_break(&DamBreakConfig::tower(params, 0.6)).unwrap();
    s.world.physics.integration_parameters.dt = 1.0 / 500.0;
    let ball = s
        .world
        .physics
        .insert_body(RigidBodyBuilder::dynamic().translation(Vector::new(1.0, 0.3, 0.15)));
    s.world
        .physics
        .insert_collider(ColliderBuilder::ball(0.08).restitution(0.3), Some(ball));
    s.world
}

/// Every bit of the state the next step reads, as integers.
fn fingerprint(w: &FluidWorld) -> Vec<u32> {
    let mut out = Vec::new();
    for (_, f) in w.fluids.iter() {
        for v in f
            .positions()
            .iter()
            .chain(f.velocities())
            .chain(f.accelerations())
        {
            out.extend(v.to_array().map(f32::to_bits));
        }
        out.extend(
            f.densities()
                .iter()
                .chain(f.pressures())
                .map(|x| x.to_bits()),
        );
        out.extend_from_slice(f.ids());
    }
    for (_, b) in w.physics.bodies.iter() {
        let p = b.position();
        out.extend(p.translation.to_array().map(f32::to_bits));
        out.extend(p.rotation.to_array().map(f32::to_bits));
        out.extend(b.linvel().to_array().map(f32::to_bits));
        out.extend(b.angvel().to_array().map(f32::to_bits));
    }
    out
}

#[test]
fn restore_and_continue_is_bitwise_the_same_as_never_stopping() {
    check_restore(scene(), "wcsph");
}

/// DFSPH keeps warm-start pressures per particle and walls add density: both must survive
/// the round trip.
#[test]
fn restore_and_continue_with_dfsph_and_wall_density() {
    check_restore(
        scene_with(
            FluidParamsBuilder::water(0.05)
                .solver(rapier_sph::solver::Solver::dfsph())
                .wall_density(true),
        ),
        "dfsph",
    );
}

/// The implicit viscosity solve's warm start (the velocity change of its last solve) is
/// kept in the particles' attributes: the restored run starts its solves from it too.
#[test]
fn restore_and_continue_with_implicit_viscosity() {
    let solve = rapier_sph::ViscositySolve::Implicit(rapier_sph::ImplicitViscosity::default());
    check_restore(
        scene_with(
            FluidParamsBuilder::water(0.05)
                .viscosity(50.0)
                .viscosity_solve(solve),
        ),
        "implicit-viscosity",
    );
}

/// The Clavet solver's viscoelastic springs (rest lengths keyed by particle id) are state:
/// without them the restored run would start every spring again at rest length h.
#[test]
fn restore_and_continue_with_clavet_springs() {
    use rapier_sph::solver::{Clavet, Solver, Springs};
    check_restore(
        scene_with(
            FluidParamsBuilder::water(0.05).solver(Solver::Clavet(Clavet {
                springs: Some(Springs {
                    plasticity: 50.0,
                    ..Springs::default()
                }),
                ..Clavet::default()
            })),
        ),
        "clavet springs",
    );
}

/// A dynamic box lying on the water column: the coupling remembers the velocity it left
/// each body with (rapier's change of it over the next frame shapes the path the fluid sees),
/// and that memory must survive the round trip.
#[test]
fn restore_and_continue_with_a_body_on_the_water() {
    let mut w = scene_with(FluidParamsBuilder::water(0.05).wall_density(true));
    let top = w
        .fluids
        .iter()
        .flat_map(|(_, f)| f.positions().iter().map(|p| p.y))
        .fold(0.0, f32::max);
    let body = w
        .physics
        .insert_body(RigidBodyBuilder::dynamic().translation(Vector::new(0.15, top + 0.06, 0.15)));
    w.physics.insert_collider(
        ColliderBuilder::cuboid(0.05, 0.03, 0.05).density(500.0),
        Some(body),
    );
    // Saved once the box floats on the water (it falls for ~0.1 s).
    check_restore_after(w, "body", 150);
}

/// Emitters (their clocks and slots) and sinks (their counters) are part of the state.
#[test]
fn restore_and_continue_with_an_emitter_and_a_sink() {
    use rapier_sph::{Emitter, Nozzle, Region, Sink};
    let mut w = scene();
    let (_, f) = w.fluids.iter_mut().next().unwrap();
    f.add_emitter(
        Emitter::new(
            Nozzle::Square { half_width: 0.06 },
            Vector::new(0.6, 0.5, 0.15),
            Vector::new(0.0, -1.0, 0.0),
            1.0,
            300.0,
        )
        .budget(150),
    )
    .unwrap();
    f.add_sink(Sink::new(Region::Ball {
        center: Vector::new(0.0, 0.0, 0.0),
        radius: 0.15,
    }))
    .unwrap();
    f.set_capacity(Some(2000)).unwrap();
    check_restore(w, "emitter");
}

fn check_restore(a: FluidWorld, name: &str) {
    check_restore_after(a, name, 40);
}

/// Steps `a` `before` times, saves, and checks that the restored copy continues bitwise.
fn check_restore_after(mut a: FluidWorld, name: &str, before: usize) {
    let path = std::env::temp_dir().join(format!(
        "rapier-sph-snapshot-{name}-{}.bin",
        std::process::id()
    ));
    for _ in 0..before {
        a.step().unwrap();
    }
    snapshot::save(&a, &path).unwrap();
    // The ball is moving and touching things: rapier's state is not trivial.
    for _ in 0..60 {
        a.step().unwrap();
    }
    let mut b = snapshot::load(&path).unwrap();
    for _ in 0..60 {
        b.step().unwrap();
    }
    let (fa, fb) = (fingerprint(&a), fingerprint(&b));
    assert_eq!(fa.len(), fb.len());
    let differing = fa.iter().zip(&fb).filter(|(x, y)| x != y).count();
    assert_eq!(differing, 0, "{differing} of {} words differ", fa.len());
    // And the run did something: the state moved since the snapshot.
    let c = snapshot::load(&path).unwrap();
    assert_ne!(fingerprint(&c), fa);
    let size = std::fs::metadata(&path).unwrap().len();
    println!(
        "snapshot of {} particles: {size} bytes",
        c.fluids.num_particles()
    );
    std::fs::remove_file(&path).ok();
}

#[test]
fn bad_files_are_refused() {
    let mut w = scene();
    w.step().unwrap();
    let bytes = snapshot::to_bytes(&w).unwrap();
    assert!(matches!(
        snapshot::from_bytes(b"hello"),
        Err(SnapshotError::NotASnapshot)
    ));
    assert!(matches!(
        snapshot::from_bytes(&bytes[..bytes.len() / 2]),
        Err(SnapshotError::Encoding(_))
    ));
    let mut other = bytes.clone();
    other[16] = 99;
    assert!(matches!(
        snapshot::from_bytes(&other),
        Err(SnapshotError::Version { found: 99 })
    ));
    assert!(matches!(
        snapshot::load("/nonexistent/state.bin"),
        Err(SnapshotError::Io { .. })
    ));
    assert!(snapshot::from_bytes(&bytes).is_ok());
}

/// Loading reads only regular files within the limit: `/dev/zero`, a folder and a file past
/// the limit are refused before they are read; a corrupted byte anywhere fails the checksum.
#[test]
fn loads_are_bounded_and_checked() {
    let dir =
        std::env::temp_dir().join(format!("rapier-sph-snapshot-bounds-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut w = scene();
    w.step().unwrap();
    let path = dir.join("state.bin");
    snapshot::save(&w, &path).unwrap();
    let size = std::fs::metadata(&path).unwrap().len();
    assert!(snapshot::load_with_limit(&path, size).is_ok());
    match snapshot::load_with_limit(&path, size - 1) {
        Err(SnapshotError::Io { source, .. }) => assert!(source.to_string().contains("limit")),
        other => panic!("expected an I/O error, got {:?}", other.err()),
    }
    assert!(matches!(
        snapshot::load(&dir),
        Err(SnapshotError::Io { .. })
    ));
    if std::path::Path::new("/dev/zero").exists() {
        assert!(matches!(
            snapshot::load("/dev/zero"),
            Err(SnapshotError::Io { .. })
        ));
    }
    // One byte of the payload changed: the checksum says so.
    let mut bytes = snapshot::to_bytes(&w).unwrap();
    let k = bytes.len() / 2;
    bytes[k] ^= 0x10;
    assert!(matches!(
        snapshot::from_bytes(&bytes),
        Err(SnapshotError::Checksum { .. })
    ));
    // Bytes added at the end: the length says so.
    let mut longer = snapshot::to_bytes(&w).unwrap();
    longer.push(0);
    assert!(matches!(
        snapshot::from_bytes(&longer),
        Err(SnapshotError::Encoding(_))
    ));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A mixture (`rapier_sph::mixture`): its phases travel with the parameters and its
/// fractions with the particles' attributes, so the restored copy continues bitwise (the
/// fractions set the particles' masses, which the positions then follow).
#[test]
fn restore_and_continue_with_a_mixture() {
    let mixture = rapier_sph::mixture::Mixture::oil_in_water(5.6e-5, 1e-5);
    let mut w = scene_with(FluidParamsBuilder::water(0.05).mixture(mixture));
    for (_, f) in w.fluids.iter_mut() {
        f.set_fractions(&[0.5, 0.5]).unwrap();
    }
    check_restore(w, "mixture");
}
