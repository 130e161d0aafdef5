//! The step's per-fluid scratch, and the per-fluid state the pipeline keeps between frames:
//! the solver's state. Held by [`super::FluidPipeline`], one entry per fluid of the set it
//! steps, matched by handle.

use crate::boundary::bodies::ImpulseRecord;
use crate::boundary::forces::FluidForces;
use crate::boundary::{ContactWorkspace, WallWorkspace};
use crate::fluid::{FluidHandle, FluidSet};
use crate::math::{Real, Vector};
use crate::neighbors::NeighbourSearch;
use crate::solver::SolverState;
use crate::solver::pbf::PbfBuffers;

/// Scratch one fluid's substep reuses, so that a warm step never allocates.
#[derive(Clone, Debug, Default)]
pub(crate) struct Workspace {
    /// Grid, neighbour lists and the re-sort's scratch.
    pub search: NeighbourSearch,
    /// Colliders near each cell (collider contact's candidates).
    pub contact: ContactWorkspace,
    /// Impulses on dynamic bodies recorded by contact, one buffer per chunk of particles.
    pub impulses: Vec<Vec<ImpulseRecord>>,
    /// Impulses on dynamic bodies from the walls' pressure term (one buffer).
    pub wall_impulses: Vec<Vec<ImpulseRecord>>,
    /// Impulses on dynamic bodies from the walls' viscosity.
    pub wall_viscous_impulses: Vec<ImpulseRecord>,
    /// Wall contributions to density (see [`crate::boundary::wall`]).
    pub wall: WallWorkspace,
    /// Buffers of the overlap relaxation (a PBF projection; see `pipeline::relax`).
    pub relax: PbfBuffers,
    /// Positions at the start of the current substep (written by the particle update, swept
    /// from by collider contact).
    pub previous_positions: Vec<Vector>,
    /// `1/ρ` of every particle, written by the density stage.
    pub inv_densities: Vec<Real>,
    /// The surface normals of the surface-tension stage (`forces::surface_tension`).
    pub surface_normals: Vec<Vector>,
    /// Per-chunk partial sums for diagnostics (summed serially, so results are deterministic).
    pub partials: Vec<(f64, Real)>,
    /// Largest speed after the last substep (the adaptive time step's input).
    pub max_speed: Real,
    /// Largest mean density error of the frame's substeps (the sleep test's input).
    pub frame_error: Real,
    /// Whether particles came or went (emitters, sinks) or an emitter was blocked during the
    /// frame (the sleep test's input).
    pub frame_changed: bool,
    /// Fastest surface speeds of the non-fixed bodies near the fluid during the frame (the
    /// adaptive time step's input beside `max_speed`; the kinematic ones bound the speeds
    /// they can give, see `pipeline::substep`).
    pub bodies_near: crate::boundary::bodies::NearBodies,
    /// The fluid's largest speed at the frame's start plus what gravity adds over the frame
    /// (m/s): with `bodies_near`, the bound on particle speeds near kinematic bodies.
    pub frame_speed: Real,
    /// What the fluid did to the watched colliders this frame (`boundary::forces`).
    pub forces: FluidForces,
    /// The scalar diffusion's new values and row sums (`crate::scalars`; empty for a fluid
    /// without scalars).
    pub scalar_scratch: (Vec<Real>, Vec<Real>),
    /// The implicit viscosity solve's buffers (`forces::viscosity_implicit`; empty unless the
    /// fluid uses it).
    pub viscosity: crate::forces::viscosity_implicit::Scratch,
    /// The mixture's buffers (`crate::mixture`; empty for a fluid without a mixture).
    pub mixture: crate::mixture::Scratch,
    /// The sleep test's cells (`pipeline::sleep`; empty for a fluid that may not sleep).
    pub sleep_cells: super::sleep::DriftCells,
}

impl Workspace {
    /// Reserves the per-particle scratch for `capacity` particles (see
    /// [`crate::Fluid::set_capacity`]): a fluid filling up to its capacity then never
    /// reallocates it. Costs a length check once reserved.
    pub fn reserve(&mut self, capacity: usize) {
        self.search.reserve(capacity);
        let extra = |len: usize| capacity.saturating_sub(len);
        let _ = self
            .previous_positions
            .try_reserve_exact(extra(self.previous_positions.len()));
        let _ = self
            .inv_densities
            .try_reserve_exact(extra(self.inv_densities.len()));
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        let v = std::mem::size_of::<Vector>();
        let records = |r: &Vec<Vec<ImpulseRecord>>| {
            r.iter().map(|c| c.capacity()).sum::<usize>() * std::mem::size_of::<ImpulseRecord>()
        };
        self.search.heap_bytes()
            + self.viscosity.heap_bytes()
            + self.contact.heap_bytes()
            + self.wall.heap_bytes()
            + self.relax.heap_bytes()
            + records(&self.impulses)
            + records(&self.wall_impulses)
            + self.wall_viscous_impulses.capacity() * std::mem::size_of::<ImpulseRecord>()
            + self.previous_positions.capacity() * v
            + self.inv_densities.capacity() * 4
            + self.surface_normals.capacity() * v
            + self.partials.capacity() * std::mem::size_of::<(f64, Real)>()
            + self.forces.heap_bytes()
            + (self.scalar_scratch.0.capacity() + self.scalar_scratch.1.capacity()) * 4
            + self.mixture.heap_bytes()
            + self.sleep_cells.heap_bytes()
    }
}

/// What the pipeline keeps for one fluid: its solver's state and the step's scratch.
#[derive(Clone, Debug)]
pub(crate) struct FluidRuntime {
    /// The fluid this belongs to.
    pub handle: FluidHandle,
    /// The fluid's epoch ([`crate::Fluid::clear`] and [`crate::Fluid::reset`] bump it) when
    /// the solver state was made: a cleared fluid's state starts afresh.
    pub epoch: u64,
    /// The solver's state (rebuilt when the fluid's parameters change solver).
    pub solver: SolverState,
    /// Scratch.
    pub ws: Workspace,
    /// The overlap relaxation's rounds left this frame (see `pipeline::relax`).
    pub relax: super::relax::RelaxBudget,
}

/// One [`FluidRuntime`] per fluid of the set last stepped, in the set's order, and the
/// groups of interacting fluids (each with its own runtime).
#[derive(Clone, Debug, Default)]
pub(crate) struct Runtimes {
    entries: Vec<FluidRuntime>,
    /// Groups of interacting fluids (`pipeline::interaction`); empty when none interacts.
    pub groups: super::interaction::Groups,
}

impl Runtimes {
    /// Matches the entries to `fluids` (same handles, same order; a new fluid gets a fresh
    /// entry, a removed one's entry is dropped, a fluid whose parameters changed solver or
    /// that was cleared or reset since gets a fresh solver state). Allocates nothing when
    /// nothing changed.
    pub fn sync(&mut self, fluids: &FluidSet) {
        let same = self.entries.len() == fluids.len()
            && self.entries.iter().zip(fluids.iter()).all(|(e, (h, f))| {
                e.handle == h && e.epoch == f.epoch && e.solver.is_for(&f.params().solver)
            });
        if same {
            return;
        }
        let mut old = std::mem::take(&mut self.entries);
        for (handle, fluid) in fluids.iter() {
            let solver = &fluid.params().solver;
            let entry = match old.iter().position(|e| e.handle == handle) {
                Some(k) => {
                    let mut e = old.swap_remove(k);
                    if !e.solver.is_for(solver) || e.epoch != fluid.epoch {
                        e.solver = SolverState::new(solver);
                        e.epoch = fluid.epoch;
                    }
                    e
                }
                None => FluidRuntime {
                    handle,
                    epoch: fluid.epoch,
                    solver: SolverState::new(solver),
                    ws: Workspace::default(),
                    relax: Default::default(),
                },
            };
            self.entries.push(entry);
        }
    }

    /// The entries, in the set's order.
    pub fn iter_mut(&mut self) -> std::slice::IterMut<'_, FluidRuntime> {
        self.entries.iter_mut()
    }

    /// The entries, in the set's order, each with whether a group steps its fluid.
    pub fn with_groups_mut(&mut self) -> impl Iterator<Item = (&mut FluidRuntime, bool)> {
        let groups = &self.groups;
        let grouped = move |k| !groups.list.is_empty() && groups.steps(k);
        self.entries
            .iter_mut()
            .enumerate()
            .map(move |(k, e)| (e, grouped(k)))
    }

    /// The entries, then the groups' runtimes (whose records count under their first
    /// fluid's handle).
    pub fn all_mut(&mut self) -> impl Iterator<Item = &mut FluidRuntime> {
        let groups = self.groups.list.iter_mut().map(|g| &mut g.rt);
        self.entries.iter_mut().chain(groups)
    }

    /// The frame's start of each group: its relaxation budget, and its members' speeds and
    /// nearby bodies (measured per member by the frame's quarantine) merged.
    pub fn begin_group_frames(&mut self) {
        for g in &mut self.groups.list {
            let (mut near, mut speed, mut frame): (_, Real, Real) = (Default::default(), 0.0, 0.0);
            for &k in g.members() {
                let ws = &self.entries[k].ws;
                near = ws.bodies_near.merge(near);
                speed = speed.max(ws.max_speed);
                frame = frame.max(ws.frame_speed);
            }
            g.begin_relax();
            g.rt.ws.bodies_near = near;
            g.rt.ws.max_speed = speed;
            g.rt.ws.frame_speed = frame;
        }
    }

    /// After a group's substep: its fastest speed is each member's (the next substep's
    /// CFL input).
    pub fn spread_group_speed(&mut self, group: usize) {
        let g = &self.groups.list[group];
        for &k in g.members() {
            self.entries[k].ws.max_speed = g.rt.ws.max_speed;
        }
    }

    /// What each group's overlap relaxation left unfinished this frame.
    pub fn end_group_relaxations(&mut self) -> impl Iterator<Item = super::relax::RelaxLeft> {
        self.groups.list.iter_mut().filter_map(|g| {
            let pending = g.relax_pending();
            g.rt.relax.end_frame(pending)
        })
    }

    /// The entry of `handle`.
    pub fn get(&self, handle: FluidHandle) -> Option<&FluidRuntime> {
        self.entries.iter().find(|e| e.handle == handle)
    }

    /// The entry of `handle`, made for `fluids` if it does not exist yet.
    #[cfg_attr(not(feature = "snapshot"), allow(dead_code))]
    pub fn get_or_sync(
        &mut self,
        handle: FluidHandle,
        fluids: &FluidSet,
    ) -> Option<&mut FluidRuntime> {
        self.sync(fluids);
        self.entries.iter_mut().find(|e| e.handle == handle)
    }

    /// Heap bytes held by every entry.
    pub fn heap_bytes(&self) -> usize {
        self.entries
            .iter()
            .map(|e| e.ws.heap_bytes() + e.solver.heap_bytes())
            .sum::<usize>()
            + self.entries.capacity() * std::mem::size_of::<FluidRuntime>()
            + self.groups.heap_bytes()
    }
}
