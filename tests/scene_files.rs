//! Scene files: the shipped scenes load and build, the dam break file builds exactly the
//! example's scene, RON written back reads back equal, and mistakes are reported with the
//! file, line and field.
#![cfg(feature = "scene")]

use rapier_sph::FluidParamsBuilder;
use rapier_sph::math::Vector;
use rapier_sph::scene_file::{Positive, Preset, SceneError, SceneFile};
use rapier_sph::scenes::{DamBreakConfig, ObstacleCourseConfig, dam_break, obstacle_course};
use rapier_sph::{FluidWorld, Region};
use std::path::Path;

fn scenes_dir() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes"))
}

#[test]
fn every_shipped_scene_loads_and_builds() {
    let mut n = 0;
    for entry in std::fs::read_dir(scenes_dir()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "ron") {
            let (scene, built) = SceneFile::load_and_build(&path).unwrap_or_else(|e| panic!("{e}"));
            // Every scene has fluid: particles at the start or an emitter.
            let emits = built
                .fluids
                .iter()
                .any(|h| built.world.fluids[*h].emitters().next().is_some());
            assert!(
                built.world.fluids.num_particles() > 0 || emits,
                "{}",
                path.display()
            );
            assert!(built.frames >= 1 && built.steps_per_frame >= 1);
            // The frame time is a whole number of steps.
            let frame = built.steps_per_frame as f32 * built.dt;
            assert!((frame * scene.frame_rate.0 - 1.0).abs() < 1e-5);
            n += 1;
        }
    }
    assert!(n >= 4, "found {n} scenes");
}

#[test]
fn the_reference_scene_has_every_shape() {
    let (scene, built) = SceneFile::load_and_build(scenes_dir().join("reference.ron")).unwrap();
    assert_eq!(scene.bodies[0].colliders.len(), 21); // every parry shape, TriMesh inline and from a file, Polyline with and without indices
    assert_eq!(built.world.physics.colliders.len(), 23);
    assert_eq!(built.world.physics.bodies.len(), 3);
    // 7 × 7 × 10 particles in the block (0.3/0.04 → 7, 0.4/0.04 → 10), two singles, the
    // fills: the 6 cm ball on the 3 × 3 × 3 lattice at 4 cm less its 8 corners (0.069 m from
    // the center), and the 10 cm can, 2 × 2 × 2.
    let f = &built.world.fluids[built.fluids[0]];
    assert_eq!(f.len(), 7 * 7 * 10 + 2 + 19 + 8);
    // The third emitter rides the can's body.
    let can = built
        .named_colliders
        .iter()
        .find(|(n, _)| n == "can")
        .unwrap()
        .1;
    let body = built.world.physics.colliders[can].parent().unwrap();
    let attached: Vec<_> = f.emitters().filter_map(|(_, e)| e.attachment()).collect();
    assert_eq!(attached, [rapier_sph::Attachment::Body(body)]);
    assert_eq!(f.params().viscosity, 0.5);
    assert_eq!(f.params().wall_viscosity, 0.1);
    assert_eq!(
        f.params().solver,
        rapier_sph::Solver::Dfsph(rapier_sph::Dfsph {
            max_density_error: 0.001,
            warm_start: 0.75,
            ..Default::default()
        })
    );
    assert!(f.params().wall_density);
    // The OBJ ramp was read and scaled: 8 triangles, 0.5 m long.
    let ramp = built
        .world
        .physics
        .colliders
        .iter()
        .filter_map(|(_, c)| c.shape().as_trimesh())
        .find(|t| t.indices().len() == 8)
        .expect("the ramp");
    let aabb = ramp.local_aabb();
    assert!((aabb.maxs.x - aabb.mins.x - 0.5).abs() < 1e-6);
}

#[test]
fn the_dam_break_file_builds_the_examples_scene() {
    let (_, built) = SceneFile::load_and_build(scenes_dir().join("dam_break.ron")).unwrap();
    let code = dam_break(&DamBreakConfig::tower(
        FluidParamsBuilder::paper().build().unwrap(),
        1.0,
    ))
    .unwrap();
    let a = &built.world.fluids[built.fluids[0]];
    let b = &code.world.fluids[code.fluid];
    assert_eq!(a.params(), b.params());
    assert_eq!(a.positions(), b.positions());
    assert_eq!(built.world.physics.colliders.len(), 6);
    let mut from_file: Vec<_> = built
        .world
        .physics
        .colliders
        .iter()
        .map(|(_, c)| c.compute_aabb())
        .collect();
    let mut from_code: Vec<_> = code
        .world
        .physics
        .colliders
        .iter()
        .map(|(_, c)| c.compute_aabb())
        .collect();
    let key = |a: &rapier3d::parry::bounding_volume::Aabb| {
        a.mins.to_array().map(|x| (x * 1e4).round() as i64)
    };
    from_file.sort_by_key(key);
    from_code.sort_by_key(key);
    for (a, b) in from_file.iter().zip(&from_code) {
        assert!(
            (a.mins - b.mins).abs().max_element() < 1e-5,
            "{a:?} vs {b:?}"
        );
        assert!(
            (a.maxs - b.maxs).abs().max_element() < 1e-5,
            "{a:?} vs {b:?}"
        );
    }
}

#[test]
fn written_ron_reads_back_equal() {
    let scene = SceneFile::load(scenes_dir().join("reference.ron")).unwrap();
    let text = scene.to_ron();
    assert_eq!(SceneFile::parse(&text, "written.ron").unwrap(), scene);
}

fn parse_err(text: &str) -> (usize, usize, String, String) {
    match SceneFile::parse(text, "bad.ron") {
        Err(SceneError::Parse {
            line,
            column,
            field,
            message,
            ..
        }) => (line, column, field, message),
        other => panic!("expected a parse error, got {other:?}"),
    }
}

const GOOD: &str = "Scene(
    duration: 1.0,
    fluids: [
        Fluid(
            preset: Water(spacing: 0.1),
            blocks: [Block(min: (0.0, 0.0, 0.0), size: (0.5, 0.5, 0.5))],
        ),
    ],
    bodies: [
        Body(colliders: [
            Collider(shape: Ball(radius: 0.5)),
        ]),
    ],
)";

#[test]
fn mistakes_name_the_file_line_and_field() {
    assert!(SceneFile::parse(GOOD, "good.ron").is_ok());

    // An unknown field.
    let (line, _, field, message) = parse_err(&GOOD.replace("radius: 0.5", "raduis: 0.5"));
    assert_eq!(line, 11);
    assert!(field.starts_with("bodies[0].colliders[0].shape"), "{field}");
    assert!(message.contains("raduis"), "{message}");

    // A bad value: a negative radius.
    let (line, _, field, message) = parse_err(&GOOD.replace("radius: 0.5", "radius: -0.5"));
    assert_eq!(line, 11);
    assert!(field.contains("radius"), "{field}");
    assert!(message.contains("positive"), "{message}");

    // A size with a zero component.
    let (line, _, field, _) =
        parse_err(&GOOD.replace("size: (0.5, 0.5, 0.5)", "size: (0.5, 0.0, 0.5)"));
    assert_eq!(line, 6);
    assert_eq!(field, "fluids[0].blocks[0].size");

    // Parameters checked as a whole: h below the spacing, reported at the fluid's entry
    // with the parameter's name.
    let (line, _, field, message) = parse_err(&GOOD.replace(
        "preset: Water(spacing: 0.1),",
        "preset: Water(spacing: 0.1),\n            smoothing_length: 0.05,",
    ));
    assert!((4..=9).contains(&line), "{line}");
    assert!(field.starts_with("fluids[0]"), "{field}");
    assert!(message.contains("smoothing_length"), "{message}");

    // A missing required field.
    let (_, _, _, message) = parse_err(&GOOD.replace("duration: 1.0,", ""));
    assert!(message.contains("duration"), "{message}");

    // Broken syntax.
    let (line, _, _, _) = parse_err(&GOOD.replace("Ball(radius: 0.5)),", "Ball(radius: 0.5),"));
    assert!(line >= 11, "{line}");

    // The message carries it all.
    let err = SceneFile::parse(&GOOD.replace("radius: 0.5", "radius: -0.5"), "scenes/x.ron")
        .unwrap_err()
        .to_string();
    assert!(err.starts_with("scenes/x.ron:11:"), "{err}");
    assert!(err.contains("radius"), "{err}");
}

#[test]
fn build_errors_name_the_field() {
    let text = GOOD.replace(
        "Ball(radius: 0.5)",
        "TriMeshFile(path: \"no_such_file.obj\")",
    );
    // Built from a value (no text): the field, no line.
    let scene = SceneFile::parse(&text, "bad.ron").unwrap();
    match scene.build(Path::new("bad.ron"), scenes_dir()) {
        Err(SceneError::Invalid { field, message, .. }) => {
            assert_eq!(field, "bodies[0].colliders[0].shape");
            assert!(message.contains("no_such_file.obj"), "{message}");
        }
        other => panic!("expected an invalid scene, got {:?}", other.err()),
    }
    // Loaded from a file: the same error at the field's line.
    let dir = std::env::temp_dir().join(format!("rapier_sph_build_err_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("bad.ron");
    std::fs::write(&file, &text).unwrap();
    match SceneFile::load_and_build(&file) {
        Err(SceneError::Parse {
            line,
            field,
            message,
            ..
        }) => {
            assert_eq!(line, 11);
            assert_eq!(field, "bodies[0].colliders[0].shape");
            assert!(message.contains("no_such_file.obj"), "{message}");
        }
        other => panic!("expected a located error, got {:?}", other.err()),
    }
    std::fs::remove_dir_all(&dir).unwrap();
    // A degenerate hull is found as the file is read, at its line.
    let text = GOOD.replace(
        "Ball(radius: 0.5)",
        "ConvexHull(points: [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0)])",
    );
    let (line, _, field, message) = parse_err(&text);
    assert_eq!(line, 11);
    assert_eq!(field, "bodies[0].colliders[0].shape");
    assert!(message.contains("degenerate"), "{message}");
    assert!(matches!(
        SceneFile::load(scenes_dir().join("missing.ron")),
        Err(SceneError::Io { .. })
    ));
}

/// Same rapier world: the same bodies (type, pose, velocities, mass) and colliders (shape
/// type, pose, bounding box, parent, sensor, mass), in the same order. Poses and boxes are
/// compared exactly: the file writes the f32 values the Rust builder computes.
fn assert_same_rapier_world(a: &FluidWorld, b: &FluidWorld) {
    let (pa, pb) = (&a.physics, &b.physics);
    assert_eq!(pa.bodies.len(), pb.bodies.len(), "bodies");
    assert_eq!(pa.colliders.len(), pb.colliders.len(), "colliders");
    for ((ha, ba), (hb, bb)) in pa.bodies.iter().zip(pb.bodies.iter()) {
        assert_eq!(ha, hb);
        assert_eq!(ba.body_type(), bb.body_type(), "body {ha:?}");
        assert_eq!(ba.position(), bb.position(), "body {ha:?}");
        assert_eq!(ba.linvel(), bb.linvel(), "body {ha:?}");
        assert_eq!(ba.angvel(), bb.angvel(), "body {ha:?}");
        assert_eq!(ba.mass(), bb.mass(), "body {ha:?}");
        assert_eq!(ba.colliders(), bb.colliders(), "body {ha:?}");
    }
    for ((ha, ca), (hb, cb)) in pa.colliders.iter().zip(pb.colliders.iter()) {
        assert_eq!(ha, hb);
        let what = format!("collider {ha:?} ({:?})", ca.shape().shape_type());
        assert_eq!(ca.shape().shape_type(), cb.shape().shape_type(), "{what}");
        assert_eq!(ca.position(), cb.position(), "{what}");
        assert_eq!(ca.compute_aabb(), cb.compute_aabb(), "{what}");
        assert_eq!(ca.parent(), cb.parent(), "{what}");
        assert_eq!(ca.is_sensor(), cb.is_sensor(), "{what}");
        assert_eq!(ca.mass(), cb.mass(), "{what}");
        if let (Some(ta), Some(tb)) = (ca.shape().as_trimesh(), cb.shape().as_trimesh()) {
            assert_eq!(ta.vertices(), tb.vertices(), "{what}");
            assert_eq!(ta.indices(), tb.indices(), "{what}");
        }
        if let (Some(ta), Some(tb)) = (ca.shape().as_heightfield(), cb.shape().as_heightfield()) {
            let (ha, hb) = (ta.heights(), tb.heights());
            assert_eq!((ha.nrows(), ha.ncols()), (hb.nrows(), hb.ncols()), "{what}");
            assert_eq!(ha.data(), hb.data(), "{what}");
            assert_eq!(ta.scale(), tb.scale(), "{what}");
        }
    }
}

#[test]
fn the_obstacle_course_file_is_the_rust_scene() {
    let path = scenes_dir().join("obstacle_course.ron");
    let (mut scene, built) = SceneFile::load_and_build(&path).unwrap();
    let Preset::Water { spacing } = scene.fluids[0].preset else {
        panic!("the course is water");
    };
    // The file at its own spacing (3 cm, the example's default) against the Rust scene with
    // the default configuration: the same world, emitter and sink.
    let params = |s: f32| FluidParamsBuilder::water(s).build().unwrap();
    let code = obstacle_course(&ObstacleCourseConfig::new(params(spacing.0))).unwrap();
    assert_same_rapier_world(&built.world, &code.world);
    assert_eq!(built.dt, code.world.physics.integration_parameters.dt);
    assert_eq!(built.steps_per_frame, 1);
    let (fa, fb) = (
        &built.world.fluids[built.fluids[0]],
        &code.world.fluids[code.fluid],
    );
    assert_eq!(fa.params(), fb.params());
    assert_eq!(fa.len(), 0);
    assert_eq!(fb.len(), 0);
    let emitters = |f: &rapier_sph::Fluid| f.emitters().map(|(_, e)| e.clone()).collect::<Vec<_>>();
    assert_eq!(emitters(fa).len(), 1);
    assert_eq!(
        emitters(fa),
        emitters(fb),
        "emitters (every field and the state)"
    );
    assert_eq!(fa.capacity(), fb.capacity());
    let sink = |f: &rapier_sph::Fluid| {
        let r = code_sink_region(f);
        assert!(matches!(r, Region::Aabb { .. }));
        r
    };
    assert_eq!(sink(fa), sink(fb));
    let bucket = built
        .named_colliders
        .iter()
        .find(|(n, _)| n == "bucket")
        .expect("the bucket sensor is named")
        .1;
    assert_eq!(bucket, code.bucket_sensor);

    // The real check: both run. At 5 cm (the file with its spacing changed; the emitter's
    // rate follows as a fraction of the nozzle's blocking rate, as in the Rust scene) for
    // one simulated second, 60 frames: about 200 particles emitted and some of the flow down
    // the ramp, past the pegs and into the funnel. Built in the same order, the two worlds
    // are the same computation, so the counts and the particles are compared exactly.
    scene.fluids[0].preset = Preset::Water {
        spacing: Positive(0.05),
    };
    let mut a = scene.build(&path, scenes_dir()).unwrap();
    let mut b = obstacle_course(&ObstacleCourseConfig::new(params(0.05))).unwrap();
    assert_same_rapier_world(&a.world, &b.world);
    let (ha, hb) = (a.fluids[0], b.fluid);
    let (mut emitted, mut drained) = (0, 0);
    for frame in 1..=60 {
        let ra = a.world.step().unwrap().clone();
        let rb = b.world.step().unwrap().clone();
        assert_eq!(
            (
                ra.particles,
                ra.emitted,
                ra.drained,
                ra.quarantined,
                ra.emitter_blocked
            ),
            (
                rb.particles,
                rb.emitted,
                rb.drained,
                rb.quarantined,
                rb.emitter_blocked
            ),
            "frame {frame}: counters (particles, emitted, drained, quarantined, blocked)"
        );
        assert_eq!(ra.substeps, rb.substeps, "frame {frame}: substeps");
        emitted += ra.emitted;
        drained += ra.drained;
    }
    let (fa, fb) = (&a.world.fluids[ha], &b.world.fluids[hb]);
    assert!(emitted > 100, "only {emitted} particles emitted");
    assert_eq!(fa.len() + drained, emitted);
    assert_eq!(fa.ids(), fb.ids());
    let bits = |v: &[Vector]| {
        v.iter()
            .flat_map(|p| p.to_array().map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    assert!(
        bits(fa.positions()) == bits(fb.positions()),
        "positions differ"
    );
    assert!(
        bits(fa.velocities()) == bits(fb.velocities()),
        "velocities differ"
    );
    // The paddle wheel (kinematic, spinning from the file's `angvel`) and the crates.
    for (x, y) in a
        .bodies
        .iter()
        .zip(b.world.physics.bodies.iter().map(|(h, _)| h))
    {
        let (x, y) = (&a.world.physics.bodies[*x], &b.world.physics.bodies[y]);
        assert_eq!(x.position(), y.position());
        assert_eq!(x.angvel(), y.angvel());
    }
    let wheel = &a.world.physics.bodies[a.bodies[1]];
    let off = wheel
        .rotation()
        .angle_between(rapier_sph::math::Rotation::from_rotation_z(4.0));
    // 4 rad/s about z for 1 s. Tolerance: 60 f32 rotation updates, each exact to a few
    // 1e-7 rad; 1e-3 rad still tells a wheel that turned from one that did not (or turned at
    // another rate) by three orders of magnitude.
    assert!(off < 1e-3, "the wheel is {off} rad away from 4 rad about z");
    eprintln!(
        "obstacle course file vs Rust scene, 60 frames at 5 cm: {emitted} emitted, {drained} drained, {} live, identical",
        fa.len()
    );
}

fn code_sink_region(f: &rapier_sph::Fluid) -> Region {
    let mut regions = f.sinks().map(|(_, s)| s.region());
    let r = regions.next().expect("a sink");
    assert!(regions.next().is_none(), "one sink");
    r
}

/// A scene with an emitter, two sinks (one naming a collider), a capacity and a spinning
/// kinematic body; the error tests below each break one line of it.
const SOURCES: &str = "Scene(
    duration: 1.0,
    fluids: [
        Fluid(
            preset: Water(spacing: 0.1),
            emitters: [
                Emitter(
                    nozzle: Disk(radius: 0.2),
                    position: (0.0, 1.0, 0.0),
                    direction: (1.0, 0.0, 0.0),
                    speed: 1.5,
                    rate: 40.0,
                    start: 0.5,
                    stop: 2.0,
                    budget: 100,
                ),
            ],
            sinks: [
                Sink(region: Collider(name: \"drain\", reach: 0.05)),
                Sink(region: Aabb(min: (-9.0, -9.0, -9.0), max: (9.0, -1.0, 9.0))),
            ],
            capacity: 500,
        ),
    ],
    bodies: [
        Body(colliders: [
            Collider(name: \"drain\", shape: Ball(radius: 0.5), sensor: true),
            Collider(name: \"floor\", shape: Cuboid(half_extents: (1.0, 0.1, 1.0))),
        ]),
        Body(kind: KinematicVelocityBased, angvel: (0.0, 0.0, 2.0), colliders: [
            Collider(shape: Cuboid(half_extents: (0.1, 0.1, 0.1))),
        ]),
    ],
)";

#[test]
fn emitters_sinks_and_capacity_build() {
    let scene = SceneFile::parse(SOURCES, "sources.ron").unwrap();
    let built = scene.build(Path::new("sources.ron"), scenes_dir()).unwrap();
    let f = &built.world.fluids[built.fluids[0]];
    assert_eq!(f.capacity(), Some(500));
    let expected = rapier_sph::Emitter::new(
        rapier_sph::Nozzle::Disk { radius: 0.2 },
        Vector::new(0.0, 1.0, 0.0),
        Vector::X,
        1.5,
        40.0,
    )
    .active_between(0.5, 2.0)
    .budget(100);
    let emitters: Vec<_> = f.emitters().map(|(_, e)| e.clone()).collect();
    assert_eq!(emitters, vec![expected]);
    let drain = built.named_colliders[0].clone();
    assert_eq!(drain.0, "drain");
    let regions: Vec<_> = f.sinks().map(|(_, s)| s.region()).collect();
    assert_eq!(
        regions,
        vec![
            Region::NearCollider {
                handle: drain.1,
                reach: Some(0.05)
            },
            Region::Aabb {
                min: Vector::splat(-9.0),
                max: Vector::new(9.0, -1.0, 9.0)
            },
        ]
    );
    let spinner = &built.world.physics.bodies[built.bodies[1]];
    assert_eq!(spinner.angvel(), Vector::new(0.0, 0.0, 2.0));
    // Written back, read back equal.
    assert_eq!(SceneFile::parse(&scene.to_ron(), "w.ron").unwrap(), scene);
}

#[test]
fn a_ball_sink_reads_center_and_the_old_spelling_centre() {
    let aabb = "Aabb(min: (-9.0, -9.0, -9.0), max: (9.0, -1.0, 9.0))";
    let ball = |field: &str| {
        let text = SOURCES.replace(
            aabb,
            &format!("Ball({field}: (1.0, 2.0, 3.0), radius: 0.5)"),
        );
        let scene = SceneFile::parse(&text, "ball.ron").unwrap();
        let built = scene.build(Path::new("ball.ron"), scenes_dir()).unwrap();
        let f = &built.world.fluids[built.fluids[0]];
        f.sinks()
            .map(|(_, s)| s.region())
            .nth(1)
            .expect("two sinks")
    };
    let expected = Region::Ball {
        center: Vector::new(1.0, 2.0, 3.0),
        radius: 0.5,
    };
    assert_eq!(ball("center"), expected);
    assert_eq!(ball("centre"), expected);
}

#[test]
fn emitter_and_sink_mistakes_name_the_line_and_field() {
    assert!(SceneFile::parse(SOURCES, "good.ron").is_ok());
    let bad = |from: &str, to: &str| {
        assert!(SOURCES.contains(from), "{from}");
        parse_err(&SOURCES.replacen(from, to, 1))
    };
    // A negative rate, at its line.
    let (line, _, field, message) = bad("rate: 40.0", "rate: -40.0");
    assert_eq!((line, field.as_str()), (12, "fluids[0].emitters[0].rate"));
    assert!(message.contains("positive"), "{message}");
    // A speed that is not a number.
    let (line, _, field, _) = bad("speed: 1.5", "speed: NaN");
    assert_eq!((line, field.as_str()), (11, "fluids[0].emitters[0].speed"));
    // A zero-size nozzle.
    let (line, _, field, _) = bad("Disk(radius: 0.2)", "Disk(radius: 0.0)");
    assert_eq!(line, 8);
    assert!(field.starts_with("fluids[0].emitters[0].nozzle"), "{field}");
    assert!(field.ends_with("radius"), "{field}");
    // An unknown field.
    let (line, _, field, message) = bad("budget: 100", "budgte: 100");
    assert_eq!(line, 15);
    assert!(field.starts_with("fluids[0].emitters[0]"), "{field}");
    assert!(message.contains("budgte"), "{message}");
    // A negative budget (an unsigned count).
    let (line, _, field, _) = bad("budget: 100", "budget: -1");
    assert_eq!((line, field.as_str()), (15, "fluids[0].emitters[0].budget"));
    // Checked as a whole where the entry ends: stop before start, a zero direction, both
    // rates, no rate.
    for (from, to, what) in [
        ("stop: 2.0", "stop: 0.1", "stop"),
        (
            "direction: (1.0, 0.0, 0.0)",
            "direction: (0.0, 0.0, 0.0)",
            "direction",
        ),
        (
            "rate: 40.0",
            "rate: 40.0, rate_fraction: 0.5",
            "rate_fraction",
        ),
        ("rate: 40.0,", "", "rate"),
    ] {
        let (line, _, field, message) = bad(from, to);
        assert!((7..=16).contains(&line), "{what}: line {line}");
        assert_eq!(field, "fluids[0].emitters[0]", "{what}");
        assert!(message.contains(what), "{what}: {message}");
    }
    // A sink box upside down, a zero ball, a negative reach.
    let (line, _, field, message) = bad("max: (9.0, -1.0, 9.0)", "max: (9.0, -10.0, 9.0)");
    assert_eq!((line, field.as_str()), (20, "fluids[0].sinks[1]"));
    assert!(message.contains("max"), "{message}");
    let (line, _, field, _) = bad("reach: 0.05", "reach: -0.05");
    assert_eq!(line, 19);
    assert!(field.ends_with("reach"), "{field}");
    // A sink naming no collider: reported at the name, listing the names there are.
    let (line, _, field, message) = bad(
        "Collider(name: \"drain\", reach",
        "Collider(name: \"drian\", reach",
    );
    assert_eq!(line, 19);
    assert!(field.starts_with("fluids[0].sinks[0].region"), "{field}");
    assert!(
        message.contains("`drian`") && message.contains("`drain`"),
        "{message}"
    );
    // Two colliders with one name: reported at the second.
    let (line, _, field, message) = bad("name: \"floor\"", "name: \"drain\"");
    assert_eq!(line, 28);
    assert!(field.starts_with("bodies[0].colliders[1].name"), "{field}");
    assert!(message.contains("drain"), "{message}");
    // Capacity: zero, negative.
    let (line, _, field, message) = bad("capacity: 500", "capacity: 0");
    assert!((4..=24).contains(&line), "{line}");
    assert_eq!(field, "fluids[0]");
    assert!(message.contains("capacity"), "{message}");
    let (line, _, field, _) = bad("capacity: 500", "capacity: -5");
    assert_eq!((line, field.as_str()), (22, "fluids[0].capacity"));
    // A velocity on a body that cannot keep one.
    let (line, _, field, message) = bad(
        "kind: KinematicVelocityBased",
        "kind: KinematicPositionBased",
    );
    assert!((30..=32).contains(&line), "{line}");
    assert_eq!(field, "bodies[1]");
    assert!(message.contains("KinematicVelocityBased"), "{message}");
    // The message names the file and line.
    let err = SceneFile::parse(
        &SOURCES.replacen("rate: 40.0", "rate: -40.0", 1),
        "scenes/x.ron",
    )
    .unwrap_err()
    .to_string();
    assert!(err.starts_with("scenes/x.ron:12:"), "{err}");
}

#[test]
fn a_capacity_below_the_initial_particles_is_refused_at_its_line() {
    let text = SOURCES.replacen(
        "capacity: 500",
        "capacity: 5, blocks: [Block(min: (0.0, 0.0, 0.0), size: (0.5, 0.5, 0.5))]",
        1,
    );
    let (line, _, field, message) = parse_err(&text);
    assert_eq!(line, 22);
    assert_eq!(field, "fluids[0].capacity");
    assert!(message.contains("below the 125 particles"), "{message}");
}

#[test]
fn an_impossible_capacity_is_refused_at_its_line_not_an_abort() {
    // 10^15 particles: more than a fluid's u32 ids can name, and petabytes of memory.
    let (line, _, field, message) =
        parse_err(&SOURCES.replacen("capacity: 500", "capacity: 1000000000000000", 1));
    assert_eq!(line, 22);
    assert_eq!(field, "fluids[0].capacity");
    assert!(message.contains("MAX_PARTICLES"), "{message}");
    // 10^9 particles: ids enough, but about 1.6 TB for DFSPH (refused unless the machine
    // has that much memory and swap, or always grants memory: `vm.overcommit_memory = 1`).
    if reservations_are_bounded_below(1.5e12) {
        let (line, _, field, message) =
            parse_err(&SOURCES.replacen("capacity: 500", "capacity: 1000000000", 1));
        assert_eq!((line, field.as_str()), (22, "fluids[0].capacity"));
        assert!(message.contains("memory"), "{message}");
    }
}

/// Whether a reservation of `bytes` must fail on this machine: Linux with an overcommit policy
/// that refuses reservations beyond RAM + swap (not `1`), and less RAM + swap than `bytes`.
fn reservations_are_bounded_below(bytes: f64) -> bool {
    let policy = std::fs::read_to_string("/proc/sys/vm/overcommit_memory");
    let Ok(info) = std::fs::read_to_string("/proc/meminfo") else {
        return false;
    };
    let kib = |key: &str| -> f64 {
        info.lines()
            .find(|l| l.starts_with(key))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|v| v.parse().ok())
            .unwrap_or(f64::INFINITY)
    };
    policy.is_ok_and(|p| p.trim() != "1") && (kib("MemTotal:") + kib("SwapTotal:")) * 1024.0 < bytes
}

#[test]
fn the_module_docs_example_parses() {
    // The full example in `scene_file`'s documentation (its mesh file does not exist, so it
    // is parsed, not built).
    let src = include_str!("../src/scene_file/mod.rs");
    let start = src.find("//! ```ron\n").expect("the example") + "//! ```ron\n".len();
    let end = start + src[start..].find("//! ```\n").unwrap();
    let text: String = src[start..end]
        .lines()
        .map(|l| {
            l.strip_prefix("//!")
                .unwrap()
                .strip_prefix(' ')
                .unwrap_or("")
        })
        .collect::<Vec<_>>()
        .join("\n");
    let scene = SceneFile::parse(&text, "docs.ron").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.fluids[0].emitters.len(), 2);
    assert_eq!(scene.fluids[0].sinks.len(), 2);
    assert_eq!(scene.fluids[0].fill.len(), 2);
}

/// A fluid's solver and wall densities come from the file, unset fields keep the solver's
/// defaults, and bad solver values are named at their line like every other field.
#[test]
fn solvers_come_from_the_file() {
    use rapier_sph::solver::{Clavet, Dfsph, Pbf, Solver, Springs};
    let with = |extra: &str| {
        GOOD.replace(
            "preset: Water(spacing: 0.1),",
            &format!("preset: Water(spacing: 0.1), {extra}"),
        )
    };
    for (text, expected) in [
        ("solver: Wcsph,", Solver::Wcsph),
        ("solver: Dfsph(),", Solver::dfsph()),
        (
            "solver: Dfsph(max_density_error: 0.0005, warm_start: 0.5),",
            Solver::Dfsph(Dfsph {
                max_density_error: 0.0005,
                warm_start: 0.5,
                ..Dfsph::default()
            }),
        ),
        (
            "solver: Pbf(iterations: 8),",
            Solver::Pbf(Pbf {
                iterations: 8,
                ..Pbf::default()
            }),
        ),
        (
            "solver: Clavet(stiffness: 2.0, cohesion: 0.5, springs: Some(Springs(plasticity: 2.0))),",
            Solver::Clavet(Clavet {
                stiffness: 2.0,
                cohesion: 0.5,
                springs: Some(Springs {
                    plasticity: 2.0,
                    ..Springs::default()
                }),
                ..Clavet::default()
            }),
        ),
    ] {
        let scene =
            SceneFile::parse(&with(text), "s.ron").unwrap_or_else(|e| panic!("{text}: {e}"));
        assert_eq!(scene.fluids[0].params().unwrap().solver, expected, "{text}");
    }
    let walls = SceneFile::parse(&with("wall_density: true,"), "s.ron").unwrap();
    assert!(walls.fluids[0].params().unwrap().wall_density);
    // WCSPH's pressure forces: Adami's walls need the walls' density, refused without it.
    let adami = "solver: Wcsph, wall_density: true, wcsph_pressure: Adami,";
    let scene = SceneFile::parse(&with(adami), "s.ron").unwrap();
    assert_eq!(
        scene.fluids[0].params().unwrap().wcsph_pressure,
        rapier_sph::WcsphPressure::Adami
    );
    let no_walls = "solver: Wcsph, wall_density: false, wcsph_pressure: Adami,";
    let (_, _, _, message) = parse_err(&with(no_walls));
    assert!(message.contains("wcsph_pressure"), "{message}");
    // A negative value: refused by its type, at its line.
    let (line, _, field, _) = parse_err(&with("solver: Dfsph(warm_start: -0.5),"));
    assert_eq!(line, 5);
    assert!(field.ends_with("warm_start"), "{field}");
    // Out of range for the solver: refused by the parameter check, naming the field.
    let (_, _, _, message) = parse_err(&with("solver: Dfsph(warm_start: 1.5),"));
    assert!(message.contains("warm_start"), "{message}");
    // A misspelt field.
    let (_, _, _, message) = parse_err(&with("solver: Pbf(iteratoins: 3),"));
    assert!(message.contains("iteratoins"), "{message}");
}

/// A scene without `dt` takes one step per frame, which the fluid pipeline substeps (as a game
/// steps the crate); a given `dt` is rounded down to a whole number of steps per frame.
#[test]
fn a_scene_without_dt_steps_once_per_frame() {
    let scene = SceneFile::parse(GOOD, "good.ron").unwrap();
    let (dt, steps) = scene.time_step();
    assert_eq!((dt, steps), (1.0 / 30.0, 1));
    let with_dt = GOOD.replace("duration: 1.0,", "duration: 1.0, dt: 0.004,");
    let (dt, steps) = SceneFile::parse(&with_dt, "dt.ron").unwrap().time_step();
    assert_eq!(steps, 9); // 1/30 s holds 8.3 steps of 4 ms: 9 steps of 3.7 ms
    assert!((dt * 9.0 - 1.0 / 30.0).abs() < 1e-7);
}

/// Particles beside or below the colliders' box count as outside the scene; particles above
/// it (against gravity) do not: water over a floor has not left the floor.
#[test]
fn particles_outside_the_colliders_are_counted() {
    // A 2 m floor (top at y = 0); particles 0.5 m above it, 2 m beside it, 1 m under it.
    let text = "Scene(
        duration: 1.0,
        fluids: [Fluid(preset: Water(spacing: 0.1),
                       particles: [(0.0, 0.5, 0.0), (0.9, 3.0, 0.9), (3.0, 0.5, 0.0), (0.0, -1.0, 0.0)])],
        bodies: [Body(kind: Fixed, colliders: [
            Collider(shape: Cuboid(half_extents: (1.0, 0.1, 1.0)), position: (0.0, -0.1, 0.0)),
        ])],
    )";
    let built = SceneFile::parse(text, "floor.ron")
        .unwrap()
        .build(Path::new("floor.ron"), Path::new("."))
        .unwrap();
    let (lo, hi) = built.collider_bounds().unwrap();
    assert!(
        (lo.y + 0.2).abs() < 1e-6 && hi.y == f32::INFINITY,
        "{lo} {hi}"
    );
    assert_eq!(built.particles_outside_colliders(), 2);
}

/// `scenes/water_obstacles.ron` is a closed box: none of its 2,400 particles leaves it over
/// its whole run (with the open box it had, about 108 splashed over the rim).
#[test]
fn water_obstacles_keeps_its_water() {
    let (_, mut built) =
        SceneFile::load_and_build(scenes_dir().join("water_obstacles.ron")).unwrap();
    let n = built.world.fluids.num_particles();
    for _ in 0..built.frames * built.steps_per_frame {
        built.world.step().unwrap();
    }
    assert_eq!(built.world.fluids.num_particles(), n);
    assert_eq!(built.particles_outside_colliders(), 0);
}

/// The errors that used to name no line (found when the scene was built): a triangle mesh
/// index out of range, an empty mesh, a ragged or non-finite height field, a degenerate hull,
/// and the other shapes' checks, are now found as the shape is read, at its line.
#[test]
fn shape_errors_name_their_line() {
    for (shape, says) in [
        (
            "TriMesh(vertices: [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)], indices: [(0, 1, 7)])",
            "past the 3 vertices",
        ),
        ("TriMesh(vertices: [], indices: [])", ""),
        (
            "HeightField(heights: [[0.0, 0.1], [0.0]], scale: (1.0, 1.0, 1.0))",
            "same length",
        ),
        (
            "HeightField(heights: [[0.0, 1e300], [0.0, 0.0]], scale: (1.0, 1.0, 1.0))",
            "not a finite number",
        ),
        (
            "ConvexHull(points: [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (2.0, 0.0, 0.0)])",
            "degenerate",
        ),
        (
            "RoundConvexHull(points: [(0.0, 0.0, 0.0)], border_radius: 0.1)",
            "degenerate",
        ),
        ("Polyline(vertices: [(0.0, 0.0, 0.0)])", "at least 2"),
        (
            "Polyline(vertices: [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0)], indices: [(0, 2)])",
            "past the 2 vertices",
        ),
        ("HalfSpace(normal: (0.0, 0.0, 0.0))", "zero"),
        (
            "Voxels(voxel_size: (0.1, 0.1, 0.1), points: [])",
            "at least one",
        ),
        ("Compound(parts: [])", "at least one part"),
        (
            "Compound(parts: [Part(shape: Compound(parts: [Part(shape: Ball(radius: 0.1))]))])",
            "cannot hold a compound",
        ),
        ("TriMeshFile(path: \"\")", "empty"),
    ] {
        let (line, _, field, message) = parse_err(&GOOD.replace("Ball(radius: 0.5)", shape));
        assert_eq!(line, 11, "{shape}: {message}");
        assert!(
            field.starts_with("bodies[0].colliders[0].shape"),
            "{shape}: {field}"
        );
        assert!(message.contains(says), "{shape}: {message}");
    }
}

/// Settings that ask for unbounded work, and particle counts beyond a fluid's limits, are
/// refused when the file is read, at the field's line.
#[test]
fn unbounded_settings_are_refused_at_their_line() {
    // dt: 10^-30 s, 3·10^28 steps in a frame.
    let (line, _, field, message) =
        parse_err(&GOOD.replace("duration: 1.0,", "duration: 1.0, dt: 1e-30,"));
    assert_eq!((line, field.as_str()), (2, "dt"));
    assert!(message.contains("MAX_STEPS_PER_FRAME"), "{message}");
    // duration: 10^30 s, 3·10^31 frames.
    let (line, _, field, message) = parse_err(&GOOD.replace("duration: 1.0,", "duration: 1e30,"));
    assert_eq!((line, field.as_str()), (2, "duration"));
    assert!(message.contains("MAX_FRAMES"), "{message}");
    // A frame rate of 10^-30 frames per second makes each frame 10^30 s long.
    let (_, _, field, _) =
        parse_err(&GOOD.replace("duration: 1.0,", "duration: 1.0, frame_rate: 1e-30,"));
    assert_eq!(field, "dt");
    // At the bound, accepted: 2^16 steps of a 1/30 s frame.
    let ok = GOOD.replace("duration: 1.0,", "duration: 1.0, dt: 5.1e-7,");
    assert_eq!(
        SceneFile::parse(&ok, "ok.ron").unwrap().time_step().1,
        65360
    );
    // PBF with 10^8 iterations a substep: refused with the fluid.
    let (line, _, field, message) = parse_err(&GOOD.replace(
        "preset: Water(spacing: 0.1),",
        "preset: Water(spacing: 0.1),\n            solver: Pbf(iterations: 100000000),",
    ));
    assert!(
        (4..=10).contains(&line) && field.starts_with("fluids[0]"),
        "{line} {field}"
    );
    assert!(message.contains("iterations"), "{message}");
    // A kilometre of water at a millimetre: 10^18 particles.
    let (line, _, field, message) = parse_err(
        &GOOD
            .replace("Water(spacing: 0.1)", "Water(spacing: 0.001)")
            .replace("size: (0.5, 0.5, 0.5)", "size: (1000.0, 1000.0, 1000.0)"),
    );
    assert_eq!((line, field.as_str()), (6, "fluids[0].blocks[0].size"));
    assert!(message.contains("MAX_PARTICLES"), "{message}");
    // A particle beyond 10,000 km.
    let (line, _, field, _) = parse_err(&GOOD.replace(
        "blocks: [",
        "particles: [(0.0, 0.0, 0.0), (2e7, 0.0, 0.0)],\n            blocks: [",
    ));
    assert_eq!((line, field.as_str()), (6, "fluids[0].particles[1]"));
    // An emitter at 10^12 particles per second, and a nozzle of 10^5 m.
    let (line, _, field, message) = parse_err(&SOURCES.replacen("rate: 40.0", "rate: 1e12", 1));
    assert!((7..=16).contains(&line), "{line}");
    assert!(field.starts_with("fluids[0].emitters[0]"), "{field}");
    assert!(message.contains("MAX_RATE"), "{message}");
    let (line, _, field, message) =
        parse_err(&SOURCES.replacen("Disk(radius: 0.2)", "Disk(radius: 1e5)", 1));
    assert_eq!((line, field.as_str()), (8, "fluids[0].emitters[0].nozzle"));
    assert!(message.contains("MAX_NOZZLE_SLOTS"), "{message}");
}

/// Files are read within a size limit and only when they are regular files: a mesh path to
/// `/dev/zero` (which used to be read until memory ran out) and a mesh larger than the limit
/// (a sparse file: no disk is used) are refused at the shape's line; so is a scene file that
/// is a device.
#[test]
fn file_reads_are_bounded() {
    let dir = std::env::temp_dir().join(format!("rapier_sph_bounded_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let big = dir.join("big.obj");
    std::fs::File::create(&big)
        .unwrap()
        .set_len(rapier_sph::scene_file::MAX_FILE_BYTES + 1)
        .unwrap();
    for (mesh, says) in [
        ("/dev/zero", "not a regular file"),
        (big.to_str().unwrap(), "limit"),
        (dir.to_str().unwrap(), "not a regular file"),
    ] {
        if !Path::new(mesh).exists() {
            continue; // no /dev/zero on this system
        }
        let text = GOOD.replace("Ball(radius: 0.5)", &format!("TriMeshFile(path: {mesh:?})"));
        let file = dir.join("scene.ron");
        std::fs::write(&file, &text).unwrap();
        match SceneFile::load_and_build(&file) {
            Err(SceneError::Parse {
                line,
                field,
                message,
                ..
            }) => {
                assert_eq!(line, 11, "{mesh}");
                assert_eq!(field, "bodies[0].colliders[0].shape");
                assert!(message.contains(says), "{mesh}: {message}");
            }
            other => panic!("{mesh}: expected a located error, got {:?}", other.err()),
        }
    }
    if Path::new("/dev/zero").exists() {
        assert!(matches!(
            SceneFile::load("/dev/zero"),
            Err(SceneError::Io { .. })
        ));
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A hose carried by a moving pipe, and a tub of water filled from a named sensor and a
/// shape: the carried nozzle's particles leave with the pipe's velocity, and every name and
/// every fill that cannot be made is reported at its line and field.
const CARRIED: &str = "Scene(
    duration: 1.0,
    fluids: [
        Fluid(
            preset: Water(spacing: 0.05),
            fill: [
                Collider(name: \"pool\"),
                Shape(shape: Cylinder(half_height: 0.1, radius: 0.1), position: (0.5, 0.5, 0.0)),
            ],
            emitters: [
                Emitter(nozzle: Disk(radius: 0.05), position: (0.0, -0.1, 0.0), speed: 1.0,
                        rate: 200.0, attached_to: Body(collider: \"pipe\")),
            ],
        ),
    ],
    bodies: [
        Body(colliders: [
            Collider(shape: Cuboid(half_extents: (1.0, 0.1, 1.0))),
            Collider(name: \"pool\", shape: Cuboid(half_extents: (0.2, 0.1, 0.2)), position: (0.0, 0.2, 0.0), sensor: true),
        ]),
        Body(kind: KinematicVelocityBased, position: (0.0, 1.0, 0.0), linvel: (0.5, 0.0, 0.0), colliders: [
            Collider(name: \"pipe\", shape: Cuboid(half_extents: (0.05, 0.05, 0.05)), sensor: true),
        ]),
    ],
)";

#[test]
fn carried_emitters_and_fills_build_and_their_mistakes_are_located() {
    let scene = SceneFile::parse(CARRIED, "carried.ron").unwrap();
    let mut built = scene.build(Path::new("carried.ron"), scenes_dir()).unwrap();
    let water = built.fluids[0];
    // The pool: 0.4 × 0.2 × 0.4 m at 5 cm, 8 × 4 × 8 exactly; the cylinder: 4 layers of the
    // 4 × 4 lattice less its 4 corners (0.106 m from the axis).
    assert_eq!(built.world.fluids[water].len(), 8 * 4 * 8 + 4 * 12);
    let before = built.world.fluids[water].len();
    let ids_before = built.world.fluids[water]
        .ids()
        .iter()
        .copied()
        .max()
        .unwrap();
    for _ in 0..6 {
        built.world.step().unwrap();
    }
    // The jet left the moving pipe with its 0.5 m/s along x (plus its own 1 m/s down).
    let f = &built.world.fluids[water];
    assert!(f.len() > before);
    let jet: Vec<_> = f
        .ids()
        .iter()
        .zip(f.velocities())
        .filter(|(id, _)| **id > ids_before)
        .map(|(_, v)| *v)
        .collect();
    assert!(!jet.is_empty());
    assert!(jet.iter().all(|v| (v.x - 0.5).abs() < 0.05), "{jet:?}");

    let bad = |from: &str, to: &str| {
        assert!(CARRIED.contains(from), "{from}");
        parse_err(&CARRIED.replacen(from, to, 1))
    };
    // Names no collider has, at the name's line, listing the names there are.
    let (line, _, field, message) = bad("Collider(name: \"pool\"),", "Collider(name: \"poll\"),");
    assert_eq!(
        (line, field.as_str()),
        (7, "fluids[0].fill[0].Collider.name")
    );
    assert!(
        message.contains("`poll`") && message.contains("`pool`"),
        "{message}"
    );
    // (An emitter is checked as a whole where its entry ends: its errors point at the entry.)
    let (line, _, field, _) = bad("Body(collider: \"pipe\")", "Body(collider: \"pip\")");
    assert_eq!(
        (line, field.as_str()),
        (12, "fluids[0].emitters[0].attached_to.Body.collider")
    );
    let (line, _, field, _) = bad("Body(collider: \"pipe\")", "Collider(name: \"pip\")");
    assert_eq!(
        (line, field.as_str()),
        (12, "fluids[0].emitters[0].attached_to.Collider.name")
    );
    // A shape that cannot be filled: a bad size as it is read, an unbounded one (whose box
    // would hold more particles than memory) when built.
    let (line, _, field, _) = bad("radius: 0.1)", "radius: -0.1)");
    assert_eq!(line, 8);
    assert!(field.starts_with("fluids[0].fill[1]"), "{field}");
    let text = CARRIED.replacen(
        "Cylinder(half_height: 0.1, radius: 0.1)",
        "HalfSpace(normal: (0.0, 1.0, 0.0))",
        1,
    );
    let scene = SceneFile::parse(&text, "unbounded.ron").unwrap();
    match scene.build(Path::new("unbounded.ron"), scenes_dir()) {
        Err(SceneError::Invalid { field, message, .. }) => {
            assert_eq!(field, "fluids[0].fill[1]");
            assert!(message.contains("`shape`"), "{message}");
        }
        other => panic!("expected an invalid fill, got {:?}", other.err()),
    }
}

/// `interacts: true` makes the fluids of `oil_on_water.ron` (DFSPH) and `pbf_oil_on_water.ron`
/// interact: after 1 s of the lock exchange the water's mean height is below the oil's by
/// more than a spacing (both start at 0.1 m; without interaction the oil would fall through
/// the water instead).
#[test]
fn the_oil_on_water_file_builds_interacting_fluids() {
    for file in ["oil_on_water.ron", "pbf_oil_on_water.ron"] {
        oil_on_water_file(file);
    }
}

fn oil_on_water_file(file: &str) {
    let (_, mut built) = SceneFile::load_and_build(scenes_dir().join(file)).unwrap();
    let [water, oil] = built.fluids[..] else {
        panic!("two fluids")
    };
    let all = rapier_sph::rapier3d::prelude::InteractionGroups::all();
    for h in [water, oil] {
        assert_eq!(built.world.fluids[h].params().fluid_groups, all);
    }
    for _ in 0..60 * built.steps_per_frame {
        built.world.step().unwrap();
    }
    let mean = |h| {
        let f: &rapier_sph::Fluid = &built.world.fluids[h];
        f.positions().iter().map(|x| x.y).sum::<f32>() / f.len() as f32
    };
    let (w, o) = (mean(water), mean(oil));
    println!("{file}: water at {w}, oil at {o}");
    assert!(w < o - 0.02, "{file}: water at {w}, oil at {o}");
}

#[test]
fn sleep_is_read_from_the_fluid_entry() {
    use rapier_sph::Sleep;
    let with = |entry: &str| {
        let text = GOOD.replace(
            "preset: Water(spacing: 0.1),",
            &format!("preset: Water(spacing: 0.1),\n            {entry}"),
        );
        SceneFile::parse(&text, "sleep.ron").map(|s| s.fluids[0].params().unwrap().sleep)
    };
    // Absent: off.
    assert_eq!(
        SceneFile::parse(GOOD, "good.ron").unwrap().fluids[0]
            .params()
            .unwrap()
            .sleep,
        None
    );
    assert_eq!(with("sleep: Sleep(),").unwrap(), Some(Sleep::default()));
    let custom = with("sleep: Sleep(time: 1.5, mean_drift: 0.05),")
        .unwrap()
        .unwrap();
    assert_eq!(custom.time, 1.5);
    assert_eq!(custom.mean_drift, 0.05);
    assert_eq!(custom.max_drift, Sleep::default().max_drift);
    // A non-positive time is refused at its line, naming the field.
    let text = GOOD.replace(
        "preset: Water(spacing: 0.1),",
        "preset: Water(spacing: 0.1),\n            sleep: Sleep(time: -1.0),",
    );
    let (line, _, field, _) = parse_err(&text);
    assert_eq!(line, 6); // the `sleep:` line
    assert!(field.contains("sleep"), "{field}");
}

/// `emulsion.ron`: one fluid with a mixture of water and oil (`rapier_sph::mixture`), every
/// particle at half of each; after 3 s (1.6 times the separation time `H/(τΔρg)` = 1.8 s)
/// the particles more than a spacing above the 0.1 m the volumes give are mostly oil, those
/// more than a spacing below mostly water.
#[test]
fn the_emulsion_file_builds_a_mixture_that_separates() {
    let (_, mut built) = SceneFile::load_and_build(scenes_dir().join("emulsion.ron")).unwrap();
    let h = built.fluids[0];
    let f = &built.world.fluids[h];
    assert_eq!(f.params().mixture.as_ref().map(|m| m.len()), Some(2));
    assert!(f.fractions(1).unwrap().iter().all(|&a| a == 0.5));
    for _ in 0..180 * built.steps_per_frame {
        built.world.step().unwrap();
    }
    let f = &built.world.fluids[h];
    let s = f.params().particle_spacing;
    let mean = |above: bool| {
        let (mut sum, mut n) = (0.0, 0);
        for (x, &a) in f.positions().iter().zip(f.fractions(1).unwrap()) {
            if (above && x.y > 0.1 + s) || (!above && x.y < 0.1 - s) {
                sum += a;
                n += 1;
            }
        }
        sum / n as f32
    };
    let (top, bottom) = (mean(true), mean(false));
    println!("emulsion.ron after 3 s: oil fraction {top} above, {bottom} below");
    assert!(top > 0.9 && bottom < 0.1, "{top} {bottom}");
}
