//! Emitters, sinks, fills and collider names, as written in a scene file.

use super::shapes::ShapeDesc;
use super::values::{NonNegative, Positive, Vec3};
use crate::emitter::{Attachment, Emitter, Nozzle, Region, Sink};
use crate::math::Real;
use rapier3d::geometry::{ColliderHandle, ColliderSet};
use serde::{Deserialize, Serialize};
use std::cell::RefCell;
use std::collections::BTreeSet;

/// An emitter's opening, as in [`Nozzle`]. Sizes must be positive.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum NozzleDesc {
    /// A disk across the emitter's direction.
    Disk {
        /// Radius (m).
        radius: Positive,
    },
    /// A square of side `2·half_width` across the emitter's direction.
    Square {
        /// Half the side (m).
        half_width: Positive,
    },
    /// A sphere emitting radially outward (the direction is not used).
    Sphere {
        /// Radius (m).
        radius: Positive,
    },
}

impl From<&NozzleDesc> for Nozzle {
    fn from(n: &NozzleDesc) -> Self {
        match n {
            NozzleDesc::Disk { radius } => Nozzle::Disk { radius: radius.0 },
            NozzleDesc::Square { half_width } => Nozzle::Square {
                half_width: half_width.0,
            },
            NozzleDesc::Sphere { radius } => Nozzle::Sphere { radius: radius.0 },
        }
    }
}

/// An emitter ([`Emitter`]): every field of it. The rate is given either in particles per
/// second (`rate`) or as a fraction of the nozzle's blocking rate at the fluid's spacing
/// (`rate_fraction`, see [`Emitter::max_rate`]), which keeps the jet unblocked when the
/// spacing changes; exactly one of the two.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Emitter")]
pub struct EmitterDesc {
    /// The opening.
    pub nozzle: NozzleDesc,
    /// Center of the nozzle (m).
    pub position: Vec3,
    /// Direction of the jet (any length, not zero; not used by a sphere). Default `(0, -1, 0)`.
    #[serde(default = "default_direction")]
    pub direction: Vec3,
    /// Jet speed (m/s).
    pub speed: Positive,
    /// Particles per second.
    #[serde(default)]
    pub rate: Option<Positive>,
    /// Rate as a fraction of [`Emitter::max_rate`] at the fluid's spacing.
    #[serde(default)]
    pub rate_fraction: Option<Positive>,
    /// Emitter clock time (s) emission starts. Default 0.
    #[serde(default)]
    pub start: NonNegative,
    /// Emitter clock time (s) emission stops. Default: never.
    #[serde(default)]
    pub stop: Option<NonNegative>,
    /// Most particles emitted in total. Default: no limit.
    #[serde(default)]
    pub budget: Option<u64>,
    /// Off: its clock runs, nothing is emitted. Default `true`.
    #[serde(default = "yes")]
    pub enabled: bool,
    /// What carries the emitter ([`crate::Fluid::attach_emitter`]): its `position` and
    /// `direction` are then in the carrier's frame, and its particles leave with the
    /// carrier's velocity. Default: nothing (a fixed nozzle in the world's frame).
    #[serde(default)]
    pub attached_to: Option<AttachmentDesc>,
}

/// What carries an emitter ([`Attachment`]), named through a collider of the file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum AttachmentDesc {
    /// The collider named `name` ([`Attachment::Collider`]).
    Collider {
        /// The collider's name.
        name: ColliderRef,
    },
    /// The body that carries the collider named `collider` ([`Attachment::Body`]).
    Body {
        /// The name of one of the body's colliders.
        collider: ColliderRef,
    },
}

impl AttachmentDesc {
    /// The name of the collider it refers to.
    pub fn collider_name(&self) -> &str {
        match self {
            AttachmentDesc::Collider { name } => &name.0,
            AttachmentDesc::Body { collider } => &collider.0,
        }
    }

    /// The attachment, `collider` resolving the name to a collider of `colliders`.
    ///
    /// # Errors
    /// A message when the name is unknown or the collider has no body (for `Body`).
    pub fn attachment(
        &self,
        collider: impl Fn(&str) -> Option<ColliderHandle>,
        colliders: &ColliderSet,
    ) -> Result<Attachment, String> {
        let name = self.collider_name();
        let handle = collider(name).ok_or_else(|| format!("no collider is named `{name}`"))?;
        match self {
            AttachmentDesc::Collider { .. } => Ok(Attachment::Collider(handle)),
            AttachmentDesc::Body { .. } => colliders
                .get(handle)
                .and_then(|c| c.parent())
                .map(Attachment::Body)
                .ok_or_else(|| format!("the collider `{name}` is on no body")),
        }
    }
}

/// A volume filled with particles at rest on the fluid's lattice ([`crate::Fluid::fill_shape`]):
/// a named collider of the file (typically a sensor marking a pool's water) or a shape
/// given here.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum FillDesc {
    /// The shape and pose of the collider named `name` ([`crate::Fluid::fill_collider`]).
    Collider {
        /// The collider's name.
        name: ColliderRef,
    },
    /// A shape at a pose: the volume to fill, not a collider.
    Shape {
        /// The shape (bounded: not a half-space), checked as it is read.
        #[serde(deserialize_with = "super::values::checked")]
        shape: ShapeDesc,
        /// Position (m).
        #[serde(default)]
        position: Vec3,
        /// Rotation (rotation vector, rad).
        #[serde(default)]
        rotation: Vec3,
    },
}

fn default_direction() -> Vec3 {
    Vec3([0.0, -1.0, 0.0])
}
fn yes() -> bool {
    true
}

impl EmitterDesc {
    /// The emitter for a fluid of particle spacing `spacing` (m), validated (not yet
    /// attached: see [`AttachmentDesc::attachment`]).
    ///
    /// # Errors
    /// A message naming what is wrong: both or neither of `rate` and `rate_fraction`, or
    /// what [`Emitter::validate`] refuses.
    pub fn emitter(&self, spacing: Real) -> Result<Emitter, String> {
        let mut e = Emitter::new(
            (&self.nozzle).into(),
            self.position.vector(),
            self.direction.vector(),
            self.speed.0,
            // Replaced below; `rate_fraction` needs the slots, which need the emitter.
            1.0,
        );
        let rate = match (self.rate, self.rate_fraction) {
            (Some(_), Some(_)) => return Err("give `rate` or `rate_fraction`, not both".into()),
            (Some(r), None) => r.0,
            (None, Some(f)) => e.max_rate(spacing) * f.0,
            (None, None) => {
                return Err(
                    "missing `rate` (particles/s) or `rate_fraction` (of the blocking rate)".into(),
                );
            }
        };
        e.set_rate(rate).map_err(|e| e.to_string())?;
        e = e.active_between(self.start.0, self.stop.map_or(Real::INFINITY, |s| s.0));
        if let Some(b) = self.budget {
            e = e.budget(b);
        }
        e.set_enabled(self.enabled);
        e.validate().map_err(|e| e.to_string())?;
        Ok(e)
    }
}

impl super::values::Validate for EmitterDesc {
    fn validate(&self) -> Result<(), String> {
        // The crate's own validation (direction not zero, stop not before start, ...); the
        // spacing only scales `rate_fraction`, so any positive one will do here.
        self.emitter(1.0).map(|_| ())
    }
}

/// Where a sink removes particles, as in [`Region`] (`Collider` is [`Region::NearCollider`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum SinkRegionDesc {
    /// The box `[min, max]`.
    Aabb {
        /// Lower corner (m).
        min: Vec3,
        /// Upper corner (m), not below `min`.
        max: Vec3,
    },
    /// A ball.
    Ball {
        /// Center (m). The old spelling `centre` is still read.
        #[serde(alias = "centre")]
        center: Vec3,
        /// Radius (m).
        radius: Positive,
    },
    /// Inside the collider named `name` (a `name` of a `Collider` entry of the file), or
    /// within `reach` of its surface.
    Collider {
        /// The collider's name.
        name: ColliderRef,
        /// Distance from the surface that still drains (m). Default: one particle spacing.
        #[serde(default)]
        reach: Option<NonNegative>,
    },
}

/// A sink ([`Sink`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Sink")]
pub struct SinkDesc {
    /// The region.
    pub region: SinkRegionDesc,
    /// Off: removes nothing. Default `true`.
    #[serde(default = "yes")]
    pub enabled: bool,
}

impl SinkDesc {
    /// The sink, validated; `collider` resolves a collider name to its handle.
    ///
    /// # Errors
    /// A message when a collider name is unknown or [`Sink::validate`] refuses the sink.
    pub fn sink(&self, collider: impl Fn(&str) -> Option<ColliderHandle>) -> Result<Sink, String> {
        let region = match &self.region {
            SinkRegionDesc::Aabb { min, max } => Region::Aabb {
                min: min.vector(),
                max: max.vector(),
            },
            SinkRegionDesc::Ball { center, radius } => Region::Ball {
                center: center.vector(),
                radius: radius.0,
            },
            SinkRegionDesc::Collider { name, reach } => Region::NearCollider {
                handle: collider(&name.0)
                    .ok_or_else(|| format!("no collider is named `{}`", name.0))?,
                reach: reach.map(|r| r.0),
            },
        };
        let mut sink = Sink::new(region);
        sink.set_enabled(self.enabled);
        sink.validate().map_err(|e| e.to_string())?;
        Ok(sink)
    }
}

impl super::values::Validate for SinkDesc {
    fn validate(&self) -> Result<(), String> {
        // Names are resolved when the whole file has been read; a placeholder handle here.
        self.sink(|_| Some(rapier3d::geometry::ColliderSet::invalid_handle()))
            .map(|_| ())
    }
}

/// Collider names checked during a second reading of a file whose names do not match, so
/// the error points at the offending name (see [`super::SceneFile::parse`]).
pub(crate) struct NameCheck {
    /// Every name given to a collider in the file.
    pub known: BTreeSet<String>,
    /// Names met so far in this reading.
    pub seen: BTreeSet<String>,
}

thread_local! {
    static NAME_CHECK: RefCell<Option<NameCheck>> = const { RefCell::new(None) };
}

/// Turns the name check on for the current thread until dropped.
pub(crate) struct NameCheckGuard;

impl NameCheckGuard {
    pub(crate) fn new(known: BTreeSet<String>) -> Self {
        NAME_CHECK.with(|c| {
            *c.borrow_mut() = Some(NameCheck {
                known,
                seen: BTreeSet::new(),
            })
        });
        NameCheckGuard
    }
}

impl Drop for NameCheckGuard {
    fn drop(&mut self) {
        NAME_CHECK.with(|c| *c.borrow_mut() = None);
    }
}

/// The name of a collider, for sinks to refer to (unique within a file, not empty).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub struct ColliderName(pub String);

impl TryFrom<String> for ColliderName {
    type Error = String;
    fn try_from(s: String) -> Result<Self, String> {
        if s.is_empty() {
            return Err("a collider name must not be empty".into());
        }
        let repeated = NAME_CHECK.with(|c| {
            c.borrow_mut()
                .as_mut()
                .is_some_and(|check| !check.seen.insert(s.clone()))
        });
        if repeated {
            return Err(format!("another collider is already named `{s}`"));
        }
        Ok(ColliderName(s))
    }
}

impl From<ColliderName> for String {
    fn from(n: ColliderName) -> String {
        n.0
    }
}

/// A reference to a named collider ([`ColliderName`]).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub struct ColliderRef(pub String);

impl TryFrom<String> for ColliderRef {
    type Error = String;
    fn try_from(s: String) -> Result<Self, String> {
        NAME_CHECK.with(|c| match c.borrow().as_ref() {
            Some(check) if !check.known.contains(&s) => Err(unknown_name(&s, &check.known)),
            _ => Ok(ColliderRef(s)),
        })
    }
}

impl From<ColliderRef> for String {
    fn from(n: ColliderRef) -> String {
        n.0
    }
}

/// The message for a reference to a name no collider has.
pub(crate) fn unknown_name(name: &str, known: &BTreeSet<String>) -> String {
    if known.is_empty() {
        format!("no collider is named `{name}` (no collider has a name)")
    } else {
        let list: Vec<String> = known.iter().map(|n| format!("`{n}`")).collect();
        format!(
            "no collider is named `{name}` (named colliders: {})",
            list.join(", ")
        )
    }
}
