//! Random inputs to the parameter builder, the particle insertion and the step (proptest):
//! no panic, ever; bad input is a typed error; whatever the step is given, no NaN or infinity
//! survives into the state (it is quarantined and counted), and no particle is lost otherwise.

use proptest::prelude::*;
use rapier_sph::math::{Real, Vector};
use rapier_sph::rapier3d::prelude::*;
use rapier_sph::*;

/// Any float: normal, subnormal, zero, infinite, NaN, of either sign.
fn any_real() -> impl Strategy<Value = Real> {
    prop_oneof![
        any::<Real>(),
        -10.0..10.0 as Real,
        0.0..1.0 as Real,
        Just(Real::NAN),
        Just(Real::INFINITY),
        Just(0.0),
    ]
}

fn solver() -> impl Strategy<Value = Solver> {
    prop_oneof![
        Just(Solver::Wcsph),
        Just(Solver::dfsph()),
        Just(Solver::pbf()),
        Just(Solver::clavet())
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Every setter with any value: `build` returns parameters that validate, or an error
    /// naming a field; it never panics.
    #[test]
    fn builder_never_panics(
        spacing in any_real(), rho in any_real(), radius in any_real(), mass in any_real(),
        h in any_real(), k in any_real(), visc in any_real(), rest in any_real(),
        fric in any_real(), solver in solver(), walls in any::<bool>(), set_mass in any::<bool>(),
    ) {
        let mut b = FluidParamsBuilder::water(spacing)
            .rest_density(rho)
            .particle_radius(radius)
            .smoothing_length(h)
            .stiffness(k)
            .viscosity(visc)
            .restitution(rest)
            .friction(fric)
            .solver(solver)
            .wall_density(walls);
        if set_mass {
            b = b.particle_mass(mass);
        }
        match b.build() {
            Ok(p) => {
                prop_assert!(p.validate().is_ok());
                prop_assert!(p.particle_spacing > 0.0 && p.particle_spacing.is_finite());
                prop_assert!(p.particle_mass > 0.0 && p.particle_mass.is_finite());
                prop_assert!(p.smoothing_length >= p.particle_spacing);
            }
            Err(e) => prop_assert!(!e.to_string().is_empty()),
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Random particles (some placed with non-finite coordinates: refused), random and
    /// extreme velocities, random time steps and gravity, with and without a floor, a light
    /// dynamic box or a moving, spinning closed container: every
    /// step returns (an error for a bad `dt` or gravity, changing nothing), and afterwards
    /// every particle is finite and `live + quarantined` equals what was inserted. The viscosity
    /// ranges up to 10⁷ Pa·s and half the runs spawn every point twice; densities and pressures
    /// stay finite, no frame relaxes more than its budget of rounds, and no particle spawned
    /// in the container's interior ever leaves it (rapier moves the container each frame).
    #[test]
    fn step_never_panics_and_never_keeps_nan(
        solver in solver(),
        walls in any::<bool>(),
        points in prop::collection::vec((any_real(), any_real(), any_real()), 1..120),
        speeds in prop::collection::vec(any_real(), 1..120),
        dts in prop::collection::vec(any_real(), 1..6),
        gravity in (any_real(), any_real(), any_real()),
        floor in any::<bool>(),
        poison in prop::collection::vec((0usize..120, any_real()), 0..4),
        viscosity in prop_oneof![Just(0.5 as Real), Just(1e4), Just(1e6), 0.0..1e7 as Real],
        overfill in any::<bool>(),
        body in 0u8..3,
        body_motion in (any_real(), any_real()),
    ) {
        let params = FluidParamsBuilder::water(0.05)
            .solver(solver)
            .wall_density(walls)
            .viscosity(viscosity)
            .build()
            .unwrap();
        let mut world = FluidWorld::new();
        if floor {
            let body = world.physics.insert_body(RigidBodyBuilder::fixed());
            world.physics.insert_collider(
                ColliderBuilder::cuboid(5.0, 0.1, 5.0).translation(Vector::new(0.0, -0.1, 0.0)),
                Some(body),
            );
            world.physics.step();
        }
        // A light dynamic box (1–10 kg/m³: a beach ball) among the particles, or a closed
        // kinematic container moving and spinning through them at random (finite) rates.
        let finite = |x: Real| if x.is_finite() { x % 100.0 } else { 0.0 };
        let (a, b) = (finite(body_motion.0), finite(body_motion.1));
        if body == 1 {
            let h = world.physics.insert_body(RigidBodyBuilder::dynamic().linvel(Vector::new(a, b, 0.0)));
            world.physics.insert_collider(
                ColliderBuilder::cuboid(0.08, 0.08, 0.08).density(1.0 + b.abs() % 9.0),
                Some(h),
            );
            world.physics.step();
        } else if body == 2 {
            let h = world.physics.insert_body(
                RigidBodyBuilder::kinematic_velocity_based()
                    .linvel(Vector::new(a, 0.0, 0.0))
                    .angvel(Vector::new(0.0, 0.0, b)),
            );
            for axis in 0..3 {
                for side in [-1.0, 1.0] {
                    let mut half = Vector::splat(0.54);
                    half[axis] = 0.02;
                    let mut c = Vector::ZERO;
                    c[axis] = side * 0.52;
                    world.physics.insert_collider(
                        ColliderBuilder::cuboid(half.x, half.y, half.z).translation(c),
                        Some(h),
                    );
                }
            }
            world.physics.step();
        }
        let mut fluid = Fluid::new(params).unwrap();
        // Each point alone: a non-finite one is refused with an error, a finite one accepted.
        let mut inserted = 0usize;
        // An overfilled spawn: every point twice (a double-clicked "spawn water").
        let copies = if overfill { 2 } else { 1 };
        for (k, &(x, y, z)) in points.iter().cycle().take(copies * points.len()).enumerate() {
            // Keep finite points near the origin so they interact.
            let p = Vector::new(x % 0.5, y % 0.5, z % 0.5);
            let s = speeds[k % speeds.len()];
            let v = Vector::new(s, -s, 0.5 * s);
            let r = fluid.add_particles_with_velocities(&[p], Some(&[v]));
            let finite = p.is_finite() && v.is_finite();
            prop_assert_eq!(r.is_ok(), finite, "point {:?} velocity {:?}", p, v);
            inserted += finite as usize;
        }
        // Game code writing anything through `velocities_mut` (NaN, infinity, 1e38 m/s).
        let n = fluid.len();
        for &(k, value) in &poison {
            if n > 0 {
                fluid.velocities_mut()[k % n] = Vector::new(value, 0.0, -value);
            }
        }
        // The closed container (rapier's first step moved it by its velocity): the ids of the
        // particles spawned in its interior, at least half a spacing from its inner faces
        // (0.5 m), none of which may leave it.
        let container = (body == 2).then(|| {
            let (c, b) = world.physics.bodies.iter().find(|(_, b)| b.is_kinematic()).unwrap();
            let pose = *b.position();
            let inside: Vec<u32> = fluid
                .positions()
                .iter()
                .zip(fluid.ids())
                .filter(|(p, _)| pose.inverse_transform_point(**p).abs().max_element() < 0.475)
                .map(|(_, &id)| id)
                .collect();
            (c, inside)
        });
        let handle = world.fluids.insert(fluid);
        let g = Vector::new(gravity.0, gravity.1, gravity.2);
        for &dt in &dts {
            // Long frames are capped by the adaptive substeps; keep the test fast.
            let dt = if dt.is_finite() { dt.clamp(-1.0, 0.05) } else { dt };
            let before = world.fluids[handle].positions().to_vec();
            let bad_input = !(dt.is_finite()
                && dt >= rapier_sph::pipeline::MIN_TIME_STEP
                && g.length() <= rapier_sph::pipeline::MAX_GRAVITY);
            if container.is_some() && !bad_input {
                // As a game loop does: rapier moves the container over the frame, then the
                // fluid steps against its motion (the pipeline reads the body's pose as the
                // frame's end and its velocity for the way there).
                world.physics.integration_parameters.dt = dt;
                world.physics.step();
            }
            let r = world.pipeline.step(
                g,
                dt,
                &mut world.fluids,
                &mut world.physics.bodies,
                &world.physics.colliders,
                &world.physics.broad_phase,
            );
            prop_assert_eq!(r.is_err(), bad_input, "dt {} gravity {:?}", dt, g);
            if bad_input {
                // Refused: nothing changed (a NaN written by the caller waits for the next
                // accepted step's quarantine).
                prop_assert_eq!(world.fluids[handle].positions(), &before[..]);
                continue;
            }
            let f = &world.fluids[handle];
            for (x, v) in f.positions().iter().zip(f.velocities()) {
                prop_assert!(x.is_finite() && v.is_finite(), "{:?} {:?}", x, v);
            }
            for (rho, p) in f.densities().iter().zip(f.pressures()) {
                prop_assert!(rho.is_finite() && p.is_finite(), "density {} pressure {}", rho, p);
            }
            let report = world.pipeline.report();
            prop_assert!(report.relax_rounds <= rapier_sph::pipeline::RELAX_FRAME_ROUNDS);
            prop_assert_eq!(f.len() + f.quarantined(), inserted);
            // Whatever the speeds, the spawn and the container's motion, none of the particles
            // spawned in the container's interior gets out.
            if let Some((c, inside)) = &container {
                let pose = *world.physics.bodies[*c].position();
                let out = f
                    .positions()
                    .iter()
                    .zip(f.ids())
                    .filter(|(p, id)| {
                        inside.binary_search(id).is_ok()
                            && pose.inverse_transform_point(**p).abs().max_element() > 0.5
                    })
                    .count();
                prop_assert_eq!(out, 0, "particles left the moving container");
            }
        }
    }
}

/// One call a game makes between steps, with arbitrary arguments.
#[derive(Clone, Debug)]
enum GameCall {
    /// Fill a ball of this radius at this point.
    FillBall(Real, (Real, Real, Real)),
    /// Fill a box of these half extents, turned by this angle about z.
    FillBox((Real, Real, Real), Real),
    /// Remove these ids (some never handed out).
    Remove(Vec<u32>),
    Clear,
    Reset,
    /// Attach the emitter to the body (0), its collider (1), a removed body (2) or a handle
    /// of another set (3); 4 detaches it.
    Attach(u8),
    /// Remove the carrying body (and its collider) from the world.
    RemoveBody,
}

fn game_call() -> impl Strategy<Value = GameCall> {
    prop_oneof![
        (any_real(), (any_real(), any_real(), any_real()))
            .prop_map(|(r, c)| GameCall::FillBall(r, c)),
        ((any_real(), any_real(), any_real()), any_real())
            .prop_map(|(h, a)| GameCall::FillBox(h, a)),
        prop::collection::vec(any::<u32>(), 0..6).prop_map(GameCall::Remove),
        prop::collection::vec(0u32..200, 0..6).prop_map(GameCall::Remove),
        Just(GameCall::Clear),
        Just(GameCall::Reset),
        (0u8..5).prop_map(GameCall::Attach),
        Just(GameCall::RemoveBody),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// The game calls (fill any shape, remove by id, clear, reset, attach an emitter to a
    /// moving body, a collider or a handle that names nothing, remove that body) with any
    /// arguments, between steps of any solver: no panic; an error exactly for bad input
    /// (non-finite or non-positive sizes, unknown ids or handles), changing nothing; after
    /// every step each particle is finite and every particle ever added is live, drained,
    /// quarantined or removed.
    #[test]
    fn game_calls_never_panic_and_keep_the_books(
        solver in solver(),
        calls in prop::collection::vec(game_call(), 1..8),
    ) {
        let mut game = Game::new(solver);
        // Particles added since the last reset, by the game and by the emitter.
        let mut added = 0usize;
        for call in calls {
            let f = &game.world.fluids[game.fluid];
            let before = (f.len(), f.removed(), f.state_hash());
            let result = game.apply(call, &mut added)?;
            let f = &game.world.fluids[game.fluid];
            if result.is_err() {
                // Refused: nothing changed.
                prop_assert_eq!((f.len(), f.removed(), f.state_hash()), before);
            }
            let r = game.world.step().unwrap();
            added += r.emitted;
            let f = &game.world.fluids[game.fluid];
            for (x, v) in f.positions().iter().zip(f.velocities()) {
                prop_assert!(x.is_finite() && v.is_finite(), "{:?} {:?}", x, v);
            }
            prop_assert_eq!(f.len() + f.removed() + f.drained() + f.quarantined(), added);
        }
    }
}

/// A floor, a kinematic body (moving and turning) with a collider, a removed body, a handle
/// of another set, and a fluid with a hose that can be attached to them.
struct Game {
    world: FluidWorld,
    fluid: FluidHandle,
    hose: EmitterHandle,
    body: RigidBodyHandle,
    collider: ColliderHandle,
    gone: RigidBodyHandle,
    stranger: RigidBodyHandle,
}

impl Game {
    fn new(solver: Solver) -> Self {
        let mut world = FluidWorld::new();
        let floor = world.physics.insert_body(RigidBodyBuilder::fixed());
        world.physics.insert_collider(
            ColliderBuilder::cuboid(2.0, 0.1, 2.0).translation(Vector::new(0.0, -0.1, 0.0)),
            Some(floor),
        );
        let body = world.physics.insert_body(
            RigidBodyBuilder::kinematic_velocity_based()
                .translation(Vector::new(0.0, 0.6, 0.0))
                .linvel(Vector::new(0.5, 0.0, 0.0))
                .angvel(Vector::new(0.0, 2.0, 0.0)),
        );
        let collider = world
            .physics
            .insert_collider(ColliderBuilder::ball(0.05), Some(body));
        let gone = world.physics.insert_body(RigidBodyBuilder::fixed());
        world.physics.remove_body(gone);
        let mut elsewhere = RigidBodySet::new();
        for _ in 0..8 {
            elsewhere.insert(RigidBodyBuilder::fixed());
        }
        let stranger = elsewhere.insert(RigidBodyBuilder::fixed());
        world.physics.step();
        let mut fluid = Fluid::new(FluidParamsBuilder::water(0.05).solver(solver)).unwrap();
        let nozzle = Nozzle::Disk { radius: 0.05 };
        let hose = fluid
            .add_emitter(Emitter::new(
                nozzle,
                Vector::new(0.15, 0.0, 0.0),
                Vector::X,
                1.0,
                200.0,
            ))
            .unwrap();
        fluid.set_capacity(Some(3_000)).unwrap();
        let fluid = world.fluids.insert(fluid);
        Self {
            world,
            fluid,
            hose,
            body,
            collider,
            gone,
            stranger,
        }
    }

    /// Makes one call; checks that it fails exactly on bad input. `added` counts the particles
    /// the call added (a reset zeroes it).
    fn apply(&mut self, call: GameCall, added: &mut usize) -> Result<SphResult<()>, TestCaseError> {
        use rapier_sph::math::{Pose, Rotation};
        use rapier_sph::rapier3d::parry::shape::{Ball, Cuboid};
        let f = &mut self.world.fluids[self.fluid];
        Ok(match call {
            GameCall::FillBall(r, (x, y, z)) => {
                let r = if r.is_finite() { r % 0.3 } else { r };
                let c = Vector::new(x % 1.0, (y % 1.0).abs() + 0.3, z % 1.0);
                let res = f.fill_shape(&Ball::new(r), &Pose::from_translation(c));
                check_fill(&res, r.is_finite() && r > 0.0 && c.is_finite())?;
                res.map(|ids| *added += ids.len())
            }
            GameCall::FillBox((a, b, c), angle) => {
                let half = Vector::new(a % 0.3, b % 0.3, c % 0.3);
                let turn = Rotation::from_rotation_z(angle);
                let res =
                    f.fill_shape(&Cuboid::new(half), &Pose::from_parts(Vector::Y * 0.5, turn));
                let good = half.is_finite() && half.min_element() > 0.0 && angle.is_finite();
                check_fill(&res, good)?;
                res.map(|ids| *added += ids.len())
            }
            GameCall::Remove(ids) => {
                let unknown = ids.iter().any(|&id| id as usize >= added_ids(f));
                let res = f.remove_particles(&ids).map(|_| ());
                prop_assert_eq!(res.is_err(), unknown, "ids {:?}", ids);
                res
            }
            GameCall::Clear => {
                f.clear();
                Ok(())
            }
            GameCall::Reset => {
                f.reset();
                *added = 0;
                Ok(())
            }
            GameCall::Attach(k) => self.attach(k)?,
            GameCall::RemoveBody => {
                self.world.physics.remove_body(self.body);
                Ok(())
            }
        })
    }

    /// Attaches the hose to the body (0), its collider (1), a removed body (2), a body of
    /// another set (3), or detaches it (4); an error exactly for 2, 3 and a removed body.
    fn attach(&mut self, k: u8) -> Result<SphResult<()>, TestCaseError> {
        let p = &self.world.physics;
        let (bodies, colliders) = (&p.bodies, &p.colliders);
        let f = &mut self.world.fluids[self.fluid];
        let to = match k {
            0 => Attachment::Body(self.body),
            1 => Attachment::Collider(self.collider),
            2 => Attachment::Body(self.gone),
            3 => Attachment::Body(self.stranger),
            _ => return Ok(f.detach_emitter(self.hose, bodies, colliders).map(|_| ())),
        };
        let res = f.attach_emitter(self.hose, to, bodies, colliders);
        let bad = k == 2
            || k == 3
            || (k == 0 && bodies.get(self.body).is_none())
            || (k == 1 && colliders.get(self.collider).is_none());
        prop_assert_eq!(res.is_err(), bad, "attach {}", k);
        Ok(res)
    }
}

/// A fill of bad input is refused naming `shape` or `pose`; a good one succeeds or meets the
/// fluid's capacity.
fn check_fill(res: &SphResult<std::ops::Range<u32>>, good: bool) -> Result<(), TestCaseError> {
    match (res, good) {
        (Ok(_), true) | (Err(SphError::InvalidParticle { .. }), true) => Ok(()),
        (
            Err(SphError::InvalidParameter {
                field: "shape" | "pose",
                ..
            }),
            false,
        ) => Ok(()),
        (other, _) => Err(TestCaseError::fail(format!(
            "fill (good input: {good}): {other:?}"
        ))),
    }
}

/// Ids handed out so far (every id below it was): the largest live id bounds it from below,
/// and the fluid's counters give it exactly.
fn added_ids(f: &Fluid) -> usize {
    f.len() + f.removed() + f.drained() + f.quarantined()
}
