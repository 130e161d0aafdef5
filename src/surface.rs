//! Liquid surfaces (feature `surface`): a triangle mesh around the particles, reconstructed
//! by [`splashsurf_lib`] (the SPlisHSPlasH group's marching-cubes reconstruction) — the
//! Unity paper's future work.
//!
//! The particles' volume sets splashsurf's particle radius: a particle on the fluid's
//! lattice fills `spacing³`, so the sphere of equal volume has radius
//! `r = spacing·(3/(4π))^(1/3) ≈ 0.62·spacing`. With that radius the surface of a block at
//! rest encloses the block's volume (tested within 10 %).

#![cfg_attr(docsrs, doc(cfg(feature = "surface")))]

use crate::fluid::{Fluid, FluidSet};
use crate::math::{Real, Vector};
use crate::mesh::TriangleMesh;
use splashsurf_lib::nalgebra::Vector3;
use std::borrow::Cow;
use std::fmt;

/// Reconstruction settings, relative to each fluid's particle spacing.
///
/// # Examples
///
/// ```
/// use rapier_sph::math::Vector;
/// use rapier_sph::surface::{SurfaceOptions, reconstruct};
/// use rapier_sph::{Fluid, FluidParamsBuilder};
///
/// let mut fluid = Fluid::new(FluidParamsBuilder::water(0.05).build()?)?;
/// fluid.add_block(Vector::ZERO, Vector::splat(0.3))?;
/// // The smooth preset, on the calling thread only (the other cores keep stepping).
/// let options = SurfaceOptions {
///     multi_threading: false,
///     ..SurfaceOptions::smooth()
/// };
/// let mesh = reconstruct(&fluid, &options)?;
/// assert!(!mesh.is_empty() && mesh.signed_volume() > 0.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceOptions {
    /// Kernel support radius of the reconstruction as a multiple of the spacing. Default 2.5
    /// (larger: smoother, blobbier surfaces).
    pub support_factor: Real,
    /// Marching-cubes cell size as a multiple of the spacing. Default 0.5 (smaller: finer
    /// meshes, slower).
    pub cube_size_factor: Real,
    /// Iso-surface threshold as a fraction of the rest density. Default 0.6 (splashsurf's).
    pub iso_surface_threshold: Real,
    /// Let splashsurf use threads. Default true.
    pub multi_threading: bool,
    /// Reconstruct around Laplacian-smoothed particle centers instead of the particles
    /// (Yu & Turk 2013's `x̃ = (1 − λ)x + λ·x̄ʷ`, see [`crate::visual::Anisotropy`]): `λ` in
    /// `[0, 1]`, 0 off. splashsurf_lib 0.14 has no anisotropic kernels; the smoothed centers
    /// are the half of Yu & Turk's method that flattens a surface made of particle layers,
    /// but alone they pull the surface in: a settled block of 12 × 8 × 12 particles loses
    /// 33 % of its volume at λ = 0.9, 19 % at 0.5 (`tests/surface.rs`). Default 0 (off).
    pub smoothed_centers: Real,
    /// splashsurf's marching-cubes cleanup (Moore & Warren's mesh displacement: vertices
    /// snapped to grid points, slivers collapsed). Default false.
    pub cleanup: bool,
    /// splashsurf's barnacle decimation (merges the small bumps marching cubes leaves on
    /// flat parts). Default false.
    pub decimate_barnacles: bool,
    /// Iterations of Laplacian smoothing of the mesh (each vertex moved by
    /// [`Self::mesh_smoothing`] towards the mean of its neighbours). Default 0.
    pub mesh_smoothing_iterations: usize,
    /// How far each smoothing iteration moves a vertex to its neighbours' mean, in `[0, 1]`.
    /// Default 0.5.
    pub mesh_smoothing: Real,
}

impl Default for SurfaceOptions {
    fn default() -> Self {
        Self {
            support_factor: 2.5,
            cube_size_factor: 0.5,
            iso_surface_threshold: 0.6,
            multi_threading: true,
            smoothed_centers: 0.0,
            cleanup: false,
            decimate_barnacles: false,
            mesh_smoothing_iterations: 0,
            mesh_smoothing: 0.5,
        }
    }
}

impl SurfaceOptions {
    /// Settings for a smooth surface at coarse resolutions (the shipped scenes': 2,000 to
    /// 10,000 particles, streams one or two particles thick): a kernel of 3 spacings and an
    /// iso-surface at 0.4 of the rest density (the defaults, 2.5 and 0.6, leave holes in
    /// those streams), cubes of 0.6 spacings, marching-cubes cleanup, barnacle decimation
    /// and 10 iterations of mesh smoothing (half-way steps). On a settled block of
    /// 12 × 8 × 12 particles (`tests/surface.rs`) against the defaults: the lid's mean
    /// normal deviation 1.4° → 0.35°, 5,992 → 3,664 triangles, enclosed volume +1 % → +16 %
    /// of the particles' (the lower threshold puts the surface farther out). Smoothed
    /// centers stay off: they shrink that block by a third. Cost in `docs/outputs.md`.
    pub fn smooth() -> Self {
        Self {
            support_factor: 3.0,
            iso_surface_threshold: 0.4,
            cube_size_factor: 0.6,
            cleanup: true,
            decimate_barnacles: true,
            mesh_smoothing_iterations: 10,
            mesh_smoothing: 0.5,
            ..Self::default()
        }
    }
}

/// A reconstruction failed.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceError {
    /// splashsurf's message (with its causes).
    pub message: String,
}

impl fmt::Display for SurfaceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "surface reconstruction failed: {}", self.message)
    }
}

impl std::error::Error for SurfaceError {}

/// The radius of the sphere with the volume of one lattice particle (`spacing³`).
pub fn volume_radius(spacing: Real) -> Real {
    spacing * (3.0 / (4.0 * std::f32::consts::PI)).cbrt()
}

/// The surface of one fluid (an empty mesh for an empty fluid).
///
/// # Errors
/// [`SurfaceError`] with splashsurf's message when the reconstruction fails.
pub fn reconstruct(fluid: &Fluid, options: &SurfaceOptions) -> Result<TriangleMesh, SurfaceError> {
    reconstruct_points(
        fluid.positions(),
        fluid.params().particle_spacing,
        fluid.params().rest_density,
        options,
    )
}

/// The surface around `positions`, particles on a lattice of `spacing` at rest.
///
/// # Errors
/// [`SurfaceError`] with splashsurf's message when the reconstruction fails.
pub fn reconstruct_points(
    positions: &[Vector],
    spacing: Real,
    rest_density: Real,
    options: &SurfaceOptions,
) -> Result<TriangleMesh, SurfaceError> {
    check_settings(spacing, rest_density, options)?;
    if positions.is_empty() {
        return Ok(TriangleMesh::default());
    }
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        return Err(SurfaceError {
            message: format!("particle {i} has a non-finite position"),
        });
    }
    let centers = centers(positions, spacing, options)?;
    let points: Vec<Vector3<f32>> = centers
        .iter()
        .map(|p| Vector3::new(p.x, p.y, p.z))
        .collect();
    let mut params = splashsurf_lib::Parameters::new(
        volume_radius(spacing),
        options.support_factor * spacing,
        options.cube_size_factor * spacing,
    );
    params.rest_density = rest_density;
    params.iso_surface_threshold = options.iso_surface_threshold;
    params.enable_multi_threading = options.multi_threading;
    let mut r = splashsurf_lib::reconstruct_surface::<i64, f32>(&points, &params).map_err(|e| {
        let mut message = e.to_string();
        let mut src = std::error::Error::source(&e);
        while let Some(s) = src {
            message.push_str(": ");
            message.push_str(&s.to_string());
            src = s.source();
        }
        SurfaceError { message }
    })?;
    postprocess(&mut r, options);
    let mesh = &r.mesh;
    Ok(TriangleMesh {
        vertices: mesh
            .vertices
            .iter()
            .map(|v| Vector::new(v.x, v.y, v.z))
            .collect(),
        triangles: mesh
            .triangles
            .iter()
            .map(|t| [t[0] as u32, t[1] as u32, t[2] as u32])
            .collect(),
    })
}

/// Refuses settings splashsurf cannot build from: the smoothing fractions outside [0, 1],
/// and a spacing, rest density or size factor that is not positive and finite.
fn check_settings(
    spacing: Real,
    rest_density: Real,
    options: &SurfaceOptions,
) -> Result<(), SurfaceError> {
    if !(0.0..=1.0).contains(&options.smoothed_centers)
        || !(0.0..=1.0).contains(&options.mesh_smoothing)
    {
        return Err(SurfaceError {
            message: format!(
                "smoothed_centers and mesh_smoothing must be in [0, 1], got {} and {}",
                options.smoothed_centers, options.mesh_smoothing
            ),
        });
    }
    for (what, v) in [
        ("spacing", spacing),
        ("rest density", rest_density),
        ("support_factor", options.support_factor),
        ("cube_size_factor", options.cube_size_factor),
        ("iso_surface_threshold", options.iso_surface_threshold),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(SurfaceError {
                message: format!("{what} must be positive and finite, got {v}"),
            });
        }
    }
    Ok(())
}

/// The centers the surface is built around: the particles' positions, or with
/// [`SurfaceOptions::smoothed_centers`] above 0 the Laplacian-smoothed centers
/// [`crate::visual::Anisotropy`] computes (borrowed when unchanged, to avoid a copy).
fn centers<'a>(
    positions: &'a [Vector],
    spacing: Real,
    options: &SurfaceOptions,
) -> Result<Cow<'a, [Vector]>, SurfaceError> {
    if options.smoothed_centers <= 0.0 {
        return Ok(Cow::Borrowed(positions));
    }
    let mut a = crate::visual::Anisotropy::new(crate::visual::AnisotropySettings {
        // The reconstruction kernel's support: the centers are smoothed over the
        // neighbourhood the surface is built from.
        radius: options.support_factor,
        smoothing: options.smoothed_centers,
        ..Default::default()
    })
    .map_err(|e| SurfaceError {
        message: e.to_string(),
    })?;
    Ok(Cow::Owned(
        a.compute_points(positions, spacing)
            .iter()
            .map(|e| e.center)
            .collect(),
    ))
}

/// splashsurf's post-processing of the marching-cubes mesh, each step only when `options`
/// asks for it, in this order: [`SurfaceOptions::cleanup`],
/// [`SurfaceOptions::decimate_barnacles`], [`SurfaceOptions::mesh_smoothing_iterations`].
fn postprocess(r: &mut splashsurf_lib::SurfaceReconstruction<i64, f32>, options: &SurfaceOptions) {
    if options.cleanup {
        splashsurf_lib::postprocessing::marching_cubes_cleanup(
            &mut r.mesh,
            &r.grid,
            None,
            5,
            false,
        );
    }
    if options.decimate_barnacles {
        splashsurf_lib::postprocessing::decimation(&mut r.mesh, false);
    }
    if options.mesh_smoothing_iterations > 0 {
        use splashsurf_lib::mesh::Mesh3d;
        let connectivity = r.mesh.vertex_vertex_connectivity();
        let weights = vec![1.0f32; r.mesh.vertices.len()];
        splashsurf_lib::postprocessing::par_laplacian_smoothing_inplace(
            &mut r.mesh,
            &connectivity,
            options.mesh_smoothing_iterations,
            options.mesh_smoothing,
            &weights,
        );
    }
}

/// The surfaces of every fluid of the set, in one mesh.
///
/// # Errors
/// [`SurfaceError`] with splashsurf's message when the reconstruction fails.
pub fn reconstruct_fluids(
    fluids: &FluidSet,
    options: &SurfaceOptions,
) -> Result<TriangleMesh, SurfaceError> {
    let mut out = TriangleMesh::default();
    for (_, f) in fluids.iter() {
        let m = reconstruct(f, options)?;
        out.append_transformed(&m, &crate::math::Pose::IDENTITY);
    }
    Ok(out)
}

/// A mesh made by a [`SurfaceWorker`].
#[derive(Clone, Debug)]
pub struct SurfaceFrame {
    /// The number [`SurfaceWorker::submit`] returned for the positions it was made from.
    pub job: u64,
    /// The surface.
    pub mesh: TriangleMesh,
    /// Seconds the reconstruction took on the worker.
    pub seconds: f64,
}

struct Job {
    id: u64,
    positions: Vec<Vector>,
    spacing: Real,
    rest_density: Real,
}

/// Surface reconstruction on a worker thread, for a game that wants a mesh at 10–20 Hz
/// while it steps and draws at its own rate: [`Self::submit`] copies the positions and
/// returns at once, [`Self::try_take`] hands back the newest finished mesh, if any, without
/// waiting. One job at a time: a submit while the worker is busy is refused (returns
/// `None`), so a slow reconstruction drops frames instead of queueing them.
///
/// splashsurf's own threads run on rayon's global pool, which the fluid's step uses too: with
/// [`SurfaceOptions::multi_threading`] off the worker takes one core and leaves the others
/// to the simulation.
///
/// # Examples
///
/// ```
/// use rapier_sph::surface::{SurfaceOptions, SurfaceWorker};
/// use rapier_sph::{Fluid, FluidParamsBuilder};
/// use rapier_sph::math::Vector;
///
/// let mut fluid = Fluid::new(FluidParamsBuilder::water(0.05).build()?)?;
/// fluid.add_block(Vector::ZERO, Vector::new(0.3, 0.3, 0.3))?;
/// let mut worker = SurfaceWorker::spawn(SurfaceOptions {
///     multi_threading: false,
///     ..SurfaceOptions::smooth()
/// });
/// let job = worker.submit(&fluid).expect("the worker is idle");
/// // ... step and draw; each frame: `if let Some(frame) = worker.try_take() { ... }`
/// let frame = worker.wait().expect("one job was submitted")?;
/// assert_eq!(frame.job, job);
/// assert!(!frame.mesh.triangles.is_empty());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct SurfaceWorker {
    jobs: Option<std::sync::mpsc::Sender<Job>>,
    results: std::sync::mpsc::Receiver<Result<SurfaceFrame, SurfaceError>>,
    thread: Option<std::thread::JoinHandle<()>>,
    next_id: u64,
    busy: bool,
}

impl SurfaceWorker {
    /// Starts the worker thread.
    pub fn spawn(options: SurfaceOptions) -> Self {
        let (job_tx, job_rx) = std::sync::mpsc::channel::<Job>();
        let (res_tx, res_rx) = std::sync::mpsc::channel();
        let thread = std::thread::Builder::new()
            .name("rapier-sph surface".into())
            .spawn(move || {
                for job in job_rx {
                    let t = std::time::Instant::now();
                    let mesh =
                        reconstruct_points(&job.positions, job.spacing, job.rest_density, &options);
                    let out = mesh.map(|mesh| SurfaceFrame {
                        job: job.id,
                        mesh,
                        seconds: t.elapsed().as_secs_f64(),
                    });
                    if res_tx.send(out).is_err() {
                        break;
                    }
                }
            })
            .ok();
        Self {
            jobs: Some(job_tx),
            results: res_rx,
            thread,
            next_id: 0,
            busy: false,
        }
    }

    /// Copies `fluid`'s positions for reconstruction. Returns the job's number, or `None`
    /// while the previous job is not finished (or the worker thread could not start).
    pub fn submit(&mut self, fluid: &Fluid) -> Option<u64> {
        self.submit_points(
            fluid.positions().to_vec(),
            fluid.params().particle_spacing,
            fluid.params().rest_density,
        )
    }

    /// [`Self::submit`] for any particles at `spacing` and `rest_density`.
    pub fn submit_points(
        &mut self,
        positions: Vec<Vector>,
        spacing: Real,
        rest_density: Real,
    ) -> Option<u64> {
        if self.busy || self.thread.is_none() {
            return None;
        }
        let id = self.next_id;
        let job = Job {
            id,
            positions,
            spacing,
            rest_density,
        };
        self.jobs.as_ref()?.send(job).ok()?;
        self.next_id += 1;
        self.busy = true;
        Some(id)
    }

    /// `true` while a job is being reconstructed.
    pub fn is_busy(&mut self) -> bool {
        self.busy
    }

    /// The finished mesh, if the worker has one; never waits.
    ///
    /// # Errors
    /// Inside the option: the job's [`SurfaceError`].
    pub fn try_take(&mut self) -> Option<Result<SurfaceFrame, SurfaceError>> {
        let r = self.results.try_recv().ok()?;
        self.busy = false;
        Some(r)
    }

    /// Waits for the job in flight; `None` when there is none.
    ///
    /// # Errors
    /// Inside the option: the job's [`SurfaceError`].
    pub fn wait(&mut self) -> Option<Result<SurfaceFrame, SurfaceError>> {
        if !self.busy {
            return None;
        }
        let r = self.results.recv().ok()?;
        self.busy = false;
        Some(r)
    }
}

impl Drop for SurfaceWorker {
    fn drop(&mut self) {
        // Closing the job channel ends the worker's loop after its current job.
        self.jobs = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
