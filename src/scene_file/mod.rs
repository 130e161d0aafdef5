//! Scene files (feature `scene`): fluids, rapier bodies and colliders, camera and duration in
//! one [RON](https://github.com/ron-rs/ron) file, loaded with serde.
//!
//! RON is the one format: it reads like Rust (struct and enum names, comments, trailing
//! commas). Optional fields may be left out; `Some(..)` around optional values may be
//! left out too (the `implicit_some` extension is on). A complete example with every field,
//! which the tests load, is `scenes/reference.ron`; the shipped scenes are `scenes/*.ron`.
//!
//! ```ron
//! Scene(
//!     description: "A block of water dropped into a box",
//!     duration: 1.0,            // simulated seconds
//!     frame_rate: 30.0,         // frames per second for pictures and exports
//!     // dt: 0.0005,            // time step (s); default: one step per frame, which the fluid
//!                               // pipeline splits into the substeps its solver needs
//!     gravity: (0.0, -9.81, 0.0),
//!     fluids: [
//!         Fluid(
//!             name: "water",
//!             preset: Water(spacing: 0.05),   // or Paper
//!             viscosity: 0.2,                 // any parameter of FluidParams may be overridden
//!             blocks: [Block(min: (-0.25, 0.1, -0.25), size: (0.5, 0.5, 0.5))],
//!             fill: [                         // any shape, filled on the fluid's lattice
//!                 Collider(name: "pool"),     // a named collider's volume (a sensor, say)
//!                 Shape(shape: Cylinder(half_height: 0.2, radius: 0.1), position: (0.6, 0.3, 0.0)),
//!             ],
//!             emitters: [
//!                 Emitter(
//!                     nozzle: Disk(radius: 0.08),     // or Square(half_width: ..), Sphere(radius: ..)
//!                     position: (0.0, 1.0, 0.0),
//!                     direction: (1.0, -0.3, 0.0),    // any length; not used by a sphere
//!                     speed: 1.5,                     // m/s
//!                     rate: 400.0,                    // particles/s, or rate_fraction: 0.8
//!                                                     // (of the nozzle's blocking rate)
//!                     start: 0.0, stop: 5.0,          // s on the emitter's clock (default 0, never)
//!                     budget: 2000,                   // particles in all (default: no limit)
//!                 ),
//!                 // A hose carried by the body of the collider "nozzle": position and
//!                 // direction in the body's frame, particles leave with its velocity.
//!                 // (`attached_to: Collider(name: "nozzle")` follows the collider itself.)
//!                 Emitter(nozzle: Disk(radius: 0.03), position: (0.0, -0.1, 0.0), speed: 1.0,
//!                         rate: 300.0, attached_to: Body(collider: "nozzle")),
//!             ],
//!             sinks: [
//!                 Sink(region: Collider(name: "drain")),  // reach: 0.05 (default: one spacing)
//!                 Sink(region: Aabb(min: (-9.0, -9.0, -9.0), max: (9.0, -1.0, 9.0))),
//!                 // Sink(region: Ball(center: (0.0, 0.0, 0.0), radius: 0.2)),
//!             ],
//!             capacity: 20000,                // emitters pause at this many particles
//!         ),
//!     ],
//!     bodies: [
//!         Body(kind: Fixed, colliders: [
//!             Collider(shape: Cuboid(half_extents: (1.0, 0.1, 1.0))),
//!             Collider(shape: TriMeshFile(path: "bowl.obj", scale: (1.0, 1.0, 1.0)), position: (0.0, 0.5, 0.0)),
//!             Collider(name: "drain", shape: Ball(radius: 0.1), position: (0.8, 0.2, 0.0), sensor: true),
//!             Collider(name: "pool", shape: Cuboid(half_extents: (0.3, 0.05, 0.3)), position: (0.0, 0.15, 0.0), sensor: true),
//!         ]),
//!         // A kinematic paddle wheel turning at 4 rad/s about z.
//!         Body(kind: KinematicVelocityBased, position: (0.5, 0.4, 0.0), angvel: (0.0, 0.0, 4.0),
//!              colliders: [Collider(shape: Cuboid(half_extents: (0.12, 0.01, 0.2)))]),
//!         // A pipe moving at 0.2 m/s, carrying the hose above.
//!         Body(kind: KinematicVelocityBased, position: (-0.5, 1.0, 0.0), linvel: (0.2, 0.0, 0.0),
//!              colliders: [Collider(name: "nozzle", shape: Cuboid(half_extents: (0.05, 0.05, 0.05)))]),
//!     ],
//!     camera: Orbit(target: (0.0, 0.3, 0.0), distance: 3.0, azimuth: 30.0, elevation: 25.0),
//! )
//! ```
//!
//! Errors name the file, the line and column, and the field (`fluids[0].blocks[1].size`):
//! unknown fields are refused (`deny_unknown_fields`), numbers are checked while they are read
//! (a radius must be positive and finite, a position finite), and each fluid's parameters are
//! validated as a whole when its entry ends; so are emitters, sinks, bodies and shapes (an
//! emitter whose `stop` is before its `start`, a sink box with `max` below `min`, a velocity
//! on a body that cannot keep one, a mesh index past its vertices, a degenerate hull).
//! Collider names are checked once the whole file is read: a sink, a fill or an emitter's
//! `attached_to` that names no collider, or two colliders with one name, is reported at the
//! name's line. So are the bounds on the work
//! a scene asks for ([`MAX_STEPS_PER_FRAME`], [`MAX_FRAMES`]) and on its particles (a fluid's
//! count and memory, nozzles, capacities: see [`crate::fluid::MAX_PARTICLES`]), each at its
//! field's line; [`SceneFile::load_and_build`] reports what fails when the scene is built (a
//! mesh file that cannot be read) at the field's line too. Files are read only if they are
//! regular files of at most [`MAX_FILE_BYTES`].
//!
//! Bodies keep a velocity only if they are `Dynamic` (initial velocity) or
//! `KinematicVelocityBased` (constant `linvel` and `angvel`: a conveyor, a paddle wheel). A
//! `KinematicPositionBased` body moves only when a program sets its next pose each step, which
//! a file cannot describe, so a velocity on it (or on a `Fixed` body) is an error.

#![cfg_attr(docsrs, doc(cfg(feature = "scene")))]

mod build;
mod fluid;
mod locate;
mod shapes;
mod sources;
mod values;

pub use build::BuiltScene;
#[cfg(feature = "render")]
pub use build::scene_bounds;
pub use fluid::{
    BlockDesc, EosDesc, FluidDesc, KernelDesc, MixtureDesc, PhaseDesc, Preset, SleepDesc,
    SolverDesc, SpringsDesc, ViscositySolveDesc, WcsphDensityDesc, WcsphPressureDesc,
};
pub use shapes::{CompoundPart, ShapeDesc};
pub use sources::{
    AttachmentDesc, ColliderName, ColliderRef, EmitterDesc, FillDesc, NozzleDesc, SinkDesc,
    SinkRegionDesc,
};
pub use values::{Finite, NonNegative, Positive, PositiveVec3, Vec3};

use crate::math::{Real, Vector};
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;
use std::fmt;
use std::path::{Path, PathBuf};

/// Largest scene file, and largest mesh file a scene reads (1 GiB, tens of millions of
/// triangles in OBJ). A larger file, or one that is not a regular file (a device such as
/// `/dev/zero`, a pipe), is refused before it is read.
pub const MAX_FILE_BYTES: u64 = 1 << 30;

/// Most steps a frame may take: `ceil(1/(frame_rate·dt)) ≤ 65,536` (2^16), checked when a
/// scene is read (the field `dt`). Each step is a rapier step and a fluid step (which the
/// fluid pipeline may split further, within its own bound [`crate::pipeline::MAX_SUBSTEPS`]).
/// The bound admits, at 30 frames per second, steps down to 0.5 µs: five times finer than the
/// acoustic limit `0.4·h/c` of water at 0.1 mm spacing (2.7 µs, 12,500 steps a frame).
pub const MAX_STEPS_PER_FRAME: usize = 1 << 16;

/// Longest step a scene may take (s): the fluid pipeline divides a step into at most 256
/// adaptive substeps by default, and the coarsest stable substep of the presets is about
/// 5 ms (DFSPH under gravity at 5 cm spacing), so a step much longer than 256 × 5 ms = 1.28 s
/// would run against the substep cap. A scene without `dt` steps once per frame, so this also
/// bounds the frame (a frame rate of 10^-30 is refused).
pub const MAX_STEP_SECONDS: Real = 1.0;

/// Most frames a scene may last: `duration·frame_rate ≤ 2^24` (16,777,216; 6.5 days at 30
/// frames per second), checked when a scene is read (the field `duration`). A frame's time,
/// `frame/frame_rate`, is computed in single precision, which tells consecutive frames apart
/// only up to 2^24 frames.
pub const MAX_FRAMES: usize = 1 << 24;

/// A whole scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Scene")]
pub struct SceneFile {
    /// Free text shown by `rapier-sph validate`.
    #[serde(default)]
    pub description: String,
    /// Simulated time (s).
    pub duration: Positive,
    /// Time step (s) of rapier and of each fluid step, rounded down so a frame holds a whole
    /// number of steps. Default: one step per frame (`1/frame_rate`), as a game steps the
    /// crate: the fluid pipeline splits each step into the substeps its solver needs (its
    /// adaptive substeps, [`crate::pipeline::TimeStepping`], are on by default; DFSPH takes a
    /// few per 1/60 s frame where the acoustic limit of WCSPH would take dozens).
    #[serde(default)]
    pub dt: Option<Positive>,
    /// Frames per second for pictures and exports. Default 30.
    #[serde(default = "default_frame_rate")]
    pub frame_rate: Positive,
    /// Gravity (m/s²). Default `(0, -9.81, 0)`.
    #[serde(default = "default_gravity")]
    pub gravity: Vec3,
    /// The fluids.
    #[serde(default, deserialize_with = "values::checked_vec")]
    pub fluids: Vec<FluidDesc>,
    /// Rapier bodies with their colliders.
    #[serde(default, deserialize_with = "values::checked_vec")]
    pub bodies: Vec<BodyDesc>,
    /// The camera for pictures. Default: [`CameraDesc::Auto`] from 30° azimuth, 25° elevation.
    #[serde(default)]
    pub camera: Option<CameraDesc>,
}

fn default_frame_rate() -> Positive {
    Positive(30.0)
}
fn default_gravity() -> Vec3 {
    Vec3([0.0, -9.81, 0.0])
}

/// A rapier body's type.
#[derive(Copy, Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum BodyKind {
    /// Never moves (the default).
    #[default]
    Fixed,
    /// Moved by forces and contacts.
    Dynamic,
    /// Moved by setting its next position.
    KinematicPositionBased,
    /// Moved by its velocity.
    KinematicVelocityBased,
}

/// A rapier rigid body and its colliders.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Body")]
pub struct BodyDesc {
    /// The body type. Default `Fixed`.
    #[serde(default)]
    pub kind: BodyKind,
    /// Position (m).
    #[serde(default)]
    pub position: Vec3,
    /// Orientation as a rotation vector (axis × angle in radians), as rapier's builders take.
    #[serde(default)]
    pub rotation: Vec3,
    /// Initial linear velocity (m/s); for a `KinematicVelocityBased` body, the velocity it
    /// keeps. Only `Dynamic` and `KinematicVelocityBased` bodies may have one (rapier
    /// ignores it on the others).
    #[serde(default)]
    pub linvel: Vec3,
    /// Initial angular velocity (rad/s, axis × rate); for a `KinematicVelocityBased` body,
    /// the spin it keeps (a paddle wheel). Only `Dynamic` and `KinematicVelocityBased` bodies
    /// may have one: a `KinematicPositionBased` body moves only when its next pose is set
    /// each step, which a file cannot do.
    #[serde(default)]
    pub angvel: Vec3,
    /// The colliders attached to the body.
    #[serde(default)]
    pub colliders: Vec<ColliderDesc>,
}

impl values::Validate for BodyDesc {
    fn validate(&self) -> Result<(), String> {
        let moving = self.linvel.vector() != Vector::ZERO || self.angvel.vector() != Vector::ZERO;
        match self.kind {
            BodyKind::Fixed | BodyKind::KinematicPositionBased if moving => Err(format!(
                "a {:?} body does not keep a velocity (rapier ignores linvel and angvel on it); \
                 use KinematicVelocityBased for a body that moves or spins at a constant rate",
                self.kind
            )),
            _ => Ok(()),
        }
    }
}

/// A rapier collider.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Collider")]
pub struct ColliderDesc {
    /// A name, unique in the file, by which a sink refers to the collider
    /// (`Sink(region: Collider(name: "drain"))`); the runner also reports the fluid inside
    /// named sensors.
    #[serde(default)]
    pub name: Option<ColliderName>,
    /// The shape (every parry shape; see [`ShapeDesc`]), checked as it is read.
    #[serde(deserialize_with = "values::checked")]
    pub shape: ShapeDesc,
    /// Position relative to the body (m).
    #[serde(default)]
    pub position: Vec3,
    /// Rotation relative to the body (rotation vector, rad).
    #[serde(default)]
    pub rotation: Vec3,
    /// Density (kg/m³) for the body's mass. Default: rapier's (1).
    #[serde(default)]
    pub density: Option<Positive>,
    /// Friction coefficient between rigid bodies. Default: rapier's (0.5).
    #[serde(default)]
    pub friction: Option<NonNegative>,
    /// Restitution between rigid bodies. Default: rapier's (0).
    #[serde(default)]
    pub restitution: Option<NonNegative>,
    /// A sensor: detects, does not collide (the fluid ignores sensors).
    #[serde(default)]
    pub sensor: bool,
}

/// The camera for pictures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum CameraDesc {
    /// Frames the whole scene (colliders and particles, infinite shapes left out) from this
    /// azimuth and elevation (degrees).
    Auto {
        /// Degrees about +y (0 looks along −z).
        #[serde(default = "default_azimuth")]
        azimuth: Finite,
        /// Degrees above the horizon.
        #[serde(default = "default_elevation")]
        elevation: Finite,
        /// Degrees the camera turns per simulated second (0: fixed).
        #[serde(default)]
        degrees_per_second: Finite,
    },
    /// From `eye` towards `target`.
    LookAt {
        /// Camera position (m).
        eye: Vec3,
        /// The point looked at (m).
        target: Vec3,
        /// Vertical field of view (degrees). Default 40.
        #[serde(default = "default_fov")]
        fov_y_degrees: Positive,
    },
    /// On a sphere around `target`.
    Orbit {
        /// The point looked at (m).
        target: Vec3,
        /// Distance from the target (m).
        distance: Positive,
        /// Degrees about +y (0 looks along −z).
        azimuth: Finite,
        /// Degrees above the horizon.
        elevation: Finite,
        /// Degrees the camera turns per simulated second (0: fixed).
        #[serde(default)]
        degrees_per_second: Finite,
        /// Vertical field of view (degrees). Default 40.
        #[serde(default = "default_fov")]
        fov_y_degrees: Positive,
    },
}

fn default_azimuth() -> Finite {
    Finite(30.0)
}
fn default_elevation() -> Finite {
    Finite(25.0)
}
fn default_fov() -> Positive {
    Positive(40.0)
}

/// Errors of reading, checking and building a scene file.
#[derive(Debug)]
#[non_exhaustive]
pub enum SceneError {
    /// The file could not be read.
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The file is not a valid scene: bad syntax, an unknown or missing field, a bad value,
    /// or (from [`SceneFile::load_and_build`]) a scene that cannot be built (a mesh file that
    /// cannot be read, ...). Always located: file, line, column, field.
    Parse {
        /// The file.
        path: PathBuf,
        /// Line (1-based).
        line: usize,
        /// Column (1-based).
        column: usize,
        /// The field, as a path such as `bodies[0].colliders[1].shape` (empty at top level).
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A scene value cannot be built by [`SceneFile::build`] (a mesh file is missing or too
    /// large). The value may not come from a text (a [`SceneFile`] made in code), so the error
    /// names the field only; [`SceneFile::load_and_build`] reports it as a
    /// [`SceneError::Parse`] at the field's line.
    Invalid {
        /// The scene file.
        path: PathBuf,
        /// The field, as a path.
        field: String,
        /// What is wrong.
        message: String,
    },
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SceneError::Io { path, source } => write!(f, "{}: {source}", path.display()),
            SceneError::Parse {
                path,
                line,
                column,
                field,
                message,
            } => {
                write!(f, "{}:{line}:{column}: ", path.display())?;
                if !field.is_empty() {
                    write!(f, "field `{field}`: ")?;
                }
                write!(f, "{message}")
            }
            SceneError::Invalid {
                path,
                field,
                message,
            } => write!(f, "{}: field `{field}`: {message}", path.display()),
        }
    }
}

impl std::error::Error for SceneError {}

impl SceneFile {
    /// Reads and checks a scene file (at most [`MAX_FILE_BYTES`], a regular file).
    ///
    /// # Errors
    /// [`SceneError::Io`] when the file cannot be read (missing, too large, not a regular
    /// file, not UTF-8), else [`SceneFile::parse`]'s errors.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, SceneError> {
        let path = path.as_ref();
        let text = Self::read_text(path)?;
        Self::parse(&text, path)
    }

    /// The text of a scene file, read within [`MAX_FILE_BYTES`].
    fn read_text(path: &Path) -> Result<String, SceneError> {
        let io = |source| SceneError::Io {
            path: path.to_path_buf(),
            source,
        };
        let bytes = crate::error::read_regular_file(path, MAX_FILE_BYTES).map_err(io)?;
        String::from_utf8(bytes)
            .map_err(|e| io(std::io::Error::new(std::io::ErrorKind::InvalidData, e)))
    }

    /// Parses and checks scene text; `path` is only used in error messages.
    ///
    /// Besides every value, it checks what [`SceneFile::build`] would refuse without reading
    /// a file: the steps per frame ([`MAX_STEPS_PER_FRAME`]) and the frames
    /// ([`MAX_FRAMES`]), each fluid's particle count and its memory (a block's lattice,
    /// [`crate::fluid::MAX_PARTICLES`], [`crate::fluid::bytes_per_particle`]), positions
    /// within 10,000 km, emitters at the fluid's spacing, capacities, collider names.
    ///
    /// # Errors
    /// [`SceneError::Parse`], naming the file, the line and column, and the field.
    pub fn parse(text: &str, path: impl AsRef<Path>) -> Result<Self, SceneError> {
        let path = path.as_ref();
        let scene = Self::read(text, path)?;
        if let Err((field, message)) = scene.check() {
            return Err(located(text, path, field, message));
        }
        // Collider names can only be checked once the whole file is read (a sink may come
        // before the collider it names). When they do not match, the file is read again with
        // the names known, so the error points at the offending name.
        if let Err((field, message)) = scene.check_names() {
            let _check = sources::NameCheckGuard::new(scene.collider_names());
            Self::read(text, path)?;
            return Err(SceneError::Invalid {
                path: path.to_path_buf(),
                field,
                message,
            });
        }
        Ok(scene)
    }

    /// What [`SceneFile::build`] would refuse that needs no file: returns the field and the
    /// message of the first problem (see [`SceneFile::parse`]).
    fn check(&self) -> Result<(), (String, String)> {
        self.check_timing()?;
        let g = self.gravity.vector();
        if !crate::math::is_finite(g) || !(g.length() <= crate::pipeline::MAX_GRAVITY) {
            return Err((
                "gravity".into(),
                format!(
                    "{:e} m/s^2: gravity must be finite and at most MAX_GRAVITY (10^6 m/s^2)",
                    g.length()
                ),
            ));
        }
        for (fi, f) in self.fluids.iter().enumerate() {
            check_fluid(fi, f)?;
        }
        Ok(())
    }

    /// The frames ([`MAX_FRAMES`]), the step's length ([`MAX_STEP_SECONDS`]) and the steps
    /// per frame ([`MAX_STEPS_PER_FRAME`]): the run's length in steps must stay bounded.
    fn check_timing(&self) -> Result<(), (String, String)> {
        let frames = self.duration.0 as f64 * self.frame_rate.0 as f64;
        if frames > MAX_FRAMES as f64 {
            return Err((
                "duration".into(),
                format!(
                    "{} s at {} frames/s is {frames:.3e} frames, more than MAX_FRAMES (2^24 = \
                     {MAX_FRAMES})",
                    self.duration.0, self.frame_rate.0
                ),
            ));
        }
        let (dt, steps) = self.time_step();
        if dt > MAX_STEP_SECONDS {
            return Err((
                "dt".into(),
                format!(
                    "a step of {dt:e} s (one frame of 1/{} s when no dt is given) is longer than \
                     MAX_STEP_SECONDS ({MAX_STEP_SECONDS} s): the substeps could not keep it stable",
                    self.frame_rate.0
                ),
            ));
        }
        if steps > MAX_STEPS_PER_FRAME || !(dt >= crate::pipeline::MIN_TIME_STEP) {
            let given = if self.dt.is_some() {
                ""
            } else {
                " (the default)"
            };
            return Err((
                "dt".into(),
                format!(
                    "a time step of {dt:e} s{given} takes {} steps per frame of 1/{} s, more \
                     than MAX_STEPS_PER_FRAME (2^16 = {MAX_STEPS_PER_FRAME})",
                    if steps == usize::MAX {
                        "more than 10^19".to_string()
                    } else {
                        steps.to_string()
                    },
                    self.frame_rate.0
                ),
            ));
        }
        Ok(())
    }

    /// The names given to colliders.
    fn collider_names(&self) -> BTreeSet<String> {
        self.bodies
            .iter()
            .flat_map(|b| &b.colliders)
            .filter_map(|c| c.name.as_ref().map(|n| n.0.clone()))
            .collect()
    }

    /// Checks that collider names are unique and that every collider sink names one.
    /// Returns the field and the message of the first problem.
    fn check_names(&self) -> Result<(), (String, String)> {
        let mut names = BTreeSet::new();
        for (bi, b) in self.bodies.iter().enumerate() {
            for (ci, c) in b.colliders.iter().enumerate() {
                if let Some(n) = &c.name
                    && !names.insert(n.0.clone())
                {
                    return Err((
                        format!("bodies[{bi}].colliders[{ci}].name"),
                        format!("another collider is already named `{}`", n.0),
                    ));
                }
            }
        }
        for (fi, f) in self.fluids.iter().enumerate() {
            for (field, name) in fluid_names(fi, f) {
                if !names.contains(name) {
                    return Err((field, sources::unknown_name(name, &names)));
                }
            }
        }
        Ok(())
    }

    /// Deserialises and checks values (not names).
    fn read(text: &str, path: &Path) -> Result<Self, SceneError> {
        let options = ron::Options::default()
            .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME);
        let spanned = |e: ron::error::SpannedError, field: String| SceneError::Parse {
            path: path.to_path_buf(),
            line: e.span.start.line,
            column: e.span.start.col,
            field,
            message: e.code.to_string(),
        };
        let mut de = ron::Deserializer::from_str_with_options(text, &options)
            .map_err(|e| spanned(e, String::new()))?;
        let scene: SceneFile = match serde_path_to_error::deserialize(&mut de) {
            Ok(s) => s,
            Err(e) => {
                let field = e.path().to_string();
                let field = if field == "." { String::new() } else { field };
                let code = e.into_inner();
                return Err(spanned(de.span_error(code), field));
            }
        };
        de.end()
            .map_err(|code| spanned(de.span_error(code), String::new()))?;
        Ok(scene)
    }

    /// Writes the scene as RON text (pretty-printed).
    pub fn to_ron(&self) -> String {
        let config = ron::ser::PrettyConfig::new().struct_names(true);
        ron::Options::default()
            .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
            .to_string_pretty(self, config)
            .expect("scene values are plain data")
    }

    /// The time step the scene runs with: `dt` if given, else one frame (`1/frame_rate`,
    /// which the fluid pipeline substeps); rounded down so that a frame holds a whole number
    /// of steps. Returns `(dt, steps per frame)`.
    pub fn time_step(&self) -> (Real, usize) {
        let frame = 1.0 / self.frame_rate.0;
        let dt = self.dt.map_or(frame, |d| d.0);
        let steps = (frame / dt).ceil().max(1.0) as usize;
        (frame / steps as Real, steps)
    }

    /// Number of frames in `duration`.
    pub fn frames(&self) -> usize {
        (self.duration.0 * self.frame_rate.0).round().max(1.0) as usize
    }

    /// [`SceneFile::load`] then [`SceneFile::build`], mesh paths relative to the file.
    ///
    /// # Errors
    /// [`SceneError::Io`] when the scene file cannot be read; every other error is a
    /// [`SceneError::Parse`] naming the file, the line and column, and the field (a build
    /// error, such as a mesh file that cannot be read, is located at its field).
    pub fn load_and_build(path: impl AsRef<Path>) -> Result<(Self, BuiltScene), SceneError> {
        let path = path.as_ref();
        let text = Self::read_text(path)?;
        let scene = Self::parse(&text, path)?;
        let base = path.parent().unwrap_or(Path::new("."));
        match scene.build(path, base) {
            Ok(built) => Ok((scene, built)),
            Err(SceneError::Invalid { field, message, .. }) => {
                Err(located(&text, path, field, message))
            }
            Err(e) => Err(e),
        }
    }
}

/// The collider names fluid `fi` refers to (its sinks, fills and emitters' carriers), each
/// with its field.
fn fluid_names(fi: usize, f: &FluidDesc) -> Vec<(String, &str)> {
    let mut out = Vec::new();
    for (k, s) in f.sinks.iter().enumerate() {
        if let SinkRegionDesc::Collider { name, .. } = &s.region {
            out.push((
                format!("fluids[{fi}].sinks[{k}].region.Collider.name"),
                &*name.0,
            ));
        }
    }
    for (k, fill) in f.fill.iter().enumerate() {
        if let FillDesc::Collider { name } = fill {
            out.push((format!("fluids[{fi}].fill[{k}].Collider.name"), &*name.0));
        }
    }
    for (k, e) in f.emitters.iter().enumerate() {
        let field = match &e.attached_to {
            Some(AttachmentDesc::Collider { .. }) => "Collider.name",
            Some(AttachmentDesc::Body { .. }) => "Body.collider",
            None => continue,
        };
        let name = e.attached_to.as_ref().map_or("", |a| a.collider_name());
        out.push((
            format!("fluids[{fi}].emitters[{k}].attached_to.{field}"),
            name,
        ));
    }
    out
}

/// A [`SceneError::Parse`] at the place `field` is written in `text`.
fn located(text: &str, path: &Path, field: String, message: String) -> SceneError {
    let (line, column) = locate::locate(text, &field);
    SceneError::Parse {
        path: path.to_path_buf(),
        line,
        column,
        field,
        message,
    }
}

/// Is `p` beyond 10,000 km from the origin (or not finite)? Single precision cannot
/// resolve a particle spacing there.
fn far(p: Vector) -> bool {
    !crate::math::is_finite(p) || p.abs().max_element() > 1.0e7
}

/// What [`SceneFile::build`] would refuse in fluid `fi` without reading a file: its particle
/// count and memory, positions within 10,000 km, its emitters at its spacing, its capacity.
/// Returns the field and the message of the first problem.
fn check_fluid(fi: usize, f: &FluidDesc) -> Result<(), (String, String)> {
    let field = |name: String| format!("fluids[{fi}]{name}");
    let Ok(params) = f.params() else {
        return Ok(()); // checked as the fluid was read
    };
    let s = params.particle_spacing;
    let bytes = crate::fluid::bytes_per_particle(&params);
    let mut total = check_blocks(fi, f, s, bytes)?;
    if let Some(k) = f.particles.iter().position(|p| far(p.vector())) {
        return Err((
            field(format!(".particles[{k}]")),
            "position beyond 10,000 km from the origin (single precision cannot \
             resolve particle spacing there)"
                .into(),
        ));
    }
    total += f.particles.len() as f64;
    crate::fluid::check_particle_count(total, bytes, "particles")
        .map_err(|e| (field(".particles".into()), e.to_string()))?;
    for (k, e) in f.emitters.iter().enumerate() {
        let emitter = e
            .emitter(s)
            .map_err(|m| (field(format!(".emitters[{k}]")), m))?;
        emitter
            .check_slots(s)
            .map_err(|e| (field(format!(".emitters[{k}].nozzle")), e.to_string()))?;
    }
    if let Some(cap) = f.capacity {
        if (cap as f64) < total {
            return Err((
                field(".capacity".into()),
                format!("{cap} is below the {total} particles the file adds"),
            ));
        }
        crate::fluid::check_particle_count(cap as f64, bytes, "capacity")
            .map_err(|e| (field(".capacity".into()), e.to_string()))?;
    }
    Ok(())
}

/// Fluid `fi`'s blocks at spacing `s`: the running particle count against the memory limit
/// (`bytes` per particle) and each lattice's first and last points within 10,000 km.
/// Returns the blocks' particle count.
fn check_blocks(fi: usize, f: &FluidDesc, s: Real, bytes: usize) -> Result<f64, (String, String)> {
    let field = |name: String| format!("fluids[{fi}]{name}");
    let mut total = 0.0f64;
    for (k, b) in f.blocks.iter().enumerate() {
        let counts = crate::fluid::block_counts(s, b.size.vector());
        total += counts.x as f64 * counts.y as f64 * counts.z as f64;
        crate::fluid::check_particle_count(total, bytes, "size")
            .map_err(|e| (field(format!(".blocks[{k}].size")), e.to_string()))?;
        // The lattice's first and last points, as `Fluid::add_block` places them.
        let first = b.min.vector() + Vector::splat(0.5 * s);
        let last = first + (counts - Vector::ONE) * s;
        if far(first) || far(last) {
            return Err((
                field(format!(".blocks[{k}].min")),
                "the block reaches beyond 10,000 km from the origin (single precision \
                 cannot resolve particle spacing there)"
                    .into(),
            ));
        }
    }
    Ok(total)
}

/// A [`SceneError::Invalid`] naming the scene file `path` and the `field` at fault.
fn invalid(path: &Path, field: String, message: String) -> SceneError {
    SceneError::Invalid {
        path: path.to_path_buf(),
        field,
        message,
    }
}
