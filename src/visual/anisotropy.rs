//! Anisotropic particle ellipsoids after Yu & Turk 2013 ("Reconstructing surfaces of
//! particle-based fluids using anisotropic kernels", ACM Transactions on Graphics 32(1)).
//!
//! For each particle `i`, over the particles `j` within the radius `R` (itself included):
//!
//! - weights `w_ij = 1 − (|x_i − x_j| / R)³` (their eq. 11),
//! - the weighted mean `x̄ʷ_i = Σ w_ij x_j / Σ w_ij` and covariance
//!   `C_i = Σ w_ij (x_j − x̄ʷ_i)(x_j − x̄ʷ_i)ᵀ / Σ w_ij` (eqs. 9, 10),
//! - its eigen decomposition `C = R diag(σ1, σ2, σ3) Rᵀ` (`σ1 ≥ σ2 ≥ σ3`), the small axes
//!   clamped to `σ̃k = max(σk, σ1 / k_r)` (eq. 15) so no ellipsoid degenerates, and a
//!   sphere of `k_n·r0` for particles with fewer than `N_ε` neighbours (eq. 15's second
//!   case, `k_n` = 0.5: lone droplets stay round and small, so spray does not read as beads),
//! - the smoothed center `x̃_i = (1 − λ) x_i + λ x̄ʷ_i` (eq. 6, one step of Laplacian
//!   smoothing, which pulls the surface layer in by the bias of the particles' lattice).
//!
//! The ellipsoid's radii are proportional to the clamped `σ̃k`, as the paper's kernel
//! matrix `G = R (k_s Σ̃)⁻¹ Rᵀ / h` makes them. The paper's `k_s` (1400) depends on its
//! scenes' units; here the scale is fixed instead by asking that a particle inside a
//! uniform bulk get the sphere of radius `r0`: for the weight above over a ball of radius
//! `R` filled uniformly, `σ = ∫w x² dV / ∫w dV = (∫₀ᴿ(1 − r³/R³) r⁴ dr) / (3 ∫₀ᴿ(1 − r³/R³) r² dr)
//! = (3R⁵/40) / (3 · R³/6) = 0.15 R²`, so `radius_k = r0 · σ̃k / (0.15 R²)`. A particle on a
//! flat free surface (half a ball) gets a smaller σ along the normal, a particle of a thin
//! sheet a σ3 clamped at `σ1 / k_r`: flat discs, as the paper shows.

use super::{Search, positive};
use crate::fluid::Fluid;
use crate::math::{Real, Vector};
use crate::par::CHUNK;
use crate::{SphError, SphResult};
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Settings of [`Anisotropy`].
///
/// # Examples
///
/// ```
/// use rapier_sph::SphError;
/// use rapier_sph::visual::{Anisotropy, AnisotropySettings};
///
/// // Yu & Turk's neighbourhood of 4 spacings: smoother, about 4 times the cost.
/// let settings = AnisotropySettings { radius: 4.0, ..Default::default() };
/// let anisotropy = Anisotropy::new(settings)?;
/// assert_eq!(anisotropy.settings().radius, 4.0);
/// // A setting out of range is refused, naming the field.
/// let bad = AnisotropySettings { smoothing: 1.5, ..Default::default() };
/// assert!(matches!(
///     Anisotropy::new(bad),
///     Err(SphError::InvalidParameter { field: "smoothing", .. })
/// ));
/// # Ok::<(), SphError>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct AnisotropySettings {
    /// Neighbourhood radius `R` in particle spacings. Default 2.5 (about 65 neighbours in
    /// a uniform bulk). Yu & Turk use twice the SPH support (`2h`: 4 spacings for this
    /// crate's water preset, about 270 neighbours): smoother, and about 4 times the cost
    /// (see `examples/visual_cost.rs`).
    pub radius: Real,
    /// Laplacian smoothing of the centers, `λ` in `[0, 1]` (0: the particle's own position).
    /// Default 0.9 (Yu & Turk's choice).
    pub smoothing: Real,
    /// Largest ratio `k_r` between the largest and the smallest `σ` (≥ 1). Default 4 (Yu & Turk).
    pub max_ratio: Real,
    /// Fewer particles than this in the neighbourhood (the particle included) give a
    /// sphere. Default 6: Yu & Turk's `N_ε` = 25 is for their neighbourhood of radius `2h`
    /// (about 4 spacings, some 270 particles in a bulk); scaled by the volume to the default
    /// radius of 2.5 spacings it is `25 · (2.5/4)³ ≈ 6`. A single layer of particles (21 within
    /// 2.5 spacings on a square lattice) is then still drawn as a sheet.
    pub min_neighbors: usize,
    /// Scale of an isolated particle's sphere (fewer than `min_neighbors` around it), `k_n`
    /// in `(0, 1]`. Default 0.5 (Yu & Turk's `k_n`): spray and lone droplets are drawn at
    /// half a bulk particle's radius, so a splash reads as spray instead of beads.
    pub isolated_scale: Real,
    /// Radius `r0` of a particle in a uniform bulk, in particle spacings. Default 0.5 (the
    /// water preset's particle radius).
    pub particle_radius: Real,
}

impl Default for AnisotropySettings {
    fn default() -> Self {
        Self {
            radius: 2.5,
            smoothing: 0.9,
            max_ratio: 4.0,
            min_neighbors: 6,
            isolated_scale: 0.5,
            particle_radius: 0.5,
        }
    }
}

impl AnisotropySettings {
    /// Checks every field.
    ///
    /// # Errors
    /// [`SphError::InvalidParameter`] naming the field that is out of range.
    pub fn validate(&self) -> SphResult<()> {
        positive("radius", self.radius)?;
        positive("particle_radius", self.particle_radius)?;
        if !(0.0..=1.0).contains(&self.smoothing) {
            return Err(SphError::InvalidParameter {
                field: "smoothing",
                value: self.smoothing as f64,
                reason: "must be in [0, 1]",
            });
        }
        if !(self.isolated_scale > 0.0 && self.isolated_scale <= 1.0) {
            return Err(SphError::InvalidParameter {
                field: "isolated_scale",
                value: self.isolated_scale as f64,
                reason: "must be in (0, 1]",
            });
        }
        if !(self.max_ratio.is_finite() && self.max_ratio >= 1.0) {
            return Err(SphError::InvalidParameter {
                field: "max_ratio",
                value: self.max_ratio as f64,
                reason: "must be a finite number of at least 1",
            });
        }
        Ok(())
    }
}

/// One particle's ellipsoid: `{ center + Σ_k u_k · radii[k] · axes[k] : |u| ≤ 1 }`.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Ellipsoid {
    /// The smoothed center (m).
    pub center: Vector,
    /// Orthonormal principal axes, largest radius first.
    pub axes: [Vector; 3],
    /// Radii along `axes` (m), largest first.
    pub radii: [Real; 3],
}

impl Ellipsoid {
    /// A sphere.
    pub fn sphere(center: Vector, radius: Real) -> Self {
        Self {
            center,
            axes: [Vector::X, Vector::Y, Vector::Z],
            radii: [radius; 3],
        }
    }

    /// The columns of the linear map from the unit ball to the ellipsoid:
    /// `radii[k] · axes[k]`.
    pub fn columns(&self) -> [Vector; 3] {
        [0, 1, 2].map(|k| self.axes[k] * self.radii[k])
    }
}

/// Computes [`Ellipsoid`]s for a fluid's particles on request; holds its buffers between
/// calls (no allocation once warm).
///
/// # Examples
///
/// ```
/// use rapier_sph::visual::{Anisotropy, AnisotropySettings};
/// use rapier_sph::{Fluid, FluidParamsBuilder};
/// use rapier_sph::math::Vector;
///
/// let mut fluid = Fluid::new(FluidParamsBuilder::water(0.05).build()?)?;
/// fluid.add_block(Vector::ZERO, Vector::new(0.5, 0.5, 0.5))?;
/// let mut anisotropy = Anisotropy::new(AnisotropySettings::default())?;
/// let ellipsoids = anisotropy.compute(&fluid);
/// assert_eq!(ellipsoids.len(), fluid.len());
/// // Same order as `fluid.positions()`; draw each as an ellipsoid (or its bounding box).
/// let e = &ellipsoids[0];
/// assert!(e.radii[0] >= e.radii[2]);
/// # Ok::<(), rapier_sph::SphError>(())
/// ```
#[derive(Clone, Debug)]
pub struct Anisotropy {
    settings: AnisotropySettings,
    search: Search,
    sorted_out: Vec<Ellipsoid>,
    out: Vec<Ellipsoid>,
}

impl Anisotropy {
    /// # Errors
    /// [`SphError::InvalidParameter`] when a setting is out of range.
    pub fn new(settings: AnisotropySettings) -> SphResult<Self> {
        settings.validate()?;
        Ok(Self {
            settings,
            search: Search::default(),
            sorted_out: Vec::new(),
            out: Vec::new(),
        })
    }

    /// The settings.
    pub fn settings(&self) -> &AnisotropySettings {
        &self.settings
    }

    /// The ellipsoids of `fluid`'s particles, in the order of [`Fluid::positions`], at its
    /// particle spacing.
    pub fn compute(&mut self, fluid: &Fluid) -> &[Ellipsoid] {
        self.compute_points(fluid.positions(), fluid.params().particle_spacing)
    }

    /// The ellipsoids of any point set with particle spacing `spacing` (m), e.g. positions
    /// from [`super::Interpolation`]. Non-finite points get a sphere at the point.
    pub fn compute_points(&mut self, positions: &[Vector], spacing: Real) -> &[Ellipsoid] {
        let n = positions.len();
        let s = &self.settings;
        let radius = s.radius * spacing;
        let r0 = s.particle_radius * spacing;
        self.search.build(positions, radius);
        self.sorted_out
            .resize(n, Ellipsoid::sphere(Vector::ZERO, r0));
        let (search, settings) = (&self.search, *s);
        crate::par_chunks_mut!(self.sorted_out, CHUNK)
            .enumerate()
            .for_each(|(c, out)| {
                for (k, e) in out.iter_mut().enumerate() {
                    let i = c * CHUNK + k;
                    *e = ellipsoid(i, search, &settings, radius, r0);
                }
            });
        self.out.resize(n, Ellipsoid::sphere(Vector::ZERO, r0));
        for (k, &i) in self.search.order.iter().enumerate() {
            self.out[i as usize] = self.sorted_out[k];
        }
        &self.out
    }

    /// The ellipsoids of the last call.
    pub fn ellipsoids(&self) -> &[Ellipsoid] {
        &self.out
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.search.heap_bytes()
            + (self.sorted_out.capacity() + self.out.capacity()) * std::mem::size_of::<Ellipsoid>()
    }
}

/// The ellipsoid of sorted particle `i`.
#[inline]
fn ellipsoid(
    i: usize,
    search: &Search,
    s: &AnisotropySettings,
    radius: Real,
    r0: Real,
) -> Ellipsoid {
    let xi = search.sorted[i];
    if !crate::math::is_finite(xi) {
        return Ellipsoid::sphere(xi, r0);
    }
    let inv_r = 1.0 / radius;
    // Sums relative to x_i (small numbers, so the one-pass covariance keeps its digits).
    // The particle itself: weight 1 at offset 0.
    let mut sw: Real = 1.0;
    let mut sx = Vector::ZERO;
    let (mut sxx, mut syy, mut szz, mut sxy, mut sxz, mut syz) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    let neighbors = search.lists.of(i);
    for &j in neighbors {
        let d = search.sorted[j as usize] - xi;
        let q = d.length() * inv_r;
        let w = (1.0 - q * q * q).max(0.0);
        sw += w;
        sx += d * w;
        sxx += w * d.x * d.x;
        syy += w * d.y * d.y;
        szz += w * d.z * d.z;
        sxy += w * d.x * d.y;
        sxz += w * d.x * d.z;
        syz += w * d.y * d.z;
    }
    let inv = 1.0 / sw;
    let m = sx * inv;
    let center = xi + m * s.smoothing;
    if neighbors.len() + 1 < s.min_neighbors {
        return Ellipsoid::sphere(center, r0 * s.isolated_scale);
    }
    let c = nalgebra::Matrix3::new(
        sxx * inv - m.x * m.x,
        sxy * inv - m.x * m.y,
        sxz * inv - m.x * m.z,
        sxy * inv - m.x * m.y,
        syy * inv - m.y * m.y,
        syz * inv - m.y * m.z,
        sxz * inv - m.x * m.z,
        syz * inv - m.y * m.z,
        szz * inv - m.z * m.z,
    );
    let eig = nalgebra::SymmetricEigen::new(c);
    let mut idx = [0usize, 1, 2];
    idx.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    let s1 = eig.eigenvalues[idx[0]];
    if !(s1.is_finite() && s1 > 0.0) {
        return Ellipsoid::sphere(center, r0);
    }
    let floor = s1 / s.max_ratio;
    let scale = r0 / (0.15 * radius * radius);
    let axes = idx.map(|k| {
        let v = eig.eigenvectors.column(k);
        Vector::new(v[0], v[1], v[2]).normalize_or(Vector::X)
    });
    let radii = idx.map(|k| eig.eigenvalues[k].max(floor) * scale);
    Ellipsoid {
        center,
        axes,
        radii,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lattice(nx: i32, ny: i32, nz: i32, s: Real) -> Vec<Vector> {
        let mut v = Vec::new();
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    v.push(Vector::new(x as Real, y as Real, z as Real) * s);
                }
            }
        }
        v
    }

    fn nearest(points: &[Vector], p: Vector) -> usize {
        (0..points.len())
            .min_by(|&a, &b| {
                (points[a] - p)
                    .length_squared()
                    .total_cmp(&(points[b] - p).length_squared())
            })
            .unwrap()
    }

    /// Yu & Turk 2013, section 4: a particle inside a uniform bulk has an isotropic
    /// neighbourhood, so its kernel is a sphere; with this module's normalisation the
    /// sphere of radius `r0`. On a cubic lattice the weighted covariance is exactly
    /// isotropic (the lattice's symmetry), so the radii agree to rounding; their size differs
    /// from the continuum's `0.15 R²` by the lattice sum's discretisation (a few per cent at
    /// R = 2.5 spacings), hence the 10 % band.
    #[test]
    fn a_uniform_bulk_is_isotropic() {
        let s = 0.1;
        let points = lattice(12, 12, 12, s);
        let mut a = Anisotropy::new(AnisotropySettings::default()).unwrap();
        let e = a.compute_points(&points, s);
        let i = nearest(&points, Vector::splat(5.5 * s));
        let r0 = 0.5 * s;
        let e = e[i];
        assert!(
            e.radii[0] / e.radii[2] < 1.0 + 1e-4,
            "bulk ellipsoid not round: {:?}",
            e.radii
        );
        for r in e.radii {
            assert!((r / r0 - 1.0).abs() < 0.1, "radius {r} against r0 {r0}");
        }
        // A centered particle's neighbourhood mean is itself: smoothing leaves it in place.
        assert!((e.center - points[i]).length() < 1e-5 * s);
    }

    /// Yu & Turk 2013, figure 2 / section 4: a thin sheet gets flat kernels, the smallest
    /// axis along the sheet's normal and clamped at `σ1 / k_r` (`k_r` = 4). The sheet is
    /// two particle layers thick; a single layer is tested below.
    #[test]
    fn a_flat_sheet_is_flat_with_its_smallest_axis_along_the_normal() {
        let s = 0.1;
        // The sheet lies in the plane x + y = const after a rotation, to test the axes in
        // a direction that is not a coordinate axis.
        let rot = crate::math::Rotation::from_axis_angle(Vector::Z, 0.5);
        let normal = rot * Vector::Y;
        let points: Vec<Vector> = lattice(16, 2, 16, s).into_iter().map(|p| rot * p).collect();
        let mut a = Anisotropy::new(AnisotropySettings::default()).unwrap();
        let e = a.compute_points(&points, s);
        let i = nearest(&points, rot * Vector::new(7.5 * s, 0.0, 7.5 * s));
        let e = e[i];
        assert!(
            e.axes[2].dot(normal).abs() > 0.999,
            "smallest axis {:?} against the normal {normal:?}",
            e.axes[2]
        );
        assert!(e.radii[2] < 0.5 * e.radii[1], "not flat: {:?}", e.radii);
        // The clamp: σ3 = σ1 / 4 exactly (the sheet's own σ3 is smaller).
        assert!(
            (e.radii[0] / e.radii[2] - 4.0).abs() < 1e-3,
            "{:?}",
            e.radii
        );
        // In the plane the sheet is wider than a bulk particle (its neighbours spread in 2D).
        assert!(e.radii[1] > 0.5 * s, "{:?}", e.radii);
    }

    /// A single layer (a sheet one particle thick, as a thin stream is): flat too, its
    /// σ3 = 0 clamped to σ1 / 4.
    #[test]
    fn a_single_layer_is_a_flat_disc() {
        let s = 0.1;
        let points = lattice(12, 1, 12, s);
        let mut a = Anisotropy::new(AnisotropySettings::default()).unwrap();
        let e = a.compute_points(&points, s);
        let i = nearest(&points, Vector::new(5.0 * s, 0.0, 5.0 * s));
        assert!(e[i].axes[2].y.abs() > 0.999, "{:?}", e[i]);
        assert!(
            (e[i].radii[0] / e[i].radii[2] - 4.0).abs() < 1e-3,
            "{:?}",
            e[i]
        );
    }

    /// The free surface of a block: the top layer's smallest axis is vertical.
    #[test]
    fn the_free_surface_of_a_block_is_flattened_along_its_normal() {
        let s = 0.1;
        let points = lattice(12, 8, 12, s);
        let mut a = Anisotropy::new(AnisotropySettings::default()).unwrap();
        let e = a.compute_points(&points, s);
        let i = nearest(&points, Vector::new(5.0 * s, 7.0 * s, 5.0 * s));
        assert!(e[i].axes[2].y.abs() > 0.99, "{:?}", e[i]);
        // Laplacian smoothing pulls the surface particle inwards (down).
        assert!(e[i].center.y < points[i].y);
    }

    #[test]
    fn isolated_particles_are_spheres_and_bad_settings_are_refused() {
        let s = 0.1;
        // Fewer than 6 together: a pair and a lone particle, drawn at k_n = 0.5 of r0.
        let points = vec![Vector::ZERO, Vector::new(0.1, 0.0, 0.0), Vector::splat(5.0)];
        let mut a = Anisotropy::new(AnisotropySettings::default()).unwrap();
        for e in a.compute_points(&points, s) {
            assert_eq!(e.radii, [0.25 * s; 3]);
        }
        let bad = AnisotropySettings {
            smoothing: 1.5,
            ..Default::default()
        };
        assert!(matches!(
            Anisotropy::new(bad),
            Err(SphError::InvalidParameter {
                field: "smoothing",
                ..
            })
        ));
    }
}
