//! Exports read back: particles through VTK and PLY come back bitwise (the files hold the
//! solver's own f32/u32 values), meshes through OBJ, PLY and VTK likewise; bad files give
//! typed errors, not panics.
#![cfg(feature = "io")]

use rapier_sph::io::{self, ExportError, ParticleData};
use rapier_sph::math::Vector;
use rapier_sph::mesh::{TessellationOptions, TriangleMesh};
use rapier_sph::scenes::{DamBreakConfig, dam_break};
use rapier_sph::{Fluid, FluidParamsBuilder};

fn tmp(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("rapier-sph-export-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// A dam break with two fluids, stepped a few times so every attribute is non-trivial
/// (densities and pressures vary, velocities non-zero, ids permuted by the cell sort).
fn frame() -> (ParticleData, Vec<TriangleMesh>) {
    let params = FluidParamsBuilder::water(0.05).build().unwrap();
    let mut scene = dam_break(&DamBreakConfig::tower(params.clone(), 0.6)).unwrap();
    let mut second = Fluid::new(params).unwrap();
    second
        .add_block(Vector::new(0.5, 0.05, 0.05), Vector::new(0.15, 0.15, 0.15))
        .unwrap();
    scene.world.fluids.insert(second);
    scene.world.physics.integration_parameters.dt = 1.0 / 600.0;
    for _ in 0..5 {
        scene.world.step().unwrap();
    }
    let data = ParticleData::from_fluids(&scene.world.fluids);
    let meshes = TriangleMesh::from_colliders(
        &scene.world.physics.colliders,
        &TessellationOptions::default(),
    )
    .into_iter()
    .map(|(_, m)| m)
    .collect();
    (data, meshes)
}

fn assert_bitwise(a: &ParticleData, b: &ParticleData) {
    assert_eq!(a.len(), b.len());
    let bits = |v: &[Vector]| {
        v.iter()
            .map(|p| p.to_array().map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    let sbits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&a.positions), bits(&b.positions));
    assert_eq!(bits(&a.velocities), bits(&b.velocities));
    assert_eq!(sbits(&a.densities), sbits(&b.densities));
    assert_eq!(sbits(&a.pressures), sbits(&b.pressures));
    assert_eq!(a.fluid_ids, b.fluid_ids);
    assert_eq!(a.ids, b.ids);
}

#[test]
fn particles_round_trip_through_vtk_and_ply() {
    let (data, _) = frame();
    assert!(data.len() > 500);
    // The data is not trivial: two fluids, moving particles, varied densities.
    assert!(data.fluid_ids.contains(&1) && data.fluid_ids.contains(&0));
    assert!(data.velocities.iter().any(|v| v.length() > 0.0));
    assert!(data.densities.iter().any(|d| *d != data.densities[0]));

    let vtk = tmp("particles.vtk");
    io::write_particles_vtk(&vtk, &data).unwrap();
    assert_bitwise(&data, &io::read_particles_vtk(&vtk).unwrap());

    let ply = tmp("particles.ply");
    io::write_particles_ply(&ply, &data).unwrap();
    assert_bitwise(&data, &io::read_particles_ply(&ply).unwrap());
    // Binary PLY: 8 floats and 2 uints per particle plus a short header.
    let size = std::fs::metadata(&ply).unwrap().len() as usize;
    assert!(
        size >= 40 * data.len() && size < 40 * data.len() + 1024,
        "{size}"
    );
}

#[test]
fn meshes_round_trip_through_obj_ply_and_vtk() {
    let (_, meshes) = frame();
    assert_eq!(meshes.len(), 6); // the tank's six walls
    let mut tank = TriangleMesh::default();
    for m in &meshes {
        tank.append_transformed(m, &rapier_sph::math::Pose::IDENTITY);
    }
    let ball = TriangleMesh::from_shape(
        &parry3d::shape::Ball::new(0.3),
        &TessellationOptions::default(),
    )
    .unwrap();
    for mesh in [&tank, &ball] {
        let obj = tmp("mesh.obj");
        io::write_mesh_obj(&obj, mesh).unwrap();
        // tobj renumbers vertices in order of first use: compare the triangles' corners.
        assert_eq!(soup(&io::read_mesh_obj(&obj).unwrap()), soup(mesh));
        let ply = tmp("mesh.ply");
        io::write_mesh_ply(&ply, mesh).unwrap();
        assert_eq!(&io::read_mesh_ply(&ply).unwrap(), mesh);
        let vtk = tmp("mesh.vtk");
        io::write_mesh_vtk(&vtk, mesh).unwrap();
        assert_eq!(&io::read_mesh_vtk(&vtk).unwrap(), mesh);
    }
    assert!(ball.is_closed());
}

#[test]
fn bad_input_gives_typed_errors() {
    // A missing file.
    assert!(matches!(
        io::read_particles_vtk(tmp("missing.vtk")),
        Err(ExportError::Io { .. })
    ));
    assert!(matches!(
        io::read_mesh_obj(tmp("missing.obj")),
        Err(ExportError::Io { .. })
    ));
    // A truncated file.
    let (data, _) = frame();
    let vtk = tmp("truncated.vtk");
    io::write_particles_vtk(&vtk, &data).unwrap();
    let bytes = std::fs::read(&vtk).unwrap();
    std::fs::write(&vtk, &bytes[..bytes.len() / 2]).unwrap();
    assert!(io::read_particles_vtk(&vtk).is_err());
    let ply = tmp("truncated.ply");
    io::write_particles_ply(&ply, &data).unwrap();
    let bytes = std::fs::read(&ply).unwrap();
    std::fs::write(&ply, &bytes[..bytes.len() / 2]).unwrap();
    assert!(io::read_particles_ply(&ply).is_err());
    // Inconsistent data is refused before anything is written.
    let mut bad = data.clone();
    bad.densities.pop();
    assert!(matches!(
        io::write_particles_vtk(tmp("bad.vtk"), &bad),
        Err(ExportError::Inconsistent { .. })
    ));
    let mesh = TriangleMesh::from_parts(vec![Vector::ZERO; 2], vec![[0, 1, 2]]);
    assert!(matches!(
        io::write_mesh_obj(tmp("bad.obj"), &mesh),
        Err(ExportError::Inconsistent { .. })
    ));
    // A mesh file is not a particle file.
    let m = tmp("mesh_not_particles.vtk");
    io::write_mesh_vtk(&m, &mesh_tri()).unwrap();
    assert!(matches!(
        io::read_particles_vtk(&m),
        Err(ExportError::Inconsistent { .. })
    ));
}

fn mesh_tri() -> TriangleMesh {
    TriangleMesh::from_parts(vec![Vector::ZERO, Vector::X, Vector::Y], vec![[0, 1, 2]])
}

/// The mesh as a list of triangles of corner positions (bit patterns), independent of how
/// vertices are numbered.
fn soup(m: &TriangleMesh) -> Vec<[[u32; 3]; 3]> {
    m.triangles
        .iter()
        .map(|t| t.map(|i| m.vertices[i as usize].to_array().map(f32::to_bits)))
        .collect()
}

/// Every reader reads within `io::MAX_FILE_BYTES` and only regular files: a device
/// (`/dev/zero`, which would be read until memory ran out), a folder and a file one byte past
/// the limit (sparse: no disk used) are refused with an I/O error before they are read.
#[test]
fn reads_are_bounded() {
    let big = |ext: &str| {
        let p = tmp(&format!("big.{ext}"));
        std::fs::File::create(&p)
            .unwrap()
            .set_len(io::MAX_FILE_BYTES + 1)
            .unwrap();
        p
    };
    type Read = fn(&std::path::Path) -> Result<(), ExportError>;
    let readers: [(&str, Read); 5] = [
        ("obj", |p| io::read_mesh_obj(p).map(|_| ())),
        ("ply", |p| io::read_mesh_ply(p).map(|_| ())),
        ("ply", |p| io::read_particles_ply(p).map(|_| ())),
        ("vtk", |p| io::read_mesh_vtk(p).map(|_| ())),
        ("vtk", |p| io::read_particles_vtk(p).map(|_| ())),
    ];
    for (ext, read) in readers {
        let file = big(ext);
        match read(&file) {
            Err(ExportError::Io { source, .. }) => {
                assert!(source.to_string().contains("limit"), "{ext}: {source}")
            }
            other => panic!("{ext}: expected an I/O error, got {other:?}"),
        }
        std::fs::remove_file(&file).unwrap();
        // A folder named like a mesh file.
        let dir = tmp(&format!("folder.{ext}"));
        std::fs::create_dir_all(&dir).unwrap();
        assert!(matches!(read(&dir), Err(ExportError::Io { .. })), "{ext}");
        std::fs::remove_dir(&dir).unwrap();
    }
    let zero = std::path::Path::new("/dev/zero");
    if zero.exists() {
        assert!(matches!(
            io::read_mesh_obj(zero),
            Err(ExportError::Io { .. })
        ));
        assert!(matches!(
            io::read_particles_ply(zero),
            Err(ExportError::Io { .. })
        ));
    }
}
