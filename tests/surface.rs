//! Liquid surfaces with splashsurf: a settled block's surface encloses the fluid's volume,
//! and a blob's surface is closed (every edge shared by exactly two triangles).
#![cfg(feature = "surface")]

use rapier_sph::math::Vector;
use rapier_sph::scenes::add_closed_box;
use rapier_sph::surface::{SurfaceOptions, SurfaceWorker, reconstruct, reconstruct_points};
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

/// The particles of a settled block: 12 × 8 × 12 water particles at 5 cm, 0.3 s in a box.
fn settled_block() -> (Vec<Vector>, f32) {
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
    let h = world.fluids.insert(fluid);
    world.physics.integration_parameters.dt = 0.0005;
    for _ in 0..600 {
        world.step().unwrap();
    }
    (world.fluids[h].positions().to_vec(), s)
}

/// Mean angle (degrees) between the vertex normals of the top of the block's surface (the
/// upward-facing vertices above the middle of the block) and the vertical: 0 for a flat lid.
fn top_roughness(mesh: &rapier_sph::mesh::TriangleMesh, y_mid: f32, inner: (f32, f32)) -> f64 {
    let normals = mesh.vertex_normals();
    let (mut sum, mut n) = (0.0f64, 0usize);
    for (v, nrm) in mesh.vertices.iter().zip(&normals) {
        if v.y > y_mid
            && nrm.y > 0.5
            && v.x > inner.0
            && v.x < inner.1
            && v.z > inner.0
            && v.z < inner.1
        {
            sum += (nrm.y.clamp(-1.0, 1.0) as f64).acos().to_degrees();
            n += 1;
        }
    }
    assert!(n > 20, "too few top vertices: {n}");
    sum / n as f64
}

/// `SurfaceOptions::smooth()` flattens the lid of a settled block (the particle layers'
/// ridges) compared with the defaults and makes fewer triangles (cleanup and decimation).
/// Its lower iso-surface threshold (0.4 of the rest density, which closes the holes of thin
/// streams) puts the surface farther out, so the block's volume grows (+16 % here).
#[test]
fn the_smooth_settings_flatten_the_lid_of_a_settled_block() {
    let (points, s) = settled_block();
    let expected = points.len() as f64 * (s as f64).powi(3);
    let plain = reconstruct_points(&points, s, 1000.0, &SurfaceOptions::default()).unwrap();
    let smooth = reconstruct_points(&points, s, 1000.0, &SurfaceOptions::smooth()).unwrap();
    let mid = 4.0 * s;
    let inner = (3.0 * s, 9.0 * s);
    let (r_plain, r_smooth) = (
        top_roughness(&plain, mid, inner),
        top_roughness(&smooth, mid, inner),
    );
    println!(
        "lid roughness {r_plain:.2}° → {r_smooth:.2}°, triangles {} → {}, volume {:+.1} % → {:+.1} %",
        plain.triangles.len(),
        smooth.triangles.len(),
        100.0 * (plain.signed_volume() / expected - 1.0),
        100.0 * (smooth.signed_volume() / expected - 1.0)
    );
    assert!(r_smooth < 0.5 * r_plain, "{r_plain}° → {r_smooth}°");
    assert!(smooth.triangles.len() < plain.triangles.len());
    assert!(smooth.signed_volume() > plain.signed_volume());
}

/// The worker returns the mesh the direct call makes from the same positions, refuses a
/// second job while one is in flight, and reports bad input as an error.
#[test]
fn the_worker_thread_returns_the_same_mesh_later() {
    let (points, s) = settled_block();
    let options = SurfaceOptions {
        multi_threading: false,
        ..SurfaceOptions::smooth()
    };
    let direct = reconstruct_points(&points, s, 1000.0, &options).unwrap();
    let mut worker = SurfaceWorker::spawn(options);
    assert!(worker.try_take().is_none());
    let job = worker.submit_points(points.clone(), s, 1000.0).unwrap();
    assert!(worker.submit_points(points.clone(), s, 1000.0).is_none());
    let frame = worker.wait().unwrap().unwrap();
    assert_eq!(frame.job, job);
    assert_eq!(frame.mesh, direct);
    assert!(frame.seconds > 0.0);
    let job = worker
        .submit_points(vec![Vector::new(f32::NAN, 0.0, 0.0)], s, 1000.0)
        .unwrap();
    assert_eq!(job, 1);
    assert!(worker.wait().unwrap().is_err());
    assert!(worker.wait().is_none());
}

/// Smoothed centers (Yu & Turk's λ) shrink the surface, as `SurfaceOptions` documents.
#[test]
fn smoothed_centers_pull_the_surface_in() {
    let (points, s) = settled_block();
    let volume = |l: f32| {
        let o = SurfaceOptions {
            smoothed_centers: l,
            ..SurfaceOptions::default()
        };
        reconstruct_points(&points, s, 1000.0, &o)
            .unwrap()
            .signed_volume()
    };
    let (v0, v5, v9) = (volume(0.0), volume(0.5), volume(0.9));
    println!("volume at λ = 0, 0.5, 0.9: {v0:.5} {v5:.5} {v9:.5}");
    assert!(v9 < v5 && v5 < v0);
    let bad = SurfaceOptions {
        smoothed_centers: 2.0,
        ..SurfaceOptions::default()
    };
    assert!(reconstruct_points(&points, s, 1000.0, &bad).is_err());
}
