//! Frames of a running world: foam for every fluid ([`WorldDiffuse`]) and an example's
//! `--render DIR` output of numbered PNGs and one GIF ([`Recorder`]).

use super::{Camera, GifWriter, RenderError, RenderOptions, Renderer};
use crate::math::Real;
use crate::visual::DiffuseParticles;
use crate::world::FluidWorld;
use std::path::{Path, PathBuf};

/// Spray, foam and bubbles for every fluid of a [`FluidWorld`]: one
/// [`DiffuseParticles`] per fluid, stepped after each world step, drawn by
/// [`Renderer::render_world_with`].
///
/// # Examples
///
/// ```
/// use rapier_sph::render::{Camera, RenderOptions, Renderer, WorldDiffuse};
/// use rapier_sph::visual::DiffuseSettings;
/// # use rapier_sph::scenes::{dam_break, DamBreakConfig};
/// # let params = rapier_sph::FluidParamsBuilder::water(0.05).build()?;
/// # let mut scene = dam_break(&DamBreakConfig::tower(params, 0.4))?;
/// let mut foam = WorldDiffuse::new(DiffuseSettings::default())?;
/// let mut renderer = Renderer::new(RenderOptions { width: 64, height: 36, ..Default::default() });
/// let camera = Camera::framing(scene.tank_min, scene.tank_max, 30.0, 25.0);
/// for _ in 0..3 {
///     scene.world.step()?;
///     foam.step(&scene.world)?;
/// }
/// let image = renderer.render_world_with(&camera, &scene.world, None, &foam.layers());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug)]
pub struct WorldDiffuse {
    settings: crate::visual::DiffuseSettings,
    fluids: Vec<(crate::FluidHandle, DiffuseParticles)>,
}

impl WorldDiffuse {
    /// No diffuse particle yet; every fluid gets these settings.
    ///
    /// # Errors
    /// [`crate::SphError::InvalidParameter`] when a setting is out of range.
    pub fn new(settings: crate::visual::DiffuseSettings) -> crate::SphResult<Self> {
        settings.validate()?;
        Ok(Self {
            settings,
            fluids: Vec::new(),
        })
    }

    /// Advances every fluid's diffuse particles by the world's time step (call after each
    /// [`FluidWorld::step`]).
    ///
    /// # Errors
    /// [`crate::SphError::InvalidTimeStep`] when the world's time step is not positive.
    pub fn step(&mut self, world: &FluidWorld) -> crate::SphResult<()> {
        let dt = world.physics.integration_parameters.dt;
        self.fluids.retain(|(h, _)| world.fluids.get(*h).is_some());
        for (handle, fluid) in world.fluids.iter() {
            let k = match self.fluids.iter().position(|(h, _)| *h == handle) {
                Some(k) => k,
                None => {
                    self.fluids
                        .push((handle, DiffuseParticles::new(self.settings)?));
                    self.fluids.len() - 1
                }
            };
            self.fluids[k].1.step(fluid, world.physics.gravity, dt)?;
        }
        Ok(())
    }

    /// The diffuse particles of each fluid, for [`Renderer::render_world_with`].
    pub fn layers(&self) -> Vec<&DiffuseParticles> {
        self.fluids.iter().map(|(_, d)| d).collect()
    }

    /// Diffuse particles alive in all fluids.
    pub fn len(&self) -> usize {
        self.fluids.iter().map(|(_, d)| d.len()).sum()
    }

    /// `true` when there is none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// What an example's `--render DIR` writes: numbered PNG frames `frame_0000.png`, … and one
/// animated GIF `<name>.gif` in `DIR`, each frame drawn by a [`Renderer`] from a camera that
/// may orbit a fixed number of degrees per frame.
///
/// # Examples
/// See [`Recorder::create`]; `examples/boat.rs` and `examples/dam_break.rs` use it.
pub struct Recorder {
    dir: PathBuf,
    renderer: Renderer,
    camera: Camera,
    orbit_degrees: Real,
    gif: GifWriter,
    frames: usize,
    diffuse: Option<WorldDiffuse>,
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
    /// ```
    /// use rapier_sph::math::Vector;
    /// use rapier_sph::render::{Camera, Recorder, RenderOptions};
    /// use rapier_sph::{Fluid, FluidParamsBuilder, FluidWorld};
    ///
    /// # fn main() -> Result<(), Box<dyn std::error::Error>> {
    /// let mut world = FluidWorld::new();
    /// let mut water = Fluid::new(FluidParamsBuilder::water(0.05))?;
    /// water.add_block(Vector::ZERO, Vector::splat(0.3))?;
    /// world.fluids.insert(water);
    /// let camera = Camera::framing(Vector::ZERO, Vector::splat(0.3), 30.0, 25.0);
    /// let options = RenderOptions { width: 48, height: 27, ..Default::default() };
    /// let out = std::env::temp_dir().join(format!("rapier_sph_doc_rec_{}", std::process::id()));
    /// let mut pictures = Recorder::create(&out, "splash", options, camera, 0.0, 4)?;
    /// for step in 0..4 {
    ///     world.step()?;
    ///     if step % 2 == 0 {
    ///         pictures.frame(&world)?; // out/frame_0000.png, ... and a frame of out/splash.gif
    ///     }
    /// }
    /// pictures.finish()?;
    /// assert!(out.join("frame_0001.png").exists() && out.join("splash.gif").exists());
    /// std::fs::remove_dir_all(&out)?;
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
            diffuse: None,
        })
    }

    /// Draws foam, spray and bubbles from now on: call [`Self::step`] after every world
    /// step so they follow the liquid.
    ///
    /// # Errors
    /// [`crate::SphError::InvalidParameter`] when a setting is out of range.
    pub fn with_diffuse(
        mut self,
        settings: crate::visual::DiffuseSettings,
    ) -> crate::SphResult<Self> {
        self.diffuse = Some(WorldDiffuse::new(settings)?);
        Ok(self)
    }

    /// Advances the diffuse particles (if [`Self::with_diffuse`] turned them on) after a
    /// world step.
    ///
    /// # Errors
    /// See [`WorldDiffuse::step`].
    pub fn step(&mut self, world: &FluidWorld) -> crate::SphResult<()> {
        match &mut self.diffuse {
            Some(d) => d.step(world),
            None => Ok(()),
        }
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
        let layers = self
            .diffuse
            .as_ref()
            .map(|d| d.layers())
            .unwrap_or_default();
        let image = self
            .renderer
            .render_world_with(&camera, world, None, &layers);
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
