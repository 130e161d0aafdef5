//! The error-vs-run-time report: every validation scene (`rapier_sph::validation`) swept over
//! solver × resolution × time-step policy, each run's wall time, particle-steps/s, errors
//! against the reference and stability recorded; plus the step's cost against particle count
//! for each solver (the Unity paper's Figure 5, redone).
//!
//! ```text
//! cargo run --release --features report --example error_vs_runtime            # < ~10 min on 2 cores
//! cargo run --release --features report --example error_vs_runtime -- --quick # < 1 min
//! cargo run --release --features report --example error_vs_runtime -- --full  # deeper sweeps
//! cargo run --release --features report --example error_vs_runtime -- --out /tmp/r
//! cargo run --release --features report --example error_vs_runtime -- --wcsph-adami --wcsph-delta
//! ```
//!
//! The committed report (`report/`) is the last command's output: every solver plus WCSPH with
//! Adami walls (`WCSPH-A`) and with δ-SPH densities (`WCSPH-D`), the two remedies for WCSPH's
//! impact-pressure noise, beside the paper's WCSPH.
//!
//! Writes into `--out` (default `report/`): `error_vs_runtime.csv` (one row per run, machine
//! and git revision in `#` lines at the top), `error_vs_runtime.md` (a table per scene,
//! Pareto-optimal runs marked), `error_vs_runtime.svg`/`.png` (error against wall time,
//! log–log, one panel per scene, one series per solver and policy; the dam-break fronts and
//! heights over the experimental points), `scaling.svg`/`.png`, and `recommended.txt` (the
//! solvers the report recommends, read by `tests/validation.rs`).
//!
//! A solver is **recommended** when at least one of its runs is Pareto-optimal (no other
//! stable run of the scene is both faster and more accurate) in at least half of the scenes.

use indicatif::{ProgressBar, ProgressStyle};
use plotters::prelude::*;
use rapier_sph::FluidParamsBuilder;
use rapier_sph::scenes::{DamBreakConfig, dam_break};
use rapier_sph::validation::{
    Depth, Method, RunRecord, Scene, TimePolicy, dam_break as vdb, methods, reference_step,
};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Error columns of the CSV, in order (a scene fills those it measures).
const ERROR_COLUMNS: [&str; 18] = [
    "front_rms",
    "front_rms_t3",
    "height_rms",
    "ritter_excess",
    "bottom_pressure",
    "pressure_rms",
    "mean_density_error",
    "settled_max_density_error",
    "band_rms",
    "peak",
    "peak_time",
    "peak_filtered",
    "impulse",
    "ekin_rms",
    "dissipation_t0",
    "ekin_end",
    "energy_excess",
    "max_height",
];

struct Args {
    depth: Depth,
    out: PathBuf,
    scenes: Vec<Scene>,
    skip_scaling: bool,
    /// DFSPH with [`rapier_sph::solver::Dfsph::hydrostatic_walls`] (reported as `DFSPH-HW`).
    hydrostatic_walls: bool,
    /// Adds WCSPH with wall density and [`rapier_sph::WcsphPressure::Adami`] (reported as
    /// `WCSPH-A`) beside the report's WCSPH.
    wcsph_adami: bool,
    /// Adds `WCSPH-A` with its densities from the continuity equation with δ-SPH diffusion
    /// ([`rapier_sph::WcsphDensity::DELTA_SPH`]; reported as `WCSPH-D`).
    wcsph_delta: bool,
    /// Only the methods whose name is listed (all if empty).
    solvers: Vec<String>,
}

fn parse_args() -> Args {
    let mut args = Args {
        depth: Depth::Default,
        out: PathBuf::from("report"),
        scenes: Scene::ALL.to_vec(),
        skip_scaling: false,
        hydrostatic_walls: false,
        wcsph_adami: false,
        wcsph_delta: false,
        solvers: Vec::new(),
    };
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        match a.as_str() {
            "--quick" => args.depth = Depth::Quick,
            "--full" => args.depth = Depth::Full,
            "--out" => args.out = PathBuf::from(it.next().expect("--out DIR")),
            "--scene" => {
                let name = it.next().expect("--scene NAME");
                args.scenes = Scene::ALL
                    .into_iter()
                    .filter(|s| s.name() == name)
                    .collect();
                assert!(!args.scenes.is_empty(), "unknown scene {name}");
            }
            "--no-scaling" => args.skip_scaling = true,
            "--hydrostatic-walls" => args.hydrostatic_walls = true,
            "--wcsph-adami" => args.wcsph_adami = true,
            "--wcsph-delta" => args.wcsph_delta = true,
            "--solver" => args.solvers.push(it.next().expect("--solver NAME")),
            "-h" | "--help" => {
                println!(
                    "error_vs_runtime [--quick | --full] [--out DIR] [--scene NAME] [--no-scaling]\n\
                     \x20                [--hydrostatic-walls]   (DFSPH runs as DFSPH-HW, hydrostatic walls on)\n\
                     \x20                [--wcsph-adami]   (adds WCSPH-A: WCSPH with wall density and Adami's wall pressure)\n\
                     \x20                [--wcsph-delta]   (adds WCSPH-D: WCSPH-A with δ-SPH densities, the continuity equation)\n\
                     \x20                [--solver NAME]...   (only these methods, by their printed name)\n\
                     scenes: {}",
                    Scene::ALL.map(|s| s.name()).join(", ")
                );
                std::process::exit(0);
            }
            other => panic!("unknown argument {other} (try --help)"),
        }
    }
    args
}

fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|s| s.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    format!(
        "{cpu}, {cores} cores available, {} rayon threads, {} {}, f32, release build",
        rayon::current_num_threads(),
        std::env::consts::OS,
        std::env::consts::ARCH
    )
}

fn git_revision() -> String {
    let run = |args: &[&str]| {
        std::process::Command::new("git")
            .args(args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    match run(&["rev-parse", "HEAD"]) {
        Some(rev) => {
            let dirty = run(&["status", "--porcelain", "--untracked-files=no"])
                .is_some_and(|s| !s.is_empty());
            if dirty {
                format!("{rev} (with uncommitted changes)")
            } else {
                rev
            }
        }
        None => "unknown (not a git checkout)".into(),
    }
}

fn depth_flag(d: Depth) -> &'static str {
    match d {
        Depth::Quick => " -- --quick",
        Depth::Default => "",
        Depth::Full => " -- --full",
    }
}

/// Marks the Pareto-optimal runs of one scene: stable, with a finite primary error, and no
/// other such run at most as slow and at most as wrong (one of the two strictly).
fn pareto(runs: &[&RunRecord]) -> Vec<bool> {
    let key = |r: &RunRecord| (r.wall_seconds, r.primary_error());
    runs.iter()
        .map(|r| {
            let (w, e) = key(r);
            if !e.is_finite() {
                return false;
            }
            !runs.iter().any(|o| {
                let (wo, eo) = key(o);
                eo.is_finite() && wo <= w && eo <= e && (wo < w || eo < e)
            })
        })
        .collect()
}

fn fmt_err(v: Option<f64>) -> String {
    match v {
        Some(v) if v.is_finite() => format!("{v:.4}"),
        Some(_) => "nan".into(),
        None => String::new(),
    }
}

struct ScalingPoint {
    method: &'static str,
    particles: usize,
    steps_per_second: f64,
    ns_per_particle_step: f64,
}

/// Steps/s of the dam break (the benchmark's scene: the paper's tower, water preset at
/// 0.02 m) at about `particles` particles, fixed steps of the solver's reference step.
fn measure_scaling(method: &Method, particles: usize, steps: usize) -> ScalingPoint {
    let params = FluidParamsBuilder::water(0.02)
        .solver(method.solver)
        .wall_density(method.wall_density)
        .build()
        .unwrap();
    let config = DamBreakConfig::tower(params.clone(), DamBreakConfig::scale_for(particles));
    let mut scene = dam_break(&config).unwrap();
    let g = 9.81;
    let dt = reference_step(&params, 2.0 * (g * scene.column_height).sqrt(), g);
    scene.world.physics.integration_parameters.dt = dt;
    scene.world.pipeline.time_stepping = rapier_sph::TimeStepping::Fixed;
    scene.world.physics.step();
    let n = scene.world.fluids.num_particles();
    for _ in 0..(steps / 3).max(3) {
        scene.world.step_fluids().unwrap();
    }
    let t0 = Instant::now();
    for _ in 0..steps {
        scene.world.step_fluids().unwrap();
    }
    let s = t0.elapsed().as_secs_f64();
    ScalingPoint {
        method: method.name,
        particles: n,
        steps_per_second: steps as f64 / s,
        ns_per_particle_step: s * 1e9 / (steps * n) as f64,
    }
}

const COLOURS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
];

type DrawResult = Result<(), Box<dyn std::error::Error>>;

fn log_range(values: impl Iterator<Item = f64>, floor: f64) -> std::ops::Range<f64> {
    let (mut lo, mut hi) = (f64::MAX, f64::MIN);
    for v in values.filter(|v| v.is_finite() && *v > 0.0) {
        lo = lo.min(v.max(floor));
        hi = hi.max(v.max(floor));
    }
    if lo > hi {
        return floor..floor * 10.0;
    }
    lo / 1.5..hi * 1.5
}

/// 1, 2 and 5 times the powers of ten inside `range` (label positions for a log axis).
fn keys_125(range: &std::ops::Range<f64>) -> Vec<f64> {
    let mut keys = Vec::new();
    let mut decade = 10f64.powi(range.start.log10().floor() as i32);
    while decade <= range.end {
        for m in [1.0, 2.0, 5.0] {
            let v = m * decade;
            if range.contains(&v) {
                keys.push(v);
            }
        }
        decade *= 10.0;
    }
    keys
}

fn error_panel(
    area: &DrawingArea<SVGBackend, plotters::coord::Shift>,
    scene: Scene,
    runs: &[&RunRecord],
    method_names: &[&'static str],
) -> DrawResult {
    let floor = 1e-4;
    let xs = log_range(runs.iter().map(|r| r.wall_seconds), 1e-3);
    let ys = log_range(runs.iter().map(|r| r.primary_error()), floor);
    let mut chart = ChartBuilder::on(area)
        .caption(
            format!("{}: |{}|", scene.name(), scene.primary_error_name()),
            ("sans-serif", 18),
        )
        .margin(8)
        .x_label_area_size(36)
        .y_label_area_size(56)
        .build_cartesian_2d(xs.log_scale(), ys.log_scale())?;
    chart
        .configure_mesh()
        .x_desc("wall time (s)")
        .y_desc("error")
        .light_line_style(WHITE)
        .x_labels(6)
        .y_labels(6)
        .x_label_formatter(&|v| format!("{v:.3}"))
        .y_label_formatter(&|v| format!("{v:.3}"))
        .draw()?;
    for (mi, name) in method_names.iter().enumerate() {
        let c = COLOURS[mi % COLOURS.len()];
        for policy in TimePolicy::ALL {
            let mut pts: Vec<(f64, f64, usize)> = runs
                .iter()
                .filter(|r| {
                    r.method == *name && r.policy == policy && r.primary_error().is_finite()
                })
                .map(|r| (r.wall_seconds, r.primary_error().max(floor), r.resolution))
                .collect();
            pts.sort_by_key(|p| p.2);
            let line: Vec<(f64, f64)> = pts.iter().map(|p| (p.0, p.1)).collect();
            chart.draw_series(LineSeries::new(line.clone(), c.mix(0.4)))?;
            let label = format!("{name} {}", policy.name());
            match policy {
                TimePolicy::Adaptive => chart
                    .draw_series(line.iter().map(|&p| Circle::new(p, 5, c.filled())))?
                    .label(label)
                    .legend(move |(x, y)| Circle::new((x, y), 5, c.filled())),
                TimePolicy::FixedSmall => chart
                    .draw_series(line.iter().map(|&p| TriangleMarker::new(p, 6, c.filled())))?
                    .label(label)
                    .legend(move |(x, y)| TriangleMarker::new((x, y), 6, c.filled())),
                TimePolicy::FixedLarge => chart
                    .draw_series(line.iter().map(|&p| Cross::new(p, 5, c.stroke_width(2))))?
                    .label(label)
                    .legend(move |(x, y)| Cross::new((x, y), 5, c.stroke_width(2))),
            };
        }
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 12))
        .draw()?;
    Ok(())
}

/// Simulated curves (adaptive runs, every resolution) over the reference points.
#[allow(clippy::too_many_arguments)] // one panel's axes, labels and data, each from its caller
fn curve_panel(
    area: &DrawingArea<SVGBackend, plotters::coord::Shift>,
    title: &str,
    reference: &rapier_sph::validation::Curve,
    curve_name: &str,
    runs: &[&RunRecord],
    method_names: &[&'static str],
    x_desc: &str,
    y_desc: &str,
    ritter: bool,
    band: Option<(
        &rapier_sph::validation::Curve,
        &rapier_sph::validation::Curve,
    )>,
    x_range: Option<(f64, f64)>,
) -> DrawResult {
    let (x_min, x_max) = x_range.unwrap_or((
        0.0,
        reference.points.iter().map(|p| p.0).fold(0.0, f64::max) * 1.1,
    ));
    // With a band (many points), the reference is a line and the y axis is capped at 1.6×
    // the band's top: simulated values above are drawn at the cap (said in the title).
    let y_cap = band.map(|(_, hi)| {
        hi.points
            .iter()
            .filter(|p| p.0 >= x_min && p.0 <= x_max)
            .map(|p| p.1)
            .fold(0.0, f64::max)
            * 1.6
    });
    let sims: Vec<(&RunRecord, Vec<(f64, f64)>)> = runs
        .iter()
        .filter(|r| r.policy == TimePolicy::Adaptive)
        .filter_map(|r| {
            r.curves.iter().find(|c| c.name == curve_name).map(|c| {
                (
                    *r,
                    c.points
                        .iter()
                        .copied()
                        .filter(|p| p.0 >= x_min && p.0 <= x_max)
                        .map(|p| (p.0, y_cap.map_or(p.1, |cap| p.1.min(cap))))
                        .collect::<Vec<_>>(),
                )
            })
        })
        .collect();
    let y_max = y_cap.unwrap_or_else(|| {
        reference
            .points
            .iter()
            .map(|p| p.1)
            .chain(sims.iter().flat_map(|s| s.1.iter().map(|p| p.1)))
            .fold(0.0, f64::max)
            * 1.1
    });
    let title = match y_cap {
        Some(cap) => format!("{title}, values above {cap:.1} drawn at {cap:.1}"),
        None => title.to_string(),
    };
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 16))
        .margin(8)
        .x_label_area_size(36)
        .y_label_area_size(46)
        .build_cartesian_2d(x_min..x_max, 0.0..y_max)?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .draw()?;
    if ritter {
        chart
            .draw_series(LineSeries::new(
                [(0.0, 1.0), (x_max, 1.0 + 2.0 * x_max)],
                BLACK.mix(0.4).stroke_width(1),
            ))?
            .label("Ritter bound 1 + 2T")
            .legend(|(x, y)| PathElement::new([(x - 8, y), (x + 8, y)], BLACK.mix(0.4)));
    }
    let max_res = sims.iter().map(|s| s.0.resolution).max().unwrap_or(1);
    for (mi, name) in method_names.iter().enumerate() {
        let c = COLOURS[mi % COLOURS.len()];
        let mut mine: Vec<&(&RunRecord, Vec<(f64, f64)>)> =
            sims.iter().filter(|s| s.0.method == *name).collect();
        mine.sort_by_key(|s| s.0.resolution);
        if band.is_some() {
            // Pressure signals are noisy: only the finest run of each solver, to stay legible.
            mine.retain(|s| s.0.resolution == max_res);
        }
        for s in mine {
            let shade = 0.35 + 0.65 * s.0.resolution as f64 / max_res as f64;
            let style = c
                .mix(shade)
                .stroke_width(if s.0.resolution == max_res { 2 } else { 1 });
            chart
                .draw_series(LineSeries::new(s.1.clone(), style))?
                .label(format!("{name} N={}", s.0.resolution))
                .legend(move |(x, y)| PathElement::new([(x - 8, y), (x + 8, y)], style));
        }
    }
    if let Some((lo, hi)) = band {
        let inside = |c: &rapier_sph::validation::Curve| -> Vec<(f64, f64)> {
            c.points
                .iter()
                .copied()
                .filter(|p| p.0 >= x_min && p.0 <= x_max)
                .collect()
        };
        for c in [lo, hi] {
            chart.draw_series(LineSeries::new(inside(c), BLACK.mix(0.35)))?;
        }
        chart
            .draw_series(LineSeries::new(inside(reference), BLACK.stroke_width(2)))?
            .label(format!("{} (grey: 2.5–97.5 % band)", reference.label))
            .legend(|(x, y)| PathElement::new([(x - 8, y), (x + 8, y)], BLACK.stroke_width(2)));
    } else {
        chart
            .draw_series(
                reference
                    .points
                    .iter()
                    .map(|&p| Circle::new(p, 4, BLACK.filled())),
            )?
            .label(reference.label.clone())
            .legend(|(x, y)| Circle::new((x, y), 4, BLACK.filled()));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 12))
        .draw()?;
    Ok(())
}

fn svg_to_png(svg: &str, path: &Path) -> DrawResult {
    let mut opt = resvg::usvg::Options::default();
    let db = opt.fontdb_mut();
    db.load_system_fonts();
    // plotters writes `font-family="sans-serif"`; map it to a sans face that exists.
    let families: Vec<String> = db
        .faces()
        .flat_map(|f| f.families.iter().map(|(n, _)| n.clone()))
        .collect();
    let sans = families
        .iter()
        .find(|n| n.as_str() == "DejaVu Sans")
        .or_else(|| {
            families
                .iter()
                .find(|n| n.contains("Sans") && !n.contains("Mono"))
        })
        .or(families.first())
        .cloned();
    match sans {
        Some(f) => {
            db.set_sans_serif_family(f.clone());
            opt.font_family = f;
        }
        None => eprintln!(
            "note: no system fonts found; {} has no text",
            path.display()
        ),
    }
    let tree = resvg::usvg::Tree::from_str(svg, &opt)?;
    let size = tree.size().to_int_size();
    let mut pixmap =
        resvg::tiny_skia::Pixmap::new(size.width(), size.height()).ok_or("empty picture")?;
    pixmap.fill(resvg::tiny_skia::Color::WHITE);
    resvg::render(
        &tree,
        resvg::tiny_skia::Transform::identity(),
        &mut pixmap.as_mut(),
    );
    pixmap.save_png(path)?;
    Ok(())
}

fn write_svg_and_png(out: &Path, stem: &str, svg: String) -> DrawResult {
    std::fs::write(out.join(format!("{stem}.svg")), &svg)?;
    svg_to_png(&svg, &out.join(format!("{stem}.png")))
}

fn draw_report(
    out: &Path,
    scenes: &[Scene],
    records: &[RunRecord],
    method_names: &[&'static str],
) -> DrawResult {
    let (w, h) = (2000u32, 2100u32);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        root.fill(&WHITE)?;
        // The error panels (one per scene), then the fronts, the heights and Lobovský's
        // pressure, left to right and top to bottom.
        let cells = root.split_evenly((4, 4));
        let mut next = 0;
        let runs_of = |scene: Scene| -> Vec<&RunRecord> {
            records.iter().filter(|r| r.scene == scene.name()).collect()
        };
        for scene in Scene::ALL {
            if scenes.contains(&scene) {
                error_panel(&cells[next], scene, &runs_of(scene), method_names)?;
                next += 1;
            }
        }
        type CaseFn = fn() -> rapier_sph::SphResult<vdb::Case>;
        let cases: [(Scene, CaseFn); 3] = [
            (Scene::MartinMoyceSquare, vdb::Case::martin_moyce_square),
            (Scene::MartinMoyceN2, vdb::Case::martin_moyce_n2),
            (Scene::KoshizukaOka, vdb::Case::koshizuka_oka),
        ];
        let mut heights = Vec::new();
        for (scene, case) in cases {
            if !scenes.contains(&scene) {
                continue;
            }
            let case = case()?;
            curve_panel(
                &cells[next],
                &format!("{}: surge front (adaptive runs)", scene.name()),
                &case.front,
                "front",
                &runs_of(scene),
                method_names,
                "T",
                "Z = x/a",
                true,
                None,
                None,
            )?;
            next += 1;
            if let Some(hc) = case.height.clone() {
                heights.push((scene, hc));
            }
        }
        for (scene, hc) in heights {
            let (x_desc, y_desc) = if scene == Scene::MartinMoyceN2 {
                ("τ = t·sqrt(g/a)", "H = h/(2a)")
            } else {
                ("T = t·sqrt(g/a)", "H = h/a")
            };
            curve_panel(
                &cells[next],
                &format!("{}: residual height (adaptive runs)", scene.name()),
                &hc,
                "height",
                &runs_of(scene),
                method_names,
                x_desc,
                y_desc,
                false,
                None,
                None,
            )?;
            next += 1;
        }
        if scenes.contains(&Scene::Lobovsky) {
            let data = rapier_sph::validation::lobovsky::Sensor2::load()?;
            curve_panel(
                &cells[next],
                "lobovsky: sensor 2 (15 mm), adaptive runs",
                &data.median,
                "sensor_2",
                &runs_of(Scene::Lobovsky),
                method_names,
                "T = t·sqrt(g/H)",
                "p/(ρgH)",
                false,
                Some((&data.low, &data.high)),
                Some(rapier_sph::validation::lobovsky::WINDOW),
            )?;
            next += 1;
        }
        if scenes.contains(&Scene::TaylorGreen) {
            use rapier_sph::validation::taylor_green as tg;
            // The reference every 0.1 (every tenth row) over the run's duration.
            let full = tg::reference(tg::REYNOLDS)?;
            let reference = rapier_sph::validation::Curve {
                label: full.label.clone(),
                points: full
                    .points
                    .iter()
                    .enumerate()
                    .filter(|(k, p)| k % 10 == 9 && p.0 <= tg::DURATION as f64 + 1e-9)
                    .map(|(_, p)| *p)
                    .collect(),
            };
            curve_panel(
                &cells[next],
                &format!("taylor_green: Re = {}, adaptive runs", tg::REYNOLDS),
                &reference,
                "ekin",
                &runs_of(Scene::TaylorGreen),
                method_names,
                "t (U = L = 1)",
                "E_kin",
                false,
                None,
                Some((0.0, tg::DURATION as f64)),
            )?;
        }
        root.present()?;
    }
    write_svg_and_png(out, "error_vs_runtime", svg)
}

fn draw_scaling(out: &Path, points: &[ScalingPoint], method_names: &[&'static str]) -> DrawResult {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1200, 500)).into_drawing_area();
        root.fill(&WHITE)?;
        let panels = root.split_evenly((1, 2));
        let xs = log_range(points.iter().map(|p| p.particles as f64), 100.0);
        for (k, (title, y_desc)) in [
            ("steps per second (dam break, fixed steps)", "steps/s"),
            ("cost per particle-step", "ns per particle-step"),
        ]
        .into_iter()
        .enumerate()
        {
            let value = |p: &ScalingPoint| {
                if k == 0 {
                    p.steps_per_second
                } else {
                    p.ns_per_particle_step
                }
            };
            let ys = log_range(points.iter().map(value), 1e-3);
            // Labels at 1, 2 and 5 per decade: plotters' own log-axis labels ran together
            // between 4,000 and 10,000 particles and left the cost axis one label (1000).
            let (x_keys, y_keys) = (keys_125(&xs), keys_125(&ys));
            let mut chart = ChartBuilder::on(&panels[k])
                .caption(title, ("sans-serif", 18))
                .margin(8)
                .x_label_area_size(36)
                .y_label_area_size(60)
                .build_cartesian_2d(
                    xs.clone().log_scale().with_key_points(x_keys),
                    ys.log_scale().with_key_points(y_keys),
                )?;
            chart
                .configure_mesh()
                .x_desc("particles")
                .y_desc(y_desc)
                .x_label_formatter(&|v| format!("{v:.0}"))
                .y_label_formatter(&|v| format!("{v:.0}"))
                .draw()?;
            for (mi, name) in method_names.iter().enumerate() {
                let c = COLOURS[mi % COLOURS.len()];
                let mut pts: Vec<(f64, f64)> = points
                    .iter()
                    .filter(|p| p.method == *name)
                    .map(|p| (p.particles as f64, value(p)))
                    .collect();
                pts.sort_by(|a, b| a.0.total_cmp(&b.0));
                chart.draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))?;
                chart
                    .draw_series(pts.iter().map(|&p| Circle::new(p, 5, c.filled())))?
                    .label(*name)
                    .legend(move |(x, y)| Circle::new((x, y), 5, c.filled()));
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .draw()?;
        }
        root.present()?;
    }
    write_svg_and_png(out, "scaling", svg)
}

fn main() {
    let args = parse_args();
    std::fs::create_dir_all(&args.out).expect("create the output folder");
    // Taken before the runs: the revision the runs were made with.
    let machine = machine();
    let git = git_revision();
    let started = Instant::now();
    let mut methods = methods();
    if args.hydrostatic_walls {
        for m in &mut methods {
            if let rapier_sph::Solver::Dfsph(d) = &mut m.solver {
                d.hydrostatic_walls = true;
                m.name = "DFSPH-HW";
            }
        }
    }
    let at = methods
        .iter()
        .position(|m| m.solver == rapier_sph::Solver::Wcsph);
    if let Some(k) = at {
        let adami = rapier_sph::validation::Method {
            name: "WCSPH-A",
            wall_density: true,
            wcsph_pressure: rapier_sph::WcsphPressure::Adami,
            ..methods[k]
        };
        if args.wcsph_delta {
            let delta = rapier_sph::validation::Method {
                name: "WCSPH-D",
                wcsph_density: rapier_sph::WcsphDensity::DELTA_SPH,
                ..adami
            };
            methods.insert(k + 1, delta);
        }
        if args.wcsph_adami {
            methods.insert(k + 1, adami);
        }
    }
    if !args.solvers.is_empty() {
        methods.retain(|m| args.solvers.iter().any(|s| s == m.name));
        assert!(!methods.is_empty(), "no method named {:?}", args.solvers);
    }
    let method_names: Vec<&'static str> = methods.iter().map(|m| m.name).collect();
    let mut plan = Vec::new();
    for &scene in &args.scenes {
        for m in &methods {
            for res in scene.resolutions(args.depth) {
                for policy in TimePolicy::ALL {
                    plan.push((scene, *m, res, policy));
                }
            }
        }
    }
    let scaling_counts: Vec<usize> = match args.depth {
        Depth::Quick => vec![1_000, 4_000],
        Depth::Default => vec![1_000, 4_000, 16_000],
        Depth::Full => vec![1_000, 4_000, 16_000, 64_000],
    };
    let scaling_runs = if args.skip_scaling {
        0
    } else {
        scaling_counts.len() * methods.len()
    };
    let pb = ProgressBar::new(((plan.len() + scaling_runs) * 1000) as u64);
    pb.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {percent:>3}% {msg}")
            .unwrap()
            .progress_chars("=> "),
    );
    let mut records: Vec<RunRecord> = Vec::new();
    for (k, (scene, m, res, policy)) in plan.iter().enumerate() {
        pb.set_message(format!(
            "{} {} N={res} {}",
            scene.name(),
            m.name,
            policy.name()
        ));
        let base = (k * 1000) as u64;
        let r = scene
            .run(m, *res, *policy, &mut |f| {
                pb.set_position(base + (f * 1000.0) as u64)
            })
            .unwrap_or_else(|e| {
                pb.abandon();
                eprintln!("error: {e}");
                std::process::exit(1);
            });
        pb.set_position(base + 1000);
        records.push(r);
    }
    let mut scaling = Vec::new();
    if !args.skip_scaling {
        let steps = if args.depth == Depth::Quick { 10 } else { 30 };
        for m in &methods {
            for (k, &n) in scaling_counts.iter().enumerate() {
                pb.set_message(format!("scaling {} {n} particles", m.name));
                scaling.push(measure_scaling(m, n, steps));
                pb.set_position(((plan.len() + k) * 1000) as u64);
            }
        }
    }
    pb.finish_and_clear();
    let total = started.elapsed().as_secs_f64();

    // Pareto marks and recommendations.
    let mut is_pareto = vec![false; records.len()];
    let mut pareto_scenes: Vec<(&'static str, usize)> =
        method_names.iter().map(|&n| (n, 0)).collect();
    for scene in &args.scenes {
        let idx: Vec<usize> = (0..records.len())
            .filter(|&i| records[i].scene == scene.name())
            .collect();
        let runs: Vec<&RunRecord> = idx.iter().map(|&i| &records[i]).collect();
        let marks = pareto(&runs);
        let mut seen = std::collections::HashSet::new();
        for (&i, &p) in idx.iter().zip(&marks) {
            is_pareto[i] = p;
            if p {
                seen.insert(records[i].method);
            }
        }
        for e in pareto_scenes.iter_mut() {
            if seen.contains(e.0) {
                e.1 += 1;
            }
        }
    }
    let recommended: Vec<&str> = pareto_scenes
        .iter()
        .filter(|e| 2 * e.1 >= args.scenes.len())
        .map(|e| e.0)
        .collect();

    // The command that reproduces this report: its depth and the WCSPH variants it swept.
    let mut flags: Vec<&str> = depth_flag(args.depth).split_whitespace().collect();
    for (on, flag) in [
        (args.wcsph_adami, "--wcsph-adami"),
        (args.wcsph_delta, "--wcsph-delta"),
    ] {
        if on {
            if flags.is_empty() {
                flags.push("--");
            }
            flags.push(flag);
        }
    }
    let command = format!(
        "cargo run --release --features report --example error_vs_runtime{}{}",
        if flags.is_empty() { "" } else { " " },
        flags.join(" ")
    );

    // CSV.
    let mut csv = String::new();
    writeln!(csv, "# machine: {machine}").unwrap();
    writeln!(csv, "# git revision: {git}").unwrap();
    writeln!(csv, "# command: {command}").unwrap();
    writeln!(csv, "# total wall time: {total:.1} s").unwrap();
    write!(
        csv,
        "scene,solver,resolution,spacing_m,particles,particles_end,escaped,policy,dt_ref_s,dt_mean_s,\
         duration_s,simulated_s,wall_s,substeps,particle_steps,particle_steps_per_s,stable,pareto,\
         max_density_error"
    )
    .unwrap();
    for c in ERROR_COLUMNS {
        write!(csv, ",{c}").unwrap();
    }
    writeln!(csv, ",note").unwrap();
    for (r, p) in records.iter().zip(&is_pareto) {
        write!(
            csv,
            "{},{},{},{:.6},{},{},{},{},{:.4e},{:.4e},{:.4},{:.4},{:.3},{},{},{:.0},{},{},{:.5}",
            r.scene,
            r.method,
            r.resolution,
            r.spacing,
            r.particles,
            r.particles_end,
            r.escaped,
            r.policy.name(),
            r.dt_ref,
            r.dt_mean,
            r.duration,
            r.simulated,
            r.wall_seconds,
            r.substeps,
            r.particle_steps,
            r.particle_steps_per_second(),
            r.stable,
            p,
            r.max_density_error
        )
        .unwrap();
        for c in ERROR_COLUMNS {
            write!(csv, ",{}", fmt_err(r.error(c))).unwrap();
        }
        writeln!(csv, ",\"{}\"", r.note.replace('"', "'")).unwrap();
    }
    std::fs::write(args.out.join("error_vs_runtime.csv"), csv).expect("write the CSV");

    // Markdown.
    let mut md = String::new();
    writeln!(md, "# Error against run time\n").unwrap();
    writeln!(md, "Made by `{command}` in {total:.0} s.\n").unwrap();
    writeln!(md, "- machine: {machine}").unwrap();
    writeln!(md, "- git revision: {git}").unwrap();
    writeln!(
        md,
        "- recommended solvers (a Pareto-optimal run in at least half of the scenes): {}\n",
        if recommended.is_empty() {
            "none".to_string()
        } else {
            recommended.join(", ")
        }
    )
    .unwrap();
    writeln!(
        md,
        "Errors are fractions (0.05 = 5 %). Wall time counts the fluid steps only. \
         `dt_ref` is the step the adaptive policy takes at the scene's characteristic speed; \
         `fixed dt/2` and `fixed 2dt` are fixed steps of half and twice that. ★ marks the \
         Pareto-optimal runs of a scene (no other stable run is both faster and more accurate \
         in the scene's first error). Scenes, measurements and references: `src/validation/`.\n"
    )
    .unwrap();
    writeln!(md, "![error against run time](error_vs_runtime.png)\n").unwrap();
    for scene in &args.scenes {
        let idx: Vec<usize> = (0..records.len())
            .filter(|&i| records[i].scene == scene.name())
            .collect();
        let cols: Vec<&str> = ERROR_COLUMNS
            .iter()
            .copied()
            .filter(|c| idx.iter().any(|&i| records[i].error(c).is_some()))
            .collect();
        writeln!(md, "## {}\n", scene.name()).unwrap();
        write!(
            md,
            "| | solver | N | particles | policy | mean dt (ms) | wall (s) | M particle-steps/s |"
        )
        .unwrap();
        for c in &cols {
            write!(md, " {c} |").unwrap();
        }
        writeln!(md, " max density error | stable |").unwrap();
        write!(md, "|---|---|---|---|---|---|---|---|").unwrap();
        for _ in &cols {
            write!(md, "---|").unwrap();
        }
        writeln!(md, "---|---|").unwrap();
        for &i in &idx {
            let r = &records[i];
            write!(
                md,
                "| {} | {} | {} | {} | {} | {:.3} | {:.2} | {:.2} |",
                if is_pareto[i] { "★" } else { "" },
                r.method,
                r.resolution,
                r.particles,
                r.policy.name(),
                r.dt_mean * 1e3,
                r.wall_seconds,
                r.particle_steps_per_second() / 1e6
            )
            .unwrap();
            for c in &cols {
                write!(md, " {} |", fmt_err(r.error(c))).unwrap();
            }
            writeln!(
                md,
                " {:.4} | {} |",
                r.max_density_error,
                if r.stable {
                    "yes".to_string()
                } else {
                    format!("no: {}", r.note)
                }
            )
            .unwrap();
        }
        writeln!(md).unwrap();
        // The spray, as a figure: no bound holds particle by particle (pressure moves energy
        // between particles), but a particle carrying Ritter's front's 2gH per unit mass
        // rises 2H at most.
        let mut highest: Vec<(&str, f64)> = Vec::new();
        for &i in &idx {
            let r = &records[i];
            let Some(top) = r.error("max_height").filter(|h| h.is_finite() && r.stable) else {
                continue;
            };
            match highest.iter_mut().find(|(m, _)| *m == r.method) {
                Some((_, h)) => *h = h.max(top),
                None => highest.push((r.method, top)),
            }
        }
        if !highest.is_empty() {
            let list: Vec<String> = highest.iter().map(|(m, h)| format!("{m} {h:.3}")).collect();
            writeln!(
                md,
                "Highest particle over the stable runs (`max_height`, over the highest at the \
                 start; 2 is where Ritter's front's `2gH` per unit mass would lift a particle): \
                 {}.\n",
                list.join(", ")
            )
            .unwrap();
        }
    }
    if !scaling.is_empty() {
        writeln!(
            md,
            "## Cost against particle count\n\n\
             The benchmark's dam break (the paper's tower, water preset at 0.02 m), fixed steps \
             of each solver's reference step, {} timed steps after a warm-up.\n\n\
             ![scaling](scaling.png)\n\n\
             | solver | particles | steps/s | ns per particle-step |\n|---|---|---|---|",
            if args.depth == Depth::Quick { 10 } else { 30 }
        )
        .unwrap();
        for p in &scaling {
            writeln!(
                md,
                "| {} | {} | {:.1} | {:.0} |",
                p.method, p.particles, p.steps_per_second, p.ns_per_particle_step
            )
            .unwrap();
        }
    }
    std::fs::write(args.out.join("error_vs_runtime.md"), md).expect("write the Markdown");
    let mut rec = String::from(
        "# Solvers the error-vs-run-time report recommends (one per line); read by tests/validation.rs\n",
    );
    for r in &recommended {
        writeln!(rec, "{r}").unwrap();
    }
    std::fs::write(args.out.join("recommended.txt"), rec).expect("write recommended.txt");
    if let Err(e) = draw_report(&args.out, &args.scenes, &records, &method_names) {
        eprintln!("error: drawing error_vs_runtime: {e}");
        std::process::exit(1);
    }
    if !scaling.is_empty()
        && let Err(e) = draw_scaling(&args.out, &scaling, &method_names)
    {
        eprintln!("error: drawing scaling: {e}");
        std::process::exit(1);
    }
    println!(
        "{} runs in {total:.1} s; recommended: {}; wrote {}",
        records.len(),
        recommended.join(", "),
        args.out.display()
    );
}
