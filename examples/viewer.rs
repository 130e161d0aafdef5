//! An interactive window for scene files (kiss3d, the engine of rapier's own testbed), with
//! the water drawn by screen-space fluid rendering on the GPU (`viewer_gpu/water.rs`: the
//! particles' ellipsoids splatted to depth, a narrow-range depth filter, normals, thickness,
//! Fresnel reflection and refraction of the scene behind, foam on top) and the colliders
//! solid, coloured by kind.
//!
//! ```text
//! cargo run --release --example viewer --features viewer -- scenes/water_obstacles.ron
//! cargo run --release --example viewer --features viewer -- scenes/dam_break.ron --frames 60 --screenshot shot.png
//! ```
//!
//! Mouse: orbit (left drag), pan (right drag), zoom (wheel). Keys: Space pauses and resumes,
//! N steps one frame while paused, W switches between the water and speed-coloured points,
//! Escape quits. The overlay shows the particle count, the simulated time, steps per second
//! and the density error of the last step.
//!
//! `--frames N` quits after N frames; with `--screenshot FILE` it saves the window's last
//! frame as PNG first (used to check the viewer headlessly under Xvfb). `--points` starts
//! with the points. `--spacing S` overrides every fluid's particle spacing (m) and
//! `--sim-frames N` stops the simulation after N frames and keeps drawing, so that the
//! drawing's cost can be timed alone: the viewer prints the median frame time of the frames
//! after the N-th. `--water-repeat K` runs the water's passes K times a frame (the same
//! image), to time them: the frame grows by (K − 1) times their cost.

#[path = "viewer_gpu/colliders.rs"]
mod colliders;
#[path = "viewer_gpu/water.rs"]
mod water;

use kiss3d::glamx::Mat4;
use kiss3d::post_processing::PostProcessingEffect;
use kiss3d::prelude::*;
use rapier_sph::render::{WorldDiffuse, speed_color};
use rapier_sph::scene_file::{Positive, SceneFile};
use rapier_sph::visual::{Anisotropy, AnisotropySettings, DiffuseKind, DiffuseSettings};
use std::path::Path;
use std::time::Instant;

const USAGE: &str = "usage: viewer SCENE.ron [--frames N] [--screenshot FILE.png] [--points] \
                     [--spacing S] [--sim-frames N] [--water-repeat K]";

struct Args {
    scene: String,
    frames: Option<usize>,
    screenshot: Option<String>,
    points: bool,
    spacing: Option<f32>,
    sim_frames: Option<usize>,
    water_repeat: usize,
}

fn number<T: std::str::FromStr>(v: Option<String>, flag: &str) -> Result<T, String> {
    v.and_then(|v| v.parse().ok())
        .ok_or(format!("{flag} needs a number"))
}

fn parse_args() -> Result<Args, String> {
    let mut it = std::env::args().skip(1);
    let mut args = Args {
        scene: String::new(),
        frames: None,
        screenshot: None,
        points: false,
        spacing: None,
        sim_frames: None,
        water_repeat: 1,
    };
    while let Some(a) = it.next() {
        match a.as_str() {
            "--frames" => args.frames = Some(number(it.next(), "--frames")?),
            "--screenshot" => args.screenshot = Some(it.next().ok_or("--screenshot needs a file")?),
            "--points" => args.points = true,
            "--spacing" => args.spacing = Some(number(it.next(), "--spacing")?),
            "--sim-frames" => args.sim_frames = Some(number(it.next(), "--sim-frames")?),
            "--water-repeat" => args.water_repeat = number(it.next(), "--water-repeat")?,
            "-h" | "--help" => return Err(USAGE.into()),
            s if args.scene.is_empty() && !s.starts_with('-') => args.scene = s.to_string(),
            s => return Err(format!("unexpected argument {s}")),
        }
    }
    if args.scene.is_empty() {
        return Err(USAGE.into());
    }
    Ok(args)
}

/// The scene file, with every fluid's spacing overridden by `--spacing`.
fn load(args: &Args) -> Result<rapier_sph::scene_file::BuiltScene, String> {
    let Some(spacing) = args.spacing else {
        return SceneFile::load_and_build(&args.scene)
            .map(|(_, b)| b)
            .map_err(|e| e.to_string());
    };
    let mut scene = SceneFile::load(&args.scene).map_err(|e| e.to_string())?;
    for f in &mut scene.fluids {
        f.particle_spacing = Some(Positive(spacing));
    }
    let path = Path::new(&args.scene);
    scene
        .build(path, path.parent().unwrap_or(Path::new(".")))
        .map_err(|e| e.to_string())
}

/// The water's inputs, recomputed after each simulated frame: ellipsoids and foam dots.
struct WaterInput {
    anisotropy: Vec<Anisotropy>,
    diffuse: WorldDiffuse,
    splats: Vec<water::Splat>,
    dots: Vec<water::Splat>,
    spacing: f32,
    /// Where the see-through test looks from: the fluid's centroid.
    center: Vec3,
    /// The world moved since the last `compute`.
    stale: bool,
}

impl WaterInput {
    fn new() -> Self {
        Self {
            anisotropy: Vec::new(),
            diffuse: WorldDiffuse::new(DiffuseSettings::default()).expect("defaults are valid"),
            splats: Vec::new(),
            dots: Vec::new(),
            spacing: 0.0,
            center: Vec3::ZERO,
            stale: true,
        }
    }

    /// The ellipsoids (`particle_radius` 0.8 spacings, as the CPU path's defaults).
    fn compute(&mut self, world: &rapier_sph::FluidWorld) {
        self.stale = false;
        self.splats.clear();
        let (mut sum, mut n) = (Vec3::ZERO, 0usize);
        for (k, (_, f)) in world.fluids.iter().enumerate() {
            if self.anisotropy.len() <= k {
                let s = AnisotropySettings {
                    particle_radius: 0.8,
                    ..AnisotropySettings::default()
                };
                self.anisotropy
                    .push(Anisotropy::new(s).expect("valid settings"));
            }
            self.spacing = self.spacing.max(f.params().particle_spacing);
            for e in self.anisotropy[k].compute(f) {
                let row = |k: usize| e.axes[k] / e.radii[k].max(1e-9);
                let (r0, r1, r2) = (row(0), row(1), row(2));
                let c = e.center;
                self.splats.push([
                    c.x, c.y, c.z, e.radii[0], r0.x, r0.y, r0.z, 0.0, r1.x, r1.y, r1.z, 0.0, r2.x,
                    r2.y, r2.z, 0.0,
                ]);
                sum += c;
                n += 1;
            }
        }
        if n > 0 {
            self.center = sum / n as f32;
        }
        self.foam_dots();
    }

    /// Foam, spray and bubbles: dots of 0.45 spacings, coverage weights of the CPU path.
    fn foam_dots(&mut self) {
        self.dots.clear();
        let r = 0.45 * self.spacing;
        for layer in self.diffuse.layers() {
            for (p, kind) in layer.positions().iter().zip(layer.kinds()) {
                let weight = match kind {
                    DiffuseKind::Foam => 0.45,
                    DiffuseKind::Spray => 0.4,
                    DiffuseKind::Bubble => 0.12,
                };
                let i = 1.0 / r;
                self.dots.push([
                    p.x, p.y, p.z, r, i, 0.0, 0.0, weight, 0.0, i, 0.0, 0.0, 0.0, 0.0, i, 0.0,
                ]);
            }
        }
    }
}

/// Frame timings (s) and the overlay's counters.
#[derive(Default)]
struct Stats {
    frame: usize,
    steps: usize,
    sim_seconds: f64,
    steps_per_second: f64,
    /// Wall time per frame of the frames that did not simulate (drawing alone).
    draw_only: Vec<f64>,
    /// Of which: ellipsoids, foam and uploads (CPU).
    prep: Vec<f64>,
    paused: bool,
    /// The step's error, if it failed (the simulation stops).
    error: Option<String>,
}

fn median_ms(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        0.0
    } else {
        1e3 * v[v.len() / 2]
    }
}

/// Steps the world one frame (and the foam after each step).
fn simulate(
    built: &mut rapier_sph::scene_file::BuiltScene,
    input: &mut WaterInput,
    stats: &mut Stats,
) -> Result<(), String> {
    let t = Instant::now();
    for _ in 0..built.steps_per_frame {
        built.world.step().map_err(|e| e.to_string())?;
        input
            .diffuse
            .step(&built.world)
            .map_err(|e| e.to_string())?;
        stats.steps += 1;
    }
    let dt = t.elapsed().as_secs_f64();
    stats.sim_seconds += dt;
    stats.steps_per_second = built.steps_per_frame as f64 / dt.max(1e-9);
    Ok(())
}

fn overlay(window: &mut Window, built: &rapier_sph::scene_file::BuiltScene, s: &Stats) {
    let note = match (&s.error, s.paused) {
        (Some(e), _) => format!("   error: {e}"),
        (None, true) => "   [paused: Space resumes, N steps]".to_string(),
        _ => String::new(),
    };
    let r = built.world.pipeline.report();
    let line1 = format!(
        "particles {}   t = {:.2} s   {:.0} steps/s",
        built.world.fluids.num_particles(),
        s.steps as f32 * built.dt,
        s.steps_per_second,
    );
    let line2 = format!(
        "density error: max {:.1} %, mean {:.1} %{note}",
        100.0 * r.max_density_error,
        100.0 * r.mean_density_error,
    );
    let font = Font::default();
    let ink = Color::new(0.05, 0.05, 0.1, 1.0);
    window.draw_text(&line1, Vec2::new(10.0, 10.0), 30.0, &font, ink);
    window.draw_text(&line2, Vec2::new(10.0, 44.0), 30.0, &font, ink);
}

fn draw_points(window: &mut Window, world: &rapier_sph::FluidWorld) {
    let max_speed = (2.0 * 9.81 * 1.0f32).sqrt();
    for (_, f) in world.fluids.iter() {
        for (p, v) in f.positions().iter().zip(f.velocities()) {
            let c = speed_color(v.length() / max_speed);
            let color = Color::new(c[0].sqrt(), c[1].sqrt(), c[2].sqrt(), 1.0);
            window.draw_point(*p, color, 6.0);
        }
    }
}

fn save_and_report(window: &Window, args: &Args, s: &Stats) {
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
        "{} frames, {} steps in {:.2} s of simulation ({:.0} steps/s)",
        s.frame,
        s.steps,
        s.sim_seconds,
        s.steps as f64 / s.sim_seconds.max(1e-9)
    );
    if !s.draw_only.is_empty() {
        println!(
            "drawing alone ({}): median {:.1} ms per frame over {} frames (ellipsoids, foam and \
             uploads {:.1} ms of it)",
            if args.points {
                "points"
            } else {
                "screen-space water"
            },
            median_ms(&s.draw_only),
            s.draw_only.len(),
            median_ms(&s.prep),
        );
    }
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
    let built = match load(&args) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };

    let mut window = Window::new_with_size("rapier-sph viewer", 960, 600).await;
    window.set_background_color(Color::new(0.85, 0.88, 0.92, 1.0));
    let start = built.camera.camera_at(&built.world, 0.0);
    let fov = start.fov_y_degrees.to_radians();
    let camera = OrbitCamera3d::new_with_frustum(fov, 0.05, 200.0, start.eye, start.target);
    let mut root = SceneNode3d::empty();
    let light = Vec3::new(0.4, 1.0, 0.3);
    root.add_light(Light::point(100.0))
        .set_position(start.eye + Vec3::new(0.0, 5.0, 0.0));
    let colliders = colliders::Colliders::new(&built.world, &mut root);
    let mut input = WaterInput::new();
    input.compute(&built.world);
    let mut gpu = water::GpuWater::new(water::View {
        view: Mat4::IDENTITY,
        fov,
        znear: 0.05,
        zfar: 200.0,
        light,
        spacing: input.spacing,
    });
    gpu.repeat = args.water_repeat;
    gpu.set_splats(&input.splats);
    gpu.set_foam(&input.dots);
    let mut app = App {
        built,
        window,
        camera,
        root,
        colliders,
        input,
        gpu,
    };
    app.run(&args).await;
}

/// Everything the frame loop draws and steps.
struct App {
    built: rapier_sph::scene_file::BuiltScene,
    window: Window,
    camera: OrbitCamera3d,
    root: SceneNode3d,
    colliders: colliders::Colliders,
    input: WaterInput,
    gpu: water::GpuWater,
}

impl App {
    /// Steps (unless paused or past `--sim-frames`), prepares the water or the points, draws.
    /// Returns whether it simulated and whether the window is still open.
    async fn frame(&mut self, simulate_now: bool, points: bool, stats: &mut Stats) -> bool {
        let frame_start = Instant::now();
        let App {
            built,
            window,
            camera,
            root,
            colliders,
            input,
            gpu,
        } = self;
        if simulate_now && let Err(e) = simulate(built, input, stats) {
            stats.error = Some(e);
        }
        stats.frame += 1;
        input.stale |= simulate_now;
        let prep = Instant::now();
        let occluders = colliders.update(&built.world, window, (camera.eye(), input.center));
        if !points {
            if input.stale {
                input.compute(&built.world);
                gpu.set_splats(&input.splats);
                gpu.set_foam(&input.dots);
            }
            gpu.set_colliders(&occluders);
            gpu.view.view = camera.view_transform().to_mat4();
        } else {
            draw_points(window, &built.world);
        }
        let prep = prep.elapsed().as_secs_f64();
        overlay(window, built, stats);
        let alive = if points {
            window.render_3d(root, camera).await
        } else {
            {
                let effect: &mut dyn PostProcessingEffect = &mut *gpu;
                window
                    .render_3d_with_chain(root, camera, &mut [effect])
                    .await
            }
        };
        if !simulate_now {
            stats.draw_only.push(frame_start.elapsed().as_secs_f64());
            stats.prep.push(prep);
        }
        alive
    }

    /// The frame loop.
    async fn run(&mut self, args: &Args) {
        let (mut paused, mut points) = (false, args.points);
        let mut stats = Stats::default();
        let mut step_once = false;
        loop {
            let sim_allowed = args.sim_frames.is_none_or(|n| stats.frame < n);
            let simulate_now = (!paused || step_once) && stats.error.is_none() && sim_allowed;
            stats.paused = paused;
            if !self.frame(simulate_now, points, &mut stats).await {
                break;
            }
            step_once = false;
            for event in self.window.events().iter() {
                if let WindowEvent::Key(key, Action::Press, _) = event.value {
                    match key {
                        Key::Space => paused = !paused,
                        Key::N => step_once = true,
                        Key::W => points = !points,
                        _ => {}
                    }
                }
            }
            if args.frames.is_some_and(|n| stats.frame >= n) {
                save_and_report(&self.window, args, &stats);
                break;
            }
        }
    }
}
