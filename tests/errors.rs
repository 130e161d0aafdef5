//! Bad input gives typed errors that name the culprit, changes nothing, and never panics.

use rapier_sph::math::{Real, Vector};
use rapier_sph::rapier3d::prelude::*;
use rapier_sph::scenes::{DamBreakConfig, dam_break};
use rapier_sph::{
    EquationOfState, Fluid, FluidParams, FluidParamsBuilder, FluidPipeline, FluidSet, SphError,
    SphResult,
};

const BAD: [Real; 5] = [Real::NAN, Real::INFINITY, Real::NEG_INFINITY, 0.0, -1.0];

fn field_of<T: std::fmt::Debug>(r: SphResult<T>) -> &'static str {
    match r {
        Err(SphError::InvalidParameter { field, .. }) => field,
        other => panic!("expected an InvalidParameter error, got {other:?}"),
    }
}

fn base() -> FluidParamsBuilder {
    FluidParamsBuilder::water(0.05)
}

/// Every size/mass field, set to NaN, ±∞, 0 and −1 through the builder, is refused with its
/// own name; and the same values written directly into `FluidParams` are refused by
/// `Fluid::new` and `Fluid::set_params`.
#[test]
fn bad_size_and_mass_fields_are_named() {
    type Set = fn(FluidParamsBuilder, Real) -> FluidParamsBuilder;
    type Poke = fn(&mut FluidParams, Real);
    let fields: [(&str, Set, Poke); 5] = [
        (
            "rest_density",
            |b, v| b.rest_density(v),
            |p, v| p.rest_density = v,
        ),
        (
            "particle_spacing",
            |b, v| b.particle_spacing(v),
            |p, v| p.particle_spacing = v,
        ),
        (
            "particle_radius",
            |b, v| b.particle_radius(v),
            |p, v| p.particle_radius = v,
        ),
        (
            "particle_mass",
            |b, v| b.particle_mass(v),
            |p, v| p.particle_mass = v,
        ),
        (
            "smoothing_length",
            |b, v| b.smoothing_length(v),
            |p, v| p.smoothing_length = v,
        ),
    ];
    let good = base().build().unwrap();
    let mut fluid = Fluid::new(good.clone()).unwrap();
    for (name, set, poke) in fields {
        for v in BAD {
            assert_eq!(
                field_of(set(base(), v).build()),
                name,
                "builder with {name} = {v}"
            );
            let mut p = good.clone();
            poke(&mut p, v);
            assert_eq!(field_of(p.validate()), name, "validate with {name} = {v}");
            assert_eq!(
                field_of(Fluid::new(p.clone())),
                name,
                "Fluid::new with {name} = {v}"
            );
            assert_eq!(
                field_of(fluid.set_params(p)),
                name,
                "set_params with {name} = {v}"
            );
            // A refused set_params keeps the old parameters.
            assert_eq!(fluid.params(), &good);
        }
    }
    // The water preset with a bad spacing names the spacing.
    for v in BAD {
        assert_eq!(
            field_of(FluidParamsBuilder::water(v).build()),
            "particle_spacing"
        );
    }
}

#[test]
fn smoothing_length_below_the_spacing_is_refused() {
    let s = 0.05;
    assert_eq!(
        field_of(base().smoothing_length(0.99 * s).build()),
        "smoothing_length"
    );
    assert_eq!(
        field_of(base().smoothing_length(s.next_down()).build()),
        "smoothing_length"
    );
    // Exactly the spacing is allowed.
    assert!(base().smoothing_length(s).build().is_ok());
}

#[test]
fn other_bad_fields_are_named() {
    for v in [Real::NAN, Real::INFINITY, -1.0] {
        assert_eq!(field_of(base().viscosity(v).build()), "viscosity");
        assert_eq!(field_of(base().restitution(v).build()), "restitution");
        assert_eq!(field_of(base().friction(v).build()), "friction");
    }
    assert_eq!(field_of(base().restitution(1.5).build()), "restitution");
    for v in BAD {
        assert_eq!(field_of(base().stiffness(v).build()), "stiffness");
        let tait = |c, g| EquationOfState::Tait {
            speed_of_sound: c,
            exponent: g,
        };
        assert_eq!(
            field_of(base().equation_of_state(tait(v, 7.0)).build()),
            "speed_of_sound"
        );
        assert_eq!(
            field_of(base().equation_of_state(tait(30.0, v)).build()),
            "exponent"
        );
    }
    for v in [Real::NAN, Real::INFINITY, -0.1, 1.01] {
        let solver = rapier_sph::Solver::Dfsph(rapier_sph::Dfsph {
            warm_start: v,
            ..Default::default()
        });
        assert_eq!(field_of(base().solver(solver).build()), "warm_start");
    }
    // The carried prediction error needs the projected solve.
    let carry = rapier_sph::Solver::Dfsph(rapier_sph::Dfsph {
        carry_density_error: true,
        ..Default::default()
    });
    assert_eq!(
        field_of(base().solver(carry).build()),
        "carry_density_error"
    );
    for v in [Real::NAN, Real::INFINITY, -1.0] {
        let springs = |s: rapier_sph::solver::Springs| {
            rapier_sph::Solver::Clavet(rapier_sph::solver::Clavet {
                springs: Some(s),
                ..Default::default()
            })
        };
        let d = rapier_sph::solver::Springs::default();
        for (field, s) in [
            (
                "spring_stiffness",
                rapier_sph::solver::Springs { stiffness: v, ..d },
            ),
            (
                "yield_ratio",
                rapier_sph::solver::Springs {
                    yield_ratio: v,
                    ..d
                },
            ),
            (
                "plasticity",
                rapier_sph::solver::Springs { plasticity: v, ..d },
            ),
        ] {
            assert_eq!(field_of(base().solver(springs(s)).build()), field);
        }
    }
}

fn some_particles() -> Vec<Vector> {
    rapier_sph::fluid::lattice(Vector::ZERO, 3, 3, 3, 0.05)
}

#[test]
fn non_finite_particles_are_refused_and_nothing_is_added() {
    let mut fluid = Fluid::new(base().build().unwrap()).unwrap();
    let first = fluid.add_particles(&some_particles()).unwrap();
    assert_eq!(first, 0..27);
    let before = (fluid.positions().to_vec(), fluid.ids().to_vec());

    for bad in [
        Vector::new(Real::NAN, 0.0, 0.0),
        Vector::new(0.0, Real::INFINITY, 0.0),
        Vector::new(0.0, 0.0, Real::NEG_INFINITY),
        Vector::new(2.0e7, 0.0, 0.0), // beyond what f32 resolves at this spacing
    ] {
        let mut pts = some_particles();
        pts[5] = bad;
        match fluid.add_particles(&pts) {
            Err(SphError::InvalidParticle { index, .. }) => assert_eq!(index, 5, "{bad}"),
            other => panic!("{bad}: expected InvalidParticle, got {other:?}"),
        }
        assert_eq!((fluid.positions().to_vec(), fluid.ids().to_vec()), before);
    }

    // Bad velocities, and mismatched lengths.
    let pts = some_particles();
    let mut vel = vec![Vector::ZERO; pts.len()];
    vel[7] = Vector::new(0.0, Real::NAN, 0.0);
    match fluid.add_particles_with_velocities(&pts, Some(&vel)) {
        Err(SphError::InvalidParticle { index: 7, .. }) => {}
        other => panic!("expected InvalidParticle #7, got {other:?}"),
    }
    assert!(matches!(
        fluid.add_particles_with_velocities(&pts, Some(&vel[..3])),
        Err(SphError::InvalidParticle { .. })
    ));
    assert_eq!((fluid.positions().to_vec(), fluid.ids().to_vec()), before);
    assert_eq!(fluid.velocities().len(), 27);

    // Blocks with bad sizes.
    for size in [
        Vector::new(0.0, 1.0, 1.0),
        Vector::new(-1.0, 1.0, 1.0),
        Vector::new(Real::NAN, 1.0, 1.0),
    ] {
        assert_eq!(field_of(fluid.add_block(Vector::ZERO, size)), "size");
    }
    assert_eq!(
        field_of(fluid.add_block(Vector::splat(Real::NAN), Vector::ONE)),
        "size"
    );
    assert_eq!(fluid.len(), 27);

    // Refused additions consumed no ids.
    assert_eq!(fluid.add_particles(&some_particles()).unwrap(), 27..54);
}

/// A fluid on a floor, with rapier stepped once: ready to step.
fn scene() -> (
    PhysicsWorld,
    FluidSet,
    rapier_sph::FluidHandle,
    FluidPipeline,
) {
    let mut world = PhysicsWorld::default();
    let floor = world.insert_body(RigidBodyBuilder::fixed());
    world.insert_collider(ColliderBuilder::cuboid(1.0, 0.1, 1.0), Some(floor));
    world.step();
    let mut fluid = Fluid::new(base().build().unwrap()).unwrap();
    fluid
        .add_block(Vector::new(-0.2, 0.15, -0.2), Vector::splat(0.3))
        .unwrap();
    let mut fluids = FluidSet::new();
    let h = fluids.insert(fluid);
    let mut pipeline = FluidPipeline::new();
    // A few good steps, so there is state (velocities, densities, order) to preserve.
    for _ in 0..5 {
        pipeline
            .step(
                world.gravity,
                1e-3,
                &mut fluids,
                &mut world.bodies,
                &world.colliders,
                &world.broad_phase,
            )
            .unwrap();
    }
    (world, fluids, h, pipeline)
}

type State = (Vec<[u32; 3]>, Vec<[u32; 3]>, Vec<u32>, Vec<u32>);

fn state(fluids: &FluidSet, h: rapier_sph::FluidHandle) -> State {
    let f = &fluids[h];
    let b = |v: &[Vector]| {
        v.iter()
            .map(|v| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()])
            .collect()
    };
    (
        b(f.positions()),
        b(f.velocities()),
        f.ids().to_vec(),
        f.densities().iter().map(|d| d.to_bits()).collect(),
    )
}

#[test]
fn bad_time_steps_are_refused_and_change_nothing() {
    let (mut world, mut fluids, h, mut pipeline) = scene();
    let before = state(&fluids, h);
    let report_before = pipeline.report().clone();
    for dt in [
        0.0,
        -0.0,
        -1e-3,
        Real::NAN,
        Real::INFINITY,
        Real::NEG_INFINITY,
    ] {
        let r = pipeline.step(
            world.gravity,
            dt,
            &mut fluids,
            &mut world.bodies,
            &world.colliders,
            &world.broad_phase,
        );
        match r {
            Err(SphError::InvalidTimeStep { dt: got }) => {
                assert!(got.to_bits() == (dt as f64).to_bits(), "{got} vs {dt}")
            }
            other => panic!("dt = {dt}: expected InvalidTimeStep, got {other:?}"),
        }
        assert_eq!(state(&fluids, h), before, "dt = {dt} changed the fluid");
        assert_eq!(
            pipeline.report(),
            &report_before,
            "dt = {dt} changed the report"
        );
    }
    // Non-finite gravity: refused, names the gravity, changes nothing.
    for g in [
        Vector::new(0.0, Real::NAN, 0.0),
        Vector::new(Real::INFINITY, 0.0, 0.0),
    ] {
        let r = pipeline.step(
            g,
            1e-3,
            &mut fluids,
            &mut world.bodies,
            &world.colliders,
            &world.broad_phase,
        );
        assert_eq!(field_of(r), "gravity");
        assert_eq!(state(&fluids, h), before);
    }
    // rapier takes at least one substep per step: 0 is refused, naming the field.
    pipeline.rapier_substeps = 0;
    let r = pipeline.step(
        world.gravity,
        1e-3,
        &mut fluids,
        &mut world.bodies,
        &world.colliders,
        &world.broad_phase,
    );
    assert_eq!(field_of(r), "rapier_substeps");
    assert_eq!(state(&fluids, h), before);
    pipeline.rapier_substeps = 4;
    // And the fluid still steps afterwards.
    pipeline
        .step(
            world.gravity,
            1e-3,
            &mut fluids,
            &mut world.bodies,
            &world.colliders,
            &world.broad_phase,
        )
        .unwrap();
    assert_ne!(state(&fluids, h), before);
}

#[test]
fn colliders_without_a_rapier_step_are_reported() {
    let mut world = PhysicsWorld::default();
    let floor = world.insert_body(RigidBodyBuilder::fixed());
    world.insert_collider(ColliderBuilder::cuboid(1.0, 0.1, 1.0), Some(floor));
    world.insert_collider(ColliderBuilder::ball(0.2), None);
    let mut fluid = Fluid::new(base().build().unwrap()).unwrap();
    fluid
        .add_block(Vector::new(-0.2, 0.15, -0.2), Vector::splat(0.2))
        .unwrap();
    let mut fluids = FluidSet::new();
    let h = fluids.insert(fluid);
    let before = state(&fluids, h);
    let mut pipeline = FluidPipeline::new();
    let r = pipeline.step(
        world.gravity,
        1e-3,
        &mut fluids,
        &mut world.bodies,
        &world.colliders,
        &world.broad_phase,
    );
    assert_eq!(
        r.map(|_| ()),
        Err(SphError::BroadPhaseNotUpdated { colliders: 2 })
    );
    assert_eq!(state(&fluids, h), before);
    // After rapier steps once, it works.
    world.step();
    pipeline
        .step(
            world.gravity,
            1e-3,
            &mut fluids,
            &mut world.bodies,
            &world.colliders,
            &world.broad_phase,
        )
        .unwrap();
}

#[test]
fn empty_sets_and_empty_fluids_step_fine() {
    let mut world = PhysicsWorld::default();
    let mut pipeline = FluidPipeline::new();
    let mut fluids = FluidSet::new();
    // No fluid, no collider.
    let r = pipeline
        .step(
            world.gravity,
            1e-3,
            &mut fluids,
            &mut world.bodies,
            &world.colliders,
            &world.broad_phase,
        )
        .unwrap();
    assert_eq!(r.particles, 0);
    // An empty fluid, beside colliders.
    let floor = world.insert_body(RigidBodyBuilder::fixed());
    world.insert_collider(ColliderBuilder::cuboid(1.0, 0.1, 1.0), Some(floor));
    world.step();
    let h = fluids.insert(Fluid::new(base().build().unwrap()).unwrap());
    for _ in 0..3 {
        let r = pipeline
            .step(
                world.gravity,
                1e-3,
                &mut fluids,
                &mut world.bodies,
                &world.colliders,
                &world.broad_phase,
            )
            .unwrap();
        assert_eq!(r.particles, 0);
        assert_eq!(r.non_finite, 0);
    }
    assert!(fluids[h].is_empty());
    // A fluid emptied by removal steps fine too.
    fluids[h]
        .add_particles(&[Vector::new(0.0, 0.5, 0.0)])
        .unwrap();
    assert_eq!(fluids[h].remove_particles_where(|_, _, _| true), 1);
    pipeline
        .step(
            world.gravity,
            1e-3,
            &mut fluids,
            &mut world.bodies,
            &world.colliders,
            &world.broad_phase,
        )
        .unwrap();
    // Removed fluids: stale handles are refused.
    fluids.remove(h).unwrap();
    assert!(fluids.get(h).is_none());
    assert_eq!(fluids.remove(h).map(|_| ()), Err(SphError::UnknownFluid));
    let h2 = fluids.insert(Fluid::new(base().build().unwrap()).unwrap());
    assert_ne!(h, h2);
    assert!(fluids.get(h).is_none());
}

#[test]
fn bad_scene_configs_are_refused() {
    let params = base().build().unwrap();
    let mut c = DamBreakConfig::tower(params.clone(), 0.5);
    c.counts = [0, 5, 5];
    assert_eq!(field_of(dam_break(&c).map(|_| ())), "counts");
    let mut c = DamBreakConfig::tower(params.clone(), 0.5);
    c.tank_length_ratio = 0.5;
    assert_eq!(field_of(dam_break(&c).map(|_| ())), "tank_length_ratio");
    let mut c = DamBreakConfig::tower(params, 0.5);
    c.tank_height_ratio = Real::NAN;
    assert_eq!(field_of(dam_break(&c).map(|_| ())), "tank_height_ratio");
    let floating = |density: Real| {
        rapier_sph::scenes::FloatingBox::new(rapier_sph::scenes::FloatingBoxConfig {
            spacing: 0.05,
            tank: 0.5,
            depth: 0.2,
            half_width: 0.1,
            half_height: 0.05,
            density,
            solver: rapier_sph::Solver::Wcsph,
        })
        .map(|_| ())
    };
    for v in [Real::NAN, 0.0, -500.0] {
        assert_eq!(field_of(floating(v)), "density");
    }
}

/// Error messages are printable and mention the field.
#[test]
fn errors_display() {
    let e = base().smoothing_length(-1.0).build().unwrap_err();
    let s = e.to_string();
    assert!(s.contains("smoothing_length"), "{s}");
    let e: Box<dyn std::error::Error> = Box::new(SphError::InvalidTimeStep { dt: 0.0 });
    assert!(!e.to_string().is_empty());
}
