//! Screen-space fluid rendering on the CPU, in the manner of the GPU technique games use
//! (van der Laan, Green & Sainz 2009, "Screen space fluid rendering with curvature flow";
//! NVIDIA Flex and Obi Fluid ship variants of it):
//!
//! 1. **Depth splatting** of every particle's ellipsoid ([`crate::visual::Anisotropy`],
//!    Yu & Turk 2013): the nearest ray–ellipsoid intersection per pixel, depth-tested
//!    against the opaque scene.
//! 2. **Thickness**: the chord each ray cuts through each ellipsoid (up to the scene behind),
//!    summed.
//! 3. **Depth smoothing** by a narrow-range filter after Truong & Yuksel 2018 ("A narrow-range
//!    filter for screen-space fluid rendering", Proc. ACM CGIT 1(1)), separable (a pass
//!    along x, then along y), with a footprint of a fixed size in the world (so it shrinks
//!    with distance) and a range `μ` of one particle spacing: a sample more than `μ` behind
//!    the center pixel is left out (it belongs to water farther back: silhouettes do not
//!    bleed into what is behind them), a sample more than `μ` in front is clamped to `μ` in
//!    front (so the crevices between splats are pulled up to the surface rather than kept
//!    as dark seams).
//! 4. **Normals** from the smoothed depth (of the two one-sided differences per axis, the one
//!    with the smaller depth step, so edges do not bend the normal).
//! 5. **Shading**: Fresnel (Schlick, water's F0 = 0.02) between a reflection of the sky and
//!    a refraction of the scene behind (the opaque image shifted along the normal by the
//!    thickness), the refracted light attenuated by Beer–Lambert absorption over the
//!    thickness towards the deep-water colour, a sun highlight; foam on top.
//!
//! Everything runs per pixel over rows in parallel (rayon, fixed chunks, so the image is
//! the same for any thread count); the splats run over bands of rows in parallel, each
//! band in the splats' order.

use super::raster::{Rgb, Target, lerp3};
use crate::math::{Real, Vector};
use crate::par::CHUNK;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// A splat in view space: center and the inverse of the ellipsoid's map (rows `axes[k] /
/// radii[k]`), and its largest radius.
#[derive(Copy, Clone, Debug)]
pub(crate) struct Splat {
    pub center: Vector,
    pub inv_rows: [Vector; 3],
    pub max_radius: Real,
}

/// Per-pixel buffers of the fluid passes (held between frames).
#[derive(Default)]
pub(crate) struct FluidBuffers {
    pub width: usize,
    pub height: usize,
    /// Nearest fluid depth along the view axis (∞: no fluid).
    pub depth: Vec<Real>,
    pub smooth: Vec<Real>,
    scratch: Vec<Real>,
    pub thickness: Vec<Real>,
    thick_scratch: Vec<Real>,
    /// Foam coverage (0: none, ≥ 1: opaque foam).
    pub foam: Vec<Real>,
    /// Copy of the opaque scene's colours (refraction reads it).
    scene: Vec<Rgb>,
    /// Rows `y0..y1` each splat covers (scratch of [`Self::splat_all`]).
    splat_rows: Vec<(u32, u32)>,
}

/// Shading inputs.
pub(crate) struct Shade {
    /// Per particle spacing of thickness.
    pub absorption: Rgb,
    pub spacing: Real,
    pub deep: Rgb,
    pub foam: Rgb,
    pub light: Vector,
    pub refraction: Real,
    /// View → world: right, up, back.
    pub basis: (Vector, Vector, Vector),
    pub fog: Real,
    pub fog_start: Real,
    pub background: Rgb,
    pub sky_top: Rgb,
    pub sky_horizon: Rgb,
    pub ground: Rgb,
}

impl FluidBuffers {
    pub fn reset(&mut self, width: usize, height: usize) {
        self.width = width;
        self.height = height;
        let n = width * height;
        for b in [&mut self.depth, &mut self.smooth, &mut self.scratch] {
            b.clear();
            b.resize(n, Real::INFINITY);
        }
        for b in [&mut self.thickness, &mut self.thick_scratch, &mut self.foam] {
            b.clear();
            b.resize(n, 0.0);
        }
    }

    /// Splats every ellipsoid: nearest depth and thickness, behind the opaque scene culled.
    /// The image is cut into bands of rows splatted in parallel, each band going through the
    /// splats in their order, so every pixel sums its thicknesses in the same order whatever
    /// the thread count (the same image as a serial loop).
    pub fn splat_all(&mut self, t: &Target, splats: &[Splat]) {
        let w = t.width;
        if w == 0 {
            return;
        }
        let band = 16usize;
        // Each splat's rows, so a band skips the splats that miss it at once.
        self.splat_rows.clear();
        self.splat_rows.extend(splats.iter().map(|s| {
            let d = -s.center.z;
            let r = s.max_radius;
            if d - r < super::raster::NEAR {
                return (0, 0);
            }
            let sy = 0.5 * t.height as Real - s.center.y * t.focal / d;
            let rs = r * t.focal / (d - r) + 1.0;
            let y0 = (sy - rs).floor().max(0.0) as u32;
            let y1 = ((sy + rs).ceil().min(t.height as Real)).max(0.0) as u32;
            (y0, y1)
        }));
        let spans = &self.splat_rows;
        crate::par_chunks_mut!(self.depth, band * w)
            .zip(crate::par_chunks_mut!(self.thickness, band * w))
            .enumerate()
            .for_each(|(b, (depth, thickness))| {
                let rows = (b * band, b * band + depth.len() / w);
                for (s, &(y0, y1)) in splats.iter().zip(spans) {
                    if (y1 as usize) <= rows.0 || (y0 as usize) >= rows.1 {
                        continue;
                    }
                    splat_rows(t, s, rows, depth, thickness);
                }
            });
    }

    /// Adds a soft foam dot of view-space center `c` and radius `r`, `weight` in `[0, 1]`,
    /// visible in front of the scene; under the fluid's surface it fades over `fade` metres.
    pub fn foam_dot(&mut self, t: &Target, c: Vector, r: Real, weight: Real, fade: Real) {
        let d = -c.z;
        if d - r < super::raster::NEAR {
            return;
        }
        let f = t.focal;
        let (cx, cy) = (0.5 * t.width as Real, 0.5 * t.height as Real);
        let sx = cx + c.x * f / d;
        let sy = cy - c.y * f / d;
        let rs = (r * f / d).max(0.75);
        let x0 = (sx - rs).floor().max(0.0) as usize;
        let y0 = (sy - rs).floor().max(0.0) as usize;
        let x1 = ((sx + rs).ceil().min(t.width as Real)).max(0.0) as usize;
        let y1 = ((sy + rs).ceil().min(t.height as Real)).max(0.0) as usize;
        let inv_rs = 1.0 / rs;
        for py in y0..y1 {
            let v = (py as Real + 0.5 - sy) * inv_rs;
            for px in x0..x1 {
                let u = (px as Real + 0.5 - sx) * inv_rs;
                let q = u * u + v * v;
                if q >= 1.0 {
                    continue;
                }
                let k = py * t.width + px;
                if t.inv_depth[k] > 0.0 && d > 1.0 / t.inv_depth[k] {
                    continue;
                }
                let surface = self.smooth[k];
                let under = if d > surface {
                    (-(d - surface) / fade).exp()
                } else {
                    1.0
                };
                self.foam[k] += weight * under * (1.0 - q) * (1.0 - q);
            }
        }
    }

    /// The narrow-range filter (separable): `radius_world` is the footprint's half-width
    /// (m), `mu` the range (m), `max_px` caps the footprint in pixels.
    pub fn smooth_depth(&mut self, focal: Real, radius_world: Real, mu: Real, max_px: usize) {
        let (w, h) = (self.width, self.height);
        let rows = CHUNK.div_ceil(w.max(1)).max(1);
        let filter = NarrowRange {
            focal,
            radius_world,
            mu,
            max_px,
        };
        // Along x: depth → scratch.
        {
            let depth = &self.depth;
            crate::par_chunks_mut!(self.scratch, rows * w)
                .enumerate()
                .for_each(|(c, out)| {
                    for (k, o) in out.iter_mut().enumerate() {
                        let i = c * rows * w + k;
                        let (x, y) = (i % w, i / w);
                        *o = filter.at(depth, (y * w, 1, w), x);
                    }
                });
        }
        // Along y: scratch → smooth (the same center depth decides the footprint).
        {
            let (scratch, depth) = (&self.scratch, &self.depth);
            crate::par_chunks_mut!(self.smooth, rows * w)
                .enumerate()
                .for_each(|(c, out)| {
                    for (k, o) in out.iter_mut().enumerate() {
                        let i = c * rows * w + k;
                        let (x, y) = (i % w, i / w);
                        if !depth[i].is_finite() {
                            *o = Real::INFINITY;
                            continue;
                        }
                        *o = filter.at(scratch, (x, w, h), y);
                    }
                });
        }
        // Thickness: a small separable box (its splats are blotchy at the particle scale).
        let r = 2usize;
        for pass in 0..2 {
            let (src, dst) = if pass == 0 {
                (&self.thickness, &mut self.thick_scratch)
            } else {
                (&self.thick_scratch, &mut self.thickness)
            };
            crate::par_chunks_mut!(dst, rows * w)
                .enumerate()
                .for_each(|(c, out)| {
                    for (k, o) in out.iter_mut().enumerate() {
                        let i = c * rows * w + k;
                        let (x, y) = (i % w, i / w);
                        let (mut sum, mut n) = (0.0, 0.0);
                        if pass == 0 {
                            for xx in x.saturating_sub(r)..(x + r + 1).min(w) {
                                sum += src[y * w + xx];
                                n += 1.0;
                            }
                        } else {
                            for yy in y.saturating_sub(r)..(y + r + 1).min(h) {
                                sum += src[yy * w + x];
                                n += 1.0;
                            }
                        }
                        *o = sum / n;
                    }
                });
        }
    }

    /// Shades every fluid pixel and composites it (and the foam) over `t`'s colours.
    pub fn shade(&mut self, t: &mut Target, s: &Shade) {
        let w = self.width;
        self.scene.clear();
        self.scene.extend_from_slice(&t.color);
        let rows = CHUNK.div_ceil(w.max(1)).max(1);
        let half = (s.light + Vector::Z).normalize();
        let (this, focal) = (&*self, t.focal);
        crate::par_chunks_mut!(t.color, rows * w)
            .enumerate()
            .for_each(|(c, out)| {
                for (k, o) in out.iter_mut().enumerate() {
                    let i = c * rows * w + k;
                    let foam = 0.9 * this.foam[i].min(1.0);
                    let d = this.smooth[i];
                    if !d.is_finite() {
                        if foam > 0.0 {
                            *o = lerp3(*o, s.foam, foam);
                        }
                        continue;
                    }
                    let (p, n) = this.surface_at(i, focal);
                    let view = (-p).normalize_or(Vector::Z);
                    let cos = n.dot(view).clamp(0.0, 1.0);
                    let fresnel = 0.02 + 0.98 * (1.0 - cos).powi(5);
                    let reflect = s.reflection(n * (2.0 * n.dot(view)) - view);
                    let refract = this.refraction(i, n, focal, s);
                    let diffuse = 0.75 + 0.25 * n.dot(s.light).max(0.0);
                    let mut col = lerp3(refract.map(|v| v * diffuse), reflect, fresnel);
                    let spec = n.dot(half).max(0.0).powi(90) * 1.4;
                    col = col.map(|v| v + spec);
                    col = lerp3(col, s.foam, foam);
                    let fog = ((d - s.fog_start) / s.fog_start).clamp(0.0, 1.0) * s.fog;
                    *o = lerp3(col, s.background, fog);
                }
            });
    }

    /// The view-space point of fluid pixel `i` (on the smoothed depth) and its normal, from
    /// the smaller of the one-sided depth differences along x and along y (which does not
    /// blur the silhouette into the background).
    fn surface_at(&self, i: usize, focal: Real) -> (Vector, Vector) {
        let (w, h) = (self.width, self.height);
        let (x, y) = (i % w, i / w);
        let (cx, cy) = (0.5 * w as Real, 0.5 * h as Real);
        let pos = |x: usize, y: usize, d: Real| {
            Vector::new(
                (x as Real + 0.5 - cx) / focal * d,
                -(y as Real + 0.5 - cy) / focal * d,
                -d,
            )
        };
        let p = pos(x, y, self.smooth[i]);
        let side = |x2: Option<usize>, y2: Option<usize>| -> Option<Vector> {
            let (x2, y2) = (x2?, y2?);
            if x2 >= w || y2 >= h {
                return None;
            }
            let d2 = self.smooth[y2 * w + x2];
            d2.is_finite().then(|| pos(x2, y2, d2) - p)
        };
        let pick = |a: Option<Vector>, b: Option<Vector>, fallback: Vector| match (a, b) {
            (Some(a), Some(b)) => {
                if a.z.abs() <= b.z.abs() {
                    a
                } else {
                    b
                }
            }
            (Some(a), None) => a,
            (None, Some(b)) => b,
            (None, None) => fallback,
        };
        let ddx = pick(
            side(Some(x + 1), Some(y)),
            side(x.checked_sub(1), Some(y)).map(|v| -v),
            Vector::X,
        );
        let ddy = pick(
            side(Some(x), Some(y + 1)),
            side(Some(x), y.checked_sub(1)).map(|v| -v),
            -Vector::Y,
        );
        let mut n = ddy.cross(ddx).normalize_or(Vector::Z);
        if n.z < 0.0 {
            n = -n;
        }
        (p, n)
    }

    /// Refraction at fluid pixel `i`: the scene behind, shifted along the normal by the
    /// thickness, attenuated per channel by Beer–Lambert absorption towards the deep colour.
    fn refraction(&self, i: usize, n: Vector, focal: Real, s: &Shade) -> Rgb {
        let (w, h) = (self.width, self.height);
        let (x, y) = (i % w, i / w);
        let thick = self.thickness[i];
        let shift = s.refraction * thick.min(0.5) * focal / self.smooth[i];
        let sx = (x as Real + n.x * shift).clamp(0.0, (w - 1) as Real) as usize;
        let sy = (y as Real - n.y * shift).clamp(0.0, (h - 1) as Real) as usize;
        let behind = self.scene[sy * w + sx];
        let tr = [0, 1, 2].map(|ch| (-s.absorption[ch] * thick / s.spacing).exp());
        [0, 1, 2].map(|ch| behind[ch] * tr[ch] + s.deep[ch] * (1.0 - tr[ch]))
    }
}

impl Shade {
    /// Reflection along the view-space direction `r`: the sky (and a dim ground below the
    /// horizon).
    fn reflection(&self, r: Vector) -> Rgb {
        let (right, up, back) = self.basis;
        let r_up = (right * r.x + up * r.y + back * r.z).y;
        if r_up >= 0.0 {
            lerp3(self.sky_horizon, self.sky_top, r_up.sqrt())
        } else {
            lerp3(self.sky_horizon, self.ground, (-r_up).sqrt().min(1.0))
        }
    }
}

/// The narrow-range filter of Truong & Yuksel (2018), one direction of its separable form.
#[derive(Clone, Copy)]
struct NarrowRange {
    focal: Real,
    /// The footprint's half-width (m).
    radius_world: Real,
    /// The range (m): depths farther than `mu` behind the center are ignored, nearer ones
    /// clamped.
    mu: Real,
    /// Caps the footprint (pixels).
    max_px: usize,
}

impl NarrowRange {
    /// The filtered depth at pixel `pos` of the line `(base, stride, len)` of `src` (its
    /// pixels are `src[base + q·stride]` for `q < len`).
    #[inline]
    fn at(&self, src: &[Real], (base, stride, len): (usize, usize, usize), pos: usize) -> Real {
        let zc = src[base + pos * stride];
        if !zc.is_finite() {
            return zc;
        }
        let r = ((self.radius_world * self.focal / zc) as usize).min(self.max_px);
        if r == 0 {
            return zc;
        }
        let mu = self.mu;
        let inv_r = 1.0 / (r as Real + 1.0);
        let (mut sum, mut wsum) = (0.0, 0.0);
        let lo = pos.saturating_sub(r);
        let hi = (pos + r + 1).min(len);
        for q in lo..hi {
            let mut z = src[base + q * stride];
            if !z.is_finite() || z > zc + mu {
                continue;
            }
            if z < zc - mu {
                z = zc - mu;
            }
            let t = (q as Real - pos as Real) * inv_r;
            let wgt = (1.0 - t * t) * (1.0 - t * t);
            sum += wgt * z;
            wsum += wgt;
        }
        if wsum > 0.0 { sum / wsum } else { zc }
    }
}

/// Splats `s` into the rows `rows.0..rows.1` of the image, whose depth and thickness are
/// `depth` and `thickness` (those rows only).
#[inline]
fn splat_rows(
    t: &Target,
    s: &Splat,
    rows: (usize, usize),
    depth: &mut [Real],
    thickness: &mut [Real],
) {
    let d = -s.center.z;
    let r = s.max_radius;
    if d - r < super::raster::NEAR {
        return;
    }
    let f = t.focal;
    let (cx, cy) = (0.5 * t.width as Real, 0.5 * t.height as Real);
    let sx = cx + s.center.x * f / d;
    let sy = cy - s.center.y * f / d;
    let rs = r * f / (d - r) + 1.0;
    let x0 = (sx - rs).floor().max(0.0) as usize;
    let y0 = ((sy - rs).floor().max(0.0) as usize).max(rows.0);
    let x1 = ((sx + rs).ceil().min(t.width as Real)).max(0.0) as usize;
    let y1 = (((sy + rs).ceil().min(t.height as Real)).max(0.0) as usize).min(rows.1);
    if y0 >= y1 || x0 >= x1 {
        return;
    }
    let m = s.inv_rows;
    let w = Vector::new(m[0].dot(s.center), m[1].dot(s.center), m[2].dot(s.center));
    let cc = w.dot(w) - 1.0;
    let inv_f = 1.0 / f;
    for py in y0..y1 {
        let ry = -(py as Real + 0.5 - cy) * inv_f;
        for px in x0..x1 {
            let rx = (px as Real + 0.5 - cx) * inv_f;
            let ray = Vector::new(rx, ry, -1.0);
            let u = Vector::new(m[0].dot(ray), m[1].dot(ray), m[2].dot(ray));
            let a = u.dot(u);
            let b = u.dot(w);
            let disc = b * b - a * cc;
            if disc <= 0.0 {
                continue;
            }
            let root = disc.sqrt();
            let t0 = (b - root) / a;
            let t1 = (b + root) / a;
            let k = py * t.width + px;
            let inv_scene = t.inv_depth[k];
            let scene = if inv_scene > 0.0 {
                1.0 / inv_scene
            } else {
                Real::INFINITY
            };
            if t0 >= scene || t0 < super::raster::NEAR {
                continue;
            }
            let kb = k - rows.0 * t.width;
            if t0 < depth[kb] {
                depth[kb] = t0;
            }
            thickness[kb] += t1.min(scene) - t0;
        }
    }
}
