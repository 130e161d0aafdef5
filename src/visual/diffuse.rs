//! Spray, foam and air bubbles after Ihmsen, Akinci, Akinci & Teschner 2012 ("Unified spray,
//! foam and air bubbles for particle-based fluids", The Visual Computer 28(6–8)), as a
//! drawing layer: generated from the liquid, advected by class, never fed back into it.
//!
//! Per fluid particle `i`, over its neighbours `j` within the support `h`
//! (`x_ij = x_i − x_j`, `v_ij = v_i − v_j`, `W̃(x) = 1 − |x|/h`, the paper's eq. 1):
//!
//! - trapped air `I_ta = Σ |v_ij| (1 − v̂_ij·x̂_ij) W̃(x_ij)` (eqs. 2, 3): where particles
//!   move towards each other, the liquid folds over and traps air;
//! - wave crest `I_wc = Σ κ̃_ij W̃(x_ij)` for surface particles moving along their normal
//!   (`v̂_i·n̂_i ≥ 0.6`), with `κ_ij = 1 − n̂_i·n̂_j` counted where the surface is convex
//!   (`x̂_ji·n̂_i < 0`) (eqs. 4–6); the normal `n̂_i` is the normalised colour-field gradient
//!   `−Σ V_j ∇W(x_ij)`, and a particle is on the surface where that gradient's length is at
//!   least half its value at a flat free surface (`∫∫ W dA` over the plane through the
//!   particle, computed from the kernel);
//! - kinetic energy `E_k = ½|v_i|²` (per unit mass here, J/kg);
//! - each clamped to `[0, 1]` by `Φ(I, τmin, τmax) = (min(I, τmax) − min(I, τmin)) /
//!   (τmax − τmin)` (eq. 7), and `n_d = Φ(E_k) · (k_ta Φ(I_ta) + k_wc Φ(I_wc)) · Δt` diffuse
//!   particles are generated (eq. 8: the integer part, and one more with the probability of
//!   the fraction), placed at random in the cylinder of radius `r` (the particle radius)
//!   around `x_i` along `v_i` of length `|v_i|Δt`, with the liquid's velocity plus the
//!   radial offset (eqs. 9–11).
//!
//! Each diffuse particle is classed every step by its number of liquid neighbours within
//! `h` (section 4.2): **spray** (fewer than 6) moves ballistically under gravity, **foam**
//! (6 to 20) is carried by the liquid's velocity `ṽ = Σ v_j K(x − x_j) / Σ K(x − x_j)`
//! (cubic spline `K`), **bubbles** (more than 20) feel buoyancy and drag towards `ṽ`:
//! `v += Δt(−k_b g + k_d (ṽ − v)/Δt)` (eq. 12). Foam dissolves when its lifetime runs out.
//! Departure from the paper: spray too counts down its lifetime, since nothing here
//! collides with the rapier colliders, so spray that misses the liquid would fall forever.
//!
//! The thresholds are the paper's kind of scene-dependent constants (its table 1 lists
//! them per scene); the defaults are chosen for this crate's water preset at spacings of
//! 1 to 5 cm, speeds of metres per second.

use super::{Search, positive};
use crate::fluid::Fluid;
use crate::kernel::{CubicSpline, Kernel};
use crate::math::{Real, Vector};
use crate::par::CHUNK;
use crate::{SphError, SphResult};
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Settings of [`DiffuseParticles`].
///
/// # Examples
///
/// ```
/// use rapier_sph::SphError;
/// use rapier_sph::visual::{DiffuseParticles, DiffuseSettings};
///
/// // Less foam than the default, dissolving sooner, at most 5,000 particles.
/// let settings = DiffuseSettings {
///     max_particles: 5_000,
///     trapped_air_rate: 20.0,
///     wave_crest_rate: 20.0,
///     lifetime: 1.0,
///     ..Default::default()
/// };
/// let foam = DiffuseParticles::new(settings)?;
/// assert_eq!(foam.settings().max_particles, 5_000);
/// // A setting out of range is refused, naming the field.
/// let bad = DiffuseSettings { drag: 2.0, ..Default::default() };
/// assert!(matches!(
///     DiffuseParticles::new(bad),
///     Err(SphError::InvalidParameter { field: "drag", .. })
/// ));
/// # Ok::<(), SphError>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DiffuseSettings {
    /// The most diffuse particles alive at once; generation stops at the cap (what was not
    /// generated is counted in [`DiffuseReport::dropped`]). Default 20,000.
    pub max_particles: usize,
    /// `[τmin, τmax]` of the trapped-air potential (m/s). Default `[5, 20]`.
    pub trapped_air: (Real, Real),
    /// `[τmin, τmax]` of the wave-crest potential. Default `[2, 8]`.
    pub wave_crest: (Real, Real),
    /// `[τmin, τmax]` of the kinetic energy per unit mass (J/kg). Default `[0.5, 5]`: no
    /// diffuse particle from liquid slower than 1 m/s, full rate above 3.2 m/s.
    pub kinetic_energy: (Real, Real),
    /// `k_ta`: diffuse particles per second from a fluid particle at full trapped-air
    /// potential and kinetic energy. Default 40.
    pub trapped_air_rate: Real,
    /// `k_wc`: the same for the wave-crest potential. Default 40.
    pub wave_crest_rate: Real,
    /// Lifetime of foam (and spray) in seconds; each particle draws its own uniformly in
    /// `[0.5, 1.5]` times this. Default 2.
    pub lifetime: Real,
    /// Fewer liquid neighbours than this: spray. Default 6 (Ihmsen et al.).
    pub spray_below: usize,
    /// More liquid neighbours than this: bubble. Default 20 (Ihmsen et al.).
    pub bubble_above: usize,
    /// Buoyancy `k_b` of bubbles (times −gravity). Default 2.
    pub buoyancy: Real,
    /// Drag `k_d` of bubbles towards the liquid's velocity, in `[0, 1]` per step. Default 0.5.
    pub drag: Real,
    /// Seed of the generator's random placement (results depend only on it and the data).
    pub seed: u64,
}

impl Default for DiffuseSettings {
    fn default() -> Self {
        Self {
            max_particles: 20_000,
            trapped_air: (5.0, 20.0),
            wave_crest: (2.0, 8.0),
            kinetic_energy: (0.5, 5.0),
            trapped_air_rate: 40.0,
            wave_crest_rate: 40.0,
            lifetime: 2.0,
            spray_below: 6,
            bubble_above: 20,
            buoyancy: 2.0,
            drag: 0.5,
            seed: 0x5eed,
        }
    }
}

impl DiffuseSettings {
    /// Checks every field.
    ///
    /// # Errors
    /// [`SphError::InvalidParameter`] naming the field that is out of range.
    pub fn validate(&self) -> SphResult<()> {
        for (field, (lo, hi)) in [
            ("trapped_air", self.trapped_air),
            ("wave_crest", self.wave_crest),
            ("kinetic_energy", self.kinetic_energy),
        ] {
            if !(lo.is_finite() && hi.is_finite() && lo >= 0.0 && hi > lo) {
                return Err(SphError::InvalidParameter {
                    field,
                    value: hi as f64,
                    reason: "must be a range [min, max] of finite numbers with 0 ≤ min < max",
                });
            }
        }
        for (field, v) in [
            ("trapped_air_rate", self.trapped_air_rate),
            ("wave_crest_rate", self.wave_crest_rate),
            ("buoyancy", self.buoyancy),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(SphError::InvalidParameter {
                    field,
                    value: v as f64,
                    reason: "must be a finite number ≥ 0",
                });
            }
        }
        positive("lifetime", self.lifetime)?;
        if !(0.0..=1.0).contains(&self.drag) {
            return Err(SphError::InvalidParameter {
                field: "drag",
                value: self.drag as f64,
                reason: "must be in [0, 1]",
            });
        }
        if self.bubble_above < self.spray_below {
            return Err(SphError::InvalidParameter {
                field: "bubble_above",
                value: self.bubble_above as f64,
                reason: "must be at least spray_below",
            });
        }
        Ok(())
    }
}

/// The class of a diffuse particle, from its number of liquid neighbours.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum DiffuseKind {
    /// In the air: ballistic.
    Spray,
    /// On the surface: carried by the liquid, dissolves.
    Foam,
    /// Under the surface: rises, dragged by the liquid.
    Bubble,
}

/// What one [`DiffuseParticles::step`] did.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct DiffuseReport {
    /// Diffuse particles generated this step.
    pub created: usize,
    /// Particles the potentials asked for but the cap refused.
    pub dropped: usize,
    /// Particles removed (lifetime over, or non-finite).
    pub removed: usize,
    /// Alive after the step, by class.
    pub spray: usize,
    /// Foam particles alive.
    pub foam: usize,
    /// Bubbles alive.
    pub bubbles: usize,
}

/// Spray, foam and bubbles of one fluid: stepped by the game after the fluid's step, read
/// for drawing. See the [module docs](self) for the formulas.
///
/// # Examples
///
/// ```
/// use rapier_sph::visual::{DiffuseParticles, DiffuseSettings};
/// use rapier_sph::scenes::{dam_break, DamBreakConfig};
/// use rapier_sph::FluidParamsBuilder;
///
/// let params = FluidParamsBuilder::water(0.05).build()?;
/// let mut scene = dam_break(&DamBreakConfig::tower(params, 0.4))?;
/// let mut spray = DiffuseParticles::new(DiffuseSettings::default())?;
/// let dt = 1.0 / 60.0;
/// for _ in 0..3 {
///     scene.world.step()?;
///     let fluid = &scene.world.fluids[scene.fluid];
///     let report = spray.step(fluid, scene.world.physics.gravity, dt)?;
///     assert!(report.spray + report.foam + report.bubbles <= 20_000);
/// }
/// // Draw spray.positions() with spray.kinds() (white dots, foam on the surface).
/// # Ok::<(), rapier_sph::SphError>(())
/// ```
#[derive(Clone, Debug)]
pub struct DiffuseParticles {
    settings: DiffuseSettings,
    positions: Vec<Vector>,
    velocities: Vec<Vector>,
    lifetimes: Vec<Real>,
    kinds: Vec<DiffuseKind>,
    steps: u64,
    search: Search,
    /// Liquid and diffuse points together (liquid first), for one neighbour search.
    points: Vec<Vector>,
    /// Sorted index of each point.
    rank: Vec<u32>,
    /// Per sorted liquid particle: outward normal (zero off the surface).
    normals: Vec<Vector>,
    /// Per liquid particle (caller's order): diffuse particles to generate (expected count).
    counts: Vec<Real>,
    /// Per diffuse particle: liquid velocity around it and liquid neighbour count.
    around: Vec<(Vector, u32)>,
}

impl DiffuseParticles {
    /// No diffuse particle yet.
    ///
    /// # Errors
    /// [`SphError::InvalidParameter`] when a setting is out of range.
    pub fn new(settings: DiffuseSettings) -> SphResult<Self> {
        settings.validate()?;
        Ok(Self {
            settings,
            positions: Vec::new(),
            velocities: Vec::new(),
            lifetimes: Vec::new(),
            kinds: Vec::new(),
            steps: 0,
            search: Search::default(),
            points: Vec::new(),
            rank: Vec::new(),
            normals: Vec::new(),
            counts: Vec::new(),
            around: Vec::new(),
        })
    }

    /// The settings.
    pub fn settings(&self) -> &DiffuseSettings {
        &self.settings
    }

    /// Positions (m).
    pub fn positions(&self) -> &[Vector] {
        &self.positions
    }

    /// Velocities (m/s).
    pub fn velocities(&self) -> &[Vector] {
        &self.velocities
    }

    /// Classes, from the last step.
    pub fn kinds(&self) -> &[DiffuseKind] {
        &self.kinds
    }

    /// Seconds left to live (foam and spray).
    pub fn lifetimes(&self) -> &[Real] {
        &self.lifetimes
    }

    /// Alive diffuse particles.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// `true` when there is none.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Removes every diffuse particle.
    pub fn clear(&mut self) {
        self.positions.clear();
        self.velocities.clear();
        self.lifetimes.clear();
        self.kinds.clear();
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.search.heap_bytes()
            + (self.positions.capacity() + self.velocities.capacity()) * 12
            + self.lifetimes.capacity() * 4
            + self.kinds.capacity()
            + self.points.capacity() * 12
            + self.rank.capacity() * 4
            + self.normals.capacity() * 12
            + self.counts.capacity() * 4
            + self.around.capacity() * 16
    }

    /// Advances the diffuse particles by `dt` over `fluid` as it is after its step (call it
    /// once per fluid step, with the step's `dt` and the world's `gravity`): classifies and
    /// moves the existing ones, removes those whose time is up, then generates new ones from
    /// the liquid's potentials, up to the cap.
    ///
    /// # Errors
    /// [`SphError::InvalidTimeStep`] unless `dt` is finite and positive.
    pub fn step(&mut self, fluid: &Fluid, gravity: Vector, dt: Real) -> SphResult<DiffuseReport> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(SphError::InvalidTimeStep { dt: dt as f64 });
        }
        let mut report = DiffuseReport::default();
        self.search_together(fluid);
        self.liquid_around(fluid);
        self.advance(gravity, dt, &mut report);
        self.surface_normals(fluid);
        self.potentials(fluid, dt);
        self.generate(fluid, dt, &mut report);
        for k in &self.kinds {
            match k {
                DiffuseKind::Spray => report.spray += 1,
                DiffuseKind::Foam => report.foam += 1,
                DiffuseKind::Bubble => report.bubbles += 1,
            }
        }
        Ok(report)
    }

    /// One neighbour search over the liquid and the diffuse particles together (liquid
    /// first); `rank` maps each point to its sorted index.
    fn search_together(&mut self, fluid: &Fluid) {
        let (n, m) = (fluid.len(), self.positions.len());
        self.points.clear();
        self.points.extend_from_slice(fluid.positions());
        self.points.extend_from_slice(&self.positions);
        self.search
            .build(&self.points, fluid.params().smoothing_length);
        self.rank.resize(n + m, 0);
        for (k, &i) in self.search.order.iter().enumerate() {
            self.rank[i as usize] = k as u32;
        }
    }

    /// Per existing diffuse particle: the kernel-weighted liquid velocity around it and
    /// the number of liquid neighbours.
    fn liquid_around(&mut self, fluid: &Fluid) {
        let (n, m) = (fluid.len(), self.positions.len());
        let kernel = CubicSpline::new(fluid.params().smoothing_length);
        let (search, rank, velocities) = (&self.search, &self.rank, fluid.velocities());
        let order = &search.order;
        self.around.resize(m, (Vector::ZERO, 0));
        crate::par_chunks_mut!(self.around, CHUNK)
            .enumerate()
            .for_each(|(c, out)| {
                for (k, a) in out.iter_mut().enumerate() {
                    let sk = rank[n + c * CHUNK + k] as usize;
                    let x = search.sorted[sk];
                    let (mut sv, mut sw, mut count) = (Vector::ZERO, 0.0, 0u32);
                    for &j in search.lists.of(sk) {
                        let oj = order[j as usize] as usize;
                        if oj >= n {
                            continue;
                        }
                        let w = kernel.w((x - search.sorted[j as usize]).length());
                        sv += velocities[oj] * w;
                        sw += w;
                        count += 1;
                    }
                    *a = (if sw > 0.0 { sv / sw } else { Vector::ZERO }, count);
                }
            });
    }

    /// Classifies, moves and ages the existing diffuse particles; removes those whose time
    /// is up or that became non-finite.
    fn advance(&mut self, gravity: Vector, dt: Real, report: &mut DiffuseReport) {
        let s = self.settings;
        let mut kept = 0;
        for d in 0..self.positions.len() {
            let (v_liquid, count) = self.around[d];
            let kind = s.kind_of(count as usize);
            let mut v = self.velocities[d];
            let mut life = self.lifetimes[d];
            match kind {
                DiffuseKind::Spray => {
                    v += gravity * dt;
                    life -= dt;
                }
                DiffuseKind::Foam => {
                    v = v_liquid;
                    life -= dt;
                }
                DiffuseKind::Bubble => {
                    v += -gravity * (s.buoyancy * dt) + (v_liquid - v) * s.drag;
                }
            }
            let x = self.positions[d] + v * dt;
            if life <= 0.0 || !crate::math::is_finite(x) || !crate::math::is_finite(v) {
                report.removed += 1;
                continue;
            }
            self.positions[kept] = x;
            self.velocities[kept] = v;
            self.lifetimes[kept] = life;
            self.kinds[kept] = kind;
            kept += 1;
        }
        self.positions.truncate(kept);
        self.velocities.truncate(kept);
        self.lifetimes.truncate(kept);
        self.kinds.truncate(kept);
    }

    /// Outward normals of the liquid particles (sorted order; diffuse points and particles
    /// away from the surface left at zero).
    fn surface_normals(&mut self, fluid: &Fluid) {
        let params = fluid.params();
        let (h, n) = (params.smoothing_length, fluid.len());
        let kernel = CubicSpline::new(h);
        // A flat free surface's colour-field gradient is the kernel's integral over the
        // plane through the particle: 2π ∫₀ʰ W(r) r dr (midpoint rule, 64 intervals).
        let flat = {
            let steps = 64;
            let dr = h / steps as Real;
            (0..steps)
                .map(|k| {
                    let r = (k as Real + 0.5) * dr;
                    kernel.w(r) * r * dr
                })
                .sum::<Real>()
                * std::f32::consts::TAU
        };
        let surface = 0.5 * flat;
        let densities = fluid.densities();
        let rest_volume = params.particle_mass / params.rest_density;
        let volume = |i: usize| match densities.get(i) {
            Some(&rho) if rho > 0.0 => params.particle_mass / rho,
            _ => rest_volume,
        };
        let (search, order) = (&self.search, &self.search.order);
        self.normals.resize(self.points.len(), Vector::ZERO);
        crate::par_chunks_mut!(self.normals, CHUNK)
            .enumerate()
            .for_each(|(c, out)| {
                for (k, nrm) in out.iter_mut().enumerate() {
                    let i = c * CHUNK + k;
                    *nrm = Vector::ZERO;
                    if order[i] as usize >= n {
                        continue;
                    }
                    let xi = search.sorted[i];
                    let mut grad = Vector::ZERO;
                    for &j in search.lists.of(i) {
                        let oj = order[j as usize] as usize;
                        if oj >= n {
                            continue;
                        }
                        let r = xi - search.sorted[j as usize];
                        let d = r.length();
                        if d > 0.0 {
                            grad += r * (volume(oj) * kernel.dw(d) / d);
                        }
                    }
                    // `grad` is ∇c (into the liquid); the outward normal is −∇c.
                    if grad.length() >= surface {
                        *nrm = -grad.normalize();
                    }
                }
            });
    }

    /// Potentials (trapped air, wave crests, kinetic energy) → the expected number of new
    /// diffuse particles per liquid particle (sorted order).
    fn potentials(&mut self, fluid: &Fluid, dt: Real) {
        let s = self.settings;
        let (h, n) = (fluid.params().smoothing_length, fluid.len());
        let velocities = fluid.velocities();
        let (search, order, normals) = (&self.search, &self.search.order, &self.normals);
        let phi = |x: Real, (lo, hi): (Real, Real)| (x.min(hi) - x.min(lo)) / (hi - lo);
        self.counts.resize(self.points.len(), 0.0);
        crate::par_chunks_mut!(self.counts, CHUNK)
            .enumerate()
            .for_each(|(c, out)| {
                for (k, cnt) in out.iter_mut().enumerate() {
                    let i = c * CHUNK + k;
                    *cnt = 0.0;
                    let oi = order[i] as usize;
                    if oi >= n {
                        continue;
                    }
                    let vi = velocities[oi];
                    let ek = phi(0.5 * vi.length_squared(), s.kinetic_energy);
                    if !(ek > 0.0) {
                        continue;
                    }
                    let xi = search.sorted[i];
                    let ni = normals[i];
                    let crest = ni != Vector::ZERO && vi.normalize_or_zero().dot(ni) >= 0.6;
                    let (mut ta, mut wc) = (0.0, 0.0);
                    for &j in search.lists.of(i) {
                        let oj = order[j as usize] as usize;
                        if oj >= n {
                            continue;
                        }
                        let xij = xi - search.sorted[j as usize];
                        let d = xij.length();
                        if d <= 0.0 {
                            continue;
                        }
                        let w = (1.0 - d / h).max(0.0);
                        let vij = vi - velocities[oj];
                        let speed = vij.length();
                        if speed > 0.0 {
                            ta += speed * (1.0 - vij.dot(xij) / (speed * d)) * w;
                        }
                        let nj = normals[j as usize];
                        // Convex: the neighbour lies below i's tangent plane (x̂_ji·n̂_i < 0).
                        if crest && nj != Vector::ZERO && (-xij).dot(ni) < 0.0 {
                            wc += (1.0 - ni.dot(nj)) * w;
                        }
                    }
                    *cnt = ek
                        * (s.trapped_air_rate * phi(ta, s.trapped_air)
                            + s.wave_crest_rate * phi(wc, s.wave_crest))
                        * dt;
                }
            });
    }

    /// Generates the new diffuse particles, in the liquid's sorted order (deterministic), up
    /// to the cap; what the cap refuses is counted as dropped.
    fn generate(&mut self, fluid: &Fluid, dt: Real, report: &mut DiffuseReport) {
        let s = self.settings;
        let (ids, velocities) = (fluid.ids(), fluid.velocities());
        let r_cyl = fluid.params().particle_radius;
        self.steps += 1;
        for k in 0..self.counts.len() {
            let cnt = self.counts[k];
            if !(cnt > 0.0) {
                continue;
            }
            let oi = self.search.order[k] as usize;
            let id = ids.get(oi).copied().unwrap_or(oi as u32);
            let mut rng = Rng::new(s.seed, self.steps, id);
            let whole = cnt.floor();
            let number = whole as usize + (rng.next() < cnt - whole) as usize;
            let room = s.max_particles.saturating_sub(self.positions.len());
            let take = number.min(room);
            report.dropped += number - take;
            let (xi, vi) = (fluid.positions()[oi], velocities[oi]);
            let speed = vi.length();
            let axis = if speed > 0.0 { vi / speed } else { Vector::Y };
            let e1 = axis.any_orthonormal_vector();
            let e2 = axis.cross(e1);
            let kind = s.kind_of(self.search.lists.of(k).len());
            for _ in 0..take {
                let r = r_cyl * rng.next().sqrt();
                let theta = rng.next() * std::f32::consts::TAU;
                let along = rng.next() * speed * dt;
                let radial = e1 * (r * theta.cos()) + e2 * (r * theta.sin());
                self.positions.push(xi + radial + axis * along);
                self.velocities.push(vi + radial);
                self.lifetimes.push(s.lifetime * (0.5 + rng.next()));
                self.kinds.push(kind);
                report.created += 1;
            }
        }
    }
}

impl DiffuseSettings {
    /// The class of a diffuse particle with `count` liquid neighbours.
    fn kind_of(&self, count: usize) -> DiffuseKind {
        if count < self.spray_below {
            DiffuseKind::Spray
        } else if count > self.bubble_above {
            DiffuseKind::Bubble
        } else {
            DiffuseKind::Foam
        }
    }
}

/// SplitMix64 (Steele, Lea & Flood 2014) keyed by seed, step and particle id: the same
/// numbers on every run and thread count, with no dependency.
struct Rng(u64);

impl Rng {
    fn new(seed: u64, step: u64, id: u32) -> Self {
        Self(
            seed ^ step.wrapping_mul(0x9E37_79B9_7F4A_7C15)
                ^ (id as u64).wrapping_mul(0xD1B5_4A32_D192_ED03),
        )
    }
    /// Uniform in `[0, 1)`.
    fn next(&mut self) -> Real {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 40) as Real / (1u64 << 24) as Real
    }
}
