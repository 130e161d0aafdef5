//! Headless pictures: what is drawn lands where the camera says, colliders and particles
//! occlude correctly, PNG and GIF files are written and read back.
#![cfg(feature = "render")]

mod common;

use common::on_threads;
use rapier_sph::math::Vector;
use rapier_sph::render::{Camera, FluidStyle, GifWriter, Image, RenderOptions, Renderer};
use rapier_sph::{Fluid, FluidParamsBuilder, FluidWorld};
use rapier3d::prelude::{ColliderBuilder, RigidBodyBuilder};

fn tmp(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("rapier-sph-render-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn options() -> RenderOptions {
    RenderOptions {
        width: 160,
        height: 120,
        supersample: 1,
        fog: 0.0,
        ..RenderOptions::default()
    }
}

fn is_background(c: [u8; 3]) -> bool {
    // The background is a grey-blue gradient: all channels above 190 after gamma.
    c.iter().all(|&x| x > 190)
}

#[test]
fn an_empty_world_is_background_and_a_ball_shows_in_the_middle() {
    let camera = Camera::look_at(Vector::new(0.0, 0.0, 5.0), Vector::ZERO);
    let mut world = FluidWorld::new();
    let img = Renderer::new(options()).render_world(&camera, &world, None);
    assert_eq!(
        (img.width, img.height, img.rgb.len()),
        (160, 120, 160 * 120 * 3)
    );
    assert!((0..160).all(|x| is_background(img.pixel(x, 60))));

    let body = world.physics.insert_body(RigidBodyBuilder::fixed());
    world
        .physics
        .insert_collider(ColliderBuilder::ball(1.0), Some(body));
    let img = Renderer::new(options()).render_world(&camera, &world, None);
    // The ball (radius 1 at distance 5, 40° field of view) spans ±41 px around the center:
    // tan(11.5°)·60/tan(20°) ≈ 33.5 px, so ±30 px is inside and ±50 px outside.
    assert!(!is_background(img.pixel(80, 60)));
    assert!(!is_background(img.pixel(110, 60)));
    assert!(is_background(img.pixel(80 + 50, 60)));
    assert!(is_background(img.pixel(80, 60 - 50)));
}

#[test]
fn particles_are_drawn_coloured_by_speed_and_hidden_behind_opaque_colliders() {
    let params = FluidParamsBuilder::water(0.1).build().unwrap();
    let mut world = FluidWorld::new();
    let mut fluid = Fluid::new(params).unwrap();
    // A slow particle on the left and a fast one on the right.
    fluid
        .add_particles_with_velocities(
            &[Vector::new(-1.0, 0.0, 0.0), Vector::new(1.0, 0.0, 0.0)],
            Some(&[Vector::ZERO, Vector::new(0.0, 0.0, 3.0)]),
        )
        .unwrap();
    world.fluids.insert(fluid);
    let camera = Camera::look_at(Vector::new(0.0, 0.0, 5.0), Vector::ZERO);
    let mut renderer = Renderer::new(RenderOptions {
        style: FluidStyle::Spheres,
        particle_scale: 2.0, // radius 0.2 m: about 16 px
        ..options()
    });
    let img = renderer.render_world(&camera, &world, None);
    // x = ±1 at distance 5 projects to 80 ± 60/tan(20°)/5 ≈ 80 ± 33 px.
    let slow = img.pixel(80 - 33, 60);
    let fast = img.pixel(80 + 33, 60);
    assert!(!is_background(slow) && slow[2] > slow[0], "{slow:?}");
    // The fast particle is at the white end of the scale: brighter than the slow one.
    let lum = |c: [u8; 3]| c.iter().map(|&x| x as u32).sum::<u32>();
    assert!(lum(fast) > lum(slow) + 100, "{fast:?} vs {slow:?}");
    assert!(is_background(img.pixel(80, 60)));

    // A wall behind the particles (opaque, since it is farther than the fluid) does not
    // hide them; the same wall in front of them (nearer than the fluid) is translucent.
    let body = world.physics.insert_body(RigidBodyBuilder::fixed());
    let behind = world.physics.insert_collider(
        ColliderBuilder::cuboid(3.0, 3.0, 0.1).translation(Vector::new(0.0, 0.0, -1.0)),
        Some(body),
    );
    let img = renderer.render_world(&camera, &world, None);
    assert_eq!(img.pixel(80 - 33, 60), slow);
    assert!(!is_background(img.pixel(80, 60)));
    world.physics.remove_collider(behind);
    world.physics.insert_collider(
        ColliderBuilder::cuboid(3.0, 3.0, 0.1).translation(Vector::new(0.0, 0.0, 1.0)),
        Some(body),
    );
    let img = renderer.render_world(&camera, &world, None);
    let seen = img.pixel(80 - 33, 60);
    assert_ne!(seen, slow);
    assert!(
        seen[2] > seen[0],
        "the particle still shows through: {seen:?}"
    );
}

/// A collider given its own colour (`RenderOptions::collider_colors`) is drawn in it; the
/// other colliders keep the palette's.
#[test]
fn colliders_with_their_own_colour_are_drawn_in_it() {
    let params = FluidParamsBuilder::water(0.1).build().unwrap();
    let mut world = FluidWorld::new();
    let mut fluid = Fluid::new(params).unwrap();
    fluid.add_particles(&[Vector::new(0.0, 0.0, -1.0)]).unwrap();
    world.fluids.insert(fluid);
    let camera = Camera::look_at(Vector::new(0.0, 0.0, 5.0), Vector::ZERO);
    let body = world.physics.insert_body(RigidBodyBuilder::fixed());
    // A plate between the camera and the particle, on the left half of the view only.
    let plate = world.physics.insert_collider(
        ColliderBuilder::cuboid(1.0, 1.0, 0.05).translation(Vector::new(-1.0, 0.0, 1.0)),
        Some(body),
    );
    let options = RenderOptions {
        particle_scale: 2.0,
        style: rapier_sph::render::FluidStyle::Spheres,
        ..options()
    };
    let plain = Renderer::new(options.clone()).render_world(&camera, &world, None);
    let green = [0.1, 0.9, 0.1];
    let mut renderer = Renderer::new(RenderOptions {
        collider_colors: vec![(plate, green)],
        ..options
    });
    let coloured = renderer.render_world(&camera, &world, None);
    // The plate covers half the view: in its own colour, green pixels along the middle row;
    // in the default palette, none.
    let green_px = |img: &rapier_sph::render::Image| {
        (0..160)
            .map(|x| img.pixel(x, 60))
            .map(|c| c.map(u32::from))
            .filter(|c| c[1] > 2 * c[0] && c[1] > 2 * c[2])
            .count()
    };
    assert!(
        green_px(&coloured) > 40,
        "{} green pixels",
        green_px(&coloured)
    );
    assert_eq!(green_px(&plain), 0);
}

#[test]
fn png_and_gif_files_are_written() {
    let camera = Camera::orbit(Vector::ZERO, 5.0, 30.0, 20.0);
    let mut world = FluidWorld::new();
    let body = world.physics.insert_body(RigidBodyBuilder::fixed());
    world
        .physics
        .insert_collider(ColliderBuilder::cuboid(1.0, 0.5, 1.0), Some(body));
    let mut renderer = Renderer::new(options());
    let img = renderer.render_world(&camera, &world, None);
    let png = tmp("frame.png");
    img.save_png(&png).unwrap();
    assert_eq!(Image::load_png(&png).unwrap(), img);

    let gif = tmp("anim.gif");
    let mut writer = GifWriter::create(&gif, 160, 120, 5).unwrap();
    for k in 0..3 {
        let img = renderer.render_world(&camera.rotated(30.0 * k as f32), &world, None);
        writer.add_frame(&img).unwrap();
    }
    let wrong = Image {
        width: 10,
        height: 10,
        rgb: vec![0; 300],
    };
    assert!(writer.add_frame(&wrong).is_err());
    writer.finish().unwrap();
    let bytes = std::fs::read(&gif).unwrap();
    assert!(bytes.starts_with(b"GIF89a"));
    // Three frames: three image descriptors (0x2C) after graphic control extensions.
    let frames = bytes.windows(2).filter(|w| w == &[0x21, 0xF9]).count();
    assert_eq!(frames, 3);
    assert!(matches!(
        Image::load_png(tmp("missing.png")),
        Err(rapier_sph::render::RenderError::Io { .. })
    ));
}

/// The screen-space style: a block of water in front of a wall reads as water (blue, the
/// wall's colour shifted towards blue by the absorption over its thickness), is opaque where
/// it is thick, and covers the block's silhouette (splats of 0.8 spacings around particles
/// that span ±0.25 m: the block's edge projects to about ±10 px at this distance).
#[test]
fn screen_space_water_is_blue_over_the_wall_behind_it_and_covers_the_block() {
    let params = FluidParamsBuilder::water(0.05).build().unwrap();
    let mut world = FluidWorld::new();
    let mut fluid = Fluid::new(params).unwrap();
    fluid
        .add_block(Vector::splat(-0.25), Vector::splat(0.5))
        .unwrap();
    world.fluids.insert(fluid);
    let body = world.physics.insert_body(RigidBodyBuilder::fixed());
    // A fixed box far behind (a light stone-grey cuboid in the palette).
    world.physics.insert_collider(
        ColliderBuilder::cuboid(5.0, 5.0, 0.1).translation(Vector::new(0.0, 0.0, -3.0)),
        Some(body),
    );
    let camera = Camera::look_at(Vector::new(0.0, 0.0, 5.0), Vector::ZERO);
    let mut renderer = Renderer::new(options());
    let img = renderer.render_world(&camera, &world, None);
    let wall = img.pixel(5, 5);
    let water = img.pixel(80, 60);
    // The wall is grey (channels within 10 of each other); the water in front is blue.
    assert!(wall[0].abs_diff(wall[2]) < 12, "wall {wall:?}");
    assert!(
        water[2] as i32 > water[0] as i32 + 60,
        "water {water:?} over wall {wall:?}"
    );
    // The block projects to ±0.25/4.75 · 60/tan(20°) ≈ ±8.7 px (front face): inside is
    // water, 20 px out is the wall.
    let inside = img.pixel(80 + 6, 60 - 6);
    assert!(inside[2] as i32 > inside[0] as i32 + 40, "{inside:?}");
    assert_eq!(img.pixel(80 + 20, 60), img.pixel(80 + 30, 60));
}

/// The frame is the same for any number of threads (the per-pixel passes run over fixed
/// chunks, the splats bands of rows each in the splats' order).
#[test]
fn screen_space_frames_do_not_depend_on_the_thread_count() {
    let params = FluidParamsBuilder::water(0.05).build().unwrap();
    let mut scene =
        rapier_sph::scenes::dam_break(&rapier_sph::scenes::DamBreakConfig::tower(params, 0.5))
            .unwrap();
    for _ in 0..20 {
        scene.world.step().unwrap();
    }
    let mut foam = rapier_sph::render::WorldDiffuse::new(Default::default()).unwrap();
    foam.step(&scene.world).unwrap();
    let camera = Camera::framing(scene.tank_min, scene.tank_max, 30.0, 25.0);
    let draw = |threads: usize| {
        on_threads(threads, || {
            Renderer::new(options()).render_world_with(&camera, &scene.world, None, &foam.layers())
        })
    };
    assert_eq!(draw(1), draw(3));
}

/// Colliders are told apart by colour: a dynamic body orange, a fixed ball red, a fixed
/// wall grey (see `RenderOptions::collider_palette`).
#[test]
fn colliders_are_coloured_by_kind() {
    let mut world = FluidWorld::new();
    let fixed = world.physics.insert_body(RigidBodyBuilder::fixed());
    world.physics.insert_collider(
        ColliderBuilder::ball(0.5).translation(Vector::new(-1.2, 0.0, 0.0)),
        Some(fixed),
    );
    world.physics.insert_collider(
        ColliderBuilder::cuboid(3.0, 3.0, 0.1).translation(Vector::new(0.0, 0.0, -2.0)),
        Some(fixed),
    );
    let crate_body = world
        .physics
        .insert_body(RigidBodyBuilder::dynamic().translation(Vector::new(1.2, 0.0, 0.0)));
    world
        .physics
        .insert_collider(ColliderBuilder::cuboid(0.4, 0.4, 0.4), Some(crate_body));
    let camera = Camera::look_at(Vector::new(0.0, 0.0, 5.0), Vector::ZERO);
    let img = Renderer::new(options()).render_world(&camera, &world, None);
    // x = ±1.2 at distance 5 projects to 80 ± 40 px.
    let ball = img.pixel(80 - 40, 60);
    let crate_ = img.pixel(80 + 40, 60);
    let wall = img.pixel(80, 20);
    assert!(ball[0] as i32 > ball[1] as i32 + 60, "ball {ball:?}");
    assert!(
        crate_[0] > crate_[1] && crate_[1] as i32 > crate_[2] as i32 + 40,
        "crate {crate_:?}"
    );
    assert!(wall[0].abs_diff(wall[2]) < 12, "wall {wall:?}");
}
