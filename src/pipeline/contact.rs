//! The contact stage of a substep: every particle's motion swept against the colliders near
//! it (`boundary::contact`), and the impulses it recorded on dynamic bodies handed to them
//! (`boundary::bodies`).

use super::workspace::Workspace;
use crate::boundary::Coupling;
use crate::boundary::candidates::ColliderQuery;
use crate::boundary::contact::{self, ContactInput, ContactResponse, Movers};
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
}

/// Collider contact of every particle, swept from the positions at the substep's start to
/// the current ones; the impulses it recorded on dynamic bodies go to them. Returns the
/// number of particles pushed out of a solid.
pub(super) fn collider_contact(
    fluid: &mut Fluid,
    ws: &mut Workspace,
    scene: Option<Scene<'_>>,
    depenetrate: bool,
    coupling: Option<&mut Coupling>,
    report: &mut StepReport,
) -> usize {
    let Some(scene) = scene else {
        ws.contact.clear();
        return 0;
    };
    let (p, particles) = fluid.split_mut();
    let Workspace {
        search,
        contact,
        impulses,
        previous_positions,
        ..
    } = ws;
    let (positions, velocities) = (particles.positions, particles.velocities);
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
            mass: p.particle_mass,
            records: impulses,
        });
        contact::resolve(&input, positions, velocities, movers)
    });
    if let Some(c) = coupling
        && !c.table().is_empty()
    {
        report.timed(Stage::Contact, || {
            c.exchange(impulses, velocities, p.particle_mass)
        });
    }
    report.contacts += counts.contacts;
    report.contact_fallbacks += counts.fallbacks;
    report.depenetrated += counts.depenetrated;
    counts.depenetrated
}
