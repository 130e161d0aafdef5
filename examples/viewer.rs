//! An interactive window for scene files (kiss3d, the engine of rapier's own testbed).
//!
//! ```text
//! cargo run --release --example viewer --features viewer -- scenes/water_obstacles.ron
//! cargo run --release --example viewer --features viewer -- scenes/dam_break.ron --frames 60 --screenshot shot.png
//! ```
//!
//! Mouse: orbit (left drag), pan (right drag), zoom (wheel). Keys: Space pauses and resumes,
//! N steps one frame while paused, Escape quits. The overlay shows the particle count, the
//! simulated time, steps per second and the density error of the last step.
//!
//! `--frames N` quits after N frames; with `--screenshot FILE` it saves the window's last
//! frame as PNG first (used to check the viewer headlessly under Xvfb).

use kiss3d::prelude::*;
use rapier_sph::mesh::{TessellationOptions, TriangleMesh};
use rapier_sph::render::speed_color;
use rapier_sph::scene_file::SceneFile;
use std::time::Instant;

struct Args {
    scene: String,
    frames: Option<usize>,
    screenshot: Option<String>,
}

fn parse_args() -> Result<Args, String> {
    let mut it = std::env::args().skip(1);
    let mut args = Args {
        scene: String::new(),
        frames: None,
        screenshot: None,
    };
    while let Some(a) = it.next() {
        match a.as_str() {
            "--frames" => {
                let v = it.next().ok_or("--frames needs a number")?;
                args.frames = Some(v.parse().map_err(|_| "--frames needs a number")?);
            }
            "--screenshot" => args.screenshot = Some(it.next().ok_or("--screenshot needs a file")?),
            "-h" | "--help" => {
                return Err("usage: viewer SCENE.ron [--frames N] [--screenshot FILE.png]".into());
            }
            s if args.scene.is_empty() && !s.starts_with('-') => args.scene = s.to_string(),
            s => return Err(format!("unexpected argument {s}")),
        }
    }
    if args.scene.is_empty() {
        return Err("usage: viewer SCENE.ron [--frames N] [--screenshot FILE.png]".into());
    }
    Ok(args)
}

/// One vertex per triangle corner, so kiss3d's computed normals give flat faces.
fn unwelded(m: &TriangleMesh) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut v = Vec::with_capacity(m.triangles.len() * 3);
    let mut t = Vec::with_capacity(m.triangles.len());
    for tri in &m.triangles {
        let base = v.len() as u32;
        for &i in tri {
            v.push(m.vertices[i as usize]);
        }
        t.push([base, base + 1, base + 2]);
    }
    (v, t)
}

#[kiss3d::main]
async fn main() {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2);
        }
    };
    let (_scene, mut built) = match SceneFile::load_and_build(&args.scene) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };

    let mut window = Window::new_with_size("rapier-sph viewer", 960, 600).await;
    window.set_background_color(Color::new(0.85, 0.88, 0.92, 1.0));
    let start = built.camera.camera_at(&built.world, 0.0);
    let mut camera = OrbitCamera3d::new(start.eye, start.target);
    let mut root = SceneNode3d::empty();
    root.add_light(Light::point(100.0))
        .set_position(start.eye + Vec3::new(0.0, 5.0, 0.0));

    // One scene node per collider (in its own frame), moved to the collider's pose each frame.
    let mut colliders = Vec::new();
    for (handle, c) in built.world.physics.colliders.iter() {
        if c.is_sensor() {
            continue;
        }
        if let Some(m) = TriangleMesh::from_shape(c.shape(), &TessellationOptions::default()) {
            if m.is_empty() {
                continue;
            }
            let (v, t) = unwelded(&m);
            let mesh = Rc::new(RefCell::new(GpuMesh3d::new(v, t, None, None, false)));
            let node = root
                .add_mesh(mesh, Vec3::ONE)
                .set_color(Color::new(0.62, 0.6, 0.55, 0.3)) // translucent: tanks do not hide the fluid
                .enable_backface_culling(false);
            colliders.push((handle, node));
        }
    }

    let font = Font::default();
    let max_speed = (2.0 * 9.81 * 1.0f32).sqrt();
    let mut paused = false;
    let mut frame = 0usize;
    let mut steps = 0usize;
    let mut sim_seconds = 0.0f64;
    let mut steps_per_second = 0.0f64;
    let mut error: Option<String> = None;
    while window.render_3d(&mut root, &mut camera).await {
        let mut step_once = false;
        for event in window.events().iter() {
            if let WindowEvent::Key(key, Action::Press, _) = event.value {
                match key {
                    Key::Space => paused = !paused,
                    Key::N => step_once = true,
                    _ => {}
                }
            }
        }
        if (!paused || step_once) && error.is_none() {
            let t = Instant::now();
            for _ in 0..built.steps_per_frame {
                if let Err(e) = built.world.step() {
                    error = Some(e.to_string());
                    break;
                }
                steps += 1;
            }
            let dt = t.elapsed().as_secs_f64();
            sim_seconds += dt;
            steps_per_second = built.steps_per_frame as f64 / dt.max(1e-9);
            frame += 1;
        }
        for (handle, node) in &mut colliders {
            if let Some(c) = built.world.physics.colliders.get(*handle) {
                node.set_pose(*c.position());
            }
        }
        for (_, f) in built.world.fluids.iter() {
            let size = 6.0;
            for (p, v) in f.positions().iter().zip(f.velocities()) {
                let c = speed_color(v.length() / max_speed);
                window.draw_point(
                    *p,
                    Color::new(c[0].sqrt(), c[1].sqrt(), c[2].sqrt(), 1.0),
                    size,
                );
            }
        }
        let r = built.world.pipeline.report();
        let line1 = format!(
            "particles {}   t = {:.2} s   {:.0} steps/s",
            built.world.fluids.num_particles(),
            steps as f32 * built.dt,
            steps_per_second,
        );
        let line2 = format!(
            "density error: max {:.1} %, mean {:.1} %{}{}",
            100.0 * r.max_density_error,
            100.0 * r.mean_density_error,
            if paused {
                "   [paused: Space resumes, N steps]"
            } else {
                ""
            },
            error
                .as_deref()
                .map(|e| format!("   error: {e}"))
                .unwrap_or_default(),
        );
        let ink = Color::new(0.05, 0.05, 0.1, 1.0);
        window.draw_text(&line1, Vec2::new(10.0, 10.0), 30.0, &font, ink);
        window.draw_text(&line2, Vec2::new(10.0, 44.0), 30.0, &font, ink);
        if let Some(n) = args.frames
            && frame >= n
        {
            if let Some(path) = &args.screenshot {
                match window.snap_image().save(path) {
                    Ok(()) => println!("screenshot saved to {path}"),
                    Err(e) => {
                        eprintln!("error: {path}: {e}");
                        std::process::exit(1);
                    }
                }
            }
            println!(
                "{frame} frames, {steps} steps in {sim_seconds:.2} s of simulation ({:.0} steps/s)",
                steps as f64 / sim_seconds.max(1e-9)
            );
            break;
        }
    }
}
