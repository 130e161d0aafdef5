//! Liquid surfaces with splashsurf: a settled block's surface encloses the fluid's volume,
//! and a blob's surface is closed (every edge shared by exactly two triangles).
#![cfg(feature = "surface")]

use rapier_sph::math::Vector;
use rapier_sph::scenes::add_closed_box;
use rapier_sph::surface::{SurfaceOptions, reconstruct, reconstruct_points};
use rapier_sph::{Fluid, FluidParamsBuilder, FluidWorld};

#[test]
fn a_settled_block_encloses_its_volume_within_ten_percent() {
    // 12 × 8 × 12 particles of water at 5 cm in a box just as wide, settled for 0.3 s.
    // Its volume is N·s³ (each lattice particle stands for s³ of water).
    let s = 0.05;
    let params = FluidParamsBuilder::water(s).build().unwrap();
    let mut world = FluidWorld::new();
    let (nx, ny, nz) = (12, 8, 12);
    add_closed_box(
        &mut world,
        Vector::ZERO,
        Vector::new(nx as f32 * s, 2.0 * ny as f32 * s, nz as f32 * s),
        0.1,
    );
    let mut fluid = Fluid::new(params).unwrap();
    fluid
        .add_block(
            Vector::ZERO,
            Vector::new(nx as f32 * s, ny as f32 * s, nz as f32 * s) * 1.001,
        )
        .unwrap();
    assert_eq!(fluid.len(), nx * ny * nz);
    let h = world.fluids.insert(fluid);
    world.physics.integration_parameters.dt = 0.0005;
    for _ in 0..600 {
        world.step().unwrap();
    }
    let fluid = &world.fluids[h];
    let expected = fluid.len() as f64 * (s as f64).powi(3);
    let mesh = reconstruct(fluid, &SurfaceOptions::default()).unwrap();
    let volume = mesh.signed_volume();
    println!(
        "settled block: {} triangles, volume {volume:.5} m³ vs {expected:.5} m³ ({:+.1} %), open edges {}",
        mesh.triangles.len(),
        100.0 * (volume / expected - 1.0),
        mesh.non_manifold_edges()
    );
    assert!(
        (volume / expected - 1.0).abs() < 0.10,
        "volume {volume} vs {expected}"
    );
}

#[test]
fn a_blob_has_a_closed_surface() {
    // A ball of particles on a lattice, free in space.
    let s = 0.05;
    let mut points = Vec::new();
    for i in -6..=6 {
        for j in -6..=6 {
            for k in -6..=6 {
                let p = Vector::new(i as f32, j as f32, k as f32) * s;
                if p.length() <= 6.0 * s {
                    points.push(p);
                }
            }
        }
    }
    let mesh = reconstruct_points(&points, s, 1000.0, &SurfaceOptions::default()).unwrap();
    assert!(mesh.triangles.len() > 100);
    assert_eq!(
        mesh.non_manifold_edges(),
        0,
        "edges not shared by exactly two triangles"
    );
    assert!(mesh.is_closed());
    // Outward orientation: positive enclosed volume, near the ball's N·s³.
    let expected = points.len() as f64 * (s as f64).powi(3);
    let v = mesh.signed_volume();
    assert!(
        v > 0.0 && (v / expected - 1.0).abs() < 0.15,
        "{v} vs {expected}"
    );
}

#[test]
fn bad_input_is_refused() {
    let nan = [Vector::new(f32::NAN, 0.0, 0.0)];
    assert!(reconstruct_points(&nan, 0.05, 1000.0, &SurfaceOptions::default()).is_err());
    assert!(reconstruct_points(&[Vector::ZERO], -1.0, 1000.0, &SurfaceOptions::default()).is_err());
    let empty = reconstruct_points(&[], 0.05, 1000.0, &SurfaceOptions::default()).unwrap();
    assert!(empty.is_empty());
}
