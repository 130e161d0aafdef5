//! A small z-buffered software rasteriser: triangles (flat or per-vertex colours, clipped at
//! the near plane), sphere impostors (exact per-pixel sphere depth and normal), translucent
//! triangles blended over the opaque image. Depth is stored as `1/d` (d the distance along
//! the view axis), which is linear in screen space.

use crate::math::{Real, Vector};

/// Colour in linear-ish RGB, each channel in `[0, 1]`.
pub type Rgb = [Real; 3];

pub(crate) struct Target {
    pub width: usize,
    pub height: usize,
    pub color: Vec<Rgb>,
    /// `1/d` of the nearest opaque surface so far (0: nothing).
    pub inv_depth: Vec<Real>,
    /// Focal length in pixels.
    pub focal: Real,
    /// Which opaque tagged surface (a collider) covers each pixel (`NO_ID`: none).
    pub id: Vec<u32>,
    /// View-space normal of the opaque tagged surface at each pixel.
    pub normal: Vec<Vector>,
}

/// No tagged surface at this pixel.
pub(crate) const NO_ID: u32 = u32::MAX;

pub(crate) const NEAR: Real = 1e-3;

impl Target {
    pub fn new() -> Self {
        Self {
            width: 0,
            height: 0,
            color: Vec::new(),
            inv_depth: Vec::new(),
            focal: 1.0,
            id: Vec::new(),
            normal: Vec::new(),
        }
    }

    pub fn reset(&mut self, width: usize, height: usize, focal: Real, top: Rgb, bottom: Rgb) {
        self.width = width;
        self.height = height;
        self.focal = focal;
        self.color.clear();
        for y in 0..height {
            let t = y as Real / (height.max(2) - 1) as Real;
            let c = lerp3(top, bottom, t);
            self.color.extend(std::iter::repeat_n(c, width));
        }
        self.inv_depth.clear();
        self.inv_depth.resize(width * height, 0.0);
        self.id.clear();
        self.id.resize(width * height, NO_ID);
        self.normal.clear();
        self.normal.resize(width * height, Vector::Z);
    }

    /// Darkens the pixels on the outline of tagged surfaces: where the tag changes, the
    /// depth jumps (by more than `depth_jump` relatively) or the normal turns by more than
    /// about 35° (a crease). `strength` in `[0, 1]` is how much darker.
    pub fn outlines(&mut self, strength: Real, depth_jump: Real) {
        let (w, h) = (self.width, self.height);
        if w < 2 || h < 2 {
            return;
        }
        let edge = |a: usize, b: usize, this: &Self| -> bool {
            let (ia, ib) = (this.id[a], this.id[b]);
            if ia == NO_ID && ib == NO_ID {
                return false;
            }
            let (da, db) = (this.inv_depth[a], this.inv_depth[b]);
            if (da - db).abs() > depth_jump * da.max(db) {
                return true;
            }
            // A crease: the normal turns by more than about 35°. Faces seen nearly edge-on
            // (normal within about 15° of the image plane) are left out: there, two faces of
            // a thin wall alternate from pixel to pixel and would be speckled with marks.
            let (na, nb) = (this.normal[a], this.normal[b]);
            let turned = na.z.abs() > 0.25 && nb.z.abs() > 0.25 && na.dot(nb) < 0.82;
            // Two colliders meeting: an edge unless they are coplanar there (overlapping
            // walls of a tank would otherwise flicker between their tags).
            if ia != ib {
                return turned || (da - db).abs() > 1e-3 * da.max(db);
            }
            turned
        };
        let mut mark = vec![false; w * h];
        for y in 0..h {
            for x in 0..w {
                let k = y * w + x;
                if (x + 1 < w && edge(k, k + 1, self)) || (y + 1 < h && edge(k, k + w, self)) {
                    // Darken the nearer of the two sides (the silhouette's own pixel).
                    mark[k] = true;
                }
            }
        }
        for (c, &m) in self.color.iter_mut().zip(&mark) {
            if m {
                *c = c.map(|v| v * (1.0 - strength));
            }
        }
    }

    /// Screen position (pixels) and `1/d` of a view-space point with `d = -z > 0`.
    #[inline]
    fn project(&self, p: Vector) -> (Real, Real, Real) {
        let d = -p.z;
        let inv = 1.0 / d;
        (
            0.5 * self.width as Real + p.x * self.focal * inv,
            0.5 * self.height as Real - p.y * self.focal * inv,
            inv,
        )
    }

    /// Draws a sphere of view-space center `c` and radius `r`; `shade(normal, d)` gives the
    /// colour of a visible point from its view-space normal and depth.
    pub fn sphere(&mut self, c: Vector, r: Real, mut shade: impl FnMut(Vector, Real) -> Rgb) {
        let d = -c.z;
        if d - r < NEAR {
            return;
        }
        let (sx, sy, _) = self.project(c);
        let rs = r * self.focal / d;
        let x0 = ((sx - rs).floor().max(0.0)) as usize;
        let y0 = ((sy - rs).floor().max(0.0)) as usize;
        let x1 = ((sx + rs).ceil().min(self.width as Real)).max(0.0) as usize;
        let y1 = ((sy + rs).ceil().min(self.height as Real)).max(0.0) as usize;
        let inv_rs = 1.0 / rs;
        for py in y0..y1 {
            let v = (py as Real + 0.5 - sy) * inv_rs;
            for px in x0..x1 {
                let u = (px as Real + 0.5 - sx) * inv_rs;
                let q = u * u + v * v;
                if q >= 1.0 {
                    continue;
                }
                let nz = (1.0 - q).sqrt();
                let depth = d - r * nz;
                let inv = 1.0 / depth;
                let k = py * self.width + px;
                if inv > self.inv_depth[k] {
                    self.inv_depth[k] = inv;
                    self.color[k] = shade(Vector::new(u, -v, nz), depth);
                }
            }
        }
    }

    /// Draws a triangle given in view space with per-vertex colours. With `alpha < 1` the
    /// triangle is blended over what is there (depth-tested, depth not written).
    pub fn triangle(&mut self, p: [Vector; 3], c: [Rgb; 3], alpha: Real) {
        // Clip against the near plane (Sutherland–Hodgman on one plane).
        let inside = |v: &Vector| -v.z >= NEAR;
        if p.iter().all(inside) {
            self.raster(p, c, alpha);
            return;
        }
        if !p.iter().any(inside) {
            return;
        }
        let mut poly: Vec<(Vector, Rgb)> = Vec::with_capacity(4);
        for i in 0..3 {
            let (a, ca) = (p[i], c[i]);
            let (b, cb) = (p[(i + 1) % 3], c[(i + 1) % 3]);
            if inside(&a) {
                poly.push((a, ca));
            }
            if inside(&a) != inside(&b) {
                let t = (-a.z - NEAR) / ((-a.z) - (-b.z));
                poly.push((a + (b - a) * t, lerp3(ca, cb, t)));
            }
        }
        for k in 1..poly.len().saturating_sub(1) {
            self.raster(
                [poly[0].0, poly[k].0, poly[k + 1].0],
                [poly[0].1, poly[k].1, poly[k + 1].1],
                alpha,
            );
        }
    }

    /// An opaque triangle tagged with `id` and its view-space `normal` (for
    /// [`Self::outlines`]).
    pub fn solid_triangle(&mut self, p: [Vector; 3], c: Rgb, id: u32, normal: Vector) {
        let inside = |v: &Vector| -v.z >= NEAR;
        if p.iter().all(inside) {
            self.raster_tagged(p, [c; 3], 1.0, Some((id, normal)));
        } else {
            // Rare (a collider crossing the near plane): drawn untagged through the clipper.
            self.triangle(p, [c; 3], 1.0);
        }
    }

    fn raster(&mut self, p: [Vector; 3], c: [Rgb; 3], alpha: Real) {
        self.raster_tagged(p, c, alpha, None)
    }

    fn raster_tagged(
        &mut self,
        p: [Vector; 3],
        c: [Rgb; 3],
        alpha: Real,
        tag: Option<(u32, Vector)>,
    ) {
        let s = p.map(|v| self.project(v));
        let area = (s[1].0 - s[0].0) * (s[2].1 - s[0].1) - (s[2].0 - s[0].0) * (s[1].1 - s[0].1);
        if area.abs() < 1e-12 || !area.is_finite() {
            return;
        }
        let inv_area = 1.0 / area;
        let xmin = s.iter().map(|v| v.0).fold(Real::INFINITY, Real::min);
        let xmax = s.iter().map(|v| v.0).fold(Real::NEG_INFINITY, Real::max);
        let ymin = s.iter().map(|v| v.1).fold(Real::INFINITY, Real::min);
        let ymax = s.iter().map(|v| v.1).fold(Real::NEG_INFINITY, Real::max);
        let x0 = xmin.floor().max(0.0) as usize;
        let y0 = ymin.floor().max(0.0) as usize;
        let x1 = (xmax.ceil().min(self.width as Real)).max(0.0) as usize;
        let y1 = (ymax.ceil().min(self.height as Real)).max(0.0) as usize;
        let flat = c[0] == c[1] && c[1] == c[2];
        for py in y0..y1 {
            let y = py as Real + 0.5;
            for px in x0..x1 {
                let x = px as Real + 0.5;
                let w0 = ((s[1].0 - x) * (s[2].1 - y) - (s[2].0 - x) * (s[1].1 - y)) * inv_area;
                let w1 = ((s[2].0 - x) * (s[0].1 - y) - (s[0].0 - x) * (s[2].1 - y)) * inv_area;
                let w2 = 1.0 - w0 - w1;
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let inv = w0 * s[0].2 + w1 * s[1].2 + w2 * s[2].2;
                let k = py * self.width + px;
                if inv <= self.inv_depth[k] {
                    continue;
                }
                let col = if flat {
                    c[0]
                } else {
                    [0, 1, 2].map(|ch| w0 * c[0][ch] + w1 * c[1][ch] + w2 * c[2][ch])
                };
                if alpha >= 1.0 {
                    self.inv_depth[k] = inv;
                    self.color[k] = col;
                    if let Some((id, n)) = tag {
                        self.id[k] = id;
                        self.normal[k] = n;
                    }
                } else {
                    self.color[k] = lerp3(self.color[k], col, alpha);
                }
            }
        }
    }

    /// Blends a line from `a` to `b` (view space) over the image in `style`, hidden behind
    /// opaque surfaces (with a 1 % depth tolerance, so a surface's own edges show) and faded
    /// to `style.alpha_behind` where `veil` (a depth per pixel, e.g. the water's) is in
    /// front of it.
    pub fn line(&mut self, a: Vector, b: Vector, style: LineStyle, veil: &[Real]) {
        let LineStyle {
            color: c,
            alpha,
            width,
            alpha_behind,
        } = style;
        // Clip to the near plane.
        let (da, db) = (-a.z, -b.z);
        if da < NEAR && db < NEAR {
            return;
        }
        let (a, b) = if da < NEAR {
            (a + (b - a) * ((NEAR - da) / (db - da)), b)
        } else if db < NEAR {
            (a, b + (a - b) * ((NEAR - db) / (da - db)))
        } else {
            (a, b)
        };
        let (ax, ay, ia) = self.project(a);
        let (bx, by, ib) = self.project(b);
        let len = (bx - ax).hypot(by - ay);
        if !len.is_finite() {
            return;
        }
        let steps = len.ceil().max(1.0) as usize;
        let r = (0.5 * width).max(0.5);
        let ri = r.ceil() as isize;
        for k in 0..=steps {
            let t = k as Real / steps as Real;
            let (x, y) = (ax + (bx - ax) * t, ay + (by - ay) * t);
            let inv = ia + (ib - ia) * t;
            let (cx, cy) = (x.floor() as isize, y.floor() as isize);
            for oy in -ri..=ri {
                for ox in -ri..=ri {
                    let (px, py) = (cx + ox, cy + oy);
                    if px < 0 || py < 0 || px >= self.width as isize || py >= self.height as isize {
                        continue;
                    }
                    let dx = px as Real + 0.5 - x;
                    let dy = py as Real + 0.5 - y;
                    if dx * dx + dy * dy > r * r {
                        continue;
                    }
                    let k = py as usize * self.width + px as usize;
                    if inv < 0.99 * self.inv_depth[k] {
                        continue;
                    }
                    let a = if veil.get(k).is_some_and(|&v| v * inv < 1.0) {
                        alpha_behind
                    } else {
                        alpha
                    };
                    self.color[k] = lerp3(self.color[k], c, a);
                }
            }
        }
    }

    /// The image, box-filtered down by `factor` along each axis, as 8-bit sRGB-ish RGB.
    pub fn resolve(&self, factor: usize) -> (usize, usize, Vec<u8>) {
        let (w, h) = (self.width / factor, self.height / factor);
        let mut out = Vec::with_capacity(w * h * 3);
        let norm = 1.0 / (factor * factor) as Real;
        for y in 0..h {
            for x in 0..w {
                let mut acc = [0.0; 3];
                for dy in 0..factor {
                    for dx in 0..factor {
                        let c = self.color[(y * factor + dy) * self.width + x * factor + dx];
                        for ch in 0..3 {
                            acc[ch] += c[ch];
                        }
                    }
                }
                for a in acc {
                    out.push(
                        (a * norm)
                            .clamp(0.0, 1.0)
                            .powf(1.0 / 2.2)
                            .mul_add(255.0, 0.5) as u8,
                    );
                }
            }
        }
        (w, h, out)
    }
}

#[inline]
pub(crate) fn lerp3(a: Rgb, b: Rgb, t: Real) -> Rgb {
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
    ]
}

/// How [`Target::line`] draws: colour, opacity, width (pixels) and the opacity where the
/// line is behind the veil.
#[derive(Clone, Copy, Debug)]
pub struct LineStyle {
    /// The line's colour.
    pub color: Rgb,
    /// Its opacity in front of the veil.
    pub alpha: Real,
    /// Its width in pixels.
    pub width: Real,
    /// Its opacity behind the veil.
    pub alpha_behind: Real,
}
