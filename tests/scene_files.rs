//! Scene files: the shipped scenes load and build, the dam break file builds exactly the
//! example's scene, RON written back reads back equal, and mistakes are reported with the
//! file, line and field.
#![cfg(feature = "scene")]

use rapier_sph::FluidParamsBuilder;
use rapier_sph::scene_file::{SceneError, SceneFile};
use rapier_sph::scenes::{DamBreakConfig, dam_break};
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
            assert!(built.world.fluids.num_particles() > 0, "{}", path.display());
            assert!(built.frames >= 1 && built.steps_per_frame >= 1);
            // The frame time is a whole number of steps.
            let frame = built.steps_per_frame as f32 * built.dt;
            assert!((frame * scene.frame_rate.0 - 1.0).abs() < 1e-5);
            n += 1;
        }
    }
    assert!(n >= 3, "found {n} scenes");
}

#[test]
fn the_reference_scene_has_every_shape() {
    let (scene, built) = SceneFile::load_and_build(scenes_dir().join("reference.ron")).unwrap();
    assert_eq!(scene.bodies[0].colliders.len(), 21); // every parry shape, TriMesh inline and from a file, Polyline with and without indices
    assert_eq!(built.world.physics.colliders.len(), 22);
    assert_eq!(built.world.physics.bodies.len(), 2);
    // 7 × 7 × 10 particles in the block (0.3/0.04 → 7, 0.4/0.04 → 10), plus two singles.
    let f = &built.world.fluids[built.fluids[0]];
    assert_eq!(f.len(), 7 * 7 * 10 + 2);
    assert_eq!(f.params().viscosity, 0.5);
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
    let scene = SceneFile::parse(&text, "bad.ron").unwrap();
    match scene.build(Path::new("bad.ron"), scenes_dir()) {
        Err(SceneError::Invalid { field, message, .. }) => {
            assert_eq!(field, "bodies[0].colliders[0].shape");
            assert!(message.contains("no_such_file.obj"), "{message}");
        }
        other => panic!("expected an invalid scene, got {:?}", other.err()),
    }
    let text = GOOD.replace(
        "Ball(radius: 0.5)",
        "ConvexHull(points: [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0)])",
    );
    let scene = SceneFile::parse(&text, "bad.ron").unwrap();
    assert!(matches!(
        scene.build(Path::new("bad.ron"), scenes_dir()),
        Err(SceneError::Invalid { .. })
    ));
    assert!(matches!(
        SceneFile::load(scenes_dir().join("missing.ron")),
        Err(SceneError::Io { .. })
    ));
}
