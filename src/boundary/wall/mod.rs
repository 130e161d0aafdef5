//! Stage 2: walls that count in the density.
//!
//! A particle next to a wall is missing the neighbours the wall's volume takes up: summed over
//! fluid particles alone, its density is too low, its pressure negative or zero, and it clings
//! to the wall and clumps (the Unity paper's Figure 7). Here every collider within the kernel
//! support contributes the density of its solid volume, `ρ0·Φ`, and the gradient of that
//! density, which the pressure stages turn into a wall pressure force (pressure mirrored
//! from the particle, as in Akinci et al. 2012).
//!
//! `Φ` is the kernel's integral over the solid, computed as the integral over the half-space
//! behind the collider's surface at the closest point (see [`crate::kernel::half_space`];
//! Koschier & Bender 2017's density maps, with the distance field evaluated on the fly by a
//! parry point projection instead of a precomputed grid). Several colliders combine as the
//! union of independent half-spaces, `Φ = 1 − Π(1 − Φ_k)`: exact next to one wall, exact at
//! the tip of a right-angled corner (¾ of the kernel inside the walls), and never counting a
//! region twice. Limits, stated plainly: curvature within one kernel radius is ignored (a
//! concave corner inside a *single* trimesh sees only its nearest face), and a thin plate with
//! fluid on both sides counts as a half-space from each side.
//!
//! The wall's velocity at the closest point enters the density's rate of change, so moving
//! bodies compress the fluid they push.
//!
//! A particle the walls alone bring close to `ρ0` (squeezed into a gap narrower than the
//! fluid's spacing, such as the layer under a heavy body landing on the floor) is *pinched*
//! ([`WallWorkspace::pinched`]): no motion of its own lowers its density, and the pressure
//! solves leave it to contact and to its neighbours.
//!
//! Clavet's relaxation has two densities of its own kernels, `Σ(1 − q)²` and `Σ(1 − q)³`:
//! [`WallWorkspace::update_clavet`] adds the walls to those the same way (see
//! [`crate::solver::clavet`], "Walls").
//!
//! With [`crate::FluidParams::wall_viscosity`] `ε_w > 0` the solid volume also stands in for
//! fluid moving with the wall in Müller's viscosity term: `Σ_j m/ρ_j ∇²W_ij (v_j − v_i)`
//! gains `Σ_k L_k (v_k − v_i)`, `L_k` the viscosity Laplacian integrated over wall `k`'s
//! half-space ([`crate::kernel::ViscosityLaplacian::half_space_integral`], combined over
//! several walls like the density) and `v_k` the wall's velocity at the closest point. The
//! pipeline applies it implicitly per particle after the solver (see `wall_viscosity` in
//! `pipeline/substep.rs` and [`crate::forces::wall_viscosity`]), and a dynamic body takes the
//! opposite impulse.

use super::ContactWorkspace;
use super::bodies::MovingCollider;
use super::candidates::ColliderQuery;
use super::forces::{Share, Watch};
use crate::kernel::{HalfSpaceTable, KernelKind};
use crate::math::{Real, Vector};
use crate::neighbors::NeighborGrid;
use crate::par::CHUNK;
use parry3d::partitioning::Bvh;
use rapier3d::dynamics::RigidBodySet;
use rapier3d::geometry::ColliderSet;
use rapier3d::glamx::Vec3A;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

mod planes;
mod terms;
pub(crate) use planes::WallPlanes;
pub(crate) use terms::surface_near;
use terms::{Rows, Terms, WallSlot, clavet_walls, update_chunk};

/// What the wall stage reads besides the particles: the fluid's parameters, what its solver
/// asks for, and the rapier side.
pub(crate) struct WallQuery<'a> {
    /// The fluid's parameters (density kernel, support, spacing, rest density, groups).
    pub params: &'a crate::params::FluidParams,
    /// Kernel of the pressure-gradient table (the solver's force kernel).
    pub force_kernel: KernelKind,
    /// The broad-phase's tree, the colliders and the bodies.
    pub scene: (&'a Bvh, &'a ColliderSet, &'a RigidBodySet),
    /// The moving bodies of the substep, if any.
    pub coupling: Option<&'a super::Coupling>,
    /// Gravity, when the solver asks for the walls' hydrostatic pressure.
    pub hydrostatic: Option<Vector>,
    /// Whether to compute the walls' viscous sums.
    pub viscous: bool,
    /// The positions are predicted to the substep's end (moving bodies are taken there).
    pub predicted: bool,
    /// The watched colliders, when some collider's forces are watched: each particle's
    /// shares of its walls are recorded in [`WallWorkspace::share_chunks`].
    pub watch: Option<&'a Watch>,
    /// Keep each particle's walls as planes ([`WallWorkspace::plane_chunks`]).
    pub planes: bool,
}

impl WallQuery<'_> {
    /// The colliders the fluid may meet (see [`ColliderQuery`]).
    fn colliders(&self) -> ColliderQuery<'_> {
        let (bvh, colliders, _) = self.scene;
        ColliderQuery {
            bvh,
            colliders,
            groups: self.params.collision_groups,
            coupling: self.coupling,
        }
    }
}

/// A particle's wall terms due to dynamic bodies (see [`WallWorkspace::coupled`]).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Coupled {
    /// Dynamic bodies' share of the wall density's gradient (kg/m⁴).
    pub gradient: Vector,
    /// Dynamic bodies' share of the hydrostatic wall acceleration (m/s²).
    pub hydrostatic: Vector,
    /// Coupling-table entry of the body contributing most (`u32::MAX`: none).
    pub entry: u32,
    /// Closest point on that body's surface.
    pub point: Vector,
    /// Dynamic bodies' share of [`WallWorkspace::viscous`] (1/m²).
    pub viscous: Real,
    /// Dynamic bodies' share of [`WallWorkspace::viscous_velocity`] (m/s/m²).
    pub viscous_velocity: Vector,
}

impl Default for Coupled {
    fn default() -> Self {
        Self {
            gradient: Vector::ZERO,
            hydrostatic: Vector::ZERO,
            entry: u32::MAX,
            point: Vector::ZERO,
            viscous: 0.0,
            viscous_velocity: Vector::ZERO,
        }
    }
}

/// Per-particle wall contributions of the current step (indexed like the sorted particles).
#[derive(Clone, Debug, Default)]
pub struct WallWorkspace {
    candidates: ContactWorkspace,
    tables: Option<(
        KernelKind,
        KernelKind,
        Real,
        Real,
        HalfSpaceTable,
        HalfSpaceTable,
    )>,
    /// Density the walls add to each particle, `ρ0·Φ` (kg/m³; 0 far from every wall).
    pub density: Vec<Real>,
    /// Gradient of that density at the particle, computed with the force kernel (kg/m⁴). It
    /// points into the walls.
    pub gradient: Vec<Vector>,
    /// `Σ_k v_wall,k · ∇ρ_wall,k`: the part of the density's rate of change due to the walls'
    /// own motion (0 for static colliders).
    pub motion: Vec<Real>,
    /// Fraction `Φ ∈ [0, 1]` of each particle's kernel covered by walls.
    pub coverage: Vec<Real>,
    /// Acceleration from the walls' hydrostatic pressure (m/s²; zero unless
    /// `hydrostatic_on`): the
    /// wall's pressure is the particle's plus the hydrostatic difference, `p_b = p_i +
    /// ρ0·g·(x_b − x_i)` (Adami et al. 2012's wall pressure), and the mirrored part `p_i`
    /// acts through `gradient`; this is the rest, `−Σ_b V_b (g·(x_b − x_i)) ∇W_ib =
    /// −(M·n⊗n + Φ·(I − n⊗n))·g` per wall (see [`HalfSpaceTable::eval_moment`]), plus
    /// `∇ρ_wall·(g·(x̄_i − x_i))/ρ0`: the wall's pressure is taken from the neighbours
    /// (see `neighbour_pressure`), whose weighted center `x̄_i` is not at the particle.
    pub hydrostatic: Vec<Vector>,
    /// `true` when the last update computed `hydrostatic` (asked for it, under gravity).
    pub hydrostatic_on: bool,
    /// The parts of `gradient` and of `hydrostatic` due to dynamic bodies of the coupling
    /// table, with the table entry and surface point of the body contributing most
    /// (`u32::MAX`: none). Empty when no dynamic body is near (see [`super::bodies`]).
    pub coupled: Vec<Coupled>,
    /// `true` when `coupled` holds data for this update.
    pub coupled_any: bool,
    /// `L_i = Σ_k L_k`, the viscosity Laplacian integrated over the walls near each particle
    /// (1/m²; see the module docs). Meaningful only after an update asked for it.
    pub viscous: Vec<Real>,
    /// `Σ_k L_k·v_k`, the walls' velocities weighted like `viscous` (zero for static walls).
    pub viscous_velocity: Vec<Vector>,
    /// Weight `γ` of the particle's own pressure in the wall's pressure force for DFSPH:
    /// [`crate::solver::WALL_MIRROR`] (the own pressure counted once).
    pub mirror: Real,
    /// `true` when the update was asked for the hydrostatic wall pressure: the wall's
    /// pressure is then the particle's *neighbours'* pressure carried back to it, not the
    /// particle's own mirrored (see [`crate::solver::HYDROSTATIC_WALL_MIRROR`]). DFSPH adds
    /// `π̂_i·∇ρ_wall` to the own term, `π̂_i` the average of the pressure values of the
    /// neighbours on the fluid side of the particle, weighted by `max(0, ∇W_ij·û_i)` with
    /// `û_i` the unit vector away from the walls (`−∇ρ_wall` normalised); the hydrostatic
    /// difference from their weighted center back to the particle is part of `hydrostatic`.
    pub neighbour_pressure: bool,
    /// Clavet's densities `Σ(1 − q)²` and `Σ(1 − q)³` (see [`crate::solver::clavet`]) the
    /// walls add to each particle, from the static and kinematic colliders: the solid as the
    /// rows of the fluid's lattice continued behind its surface, as for `density`. Dynamic
    /// bodies meet a Clavet fluid through contact, whose impulses they receive. Filled by
    /// [`Self::update_clavet`]; empty otherwise.
    pub clavet: Vec<[Real; 2]>,
    /// Gradients of the two densities of `clavet` at the particle (1/m; into the walls).
    pub clavet_gradient: Vec<[Vector; 2]>,
    clavet_tables: Option<(Real, Real, HalfSpaceTable, HalfSpaceTable)>,
    /// Per chunk of particles, the watched colliders' shares of their wall terms (in particle
    /// order; empty unless [`WallQuery::watch`]; see `boundary::forces`).
    pub(crate) share_chunks: Vec<Vec<Share>>,
    /// Per particle `Σ_walls G(d) n_w`, the walls' adhesion term (see
    /// `boundary::adhesion`); empty unless the fluid has adhesion and a wall is near.
    pub(crate) adhesion: Vec<Vector>,
    adhesion_table: Option<crate::forces::surface_tension::AdhesionTable>,
    near: usize,
    /// See [`Self::pinch_fraction`].
    pinch_fraction: Real,
    /// Per chunk of particles, each particle's walls as planes (empty unless
    /// [`WallQuery::planes`]; see [`Self::predicted_density`]).
    pub(crate) plane_chunks: Vec<Vec<WallPlanes>>,
    /// Per chunk of particles, the candidates of the cell being updated, resolved once for
    /// the cell's particles (kept between updates: a warm step allocates nothing).
    cell_walls: Vec<Vec<WallSlot>>,
    /// `ρ0` times the density kernel's full integral: the walls' density of a coverage of 1.
    plane_density: Real,
}

impl WallWorkspace {
    /// `true` when some particle had a wall within its support at the last update.
    pub fn any(&self) -> bool {
        self.near > 0
    }

    /// `true` when the walls and the particle's own share `self_density` (`m·W(0)`) alone
    /// bring particle `i` above [`Self::pinch_fraction`] of `rest_density`: it sits in a gap
    /// between solids narrower than the fluid can fill (a body landing on the floor squeezes
    /// such a layer), or has been pressed into a wall. No motion of the particle brings its
    /// density down to `ρ0` there, so the pressure solves leave it out (DFSPH, PBF): asked
    /// to, they raise its pressure iteration after iteration, and that pressure pushes the
    /// bodies around it (without this test a 5,000 kg/m³ box landing in water is thrown
    /// 100 m up with DFSPH, with PBF from 3,000 kg/m³; `tests/buoyancy.rs` lands such boxes).
    /// Contact keeps it out of the solids, and its neighbours still push it out of the gap.
    #[inline]
    pub fn pinched(&self, i: usize, self_density: Real, rest_density: Real) -> bool {
        self.pinch_fraction > 0.0
            && self
                .density
                .get(i)
                .is_some_and(|&w| w + self_density >= self.pinch_fraction * rest_density)
    }

    #[cfg(test)]
    /// The threshold of [`Self::pinched`], as a fraction of `ρ0`: halfway between the
    /// densest place a particle of a resting lattice can have next to walls and `ρ0`
    /// itself. That place is the tip of a right-angled corner, one contact radius (half a
    /// spacing) from three walls: walls and own share give `ρ0·(1 − (1 − Φ(s/2))³) + m·W(0)`
    /// there (0.704 ρ0 with the cubic spline at `h = 2s`, 0.757 with Wendland C2, 0.674 with
    /// poly6; one flat wall 0.468, an edge 0.596, and a particle midway in a gap one spacing
    /// wide the same as an edge: the layer a heavy body rests on is not pinched). Pinched
    /// with the cubic spline at `h = 2s` (threshold 0.852): a particle midway in a gap
    /// narrower than about 0.47 spacings, or one on a wall's surface with another wall
    /// closer than about 0.7 spacings (interpolated between table values at quarter
    /// spacings). 0 (nothing pinched) until the first update.
    pub fn pinch_fraction(&self) -> Real {
        self.pinch_fraction
    }

    /// `ρ0` times the force kernel's full integral: what turns a wall term's gradient in units
    /// of the whole kernel into kg/m⁴ (as [`Self::gradient`]); 0 before the first update.
    pub(crate) fn gradient_unit(&self, rest_density: Real) -> Real {
        self.tables
            .as_ref()
            .map_or(0.0, |(_, _, _, _, _, tf)| rest_density * tf.full())
    }

    /// With [`WallQuery::planes`]: the walls' density of particle `i` after it moves with
    /// velocity `v` for `dt`, the colliders near it taken as the planes at their closest
    /// points (see `planes.rs`). `None` where no plane was kept: no wall within the
    /// support, more walls than kept, or planes not asked for.
    #[inline]
    pub(crate) fn predicted_density(&self, i: usize, v: Vector, dt: Real) -> Option<Real> {
        let planes = self.plane_chunks.get(i / CHUNK)?.get(i % CHUNK)?;
        let (_, _, _, _, td, _) = self.tables.as_ref()?;
        let u = planes.coverage_after(v, dt, td, td.full())?;
        Some(self.plane_density * u)
    }

    /// With [`WallQuery::planes`]: every particle's velocity in `v` as contact at `radius`
    /// will leave it after `dt` (see `WallPlanes::clip`), into `out`; a particle without
    /// planes keeps its own.
    pub(crate) fn clip_velocities(
        &self,
        v: &[Vec3A],
        (dt, radius): (Real, Real),
        out: &mut Vec<Vec3A>,
    ) {
        out.resize(v.len(), Vec3A::ZERO);
        let planes = &self.plane_chunks;
        crate::par_chunks_mut!(out, CHUNK)
            .enumerate()
            .for_each(|(c, out)| {
                let v = &v[c * CHUNK..][..out.len()];
                match planes.get(c).filter(|p| p.len() == out.len()) {
                    Some(p) => {
                        for ((o, &v), p) in out.iter_mut().zip(v).zip(p) {
                            *o = Vec3A::from(p.clip(Vector::from(v), dt, radius));
                        }
                    }
                    None => out.copy_from_slice(v),
                }
            });
    }

    /// Forgets every contribution (no collider near the fluid).
    pub fn clear(&mut self) {
        self.plane_chunks.clear();
        self.candidates.clear();
        self.near = 0;
        self.density.clear();
        self.gradient.clear();
        self.motion.clear();
        self.coverage.clear();
        self.hydrostatic.clear();
        self.hydrostatic_on = false;
        self.coupled.clear();
        self.coupled_any = false;
        self.viscous.clear();
        self.viscous_velocity.clear();
        self.clavet.clear();
        self.clavet_gradient.clear();
        self.adhesion.clear();
    }

    /// The walls' adhesion term ([`Self::adhesion`]) of every particle of `grid`, at the
    /// positions and with the colliders of the last [`Self::update`]; empty when no wall is
    /// near.
    pub(crate) fn update_adhesion(
        &mut self,
        grid: &NeighborGrid,
        positions: &[Vector],
        query: &WallQuery<'_>,
    ) {
        if !self.candidates.any() {
            self.adhesion.clear();
            return;
        }
        let h = query.params.smoothing_length;
        if self
            .adhesion_table
            .as_ref()
            .is_none_or(|t| t.support() != h)
        {
            self.adhesion_table = Some(crate::forces::surface_tension::AdhesionTable::new(h));
        }
        let Some(table) = &self.adhesion_table else {
            unreachable!("made above")
        };
        super::adhesion::update(
            &self.candidates,
            grid,
            positions,
            query,
            table,
            &mut self.adhesion,
        );
    }

    fn tables(&mut self, density: KernelKind, force: KernelKind, h: Real, spacing: Real) {
        let fresh = match &self.tables {
            Some((d, f, th, ts, ..)) => *d != density || *f != force || *th != h || *ts != spacing,
            None => true,
        };
        if fresh {
            let td = crate::with_kernel!(density, K => HalfSpaceTable::new::<K>(h, spacing));
            let tf = crate::with_kernel!(force, K => HalfSpaceTable::new::<K>(h, spacing));
            let own = spacing.powi(3) * density.w(0.0, h);
            let corner = 1.0 - (1.0 - td.eval(0.5 * spacing).0).powi(3) + own;
            self.pinch_fraction = 0.5 * (1.0 + corner);
            self.tables = Some((density, force, h, spacing, td, tf));
        }
    }

    /// Computes the wall contributions of every particle of `grid`, whose sorted positions
    /// are `positions`. Returns the number of particles with a wall within `h`. `neighbors`
    /// must be the lists over `grid` when `hydrostatic` is given (they are read only then).
    ///
    /// The moving bodies of `coupling`'s table stand at their pose of the substep's start,
    /// where the particles are for WCSPH and DFSPH; with `predicted` (PBF, whose positions
    /// are predicted to the substep's end before this update) they stand at their pose of
    /// the substep's *end*, with their surface velocity there, so a position constraint
    /// pairs particle and body at the same time. Taken at its start, a body's motion over
    /// the substep would be missing from PBF's constraints, and the velocity change its
    /// impulses make (which moves it from the next substep on) would reach them a substep
    /// late: an explicit-Euler loop, which a body resting on particles pinched against the
    /// floor (stiff: they cannot move out of the way) drives into growing oscillation
    /// (stability case 11, `cargo run --release --example stability -- --case "heavy body"
    /// --solver pbf`: a 2000 kg/m³ box rocks and explodes after about 1 s at the start pose;
    /// at the end pose it rests, KE ratio 0.015).
    pub(crate) fn update(
        &mut self,
        search: &crate::neighbors::NeighbourSearch,
        positions: &[Vector],
        query: &WallQuery<'_>,
    ) -> usize {
        let p = query.params;
        let (h, spacing) = (p.smoothing_length, p.particle_spacing);
        self.tables(p.density_kernel, query.force_kernel, h, spacing);
        self.candidates
            .gather(&search.grid, positions, positions, h, &query.colliders());
        let table = query.coupling.map_or(&[][..], |c| c.table());
        self.size_for(positions.len(), query, table);
        let watch = query.watch;
        // One buffer per chunk (empty, allocated once, when nothing is watched).
        self.share_chunks
            .resize_with(positions.len().div_ceil(CHUNK), Vec::new);
        if watch.is_some() {
            self.share_chunks.iter_mut().for_each(Vec::clear);
        }
        self.plane_chunks
            .resize_with(positions.len().div_ceil(CHUNK), Vec::new);
        self.cell_walls
            .resize_with(positions.len().div_ceil(CHUNK), Vec::new);
        if !self.candidates.any() || !query.planes {
            self.plane_chunks.iter_mut().for_each(Vec::clear);
        }
        if !self.candidates.any() {
            self.zero(query.viscous);
            return 0;
        }
        let Some((_, _, _, _, td, tf)) = &self.tables else {
            unreachable!("tables are made above")
        };
        let gravity = query.hydrostatic.unwrap_or(Vector::ZERO);
        self.plane_density = p.rest_density * td.full();
        let terms = Terms {
            query,
            grid: &search.grid,
            neighbors: &search.lists,
            positions,
            candidates: &self.candidates,
            table,
            td,
            tf,
            full: (td.full(), tf.full()),
            lap: crate::kernel::ViscosityLaplacian::new(h),
            gravity,
            hydro: self.hydrostatic_on,
            any_dynamic: self.coupled_any,
        };
        let near = crate::par_chunks_mut!(self.density, CHUNK)
            .zip(crate::par_chunks_mut!(self.gradient, CHUNK))
            .zip(crate::par_chunks_mut!(self.motion, CHUNK))
            .zip(crate::par_chunks_mut!(self.coverage, CHUNK))
            .zip(crate::par_chunks_mut!(self.coupled, CHUNK))
            .zip(crate::par_chunks_mut!(self.hydrostatic, CHUNK))
            .zip(crate::par_chunks_mut!(self.viscous, CHUNK))
            .zip(crate::par_chunks_mut!(self.viscous_velocity, CHUNK))
            .zip(crate::par_iter_mut!(self.share_chunks[..]))
            .zip(crate::par_iter_mut!(self.plane_chunks[..]))
            .zip(crate::par_iter_mut!(self.cell_walls[..]))
            .enumerate()
            .map(|(c, tuple)| {
                let (
                    (
                        (
                            (
                                (
                                    (
                                        ((((density, gradient), motion), coverage), coupled),
                                        hydrostatic,
                                    ),
                                    viscous,
                                ),
                                viscous_velocity,
                            ),
                            out,
                        ),
                        planes,
                    ),
                    slots,
                ) = tuple;
                if query.planes {
                    planes.resize(density.len(), WallPlanes::default());
                }
                let rows = Rows {
                    density,
                    gradient,
                    motion,
                    coverage,
                    coupled,
                    hydrostatic,
                    viscous,
                    viscous_velocity,
                    planes,
                };
                update_chunk(c * CHUNK, rows, &terms, watch, (out, slots))
            })
            .sum();
        self.near = near;
        near
    }

    /// Sizes every per-particle array for `n` particles and sets the flags of this update
    /// (`table`: the coupling table). Arrays a fluid does not use this update are sized all
    /// the same, so the chunks line up (allocated once); they are read only when their flag
    /// says so (`hydrostatic_on`, `coupled_any`, an update asked for the viscous sums).
    fn size_for(&mut self, n: usize, query: &WallQuery<'_>, table: &[MovingCollider]) {
        self.density.resize(n, 0.0);
        self.gradient.resize(n, Vector::ZERO);
        self.motion.resize(n, 0.0);
        self.coverage.resize(n, 0.0);
        self.mirror = crate::solver::WALL_MIRROR;
        self.neighbour_pressure = query.hydrostatic.is_some();
        self.hydrostatic_on = query.hydrostatic.is_some_and(|g| g != Vector::ZERO);
        self.hydrostatic.resize(n, Vector::ZERO);
        self.coupled_any = table.iter().any(|m| m.dynamic);
        self.coupled.resize(n, Coupled::default());
        self.viscous.resize(n, 0.0);
        self.viscous_velocity.resize(n, Vector::ZERO);
    }

    /// No wall near any particle: every contribution zero.
    fn zero(&mut self, viscous: bool) {
        self.density.fill(0.0);
        self.gradient.fill(Vector::ZERO);
        self.motion.fill(0.0);
        self.coverage.fill(0.0);
        self.hydrostatic.fill(Vector::ZERO);
        if viscous {
            self.viscous.fill(0.0);
            self.viscous_velocity.fill(Vector::ZERO);
        }
        self.near = 0;
    }

    /// Clavet's wall densities ([`Self::clavet`], [`Self::clavet_gradient`]) of every particle
    /// of `grid` at its (predicted) position in `positions`, with the colliders found by the
    /// last [`Self::update`] on the same positions. Moving kinematic bodies stand at their pose
    /// of the substep's end (the positions are predicted there); dynamic bodies do not count
    /// (contact only, see `terms::clavet_walls`). It projects each particle near a wall onto the candidate colliders a second
    /// time (the projections of `update` are not kept): the cost falls on Clavet fluids with
    /// walls only, and `update`'s loop stays as the other solvers run it.
    pub(crate) fn update_clavet(
        &mut self,
        grid: &NeighborGrid,
        positions: &[Vector],
        query: &WallQuery<'_>,
    ) {
        let (h, spacing) = (query.params.smoothing_length, query.params.particle_spacing);
        let n = positions.len();
        self.clavet_tables(h, spacing);
        self.clavet.resize(n, [0.0; 2]);
        self.clavet_gradient.resize(n, [Vector::ZERO; 2]);
        if !self.candidates.any() {
            self.clavet.fill([0.0; 2]);
            self.clavet_gradient.fill([Vector::ZERO; 2]);
            return;
        }
        let Some((_, _, t2, t3)) = &self.clavet_tables else {
            unreachable!("tables are made above")
        };
        let table = query.coupling.map_or(&[][..], |c| c.table());
        let candidates = &self.candidates;
        crate::par_chunks_mut!(self.clavet, CHUNK)
            .zip(crate::par_chunks_mut!(self.clavet_gradient, CHUNK))
            .enumerate()
            .for_each(|(c, (dens, grad))| {
                for k in 0..dens.len() {
                    let i = c * CHUNK + k;
                    let cands = candidates.of_cell(grid.cell_of(i));
                    (dens[k], grad[k]) = clavet_walls(query, table, cands, (t2, t3), positions[i]);
                }
            });
    }

    /// Clavet's half-space tables for support `h` and spacing `spacing` (made again only
    /// when these change).
    fn clavet_tables(&mut self, h: Real, spacing: Real) {
        let fresh = match &self.clavet_tables {
            Some((th, ts, ..)) => *th != h || *ts != spacing,
            None => true,
        };
        if fresh {
            use crate::solver::clavet::{Cubic, Quadratic};
            self.clavet_tables = Some((
                h,
                spacing,
                HalfSpaceTable::new::<Quadratic>(h, spacing),
                HalfSpaceTable::new::<Cubic>(h, spacing),
            ));
        }
    }

    /// The impulse each particle's wall term gave the dynamic bodies this substep, recorded
    /// for the body contributing most (`records`, in particle order): `impulse(i, g_c) −
    /// h_c·m_i·dt`, `g_c` the dynamic bodies' share of the wall density's gradient, `impulse`
    /// the solver's (see `PressureSolver::wall_impulse`), `h_c` their share of the
    /// hydrostatic wall acceleration. With `added_mass` the particle moves with the body along
    /// the gradient's direction in the exchange (as for contact). `at` holds the positions the
    /// wall terms acted at (the substep's start: the particle then moved on with the velocity
    /// they gave it, so its angular momentum changed by `at × Δp`): each impulse is taken on
    /// the body on that line (see `bodies::on_line`).
    pub(crate) fn reaction(
        &self,
        impulse: impl Fn(usize, Vector) -> Vector,
        (added_mass, mass, dt): (bool, super::bodies::ParticleMass<'_>, Real),
        at: &[Vector],
        records: &mut Vec<super::bodies::ImpulseRecord>,
    ) {
        for (i, cw) in self.coupled.iter().enumerate() {
            if cw.entry == u32::MAX {
                continue;
            }
            let gc = cw.gradient;
            let impulse = impulse(i, gc) - cw.hydrostatic * (mass.of(i) * dt);
            if impulse != Vector::ZERO {
                records.push(super::bodies::ImpulseRecord {
                    entry: cw.entry,
                    particle: i as u32,
                    normal: if added_mass {
                        gc.normalize_or_zero()
                    } else {
                        Vector::ZERO
                    },
                    impulse,
                    point: super::bodies::on_line(at[i], cw.point, impulse),
                    moment: Vector::ZERO,
                    held: None,
                });
            }
        }
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.candidates.heap_bytes()
            + (self.density.capacity()
                + self.motion.capacity()
                + self.coverage.capacity()
                + self.viscous.capacity())
                * 4
            + (self.gradient.capacity()
                + self.hydrostatic.capacity()
                + self.viscous_velocity.capacity())
                * std::mem::size_of::<Vector>()
            + self.coupled.capacity() * std::mem::size_of::<Coupled>()
            + self.clavet.capacity() * std::mem::size_of::<[Real; 2]>()
            + self.clavet_gradient.capacity() * std::mem::size_of::<[Vector; 2]>()
            + self.adhesion.capacity() * std::mem::size_of::<Vector>()
            + self
                .plane_chunks
                .iter()
                .map(|c| c.capacity() * std::mem::size_of::<WallPlanes>() + 24)
                .sum::<usize>()
            + self
                .share_chunks
                .iter()
                .map(|c| c.capacity() * std::mem::size_of::<Share>() + 24)
                .sum::<usize>()
            + self
                .cell_walls
                .iter()
                .map(|c| c.capacity() * std::mem::size_of::<WallSlot>() + 24)
                .sum::<usize>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pinch threshold sits above every place a resting lattice reaches next to walls
    /// (the tip of a right-angled corner) and below a particle squeezed midway in a gap a
    /// quarter of a spacing wide, for the density kernels (figures in `pinch_fraction`).
    #[test]
    fn pinch_threshold_separates_corners_from_squeezed_gaps() {
        let s = 0.02;
        let h = 2.0 * s;
        for kind in [
            KernelKind::CubicSpline,
            KernelKind::WendlandC2,
            KernelKind::Poly6,
        ] {
            let mut ws = WallWorkspace::default();
            ws.tables(kind, KernelKind::Spiky, h, s);
            let (_, _, _, _, t, _) = ws.tables.as_ref().unwrap();
            let own = s.powi(3) * kind.w(0.0, h);
            let phi = |d: Real| t.eval(d).0;
            let union = |a: Real, b: Real| 1.0 - (1.0 - a) * (1.0 - b);
            let corner = 1.0 - (1.0 - phi(0.5 * s)).powi(3) + own;
            let edge = union(phi(0.5 * s), phi(0.5 * s)) + own;
            let squeezed = union(phi(0.125 * s), phi(0.125 * s)) + own;
            let f = ws.pinch_fraction();
            assert!(
                corner < f && edge < f,
                "{kind:?}: corner {corner}, edge {edge}, threshold {f}"
            );
            assert!(squeezed > f, "{kind:?}: squeezed {squeezed}, threshold {f}");
            assert!((f - 0.5 * (1.0 + corner)).abs() < 1e-6);
        }
    }
}
