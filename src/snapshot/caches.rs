//! Checks of what the narrow phase keeps for rapier's solver between steps, as a snapshot
//! restores it: the solver contact graph (per-colour buckets of `(edge, manifold)`
//! references, each solver-active manifold's back link `graph_pos` and its stamped solver-body
//! ids), the pairs' solver colours, the force-event pair list and its per-edge back links,
//! and each manifold's solver contacts' indices into its points.
//!
//! What rapier 0.36 (built without its `parallel` feature, as here) follows without checks,
//! and so what a file crafted to pass the checksum could make panic or corrupt memory with:
//! - the buckets (`SolverContactGraph::buckets`, 128 parallel colours, the overflow colour and
//!   the multibody list: 130) are indexed by colour and bucket id, also by the full rebuild;
//! - a pair's solver colour picks its bucket (`bucket_id(colour)`): at most the overflow
//!   colour 128, or 255 for none;
//! - while the graph is valid (`solver_graph_valid`), removing a pair takes its manifolds out
//!   of the buckets through their `graph_pos` and rewrites the entry swapped into the hole
//!   through a raw pointer to the edge that entry names (`remove_and_fixup`), and the solver
//!   resolves every entry to a pair's rigid manifolds through a raw projection
//!   (`ManifoldStore`): each entry must name a rigid pair's solver manifold whose `graph_pos`
//!   names the entry back;
//! - when the graph is also current (its epochs the island manager's and the multibody set's),
//!   the solver gathers bodies' velocities at the manifolds' stamped solver-body ids without
//!   bounds checks (`SolverBodies::gather_vels`): each is `u32::MAX` (a world-attached side)
//!   or below the number of awake bodies;
//! - the force-event list is indexed by its entries (`edges[edge]`) and its back links
//!   (`force_event_pos`) by edge, both ways, also by a pair's removal;
//! - the solver reads and writes back a solver contact's manifold point at its index
//!   (`manifold.points[contact_id]`).
//!
//! The fields are private; as for the graphs, islands and joints, they are read through a
//! mirror of their serde layout: the narrow phase's fields after its two graphs decoded whole
//! into [`SolverCaches`], a pair's colour from the end of its rigid contacts' encoding (after
//! its public manifolds and clusters) and a manifold's solver fields from its data's encoding
//! (between its public bodies and flags and its public normal and contacts), each pinned by
//! re-encoding. A stale but consistent cache (a graph marked for rebuild, a force list marked
//! invalid) is what rapier rebuilds from scratch in the next step, so it is not refused:
//! rebuilding it here instead would change the solve order of a restored run.

use super::graphs::{self, Fault};
use rapier3d::geometry::{ContactManifold, ContactPair, NarrowPhase};
use rapier3d::pipeline::PhysicsWorld;
use serde::{Deserialize, Serialize};

/// Rapier's `u32` for "none".
const NONE: u32 = u32::MAX;

/// The solver contact graph's buckets: 128 parallel colours, the overflow colour, the list of
/// manifolds involving a multibody.
const BUCKETS: usize = 130;

/// The overflow colour (solved sequentially), the largest a pair's colour may be but "none".
const OVERFLOW: u8 = 128;

/// `graph_pos`: the bucket in the high bits, the place in it in the low 22.
const BUCKET_SHIFT: u32 = 22;

const LAYOUT: Fault = (
    0,
    "the narrow phase's solver caches' layout is not the one this build reads (rapier upgraded)",
);

/// The narrow phase's encoding after its two interaction graphs: the collider → node map,
/// then what it keeps for the solver.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub(crate) struct SolverCaches {
    graph_indices: Vec<(u32, (u32, u32))>,
    color_masks: Vec<u128>,
    hints: Vec<u16>,
    buckets: Vec<Vec<(u32, u32)>>,
    graph_valid: bool,
    graph_epoch: u32,
    graph_mb_epoch: u32,
    force_pairs: Vec<u32>,
    force_pos: Vec<u32>,
    force_flagged: Vec<u32>,
    force_valid: bool,
}

/// A manifold's private solver fields: its colour, its bodies' solver ids, its place in the
/// solver contact graph.
#[derive(Serialize, Deserialize, Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct ManifoldSolver {
    color: u8,
    body_ids: [u32; 2],
    graph_pos: u32,
}

/// A rigid pair as the checks read it: its colour, and its solver manifolds' solver fields
/// (`None` for a pair of two soft surfaces).
#[derive(Debug, Clone)]
pub(crate) struct PairSolver {
    color: u8,
    manifolds: Vec<ManifoldSolver>,
}

/// Reads the narrow phase's solver caches. `None`: the layout is not the mirror's.
pub(crate) fn mirror_caches(np: &NarrowPhase) -> Option<SolverCaches> {
    let all = postcard::to_allocvec(np).ok()?;
    let contacts = postcard::to_allocvec(np.contact_graph()).ok()?;
    let intersections = postcard::to_allocvec(np.intersection_graph()).ok()?;
    let rest = all.strip_prefix(contacts.as_slice())?;
    let rest = rest.strip_prefix(intersections.as_slice())?;
    match postcard::take_from_bytes::<SolverCaches>(rest) {
        Ok((m, [])) => Some(m),
        _ => None,
    }
}

/// A manifold's solver fields, read between its public bodies and flags and its public normal
/// and contacts. `None`: the layout is not the mirror's.
pub(crate) fn manifold_solver(m: &ContactManifold) -> Option<ManifoldSolver> {
    let d = &m.data;
    let all = postcard::to_allocvec(d).ok()?;
    let front = postcard::to_allocvec(&(d.rigid_body1, d.rigid_body2, d.solver_flags)).ok()?;
    let back = postcard::to_allocvec(&(
        d.normal,
        &d.solver_contacts,
        d.relative_dominance,
        d.user_data,
        d.friction,
        d.restitution,
    ))
    .ok()?;
    let (solver, rest) =
        postcard::take_from_bytes::<ManifoldSolver>(all.strip_prefix(front.as_slice())?).ok()?;
    (rest == back.as_slice()).then_some(solver)
}

/// A pair's colour (after its public manifolds and clusters) and its solver manifolds' fields.
/// `Ok(None)`: a pair of two soft surfaces; `Err`: the layout is not the mirror's.
pub(crate) fn pair_solver(pair: &ContactPair) -> Result<Option<PairSolver>, Fault> {
    let Some(rigid) = pair.rigid() else {
        return Ok(None);
    };
    let all = postcard::to_allocvec(rigid).map_err(|_| LAYOUT)?;
    let front =
        postcard::to_allocvec(&(&rigid.manifolds, &rigid.solver_clusters)).map_err(|_| LAYOUT)?;
    let rest = all.strip_prefix(front.as_slice()).ok_or(LAYOUT)?;
    let ((color, _bodies), _) =
        postcard::take_from_bytes::<(u8, [u32; 2])>(rest).map_err(|_| LAYOUT)?;
    let manifolds = rigid
        .solver_manifolds()
        .iter()
        .map(manifold_solver)
        .collect::<Option<Vec<_>>>()
        .ok_or(LAYOUT)?;
    Ok(Some(PairSolver { color, manifolds }))
}

/// Every solver contact of a pair's manifolds and clusters names a point of its manifold.
fn check_contact_ids(pair: &ContactPair) -> Result<(), &'static str> {
    let Some(rigid) = pair.rigid() else {
        return Ok(());
    };
    let fine = |m: &ContactManifold| {
        m.data
            .solver_contacts
            .iter()
            .all(|c| (c.contact_indices()[0] as usize) < m.points.len())
    };
    if rigid
        .manifolds
        .iter()
        .chain(&rigid.solver_clusters)
        .all(fine)
    {
        Ok(())
    } else {
        Err("a solver contact names a point its manifold does not have")
    }
}

/// The state the checks compare the caches with: per contact edge its pair as read, the number
/// of awake bodies, and whether the graph is current (its epochs the world's).
pub(crate) struct World {
    pairs: Vec<Option<PairSolver>>,
    awake: usize,
    current: bool,
}

/// The buckets' count; every pair's colour a colour; while the graph is valid, each bucket
/// entry a rigid pair's solver manifold whose `graph_pos` names it back, and every manifold's
/// `graph_pos` an entry naming it; while it is also current, each member's solver-body ids
/// awake bodies' or `u32::MAX`.
pub(crate) fn check_graph(c: &SolverCaches, w: &World) -> Result<(), Fault> {
    if c.buckets.len() != BUCKETS {
        return Err((
            c.buckets.len(),
            "the solver contact graph does not have its 130 buckets",
        ));
    }
    for (e, p) in w.pairs.iter().enumerate() {
        if p.as_ref()
            .is_some_and(|p| p.color > OVERFLOW && p.color != u8::MAX)
        {
            return Err((e, "a contact pair's solver colour is not a colour"));
        }
    }
    if !c.graph_valid {
        return Ok(());
    }
    let manifold = |edge: u32, ordinal: u32| {
        w.pairs
            .get(edge as usize)
            .and_then(Option::as_ref)
            .and_then(|p| p.manifolds.get(ordinal as usize))
    };
    for (b, bucket) in c.buckets.iter().enumerate() {
        for (local, &(edge, ordinal)) in bucket.iter().enumerate() {
            let pos = ((b as u32) << BUCKET_SHIFT) | local as u32;
            let m = manifold(edge, ordinal).ok_or((
                edge as usize,
                "a solver contact graph entry names no rigid pair's solver manifold",
            ))?;
            if local >= 1 << BUCKET_SHIFT || m.graph_pos != pos {
                return Err((
                    edge as usize,
                    "a solver contact graph entry's manifold does not name it back",
                ));
            }
            let in_range = |id: u32| id == NONE || (id as usize) < w.awake;
            if w.current && !m.body_ids.iter().all(|&id| in_range(id)) {
                return Err((
                    edge as usize,
                    "a solver-active manifold's solver-body id is not an awake body's",
                ));
            }
        }
    }
    for (e, p) in w.pairs.iter().enumerate() {
        let Some(p) = p else { continue };
        for (k, m) in p.manifolds.iter().enumerate() {
            if m.graph_pos == NONE {
                continue;
            }
            let (b, local) = (
                m.graph_pos >> BUCKET_SHIFT,
                m.graph_pos & ((1 << BUCKET_SHIFT) - 1),
            );
            let entry = c
                .buckets
                .get(b as usize)
                .and_then(|bucket| bucket.get(local as usize));
            if entry != Some(&(e as u32, k as u32)) {
                return Err((
                    e,
                    "a manifold's place in the solver contact graph is not its own",
                ));
            }
        }
    }
    Ok(())
}

/// The force-event list's entries edges, and its back links their places: every entry's edge
/// links to the entry, every link other than "none" to an entry of that edge.
pub(crate) fn check_force_events(c: &SolverCaches, edges: usize) -> Result<(), Fault> {
    for (i, &e) in c.force_pairs.iter().enumerate() {
        if e as usize >= edges || c.force_pos.get(e as usize) != Some(&(i as u32)) {
            return Err((
                i,
                "a force-event pair is not an edge, or its edge does not link back to it",
            ));
        }
    }
    for (e, &i) in c.force_pos.iter().enumerate() {
        if i != NONE && c.force_pairs.get(i as usize) != Some(&(e as u32)) {
            return Err((e, "an edge's force-event link names another pair's entry"));
        }
    }
    Ok(())
}

/// Checks the narrow phase's solver caches (see the module docs); to be called after the
/// islands' and joints' checks (it reads the awake island and the multibodies' epoch).
///
/// # Errors
/// [`crate::SphError::InvalidParameter`] with field `"narrow_phase"`, the edge, entry or
/// bucket concerned and the fault.
pub(crate) fn check_solver_caches(p: &PhysicsWorld) -> Result<(), crate::SphError> {
    check(p).map_err(|(at, reason)| crate::SphError::InvalidParameter {
        field: "narrow_phase",
        value: at as f64,
        reason,
    })
}

fn check(p: &PhysicsWorld) -> Result<(), Fault> {
    let np = &p.narrow_phase;
    let caches = mirror_caches(np).ok_or(LAYOUT)?;
    let edges = np.contact_graph().raw_graph().raw_edges();
    let mut pairs = Vec::with_capacity(edges.len());
    for (e, edge) in edges.iter().enumerate() {
        check_contact_ids(&edge.weight).map_err(|reason| (e, reason))?;
        pairs.push(pair_solver(&edge.weight)?);
    }
    let island_epoch = super::islands::active_set_epoch(p).ok_or(LAYOUT)?;
    let mb_epoch = super::joints::topology_epoch(&p.multibody_joints).ok_or(LAYOUT)?;
    let world = World {
        pairs,
        awake: p.islands.active_bodies().count(),
        current: caches.graph_epoch == island_epoch && caches.graph_mb_epoch == mb_epoch,
    };
    check_graph(&caches, &world)?;
    check_force_events(&caches, edges.len())?;
    // The graph module's map check reads the same map: keep the two mirrors in step.
    debug_assert_eq!(
        graphs::graph_indices(np).as_deref(),
        Some(caches.graph_indices.as_slice())
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Real, Vector};
    use rapier3d::prelude::{
        ActiveEvents, ColliderBuilder, RevoluteJointBuilder, RigidBodyBuilder,
    };

    /// A world whose narrow phase keeps every kind of solver cache: boxes stacked and resting
    /// on a floor (they fall asleep), one with contact-force events, a sensor, a multibody
    /// chain lying on the floor, and balls rained on them and removed in batches (pairs
    /// removed, edges swap-moved); at frame 150 the sleepers are woken. `look` sees it after
    /// every step and change.
    fn cache_world(mut look: impl FnMut(&PhysicsWorld)) {
        let mut w = PhysicsWorld::new();
        w.insert_collider(ColliderBuilder::cuboid(3.0, 0.1, 3.0), None);
        w.insert_collider(
            ColliderBuilder::cuboid(0.5, 0.3, 0.5)
                .translation(Vector::new(1.0, 0.4, 0.0))
                .sensor(true),
            None,
        );
        let mut boxes = Vec::new();
        for k in 0..6 {
            let at = Vector::new(
                (k % 3) as Real * 0.5 - 0.5,
                0.2 + (k / 3) as Real * 0.2,
                1.0,
            );
            let b = w.insert_body(RigidBodyBuilder::dynamic().translation(at));
            let mut c = ColliderBuilder::cuboid(0.1, 0.1, 0.1);
            if k == 1 {
                c = c
                    .active_events(ActiveEvents::CONTACT_FORCE_EVENTS)
                    .contact_force_event_threshold(0.0);
            }
            w.insert_collider(c, Some(b));
            boxes.push(b);
        }
        let mut parent =
            w.insert_body(RigidBodyBuilder::fixed().translation(Vector::new(-1.0, 0.2, -1.0)));
        w.insert_collider(ColliderBuilder::ball(0.1), Some(parent));
        for k in 1..4 {
            let b = w.insert_body(RigidBodyBuilder::dynamic().translation(Vector::new(
                -1.0 + 0.22 * k as Real,
                0.2,
                -1.0,
            )));
            w.insert_collider(ColliderBuilder::ball(0.1), Some(b));
            let joint =
                RevoluteJointBuilder::new(Vector::Z).local_anchor2(Vector::new(-0.22, 0.0, 0.0));
            w.multibody_joints.insert(parent, b, joint, true).unwrap();
            parent = b;
        }
        let mut balls = Vec::new();
        for i in 0..24 {
            let at = Vector::new(
                (i % 6) as Real * 0.3 - 0.4,
                1.0 + (i / 6) as Real * 0.3,
                0.0,
            );
            let b = w.insert_body(RigidBodyBuilder::dynamic().translation(at));
            balls.push(w.insert_collider(ColliderBuilder::ball(0.1), Some(b)));
        }
        look(&w);
        for frame in 0..400 {
            w.step();
            look(&w);
            if frame % 40 == 39 && !balls.is_empty() {
                for h in balls.drain(..4) {
                    w.remove_collider(h);
                }
                look(&w);
            }
            if frame == 300 {
                for &b in &boxes {
                    w.bodies[b].apply_impulse(Vector::new(0.0, 0.05, 0.0), true);
                }
                look(&w);
            }
        }
    }

    /// The checks' inputs from a world.
    fn read(p: &PhysicsWorld) -> (SolverCaches, World) {
        let np = &p.narrow_phase;
        let pairs = np
            .contact_graph()
            .raw_graph()
            .raw_edges()
            .iter()
            .map(|e| pair_solver(&e.weight).unwrap())
            .collect();
        let caches = mirror_caches(np).expect("the narrow phase's layout");
        let current = caches.graph_epoch == super::super::islands::active_set_epoch(p).unwrap()
            && caches.graph_mb_epoch
                == super::super::joints::topology_epoch(&p.multibody_joints).unwrap();
        let world = World {
            pairs,
            awake: p.islands.active_bodies().count(),
            current,
        };
        (caches, world)
    }

    /// The mirrors read real narrow phases whole (the caches re-encode the narrow phase's
    /// tail byte for byte; every manifold's solver fields sit between its public fields), and
    /// every state of a busy run passes the checks; the run has used every cache checked.
    #[test]
    fn the_mirrors_read_real_caches() {
        let (mut checked, mut members, mut generic, mut forces, mut stale, mut asleep) =
            (0, 0, 0, 0, 0, 0);
        cache_world(|p| {
            let np = &p.narrow_phase;
            let (caches, world) = read(p);
            let mut again = postcard::to_allocvec(np.contact_graph()).unwrap();
            again.extend(postcard::to_allocvec(np.intersection_graph()).unwrap());
            again.extend(postcard::to_allocvec(&caches).unwrap());
            assert_eq!(again, postcard::to_allocvec(np).unwrap());
            check(p).unwrap();
            if caches.graph_valid && world.current {
                members += caches.buckets.iter().map(Vec::len).sum::<usize>();
                generic += caches.buckets[BUCKETS - 1].len();
            }
            stale += usize::from(!caches.graph_valid || !world.current);
            forces += caches.force_pairs.len();
            asleep += usize::from(p.bodies.iter().any(|(_, b)| b.is_sleeping()));
            checked += 1;
        });
        assert_eq!(checked, 408);
        assert!(
            members > 0 && generic > 0 && forces > 0 && stale > 0 && asleep > 0,
            "{members} solver-active manifolds ({generic} with a multibody), {forces} \
             force-event pairs, {stale} states awaiting a rebuild, {asleep} with sleepers"
        );
    }

    /// The last state of [`cache_world`] whose solver contact graph is valid, current and
    /// holds a force-event pair.
    fn current() -> (SolverCaches, World) {
        let mut out = None;
        cache_world(|p| {
            let (c, w) = read(p);
            let members = c.buckets.iter().filter(|b| !b.is_empty()).count();
            if c.graph_valid && w.current && members > 1 && !c.force_pairs.is_empty() {
                out = Some((c, w));
            }
        });
        out.expect("a state with a current solver contact graph")
    }

    /// Each fault the checks name, made in a real narrow phase's caches, is refused.
    #[test]
    fn broken_caches_are_refused() {
        let (good, world) = current();
        let edges = world.pairs.len();
        check_graph(&good, &world).unwrap();
        check_force_events(&good, edges).unwrap();
        let graph_refused = |edit: &dyn Fn(&mut SolverCaches, &mut World)| {
            let (mut c, mut w) = (
                good.clone(),
                World {
                    pairs: world.pairs.clone(),
                    awake: world.awake,
                    current: world.current,
                },
            );
            edit(&mut c, &mut w);
            check_graph(&c, &w).unwrap_err()
        };
        let first = good.buckets.iter().position(|b| !b.is_empty()).unwrap();
        let (edge, ordinal) = good.buckets[first][0];
        // The buckets' count; a colour out of range.
        graph_refused(&|c, _| {
            c.buckets.pop();
        });
        graph_refused(&|_, w| w.pairs[edge as usize].as_mut().unwrap().color = 200);
        // An entry naming an edge or a manifold that does not exist, or another manifold.
        graph_refused(&|c, _| c.buckets[first][0].0 = edges as u32);
        graph_refused(&|c, _| c.buckets[first][0].1 += 100);
        graph_refused(&|c, _| {
            let other = c.buckets.iter().rposition(|b| !b.is_empty()).unwrap();
            let e = c.buckets[other].last().copied().unwrap();
            c.buckets[first][0] = e;
        });
        // A manifold's back link naming another place; an entry dropped from its bucket.
        graph_refused(&|_, w| {
            w.pairs[edge as usize].as_mut().unwrap().manifolds[ordinal as usize].graph_pos += 1
        });
        graph_refused(&|c, _| {
            c.buckets[first].remove(0);
        });
        // A member's solver-body id past the awake bodies.
        graph_refused(&|_, w| {
            w.pairs[edge as usize].as_mut().unwrap().manifolds[ordinal as usize].body_ids[0] =
                w.awake as u32
        });
        // The same faults are not read while rapier will rebuild the graph from scratch.
        let mut stale = good.clone();
        stale.graph_valid = false;
        stale.buckets[first].clear();
        check_graph(&stale, &world).unwrap();
        // The force-event list: an entry past the edges, a back link naming another entry.
        let mut c = good.clone();
        c.force_pairs[0] = edges as u32;
        check_force_events(&c, edges).unwrap_err();
        let mut c = good.clone();
        let e = c.force_pairs[0] as usize;
        c.force_pos[e] = NONE;
        check_force_events(&c, edges).unwrap_err();
        let mut c = good.clone();
        let spare = (0..c.force_pos.len())
            .find(|&k| c.force_pos[k] == NONE)
            .unwrap();
        c.force_pos[spare] = 0;
        check_force_events(&c, edges).unwrap_err();
    }

    /// A solver contact naming a point past its manifold's is refused.
    #[test]
    fn a_solver_contact_past_its_points_is_refused() {
        let mut last = None;
        cache_world(|p| {
            if let Some(e) = p
                .narrow_phase
                .contact_graph()
                .raw_graph()
                .raw_edges()
                .iter()
                .find(|e| e.weight.rigid().is_some_and(|r| r.has_any_active_contact()))
            {
                last = Some(e.weight.clone());
            }
        });
        let mut pair = last.unwrap();
        check_contact_ids(&pair).unwrap();
        let rigid = match &mut pair.contacts {
            rapier3d::geometry::PairContacts::Rigid(r) => r,
            _ => unreachable!("a rigid pair"),
        };
        let m = rigid
            .manifolds
            .iter_mut()
            .find(|m| !m.data.solver_contacts.is_empty())
            .unwrap();
        m.data.solver_contacts[0].contact_id[0] = m.points.len() as u32;
        check_contact_ids(&pair).unwrap_err();
    }
}
