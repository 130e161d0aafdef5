//! Liquid rope coiling: a thin stream of a very viscous liquid pushed out of a nozzle onto a
//! floor, its landing point followed over time.
//!
//! ```text
//! cargo run --release --example coil                        # ν = 3 m²/s, 20 diameters, 3 s
//! cargo run --release --example coil -- --render out/coil   # also PNG frames and coil.gif
//! cargo run --release --example coil -- --nu 100 --height 8 # the viscous regime
//! cargo run --release --example coil -- --stress            # the stress-based viscosity
//! ```
//!
//! At the defaults it ends with about 7,560 particles (the nozzle releases 2,520 a second, the
//! floor keeps them) after 3,190 substeps: 76 s of CPU on one thread (`RAYON_NUM_THREADS=1`).
//!
//! It does not coil steadily (docs/solvers.md, "Rope coiling", has the figures): at the
//! defaults (gravitational by the numbers below) the rope lays loops and breaks; in the
//! viscous regime it swells instead of buckling. With `--stress` (the stress-based implicit
//! viscosity, `ViscositySolve::Stress`) it does not either (2 s: loops of 15 mm mean radius,
//! the laying point turning back in 19 of 48 frames).
//!
//! **The nozzle.** A stream in the viscous regime is pushed by the pressure behind the nozzle:
//! neither gravity nor its own momentum can drive it into the floor (that is what makes the
//! regime). An emitter only places particles with a velocity, so the nozzle here is a tube
//! (`--tube` diameters long) whose content is moved kinematically: before every step the
//! particles in it are replaced by a lattice moving at `U`, and a layer leaving the tube's
//! mouth is released into the stream. The flux is exactly `Q = n_slots·U·Δx²` whatever the
//! stream below does, the stream's top is clamped vertical, and the liquid in the tube drags
//! and presses the rope below it (the pressure of the overlap and the viscosity).
//!
//! **What it measures.** The laying point (the mean of the 20 youngest particles that have
//! come to rest, `|v| < U/4`), its azimuth about the nozzle's axis unwrapped over time, how
//! often that azimuth turns back, its radius, and a linear fit of the azimuth over the run's
//! second half: the coiling frequency if it coils. Beside it the three scaling laws of
//! liquid rope coiling (Ribe 2004, Proc. R. Soc. A 460, 3223; Maleki, Habibi, Golestanian,
//! Ribe & Bonn 2004, Phys. Rev. Lett. 93, 214502; the inertial law first in Mahadevan, Ryu
//! & Samuel 1998, Nature 392, 140), with `a1` and `U1` the rope's radius and speed where it
//! lands, `H` the fall height:
//!
//! - viscous: `Ω_V ~ U1/H`;
//! - gravitational: `Ω_G ~ (g Q³/(ν a1⁸))^(1/4)`;
//! - inertial: `Ω_I ~ (Q⁴/(ν a1¹⁰))^(1/3)`.
//!
//! They give scalings, not constants. The regime is the balance of forces in the coil:
//! `(Ω_G/Ω_V)⁴ = g H⁴/(ν a1² U1)` compares gravity with the viscous forces, `(Ω_I/Ω_V)³ =
//! U1 H³/(ν a1²)` inertia with them; both well below 1 is the viscous regime.

use clap::Parser;
use rapier_sph::math::{Real, Vector};
use rapier_sph::rapier3d::prelude::{ColliderBuilder, RigidBodyBuilder};
use rapier_sph::render::{Camera, FluidStyle, Recorder, RenderOptions};
use rapier_sph::{
    Emitter, Fluid, FluidHandle, FluidParamsBuilder, FluidWorld, ImplicitViscosity, Nozzle,
    SphResult, ViscositySolve,
};
use std::path::PathBuf;
use std::time::Instant;

#[derive(Parser, Debug)]
#[command(about = "A thin viscous stream pushed onto a floor (liquid rope coiling)")]
struct Args {
    /// Particle spacing (m).
    #[arg(long, default_value_t = 0.0025)]
    spacing: f32,
    /// Nozzle radius in spacings (2.5: 21 slots, 5 particles across).
    #[arg(long, default_value_t = 2.5)]
    radius: f32,
    /// Fall height (the nozzle's mouth above the floor) in stream diameters.
    #[arg(long, default_value_t = 20.0)]
    height: f32,
    /// Length of the nozzle's tube in stream diameters.
    #[arg(long, default_value_t = 1.0)]
    tube: f32,
    /// Speed out of the nozzle (m/s).
    #[arg(long, default_value_t = 0.3)]
    speed: f32,
    /// Kinematic viscosity (m²/s).
    #[arg(long, default_value_t = 3.0)]
    nu: f32,
    /// Rest density (kg/m³).
    #[arg(long, default_value_t = 1400.0)]
    density: f32,
    /// Seconds simulated.
    #[arg(long, default_value_t = 3.0)]
    seconds: f32,
    /// Steps per 1/60 s frame (the tube is moved once per step).
    #[arg(long, default_value_t = 15)]
    steps: u32,
    /// Iteration cap of the implicit viscosity solve.
    #[arg(long, default_value_t = 400)]
    iterations: u32,
    /// The stress-based implicit viscosity (`ViscositySolve::Stress`, Takahashi et al. 2015)
    /// instead of Weiler et al.'s Laplacian (`ViscositySolve::Implicit`).
    #[arg(long)]
    stress: bool,
    /// Feed the stream from an emitter at the nozzle instead of the tube (for comparison:
    /// it neither pushes nor, at 1/60 s frames, supplies continuously).
    #[arg(long)]
    emitter: bool,
    /// Print the laying point every frame.
    #[arg(long)]
    trace: bool,
    /// Write PNG frames and coil.gif here (a frame every 1/15 s).
    #[arg(long)]
    render: Option<PathBuf>,
}

/// The nozzle: a tube whose content moves kinematically (see the module docs).
struct Tube {
    slots: Vec<(Real, Real)>,
    mouth: Real,
    top: Real,
    speed: Real,
    spacing: Real,
    /// Ids of the particles standing in the tube, replaced at the next step.
    held: std::ops::Range<u32>,
    released: usize,
}

impl Tube {
    fn new(radius: Real, spacing: Real, mouth: Real, length: Real, speed: Real) -> Self {
        let n = (radius / spacing).floor() as i32;
        let mut slots = Vec::new();
        for i in -n..=n {
            for k in -n..=n {
                let (x, z) = (i as Real * spacing, k as Real * spacing);
                if x * x + z * z <= radius * radius {
                    slots.push((x, z));
                }
            }
        }
        Self {
            slots,
            mouth,
            top: mouth + length,
            speed,
            spacing,
            held: 0..0,
            released: 0,
        }
    }

    /// Replaces the tube's content by the lattice at time `t` and releases the layers that
    /// crossed the mouth since `t − dt`.
    fn drive(&mut self, fluid: &mut Fluid, t: Real, dt: Real) -> SphResult<()> {
        let held = self.held.clone();
        fluid.remove_particles_where(|_, _, id| held.contains(&id));
        let (s, u) = (self.spacing, self.speed);
        // Layer j is at y_j(t) = top + j·s − U·t.
        let y = |j: i64, t: Real| self.top + j as Real * s - u * t;
        let lowest = ((self.mouth - self.top + u * (t - dt)) / s).floor() as i64 - 1;
        let highest = ((u * t) / s).floor() as i64;
        let (mut free, mut inside) = (Vec::new(), Vec::new());
        for j in lowest..=highest {
            let (now, before) = (y(j, t), y(j, t - dt));
            let layer = if now > self.mouth && now <= self.top {
                &mut inside
            } else if now <= self.mouth && before > self.mouth {
                &mut free
            } else {
                continue;
            };
            layer.extend(self.slots.iter().map(|&(x, z)| Vector::new(x, now, z)));
        }
        let v = Vector::new(0.0, -u, 0.0);
        self.released += free.len();
        fluid.add_particles_with_velocities(&free, Some(&vec![v; free.len()]))?;
        self.held = fluid.add_particles_with_velocities(&inside, Some(&vec![v; inside.len()]))?;
        Ok(())
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a = Args::parse();
    let s = a.spacing;
    let radius = a.radius * s;
    let d = 2.0 * radius;
    let h = a.height * d;
    let u = a.speed;
    let mu = a.nu * a.density;
    let solve = ImplicitViscosity {
        max_iterations: a.iterations,
        ..Default::default()
    };
    let params = FluidParamsBuilder::water(s)
        .rest_density(a.density)
        .viscosity(mu)
        .wall_viscosity(mu)
        .viscosity_solve(if a.stress {
            ViscositySolve::Stress(solve)
        } else {
            ViscositySolve::Implicit(solve)
        })
        .build()?;
    let mut world = FluidWorld::new();
    world.physics.integration_parameters.dt = 1.0 / (60.0 * a.steps as Real);
    let body = world.physics.insert_body(RigidBodyBuilder::fixed());
    let half = 40.0 * radius;
    let floor = ColliderBuilder::cuboid(half, 0.05, half).translation(Vector::new(0.0, -0.05, 0.0));
    world.physics.insert_collider(floor, Some(body));
    let mut fluid = Fluid::new(params)?;
    let mut tube = Tube::new(radius, s, h, a.tube * d, u);
    if a.emitter {
        let rate = tube.slots.len() as Real * u / s;
        let nozzle = Emitter::new(
            Nozzle::Disk { radius },
            Vector::new(0.0, h, 0.0),
            -Vector::Y,
            u,
            rate,
        );
        fluid.add_emitter(nozzle)?;
    }
    let fh = world.fluids.insert(fluid);
    let q = tube.slots.len() as Real * u * s * s;
    println!(
        "coil: nozzle {} slots ({:.1} mm wide at {:.1} mm spacing), U = {u} m/s, Q = {q:.3e} \
         m³/s, fall height {:.0} mm ({} diameters), ν = {} m²/s (μ = {:.3e} Pa·s, ρ = {})",
        tube.slots.len(),
        d * 1e3,
        s * 1e3,
        h * 1e3,
        a.height,
        a.nu,
        mu,
        a.density
    );
    let mut pictures = a
        .render
        .as_ref()
        .map(|dir| recorder(dir, h, u))
        .transpose()?;
    let frames = (a.seconds * 60.0).round() as usize;
    let dt = world.physics.integration_parameters.dt;
    let mut track = Track::default();
    let mut cost = (0usize, 0usize);
    let mut residual: Real = 0.0;
    let mut blocked = 0usize;
    let start = Instant::now();
    for frame in 1..=frames {
        for k in 0..a.steps {
            let t = (frame - 1) as Real / 60.0 + (k + 1) as Real * dt;
            if !a.emitter {
                tube.drive(&mut world.fluids[fh], t, dt)?;
            }
            let rep = world.step()?;
            blocked += rep.emitter_blocked;
            cost.0 += rep.substeps as usize;
            cost.1 += rep.viscosity_iterations;
            residual = residual.max(rep.viscosity_residual);
        }
        let t = frame as f64 / 60.0;
        track.sample(t, &world.fluids[fh], u, h, d);
        if a.trace {
            let p = track.points.last().map(|p| p.1).unwrap_or_default();
            println!(
                "t {t:5.3}  n {:6}  laying point ({:+.4}, {:.4}, {:+.4})  azimuth {:8.3} rad",
                world.fluids[fh].len(),
                p.x,
                p.y,
                p.z,
                track.unwrapped.last().copied().unwrap_or_default()
            );
        }
        if let Some(p) = pictures.as_mut()
            && frame % 4 == 0
        {
            p.frame(&world)?;
        }
    }
    let wall = start.elapsed().as_secs_f64();
    if a.emitter {
        let f = &world.fluids[fh];
        println!(
            "emitter: {} particles placed of {:.0} due, {blocked} blocked",
            f.emitted(),
            tube.slots.len() as Real * u / s * a.seconds
        );
    }
    report(&a, &track, &world, fh, h, q, tube.released)?;
    println!(
        "{frames} frames, {} substeps, {} CG iterations ({:.0} a substep, worst residual \
         {residual:.1e}), wall {wall:.1} s",
        cost.0,
        cost.1,
        cost.1 as f64 / cost.0.max(1) as f64
    );
    if let (Some(p), Some(dir)) = (pictures, a.render.as_ref()) {
        p.finish()?;
        println!("pictures  {}/frame_*.png and coil.gif", dir.display());
    }
    Ok(())
}

fn recorder(dir: &PathBuf, h: Real, u: Real) -> Result<Recorder, Box<dyn std::error::Error>> {
    let options = RenderOptions {
        style: FluidStyle::Spheres,
        width: 320,
        height: 320,
        speed_range: Some((0.0, u)),
        ..Default::default()
    };
    let camera = Camera::look_at(
        Vector::new(0.0, 1.1 * h, 1.9 * h),
        Vector::new(0.0, 0.4 * h, 0.0),
    );
    Ok(Recorder::create(dir, "coil", options, camera, 0.0, 7)?)
}

/// The laying point over time and its azimuth about the nozzle's axis.
#[derive(Default)]
struct Track {
    points: Vec<(f64, Vector)>,
    unwrapped: Vec<f64>,
    /// Speed of the rope just above where it lands, per frame.
    rope: Vec<(f64, f64)>,
    /// The rope's radius at half the fall height and its centre's distance from the axis
    /// (last frame).
    radius: f64,
    offset: f64,
}

impl Track {
    fn sample(&mut self, t: f64, f: &Fluid, u: Real, h: Real, d: Real) {
        self.swell(f, h);
        let mut slow: Vec<(u32, Vector)> = f
            .ids()
            .iter()
            .zip(f.positions())
            .zip(f.velocities())
            .filter(|((_, p), v)| v.length() < 0.25 * u && p.y < h - 0.5 * d)
            .map(|((id, p), _)| (*id, *p))
            .collect();
        if slow.len() < 20 {
            return;
        }
        slow.sort_by_key(|x| std::cmp::Reverse(x.0));
        let p = slow[..20].iter().fold(Vector::ZERO, |acc, x| acc + x.1) / 20.0;
        let theta = (p.z as f64).atan2(p.x as f64);
        let turned = match (self.points.last(), self.unwrapped.last()) {
            (Some(&(_, q)), Some(&w)) => {
                let mut d = theta - (q.z as f64).atan2(q.x as f64);
                d -= (d / std::f64::consts::TAU).round() * std::f64::consts::TAU;
                w + d
            }
            _ => theta,
        };
        self.points.push((t, p));
        self.unwrapped.push(turned);
        // The rope above the laying point: particles between one and two diameters above
        // it that still move down faster than U/2.
        let band: Vec<Real> = f
            .positions()
            .iter()
            .zip(f.velocities())
            .filter(|(x, v)| x.y > p.y + 0.05 * h && x.y < p.y + 0.15 * h && v.y < -0.5 * u)
            .map(|(_, v)| -v.y)
            .collect();
        if !band.is_empty() {
            let speed = band.iter().sum::<Real>() as f64 / band.len() as f64;
            self.rope.push((t, speed));
        }
    }
}

impl Track {
    /// The rope's radius at half the fall height, `√2` times the particles' RMS distance
    /// from their centroid in a band one spacing thick (a disk of radius `R` has RMS `R/√2`).
    fn swell(&mut self, f: &Fluid, h: Real) {
        let s = f.params().particle_spacing;
        let band: Vec<Vector> = f
            .positions()
            .iter()
            .filter(|p| (p.y - 0.5 * h).abs() < 0.5 * s)
            .copied()
            .collect();
        if band.len() < 3 {
            return;
        }
        let c = band.iter().fold(Vector::ZERO, |a, p| a + *p) / band.len() as Real;
        let ms = band
            .iter()
            .map(|p| ((p.x - c.x).powi(2) + (p.z - c.z).powi(2)) as f64)
            .sum::<f64>()
            / band.len() as f64;
        self.radius = (2.0 * ms).sqrt();
        self.offset = ((c.x * c.x + c.z * c.z) as f64).sqrt();
    }
}

/// The summary: does it coil, at what frequency, against the three laws.
fn report(
    a: &Args,
    track: &Track,
    world: &FluidWorld,
    fh: FluidHandle,
    h: Real,
    q: Real,
    released: usize,
) -> SphResult<()> {
    let n = track.points.len();
    if n < 4 {
        println!("nothing landed");
        return Ok(());
    }
    let half = n / 2;
    let ts: Vec<f64> = track.points[half..].iter().map(|p| p.0).collect();
    let (slope, _) = fit_line(&ts, &track.unwrapped[half..]);
    let steps: Vec<f64> = track.unwrapped[half..]
        .windows(2)
        .map(|w| w[1] - w[0])
        .collect();
    let sign = slope.signum();
    let back = steps.iter().filter(|d| **d * sign < 0.0).count();
    let radius = track.points[half..]
        .iter()
        .map(|p| ((p.1.x * p.1.x + p.1.z * p.1.z) as f64).sqrt())
        .sum::<f64>()
        / (n - half) as f64;
    let lay_y = track.points[half..]
        .iter()
        .map(|p| p.1.y as f64)
        .sum::<f64>()
        / (n - half) as f64;
    let rope: Vec<f64> = track
        .rope
        .iter()
        .filter(|r| r.0 >= ts[0])
        .map(|r| r.1)
        .collect();
    let u1 = if rope.is_empty() {
        a.speed as f64
    } else {
        rope.iter().sum::<f64>() / rope.len() as f64
    };
    let (q, nu, g) = (q as f64, a.nu as f64, 9.81);
    let a1 = (q / (std::f64::consts::PI * u1)).sqrt();
    let fall = h as f64 - lay_y;
    let (ov, og, oi) = (
        u1 / fall,
        (g * q.powi(3) / (nu * a1.powi(8))).powf(0.25),
        (q.powi(4) / (nu * a1.powi(10))).powf(1.0 / 3.0),
    );
    println!(
        "laying point over t in [{:.2}, {:.2}] s: azimuth turned {:.2} turns (fit {:.3} rad/s), \
         turned back in {back} of {} frames, mean radius {:.1} mm, mean height {:.1} mm",
        ts[0],
        ts[ts.len() - 1],
        (track.unwrapped[n - 1] - track.unwrapped[half]) / std::f64::consts::TAU,
        slope,
        steps.len(),
        radius * 1e3,
        lay_y * 1e3
    );
    println!(
        "rope where it lands: U1 = {u1:.3} m/s, a1 = {:.2} mm (from Q), fall H = {:.1} mm",
        a1 * 1e3,
        fall * 1e3
    );
    println!(
        "laws: Ω_V = U1/H = {ov:.2}, Ω_G = {og:.2}, Ω_I = {oi:.2} rad/s; (Ω_G/Ω_V)⁴ = {:.3}, \
         (Ω_I/Ω_V)³ = {:.3}; measured |Ω|/Ω_V = {:.3}",
        (og / ov).powi(4),
        (oi / ov).powi(3),
        slope.abs() / ov
    );
    println!(
        "rope at half height (last frame): radius {:.2} mm (nozzle {:.2} mm), its centre {:.1} mm \
         off the axis; {released} particles released by the nozzle, {} in the scene",
        track.radius * 1e3,
        a.radius * a.spacing * 1e3,
        track.offset * 1e3,
        world.fluids[fh].len()
    );
    Ok(())
}

/// Least-squares line `y = a t + b`; returns `(a, b)`.
fn fit_line(t: &[f64], y: &[f64]) -> (f64, f64) {
    let n = t.len() as f64;
    let (mt, my) = (t.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let stt: f64 = t.iter().map(|t| (t - mt) * (t - mt)).sum();
    let sty: f64 = t.iter().zip(y).map(|(t, y)| (t - mt) * (y - my)).sum();
    let a = if stt > 0.0 { sty / stt } else { 0.0 };
    (a, my - a * mt)
}
