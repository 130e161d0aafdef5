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
use std::fmt;

/// Reconstruction settings, relative to each fluid's particle spacing.
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
}

impl Default for SurfaceOptions {
    fn default() -> Self {
        Self {
            support_factor: 2.5,
            cube_size_factor: 0.5,
            iso_surface_threshold: 0.6,
            multi_threading: true,
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
pub fn reconstruct(fluid: &Fluid, options: &SurfaceOptions) -> Result<TriangleMesh, SurfaceError> {
    reconstruct_points(
        fluid.positions(),
        fluid.params().particle_spacing,
        fluid.params().rest_density,
        options,
    )
}

/// The surface around `positions`, particles on a lattice of `spacing` at rest.
pub fn reconstruct_points(
    positions: &[Vector],
    spacing: Real,
    rest_density: Real,
    options: &SurfaceOptions,
) -> Result<TriangleMesh, SurfaceError> {
    let bad = |what: &str, v: Real| SurfaceError {
        message: format!("{what} must be positive and finite, got {v}"),
    };
    for (what, v) in [
        ("spacing", spacing),
        ("rest density", rest_density),
        ("support_factor", options.support_factor),
        ("cube_size_factor", options.cube_size_factor),
        ("iso_surface_threshold", options.iso_surface_threshold),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(bad(what, v));
        }
    }
    if positions.is_empty() {
        return Ok(TriangleMesh::default());
    }
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        return Err(SurfaceError {
            message: format!("particle {i} has a non-finite position"),
        });
    }
    let points: Vec<Vector3<f32>> = positions
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
    let r = splashsurf_lib::reconstruct_surface::<i64, f32>(&points, &params).map_err(|e| {
        let mut message = e.to_string();
        let mut src = std::error::Error::source(&e);
        while let Some(s) = src {
            message.push_str(": ");
            message.push_str(&s.to_string());
            src = s.source();
        }
        SurfaceError { message }
    })?;
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

/// The surfaces of every fluid of the set, in one mesh.
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
