//! The game pool ([`WavePool`]): a closed pool with a floating hull and a wave paddle.

use super::{add_closed_box, lattice_spacing};
use crate::error::{SphError, SphResult};
use crate::fluid::{Fluid, FluidHandle};
use crate::math::{Real, Vector};
use crate::params::FluidParams;
use crate::world::FluidWorld;
use rapier3d::prelude::{ActiveEvents, ColliderBuilder, RigidBodyBuilder, RigidBodyHandle};

/// The game pool ([`WavePool`]): a closed pool 2.0 × 0.8 × 0.7 m (inside), water 0.45 m
/// deep, a 40 × 10 × 24 cm hull floating in it and a kinematic paddle at its −x end that
/// swings back and forth (a wave maker). The game benchmark (`cargo bench --bench game`) and
/// the boat example (`cargo run --release --example boat`) run it.
#[derive(Clone, Debug)]
pub struct WavePoolConfig {
    /// About how many particles of water (the largest spacing whose lattice holds at least
    /// this many is taken).
    pub particles: usize,
    /// The water's parameters at a given spacing (default: the water preset, DFSPH).
    pub params: fn(Real) -> SphResult<FluidParams>,
    /// The hull's density (kg/m³; default 500: it floats half under).
    pub hull_density: Real,
    /// The paddle's stroke: it moves `amplitude` m each way every `period` s (default 8 cm,
    /// 1.5 s); an amplitude of 0 keeps it still.
    pub paddle: (Real, Real),
    /// Whether the hull's collider asks for the fluid's force on it
    /// (`ActiveEvents::CONTACT_FORCE_EVENTS`, read with `FluidPipeline::body_force`; default
    /// off: the benchmark measures the pool alone).
    pub watch_hull: bool,
}

impl Default for WavePoolConfig {
    fn default() -> Self {
        Self {
            particles: 10_000,
            params: |s| crate::params::FluidParamsBuilder::water(s).build(),
            hull_density: 500.0,
            paddle: (0.08, 1.5),
            watch_hull: false,
        }
    }
}

/// The game pool (see [`WavePoolConfig`]), stepped one 1/60 s frame at a time as a game
/// steps it.
pub struct WavePool {
    /// The rapier world, the water and the pipeline.
    pub world: FluidWorld,
    /// The water.
    pub water: FluidHandle,
    /// The floating hull (dynamic).
    pub hull: RigidBodyHandle,
    /// The paddle (kinematic, position-based).
    pub paddle: RigidBodyHandle,
    /// The particle spacing taken (m).
    pub spacing: Real,
    config: WavePoolConfig,
    frames: usize,
}

impl WavePool {
    /// Inside of the pool, from the origin.
    pub const SIZE: Vector = Vector::new(2.0, 0.8, 0.7);
    /// Depth of the water at rest (m).
    pub const DEPTH: Real = 0.45;
    /// Half extents of the hull (m).
    pub const HULL_HALF: Vector = Vector::new(0.2, 0.05, 0.12);
    /// The paddle's rest position along x (its plate is 2 cm thick).
    pub const PADDLE_X: Real = 0.15;

    /// Builds the pool, the water at rest (the water the hull displaces cut out), the hull
    /// at its expected draft.
    ///
    /// # Errors
    /// The parameters' errors, and [`SphError::InvalidParameter`] naming `particles` (0 or
    /// more than the fluid can hold) or `hull_density` (not positive and finite).
    pub fn new(config: WavePoolConfig) -> SphResult<Self> {
        if !(config.hull_density > 0.0 && config.hull_density.is_finite()) {
            return Err(SphError::InvalidParameter {
                field: "hull_density",
                value: config.hull_density as f64,
                reason: "must be positive and finite",
            });
        }
        let behind_paddle = Self::PADDLE_X + 0.02;
        let water = Vector::new(Self::SIZE.x - behind_paddle, Self::DEPTH, Self::SIZE.z);
        let spacing = lattice_spacing(water, config.particles)?;
        let params = (config.params)(spacing)?;
        let rest_density = params.rest_density;
        let mut world = FluidWorld::new();
        add_closed_box(&mut world, Vector::ZERO, Self::SIZE, 0.04);
        let (z, h) = (0.5 * Self::SIZE.z, Self::HULL_HALF);
        let paddle = world.physics.insert_body(
            RigidBodyBuilder::kinematic_position_based().translation(Vector::new(
                Self::PADDLE_X,
                0.4,
                z,
            )),
        );
        world
            .physics
            .insert_collider(ColliderBuilder::cuboid(0.01, 0.38, z - 0.01), Some(paddle));
        // Its bottom at the expected draft under the water's level.
        let draft = 2.0 * h.y * config.hull_density / rest_density;
        let hull_center = Vector::new(1.3, Self::DEPTH - draft + h.y, z);
        let hull = world
            .physics
            .insert_body(RigidBodyBuilder::dynamic().translation(hull_center));
        let mut hull_collider = ColliderBuilder::cuboid(h.x, h.y, h.z).density(config.hull_density);
        if config.watch_hull {
            hull_collider = hull_collider.active_events(ActiveEvents::CONTACT_FORCE_EVENTS);
        }
        world.physics.insert_collider(hull_collider, Some(hull));
        let mut fluid = Fluid::new(params)?;
        fluid.add_block(Vector::new(behind_paddle, 0.0, 0.0), water)?;
        let (lo, hi) = (hull_center - h, hull_center + h);
        let margin = 0.5 * spacing;
        fluid.remove_particles_where(|x, _, _| {
            x.x > lo.x - margin
                && x.x < hi.x + margin
                && x.z > lo.z - margin
                && x.z < hi.z + margin
                && x.y > lo.y - margin
        });
        let water = world.fluids.insert(fluid);
        Ok(Self {
            world,
            water,
            hull,
            paddle,
            spacing,
            config,
            frames: 0,
        })
    }

    /// One 1/60 s frame: the paddle's target for the frame's end, rapier's step, then the
    /// fluid's. Returns the time rapier's step took.
    ///
    /// # Errors
    /// [`crate::FluidPipeline::step`]'s.
    pub fn frame(&mut self) -> SphResult<std::time::Duration> {
        let dt = 1.0 / 60.0;
        self.frames += 1;
        let (amplitude, period) = self.config.paddle;
        if amplitude != 0.0 {
            let phase = std::f32::consts::TAU * self.frames as Real * dt / period;
            let x = Self::PADDLE_X + amplitude * phase.sin();
            self.world.physics.bodies[self.paddle].set_next_kinematic_translation(Vector::new(
                x,
                0.4,
                0.5 * Self::SIZE.z,
            ));
        }
        self.world.physics.integration_parameters.dt = dt;
        let start = std::time::Instant::now();
        self.world.physics.step();
        let rapier = start.elapsed();
        self.world.step_fluids()?;
        Ok(rapier)
    }

    /// The pool without its hull: removes the hull from rapier and puts back the water it
    /// displaced (the pool's block of water behind the paddle, on the same lattice, at rest).
    /// Afterwards [`Self::water_level`] and [`Self::draft_ratio`] have no hull to read and
    /// must not be called. Used to tell the water's own behaviour from the hull's (the
    /// sleeping-water measurements in `docs/performance.md`).
    ///
    /// # Errors
    /// [`Fluid::new`]'s and [`Fluid::add_block`]'s.
    pub fn remove_hull(&mut self) -> SphResult<()> {
        self.world.physics.remove_body(self.hull);
        let mut water = Fluid::new(self.world.fluids[self.water].params().clone())?;
        let behind_paddle = Self::PADDLE_X + 0.02;
        let size = Vector::new(Self::SIZE.x - behind_paddle, Self::DEPTH, Self::SIZE.z);
        water.add_block(Vector::new(behind_paddle, 0.0, 0.0), size)?;
        self.world.fluids.remove(self.water)?;
        self.water = self.world.fluids.insert(water);
        Ok(())
    }

    /// Particles outside the pool's inside (through a wall, or over the paddle's top).
    pub fn outside(&self) -> usize {
        let f = &self.world.fluids[self.water];
        f.positions()
            .iter()
            .filter(|p| p.cmplt(Vector::ZERO).any() || p.cmpgt(Self::SIZE).any())
            .count()
    }

    /// The water's level: the median, over the columns of a grid of two spacings away from
    /// the hull and the paddle's stroke, of each column's highest particle (plus half a
    /// spacing). A median of column tops follows the mean level through waves, where the
    /// topmost particles would follow the crests.
    pub fn water_level(&self) -> Real {
        let f = &self.world.fluids[self.water];
        let hull = self.world.physics.bodies[self.hull].translation();
        let cell = 2.0 * self.spacing;
        let paddle_reach = Self::PADDLE_X + self.config.paddle.0.abs() + 0.1;
        let mut tops = std::collections::BTreeMap::<(i32, i32), Real>::new();
        for p in f.positions() {
            if (p.x - hull.x).abs() < 0.4 || p.x < paddle_reach {
                continue;
            }
            let top = tops
                .entry(((p.x / cell) as i32, (p.z / cell) as i32))
                .or_insert(Real::MIN);
            *top = top.max(p.y);
        }
        let mut tops: Vec<Real> = tops.into_values().collect();
        if tops.is_empty() {
            return Real::NAN;
        }
        tops.sort_by(|a, b| a.total_cmp(b));
        tops[tops.len() / 2] + 0.5 * self.spacing
    }

    /// How deep the hull's lowest point lies under the water's level, over its expected
    /// draft (density ratio × height): 1 is Archimedes' answer.
    pub fn draft_ratio(&self) -> Real {
        let pose = self.world.physics.bodies[self.hull].position();
        let h = Self::HULL_HALF;
        let bottom = (0..8)
            .map(|c| {
                let sign = |b: usize| if c & b == 0 { -1.0 } else { 1.0 };
                pose.transform_point(Vector::new(sign(1) * h.x, sign(2) * h.y, sign(4) * h.z))
                    .y
            })
            .fold(Real::MAX, Real::min);
        let rest_density = self.world.fluids[self.water].params().rest_density;
        let expected = 2.0 * h.y * self.config.hull_density / rest_density;
        (self.water_level() - bottom) / expected
    }

    /// The hull's roll (about the pool's long axis x) and pitch (about z), in degrees.
    pub fn roll_pitch(&self) -> (Real, Real) {
        let r = self.world.physics.bodies[self.hull].rotation();
        let up = *r * Vector::Y;
        (
            up.z.atan2(up.y).to_degrees(),
            (-up.x).atan2(up.y).to_degrees(),
        )
    }
}
