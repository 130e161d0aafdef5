//! Per-particle drawing data (`rapier_sph::visual`): interpolation between steps by particle
//! id, and the diffuse particles of Ihmsen et al. 2012 ("Unified spray, foam and air bubbles
//! for particle-based fluids"). The anisotropy of Yu & Turk 2013 is tested in its module.

use rapier_sph::math::Vector;
use rapier_sph::scenes::{DamBreakConfig, dam_break};
use rapier_sph::visual::{
    Anisotropy, AnisotropySettings, DiffuseKind, DiffuseParticles, DiffuseSettings, Interpolation,
};
use rapier_sph::{FluidParamsBuilder, SphError};
use std::collections::HashMap;

fn by_id(ids: &[u32], positions: &[Vector]) -> HashMap<u32, Vector> {
    ids.iter().copied().zip(positions.iter().copied()).collect()
}

/// Interpolation returns exactly the previous positions at α = 0 and the latest at α = 1,
/// and follows particles by id while the fluid re-sorts them between the two records.
#[test]
fn interpolation_is_exact_at_the_ends_and_follows_ids_across_resorts() {
    let params = FluidParamsBuilder::water(0.04).build().unwrap();
    let mut scene = dam_break(&DamBreakConfig::tower(params, 0.6)).unwrap();
    let fluid = scene.fluid;
    // Let the column collapse a while, so particles change cells and the order changes.
    for _ in 0..20 {
        scene.world.step().unwrap();
    }
    let mut lerp = Interpolation::new();
    lerp.record(&scene.world.fluids[fluid]);
    let before = by_id(
        scene.world.fluids[fluid].ids(),
        scene.world.fluids[fluid].positions(),
    );
    let ids_before = scene.world.fluids[fluid].ids().to_vec();
    scene.world.step().unwrap();
    let f = &scene.world.fluids[fluid];
    lerp.record(f);
    assert_ne!(
        ids_before,
        f.ids(),
        "the step did not re-sort the particles: the test would not test the ids"
    );
    assert_eq!(lerp.ids(), f.ids());

    let at0 = lerp.positions(0.0).unwrap().to_vec();
    for (k, &id) in f.ids().iter().enumerate() {
        assert_eq!(at0[k], before[&id], "particle {id} at α = 0");
    }
    let at1 = lerp.positions(1.0).unwrap().to_vec();
    assert_eq!(at1, f.positions());
    // Half-way: the mid-point of the same particle's two positions (not of two particles
    // that happen to share an index).
    let half = lerp.positions(0.5).unwrap().to_vec();
    let mut moved = 0;
    for (k, &id) in f.ids().iter().enumerate() {
        let mid = (before[&id] + f.positions()[k]) * 0.5;
        assert!((half[k] - mid).length() <= 1e-6 * (1.0 + mid.length()));
        moved += (before[&id] != f.positions()[k]) as usize;
    }
    assert!(moved > 0);

    assert!(matches!(
        lerp.positions(1.5),
        Err(SphError::InvalidParameter { field: "alpha", .. })
    ));
    assert!(lerp.positions(Vector::NAN.x).is_err());
}

/// Particles that are new since the previous record (emitted) stay at their position.
#[test]
fn interpolation_keeps_new_particles_at_their_latest_position() {
    let mut lerp = Interpolation::new();
    lerp.record_positions(&[0, 1], &[Vector::ZERO, Vector::X])
        .unwrap();
    lerp.record_positions(&[2, 1], &[Vector::Y, Vector::new(3.0, 0.0, 0.0)])
        .unwrap();
    let p = lerp.positions(0.5).unwrap();
    assert_eq!(p, &[Vector::Y, Vector::new(2.0, 0.0, 0.0)]);
    assert!(lerp.record_positions(&[0], &[]).is_err());
}

/// Ihmsen et al. 2012, section 4: every potential is scaled by the clamped kinetic energy
/// (eq. 8), so a liquid at rest generates nothing. The column settles in its tank for
/// 1 s (its particles then move at millimetres per second, far below the 1 m/s where the
/// default kinetic-energy clamp starts).
#[test]
fn no_diffuse_particle_is_created_in_a_liquid_at_rest() {
    let params = FluidParamsBuilder::water(0.04).build().unwrap();
    let mut config = DamBreakConfig::tower(params, 0.6);
    // A layer that fills the tank's floor: nothing to collapse.
    config.counts = [24, 4, 6];
    config.tank_length_ratio = 1.0;
    let mut scene = dam_break(&config).unwrap();
    let mut diffuse = DiffuseParticles::new(DiffuseSettings::default()).unwrap();
    let dt = scene.world.physics.integration_parameters.dt;
    let mut max_speed: f32 = 0.0;
    for _ in 0..60 {
        scene.world.step().unwrap();
        let f = &scene.world.fluids[scene.fluid];
        max_speed = f
            .velocities()
            .iter()
            .fold(max_speed, |m, v| m.max(v.length()));
        let report = diffuse.step(f, scene.world.physics.gravity, dt).unwrap();
        assert_eq!(report.created, 0);
        assert_eq!(report.dropped, 0);
    }
    assert!(diffuse.is_empty());
    assert!(max_speed < 1.0, "the layer is not at rest: {max_speed} m/s");
}

/// A collapsing column makes spray and foam, and the count never exceeds the cap (which
/// binds: some are refused).
#[test]
fn a_dam_break_makes_diffuse_particles_and_their_count_stays_under_the_cap() {
    let params = FluidParamsBuilder::water(0.04).build().unwrap();
    let mut scene = dam_break(&DamBreakConfig::tower(params, 0.8)).unwrap();
    let cap = 150;
    let mut diffuse = DiffuseParticles::new(DiffuseSettings {
        max_particles: cap,
        ..Default::default()
    })
    .unwrap();
    let dt = scene.world.physics.integration_parameters.dt;
    let (mut created, mut dropped) = (0, 0);
    let mut kinds = std::collections::HashSet::new();
    for _ in 0..90 {
        scene.world.step().unwrap();
        let f = &scene.world.fluids[scene.fluid];
        let n = f.len();
        let before: Vec<Vector> = f.positions().to_vec();
        let r = diffuse.step(f, scene.world.physics.gravity, dt).unwrap();
        created += r.created;
        dropped += r.dropped;
        assert!(diffuse.len() <= cap);
        assert_eq!(r.spray + r.foam + r.bubbles, diffuse.len());
        kinds.extend(diffuse.kinds().iter().copied());
        // Never fed back: the liquid is untouched.
        assert_eq!(scene.world.fluids[scene.fluid].len(), n);
        assert_eq!(scene.world.fluids[scene.fluid].positions(), &before[..]);
    }
    assert!(created > 0, "a dam break generated no diffuse particle");
    assert!(
        dropped > 0,
        "the cap never bound: the test does not test it"
    );
    assert!(kinds.contains(&DiffuseKind::Foam) || kinds.contains(&DiffuseKind::Spray));
    assert!(
        diffuse
            .positions()
            .iter()
            .all(|p| rapier_sph::math::is_finite(*p))
    );
}

#[test]
fn bad_settings_and_time_steps_are_refused() {
    let bad = DiffuseSettings {
        trapped_air: (20.0, 5.0),
        ..Default::default()
    };
    assert!(matches!(
        DiffuseParticles::new(bad),
        Err(SphError::InvalidParameter {
            field: "trapped_air",
            ..
        })
    ));
    let params = FluidParamsBuilder::water(0.05).build().unwrap();
    let fluid = rapier_sph::Fluid::new(params).unwrap();
    let mut d = DiffuseParticles::new(DiffuseSettings::default()).unwrap();
    assert!(matches!(
        d.step(&fluid, Vector::ZERO, 0.0),
        Err(SphError::InvalidTimeStep { .. })
    ));
    assert!(
        Anisotropy::new(AnisotropySettings {
            radius: -1.0,
            ..Default::default()
        })
        .is_err()
    );
}
