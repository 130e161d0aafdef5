//! A column of water at rest in a closed tank: how quiet it stays and how hydrostatic its
//! pressure is, layer by layer.
//!
//! ```text
//! cargo run --release --example column                         # default solver, 10×20×10 at 2 cm, 3 s
//! cargo run --release --example column -- --solver wcsph --spacing 0.01 --seconds 5
//! cargo run --release --example column -- --solver dfsph --hydrostatic-walls --warm-start 0.5
//! cargo run --release --example column -- --solver dfsph --validation 6,8,12   # the report's scene
//! cargo run --release --example column -- --solver dfsph --hydrostatic-walls --n 8 --spacing 0.0125 --radius 0.4
//! cargo run --release --example column -- --solver clavet --n 8 --spacing 0.0125 --cohesion 0.1 --trace
//! ```
//!
//! The tank is [`rapier_sph::scenes::HydrostaticTank`] (`n × 2n × n` particles on a lattice
//! at rest density, released without pressure), stepped in frames of 1/60 s (adaptive
//! substeps). Every 0.25 s it prints the kinetic energy and the largest speed; over the last
//! quarter of the run it averages, per layer one spacing thick, the pressure over
//! `ρ0·g·depth` (depth from the free surface of the fluid's rest volume), separately for the
//! particles next to a side wall (center within one spacing of it) and for the interior ones
//! (at least 3 spacings from every side wall), and the layer's mean density; and the kinetic
//! energy split between the bulk and the top two layers, next to a side wall or not.
//!
//! Per layer it also prints where the layer sits (mean height over the spacing) and the mean
//! vertical acceleration the pressure forces and gravity leave on its particles (pairs and
//! walls recomputed from the reported pressures as the solver applies them; viscosity and
//! contact left out): what contact must carry. And the force balance: at rest the
//! particle–particle forces cancel in the total, so the walls' SPH terms (floor pressure
//! term, floor and side hydrostatic terms) and contact carry the weight; it prints each SPH
//! term's share and the rest (contact, and inertia, about zero averaged at rest).
//! `--trace` prints, every frame, the scene's bottom error, the mean pressure (the column's
//! pressure level), the center of mass's height and the kinetic energy.
//! At the end it prints the kernel's first moment `M = −Σ_j V_j (x_j − x_i) ⊗ ∇W_ij` in the
//! bulk (the identity for a continuum; a symmetric SPH gradient reads a linear pressure's
//! gradient scaled by it), brute force over all pairs.
//! It also prints the hydrostatic scene's pressure-profile RMS both ways: averaged over the
//! samples' instantaneous profiles (as the scene reports it) and of the time-averaged profile.
//! `--solver wcsph-walls` is WCSPH with walls counting in the density (the buoyancy tests'
//! setting), `wcsph-adami` with Adami's wall pressure and the symmetric pressure force
//! (`WcsphPressure::Adami`), `wcsph-delta` that with δ-SPH densities
//! (`WcsphDensity::DELTA_SPH`); `--radius r` sets the contact radius to `r` spacings (the preset's is 0.5);
//! `--solver pbf-hydrostatic` is PBF with hydrostatic walls;
//! `--support r` the kernel support to `r` spacings (the presets' is 2); `--solver clavet`
//! runs Clavet's relaxation (walls by contact only; `clavet-walls`: walls in its densities),
//! `--cohesion k` sets its cohesion (default 1).
//!
//! `--validation 6,8,12` instead runs the report's hydrostatic scene
//! (`rapier_sph::validation::hydrostatic`, adaptive steps) with the chosen settings at those
//! resolutions and prints its errors, as the `hydrostatic_bottom_pressure_within_2_percent`
//! test reads them.

use rapier_sph::math::Real;
use rapier_sph::scenes::HydrostaticTank;
use rapier_sph::{FluidParamsBuilder, Solver};

fn main() {
    let (mut n, mut s, mut seconds): (usize, Real, Real) = (10, 0.02, 3.0);
    let mut solver = "default".to_string();
    let mut hydrostatic_walls: Option<bool> = None;
    let mut warm: Option<Real> = None;
    let mut min_iterations: Option<u32> = None;
    let mut max_density_error: Option<Real> = None;
    let mut threads = 0usize;
    let mut radius: Option<Real> = None;
    let mut support: Option<Real> = None;
    let mut cohesion: Option<Real> = None;
    let mut courant: Option<Real> = None;
    let mut validation: Vec<usize> = Vec::new();
    let mut trace = false;
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i < args.len() {
        let value = args.get(i + 1).cloned().unwrap_or_default();
        let mut step = 2;
        match args[i].as_str() {
            "--n" => n = parse(&value, "--n"),
            "--spacing" => s = parse(&value, "--spacing"),
            "--seconds" => seconds = parse(&value, "--seconds"),
            "--solver" => solver = value,
            "--warm-start" => warm = Some(parse(&value, "--warm-start")),
            "--threads" => threads = parse(&value, "--threads"),
            "--radius" => radius = Some(parse(&value, "--radius")),
            "--support" => support = Some(parse(&value, "--support")),
            "--cohesion" => cohesion = Some(parse(&value, "--cohesion")),
            "--courant" => courant = Some(parse(&value, "--courant")),
            "--validation" => {
                validation = value.split(',').map(|v| parse(v, "--validation")).collect()
            }
            "--min-iterations" => min_iterations = Some(parse(&value, "--min-iterations")),
            "--max-density-error" => max_density_error = Some(parse(&value, "--max-density-error")),
            "--hydrostatic-walls" => {
                hydrostatic_walls = Some(true);
                step = 1;
            }
            "--trace" => {
                trace = true;
                step = 1;
            }
            "--no-hydrostatic-walls" => {
                hydrostatic_walls = Some(false);
                step = 1;
            }
            other => exit(&format!(
                "unknown argument {other} (--n, --spacing, --seconds, --solver default|wcsph|wcsph-walls|wcsph-adami|wcsph-delta|dfsph|pbf|pbf-hydrostatic|clavet|clavet-walls, \
                 --warm-start, --[no-]hydrostatic-walls, --threads, --radius (fraction of the spacing), --support (h in spacings), --cohesion (Clavet), --courant (adaptive substeps' Courant number, default 0.4), \
                 --trace)"
            )),
        }
        i += step;
    }
    if n < 4 || !(s.is_finite() && s > 0.0) || !(seconds.is_finite() && seconds > 0.0) {
        exit("--n must be at least 4, --spacing and --seconds positive");
    }
    if threads > 0 {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build_global()
            .unwrap_or_else(|e| exit(&e.to_string()));
    }
    let mut b = FluidParamsBuilder::water(s);
    match solver.as_str() {
        "default" => {}
        "wcsph" => b = b.solver(Solver::Wcsph).wall_density(false),
        "wcsph-walls" => b = b.solver(Solver::Wcsph).wall_density(true),
        "wcsph-adami" => {
            b = b
                .solver(Solver::Wcsph)
                .wall_density(true)
                .wcsph_pressure(rapier_sph::WcsphPressure::Adami)
        }
        "wcsph-delta" => {
            b = b
                .solver(Solver::Wcsph)
                .wall_density(true)
                .wcsph_pressure(rapier_sph::WcsphPressure::Adami)
                .wcsph_density(rapier_sph::WcsphDensity::DELTA_SPH)
        }
        "dfsph" => b = b.solver(Solver::dfsph()).wall_density(true),
        "pbf" => b = b.solver(Solver::pbf()).wall_density(true),
        "pbf-hydrostatic" => {
            b = b
                .solver(Solver::Pbf(rapier_sph::solver::Pbf {
                    hydrostatic_walls: true,
                    ..Default::default()
                }))
                .wall_density(true)
        }
        "clavet" | "clavet-walls" => {
            let mut c = rapier_sph::solver::Clavet::default();
            if let Some(k) = cohesion {
                c.cohesion = k;
            }
            b = b
                .solver(Solver::Clavet(c))
                .wall_density(solver == "clavet-walls")
        }
        other => exit(&format!("unknown solver {other}")),
    }
    if let Some(r) = support {
        // Kernel support in spacings (the presets' is 2).
        b = b.smoothing_length(r * s);
    }
    if let Some(r) = radius {
        // Contact radius as a fraction of the spacing (the preset's is 0.5).
        b = b.particle_radius(r * s);
    }
    let mut params = b.build().unwrap_or_else(|e| exit(&e.to_string()));
    if let Solver::Dfsph(d) = &mut params.solver {
        if let Some(on) = hydrostatic_walls {
            d.hydrostatic_walls = on;
        }
        if let Some(w) = warm {
            d.warm_start = w;
        }
        if let Some(m) = min_iterations {
            d.min_iterations = m;
        }
        if let Some(e) = max_density_error {
            d.max_density_error = e;
        }
    } else if hydrostatic_walls.is_some() || warm.is_some() || min_iterations.is_some() {
        exit("--warm-start and --[no-]hydrostatic-walls are DFSPH settings");
    }
    if !validation.is_empty() && radius.is_some() {
        exit("--radius is not passed to the validation scene (it builds the preset's fluid)");
    }
    if !validation.is_empty() {
        // The validation scene (`rapier_sph::validation::hydrostatic`), adaptive steps.
        use rapier_sph::validation::{Method, Scene, TimePolicy};
        let method = Method {
            name: "probe",
            solver: params.solver,
            wall_density: params.wall_density,
            wcsph_pressure: params.wcsph_pressure,
            wcsph_density: params.wcsph_density,
        };
        for res in validation {
            let r = Scene::Hydrostatic
                .run(&method, res, TimePolicy::Adaptive, &mut |_| {})
                .unwrap_or_else(|e| exit(&e.to_string()));
            println!(
                "hydrostatic scene N = {res} adaptive: bottom {:+.4}, RMS {:.4}, mean compression {:.5}, stable {}, escaped {}, {:.1} s",
                r.error("bottom_pressure").unwrap_or(f64::NAN),
                r.error("pressure_rms").unwrap_or(f64::NAN),
                r.error("mean_density_error").unwrap_or(f64::NAN),
                r.stable,
                r.escaped,
                r.wall_seconds
            );
        }
        return;
    }
    println!(
        "solver {:?}, wall density {}, {n}x{}x{n} at {s} m, {seconds} s in 1/60 s frames",
        params.solver,
        params.wall_density,
        2 * n
    );
    let rho0 = params.rest_density;
    let mut tank =
        HydrostaticTank::new(params, [n, 2 * n, n]).unwrap_or_else(|e| exit(&e.to_string()));
    let frame = 1.0 / 60.0;
    tank.world.physics.integration_parameters.dt = frame;
    if let Some(c) = courant {
        tank.world.pipeline.time_stepping = rapier_sph::TimeStepping::Adaptive {
            courant: c,
            max_substeps: 4096,
        };
    }
    let g = tank.world.physics.gravity.length();
    let height = tank.fluid_height;
    let width = n as Real * s;
    let frames = (seconds / frame).round() as usize;
    let settle = frames - frames / 4;
    let layers = 2 * n;
    // (pressure sum, expected sum, count) per layer: wall column, interior; density sum, count.
    let mut wall = vec![(0.0f64, 0.0f64); layers];
    let mut inner = vec![(0.0f64, 0.0f64); layers];
    let mut dens = vec![(0.0f64, 0usize); layers];
    // Sum of the particles' heights per layer (where each layer actually sits).
    let mut heights = vec![0.0f64; layers];
    let (mut ke_late, mut vmax_late, mut samples) = (0.0f64, Real::default(), 0usize);
    let (mut substeps, mut iterations, mut div_iterations) = (0u64, 0u64, 0u64);
    let mut bottom = 0.0f64;
    // The scene's pressure-profile RMS, sample by sample (instantaneous profiles).
    let mut profile_rms = 0.0f64;
    // Kinetic energy over the last quarter: below the top two layers / in them, away from /
    // next to a side wall.
    let mut regions = [0.0f64; 4];
    // Force balance over the last quarter (fractions of the weight): the walls' SPH terms
    // recomputed from the particles' reported pressures (see `WallBalance`).
    let balance = WallBalance::new(tank.world.fluids[tank.fluid].params(), width, g);
    let mut balance_sum = [0.0f64; 4];
    // Vertical residual acceleration per layer (wall column, interior), summed.
    let mut resid = vec![(0.0f64, 0usize, 0.0f64, 0usize); layers];
    // Bottom layer: the fluid's and the floor's zeroth-order sums (times the spacing), summed.
    let mut zeroth = (0.0f64, 0.0f64, 0usize);
    let t0 = std::time::Instant::now();
    let mut ke_window = 0.0f64;
    let mut v_window: Real = 0.0;
    for f in 1..=frames {
        let r = tank.world.step().unwrap_or_else(|e| exit(&e.to_string()));
        substeps += r.substeps as u64;
        iterations += r.solver_iterations as u64;
        div_iterations += r.divergence_iterations as u64;
        let fl = &tank.world.fluids[tank.fluid];
        let m = fl.params().particle_mass as f64;
        let ke: f64 = fl
            .velocities()
            .iter()
            .map(|v| 0.5 * m * v.length_squared() as f64)
            .sum();
        let vmax = fl
            .velocities()
            .iter()
            .map(|v| v.length())
            .fold(0.0, Real::max);
        if trace {
            // Frame by frame: time, the scene's bottom error, the mean pressure (the column's
            // pressure level), the center of mass's height, the kinetic energy.
            let b = HydrostaticTank::bottom_pressure_error_of(&tank.world, tank.fluid, height);
            let n_p = fl.len().max(1) as f64;
            let mean_p: f64 = fl.pressures().iter().map(|&p| p as f64).sum::<f64>() / n_p;
            let cy: f64 = fl.positions().iter().map(|x| x.y as f64).sum::<f64>() / n_p;
            println!(
                "trace {:.4} s: bottom {b:+.4}, mean pressure {mean_p:.2} Pa, center {cy:.6} m, \
                 kinetic energy {ke:.3e} J",
                f as Real * frame
            );
        }
        ke_window = ke_window.max(ke);
        v_window = v_window.max(vmax);
        if f % 15 == 0 {
            println!(
                "t = {:5.2} s: max kinetic energy {ke_window:.3e} J, max speed {v_window:.4} m/s",
                f as Real * frame
            );
            ke_window = 0.0;
            v_window = 0.0;
        }
        if f > settle {
            samples += 1;
            ke_late += ke;
            vmax_late = vmax_late.max(vmax);
            bottom +=
                HydrostaticTank::bottom_pressure_error_of(&tank.world, tank.fluid, height) as f64;
            profile_rms +=
                HydrostaticTank::pressure_profile_rms_of(&tank.world, tank.fluid, height) as f64;
            let b = balance.fractions(fl.positions(), fl.pressures(), fl.densities());
            for (s, v) in balance_sum.iter_mut().zip(b) {
                *s += v;
            }
            let res = balance.residuals(fl.positions(), fl.pressures(), fl.densities());
            for (x, (a, z, w)) in fl.positions().iter().zip(res) {
                if x.y < s {
                    zeroth.0 += (z * s) as f64;
                    zeroth.1 += (w * s) as f64;
                    zeroth.2 += 1;
                }
                let k = (x.y / s).floor();
                if !(k >= 0.0 && (k as usize) < layers) {
                    continue;
                }
                let side = x.x.min(width - x.x).min(x.z).min(width - x.z);
                let e = &mut resid[k as usize];
                if side < s {
                    e.0 += a as f64;
                    e.1 += 1;
                } else {
                    e.2 += a as f64;
                    e.3 += 1;
                }
            }
            for (((x, &p), &rho), v) in fl
                .positions()
                .iter()
                .zip(fl.pressures())
                .zip(fl.densities())
                .zip(fl.velocities())
            {
                let side = x.x.min(width - x.x).min(x.z).min(width - x.z);
                let e = 0.5 * m * v.length_squared() as f64;
                let top = x.y > height - 2.0 * s;
                regions[(top as usize) * 2 + (side < s) as usize] += e;
                let k = (x.y / s).floor();
                if !(k >= 0.0 && (k as usize) < layers) {
                    continue;
                }
                let k = k as usize;
                let expected = (rho0 * g * (height - x.y)) as f64;
                if side < s {
                    wall[k].0 += p as f64;
                    wall[k].1 += expected;
                } else if side >= 3.0 * s {
                    inner[k].0 += p as f64;
                    inner[k].1 += expected;
                }
                dens[k].0 += rho as f64;
                dens[k].1 += 1;
                heights[k] += x.y as f64;
            }
        }
    }
    let r = |k: usize| regions[k] / samples as f64;
    println!(
        "last quarter: mean kinetic energy below the top 2 layers {:.2e} J (interior) + {:.2e} J \
         (next to a side wall); top 2 layers {:.2e} + {:.2e} J",
        r(0),
        r(1),
        r(2),
        r(3)
    );
    let ratio = |e: (f64, f64)| if e.1 > 0.0 { e.0 / e.1 } else { f64::NAN };
    println!(
        "last quarter: layer (from the floor), p / rho0 g depth (wall column, interior), mean density, \
         mean height / spacing, vertical pressure + gravity acceleration / g (wall column, interior)"
    );
    for k in 0..layers {
        println!(
            "  {k:2}: {:6.3} {:6.3}  {:8.2}  {:7.4}  {:+7.3} {:+7.3}",
            ratio(wall[k]),
            ratio(inner[k]),
            dens[k].0 / dens[k].1.max(1) as f64,
            heights[k] / dens[k].1.max(1) as f64 / s as f64,
            resid[k].0 / resid[k].1.max(1) as f64 / g as f64,
            resid[k].2 / resid[k].3.max(1) as f64 / g as f64
        );
    }
    println!(
        "bottom layer's zeroth-order sums x spacing: fluid {:.4}, floor {:.4}",
        zeroth.0 / zeroth.2.max(1) as f64,
        zeroth.1 / zeroth.2.max(1) as f64
    );
    // The kernel's first moment in the bulk at the end: `M = −Σ_j V_j (x_j − x_i) ⊗ ∇W_ij`
    // (the identity for a continuum; the symmetric pressure force reads a linear pressure's
    // gradient scaled by about `M_yy`), over particles at least h from every wall and below
    // the top two layers. Brute force over all pairs.
    {
        use rapier_sph::kernel::{CubicSpline, Kernel};
        let f = &tank.world.fluids[tank.fluid];
        let prm = f.params();
        let kern = CubicSpline::new(prm.smoothing_length);
        let h = prm.smoothing_length;
        let xs = f.positions();
        let rho = f.densities();
        let (mut myy, mut mxx, mut cnt) = (0.0f64, 0.0f64, 0usize);
        for (i, xi) in xs.iter().enumerate() {
            let inside = xi.x > h
                && xi.x < width - h
                && xi.z > h
                && xi.z < width - h
                && xi.y > h
                && xi.y < height - 2.0 * s;
            if !inside {
                continue;
            }
            let (mut a, mut b) = (0.0f64, 0.0f64);
            for (j, xj) in xs.iter().enumerate() {
                let r = *xi - *xj;
                let d = r.length();
                if j == i || d >= h {
                    continue;
                }
                let gw = r * (kern.dw(d) / d);
                let v = (prm.particle_mass / rho[j]) as f64;
                a -= v * ((xj.y - xi.y) * gw.y) as f64;
                b -= v * ((xj.x - xi.x) * gw.x) as f64;
            }
            myy += a;
            mxx += b;
            cnt += 1;
        }
        println!(
            "kernel first moment in the bulk at the end (1 for a continuum): M_yy {:.4}, M_xx {:.4} \
             over {cnt} particles",
            -myy / cnt.max(1) as f64,
            -mxx / cnt.max(1) as f64
        );
    }
    // The same RMS from the time-averaged layers (interior and wall columns pooled).
    let averaged: Vec<f64> = (0..layers.saturating_sub(1))
        .filter_map(|k| {
            let (p, e) = (wall[k].0 + inner[k].0, wall[k].1 + inner[k].1);
            (e > 0.0).then(|| p / e - 1.0)
        })
        .collect();
    println!(
        "pressure-profile RMS (scene measure): {:.4} averaged over the samples' profiles, {:.4} \
         of the time-averaged profile (wall columns and interior only)",
        profile_rms / samples as f64,
        (averaged.iter().map(|e| e * e).sum::<f64>() / averaged.len().max(1) as f64).sqrt()
    );
    let bs: Vec<f64> = balance_sum.iter().map(|v| v / samples as f64).collect();
    println!(
        "force balance (fractions of the weight, last quarter): floor pressure term {:.4}, floor \
         hydrostatic term {:.4}, side walls' hydrostatic term {:.4}; SPH walls {:.4}, contact and \
         inertia the rest {:+.4}",
        bs[0],
        bs[1],
        bs[2],
        bs[3],
        1.0 - bs[3]
    );
    println!(
        "bottom error (scene measure) {:+.4}, mean kinetic energy {:.3e} J, max speed {:.4} m/s; \
         {:.2} substeps/frame, {:.2} density + {:.2} divergence iterations per substep; {:.1} s",
        bottom / samples as f64,
        ke_late / samples as f64,
        vmax_late,
        substeps as f64 / frames as f64,
        iterations as f64 / substeps as f64,
        div_iterations as f64 / substeps as f64,
        t0.elapsed().as_secs_f64()
    );
}

/// The vertical force the box's walls exert on the fluid through the SPH wall terms,
/// recomputed from the particles' positions, reported pressures and densities (the same
/// half-space tables and union of half-spaces as `boundary::wall`, the box's five faces).
/// At rest the particle–particle forces cancel in the total, so these terms plus contact
/// carry the weight; [`WallBalance::fractions`] returns them as fractions of it. With
/// hydrostatic walls the wall's pressure (its fluid-side neighbours' average carried back to
/// the particle, see `WallWorkspace::neighbour_pressure`) is taken as the particle's own,
/// `γ = 2` on `p_i`, and the carrying back is left out: exact in a linear hydrostatic field,
/// an approximation otherwise.
struct WallBalance {
    table: rapier_sph::kernel::HalfSpaceTable,
    /// `γ` on `p/ρ²` (DFSPH: the mirror weight; WCSPH: ½).
    gamma: Real,
    hydrostatic: bool,
    /// Kernel of the pair pressure force, its support, and whether it is WCSPH's form.
    kernel: rapier_sph::kernel::KernelKind,
    h: Real,
    wcsph: bool,
    rest: Real,
    mass: Real,
    width: Real,
    g: Real,
}

impl WallBalance {
    fn new(p: &rapier_sph::FluidParams, width: Real, g: Real) -> Self {
        let (kernel, gamma, hydrostatic) = match p.solver {
            Solver::Dfsph(d) if d.hydrostatic_walls => (
                p.density_kernel,
                rapier_sph::solver::HYDROSTATIC_WALL_MIRROR,
                true,
            ),
            Solver::Dfsph(_) => (p.density_kernel, rapier_sph::solver::WALL_MIRROR, false),
            Solver::Wcsph if p.wcsph_pressure == rapier_sph::WcsphPressure::Adami => (
                p.pressure_kernel,
                rapier_sph::solver::HYDROSTATIC_WALL_MIRROR,
                true,
            ),
            _ => (p.pressure_kernel, 0.5, false),
        };
        let h = p.smoothing_length;
        let table = rapier_sph::with_kernel!(kernel, K =>
            rapier_sph::kernel::HalfSpaceTable::new::<K>(h, p.particle_spacing));
        Self {
            table,
            gamma: if p.wall_density { gamma } else { 0.0 },
            hydrostatic,
            kernel,
            h,
            // Müller's form (the paper's WCSPH), or the symmetric one.
            wcsph: !matches!(p.solver, Solver::Dfsph(_))
                && p.wcsph_pressure == rapier_sph::WcsphPressure::Paper,
            rest: p.rest_density,
            mass: p.particle_mass,
            width,
            g,
        }
    }

    /// Each particle's vertical acceleration from the pressure forces (pairs and walls, as
    /// the solver applies them, from the reported pressures) and gravity, viscosity and
    /// contact left out: what contact (or motion) must make up at this instant (m/s²).
    /// Also returns, per particle, `(Σ_j V ∂W_ij/∂y, |∇ρ_wall,y|/ρ0)`: the fluid's and the
    /// floor's zeroth-order sums (1/m), which cancel in the mirrored wall term when consistent.
    fn residuals(
        &self,
        x: &[rapier_sph::math::Vector],
        p: &[Real],
        rho: &[Real],
    ) -> Vec<(Real, Real, Real)> {
        let h2 = self.h * self.h;
        let m = self.mass;
        let v = self.mass / self.rest;
        (0..x.len())
            .map(|i| {
                let mut ay: Real = 0.0;
                let mut zeroth: Real = 0.0;
                for j in 0..x.len() {
                    let r = x[i] - x[j];
                    let d2 = r.length_squared();
                    if j == i || d2 >= h2 {
                        continue;
                    }
                    let d = d2.sqrt();
                    let gy = self.kernel.dw(d, self.h) * r.y / d;
                    zeroth += v * gy;
                    let c = if self.wcsph {
                        (p[i] + p[j]) / (2.0 * rho[i] * rho[j])
                    } else {
                        p[i] / (rho[i] * rho[i]) + p[j] / (rho[j] * rho[j])
                    };
                    ay -= m * c * gy;
                }
                let [f, hf, hs, _] = self.fractions(&x[i..=i], &p[i..=i], &rho[i..=i]);
                // The floor's own |∇ρ_wall|/ρ0 (the union with the sides left out).
                let wall = self.table.eval(x[i].y).1;
                (ay + ((f + hf + hs) as Real - 1.0) * self.g, zeroth, wall)
            })
            .collect()
    }

    /// `[floor pressure term, floor hydrostatic term, side walls' hydrostatic term, sum]`,
    /// each the total upward force over `M·g`.
    fn fractions(&self, x: &[rapier_sph::math::Vector], p: &[Real], rho: &[Real]) -> [f64; 4] {
        let t = &self.table;
        let full = t.full();
        let mut out = [0.0f64; 4];
        for ((x, &p), &rho) in x.iter().zip(p).zip(rho) {
            // (normal's y, distance, is floor) of the floor and the four sides.
            let faces = [
                (1.0, x.y, true),
                (0.0, x.x, false),
                (0.0, self.width - x.x, false),
                (0.0, x.z, false),
                (0.0, self.width - x.z, false),
            ];
            let (mut u, mut gy): (Real, Real) = (0.0, 0.0);
            let (mut hf, mut hs): (Real, Real) = (0.0, 0.0);
            for (ny, d, floor) in faces {
                let (phi, area) = t.eval(d);
                let a = (phi / full).min(1.0);
                if a <= 0.0 && area <= 0.0 {
                    continue;
                }
                // ∇ρ_wall's y component (into the wall: −n), union-weighted.
                gy = gy * (1.0 - a) - ny * area / full * (1.0 - u);
                hf *= 1.0 - a;
                hs *= 1.0 - a;
                if self.hydrostatic {
                    let (phi_f, mom) = t.eval_moment(d);
                    // −(M n n + Φ (I − n n))·g, g = −g ŷ: upward M·g (floor) or Φ·g (sides).
                    if floor {
                        hf += mom * self.g * (1.0 - u);
                    } else {
                        hs += phi_f * self.g * (1.0 - u);
                    }
                }
                u = 1.0 - (1.0 - u) * (1.0 - a);
            }
            let grad_y = gy * self.rest * full;
            out[0] += (-self.gamma * p / (rho * rho) * grad_y) as f64;
            out[1] += hf as f64;
            out[2] += hs as f64;
        }
        let weight = (x.len() as Real * self.g) as f64;
        let _ = self.mass; // per-particle mass cancels in the fractions
        for v in out.iter_mut().take(3) {
            *v /= weight;
        }
        out[3] = out[0] + out[1] + out[2];
        out
    }
}

fn parse<T: std::str::FromStr>(v: &str, flag: &str) -> T {
    v.parse()
        .unwrap_or_else(|_| exit(&format!("{flag}: not a number: {v:?}")))
}

fn exit(msg: &str) -> ! {
    eprintln!("{msg}");
    std::process::exit(2)
}
