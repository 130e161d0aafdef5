//! Groups of interacting fluids (`crate::fluid::interaction`), stepped as one: each substep
//! gathers the members' particles into one combined fluid with the group's parameters, runs
//! the ordinary substep on it, and writes each particle back to its own fluid, in the order
//! the neighbour search left them. Three attributes of the combined fluid carry what the
//! stages need per particle: its fluid, the ratio `r_i = ρ_ref/ρ0_i` and the viscosity
//! weight `√(ε_i/ε)` (`solver::context::Phases`); the members never see them.

use super::substep::{self, SubstepInput, SubstepResult};
use super::workspace::{FluidRuntime, Workspace};
use crate::boundary::Coupling;
use crate::boundary::bodies::ParticleMass;
use crate::diagnostics::StepReport;
use crate::error::SphResult;
use crate::fluid::{Attributes, Fluid, FluidHandle, FluidSet, interaction};
use crate::math::Real;
use crate::solver::SolverState;
use crate::solver::context::Phases;

/// The prefix of the combined fluid's own attributes.
const PREFIX: &str = "interaction.";
/// Each particle's fluid (its slot in the group, as a number).
const FLUID: &str = "interaction.fluid";
/// `r_i = ρ_ref/ρ0_i` (also written by a mixture's substep, `pipeline::mixture`).
pub(super) const RATIO: &str = "interaction.ratio";
/// `√(ε_i/ε)` (also written by a mixture's substep).
pub(super) const VISCOSITY: &str = "interaction.viscosity";

/// Offset added to the ids of a group's `k`-th fluid times `k` while they are stepped
/// together (ids seed the jitter that separates coincident particles: two fluids' particle
/// 0 at one spot must not get the same direction); removed when written back.
const ID_OFFSET: u32 = 0x9E37_79B9;

/// One group of interacting fluids.
#[derive(Clone, Debug)]
pub(crate) struct Group {
    /// Its fluids, in the set's order.
    handles: Vec<FluidHandle>,
    /// Their indices in the set's order.
    members: Vec<usize>,
    /// Their rest densities.
    rest: Vec<Real>,
    /// The combined fluid (its particles live here only during a substep).
    fluid: Fluid,
    /// Its solver state and scratch.
    pub rt: FluidRuntime,
    /// Per attribute of the combined fluid: which members had it when gathered.
    had: Vec<Vec<bool>>,
}

/// Every group of interacting fluids of the set last stepped; empty when none interacts.
#[derive(Clone, Debug, Default)]
pub(crate) struct Groups {
    pub list: Vec<Group>,
    found: Vec<Vec<usize>>,
}

impl Groups {
    /// Matches the groups to `fluids`' interactions: a group whose fluids did not change
    /// keeps its solver state. Returns without allocating when no fluid interacts.
    ///
    /// # Errors
    /// `fluid::interaction::groups`' errors; nothing changes then.
    pub fn sync(&mut self, fluids: &FluidSet) -> SphResult<()> {
        interaction::groups(fluids, &mut self.found)?;
        if self.found.is_empty() {
            self.list.clear();
            return Ok(());
        }
        let all: Vec<(FluidHandle, &Fluid)> = fluids.iter().collect();
        let mut old = std::mem::take(&mut self.list);
        for members in &self.found {
            let handles: Vec<FluidHandle> = members.iter().map(|&k| all[k].0).collect();
            let params = interaction::group_params(members.iter().map(|&k| all[k].1.params()));
            let mut group = match old.iter().position(|g| g.handles == handles) {
                Some(i) => old.swap_remove(i),
                None => Group::new(handles, &params)?,
            };
            if group.fluid.params() != &params {
                group.fluid.set_params(params)?;
            }
            if !group.rt.solver.is_for(&group.fluid.params().solver) {
                group.rt.solver = SolverState::new(&group.fluid.params().solver);
            }
            group.members.clone_from(members);
            group.rest.clear();
            group
                .rest
                .extend(members.iter().map(|&k| all[k].1.params().rest_density));
            self.list.push(group);
        }
        Ok(())
    }

    /// Heap bytes held: the groups' runtimes and their combined fluids' arrays.
    pub fn heap_bytes(&self) -> usize {
        self.list
            .iter()
            .map(|g| g.rt.ws.heap_bytes() + g.rt.solver.heap_bytes() + g.fluid.heap_bytes())
            .sum()
    }

    /// `true` when the `k`-th fluid of the set is stepped with a group.
    pub fn steps(&self, k: usize) -> bool {
        self.list.iter().any(|g| g.members.contains(&k))
    }
}

impl Group {
    fn new(handles: Vec<FluidHandle>, params: &crate::FluidParams) -> SphResult<Self> {
        Ok(Self {
            rt: FluidRuntime {
                handle: handles[0],
                epoch: 0,
                solver: SolverState::new(&params.solver),
                ws: Workspace::default(),
                relax: Default::default(),
            },
            handles,
            members: Vec::new(),
            rest: Vec::new(),
            fluid: Fluid::new(params.clone())?,
            had: Vec::new(),
        })
    }

    /// The group's fluids (indices in the set's order).
    pub fn members(&self) -> &[usize] {
        &self.members
    }

    /// The frame's start of the group's overlap relaxation budget.
    pub fn begin_relax(&mut self) {
        self.rt.relax.begin_frame(&self.fluid);
    }

    /// The combined fluid's flags: whether the relaxation is pending.
    pub fn relax_pending(&self) -> bool {
        self.fluid.relax_pending
    }

    /// One substep of the group: gather, the ordinary substep, write back. `fluids` are the
    /// set's fluids in its order.
    pub fn substep(
        &mut self,
        fluids: &mut [&mut Fluid],
        input: &SubstepInput<'_>,
        coupling: &mut Coupling,
        report: &mut StepReport,
    ) -> SubstepResult {
        self.gather(fluids);
        let result = substep::substep(&mut self.fluid, &mut self.rt, input, coupling, report);
        self.scatter(fluids);
        result
    }

    /// The members' particles, one after the other, into the combined fluid, with their
    /// attributes (zeros for a member without one) and the group's three.
    fn gather(&mut self, fluids: &[&mut Fluid]) {
        let c = &mut self.fluid;
        clear_particles(c);
        for h in &mut self.had {
            h.fill(false);
        }
        let (rho_ref, eps) = (c.params().rest_density, c.params().viscosity);
        let (mut depenetrate, mut pending) = (false, false);
        for (slot, &k) in self.members.iter().enumerate() {
            let f = &*fluids[k];
            let (n0, n) = (c.positions.len(), f.len());
            c.positions.extend_from_slice(&f.positions);
            c.velocities.extend_from_slice(&f.velocities);
            c.accelerations.extend_from_slice(&f.accelerations);
            c.densities.extend_from_slice(&f.densities);
            c.pressures.extend_from_slice(&f.pressures);
            let offset = ID_OFFSET.wrapping_mul(slot as u32);
            c.ids
                .extend(f.ids.iter().map(|&id| id.wrapping_add(offset)));
            for (name, values) in f.attributes.iter() {
                if name.starts_with(PREFIX) {
                    continue;
                }
                let a = c.attributes.ensure(name, n0);
                c.attributes.vec_mut(a).extend_from_slice(values);
                if self.had.len() <= a {
                    self.had.resize(a + 1, Vec::new());
                }
                self.had[a].resize(self.members.len(), false);
                self.had[a][slot] = true;
            }
            let fp = f.params();
            let weight = if eps > 0.0 {
                (fp.viscosity / eps).sqrt()
            } else {
                0.0
            };
            let own = [
                (FLUID, slot as Real),
                (RATIO, rho_ref / fp.rest_density),
                (VISCOSITY, weight),
            ];
            for (name, value) in own {
                let a = c.attributes.ensure(name, n0);
                c.attributes.vec_mut(a).resize(n0 + n, value);
            }
            depenetrate |= f.needs_depenetration;
            pending |= f.relax_pending;
        }
        c.attributes.resize(c.positions.len());
        c.needs_depenetration = depenetrate;
        c.relax_pending = pending;
    }

    /// Each particle of the combined fluid back to its fluid, in the combined order; each
    /// density in its own fluid's units (`ρ0_i/ρ_ref` times the reference's).
    fn scatter(&mut self, fluids: &mut [&mut Fluid]) {
        let c = &self.fluid;
        let Some(fa) = c.attributes.index_of(PREFIX, "fluid") else {
            return;
        };
        let slot_of = c.attributes.get(fa);
        let rho_ref = c.params().rest_density;
        for (slot, &k) in self.members.iter().enumerate() {
            let f = &mut *fluids[k];
            clear_particles(f);
            let offset = ID_OFFSET.wrapping_mul(slot as u32);
            let scale = self.rest[slot] / rho_ref;
            let mine = || (0..c.len()).filter(|&i| slot_of[i] as usize == slot);
            for i in mine() {
                f.positions.push(c.positions[i]);
                f.velocities.push(c.velocities[i]);
                f.accelerations.push(c.accelerations[i]);
                f.densities.push(c.densities[i] * scale);
                f.pressures.push(c.pressures[i]);
                f.ids.push(c.ids[i].wrapping_sub(offset));
            }
            for (a, (name, values)) in c.attributes.iter().enumerate() {
                let had = self.had.get(a);
                // Written back to the members that had it, or to all when the substep made it.
                let own = had.is_none_or(|h| h.get(slot) == Some(&true) || !h.contains(&true));
                if name.starts_with(PREFIX) || !own {
                    continue;
                }
                let t = f.attributes.ensure(name, 0);
                let dst = f.attributes.vec_mut(t);
                dst.extend(mine().map(|i| values[i]));
            }
            f.attributes.resize(f.positions.len());
            f.needs_depenetration = c.needs_depenetration;
            f.relax_pending = c.relax_pending;
        }
    }
}

/// Empties a fluid's particle arrays and attributes (keeping their capacity and the
/// attributes' names).
fn clear_particles(f: &mut Fluid) {
    f.positions.clear();
    f.velocities.clear();
    f.accelerations.clear();
    f.densities.clear();
    f.pressures.clear();
    f.ids.clear();
    for v in f.attributes.values_mut() {
        v.clear();
    }
}

/// The group's per-particle factors, taken out of `attributes` while the step context
/// borrows them (`None` for a fluid stepped alone).
pub(crate) struct TakenPhases {
    ratio: (usize, Vec<Real>),
    viscosity: (usize, Vec<Real>),
}

/// Takes the factors out of a combined fluid's attributes (none for a single fluid: two
/// scans of its attribute names).
pub(crate) fn take_phases(attributes: &mut Attributes) -> Option<TakenPhases> {
    let r = attributes.index_of(PREFIX, "ratio")?;
    let v = attributes.index_of(PREFIX, "viscosity")?;
    Some(TakenPhases {
        ratio: (r, std::mem::take(attributes.vec_mut(r))),
        viscosity: (v, std::mem::take(attributes.vec_mut(v))),
    })
}

/// Each particle's mass in a substep of the fluid with `attributes` and particle mass
/// `mass`: for a combined fluid, the reference mass over each particle's ratio `r_i` (what
/// its contact and wall impulses on bodies count); for a fluid stepped alone, `mass` (one
/// scan of its attribute names).
pub(crate) fn masses(mass: Real, attributes: &Attributes) -> ParticleMass<'_> {
    let ratio = attributes
        .index_of(PREFIX, "ratio")
        .map(|r| attributes.get(r));
    ParticleMass { mass, ratio }
}

/// The step context's view of the taken factors.
pub(crate) fn phases(taken: &Option<TakenPhases>) -> Option<Phases<'_>> {
    taken.as_ref().map(|t| Phases {
        ratio: &t.ratio.1,
        viscosity: &t.viscosity.1,
    })
}

/// Puts the factors back where [`take_phases`] took them.
pub(crate) fn put_back_phases(attributes: &mut Attributes, taken: Option<TakenPhases>) {
    if let Some(t) = taken {
        *attributes.vec_mut(t.ratio.0) = t.ratio.1;
        *attributes.vec_mut(t.viscosity.0) = t.viscosity.1;
    }
}
