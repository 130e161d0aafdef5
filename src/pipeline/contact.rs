//! The contact stage of a substep: every particle's motion swept against the colliders near
//! it (`boundary::contact`), and the impulses it recorded on dynamic bodies handed to them
//! (`boundary::bodies`).

use super::workspace::Workspace;
use crate::boundary::Coupling;
use crate::boundary::bodies::ParticleMass;
use crate::boundary::candidates::ColliderQuery;
use crate::boundary::contact::{self, ContactInput, ContactResponse, Movers};
use crate::boundary::forces::{ContactView, Watch};
use crate::diagnostics::{Stage, StepReport};
use crate::fluid::Fluid;
use parry3d::partitioning::Bvh;
use rapier3d::dynamics::RigidBodySet;
use rapier3d::geometry::ColliderSet;

/// The rapier side a substep sees: the broad-phase's tree, the colliders and the bodies.
#[derive(Copy, Clone)]
pub(crate) struct Scene<'a> {
    pub bvh: &'a Bvh,
    pub colliders: &'a ColliderSet,
    pub bodies: &'a RigidBodySet,
    /// The colliders whose forces or touch events the game asked for.
    pub watch: &'a Watch,
}

/// Collider contact of every particle, swept from the positions at the substep's start to
/// the current ones; with `exchange`, the impulses it recorded on dynamic bodies go to them
/// (the overlap relaxation passes `false`: it stands the coupling table's bodies at the
/// pose its particles are in and moves no body). Returns the number of particles pushed out
/// of a solid.
pub(super) fn collider_contact(
    fluid: &mut Fluid,
    ws: &mut Workspace,
    scene: Option<Scene<'_>>,
    depenetrate: bool,
    (mut coupling, exchange): (Option<&mut Coupling>, bool),
    report: &mut StepReport,
) -> usize {
    let Some(scene) = scene else {
        ws.contact.clear();
        return 0;
    };
    let (p, particles) = fluid.split_mut();
    let masses = super::interaction::masses(p.particle_mass, particles.attributes);
    let Workspace {
        search,
        contact,
        impulses,
        previous_positions,
        forces,
        ..
    } = ws;
    let (positions, velocities) = (particles.positions, particles.velocities);
    forces.snapshot(scene.watch, velocities);
    let counts = report.timed(Stage::Contact, || {
        let query = ColliderQuery {
            bvh: scene.bvh,
            colliders: scene.colliders,
            groups: p.collision_groups,
            coupling: coupling.as_deref(),
        };
        contact.gather(
            &search.grid,
            previous_positions,
            positions,
            p.particle_radius,
            &query,
        );
        if !contact.any() {
            // No particle near a collider: no impulse on any body this substep (the records
            // of an earlier substep, whose particles may since have been quarantined, must
            // not be exchanged again).
            impulses.iter_mut().for_each(Vec::clear);
            return contact::ContactCounts::default();
        }
        let response = ContactResponse {
            radius: p.particle_radius,
            restitution: p.restitution,
            friction: p.friction,
        };
        let input = ContactInput {
            grid: &search.grid,
            candidates: contact,
            colliders: scene.colliders,
            response,
            depenetrate_first: depenetrate,
            previous: previous_positions,
        };
        let movers = coupling.as_deref().map(|c| Movers {
            table: c.table(),
            mass: masses,
            records: impulses,
        });
        contact::resolve(&input, positions, velocities, movers)
    });
    if !exchange {
        // What the relaxation's contact recorded on bodies is dropped, and its forces are
        // read as before it had a table (each collider as at rest).
        impulses.iter_mut().for_each(Vec::clear);
        coupling = None;
    }
    let ids = &particles.ids[..];
    let table = coupling.as_deref().map_or(&[][..], |c| c.table());
    let records = if table.is_empty() {
        &[][..]
    } else {
        &impulses[..]
    };
    let view = contact_view(scene, search, contact, table, (p, masses));
    forces.after_resolve(&view, records, positions, velocities);
    if let Some(c) = coupling.as_deref_mut()
        && !c.table().is_empty()
    {
        report.timed(Stage::Contact, || {
            c.exchange(impulses, positions, velocities, masses, false)
        });
        let m = (masses, true);
        forces.after_exchange(scene.watch, c.table(), impulses, velocities, m);
    }
    let table = coupling.as_deref().map_or(&[][..], |c| c.table());
    let view = contact_view(scene, search, contact, table, (p, masses));
    forces.touch(&view, positions, ids);
    report.contacts += counts.contacts;
    report.contact_fallbacks += counts.fallbacks;
    report.depenetrated += counts.depenetrated;
    counts.depenetrated
}

/// What the watched colliders' records read of the contact stage.
fn contact_view<'a>(
    scene: Scene<'a>,
    search: &'a crate::neighbors::NeighbourSearch,
    contact: &'a crate::boundary::ContactWorkspace,
    table: &'a [crate::boundary::bodies::MovingCollider],
    (p, masses): (&crate::params::FluidParams, ParticleMass<'a>),
) -> ContactView<'a> {
    ContactView {
        watch: scene.watch,
        grid: &search.grid,
        candidates: contact,
        colliders: scene.colliders,
        table,
        radius: p.particle_radius,
        mass: masses,
        touch: crate::boundary::forces::touch_distance(p),
    }
}
