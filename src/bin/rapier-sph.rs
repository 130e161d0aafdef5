//! `rapier-sph`: run and check scene files.
//!
//! ```text
//! rapier-sph run scenes/dam_break.ron --frames 300 --render out/ --export vtk --mesh
//! rapier-sph validate scenes/*.ron
//! ```
//!
//! Built with `cargo build --release --features cli` (add `surface` for `--mesh`).

use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use rapier_sph::Region;
use rapier_sph::io::{self, ParticleData};
use rapier_sph::mesh::{TessellationOptions, TriangleMesh};
use rapier_sph::rapier3d::prelude::ColliderHandle;
use rapier_sph::render::{FluidStyle, GifWriter, RenderOptions, Renderer, WorldDiffuse};
use rapier_sph::scene_file::SceneFile;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

#[derive(Parser)]
#[command(
    name = "rapier-sph",
    version,
    about = "Run and check rapier-sph scene files"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
enum Format {
    /// VTK legacy (ParaView).
    Vtk,
    /// Binary PLY (Blender, Houdini, MeshLab).
    Ply,
    /// Wavefront OBJ (meshes only; particles are then written as PLY).
    Obj,
}

#[derive(Subcommand)]
enum Command {
    /// Run a scene: step it, and write pictures, exports and a final state as asked.
    Run {
        /// The scene file (RON).
        scene: PathBuf,
        /// Number of frames (default: the scene's duration × frame rate).
        #[arg(long)]
        frames: Option<usize>,
        /// Write a PNG per frame and `animation.gif` into this folder.
        #[arg(long, value_name = "DIR")]
        render: Option<PathBuf>,
        /// Picture size, WIDTHxHEIGHT.
        #[arg(long, default_value = "640x360")]
        size: String,
        /// Draw particles as spheres coloured by speed (the older style) instead of
        /// screen-space water with foam.
        #[arg(long)]
        spheres: bool,
        /// Export particles each frame in this format (into --out).
        #[arg(long, value_enum)]
        export: Option<Format>,
        /// Reconstruct the liquid surface each frame (splashsurf, `SurfaceOptions::smooth()`):
        /// render it instead of the particles and, with --export, write it (OBJ, PLY or VTK).
        /// Needs the `surface` feature.
        #[arg(long)]
        mesh: bool,
        /// Folder for exports. Default: `out`.
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Start from a state saved by --save-state instead of the scene's initial particles
        /// (the scene still gives camera, time step and frame count).
        #[arg(long, value_name = "FILE")]
        resume: Option<PathBuf>,
        /// Save the final state (fluids + rapier world) to this file.
        #[arg(long, value_name = "FILE")]
        save_state: Option<PathBuf>,
        /// No progress bar.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Check scene files: parse them, build them, print what they hold.
    Validate {
        /// The scene files.
        #[arg(required = true)]
        scenes: Vec<PathBuf>,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Validate { scenes } => validate(&scenes),
        Command::Run {
            scene,
            frames,
            render,
            size,
            spheres,
            export,
            mesh,
            out,
            resume,
            save_state,
            quiet,
        } => run(RunArgs {
            scene,
            frames,
            render,
            size,
            spheres,
            export,
            mesh,
            out,
            resume,
            save_state,
            quiet,
        }),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// A sink's region in words, naming its collider if it has a name.
fn describe_sink(r: &Region, named: &[(String, ColliderHandle)]) -> String {
    match r {
        Region::Aabb { min, max } => format!(
            "box ({}, {}, {}) to ({}, {}, {})",
            min.x, min.y, min.z, max.x, max.y, max.z
        ),
        Region::Ball { center, radius } => format!(
            "ball of radius {radius} m at ({}, {}, {})",
            center.x, center.y, center.z
        ),
        Region::Collider(handle) => {
            let name = named
                .iter()
                .find(|(_, h)| h == handle)
                .map_or("(unnamed)", |(n, _)| n.as_str());
            format!("inside collider {name:?}")
        }
        Region::NearCollider { handle, reach } => {
            let name = named
                .iter()
                .find(|(_, h)| h == handle)
                .map_or("(unnamed)", |(n, _)| n.as_str());
            match reach {
                Some(r) => format!("collider {name:?}, reach {r} m"),
                None => format!("collider {name:?}, reach one spacing"),
            }
        }
    }
}

fn validate(scenes: &[PathBuf]) -> Result<()> {
    let mut failed = 0;
    for path in scenes {
        match SceneFile::load_and_build(path) {
            Ok((scene, built)) => {
                println!("{}: ok", path.display());
                describe_scene(&scene, &built);
            }
            Err(e) => {
                eprintln!("{e}");
                failed += 1;
            }
        }
    }
    if failed > 0 {
        return Err(format!("{failed} of {} scene files are invalid", scenes.len()).into());
    }
    Ok(())
}

/// What a valid scene file builds: its fluids with their emitters and sinks, its named
/// colliders, its bodies and its timing.
fn describe_scene(scene: &SceneFile, built: &rapier_sph::scene_file::BuiltScene) {
    let w = &built.world;
    if !scene.description.is_empty() {
        println!("  {}", scene.description);
    }
    for (k, h) in built.fluids.iter().enumerate() {
        describe_fluid(k, &scene.fluids[k].name, &w.fluids[*h], built);
    }
    if !built.named_colliders.is_empty() {
        let names: Vec<&str> = built
            .named_colliders
            .iter()
            .map(|(n, _)| n.as_str())
            .collect();
        println!("  named colliders: {}", names.join(", "));
    }
    println!(
        "  {} bodies, {} colliders; {} s at {} frames/s = {} frames of {} steps, dt = {:.6} s",
        w.physics.bodies.len(),
        w.physics.colliders.len(),
        scene.duration.0,
        scene.frame_rate.0,
        built.frames,
        built.steps_per_frame,
        built.dt
    );
}

fn describe_fluid(
    k: usize,
    name: &str,
    f: &rapier_sph::Fluid,
    built: &rapier_sph::scene_file::BuiltScene,
) {
    println!(
        "  fluid {k} {name:?}: {} particles, spacing {} m, h {} m, ρ0 {} kg/m³{}",
        f.len(),
        f.params().particle_spacing,
        f.params().smoothing_length,
        f.params().rest_density,
        match f.capacity() {
            Some(c) => format!(", capacity {c}"),
            None => String::new(),
        }
    );
    let spacing = f.params().particle_spacing;
    for (j, (_, e)) in f.emitters().enumerate() {
        let d = e.direction();
        let towards = match e.nozzle() {
            rapier_sph::Nozzle::Sphere { .. } => "radially".to_string(),
            _ => format!("towards ({:.3}, {:.3}, {:.3})", d.x, d.y, d.z),
        };
        println!(
            "    emitter {j}: {:?} at ({}, {}, {}) {towards}, {} m/s, {:.1} particles/s (blocking rate {:.1}){}",
            e.nozzle(),
            e.position().x,
            e.position().y,
            e.position().z,
            e.speed(),
            e.rate(),
            e.max_rate(spacing),
            match e.particle_budget() {
                Some(b) => format!(", budget {b}"),
                None => String::new(),
            }
        );
        if let Some(a) = e.attachment() {
            println!("      carried by {}", describe_carrier(a, built));
        }
    }
    for (j, (_, s)) in f.sinks().enumerate() {
        println!(
            "    sink {j}: {}",
            describe_sink(&s.region(), &built.named_colliders)
        );
    }
}

/// What carries an emitter, named through the scene's named colliders.
fn describe_carrier(
    a: rapier_sph::Attachment,
    built: &rapier_sph::scene_file::BuiltScene,
) -> String {
    let colliders = &built.world.physics.colliders;
    let name = |pick: &dyn Fn(ColliderHandle) -> bool| {
        built
            .named_colliders
            .iter()
            .find(|(_, h)| pick(*h))
            .map_or("?".to_string(), |(n, _)| format!("`{n}`"))
    };
    match a {
        rapier_sph::Attachment::Collider(h) => {
            format!(
                "the collider {} (position and direction in its frame)",
                name(&|c| c == h)
            )
        }
        rapier_sph::Attachment::Body(b) => format!(
            "the body of the collider {} (position and direction in its frame)",
            name(&|c| colliders.get(c).and_then(|c| c.parent()) == Some(b))
        ),
    }
}

struct RunArgs {
    scene: PathBuf,
    frames: Option<usize>,
    render: Option<PathBuf>,
    size: String,
    spheres: bool,
    export: Option<Format>,
    mesh: bool,
    out: PathBuf,
    resume: Option<PathBuf>,
    save_state: Option<PathBuf>,
    quiet: bool,
}

#[derive(Default)]
struct Clock {
    simulate: Duration,
    surface: Duration,
    render: Duration,
    export: Duration,
}

fn timed<T>(acc: &mut Duration, f: impl FnOnce() -> T) -> T {
    let t = Instant::now();
    let r = f();
    *acc += t.elapsed();
    r
}

/// Runs a scene file: the frames, their pictures and exports, then the summary.
fn run(a: RunArgs) -> Result<()> {
    let (scene, mut built) = SceneFile::load_and_build(&a.scene)?;
    if let Some(state) = &a.resume {
        let mut world = rapier_sph::snapshot::load(state)?;
        world.physics.integration_parameters.dt = built.dt;
        built.world = world;
    }
    if a.mesh && !cfg!(feature = "surface") {
        return Err(
            "--mesh needs the `surface` feature: cargo build --release --features cli,surface"
                .into(),
        );
    }
    let frames = a.frames.unwrap_or(built.frames);
    let n0 = built.world.fluids.num_particles();
    let mut out = Output::new(&a, &scene, &built)?;
    let bar = progress_bar(a.quiet, frames)?;
    let mut tally = Tally::default();
    let t0 = Instant::now();
    out.write_frame(0, &built.world)?;
    for frame in 1..=frames {
        let world = &mut built.world;
        timed(&mut out.clock.simulate, || -> Result<()> {
            for _ in 0..built.steps_per_frame {
                world.step()?;
                // Counted in the simulation time.
                if let Some(d) = out.diffuse.as_mut() {
                    d.step(world)?;
                }
                tally.add(world.pipeline.report());
            }
            Ok(())
        })?;
        out.write_frame(frame, world)?;
        bar.set_position(frame as u64);
        bar.set_message(format!(
            "t = {:.2} s, max |v| {:.2} m/s",
            frame as f32 / scene.frame_rate.0,
            world.pipeline.report().max_speed
        ));
    }
    bar.finish_and_clear();
    let wall = t0.elapsed().as_secs_f64();
    out.finish(&built.world)?;
    let summary = Summary {
        frames,
        n0,
        wall,
        tally: &tally,
        out: &out,
    };
    summary.print(&a, &built)?;
    if tally.non_finite > 0 {
        return Err("particles became non-finite".into());
    }
    let lost = summary.lost(built.world.fluids.num_particles());
    if lost != 0 {
        return Err(format!("{lost} particles unaccounted for").into());
    }
    Ok(())
}

fn progress_bar(quiet: bool, frames: usize) -> Result<ProgressBar> {
    let bar = if quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(frames as u64)
    };
    bar.set_style(
        ProgressStyle::with_template(
            "{bar:40.cyan/blue} {pos}/{len} frames  {msg}  [{elapsed_precise} < {eta_precise}]",
        )?
        .progress_chars("=> "),
    );
    Ok(bar)
}

/// What a run writes: pictures (PNG frames and a GIF), particle and surface exports, the
/// saved state; and what that cost.
struct Output<'a> {
    args: &'a RunArgs,
    frame_rate: f32,
    pictures: Option<(Renderer, GifWriter)>,
    /// The camera frames the initial scene once, then only turns.
    base_camera: rapier_sph::render::Camera,
    degrees_per_second: f32,
    /// Foam, spray and bubbles for the screen-space pictures, stepped with the world.
    diffuse: Option<WorldDiffuse>,
    clock: Clock,
    bytes_written: u64,
    files: usize,
}

impl<'a> Output<'a> {
    fn new(
        a: &'a RunArgs,
        scene: &SceneFile,
        built: &rapier_sph::scene_file::BuiltScene,
    ) -> Result<Self> {
        let world = &built.world;
        let pictures = match &a.render {
            Some(dir) => Some(picture_writers(a, dir, scene.frame_rate.0)?),
            None => None,
        };
        if a.export.is_some() {
            std::fs::create_dir_all(&a.out)?;
            // The colliders once, for the 3D tools (static geometry at its initial pose).
            let mut colliders = TriangleMesh::default();
            for (_, m) in TriangleMesh::from_colliders(
                &world.physics.colliders,
                &TessellationOptions::default(),
            ) {
                colliders.append_transformed(&m, &rapier_sph::math::Pose::IDENTITY);
            }
            io::write_mesh_obj(a.out.join("colliders.obj"), &colliders)?;
        }
        let diffuse = if a.render.is_some() && !a.spheres && !a.mesh {
            Some(WorldDiffuse::new(Default::default())?)
        } else {
            None
        };
        Ok(Self {
            args: a,
            frame_rate: scene.frame_rate.0,
            pictures,
            base_camera: built.camera.camera_at(world, 0.0),
            degrees_per_second: built.camera.degrees_per_second(),
            diffuse,
            clock: Clock::default(),
            bytes_written: 0,
            files: 0,
        })
    }

    fn count(&mut self, path: &std::path::Path) -> Result<()> {
        self.bytes_written += std::fs::metadata(path)?.len();
        self.files += 1;
        Ok(())
    }

    fn write_frame(&mut self, frame: usize, world: &rapier_sph::FluidWorld) -> Result<()> {
        let surface = if self.args.mesh {
            Some(timed(&mut self.clock.surface, || surface_mesh(world))?)
        } else {
            None
        };
        if self.pictures.is_some() {
            self.draw(frame, world, surface.as_ref())?;
        }
        if let Some(format) = self.args.export {
            let t = Instant::now();
            self.export(frame, format, world, surface.as_ref())?;
            self.clock.export += t.elapsed();
        }
        Ok(())
    }

    fn draw(
        &mut self,
        frame: usize,
        world: &rapier_sph::FluidWorld,
        surface: Option<&TriangleMesh>,
    ) -> Result<()> {
        let t = frame as f32 / self.frame_rate;
        let camera = self.base_camera.rotated(self.degrees_per_second * t);
        let dir = self.args.render.as_ref().expect("render dir");
        let path = dir.join(format!("frame_{frame:04}.png"));
        let layers = self
            .diffuse
            .as_ref()
            .map(|d| d.layers())
            .unwrap_or_default();
        let (renderer, gif) = self.pictures.as_mut().expect("pictures");
        timed(&mut self.clock.render, || -> Result<()> {
            let image = renderer.render_world_with(&camera, world, surface, &layers);
            image.save_png(&path)?;
            gif.add_frame(&image)?;
            Ok(())
        })?;
        self.count(&path)
    }

    fn export(
        &mut self,
        frame: usize,
        format: Format,
        world: &rapier_sph::FluidWorld,
        surface: Option<&TriangleMesh>,
    ) -> Result<()> {
        let out = &self.args.out;
        let data = ParticleData::from_fluids(&world.fluids);
        let p = match format {
            Format::Vtk => {
                let p = out.join(format!("particles_{frame:04}.vtk"));
                io::write_particles_vtk(&p, &data)?;
                p
            }
            Format::Ply | Format::Obj => {
                let p = out.join(format!("particles_{frame:04}.ply"));
                io::write_particles_ply(&p, &data)?;
                p
            }
        };
        self.count(&p)?;
        if let Some(mesh) = surface {
            let p = match format {
                Format::Vtk => out.join(format!("surface_{frame:04}.vtk")),
                Format::Ply => out.join(format!("surface_{frame:04}.ply")),
                Format::Obj => out.join(format!("surface_{frame:04}.obj")),
            };
            match format {
                Format::Vtk => io::write_mesh_vtk(&p, mesh)?,
                Format::Ply => io::write_mesh_ply(&p, mesh)?,
                Format::Obj => io::write_mesh_obj(&p, mesh)?,
            }
            self.count(&p)?;
        }
        Ok(())
    }

    /// Closes the GIF and saves the state, if asked for.
    fn finish(&mut self, world: &rapier_sph::FluidWorld) -> Result<()> {
        if let Some((_, gif)) = self.pictures.take() {
            gif.finish()?;
            let p = self
                .args
                .render
                .as_ref()
                .expect("render dir")
                .join("animation.gif");
            self.count(&p)?;
        }
        if let Some(path) = &self.args.save_state {
            rapier_sph::snapshot::save(world, path)?;
            self.count(path)?;
        }
        Ok(())
    }
}

fn picture_writers(
    a: &RunArgs,
    dir: &std::path::Path,
    frame_rate: f32,
) -> Result<(Renderer, GifWriter)> {
    let (w, h) = a
        .size
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
        .filter(|(w, h)| *w > 0 && *h > 0)
        .ok_or("--size must look like 640x360")?;
    std::fs::create_dir_all(dir)?;
    let options = RenderOptions {
        width: w,
        height: h,
        draw_particles: !a.mesh,
        style: if a.spheres {
            FluidStyle::Spheres
        } else {
            FluidStyle::ScreenSpace
        },
        ..RenderOptions::default()
    };
    let delay = (100.0 / frame_rate).round().max(2.0) as u16;
    Ok((
        Renderer::new(options),
        GifWriter::create(dir.join("animation.gif"), w, h, delay)?,
    ))
}

/// What the steps of a run reported, summed.
#[derive(Default)]
struct Tally {
    max_err: f32,
    non_finite: usize,
    steps: usize,
    substeps: usize,
    counts: Counters,
}

impl Tally {
    fn add(&mut self, r: &rapier_sph::StepReport) {
        self.max_err = self.max_err.max(r.max_density_error);
        self.non_finite += r.non_finite;
        self.counts.add(r);
        self.steps += 1;
        self.substeps += r.substeps as usize;
    }
}

/// The lines a run prints at its end.
struct Summary<'a> {
    frames: usize,
    n0: usize,
    wall: f64,
    tally: &'a Tally,
    out: &'a Output<'a>,
}

impl Summary<'_> {
    /// Every particle is accounted for: live = start + emitted − drained − quarantined.
    fn lost(&self, n: usize) -> i64 {
        let c = &self.tally.counts;
        (self.n0 + c.emitted) as i64 - (n + c.drained + c.quarantined) as i64
    }

    fn print(&self, a: &RunArgs, built: &rapier_sph::scene_file::BuiltScene) -> Result<()> {
        let world = &built.world;
        let (t, n) = (self.tally, world.fluids.num_particles());
        println!(
            "{}: {} frames, {} steps of {:.6} s = {:.3} s simulated, {} fluid substeps ({:.1} \
             per step)",
            a.scene.display(),
            self.frames,
            t.steps,
            built.dt,
            t.steps as f64 * built.dt as f64,
            t.substeps,
            t.substeps as f64 / t.steps.max(1) as f64
        );
        println!(
            "particles            {n} (start {}), {} NaN/inf, max density error {:.2} %",
            self.n0,
            t.non_finite,
            100.0 * t.max_err
        );
        match built.collider_bounds() {
            Some(_) => println!(
                "outside the scene    {} particles left the bounds of the colliders (over a \
                 rim or off an edge: they fall for ever)",
                built.particles_outside_colliders()
            ),
            None => println!("outside the scene    no bounded collider to measure against"),
        }
        self.print_sources(built);
        print_sensors(built);
        self.print_costs(a, n);
        Ok(())
    }

    fn print_sources(&self, built: &rapier_sph::scene_file::BuiltScene) {
        let (c, world) = (&self.tally.counts, &built.world);
        let lost = self.lost(world.fluids.num_particles());
        if !c.any() && lost == 0 {
            return;
        }
        println!(
            "emitted / drained    {} / {} ({} quarantined, {} lost; {} due at a blocked nozzle, \
             capacity reached in {} steps)",
            c.emitted, c.drained, c.quarantined, lost, c.blocked, c.capacity_steps
        );
        for (k, (_, f)) in world.fluids.iter().enumerate() {
            for (j, (_, e)) in f.emitters().enumerate() {
                println!("  fluid {k} emitter {j}: {} emitted in all", e.emitted());
            }
            for (j, (_, s)) in f.sinks().enumerate() {
                println!(
                    "  fluid {k} sink {j}: {} drained in all ({})",
                    s.drained(),
                    describe_sink(&s.region(), &built.named_colliders)
                );
            }
        }
    }

    fn print_costs(&self, a: &RunArgs, n: usize) {
        let (t, clock) = (self.tally, &self.out.clock);
        let sim = clock.simulate.as_secs_f64();
        println!(
            "wall time            {:.2} s: simulation {sim:.2} s ({:.1} steps/s, {:.2} M \
             particle-steps/s), surface {:.2} s, rendering {:.2} s, export {:.2} s",
            self.wall,
            t.steps as f64 / sim.max(1e-9),
            t.steps as f64 * n as f64 / sim.max(1e-9) / 1e6,
            clock.surface.as_secs_f64(),
            clock.render.as_secs_f64(),
            clock.export.as_secs_f64()
        );
        if self.out.files > 0 {
            println!(
                "files written        {}, {:.1} MB",
                self.out.files,
                self.out.bytes_written as f64 / 1e6
            );
        }
        if let Some(d) = &a.render {
            println!(
                "pictures             {}/frame_*.png, {}/animation.gif",
                d.display(),
                d.display()
            );
        }
        if a.export.is_some() {
            println!("exports              {}/", a.out.display());
        }
        if let Some(p) = &a.save_state {
            println!("state saved          {}", p.display());
        }
    }
}

/// Fluid inside each named sensor collider.
fn print_sensors(built: &rapier_sph::scene_file::BuiltScene) {
    let world = &built.world;
    for (name, h) in &built.named_colliders {
        if !world
            .physics
            .colliders
            .get(*h)
            .is_some_and(|c| c.is_sensor())
        {
            continue;
        }
        let (mut particles, mut volume) = (0, 0.0);
        for (_, f) in world.fluids.iter() {
            let a = f.amount_in(&Region::Collider(*h), &world.physics.colliders);
            particles += a.particles;
            volume += a.volume;
        }
        println!(
            "sensor {:<14} {particles} particles, {:.3} L of fluid",
            format!("{name:?}"),
            volume * 1e3
        );
    }
}

/// Emitter and sink counters summed over the steps of a run.
#[derive(Default)]
struct Counters {
    emitted: usize,
    drained: usize,
    quarantined: usize,
    blocked: usize,
    capacity_steps: usize,
}

impl Counters {
    fn add(&mut self, r: &rapier_sph::StepReport) {
        self.emitted += r.emitted;
        self.drained += r.drained;
        self.quarantined += r.quarantined;
        self.blocked += r.emitter_blocked;
        self.capacity_steps += r.capacity_reached as usize;
    }
    fn any(&self) -> bool {
        self.emitted + self.drained + self.quarantined + self.blocked + self.capacity_steps > 0
    }
}

#[cfg(feature = "surface")]
fn surface_mesh(world: &rapier_sph::FluidWorld) -> Result<TriangleMesh> {
    Ok(rapier_sph::surface::reconstruct_fluids(
        &world.fluids,
        &rapier_sph::surface::SurfaceOptions::smooth(),
    )?)
}

#[cfg(not(feature = "surface"))]
fn surface_mesh(_: &rapier_sph::FluidWorld) -> Result<TriangleMesh> {
    Err("--mesh needs the `surface` feature".into())
}
