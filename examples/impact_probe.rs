//! What the Lobovský sensor's impact peak is made of: the scene of
//! `rapier_sph::validation::lobovsky` (the report's set-up), sensor 2 (15 mm) read every frame
//! (default 0.5 ms, four times the report's sampling) over 2.2 ≤ T ≤ 3.2, with the particles
//! in the sensor's support (count, their highest and lowest pressure, the nearest one's
//! distance in spacings), the mean pressure of the wall layer below 5 cm, the substeps and the
//! highest particle. Beside the report's sensor (`wall`: the fluid's pressure extrapolated to the
//! wall, `validation::lobovsky::WallSensor`), the Shepard average of the particles' pressures
//! at the same point (`point`, the report's sensor before), the wall reading averaged over a face one spacing across
//! (`disc`), and what the wall receives: the
//! downstream wall's horizontal force per unit width (`F/w`, the crate's collider force,
//! `FluidPipeline::collider_force`) against the wall reading integrated over the wall's
//! height (`∫p dy`, the sensor read every quarter spacing up the wall's centre line), both in
//! `ρ0·g·H²`. A frame caps the step (DFSPH takes about 1.7 ms in the report at N = 15,
//! one step per 2 ms sample; here at most 0.5 ms). Pressures as `p/(ρ0·g·H)`; the last line is
//! the highest particle over the whole run (to T = 4.5).
//!
//! ```text
//! cargo run --release --example impact_probe -- SOLVER N FRAME_S [on|off]
//! cargo run --release --example impact_probe -- DFSPH 15 0.0005
//! cargo run --release --example impact_probe -- WCSPH 15 0.0005 on   # wall density on
//! cargo run --release --example impact_probe -- WCSPH-A 15 0.0005     # WCSPH, Adami's walls
//! cargo run --release --example impact_probe -- WCSPH-D 15 0.0005     # and δ-SPH densities
//! ```
//! `SOLVER` is a name of `validation::methods()` (WCSPH, DFSPH, PBF, Clavet), `WCSPH-A`
//! (WCSPH with wall density and `WcsphPressure::Adami`) or `WCSPH-D` (`WCSPH-A` with its
//! densities from the continuity equation with δ-SPH diffusion, `WcsphDensity::DELTA_SPH`),
//! `N` the particles across H (`WCSPH-D=δ` sets the diffusion coefficient, 0.1 without it);
//! the last argument overrides the method's wall density.
use rapier_sph::math::{Real, Vector};
use rapier_sph::rapier3d::prelude::ActiveEvents;
use rapier_sph::scenes::add_closed_box;
use rapier_sph::validation::lobovsky::{
    COLUMN_LENGTH, H, TANK_HEIGHT, TANK_LENGTH, downstream_sensor, probe,
};
use rapier_sph::validation::{dam_break::LAYERS, methods};
use rapier_sph::{Fluid, FluidParamsBuilder, FluidWorld, fluid::try_lattice};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let solver = a.get(1).map(String::as_str).unwrap_or("WCSPH");
    let n: usize = a.get(2).and_then(|s| s.parse().ok()).unwrap_or(15);
    let frame: Real = a.get(3).and_then(|s| s.parse().ok()).unwrap_or(0.0005);
    // `WCSPH-D=δ` sets the diffusion coefficient (0.1 without it).
    let (solver, delta) = match solver.split_once('=') {
        Some((s, d)) => (s, d.parse().expect("WCSPH-D=δ")),
        None => (solver, 0.1),
    };
    let adami = solver == "WCSPH-A" || solver == "WCSPH-D";
    let name = if adami { "WCSPH" } else { solver };
    let mut m = methods().into_iter().find(|m| m.name == name).unwrap();
    if adami {
        m.wall_density = true;
        m.wcsph_pressure = rapier_sph::WcsphPressure::Adami;
    }
    if solver == "WCSPH-D" {
        m.wcsph_density = rapier_sph::WcsphDensity::Continuity { delta };
    }
    if let Some(w) = a.get(4) {
        m.wall_density = w == "on";
    }
    let params = FluidParamsBuilder::water(H / n as Real)
        .solver(m.solver)
        .wall_density(m.wall_density)
        .wcsph_pressure(m.wcsph_pressure)
        .wcsph_density(m.wcsph_density)
        .build()
        .unwrap();
    let s = params.particle_spacing;
    let h = params.smoothing_length;
    let max = Vector::new(TANK_LENGTH, TANK_HEIGHT, LAYERS as Real * s);
    let mut world = FluidWorld::new();
    add_closed_box(&mut world, Vector::ZERO, max, (4.0 * s).max(0.05));
    world.physics.step();
    // Watch the downstream wall (the collider beyond x = TANK_LENGTH) for its force.
    let wall = world
        .physics
        .colliders
        .iter_mut()
        .find(|(_, c)| c.translation().x > TANK_LENGTH)
        .map(|(h, c)| {
            c.set_active_events(ActiveEvents::CONTACT_FORCE_EVENTS);
            h
        })
        .unwrap();
    let mut fluid = Fluid::new(params.clone()).unwrap();
    let nx = (COLUMN_LENGTH / s).round() as usize;
    fluid
        .add_particles(&try_lattice(Vector::splat(0.5 * s), nx, n, LAYERS, s).unwrap())
        .unwrap();
    let fh = world.fluids.insert(fluid);
    world.physics.integration_parameters.dt = frame;
    let g = 9.81f64;
    let scale = (g / H as f64).sqrt();
    let p_ref = 1000.0 * g * H as f64;
    let sensor = Vector::new(TANK_LENGTH, 0.015, 0.5 * max.z);
    let mut t = 0.0f64;
    let mut ymax_all: Real = 0.0;
    while t * scale < 4.5 {
        let r = world.step_fluids().unwrap().clone();
        t += frame as f64;
        let f = &world.fluids[fh];
        let ymax = f.positions().iter().map(|p| p.y).fold(0.0, Real::max);
        ymax_all = ymax_all.max(ymax);
        let tt = t * scale;
        if !(2.2..=3.2).contains(&tt) {
            continue;
        }
        let gravity = world.physics.gravity;
        let p_wall = downstream_sensor(0.015, max.z).read(f, gravity, Vector::ZERO) as f64 / p_ref;
        let p = probe(f, sensor) as f64 / p_ref;
        // The same reading averaged over a face one spacing across.
        let face = rapier_sph::validation::lobovsky::WallSensor {
            radius: 0.5 * s,
            ..downstream_sensor(0.015, max.z)
        };
        let p_disc = face.read(f, gravity, Vector::ZERO) as f64 / p_ref;
        // What the wall receives, per unit width, against the wall reading integrated up it.
        let force = world.pipeline.collider_force(wall).unwrap().force.x as f64;
        let dy = 0.25 * s;
        let integral: f64 = (0..(TANK_HEIGHT / dy).round() as usize)
            .map(|k| {
                downstream_sensor((k as Real + 0.5) * dy, max.z).read(f, gravity, Vector::ZERO)
                    as f64
                    * dy as f64
            })
            .sum();
        let unit = p_ref * H as f64;
        let (f_w, int_p) = (force / max.z as f64 / unit, integral / unit);
        // Particles in the sensor's support: count, their max and min pressure, nearest.
        let (mut cnt, mut pmax, mut pmin, mut dmin) = (0, f64::MIN, f64::MAX, Real::MAX);
        for (x, &pp) in f.positions().iter().zip(f.pressures()) {
            let d = (*x - sensor).length();
            if d < h {
                cnt += 1;
                pmax = pmax.max(pp as f64 / p_ref);
                pmin = pmin.min(pp as f64 / p_ref);
                dmin = dmin.min(d);
            }
        }
        // Mean pressure of particles within one spacing of the downstream wall, below 0.05 m.
        let (mut sw, mut nw) = (0.0, 0);
        for (x, &pp) in f.positions().iter().zip(f.pressures()) {
            if x.x > TANK_LENGTH - s && x.y < 0.05 {
                sw += pp as f64 / p_ref;
                nw += 1;
            }
        }
        println!(
            "{tt:.4} wall={p_wall:.3} disc={p_disc:.3} point={p:.3} F/w={f_w:.4} int_p={int_p:.4} n={cnt} pmax={pmax:.3} pmin={pmin:.3} dmin/s={:.2} wall_mean={:.3} nw={nw} substeps={} ymax={ymax:.3}",
            dmin / s,
            if nw > 0 { sw / nw as f64 } else { 0.0 },
            r.substeps
        );
    }
    println!("max height over run {ymax_all:.4} (H = {H})");
}
