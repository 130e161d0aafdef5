//! Headless pictures (feature `render`): the liquid as water by screen-space fluid
//! rendering on the CPU ([`FluidStyle::ScreenSpace`], the default: anisotropic particle
//! ellipsoids splatted to depth, smoothed by a narrow-range filter, shaded with Fresnel
//! reflection, refraction of the scene behind and absorption over the thickness, foam from
//! [`crate::visual::DiffuseParticles`] on top; see the `ssf` module's notes), or as shaded
//! spheres coloured by speed ([`FluidStyle::Spheres`]); the rapier colliders solid and
//! outlined, each kind of collider in its own colour; an optional liquid surface mesh; seen
//! by a fixed or orbiting [`Camera`]. A small z-buffered software rasteriser of this crate
//! draws them (no GPU, no display); `png` and `gif` encode the frames.
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
//! The faces of fixed walls (cuboids) whose plane separates the camera from the fluid's
//! centroid (the front wall and the lid of a tank, not its back wall or floor) are drawn
//! translucent with their edges outlined, so the fluid stays visible; every other collider
//! is opaque, shaded and outlined.

#![cfg_attr(docsrs, doc(cfg(feature = "render")))]

mod image;
mod raster;
mod recorder;
mod ssf;

pub use image::{GifWriter, Image, RenderError};
pub use raster::Rgb;
pub use recorder::{Recorder, WorldDiffuse};

use crate::fluid::FluidSet;
use crate::math::{Real, Vector};
use crate::mesh::{TessellationOptions, TriangleMesh};
use crate::visual::{Anisotropy, AnisotropySettings, DiffuseParticles};
use crate::world::FluidWorld;
use rapier3d::dynamics::{RigidBodySet, RigidBodyType};
use rapier3d::geometry::{ColliderHandle, ColliderSet, ShapeType};
use raster::{Target, lerp3};

/// A pinhole camera looking from `eye` at `target`. See also [`Renderer`]'s example.
///
/// # Examples
///
/// ```
/// use rapier_sph::math::Vector;
/// use rapier_sph::render::Camera;
///
/// // A tank of 2 × 1 × 1 m, seen from 30° to the side and 25° above, filling the view.
/// let camera = Camera::framing(Vector::ZERO, Vector::new(2.0, 1.0, 1.0), 30.0, 25.0);
/// assert_eq!(camera.target, Vector::new(1.0, 0.5, 0.5));
/// // Turned a quarter about the vertical: same target, same distance.
/// let turned = camera.rotated(90.0);
/// let distance = |c: &Camera| (c.eye - c.target).length();
/// assert!((distance(&turned) - distance(&camera)).abs() < 1e-5);
/// ```
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

/// How the liquid is drawn.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, Default)]
pub enum FluidStyle {
    /// Screen-space fluid: a continuous, refracting, reflecting water surface with foam.
    #[default]
    ScreenSpace,
    /// One shaded sphere per particle, coloured by speed (see [`speed_color`]).
    Spheres,
}

/// What to draw and how. See also [`Renderer`]'s example.
///
/// # Examples
///
/// ```
/// use rapier_sph::render::{FluidStyle, RenderOptions, Renderer};
///
/// // Quick previews as spheres coloured by speed, the rest as default.
/// let preview = RenderOptions { width: 320, height: 180, ..Default::default() };
/// let mut renderer = Renderer::new(RenderOptions { style: FluidStyle::Spheres, ..preview });
/// // The final frames as screen-space water, in the same buffers.
/// renderer.options_mut().style = FluidStyle::ScreenSpace;
/// assert_eq!(renderer.options().width, 320);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// How the liquid is drawn. Default [`FluidStyle::ScreenSpace`].
    pub style: FluidStyle,
    /// Screen-space style: the particle ellipsoids ([`crate::visual::Anisotropy`]); their
    /// `particle_radius` (in spacings) is the splat size of a particle in the bulk.
    /// Default: Yu & Turk's settings with `particle_radius` 0.8 (neighbouring splats overlap,
    /// so the surface is closed).
    pub anisotropy: AnisotropySettings,
    /// Screen-space style: half-width of the depth filter's footprint, in particle spacings.
    /// Default 2.5.
    pub smoothing_radius: Real,
    /// Screen-space style: absorption of red, green and blue light per particle spacing of
    /// water (Beer–Lambert over the thickness). Per spacing rather than per metre, so a
    /// scene looks the same at any scale (a game's tank is far shallower than the sea that
    /// makes real water blue). Default `[0.6, 0.22, 0.11]`: a sheet of 3 particles lets
    /// through 17 % of red, 52 % of green and 72 % of blue light, 10 particles 0.2 %, 11 %
    /// and 33 % (blue), 30 particles nearly none (the deep colour).
    pub absorption: Rgb,
    /// Screen-space style: the colour thick water tends to. Default a deep blue.
    pub deep_color: Rgb,
    /// Screen-space style: how far the scene behind the water is shifted by refraction,
    /// per metre of thickness along the surface normal. Default 0.25.
    pub refraction: Real,
    /// Screen-space style: radius of a foam dot in particle spacings. Default 0.45.
    pub foam_scale: Real,
    /// Colour each collider by its kind (fixed walls stone grey, fixed balls, capsules and
    /// cylinders red, fixed triangle meshes green, heightfields sand, compounds violet,
    /// kinematic bodies yellow, dynamic bodies orange) instead of [`Self::collider_color`].
    /// Default true.
    pub collider_palette: bool,
    /// Darken the outlines and creases of the colliders by this fraction (0: off).
    /// Default 0.55.
    pub outlines: Real,
    /// Image width (pixels). Default 640.
    pub width: u32,
    /// Image height (pixels). Default 360.
    pub height: u32,
    /// Supersampling factor per axis (anti-aliasing; cost grows with its square). Default 2.
    pub supersample: u32,
    /// Speeds mapped to the colour scale (m/s): `None` uses 0 to the frame's fastest particle.
    pub speed_range: Option<(Real, Real)>,
    /// Spheres style: drawn sphere radius as a multiple of each fluid's particle spacing.
    /// Default 0.6.
    pub particle_scale: Real,
    /// Draw the particles (turn off to show only a surface mesh). Default true.
    pub draw_particles: bool,
    /// Draw the rapier colliders. Default true.
    pub draw_colliders: bool,
    /// Collider colour. Default a light sand grey.
    pub collider_color: Rgb,
    /// Opacity of the fixed walls between the camera and the fluid. Default 0.12.
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
            style: FluidStyle::ScreenSpace,
            anisotropy: AnisotropySettings {
                particle_radius: 0.8,
                ..AnisotropySettings::default()
            },
            smoothing_radius: 2.5,
            absorption: [0.6, 0.22, 0.11],
            deep_color: [0.01, 0.09, 0.26],
            refraction: 0.25,
            foam_scale: 0.45,
            collider_palette: true,
            outlines: 0.55,
            width: 640,
            height: 360,
            supersample: 2,
            speed_range: None,
            particle_scale: 0.6,
            draw_particles: true,
            draw_colliders: true,
            collider_color: [0.55, 0.52, 0.46],
            front_collider_alpha: 0.12,
            surface_color: [0.12, 0.38, 0.75],
            tessellation: TessellationOptions::default(),
            fog: 0.35,
            collider_colors: Vec::new(),
        }
    }
}

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

/// Where the last screen-space frame's time went (seconds), see
/// [`Renderer::screen_space_timings`].
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct ScreenSpaceTimings {
    /// Particle ellipsoids ([`crate::visual::Anisotropy`]).
    pub anisotropy: f64,
    /// Depth and thickness splats.
    pub splat: f64,
    /// The narrow-range depth filter and the thickness blur.
    pub filter: f64,
    /// Foam dots and shading.
    pub shade: f64,
}

/// Draws frames. Holds its buffers between frames, so rendering a sequence allocates once.
///
/// # Examples
/// ```
/// use rapier_sph::prelude::*;
/// use rapier_sph::render::{Camera, FluidStyle, RenderOptions, Renderer};
/// let mut world = FluidWorld::new();
/// let mut water = Fluid::new(FluidParamsBuilder::water(0.05))?;
/// water.add_block(Vector::ZERO, Vector::splat(0.3))?;
/// world.fluids.insert(water);
/// world.step()?;
/// // A small picture of the water from a camera that frames the block.
/// let options = RenderOptions { width: 64, height: 36, style: FluidStyle::Spheres, ..Default::default() };
/// let camera = Camera::framing(Vector::ZERO, Vector::splat(0.3), 30.0, 25.0);
/// let image = Renderer::new(options).render_world(&camera, &world, None);
/// assert_eq!((image.width, image.height, image.rgb.len()), (64, 36, 64 * 36 * 3));
/// // image.save_png("water.png")?; writes it
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct Renderer {
    timings: ScreenSpaceTimings,
    options: RenderOptions,
    target: Target,
    fluid: ssf::FluidBuffers,
    anisotropy: Option<Anisotropy>,
    splats: Vec<ssf::Splat>,
}

/// The colour of a collider by its kind (see [`RenderOptions::collider_palette`]): dynamic
/// bodies orange, kinematic yellow, and fixed ones by shape (balls, capsules, cylinders and
/// cones red, triangle meshes green, heightfields sand, compounds violet, the rest stone
/// grey). The viewer draws its colliders with the same palette.
///
/// # Examples
/// ```
/// use rapier_sph::rapier3d::prelude::{RigidBodyType, ShapeType};
/// use rapier_sph::render::palette;
/// assert_eq!(palette(ShapeType::Cuboid, Some(RigidBodyType::Dynamic)), [0.86, 0.48, 0.16]);
/// assert_eq!(palette(ShapeType::Cuboid, None), [0.74, 0.73, 0.70]); // a fixed wall
/// ```
pub fn palette(shape: ShapeType, body: Option<RigidBodyType>) -> Rgb {
    match body {
        Some(RigidBodyType::Dynamic) => return [0.86, 0.48, 0.16],
        Some(RigidBodyType::KinematicPositionBased | RigidBodyType::KinematicVelocityBased) => {
            return [0.95, 0.80, 0.18];
        }
        _ => {}
    }
    match shape {
        ShapeType::Ball
        | ShapeType::Capsule
        | ShapeType::Cylinder
        | ShapeType::Cone
        | ShapeType::RoundCylinder
        | ShapeType::RoundCone => [0.85, 0.22, 0.20],
        ShapeType::TriMesh | ShapeType::Polyline => [0.22, 0.66, 0.42],
        ShapeType::HeightField => [0.78, 0.68, 0.46],
        ShapeType::Compound => [0.58, 0.40, 0.78],
        _ => [0.74, 0.73, 0.70],
    }
}

impl Renderer {
    /// A renderer with these options.
    pub fn new(options: RenderOptions) -> Self {
        Self {
            timings: ScreenSpaceTimings::default(),
            options,
            target: Target::new(),
            fluid: ssf::FluidBuffers::default(),
            anisotropy: None,
            splats: Vec::new(),
        }
    }

    /// The options.
    pub fn options(&self) -> &RenderOptions {
        &self.options
    }

    /// Where the last frame's screen-space passes spent their time.
    pub fn screen_space_timings(&self) -> ScreenSpaceTimings {
        self.timings
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
        self.render_world_with(camera, world, surface, &[])
    }

    /// [`Self::render_world`] with foam, spray and bubbles (screen-space style; the spheres
    /// style ignores them).
    pub fn render_world_with(
        &mut self,
        camera: &Camera,
        world: &FluidWorld,
        surface: Option<&TriangleMesh>,
        diffuse: &[&DiffuseParticles],
    ) -> Image {
        self.draw(
            camera,
            &world.fluids,
            &world.physics.colliders,
            Some(&world.physics.bodies),
            surface,
            diffuse,
        )
    }

    /// Renders the particles of `fluids`, the colliders of `colliders` and an optional
    /// liquid surface mesh. Colliders are coloured by shape only (their bodies are not
    /// known here; [`Self::render_world`] colours kinematic and dynamic bodies too).
    pub fn render(
        &mut self,
        camera: &Camera,
        fluids: &FluidSet,
        colliders: &ColliderSet,
        surface: Option<&TriangleMesh>,
    ) -> Image {
        self.draw(camera, fluids, colliders, None, surface, &[])
    }

    fn draw(
        &mut self,
        camera: &Camera,
        fluids: &FluidSet,
        colliders: &ColliderSet,
        bodies: Option<&RigidBodySet>,
        surface: Option<&TriangleMesh>,
        diffuse: &[&DiffuseParticles],
    ) -> Image {
        let o = &self.options;
        let ss = o.supersample.max(1) as usize;
        let (w, h) = (o.width.max(1) as usize * ss, o.height.max(1) as usize * ss);
        let focal = 0.5 * h as Real / (0.5 * o.fov_or(camera)).tan();
        let top = [0.62, 0.70, 0.80];
        let bottom = [0.93, 0.93, 0.90];
        self.target.reset(w, h, focal, top, bottom);
        let view = View::new(camera, fluids, o.fog, lerp3(top, bottom, 0.5));

        // Opaque colliders first, translucent ones after the fluid, then the feature edges
        // of the translucent ones (so a see-through tank still shows its shape).
        let mut front = Front::default();
        if self.options.draw_colliders {
            for (handle, mesh) in TriangleMesh::from_colliders(colliders, &o.tessellation) {
                if !mesh.vertices.is_empty() {
                    self.draw_collider(&view, (handle, &mesh), colliders, bodies, &mut front);
                }
            }
            if self.options.outlines > 0.0 {
                self.target
                    .outlines(self.options.outlines.clamp(0.0, 1.0), 0.04);
            }
        }
        if let Some(mesh) = surface {
            self.draw_surface(&view, mesh);
        }
        if self.options.draw_particles {
            match self.options.style {
                FluidStyle::Spheres => self.draw_spheres(&view, fluids),
                FluidStyle::ScreenSpace => {
                    let o = self.options.clone();
                    self.screen_space(&o, fluids, diffuse, &view);
                }
            }
        }
        self.draw_front(front);
        let (w, h, rgb) = self.target.resolve(ss);
        Image {
            width: w as u32,
            height: h as u32,
            rgb,
        }
    }

    /// The colour a collider is drawn in, and whether it is a fixed wall (a cuboid or a
    /// half-space) that may be drawn see-through where it stands between the camera and the
    /// fluid. A collider given its own colour (`collider_colors`) is drawn in it and always
    /// opaque; obstacles (balls, capsules, meshes, heightfields, compounds) and moving
    /// bodies stay solid wherever they are.
    fn collider_style(
        &self,
        handle: ColliderHandle,
        colliders: &ColliderSet,
        bodies: Option<&RigidBodySet>,
    ) -> (Rgb, bool) {
        let o = &self.options;
        let c = &colliders[handle];
        let body = c
            .parent()
            .and_then(|b| bodies.and_then(|set| set.get(b)))
            .map(|b| b.body_type());
        if let Some((_, color)) = o.collider_colors.iter().find(|(c, _)| *c == handle) {
            return (*color, false);
        }
        let color = if o.collider_palette {
            palette(c.shape().shape_type(), body)
        } else {
            o.collider_color
        };
        let moving = body.is_some_and(|b| b != RigidBodyType::Fixed);
        let wall = !moving
            && matches!(
                c.shape().shape_type(),
                ShapeType::Cuboid | ShapeType::RoundCuboid | ShapeType::HalfSpace
            );
        (color, wall)
    }

    /// Draws one collider's triangles: opaque ones now, see-through ones (and the feature
    /// edges outlining them) kept in `front` for after the fluid.
    fn draw_collider(
        &mut self,
        view: &View,
        (handle, mesh): (ColliderHandle, &TriangleMesh),
        colliders: &ColliderSet,
        bodies: Option<&RigidBodySet>,
        front: &mut Front,
    ) {
        let (base_color, wall) = self.collider_style(handle, colliders, bodies);
        // A wall's face is see-through when its plane separates the camera from the fluid
        // (the front wall and the lid of a tank; not its back wall or floor).
        let see_through = |p: &[Vector; 3]| {
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            wall && (n.dot(-p[0]) > 0.0) != (n.dot(view.fluid_center - p[0]) > 0.0)
        };
        let triangles: Vec<[Vector; 3]> = mesh
            .triangles
            .iter()
            .map(|t| t.map(|i| view.to_view(mesh.vertices[i as usize])))
            .collect();
        // Walls with see-through faces are outlined by their feature edges (below); their
        // opaque faces are not tagged, since seen through their own see-through end faces
        // two faces of a thin wall alternate pixel by pixel.
        let any_in_front = triangles.iter().any(see_through);
        let id = if any_in_front {
            raster::NO_ID
        } else {
            handle.into_raw_parts().0
        };
        for p in triangles {
            let mut n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
            let center = (p[0] + p[1] + p[2]) / 3.0;
            let in_front = see_through(&p);
            if n.dot(-center) < 0.0 {
                n = -n; // two-sided: light the side we see
            }
            let shade = 0.35 + 0.65 * n.dot(view.light).max(0.0);
            let col = view.fogged(base_color.map(|c| c * shade), -center.z);
            if in_front {
                front.translucent.push((p, col));
            } else {
                self.target.solid_triangle(p, col, id, n);
            }
        }
        if any_in_front {
            for (a, b) in mesh.feature_edges(0.5) {
                front.edges.push((view.to_view(a), view.to_view(b)));
            }
        }
    }

    /// A liquid surface mesh, smooth-shaded with a Fresnel sheen.
    fn draw_surface(&mut self, view: &View, mesh: &TriangleMesh) {
        let o = &self.options;
        let normals = mesh.vertex_normals();
        let colors: Vec<Rgb> = mesh
            .vertices
            .iter()
            .zip(&normals)
            .map(|(v, n)| {
                let pv = view.to_view(*v);
                let nv = view.direction(*n);
                let view_dir = (-pv).normalize_or_zero();
                let nv = if nv.dot(view_dir) < 0.0 { -nv } else { nv };
                let diffuse = nv.dot(view.light).max(0.0);
                let spec = nv.dot(view.half).max(0.0).powi(40);
                let fresnel = (1.0 - nv.dot(view_dir).max(0.0)).powi(3);
                let c = o.surface_color.map(|c| c * (0.3 + 0.7 * diffuse));
                let c = lerp3(c, [0.85, 0.92, 1.0], 0.35 * fresnel);
                view.fogged(c.map(|c| c + 0.6 * spec), -pv.z)
            })
            .collect();
        for t in &mesh.triangles {
            let p = t.map(|i| view.to_view(mesh.vertices[i as usize]));
            let c = t.map(|i| colors[i as usize]);
            self.target.triangle(p, c, 1.0);
        }
    }

    /// Particles as shaded spheres coloured by speed.
    fn draw_spheres(&mut self, view: &View, fluids: &FluidSet) {
        let o = &self.options;
        let (lo, hi) = o.speed_range.unwrap_or_else(|| {
            let speeds = fluids.iter().flat_map(|(_, f)| f.velocities());
            (0.0, speeds.fold(0.0, |m: Real, v| m.max(v.length())))
        });
        let inv_range = if hi > lo { 1.0 / (hi - lo) } else { 0.0 };
        for (_, f) in fluids.iter() {
            let r = o.particle_scale * f.params().particle_spacing;
            for (p, v) in f.positions().iter().zip(f.velocities()) {
                let base = speed_color((v.length() - lo) * inv_range);
                self.target.sphere(view.to_view(*p), r, |n, d| {
                    let diffuse = n.dot(view.light).max(0.0);
                    let spec = n.dot(view.half).max(0.0).powi(32);
                    let c = base.map(|c| c * (0.35 + 0.65 * diffuse) + 0.35 * spec);
                    view.fogged(c, d)
                });
            }
        }
    }

    /// The see-through collider faces over the fluid, then their outlines.
    fn draw_front(&mut self, front: Front) {
        for (p, col) in front.translucent {
            self.target
                .triangle(p, [col; 3], self.options.front_collider_alpha);
        }
        let line_width = self.options.supersample.max(1) as Real;
        let veil = match self.options.style {
            FluidStyle::ScreenSpace if self.options.draw_particles => &self.fluid.smooth[..],
            _ => &[],
        };
        for (a, b) in front.edges {
            self.target.line(
                a,
                b,
                raster::LineStyle {
                    color: [0.25, 0.25, 0.24],
                    alpha: 0.5,
                    width: line_width,
                    alpha_behind: 0.15,
                },
                veil,
            );
        }
    }

    fn screen_space(
        &mut self,
        o: &RenderOptions,
        fluids: &FluidSet,
        diffuse: &[&DiffuseParticles],
        view: &View,
    ) {
        let (w, h) = (self.target.width, self.target.height);
        self.timings = ScreenSpaceTimings::default();
        let clock = std::time::Instant::now();
        self.fluid.reset(w, h);
        let spacing = self.splat_fluids(o, fluids, view);
        if spacing <= 0.0 {
            return;
        }
        self.timings.splat = clock.elapsed().as_secs_f64() - self.timings.anisotropy;
        let t = std::time::Instant::now();
        let max_px = (24 * o.supersample.max(1)) as usize;
        self.fluid.smooth_depth(
            self.target.focal,
            o.smoothing_radius * spacing,
            spacing,
            max_px,
        );
        self.timings.filter = t.elapsed().as_secs_f64();
        let t = std::time::Instant::now();
        self.foam(o.foam_scale * spacing, spacing, diffuse, view);
        let shade = ssf::Shade {
            absorption: o.absorption,
            spacing,
            deep: o.deep_color,
            foam: [0.93, 0.96, 1.0],
            light: view.light,
            refraction: o.refraction,
            basis: view.basis,
            fog: o.fog,
            fog_start: 0.8 * view.target_distance,
            background: view.background,
            sky_top: [0.45, 0.62, 0.88],
            sky_horizon: [0.88, 0.92, 0.96],
            ground: [0.30, 0.30, 0.28],
        };
        self.fluid.shade(&mut self.target, &shade);
        self.timings.shade = t.elapsed().as_secs_f64();
    }

    /// Splats every fluid's particle ellipsoids into the depth and thickness buffers;
    /// returns the largest particle spacing (0 when there is no particle).
    fn splat_fluids(&mut self, o: &RenderOptions, fluids: &FluidSet, view: &View) -> Real {
        let mut spacing: Real = 0.0;
        for (_, f) in fluids.iter() {
            if f.is_empty() {
                continue;
            }
            spacing = spacing.max(f.params().particle_spacing);
            let a = match &mut self.anisotropy {
                Some(a) if *a.settings() == o.anisotropy => a,
                slot => {
                    // Settings were validated by `RenderOptions` users; fall back to the
                    // defaults if they are out of range rather than draw nothing.
                    let a = Anisotropy::new(o.anisotropy).unwrap_or_else(|_| {
                        Anisotropy::new(AnisotropySettings::default()).expect("defaults are valid")
                    });
                    slot.insert(a)
                }
            };
            self.splats.clear();
            let t = std::time::Instant::now();
            let ellipsoids = a.compute(f);
            self.timings.anisotropy += t.elapsed().as_secs_f64();
            for e in ellipsoids {
                let rows = [0, 1, 2].map(|k| view.direction(e.axes[k]) / e.radii[k].max(1e-9));
                self.splats.push(ssf::Splat {
                    center: view.to_view(e.center),
                    inv_rows: rows,
                    max_radius: e.radii[0],
                });
            }
            self.fluid.splat_all(&self.target, &self.splats);
        }
        spacing
    }

    /// Foam, spray and bubbles as dots of coverage over the liquid.
    fn foam(&mut self, r: Real, spacing: Real, diffuse: &[&DiffuseParticles], view: &View) {
        for d in diffuse {
            for (p, k) in d.positions().iter().zip(d.kinds()) {
                // Coverage per dot: a lone dot is a faint fleck, a few overlapping ones
                // turn white.
                let weight = match k {
                    crate::visual::DiffuseKind::Foam => 0.45,
                    crate::visual::DiffuseKind::Spray => 0.4,
                    crate::visual::DiffuseKind::Bubble => 0.12,
                };
                self.fluid
                    .foam_dot(&self.target, view.to_view(*p), r, weight, 2.0 * spacing);
            }
        }
    }
}

/// The camera's view of one frame: the basis world points are taken into (view space, the
/// camera at the origin looking down −z), the light, and the fog.
struct View {
    eye: Vector,
    basis: (Vector, Vector, Vector),
    /// Light from above-left, slightly from the camera side, in view space.
    light: Vector,
    /// Blinn's half vector between the light and the view direction.
    half: Vector,
    target_distance: Real,
    fog: Real,
    background: Rgb,
    /// View-space point the see-through test looks from: the fluid's centroid (the
    /// camera's target when there is no particle).
    fluid_center: Vector,
}

impl View {
    fn new(camera: &Camera, fluids: &FluidSet, fog: Real, background: Rgb) -> Self {
        let light = Vector::new(-0.45, 0.75, 0.5).normalize();
        let mut view = Self {
            eye: camera.eye,
            basis: camera.basis(),
            light,
            half: (light + Vector::Z).normalize(),
            target_distance: (camera.eye - camera.target).length().max(1e-6),
            fog,
            background,
            fluid_center: Vector::ZERO,
        };
        let (mut centroid, mut count) = (Vector::ZERO, 0usize);
        for (_, f) in fluids.iter() {
            for p in f.positions() {
                centroid += *p;
            }
            count += f.len();
        }
        view.fluid_center = if count > 0 {
            view.to_view(centroid / count as Real)
        } else {
            view.to_view(camera.target)
        };
        view
    }

    fn to_view(&self, p: Vector) -> Vector {
        self.direction(p - self.eye)
    }

    /// A world direction in view space.
    fn direction(&self, d: Vector) -> Vector {
        let (right, up, back) = self.basis;
        Vector::new(d.dot(right), d.dot(up), d.dot(back))
    }

    /// `c` seen through the fog at view depth `d`.
    fn fogged(&self, c: Rgb, d: Real) -> Rgb {
        let t = ((d - 0.8 * self.target_distance) / (0.8 * self.target_distance)).clamp(0.0, 1.0);
        lerp3(c, self.background, self.fog * t)
    }
}

/// Collider faces drawn after the fluid: see-through triangles and their outlines.
#[derive(Default)]
struct Front {
    translucent: Vec<([Vector; 3], Rgb)>,
    edges: Vec<(Vector, Vector)>,
}

impl RenderOptions {
    fn fov_or(&self, camera: &Camera) -> Real {
        camera.fov_y_degrees.clamp(1.0, 170.0).to_radians()
    }
}
