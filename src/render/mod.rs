//! Headless pictures (feature `render`): particles as shaded spheres coloured by speed, the
//! rapier colliders as shaded geometry, an optional liquid surface mesh, seen by a fixed or
//! orbiting [`Camera`]. A small z-buffered software rasteriser of this crate draws them (no
//! GPU, no display); `png` and `gif` encode the frames.
//!
//! ```no_run
//! # use rapier_sph::render::{Camera, RenderOptions, Renderer, GifWriter};
//! # use rapier_sph::scenes::{dam_break, DamBreakConfig};
//! # let mut scene = dam_break(&DamBreakConfig::tower(rapier_sph::FluidParamsBuilder::paper().build()?, 1.0))?;
//! let mut renderer = Renderer::new(RenderOptions::default());
//! let camera = Camera::framing(scene.tank_min, scene.tank_max, 35.0, 25.0);
//! let mut gif = GifWriter::create("dam_break.gif", 640, 360, 4)?;
//! for frame in 0..100 {
//!     for _ in 0..10 { scene.world.step()?; }
//!     let image = renderer.render_world(&camera, &scene.world, None);
//!     image.save_png(format!("frame_{frame:04}.png"))?;
//!     gif.add_frame(&image)?;
//! }
//! gif.finish()?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Colliders that lie between the camera and the fluid (their bounding-box centre is nearer
//! to the camera than the fluid's centroid, e.g. the front wall and the lid of a tank) are
//! drawn translucent so the fluid stays visible; the others are opaque.

#![cfg_attr(docsrs, doc(cfg(feature = "render")))]

mod raster;

pub use raster::Rgb;

use crate::fluid::FluidSet;
use crate::math::{Real, Vector};
use crate::mesh::{TessellationOptions, TriangleMesh};
use crate::world::FluidWorld;
use rapier3d::geometry::{ColliderHandle, ColliderSet};
use raster::{Target, lerp3};
use std::fmt;
use std::path::{Path, PathBuf};

/// A pinhole camera looking from `eye` at `target`.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Camera {
    /// Camera position (m).
    pub eye: Vector,
    /// The point looked at (m).
    pub target: Vector,
    /// Up direction (default +y).
    pub up: Vector,
    /// Vertical field of view (degrees). Default 40.
    pub fov_y_degrees: Real,
}

impl Camera {
    /// A camera at `eye` looking at `target`, y up, 40° field of view.
    pub fn look_at(eye: Vector, target: Vector) -> Self {
        Self {
            eye,
            target,
            up: Vector::Y,
            fov_y_degrees: 40.0,
        }
    }

    /// A camera on a sphere around `target`: `azimuth` (degrees, about +y, 0 looks along −z)
    /// and `elevation` (degrees above the horizon), `distance` away.
    pub fn orbit(target: Vector, distance: Real, azimuth: Real, elevation: Real) -> Self {
        let (a, e) = (azimuth.to_radians(), elevation.to_radians());
        let dir = Vector::new(a.sin() * e.cos(), e.sin(), a.cos() * e.cos());
        Self::look_at(target + dir * distance, target)
    }

    /// An orbiting camera that frames the box `[min, max]` (its bounding sphere fits the
    /// view), from `azimuth` and `elevation` in degrees.
    pub fn framing(min: Vector, max: Vector, azimuth: Real, elevation: Real) -> Self {
        let c = Self::orbit((min + max) * 0.5, 1.0, azimuth, elevation);
        let radius = 0.5 * (max - min).length();
        let half = 0.5 * c.fov_y_degrees.to_radians();
        // Fit the sphere vertically with a little margin (wide images have room to spare).
        let distance = 1.02 * radius / half.sin();
        Self::orbit((min + max) * 0.5, distance, azimuth, elevation)
    }

    /// The same camera turned about the vertical axis through `target` by `degrees`.
    pub fn rotated(&self, degrees: Real) -> Self {
        let rot = crate::math::Rotation::from_axis_angle(self.up, degrees.to_radians());
        Self {
            eye: self.target + rot * (self.eye - self.target),
            ..*self
        }
    }

    /// View-space basis: (right, up, back); the camera looks along −back.
    fn basis(&self) -> (Vector, Vector, Vector) {
        let back = (self.eye - self.target).normalize_or(Vector::Z);
        let right = self.up.cross(back).normalize_or(Vector::X);
        let up = back.cross(right);
        (right, up, back)
    }
}

/// What to draw and how.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Image width (pixels). Default 640.
    pub width: u32,
    /// Image height (pixels). Default 360.
    pub height: u32,
    /// Supersampling factor per axis (anti-aliasing; cost grows with its square). Default 2.
    pub supersample: u32,
    /// Speeds mapped to the colour scale (m/s): `None` uses 0 to the frame's fastest particle.
    pub speed_range: Option<(Real, Real)>,
    /// Drawn sphere radius as a multiple of each fluid's particle spacing. Default 0.6.
    pub particle_scale: Real,
    /// Draw the particles (turn off to show only a surface mesh). Default true.
    pub draw_particles: bool,
    /// Draw the rapier colliders. Default true.
    pub draw_colliders: bool,
    /// Collider colour. Default a light sand grey.
    pub collider_color: Rgb,
    /// Opacity of the colliders between the camera and the fluid. Default 0.18.
    pub front_collider_alpha: Real,
    /// Surface mesh colour. Default a water blue.
    pub surface_color: Rgb,
    /// Tessellation of curved and infinite collider shapes.
    pub tessellation: TessellationOptions,
    /// Fade distant things towards the background by up to this fraction (depth cue).
    /// Default 0.35.
    pub fog: Real,
    /// Colliders drawn in a colour of their own and always opaque (the crates of a scene,
    /// say, among translucent tank walls); the others use [`Self::collider_color`]. Default
    /// none.
    pub collider_colors: Vec<(ColliderHandle, Rgb)>,
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            width: 640,
            height: 360,
            supersample: 2,
            speed_range: None,
            particle_scale: 0.6,
            draw_particles: true,
            draw_colliders: true,
            collider_color: [0.55, 0.52, 0.46],
            front_collider_alpha: 0.18,
            surface_color: [0.12, 0.38, 0.75],
            tessellation: TessellationOptions::default(),
            fog: 0.35,
            collider_colors: Vec::new(),
        }
    }
}

/// An 8-bit RGB image.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width (pixels).
    pub width: u32,
    /// Height (pixels).
    pub height: u32,
    /// Row-major RGB bytes, top row first (`3 · width · height`).
    pub rgb: Vec<u8>,
}

impl Image {
    /// The colour of one pixel.
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 3] {
        let k = 3 * (y as usize * self.width as usize + x as usize);
        [self.rgb[k], self.rgb[k + 1], self.rgb[k + 2]]
    }

    /// Writes the image as PNG.
    ///
    /// # Errors
    ///
    /// [`RenderError`] naming the path when the file cannot be created or written.
    pub fn save_png(&self, path: impl AsRef<Path>) -> Result<(), RenderError> {
        let path = path.as_ref();
        let file = std::fs::File::create(path).map_err(|e| RenderError::io(path, e))?;
        let mut enc = png::Encoder::new(std::io::BufWriter::new(file), self.width, self.height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc
            .write_header()
            .map_err(|e| RenderError::encode(path, e))?;
        w.write_image_data(&self.rgb)
            .map_err(|e| RenderError::encode(path, e))?;
        w.finish().map_err(|e| RenderError::encode(path, e))
    }

    /// Reads an 8-bit RGB or RGBA PNG (alpha is dropped), e.g. to check a written frame.
    ///
    /// # Errors
    ///
    /// [`RenderError`] naming the path when the file cannot be read or is not such a PNG.
    pub fn load_png(path: impl AsRef<Path>) -> Result<Image, RenderError> {
        let path = path.as_ref();
        let file = std::fs::File::open(path).map_err(|e| RenderError::io(path, e))?;
        let mut reader = png::Decoder::new(std::io::BufReader::new(file))
            .read_info()
            .map_err(|e| RenderError::encode(path, e))?;
        let size = reader
            .output_buffer_size()
            .ok_or_else(|| RenderError::encode(path, "image too large"))?;
        let mut buf = vec![0; size];
        let info = reader
            .next_frame(&mut buf)
            .map_err(|e| RenderError::encode(path, e))?;
        let channels = match (info.color_type, info.bit_depth) {
            (png::ColorType::Rgb, png::BitDepth::Eight) => 3,
            (png::ColorType::Rgba, png::BitDepth::Eight) => 4,
            other => {
                return Err(RenderError::encode(
                    path,
                    format!("unsupported PNG layout {other:?}"),
                ));
            }
        };
        let rgb = buf[..info.buffer_size()]
            .chunks_exact(channels)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect();
        Ok(Image {
            width: info.width,
            height: info.height,
            rgb,
        })
    }
}

/// Errors of writing pictures.
#[derive(Debug)]
#[non_exhaustive]
pub enum RenderError {
    /// The file could not be created or written.
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The encoder refused the image.
    Encode {
        /// The file.
        path: PathBuf,
        /// The encoder's message.
        message: String,
    },
}

impl RenderError {
    fn io(path: &Path, source: std::io::Error) -> Self {
        RenderError::Io {
            path: path.to_path_buf(),
            source,
        }
    }
    fn encode(path: &Path, message: impl fmt::Display) -> Self {
        RenderError::Encode {
            path: path.to_path_buf(),
            message: message.to_string(),
        }
    }
}

impl fmt::Display for RenderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RenderError::Io { path, source } => write!(f, "{}: {source}", path.display()),
            RenderError::Encode { path, message } => {
                write!(f, "{}: encoding failed: {message}", path.display())
            }
        }
    }
}

impl std::error::Error for RenderError {}

/// The colour scale for speeds: deep blue (slow) through cyan to white (fast).
pub fn speed_color(t: Real) -> Rgb {
    const STOPS: [Rgb; 5] = [
        [0.01, 0.04, 0.30],
        [0.02, 0.18, 0.70],
        [0.05, 0.55, 0.85],
        [0.45, 0.85, 0.95],
        [1.0, 1.0, 1.0],
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    } * (STOPS.len() - 1) as Real;
    let i = (t.floor() as usize).min(STOPS.len() - 2);
    lerp3(STOPS[i], STOPS[i + 1], t - i as Real)
}

/// Draws frames. Holds its buffers between frames, so rendering a sequence allocates once.
pub struct Renderer {
    options: RenderOptions,
    target: Target,
}

impl Renderer {
    /// A renderer with these options.
    pub fn new(options: RenderOptions) -> Self {
        Self {
            options,
            target: Target::new(),
        }
    }

    /// The options.
    pub fn options(&self) -> &RenderOptions {
        &self.options
    }

    /// The options, mutably (e.g. to fix the speed range after the first frame).
    pub fn options_mut(&mut self) -> &mut RenderOptions {
        &mut self.options
    }

    /// Renders a [`FluidWorld`]: its fluids and colliders, plus `surface` if given.
    pub fn render_world(
        &mut self,
        camera: &Camera,
        world: &FluidWorld,
        surface: Option<&TriangleMesh>,
    ) -> Image {
        self.render(camera, &world.fluids, &world.physics.colliders, surface)
    }

    /// Renders the particles of `fluids`, the colliders of `colliders` and an optional
    /// liquid surface mesh.
    pub fn render(
        &mut self,
        camera: &Camera,
        fluids: &FluidSet,
        colliders: &ColliderSet,
        surface: Option<&TriangleMesh>,
    ) -> Image {
        let o = &self.options;
        let ss = o.supersample.max(1) as usize;
        let (w, h) = (o.width.max(1) as usize * ss, o.height.max(1) as usize * ss);
        let focal = 0.5 * h as Real / (0.5 * o.fov_or(camera)).tan();
        let top = [0.62, 0.70, 0.80];
        let bottom = [0.93, 0.93, 0.90];
        self.target.reset(w, h, focal, top, bottom);
        let background = lerp3(top, bottom, 0.5);

        let (right, up, back) = camera.basis();
        let to_view = |p: Vector| {
            let r = p - camera.eye;
            Vector::new(r.dot(right), r.dot(up), r.dot(back))
        };
        // Light from above-left, slightly from the camera side, in view space.
        let light = Vector::new(-0.45, 0.75, 0.5).normalize();
        let half = (light + Vector::Z).normalize();
        let target_distance = (camera.eye - camera.target).length().max(1e-6);
        let fog = o.fog;
        let fogged = move |c: Rgb, d: Real| {
            let t = ((d - 0.8 * target_distance) / (0.8 * target_distance)).clamp(0.0, 1.0);
            lerp3(c, background, fog * t)
        };

        // The fluid's centroid decides which colliders are "in front".
        let mut centroid = Vector::ZERO;
        let mut count = 0usize;
        for (_, f) in fluids.iter() {
            for p in f.positions() {
                centroid += *p;
            }
            count += f.len();
        }
        let fluid_depth = if count > 0 {
            -to_view(centroid / count as Real).z
        } else {
            -to_view(camera.target).z
        };

        // Opaque colliders first, translucent ones after the particles.
        let mut translucent: Vec<([Vector; 3], Rgb)> = Vec::new();
        if o.draw_colliders {
            for (handle, mesh) in TriangleMesh::from_colliders(colliders, &o.tessellation) {
                if mesh.vertices.is_empty() {
                    continue;
                }
                let own = o.collider_colors.iter().find(|(c, _)| *c == handle);
                let (mut lo, mut hi) = (mesh.vertices[0], mesh.vertices[0]);
                for v in &mesh.vertices {
                    lo = lo.min(*v);
                    hi = hi.max(*v);
                }
                let in_front = own.is_none() && -to_view((lo + hi) * 0.5).z < fluid_depth;
                let color = own.map_or(o.collider_color, |(_, c)| *c);
                for t in &mesh.triangles {
                    let p = t.map(|i| to_view(mesh.vertices[i as usize]));
                    let mut n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
                    let centre = (p[0] + p[1] + p[2]) / 3.0;
                    if n.dot(-centre) < 0.0 {
                        n = -n; // two-sided: light the side we see
                    }
                    let lambert = n.dot(light).max(0.0);
                    let shade = 0.35 + 0.65 * lambert;
                    let base = color.map(|c| c * shade);
                    let col = fogged(base, -centre.z);
                    if in_front {
                        translucent.push((p, col));
                    } else {
                        self.target.triangle(p, [col; 3], 1.0);
                    }
                }
            }
        }

        if let Some(mesh) = surface {
            let normals = mesh.vertex_normals();
            let colors: Vec<Rgb> = mesh
                .vertices
                .iter()
                .zip(&normals)
                .map(|(v, n)| {
                    let pv = to_view(*v);
                    let nv = Vector::new(n.dot(right), n.dot(up), n.dot(back));
                    let view_dir = (-pv).normalize_or_zero();
                    let nv = if nv.dot(view_dir) < 0.0 { -nv } else { nv };
                    let diffuse = nv.dot(light).max(0.0);
                    let spec = nv.dot(half).max(0.0).powi(40);
                    let fresnel = (1.0 - nv.dot(view_dir).max(0.0)).powi(3);
                    let c = o.surface_color.map(|c| c * (0.3 + 0.7 * diffuse));
                    let c = lerp3(c, [0.85, 0.92, 1.0], 0.35 * fresnel);
                    fogged(c.map(|c| c + 0.6 * spec), -pv.z)
                })
                .collect();
            for t in &mesh.triangles {
                let p = t.map(|i| to_view(mesh.vertices[i as usize]));
                let c = t.map(|i| colors[i as usize]);
                self.target.triangle(p, c, 1.0);
            }
        }

        if o.draw_particles {
            let (lo, hi) = match o.speed_range {
                Some(r) => r,
                None => {
                    let mut max: Real = 0.0;
                    for (_, f) in fluids.iter() {
                        for v in f.velocities() {
                            max = max.max(v.length());
                        }
                    }
                    (0.0, max)
                }
            };
            let inv_range = if hi > lo { 1.0 / (hi - lo) } else { 0.0 };
            for (_, f) in fluids.iter() {
                let r = o.particle_scale * f.params().particle_spacing;
                for (p, v) in f.positions().iter().zip(f.velocities()) {
                    let base = speed_color((v.length() - lo) * inv_range);
                    self.target.sphere(to_view(*p), r, |n, d| {
                        let diffuse = n.dot(light).max(0.0);
                        let spec = n.dot(half).max(0.0).powi(32);
                        let c = base.map(|c| c * (0.35 + 0.65 * diffuse) + 0.35 * spec);
                        fogged(c, d)
                    });
                }
            }
        }

        for (p, col) in translucent {
            self.target.triangle(p, [col; 3], o.front_collider_alpha);
        }

        let (w, h, rgb) = self.target.resolve(ss);
        Image {
            width: w as u32,
            height: h as u32,
            rgb,
        }
    }
}

impl RenderOptions {
    fn fov_or(&self, camera: &Camera) -> Real {
        camera.fov_y_degrees.clamp(1.0, 170.0).to_radians()
    }
}

/// Writes an animated GIF frame by frame (each frame is quantised to its own 256-colour
/// palette by the `gif` crate's NeuQuant).
pub struct GifWriter {
    encoder: gif::Encoder<std::io::BufWriter<std::fs::File>>,
    path: PathBuf,
    width: u16,
    height: u16,
    delay_cs: u16,
}

impl GifWriter {
    /// Creates `path` for frames of `width × height` pixels shown `delay_cs` hundredths of a
    /// second each, looping forever.
    ///
    /// # Errors
    ///
    /// [`RenderError`] naming the path when the file cannot be created.
    pub fn create(
        path: impl AsRef<Path>,
        width: u32,
        height: u32,
        delay_cs: u16,
    ) -> Result<Self, RenderError> {
        let path = path.as_ref();
        let (Ok(w), Ok(h)) = (u16::try_from(width), u16::try_from(height)) else {
            return Err(RenderError::encode(
                path,
                "GIF frames are at most 65535 pixels wide",
            ));
        };
        let file = std::fs::File::create(path).map_err(|e| RenderError::io(path, e))?;
        let mut encoder = gif::Encoder::new(std::io::BufWriter::new(file), w, h, &[])
            .map_err(|e| RenderError::encode(path, e))?;
        encoder
            .set_repeat(gif::Repeat::Infinite)
            .map_err(|e| RenderError::encode(path, e))?;
        Ok(Self {
            encoder,
            path: path.to_path_buf(),
            width: w,
            height: h,
            delay_cs,
        })
    }

    /// Appends a frame.
    ///
    /// # Errors
    ///
    /// [`RenderError`] when the frame's size is not the one given to [`GifWriter::create`]
    /// or the file cannot be written.
    pub fn add_frame(&mut self, image: &Image) -> Result<(), RenderError> {
        if image.width != self.width as u32 || image.height != self.height as u32 {
            return Err(RenderError::encode(
                &self.path,
                format!(
                    "frame is {}×{}, the GIF is {}×{}",
                    image.width, image.height, self.width, self.height
                ),
            ));
        }
        let mut frame = gif::Frame::from_rgb_speed(self.width, self.height, &image.rgb, 10);
        frame.delay = self.delay_cs;
        self.encoder
            .write_frame(&frame)
            .map_err(|e| RenderError::encode(&self.path, e))
    }

    /// Finishes the file.
    ///
    /// # Errors
    ///
    /// [`RenderError`] when the file cannot be written.
    pub fn finish(self) -> Result<(), RenderError> {
        let path = self.path.clone();
        self.encoder
            .into_inner()
            .map_err(|e| RenderError::encode(&path, e))
            .and_then(|mut w| std::io::Write::flush(&mut w).map_err(|e| RenderError::io(&path, e)))
    }
}

/// What an example's `--render DIR` writes: numbered PNG frames `frame_0000.png`, … and one
/// animated GIF `<name>.gif` in `DIR`, each frame drawn by a [`Renderer`] from a camera that
/// may orbit a fixed number of degrees per frame.
pub struct Recorder {
    dir: PathBuf,
    renderer: Renderer,
    camera: Camera,
    orbit_degrees: Real,
    gif: GifWriter,
    frames: usize,
}

impl Recorder {
    /// Creates `dir` (and its parents) and the GIF `dir/<name>.gif`; frames are shown
    /// `gif_delay_cs` hundredths of a second each.
    ///
    /// # Errors
    ///
    /// [`RenderError`] naming the path when the folder or the GIF cannot be created.
    ///
    /// # Examples
    ///
    /// ```no_run
    /// use rapier_sph::FluidWorld;
    /// use rapier_sph::math::Vector;
    /// use rapier_sph::render::{Camera, Recorder, RenderOptions};
    ///
    /// # fn main() -> Result<(), Box<dyn std::error::Error>> {
    /// let mut world = FluidWorld::new();
    /// // ... colliders and fluids ...
    /// let camera = Camera::framing(Vector::ZERO, Vector::new(2.0, 1.0, 1.0), 30.0, 25.0);
    /// let mut pictures = Recorder::create("out", "splash", RenderOptions::default(), camera, 0.0, 4)?;
    /// for frame in 0..240 {
    ///     world.step()?;
    ///     if frame % 4 == 0 {
    ///         pictures.frame(&world)?; // out/frame_0000.png, ... and a frame of out/splash.gif
    ///     }
    /// }
    /// pictures.finish()?;
    /// # Ok(())
    /// # }
    /// ```
    pub fn create(
        dir: impl AsRef<Path>,
        name: &str,
        options: RenderOptions,
        camera: Camera,
        orbit_degrees: Real,
        gif_delay_cs: u16,
    ) -> Result<Self, RenderError> {
        let dir = dir.as_ref();
        std::fs::create_dir_all(dir).map_err(|e| RenderError::io(dir, e))?;
        let gif = GifWriter::create(
            dir.join(format!("{name}.gif")),
            options.width,
            options.height,
            gif_delay_cs,
        )?;
        Ok(Self {
            dir: dir.to_path_buf(),
            renderer: Renderer::new(options),
            camera,
            orbit_degrees,
            gif,
            frames: 0,
        })
    }

    /// Draws `world` as the next frame: writes its PNG and appends it to the GIF.
    ///
    /// # Errors
    ///
    /// [`RenderError`] naming the path when a file cannot be written.
    pub fn frame(&mut self, world: &FluidWorld) -> Result<(), RenderError> {
        let camera = self
            .camera
            .rotated(self.orbit_degrees * self.frames as Real);
        let image = self.renderer.render_world(&camera, world, None);
        image.save_png(self.dir.join(format!("frame_{:04}.png", self.frames)))?;
        self.gif.add_frame(&image)?;
        self.frames += 1;
        Ok(())
    }

    /// Frames written so far.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Finishes the GIF.
    ///
    /// # Errors
    ///
    /// [`RenderError`] when the GIF cannot be written.
    pub fn finish(self) -> Result<(), RenderError> {
        self.gif.finish()
    }
}
