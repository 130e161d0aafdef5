//! The walls' terms of one particle: the solid's density fraction `Φ` and its gradient over
//! every collider near (union of half-spaces), the walls' velocity and viscosity terms, the
//! pinch test, and Clavet's two wall densities; evaluated per chunk of particles.

use super::planes::WallPlanes;
use super::{Coupled, WallQuery};
use crate::boundary::ContactWorkspace;
use crate::boundary::bodies::{MovingCollider, entry_of};
use crate::boundary::forces::{ParticleShares, Share, WallSink, Watch};
use crate::kernel::HalfSpaceTable;
use crate::math::{Pose, Real, Vector};
use crate::neighbors::{NeighborGrid, NeighborLists};
use rapier3d::dynamics::{RigidBody, RigidBodyHandle};
use rapier3d::geometry::{Collider, ColliderHandle};

/// What [`WallWorkspace::update`](super::WallWorkspace::update) reads for every particle.
pub(super) struct Terms<'a> {
    pub(super) query: &'a WallQuery<'a>,
    pub(super) grid: &'a NeighborGrid,
    pub(super) neighbors: &'a NeighborLists,
    pub(super) positions: &'a [Vector],
    pub(super) candidates: &'a ContactWorkspace,
    /// The coupling table of the substep (empty without moving bodies).
    pub(super) table: &'a [MovingCollider],
    /// Half-space tables of the density and force kernels, and their full values.
    pub(super) td: &'a HalfSpaceTable,
    pub(super) tf: &'a HalfSpaceTable,
    pub(super) full: (Real, Real),
    pub(super) lap: crate::kernel::ViscosityLaplacian,
    /// Gravity, when the solver asked for the walls' hydrostatic pressure (else zero).
    pub(super) gravity: Vector,
    /// The hydrostatic terms are computed (asked for, under gravity).
    pub(super) hydro: bool,
    /// Some entry of the table is a dynamic body.
    pub(super) any_dynamic: bool,
}

/// One particle's wall terms, summed over its walls as a union of independent half-spaces:
/// `U' = 1 − (1 − U)(1 − a)`, `∇U' = ∇U·(1 − a) + ∇a·(1 − U)`.
struct Sum {
    /// Coverage `U`, its gradient (in units of the whole force kernel), `Σ v_wall·∇U`, and
    /// the hydrostatic acceleration.
    u: Real,
    g: Vector,
    m: Real,
    hs: Vector,
    /// The dynamic bodies' share of `g` and of `hs`, and `(|∇|², entry, point)` of the body
    /// contributing most.
    gc: Vector,
    hc: Vector,
    main: (Real, u32, Vector),
    /// Viscous sums `Σ L_k` and `Σ L_k·v_k`: all walls, and the dynamic bodies' share.
    ls: Real,
    lv: Vector,
    lc: Real,
    lvc: Vector,
    /// The walls as planes (filled when the query asks for them).
    planes: WallPlanes,
}

impl Sum {
    /// No wall: what a particle without candidates gets.
    const ZERO: Sum = Sum {
        u: 0.0,
        g: Vector::ZERO,
        m: 0.0,
        hs: Vector::ZERO,
        gc: Vector::ZERO,
        hc: Vector::ZERO,
        main: (0.0, u32::MAX, Vector::ZERO),
        ls: 0.0,
        lv: Vector::ZERO,
        lc: 0.0,
        lvc: Vector::ZERO,
        planes: WallPlanes::EMPTY,
    };

    /// Back to [`Sum::ZERO`] field by field (a whole-struct assignment copied its 200 bytes
    /// with `memcpy` for every particle); the planes only when they are kept (`planes`):
    /// otherwise nothing writes them and they stay empty.
    #[inline(always)]
    fn reset(&mut self, planes: bool) {
        self.u = 0.0;
        self.g = Vector::ZERO;
        self.m = 0.0;
        self.hs = Vector::ZERO;
        self.gc = Vector::ZERO;
        self.hc = Vector::ZERO;
        self.main = (0.0, u32::MAX, Vector::ZERO);
        self.ls = 0.0;
        self.lv = Vector::ZERO;
        self.lc = 0.0;
        self.lvc = Vector::ZERO;
        if planes {
            self.planes = WallPlanes::EMPTY;
        }
    }
}

/// A candidate collider with what the wall terms read of it besides its shape: the
/// collider, its coupling-table entry, the pose it stands at, and, outside the table, the
/// non-fixed body it moves with (made per particle from its cell's [`WallSlot`]).
#[derive(Copy, Clone)]
struct Wall<'a> {
    handle: ColliderHandle,
    co: &'a Collider,
    found: Option<(u32, &'a MovingCollider)>,
    pose: &'a Pose,
    body: Option<&'a RigidBody>,
}

/// What [`Wall`] holds, by handle and index, resolved once per cell instead of once per
/// particle (the particles are sorted by cell), and so that it outlives one update: each chunk of
/// particles keeps its buffer of these between updates (`WallWorkspace::cell_walls`), and a
/// warm step allocates nothing for them. The collider and the body are looked up by handle
/// again per particle (an arena index); the tree search, the table's binary search and the
/// pose's choice are not repeated.
#[derive(Copy, Clone, Debug)]
pub(crate) struct WallSlot {
    handle: ColliderHandle,
    entry: Option<u32>,
    pose: Pose,
    body: Option<RigidBodyHandle>,
}

/// The resolved candidates ([`WallSlot`]) of the cell last asked for, in a chunk's buffer.
struct CellWalls<'b> {
    cell: Option<u32>,
    slots: &'b mut Vec<WallSlot>,
}

impl<'b> CellWalls<'b> {
    fn new(slots: &'b mut Vec<WallSlot>) -> Self {
        slots.clear();
        Self { cell: None, slots }
    }

    /// The resolved candidates of sorted particle `i`'s cell, in the candidates' order
    /// (colliders no longer in the set left out).
    #[inline(always)]
    fn of(&mut self, t: &Terms<'_>, i: usize) -> &[WallSlot] {
        let cell = t.grid.cell_of(i);
        if self.cell != Some(cell) {
            self.cell = Some(cell);
            self.slots.clear();
            let (_, colliders, bodies) = t.query.scene;
            for &handle in t.candidates.of_cell(cell) {
                let Some(co) = colliders.get(handle) else {
                    continue;
                };
                let found = entry_of(t.table, handle);
                // A moving body stands at its pose of the substep's start, or of its end for
                // positions predicted to the end.
                let pose = match found {
                    Some((_, m)) if m.moving && t.query.predicted => m.stop,
                    Some((_, m)) if m.moving => m.start,
                    _ => *co.position(),
                };
                let body = match found {
                    Some(_) => None,
                    None => co
                        .parent()
                        .filter(|&b| bodies.get(b).is_some_and(|b| !b.is_fixed())),
                };
                self.slots.push(WallSlot {
                    handle,
                    entry: found.map(|(k, _)| k),
                    pose,
                    body,
                });
            }
        }
        self.slots
    }
}

impl<'a> Terms<'a> {
    /// The wall terms of sorted particle `i`, whose cell's candidates are `walls`, into `s`
    /// (which must be [`Sum::ZERO`], or reset to it); each wall's own terms go to `sink` as
    /// they are united (`()`: nowhere; see `boundary::forces`).
    #[inline(always)]
    fn particle<W: WallSink>(&self, i: usize, walls: &[WallSlot], s: &mut Sum, sink: &mut W) {
        let x = self.positions[i];
        let (_, colliders, bodies) = self.query.scene;
        for slot in walls {
            // Found when the cell's candidates were resolved, in this update.
            let Some(co) = colliders.get(slot.handle) else {
                continue;
            };
            let w = Wall {
                handle: slot.handle,
                co,
                found: slot.entry.map(|k| (k, &self.table[k as usize])),
                pose: &slot.pose,
                body: slot.body.and_then(|b| bodies.get(b)),
            };
            sink.begin(w.handle);
            self.add_wall(s, &w, x, sink);
        }
        if self.hydro && s.g != Vector::ZERO {
            // The neighbours' pressure is carried back to the particle by the hydrostatic
            // difference from their weighted center (the same weights as DFSPH's average);
            // ∇ρ_wall = g·ρ0·full_f.
            let off = self.neighbour_center(i, -s.g.normalize());
            let c = self.full.1 * self.gravity.dot(off);
            s.hs += s.g * c;
            sink.center(c);
            if self.any_dynamic {
                s.hc += s.gc * c;
            }
        }
    }

    /// Adds wall `w` to the terms `s` of the particle at `x`.
    #[inline(always)]
    fn add_wall<W: WallSink>(&self, s: &mut Sum, w: &Wall<'_>, x: Vector, sink: &mut W) {
        let h = self.query.params.smoothing_length;
        let (full_d, full_f) = self.full;
        let found = w.found;
        let Some((d, normal, point)) = surface_near(w.co, w.pose, x, h) else {
            return;
        };
        if self.query.planes {
            // Every wall within the support, also one the particle does not reach yet.
            let speed = self.wall_velocity(w, point).map_or(0.0, |v| v.dot(normal));
            s.planes.push(d, normal, speed);
        }
        let (phi, _) = self.td.eval(d);
        // The force kernel's three values in one look-up (the moment is read with the
        // hydrostatic terms only).
        let (phi_f, area, mom) = self.tf.eval_with_moment(d);
        let a = (phi / full_d).min(1.0);
        let lk = if self.query.viscous {
            self.lap.half_space_integral(d) * (1.0 - s.u)
        } else {
            0.0
        };
        if a <= 0.0 && area <= 0.0 && lk <= 0.0 {
            return;
        }
        let wall_velocity = self.wall_velocity(w, point);
        // ∇Φ = −A(d)·n (into the wall), in units of the whole kernel.
        let ga = -normal * (area / full_f);
        let gk = ga * (1.0 - s.u);
        let mut hk = Vector::ZERO;
        if self.hydro {
            let gravity = self.gravity;
            let gn = normal * normal.dot(gravity);
            hk = -(gn * mom + (gravity - gn) * phi_f) * (1.0 - s.u);
            s.hs = s.hs * (1.0 - a) + hk;
        }
        let lv = wall_velocity.map_or(Vector::ZERO, |v| v * lk);
        sink.wall(a, gk, hk, lk, lv, point);
        s.g = s.g * (1.0 - a) + gk;
        s.u = 1.0 - (1.0 - s.u) * (1.0 - a);
        s.ls += lk;
        if let Some(v) = wall_velocity {
            s.lv += v * lk;
        }
        if self.any_dynamic {
            s.gc *= 1.0 - a;
            s.hc *= 1.0 - a;
            if let Some((e, mc)) = found
                && mc.dynamic
            {
                s.gc += gk;
                s.hc += hk;
                s.lc += lk;
                s.lvc += wall_velocity.unwrap_or(Vector::ZERO) * lk;
                let l = gk.length_squared();
                // The first dynamic body always (its viscous share may come without a
                // gradient at the support's edge), then the one with the largest gradient.
                if l > s.main.0 || s.main.1 == u32::MAX {
                    s.main = (l, e, point);
                }
            }
        }
        if let Some(v) = wall_velocity {
            s.m += v.dot(gk);
        }
    }

    /// Wall `w`'s velocity at its closest point `point` (static: none).
    #[inline(always)]
    fn wall_velocity(&self, w: &Wall<'_>, point: Vector) -> Option<Vector> {
        match w.found {
            Some((_, mc)) if mc.moving && self.query.predicted => Some(mc.velocity_at_stop(point)),
            Some((_, mc)) if mc.moving => Some(mc.velocity_at_start(point)),
            Some(_) => None,
            None => w.body.map(|b| b.velocity_at_point(point)),
        }
    }

    /// `x̄_i − x_i`, the center of the neighbours of sorted particle `i` weighted by
    /// `max(0, ∇W_ij·û)` (the weights of the wall's pressure, see
    /// [`WallWorkspace::neighbour_pressure`](super::WallWorkspace::neighbour_pressure)); zero when none has weight, or in a periodic
    /// grid (the separations would need the minimum image).
    fn neighbour_center(&self, i: usize, away: Vector) -> Vector {
        if self.grid.is_periodic() {
            return Vector::ZERO;
        }
        let h = self.query.params.smoothing_length;
        let positions = self.positions;
        crate::with_kernel!(self.query.force_kernel, K => {
            use crate::kernel::Kernel;
            let k = K::new(h);
            let xi = positions[i];
            let (mut sw, mut sx) = (0.0, Vector::ZERO);
            for &j in self.neighbors.of(i) {
                let r = xi - positions[j as usize];
                let d = r.length();
                // Coincident particles have no direction.
                if d >= h || d <= 0.0 {
                    continue;
                }
                let w = (r * (k.dw(d) / d)).dot(away).max(0.0);
                sw += w;
                sx -= r * w;
            }
            if sw > 0.0 { sx / sw } else { Vector::ZERO }
        })
    }
}

/// The wall terms of the particles of one chunk (`first`: its first particle) into its
/// rows; with `watch`, the watched colliders' shares too, into the chunk's own buffer `out`
/// (so the shares stay in particle order). Returns how many particles have a wall near.
///
/// A cell's candidates are resolved once for its particles (see [`CellWalls`]); a particle
/// whose cell has none gets the rows of [`Sum::ZERO`] without the walls' loop. The counts
/// that led here are in docs/performance.md ("The walls' stage, counted").
#[inline]
pub(super) fn update_chunk(
    first: usize,
    mut rows: Rows<'_>,
    terms: &Terms<'_>,
    watch: Option<&Watch>,
    (out, slots): (&mut Vec<Share>, &mut Vec<WallSlot>),
) -> usize {
    let mut cells = CellWalls::new(slots);
    let mut s = Sum::ZERO;
    let Some(watch) = watch else {
        return (0..rows.density.len())
            .map(|k| {
                let walls = cells.of(terms, first + k);
                if walls.is_empty() {
                    return rows.set(k, terms, &Sum::ZERO);
                }
                s.reset(terms.query.planes);
                terms.particle(first + k, walls, &mut s, &mut ());
                rows.set(k, terms, &s)
            })
            .sum::<usize>();
    };
    (0..rows.density.len())
        .map(|k| {
            let walls = cells.of(terms, first + k);
            if walls.is_empty() {
                return rows.set(k, terms, &Sum::ZERO);
            }
            let mut sink = ParticleShares {
                watch,
                particle: (first + k) as u32,
                first: out.len(),
                out: &mut *out,
                current: None,
            };
            s.reset(terms.query.planes);
            terms.particle(first + k, walls, &mut s, &mut sink);
            rows.set(k, terms, &s)
        })
        .sum::<usize>()
}

/// One chunk of [`WallWorkspace`](super::WallWorkspace)'s per-particle arrays.
pub(super) struct Rows<'c> {
    pub(super) density: &'c mut [Real],
    pub(super) gradient: &'c mut [Vector],
    pub(super) motion: &'c mut [Real],
    pub(super) coverage: &'c mut [Real],
    pub(super) coupled: &'c mut [Coupled],
    pub(super) hydrostatic: &'c mut [Vector],
    pub(super) viscous: &'c mut [Real],
    pub(super) viscous_velocity: &'c mut [Vector],
    /// The chunk's planes (empty unless the query asks for them).
    pub(super) planes: &'c mut [WallPlanes],
}

impl Rows<'_> {
    /// Writes the terms `s` into row `k`; returns 1 when a wall is within the particle's
    /// support, else 0.
    #[inline(always)]
    fn set(&mut self, k: usize, t: &Terms<'_>, s: &Sum) -> usize {
        let rest_density = t.query.params.rest_density;
        let (full_d, full_f) = t.full;
        self.density[k] = rest_density * full_d * s.u;
        self.gradient[k] = s.g * (rest_density * full_f);
        self.motion[k] = s.m * rest_density * full_f;
        self.coverage[k] = s.u;
        self.hydrostatic[k] = s.hs;
        if t.query.viscous {
            self.viscous[k] = s.ls;
            self.viscous_velocity[k] = s.lv;
        }
        if t.query.planes {
            self.planes[k] = s.planes;
        }
        if t.any_dynamic {
            self.coupled[k] = Coupled {
                gradient: s.gc * (rest_density * full_f),
                hydrostatic: s.hc,
                entry: s.main.1,
                point: s.main.2,
                viscous: s.lc,
                viscous_velocity: s.lvc,
            };
        }
        (s.u > 0.0 || s.g != Vector::ZERO || s.ls > 0.0) as usize
    }
}

/// Clavet's two wall densities and their gradients at `x` from the colliders among `cands`,
/// with the tables `(t2, t3)` of the kernels `(1 − q)²` and `(1 − q)³`: the union of
/// half-spaces per kernel, as in [`WallWorkspace::update`](super::WallWorkspace::update), per volume of the lattice rows
/// behind the wall. Only fixed and kinematic colliders count: dynamic bodies meet Clavet's
/// water through contact alone (see [`crate::solver::clavet`], "Walls": counted, their term
/// held a 1,400 kg/m³ box in the water).
#[inline(always)]
pub(super) fn clavet_walls(
    query: &WallQuery<'_>,
    table: &[MovingCollider],
    cands: &[rapier3d::geometry::ColliderHandle],
    (t2, t3): (&HalfSpaceTable, &HalfSpaceTable),
    x: Vector,
) -> ([Real; 2], [Vector; 2]) {
    let (_, colliders, bodies) = query.scene;
    let (h, spacing) = (query.params.smoothing_length, query.params.particle_spacing);
    // Number density of the lattice rows behind the wall.
    let per_volume = 1.0 / (spacing * spacing * spacing);
    let (full2, full3) = (t2.full(), t3.full());
    let (mut u, mut g): ([Real; 2], [Vector; 2]) = ([0.0; 2], [Vector::ZERO; 2]);
    for &handle in cands {
        let Some(co) = colliders.get(handle) else {
            continue;
        };
        if co
            .parent()
            .and_then(|b| bodies.get(b))
            .is_some_and(|b| b.is_dynamic())
        {
            // A dynamic body: contact only.
            continue;
        }
        let pose = match entry_of(table, handle) {
            Some((_, m)) if m.moving => &m.stop,
            _ => co.position(),
        };
        let Some((d, normal, _)) = surface_near(co, pose, x, h) else {
            continue;
        };
        for (t, (table, full)) in [(t2, full2), (t3, full3)].into_iter().enumerate() {
            let (phi, area) = table.eval(d);
            let a = (phi / full).min(1.0);
            let gk = -normal * (area / full * (1.0 - u[t]));
            g[t] = g[t] * (1.0 - a) + gk;
            u[t] = 1.0 - (1.0 - u[t]) * (1.0 - a);
        }
    }
    (
        [u[0] * full2 * per_volume, u[1] * full3 * per_volume],
        [g[0] * (full2 * per_volume), g[1] * (full3 * per_volume)],
    )
}

/// The surface of collider `co` (at `pose`) near `x`: the signed distance `d` to its closest
/// point (negative inside the solid), the normal there pointing to the fluid side, and the
/// point. `None` beyond `h`, or on the surface of a shape without a normal there.
#[inline]
pub(crate) fn surface_near(
    co: &rapier3d::geometry::Collider,
    pose: &crate::math::Pose,
    x: Vector,
    h: Real,
) -> Option<(Real, Vector, Vector)> {
    let proj = co.shape().project_point_with_max_dist(pose, x, false, h)?;
    let offset = x - proj.point;
    let dist = offset.length();
    let normal = if dist > 1e-6 * h {
        if proj.is_inside {
            -offset / dist
        } else {
            offset / dist
        }
    } else {
        // On the surface: the feature's normal, if the shape has one.
        let local = pose.inverse_transform_point(x);
        let (_, feature) = co.shape().project_local_point_and_get_feature(local);
        pose.rotation * co.shape().feature_normal_at_point(0, feature, local)?
    };
    let d = if proj.is_inside { -dist } else { dist };
    Some((d, normal, proj.point))
}
