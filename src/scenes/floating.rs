//! A box floating in a closed tank ([`FloatingBox`]): the buoyancy tests' and example's scene,
//! and how deep a box lies in the water ([`submerged_fraction`]).

use super::add_closed_box;
use crate::error::{SphError, SphResult};
use crate::fluid::{Fluid, FluidHandle, try_lattice};
use crate::math::{Real, Vector};
use crate::world::FluidWorld;
use rapier3d::prelude::{ColliderBuilder, Pose, RigidBodyBuilder};

/// A floating box (the buoyancy test and example): a closed tank `tank` wide holding `depth`
/// of water (walls counting in the density) and a dynamic box placed at its expected floating
/// depth (a box denser than water: its top at the surface), its bottom face moved to the
/// nearest boundary between particle layers, the water cut out around it.
#[derive(Clone, Debug)]
pub struct FloatingBoxConfig {
    /// Particle spacing (m) of the water preset.
    pub spacing: Real,
    /// Inner width and length of the tank (m).
    pub tank: Real,
    /// Water depth (m), filled in whole particle layers: `⌊depth/spacing⌋·spacing` (0.28 m
    /// for 0.3 m at 4 cm), against which the box is placed.
    pub depth: Real,
    /// Half width (x and z) of the box (m).
    pub half_width: Real,
    /// Half height of the box (m).
    pub half_height: Real,
    /// Density of the box (kg/m³).
    pub density: Real,
    /// The water's solver.
    pub solver: crate::Solver,
}

/// The scene of [`FloatingBoxConfig`], built.
pub struct FloatingBox {
    /// The world (60 Hz frames).
    pub world: FluidWorld,
    /// The water.
    pub fluid: FluidHandle,
    /// The box.
    pub body: rapier3d::dynamics::RigidBodyHandle,
    /// The configuration it was built from.
    pub config: FloatingBoxConfig,
}

/// What a floating box did over the last second of [`FloatingBox::run`].
#[derive(Copy, Clone, Debug)]
pub struct Floating {
    /// Mean submerged fraction of the box's volume (water surface measured away from the box).
    pub submerged: Real,
    /// Lowest and highest submerged fraction.
    pub range: (Real, Real),
    /// RMS acceleration of the box's corners (m/s²), from its poses frame to frame:
    /// translation plus rotation (`α × r`).
    pub shaking: Real,
    /// RMS speed of the box's corners (m/s), from its poses frame to frame.
    pub speed: Real,
    /// RMS speed of the water within two spacings of the box (m/s).
    pub water: Real,
    /// Height of the box's lowest corner at the end (m; the tank's floor is at 0).
    pub bottom: Real,
}

/// Fraction of the volume of the box of half extents `half` at `pose` below the height
/// `surface`: the box cut into 32 × 32 columns along its own y axis, each column's fraction
/// below the surface exact (height is linear along it). Exact for an upright box, and right
/// for a tilted one too.
pub fn submerged_fraction(pose: &rapier3d::math::Pose, half: Vector, surface: Real) -> Real {
    const N: usize = 32;
    let mut sum = 0.0;
    for i in 0..N {
        for k in 0..N {
            let u = (i as Real + 0.5) / N as Real * 2.0 - 1.0;
            let w = (k as Real + 0.5) / N as Real * 2.0 - 1.0;
            let y0 = pose
                .transform_point(Vector::new(u * half.x, -half.y, w * half.z))
                .y;
            let y1 = pose
                .transform_point(Vector::new(u * half.x, half.y, w * half.z))
                .y;
            let (lo, hi) = (y0.min(y1), y0.max(y1));
            sum += if hi - lo < 1e-9 {
                (lo < surface) as u8 as Real
            } else {
                ((surface - lo) / (hi - lo)).clamp(0.0, 1.0)
            };
        }
    }
    sum / (N * N) as Real
}

impl FloatingBox {
    /// Builds the tank, the water and the box.
    pub fn new(config: FloatingBoxConfig) -> SphResult<Self> {
        let c = &config;
        for (field, v) in [
            ("tank", c.tank),
            ("depth", c.depth),
            ("half_width", c.half_width),
            ("half_height", c.half_height),
            ("density", c.density),
        ] {
            if !(v > 0.0 && v.is_finite()) {
                return Err(SphError::InvalidParameter {
                    field,
                    value: v as f64,
                    reason: "must be positive and finite",
                });
            }
        }
        let (s, tank, depth) = (c.spacing, c.tank, c.depth);
        let (hw, hh) = (c.half_width, c.half_height);
        let params = crate::FluidParamsBuilder::water(s)
            .wall_density(true)
            .solver(c.solver)
            .build()?;
        let mut world = FluidWorld::new();
        world.physics.integration_parameters.dt = 1.0 / 60.0;
        let top = depth + 2.0 * hh + 0.1;
        add_closed_box(&mut world, Vector::ZERO, Vector::new(tank, top, tank), 0.05);
        let mut fluid = Fluid::new(params)?;
        let mid = 0.5 * tank;
        let half = Vector::new(hw, hh, hw);
        // The water is whole layers (its surface `layers·s`, 0.28 m for 0.3 m at 4 cm), and the
        // box's bottom face lies on a boundary between them, so that the layer under it sits
        // half a spacing from it, as the water does from the tank's floor. Placed against the
        // nominal depth instead, a box released at the surface started over a void (2 cm at
        // 4 cm spacing) it fell through freely before it hit the layer under it (a 2,000
        // kg/m³ box at 0.6 m/s; the fluid gave 2 % of Archimedes' impulse over the first frame).
        let layers = (depth / s) as usize;
        let surface = layers as Real * s;
        let floating = surface + hh * (1.0 - 2.0 * c.density.min(1000.0) / 1000.0);
        let center = Vector::new(mid, ((floating - hh) / s).round() * s + hh, mid);
        let n = (tank / s) as usize;
        // Particles at least half a spacing from the box (round-off tolerated on the faces).
        let keep = 0.5 * s * (1.0 - 1e-3);
        let pts: Vec<Vector> = try_lattice(Vector::splat(0.5 * s), n, layers, n, s)?
            .into_iter()
            .filter(|p| ((*p - center).abs() - half - Vector::splat(keep)).max_element() > 0.0)
            .collect();
        fluid.add_particles(&pts)?;
        let fluid = world.fluids.insert(fluid);
        let body = world
            .physics
            .insert_body(RigidBodyBuilder::dynamic().translation(center));
        world.physics.insert_collider(
            ColliderBuilder::cuboid(hw, hh, hw).density(c.density),
            Some(body),
        );
        world.physics.step();
        Ok(Self {
            world,
            fluid,
            body,
            config,
        })
    }

    /// Height of the tank's lid (m): water depth, the box's height and 0.1 m of air.
    pub fn tank_height(&self) -> Real {
        self.config.depth + 2.0 * self.config.half_height + 0.1
    }

    /// Runs `seconds` of 60 Hz frames, calling `each_frame(frame, world)` after every frame,
    /// and measures the last second.
    pub fn run(
        &mut self,
        seconds: Real,
        mut each_frame: impl FnMut(usize, &FluidWorld) -> SphResult<()>,
    ) -> SphResult<Floating> {
        let frames = (seconds * 60.0) as usize;
        let (mut sum, mut lo, mut hi, mut count) = (0.0, Real::MAX, Real::MIN, 0);
        let mut poses = Vec::new();
        let mut water = 0.0f64;
        for frame in 0..frames {
            self.world.step()?;
            each_frame(frame, &self.world)?;
            if frame + 62 < frames {
                continue;
            }
            let pose = *self.world.physics.bodies[self.body].position();
            poses.push(pose);
            if frame + 60 < frames {
                continue;
            }
            water += self.water_speed_squared(&pose);
            let frac = submerged_fraction(&pose, self.half_extents(), self.water_surface());
            sum += frac;
            count += 1;
            lo = lo.min(frac);
            hi = hi.max(frac);
        }
        if poses.len() < 3 {
            return Err(SphError::InvalidParameter {
                field: "seconds",
                value: seconds as f64,
                reason: "the measurement needs at least the last second plus two frames",
            });
        }
        let (shaking, speed) = self.motion(&poses);
        Ok(Floating {
            submerged: sum / count as Real,
            range: (lo, hi),
            shaking,
            speed,
            water: (water / count as f64).sqrt() as Real,
            bottom: self.lowest_corner(),
        })
    }

    fn half_extents(&self) -> Vector {
        let (hw, hh) = (self.config.half_width, self.config.half_height);
        Vector::new(hw, hh, hw)
    }

    /// Mean squared speed of the water within two spacings of the box.
    fn water_speed_squared(&self, pose: &Pose) -> f64 {
        let (s, half) = (self.config.spacing, self.half_extents());
        let f = &self.world.fluids[self.fluid];
        let (mut w2, mut wn) = (0.0f64, 0usize);
        for (x, v) in f.positions().iter().zip(f.velocities()) {
            let l = pose.inverse_transform_point(*x).abs() - half;
            if l.max_element() < 2.0 * s {
                w2 += v.length_squared() as f64;
                wn += 1;
            }
        }
        w2 / wn.max(1) as f64
    }

    /// Water surface: mean height of the topmost 5 % of the particles more than two
    /// spacings away from the box (particle centers sit half a spacing under it).
    fn water_surface(&self) -> Real {
        let (s, mid, hw) = (
            self.config.spacing,
            0.5 * self.config.tank,
            self.config.half_width,
        );
        let f = &self.world.fluids[self.fluid];
        let mut tops: Vec<Real> = f
            .positions()
            .iter()
            .filter(|p| (p.x - mid).abs() > hw + 2.0 * s || (p.z - mid).abs() > hw + 2.0 * s)
            .map(|p| p.y)
            .collect();
        tops.sort_by(|a, b| b.total_cmp(a));
        let k = (tops.len() / 20).max(1);
        tops[..k].iter().sum::<Real>() / k as Real + 0.5 * s
    }

    /// RMS acceleration and RMS speed of the box's corners over `poses` (one per frame):
    /// frame-to-frame velocities (linear, angular) from the poses, then accelerations.
    fn motion(&self, poses: &[Pose]) -> (Real, Real) {
        let dt = 1.0 / 60.0;
        let corner = self.half_extents().length();
        let vel: Vec<(Vector, Vector)> = poses
            .windows(2)
            .map(|w| {
                (
                    (w[1].translation - w[0].translation) / dt,
                    (w[1].rotation * w[0].rotation.inverse()).to_scaled_axis() / dt,
                )
            })
            .collect();
        let (mut a2, mut v2) = (0.0f64, 0.0f64);
        for w in vel.windows(2) {
            let a = (w[1].0 - w[0].0).length() / dt;
            let alpha = (w[1].1 - w[0].1).length() / dt;
            a2 += ((a + alpha * corner) as f64).powi(2);
        }
        for (v, w) in &vel {
            v2 += ((v.length() + w.length() * corner) as f64).powi(2);
        }
        (
            (a2 / (vel.len() - 1) as f64).sqrt() as Real,
            (v2 / vel.len() as f64).sqrt() as Real,
        )
    }

    /// Height of the box's lowest corner now.
    fn lowest_corner(&self) -> Real {
        let (hw, hh) = (self.config.half_width, self.config.half_height);
        let pose = self.world.physics.bodies[self.body].position();
        let mut bottom = Real::MAX;
        for c in 0..8 {
            let sign = |b: usize| if c & b == 0 { -1.0 } else { 1.0 };
            let p = Vector::new(sign(1) * hw, sign(2) * hh, sign(4) * hw);
            bottom = bottom.min(pose.transform_point(p).y);
        }
        bottom
    }
}
