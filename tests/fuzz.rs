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
    /// extreme velocities, random time steps and gravity, with and without a floor: every
    /// step returns (an error for a bad `dt` or gravity, changing nothing), and afterwards
    /// every particle is finite and `live + quarantined` equals what was inserted.
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
    ) {
        let params = FluidParamsBuilder::water(0.05)
            .solver(solver)
            .wall_density(walls)
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
        let mut fluid = Fluid::new(params).unwrap();
        // Each point alone: a non-finite one is refused with an error, a finite one accepted.
        let mut inserted = 0usize;
        for (k, &(x, y, z)) in points.iter().enumerate() {
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
        let handle = world.fluids.insert(fluid);
        let g = Vector::new(gravity.0, gravity.1, gravity.2);
        for &dt in &dts {
            // Long frames are capped by the adaptive substeps; keep the test fast.
            let dt = if dt.is_finite() { dt.clamp(-1.0, 0.05) } else { dt };
            let before = world.fluids[handle].positions().to_vec();
            let r = world.pipeline.step(
                g,
                dt,
                &mut world.fluids,
                &mut world.physics.bodies,
                &world.physics.colliders,
                &world.physics.broad_phase,
            );
            let bad_input = !(dt.is_finite() && dt > 0.0) || !g.is_finite();
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
            prop_assert_eq!(f.len() + f.quarantined(), inserted);
        }
    }
}
