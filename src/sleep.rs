//! Sleeping fluids: water at rest costs (almost) nothing, as rapier's sleeping islands do
//! for bodies (Box2D's and Jolt's sleeping, Bullet's deactivation).
//!
//! A fluid whose [`crate::FluidParams::sleep`] is set falls asleep once, for
//! [`Sleep::time`] seconds of consecutive frames, its water stayed where it was (the
//! particles' displacements averaged over cubic cells of one kernel support, their
//! root-mean-square below [`Sleep::mean_drift`] spacings, and every particle's own below
//! [`Sleep::max_drift`]), its mean density error below [`Sleep::density_error`], and every
//! non-fixed body near it stayed within [`Sleep::max_drift`] spacings too. Displacements,
//! not speeds: SPH water at rest jitters in place (DFSPH's at about 3 cm/s, see
//! docs/performance.md), and a hull floating on it rocks with it, but neither goes anywhere.
//! Averaged over cells, because that jitter moves the particles past each other below the
//! kernel's resolution while the water they make up stays put; a current moves a cell's
//! particles together and is not averaged away. Falling asleep sets its
//! particles' velocities to zero (the kinetic energy dropped is recorded:
//! [`SleepInfo::dropped_kinetic_energy`]) and puts the dynamic bodies near it to sleep in
//! rapier (`RigidBody::sleep`): the fluid and the bodies floating in it form one island, and
//! a floating hull stays where its buoyancy held it. A body near it that moves (woken by the
//! game, by rapier's contacts, or never asleep) wakes it.
//!
//! A sleeping fluid is not stepped: no neighbour search, no solver, no contact; its
//! particles stay bitwise where they are, its queries, its watched colliders' forces and its
//! contact events stay those of the last frame it was awake (a resting pool keeps pressing
//! on a pillar). Each frame costs a few checks of what could wake it, and it wakes (the
//! frame's substeps then run as usual) on any of:
//! - a non-fixed body near it moving (a kinematic paddle starting, a body falling in, a
//!   sleeping body woken by the game or by rapier), or any body teleported;
//! - a collider appearing, disappearing, moving or changing shape near it (a fixed gate
//!   removed, a collider inserted), or the watched colliders changing;
//! - gravity or the frame's length changing;
//! - the game editing the fluid: [`crate::Fluid::set_params`], adding, removing or filling
//!   particles, [`crate::Fluid::velocities_mut`], scalars, sinks, clearing, resetting, or
//!   [`crate::Fluid::wake_up`];
//! - an emitter emitting into it (its emitters run while it sleeps).
//!
//! A snapshot carries the sleep state: a restored sleeping pool sleeps on.
//!
//! A fluid stepped with others in one interaction group ([`crate::FluidParams::fluid_groups`])
//! does not sleep: its group stays awake.
//!
//! What it approximates: the velocities dropped at sleep (the jitter's kinetic energy, and
//! any current slower than the drift thresholds allow), the density error frozen at sleep
//! (at most [`Sleep::density_error`] on average); the water does not creep further while
//! asleep. The window's start positions are kept as three attributes of the fluid's
//! particles (12 bytes a particle, only for a fluid that may sleep). Leave [`crate::FluidParams::sleep`] at `None`
//! (the presets' default) for exact results. docs/performance.md has the measured costs and
//! errors.

use crate::error::{SphError, SphResult};
use crate::math::{Real, Vector};

/// When a fluid may fall asleep (see [`crate::sleep`]): every threshold must hold for
/// [`Sleep::time`] seconds.
///
/// # Examples
/// ```
/// use rapier_sph::prelude::*;
/// let params = FluidParamsBuilder::water(0.04).sleep(Sleep::default()).build()?;
/// assert_eq!(params.sleep, Some(Sleep::default()));
/// let mut bad = Sleep::default();
/// bad.time = -1.0;
/// assert!(FluidParamsBuilder::water(0.04).sleep(bad).build().is_err()); // names `sleep.time`
/// # Ok::<(), SphError>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub struct Sleep {
    /// Seconds the fluid must stay at rest before it falls asleep: the window over which
    /// the particles' displacements are measured. Default: 0.5.
    pub time: Real,
    /// Largest root-mean-square displacement of the water over [`Sleep::time`] that still
    /// counts as at rest, in particle spacings: each particle's displacement averaged with
    /// those of the particles whose window-start positions share its cubic cell of one
    /// kernel support ([`crate::FluidParams::smoothing_length`]), so that the particles'
    /// own jitter, which moves them past each other, averages out and a current does
    /// not. Default: 0.1 (a current of `0.1·spacing/time`, 6 mm/s at 3 cm and 0.5 s, keeps
    /// the water awake; the game preset's still 10,368-particle pool's cells drift 0.06–0.11
    /// spacings per 0.5 s from 12 to 20 s, its particles 0.11–0.17, see
    /// docs/performance.md).
    pub mean_drift: Real,
    /// Largest displacement over [`Sleep::time`] of any particle, and of any point of a
    /// non-fixed body near the fluid (its center of mass's displacement plus its turn times
    /// its reach), that still counts as at rest, in particle spacings. Default: 1.
    pub max_drift: Real,
    /// Largest mean density error `(ρ − ρ0)/ρ0` (averaged over the particles, the largest
    /// of a frame's substeps) that still counts as at rest (a fraction). Default: 0.01.
    pub density_error: Real,
}

impl Default for Sleep {
    fn default() -> Self {
        Self {
            time: 0.5,
            mean_drift: 0.1,
            max_drift: 1.0,
            density_error: 0.01,
        }
    }
}

impl Sleep {
    /// Checks the thresholds.
    ///
    /// # Errors
    /// [`SphError::InvalidParameter`] naming the field (`sleep.time`, `sleep.mean_drift`,
    /// …) when one is negative or not finite.
    pub fn validate(&self) -> SphResult<()> {
        let fields = [
            ("sleep.time", self.time),
            ("sleep.mean_drift", self.mean_drift),
            ("sleep.max_drift", self.max_drift),
            ("sleep.density_error", self.density_error),
        ];
        for (field, v) in fields {
            if !v.is_finite() || v < 0.0 {
                return Err(SphError::InvalidParameter {
                    field,
                    value: v as f64,
                    reason: "must be finite and non-negative",
                });
            }
        }
        Ok(())
    }
}

/// What a fluid's sleeping did (see [`crate::Fluid::sleep_info`]).
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub struct SleepInfo {
    /// Whether the fluid sleeps.
    pub asleep: bool,
    /// Seconds it has been at rest while awake (0 while it moves).
    pub quiet_time: Real,
    /// Kinetic energy (J) its particles had when they were stopped at its last falling
    /// asleep.
    pub dropped_kinetic_energy: f64,
    /// The fastest of those particles (m/s).
    pub dropped_max_speed: Real,
    /// Its mean density error when it last fell asleep (a fraction).
    pub density_error_at_sleep: Real,
    /// Times it fell asleep.
    pub times_asleep: u64,
}

/// A fluid's sleep state (on the fluid, saved in snapshots).
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub(crate) struct SleepState {
    pub info: SleepInfo,
    /// Gravity and frame length it fell asleep under.
    pub gravity: Vector,
    pub dt: Real,
    /// The particles' bounding box while asleep (they do not move).
    pub bounds: (Vector, Vector),
    /// Fingerprint of the colliders near the fluid when it fell asleep.
    pub colliders: u64,
    /// Watched colliders when it fell asleep.
    pub watched: u64,
    /// The non-fixed bodies near the fluid at the start of the sleep test's window: their
    /// centers of mass and orientations.
    pub bodies: Vec<(
        rapier3d::dynamics::RigidBodyHandle,
        Vector,
        crate::math::Rotation,
    )>,
}

impl SleepState {
    /// Wakes the fluid (and restarts its quiet time).
    #[inline]
    pub fn wake(&mut self) {
        self.info.asleep = false;
        self.info.quiet_time = 0.0;
    }

    pub fn asleep(&self) -> bool {
        self.info.asleep
    }

    /// Every stored number finite (snapshots).
    #[cfg_attr(not(feature = "snapshot"), allow(dead_code))]
    pub fn is_finite(&self) -> bool {
        let i = &self.info;
        crate::math::is_finite(self.gravity)
            && crate::math::is_finite(self.bounds.0)
            && crate::math::is_finite(self.bounds.1)
            && self.dt.is_finite()
            && i.quiet_time.is_finite()
            && i.dropped_kinetic_energy.is_finite()
            && i.dropped_max_speed.is_finite()
            && i.density_error_at_sleep.is_finite()
            && self
                .bodies
                .iter()
                .all(|b| crate::math::is_finite(b.1) && b.2.is_finite())
    }

    pub fn public(&self) -> SleepInfo {
        self.info
    }
}
