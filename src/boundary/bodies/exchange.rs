//! The fluid → body exchange of one substep: the added-mass solve that settles the impulses
//! contact and the walls recorded between the particles and each dynamic body (see
//! [`Coupling::exchange`]), and the records themselves.

use super::Coupling;
use crate::math::{Real, Vector};
use parry3d::math::AngularInertia;

impl Coupling {
    /// Settles the impulses contact recorded in one substep (`records`, per chunk, summed in
    /// chunk order) between the particles and each dynamic body, and gathers them for
    /// [`Coupling::apply`].
    ///
    /// Contact reflects each particle as if the body were infinitely heavy; a light body
    /// hit by many particles at once would then be kicked far past them (the added-mass
    /// instability of explicit coupling: a 1 kg/m³ box on water was thrown at 42 m/s by
    /// WCSPH). So the body's velocity change is solved with the particles it touched moving
    /// along with its surface in their contact normals, linear and angular together: with
    /// `x` a particle from the center of mass and `g = x × n`, each such particle gains
    /// `δv = n·(n·Δu + g·Δω)` (the body's velocity where the particle is, along the normal)
    /// and the body gives that momentum up at the particle, which gives the 6 × 6 system
    /// `Δu = M⁻¹(J − A Δu − B Δω)`, `Δω = I⁻¹(L − Bᵀ Δu − C Δω)` with
    /// `A = Σ m n nᵀ`, `B = Σ m n gᵀ`, `C = Σ m g gᵀ`, `J` the impulses and `L` their moment
    /// (`AddedMass::solve`). A body of any mass, down to a balloon's, moves no faster than the
    /// water it pushes lets it (a 1 kg/m³ box dropped on water: 1.3–3.5 m/s with every solver,
    /// `tests/light_bodies.rs`).
    ///
    /// Linear and angular momentum are exchanged exactly. Each record's impulse is taken on
    /// the line through the particle's position when its momentum changed
    /// ([`on_line`]), and the angular momentum contact gave a particle by moving it out of the
    /// body ([`ImpulseRecord::moment`]) is the body's loss too: without the two, water and a
    /// freely turning plate it hits off its center lost 0.55 % (contact) and 2.1 % (walls) of
    /// the angular momentum they exchanged, all of it the push-outs' (measured per frame);
    /// with them, 0.002 % and 0.008 %, round-off and the fluid's own.
    ///
    /// The body's other forces (gravity, rapier's contacts and joints, user forces: rapier's
    /// own velocity change over the frame, read against the velocity [`Coupling::apply`] left
    /// the body with, the fluid's impulses included) enter the solve for the walls' records
    /// (`with_rapier`; every solver's but WCSPH's, below): the wall terms met the body
    /// before its substep's share `a·dt` of that change (DFSPH's walls at its pose and
    /// velocity of the substep's start, PBF's position solve as the particles stand after
    /// their gravity's `g·dt`), and after the substep the body moves at its velocity plus
    /// `a·dt` plus the fluid's change. The particles against it must share that whole change,
    /// `Δu = M⁻¹(J − A Δu − B Δω) + a·dt`, the body keeping `J − Σ m δv = M·(Δu − a·dt)`
    /// from the fluid: the common velocity of body and particles that conserves their
    /// momentum. A body floating at rest falls by `g·dt` along rapier's path each substep and
    /// the fluid's impulses lift it back, so `Δu ≈ 0`: the particles under it are given
    /// nothing, and it floats where the wall impulse `J` equals its weight. Left out (as it
    /// was for DFSPH's walls, and is for WCSPH's), `Δu ≈ +|g|·dt` upward every substep while
    /// the body did not move: the particles under it were kicked up at a velocity the body
    /// never had, which the next substep's pressure solve took back through the body, a
    /// pump driven every substep. Measured on the still game pool (`cargo run --release --example
    /// pool_energy`, 2,556 particles, the water preset, a per-substep probe over seconds
    /// 5–12): the solves' `Δu` summed to 0.040 m/s a substep (`g·dt` = 0.041) while the
    /// hull's velocity changed by −0.0006 m/s; the exchange gave the particles 2.9 W through
    /// the walls' records and 0.2 W through contact's; the fluid's impulses on the hull were
    /// 3.0 times its weight (a body kept `M·Δu` of them, so it needed `(M + A)·g·dt`, `A`
    /// about 10.7 kg of water in the walls' records against the hull's 4.8 kg); the water's
    /// kinetic energy stayed at 1.8–2.0 J. With `a·dt`: −0.001 W and 0.005 W, the impulses
    /// 0.98 of the weight, and the kinetic energy falls (0.82 J at 5 s, 0.49 J at 12 s)
    /// until the pool falls asleep. Contact's records (`with_rapier` false) do not take
    /// `a·dt`: contact reflects each particle against the body's velocity at the substep's
    /// *end*, which already holds it.
    ///
    /// WCSPH's wall records still leave `a·dt` out, and so still pump a floating body's
    /// water: with it, `tests/buoyancy.rs`'s 16 cm cubes at 2.5 cm float 0.194 / 0.435 /
    /// 0.687 submerged for 0.25 / 0.5 / 0.75 (0.235 / 0.485 / 0.733 without), outside the
    /// test's 5 % of their height against the water's top-particle level (DFSPH's cubes:
    /// 0.212 / 0.460 / 0.703). Which level Archimedes' depth is read against decides it
    /// (docs/coupling.md, "Buoyancy"); open.
    ///
    /// `I⁻¹` is the world inverse inertia at the frame's end. Both changes move the body from
    /// the next substep on ([`super::Drift`]): the body moves with the substeps the fluid
    /// takes, not once per frame.
    pub fn exchange(
        &mut self,
        records: &[Vec<ImpulseRecord>],
        positions: &[Vector],
        velocities: &mut [Vector],
        mass: ParticleMass<'_>,
        with_rapier: bool,
    ) {
        let mut done = std::mem::take(&mut self.done);
        done.clear();
        for k in 0..self.table.len() {
            let m = &self.table[k];
            if !m.dynamic || done.contains(&m.body) {
                continue;
            }
            let body = m.body;
            done.push(body);
            let of_body = |r: &&ImpulseRecord| self.table[r.entry as usize].body == body;
            // A record's mass in the solve and the factor on its impulse (a held one: a
            // spacer of `HELD_MASS` body masses; none without a free axis).
            let lightest = m.inv_mass.max_element();
            let held = (lightest > 0.0).then(|| HELD_MASS / lightest);
            let weigh = |r: &ImpulseRecord, mi: Real| match held {
                Some(k) if r.held.is_some() => (k, k / mi),
                _ => (mi, 1.0),
            };
            let mut back = Vector::ZERO;
            let mut sums = AddedMass::default();
            for r in records.iter().flatten().filter(of_body) {
                let i = r.particle as usize;
                let (mi, scale) = weigh(r, mass.of(i));
                sums.add(r, positions[i], m.com_stop, mi, scale as f64);
            }
            if sums.count == 0 {
                continue;
            }
            // Rapier's share of the substep, on the free axes, for the walls' records (see
            // `with_rapier`).
            let ext = if with_rapier {
                m.rapier_rate * (m.backs.0 - m.backs.1) * free_axes(m.inv_mass)
            } else {
                Vector::ZERO
            };
            let (du, dw) = sums.solve(m.inv_mass, &m.inv_inertia, ext);
            let slot = match self.impulses.iter().position(|b| b.0 == body) {
                Some(s) => s,
                None => {
                    self.impulses.push((body, [0.0; 3], [0.0; 3]));
                    self.impulses.len() - 1
                }
            };
            let com = m.com_stop;
            for r in records.iter().flatten().filter(of_body) {
                // The particle moves with the body along its contact normal, at the body's
                // velocity where the particle is; the body gives that momentum up at the
                // same point, so the exchange keeps angular momentum exactly.
                let i = r.particle as usize;
                let x = positions[i] - com;
                let dv = r.normal * r.normal.dot(du + dw.cross(x));
                velocities[i] += dv;
                let (j, torque) = match weigh(r, mass.of(i)) {
                    (mi, scale) if r.held.is_some() => {
                        back = back_off(back, r);
                        // In f64: the two terms nearly cancel.
                        let (jr, taken) = (f64v(r.impulse) * scale as f64, f64v(dv) * mi as f64);
                        let l = f64v(r.point - com).cross(&jr) - f64v(x).cross(&taken);
                        (jr - taken, l - f64v(r.moment))
                    }
                    (mi, _) => {
                        let impulse = r.impulse - dv * mi;
                        let torque = (r.point - com).cross(r.impulse) - r.moment - x.cross(dv * mi);
                        (f64v(impulse), f64v(torque))
                    }
                };
                let b = &mut self.impulses[slot];
                for c in 0..3 {
                    b.1[c] += j[c];
                    b.2[c] += torque[c];
                }
            }
            let back = back * free_axes(m.inv_mass);
            for c in self.candidates.iter_mut().chain(self.table.iter_mut()) {
                if c.body == body {
                    c.vel += du - ext;
                    c.angvel += dw;
                }
            }
            for c in self.candidates.iter_mut().filter(|c| c.body == body) {
                c.drift.shift += back;
            }
        }
        self.done = done;
    }
}

/// The shift `back` moved so that it takes the body at least `r.held` away from held record
/// `r`'s particle, along the record's normal (the records taken one after the other: a
/// shift that already covers one is kept).
#[inline]
fn back_off(back: Vector, r: &ImpulseRecord) -> Vector {
    let (n, d) = (-r.normal, r.held.unwrap_or(0.0));
    let short = d - back.dot(n);
    if short > 0.0 && short.is_finite() {
        back + n * short
    } else {
        back
    }
}

/// 1 along the free axes of a body of inverse masses `inv_mass`, 0 along locked ones.
#[inline]
fn free_axes(inv_mass: Vector) -> Vector {
    Vector::new(
        (inv_mass.x > 0.0) as u32 as Real,
        (inv_mass.y > 0.0) as u32 as Real,
        (inv_mass.z > 0.0) as u32 as Real,
    )
}

/// `x` in f64.
#[inline(always)]
fn f64v(x: Vector) -> nalgebra::Vector3<f64> {
    nalgebra::Vector3::new(x.x as f64, x.y as f64, x.z as f64)
}

/// The sums of one body's added-mass solve (see [`Coupling::exchange`]), in f64: the impulse
/// `J` and its moment `L` about the center of mass (each impulse at its contact point), and
/// `Σ m·[n; g][n; g]ᵀ` with `g = x × n` (`x` the particle from the center of mass) as its
/// blocks `A = Σ m n nᵀ`, `B = Σ m n gᵀ`, `C = Σ m g gᵀ`.
#[derive(Default)]
struct AddedMass {
    j: nalgebra::Vector3<f64>,
    l: nalgebra::Vector3<f64>,
    a: nalgebra::Matrix3<f64>,
    b: nalgebra::Matrix3<f64>,
    c: nalgebra::Matrix3<f64>,
    count: usize,
}

impl AddedMass {
    /// Adds record `r` of a particle at `particle` of mass `mass` in the solve, its impulse
    /// times `scale`.
    fn add(&mut self, r: &ImpulseRecord, particle: Vector, com: Vector, mass: Real, scale: f64) {
        let v = f64v;
        let x = particle - com;
        let (n, g) = (v(r.normal), v(x.cross(r.normal)));
        let m = mass as f64;
        if r.held.is_some() {
            let j = v(r.impulse) * scale;
            self.j += j;
            self.l += v(r.point - com).cross(&j) - v(r.moment);
        } else {
            self.j += v(r.impulse);
            self.l += v((r.point - com).cross(r.impulse) - r.moment);
        }
        self.a += n * n.transpose() * m;
        self.b += n * g.transpose() * m;
        self.c += g * g.transpose() * m;
        self.count += 1;
    }

    /// The body's velocity changes `(Δu, Δω)` from
    /// `Δu = M⁻¹(J − A Δu − B Δω)`, `Δω = I⁻¹(L − Bᵀ Δu − C Δω)`: the body and the
    /// particles it touched share one velocity change along each contact normal, linear and
    /// angular. `M⁻¹` per axis (a locked axis: 0), `I⁻¹` the world inverse inertia (a locked
    /// rotation: 0). The system `(1 + D·G)` has eigenvalues ≥ 1 (`D = diag(M⁻¹, I⁻¹)` and `G`
    /// are positive semi-definite), so it is solvable for any body mass; a light body is held
    /// back by the fluid it must push, as a real one is.
    fn solve(
        &self,
        inv_mass: Vector,
        inv_inertia: &AngularInertia,
        ext: Vector,
    ) -> (Vector, Vector) {
        let v = |x: Vector| nalgebra::Vector3::new(x.x as f64, x.y as f64, x.z as f64);
        let minv = nalgebra::Matrix3::from_diagonal(&v(inv_mass));
        let iinv = nalgebra::Matrix3::from_columns(&[
            v(*inv_inertia * Vector::X),
            v(*inv_inertia * Vector::Y),
            v(*inv_inertia * Vector::Z),
        ]);
        let eye = nalgebra::Matrix3::<f64>::identity();
        let mut k = nalgebra::Matrix6::<f64>::zeros();
        k.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(eye + minv * self.a));
        k.fixed_view_mut::<3, 3>(0, 3).copy_from(&(minv * self.b));
        k.fixed_view_mut::<3, 3>(3, 0)
            .copy_from(&(iinv * self.b.transpose()));
        k.fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&(eye + iinv * self.c));
        let top = minv * self.j + v(ext);
        let bottom = iinv * self.l;
        let rhs = nalgebra::Vector6::new(top.x, top.y, top.z, bottom.x, bottom.y, bottom.z);
        let q = k
            .lu()
            .solve(&rhs)
            .filter(|q| q.iter().all(|x| x.is_finite()))
            .unwrap_or(rhs);
        let out = |i: usize| Vector::new(q[i] as Real, q[i + 1] as Real, q[i + 2] as Real);
        (out(0), out(3))
    }
}

/// The point of the line through `lever` along `impulse` nearest `point`: where an impulse
/// `impulse` that changed a particle's momentum at `lever` is taken on a body whose surface
/// met the particle at `point`. A central impulse (along the line from the particle to the
/// surface) keeps `point`; a slightly non-central one (a wall gradient summed over a curved
/// surface, a contact impulse summed over several features) has its moment about any origin
/// equal to the particle's change `lever × Δp`, so the exchange keeps angular momentum
/// exactly.
#[inline]
pub fn on_line(lever: Vector, point: Vector, impulse: Vector) -> Vector {
    let l2 = impulse.length_squared();
    if l2 > 0.0 && l2.is_finite() {
        lever + impulse * ((point - lever).dot(impulse) / l2)
    } else {
        point
    }
}

/// Each particle's mass, for the momentum the fluid and the bodies exchange: one mass for a
/// fluid stepped alone; for interacting fluids stepped as one (`crate::fluid::interaction`),
/// the reference mass divided by each particle's ratio `r_i = m_ref/m_i`, so a particle of
/// a lighter liquid gives a body its own momentum, not the reference liquid's.
#[derive(Copy, Clone, Debug)]
pub struct ParticleMass<'a> {
    /// The fluid's particle mass (the group's reference mass) (kg).
    pub mass: Real,
    /// `m_ref/m_i` per sorted particle; `None` for one fluid.
    pub ratio: Option<&'a [Real]>,
}

impl ParticleMass<'_> {
    /// The mass of sorted particle `i` (kg).
    #[inline(always)]
    pub fn of(&self, i: usize) -> Real {
        match self.ratio {
            Some(r) => self.mass / r[i],
            None => self.mass,
        }
    }
}

/// One impulse a particle gave a dynamic body's collider during contact.
#[derive(Copy, Clone, Debug)]
pub struct ImpulseRecord {
    /// Index into the coupling table.
    pub entry: u32,
    /// The particle (index in the current order).
    pub particle: u32,
    /// Contact normal (unit, out of the body; zero when the particle was not reflected off
    /// a surface).
    pub normal: Vector,
    /// Impulse on the body (N·s).
    pub impulse: Vector,
    /// Where it acts (m).
    pub point: Vector,
    /// Angular momentum (kg·m²/s, about any point) the particle gained with no impulse, which
    /// the body gives up: contact moving a particle of momentum `p` out of the body by `Δx`
    /// gives it `Δx × p` (zero for the walls' records).
    pub moment: Vector,
    /// For a particle another surface holds against the body (see `contact::hold`): how
    /// much thinner than two contact radii the gap is (m). In the added-mass solve it
    /// stands for a rigid spacer of [`HELD_MASS`] times the body's mass (`impulse` is its
    /// real mass's share), and the body is moved back by that much (no velocity). `None`
    /// for every other record.
    pub held: Option<Real>,
}

/// The mass a held particle (caught in a gap thinner than two contact radii between a body
/// closing in and another surface, see `contact::hold`) takes in the added-mass solve, in
/// units of the body's mass (of its lightest free axis): the other surface holds it, so the
/// body's approach there stops as against a rigid contact (`1 − 1/(1 + HELD_MASS)` of it,
/// 99.9 %; the rest is the round-off's order for the body's momentum in `f32`).
pub const HELD_MASS: Real = 1.0e3;
