//! Checks of rapier's island bookkeeping as a snapshot restores it: each body's private ids,
//! the active islands (the awake set and the sleeping chunks) and the persistent islands
//! (connected components of the contact and joint graph), and each body's list of colliders.
//!
//! Rapier 0.36 indexes its solver's arrays with a body's `active_set_id`, its islands with
//! `active_island_id` and `island_id`, and its link tables with the locations the persistent
//! islands store, all without checks (`staged_island_solver/worker.rs` reads
//! `solver_bodies.vels[rb.ids.active_set_id]`; `extract_sleeping_sub_island` asserts that a
//! chunk's bodies are in the awake island). These fields are private, so, as for the trees
//! (the `bvh` module), they are read through a mirror of their serde layout: the
//! `IslandManager` is encoded again and decoded into [`Islands`], all of it; a body's ids are
//! the first field of its encoding and are decoded from the front of it ([`body_ids`]).
//!
//! Rebuilding the islands instead (rapier rebuilds the persistent ones when their
//! `bootstrapped` flag is off) would renumber the active set, whose order is the solver's
//! order, and reset the split and sleep timers: a restored run would no longer equal the
//! uninterrupted one bit for bit. So what rapier wrote is kept and checked against the
//! invariants rapier's own structural validation (`PersistentIslands::assert_consistent`)
//! asserts, plus those of the active set.

use crate::error::SphError;
use rapier3d::dynamics::{RigidBody, RigidBodySet};
use rapier3d::geometry::ColliderSet;
use rapier3d::pipeline::PhysicsWorld;
use serde::{Deserialize, Serialize};

/// A body handle's arena index and generation.
type Handle = (u32, u32);

/// An index or island id rapier uses for "none".
const NONE: u32 = u32::MAX;

/// Parry's `VecMap<T>`: the number of entries, then a slot per key.
#[derive(Serialize, Deserialize, Debug)]
pub(crate) struct VecMap<T> {
    n: usize,
    v: Vec<Option<T>>,
}

impl<T> VecMap<T> {
    fn get(&self, k: usize) -> Option<&T> {
        self.v.get(k).and_then(Option::as_ref)
    }

    fn iter(&self) -> impl Iterator<Item = (usize, &T)> {
        self.v
            .iter()
            .enumerate()
            .filter_map(|(k, e)| e.as_ref().map(|e| (k, e)))
    }

    /// The count matches the entries, and every free id is a distinct empty slot.
    fn check<F: Copy + Into<u64>>(&self, free: &[F]) -> Result<(), Fault> {
        if self.iter().count() != self.n {
            return Err((self.n, "an island map's count is not its number of entries"));
        }
        let mut seen = vec![false; self.v.len()];
        for (k, &f) in free.iter().enumerate() {
            let f: u64 = f.into();
            let slot = usize::try_from(f).ok().filter(|&f| f < self.v.len());
            match slot {
                Some(f) if self.v[f].is_none() && !std::mem::replace(&mut seen[f], true) => {}
                _ => {
                    return Err((
                        k,
                        "a free island id is outside the map, in use or listed twice",
                    ));
                }
            }
        }
        Ok(())
    }
}

/// Rapier's `Island` (an active island: the awake set or a sleeping chunk).
#[derive(Serialize, Deserialize, Debug)]
pub(crate) struct Island {
    bodies: Vec<Handle>,
}

/// Rapier's `JointLinkKey`.
#[derive(Serialize, Deserialize, Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum JointLinkKey {
    Impulse(Handle),
    MultibodyChain { multibody: u64, ordinal: u32 },
    SoftAttachment { soft_body: u64, ordinal: u32 },
    SoftProxyChain { soft_body: u64, ordinal: u32 },
}

/// Rapier's `ContactLink`.
#[derive(Serialize, Deserialize, Debug)]
struct ContactLink {
    edge_id: u32,
    body1: Handle,
    body2: Handle,
}

/// Rapier's `JointLink`.
#[derive(Serialize, Deserialize, Debug)]
struct JointLink {
    key: JointLinkKey,
    body1: Handle,
    body2: Handle,
}

/// Rapier's `PersistentIsland`.
#[derive(Serialize, Deserialize, Debug)]
struct PersistentIsland {
    bodies: Vec<Handle>,
    contact_links: Vec<ContactLink>,
    joint_links: Vec<JointLink>,
    constraint_remove_count: u32,
    split_denied_until: u32,
    sleeping: bool,
}

/// Rapier's `PersistentIslands` as serialised (its workspaces are skipped).
#[derive(Serialize, Deserialize, Debug)]
struct Persistent {
    islands: VecMap<PersistentIsland>,
    free_islands: Vec<u32>,
    contact_link_locs: Vec<(u32, u32)>,
    joint_link_locs: Vec<(JointLinkKey, (u32, u32))>,
    removal_journal: Vec<(Handle, Handle)>,
    split_island: Option<u32>,
    sleep_scan_stamp: u32,
    bootstrapped: bool,
}

/// Rapier's `IslandManager` (0.36) as serialised: the active-set epoch, the active islands,
/// which one is awake, their free ids, and the persistent islands.
#[derive(Serialize, Deserialize, Debug)]
pub(crate) struct Islands {
    active_set_epoch: u32,
    islands: VecMap<Island>,
    awake_island: Option<usize>,
    free_islands: Vec<usize>,
    persistent: Persistent,
}

/// Rapier's `RigidBodyIds`: the first field of a serialised `RigidBody`.
#[derive(Serialize, Deserialize, Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct BodyIds {
    active_island_id: u32,
    active_set_id: u32,
    island_id: u32,
    island_index: u32,
}

/// What is wrong, and where.
type Fault = (usize, &'static str);

/// The error of a fault of `field`.
fn bad(field: &'static str, (at, reason): Fault) -> SphError {
    SphError::InvalidParameter {
        field,
        value: at as f64,
        reason,
    }
}

/// The mirror of rapier's island manager, read from its postcard encoding; `None` when the
/// layout is not the one mirrored.
pub(crate) fn mirror_islands(p: &PhysicsWorld) -> Option<(Islands, Vec<u8>)> {
    let bytes = postcard::to_allocvec(&p.islands).ok()?;
    match postcard::take_from_bytes(&bytes) {
        Ok((m, [])) => Some((m, bytes)),
        _ => None,
    }
}

/// The island manager's active-set epoch (the first field of its encoding), which rapier
/// bumps whenever a body's place in the awake set changes.
pub(crate) fn active_set_epoch(p: &PhysicsWorld) -> Option<u32> {
    let bytes = postcard::to_allocvec(&p.islands).ok()?;
    postcard::take_from_bytes::<u32>(&bytes)
        .ok()
        .map(|(epoch, _)| epoch)
}

/// A body's private ids, decoded from the front of its encoding.
pub(crate) fn body_ids(rb: &RigidBody) -> Option<BodyIds> {
    let bytes = postcard::to_allocvec(rb).ok()?;
    postcard::take_from_bytes(&bytes).ok().map(|(ids, _)| ids)
}

/// The bodies' generations and ids by arena index (`None` for an empty slot).
struct Bodies {
    ids: Vec<Option<(u32, BodyIds)>>,
}

impl Bodies {
    fn new(set: &RigidBodySet) -> Result<Self, Fault> {
        let mut ids = Vec::new();
        for (h, rb) in set.iter() {
            let (i, g) = h.into_raw_parts();
            let id = body_ids(rb).ok_or((
                i as usize,
                "a body's layout is not the one this build reads (rapier upgraded)",
            ))?;
            if ids.len() <= i as usize {
                ids.resize(i as usize + 1, None);
            }
            ids[i as usize] = Some((g, id));
        }
        Ok(Self { ids })
    }

    /// The ids of the body with this handle, if it is in the set.
    fn get(&self, (i, g): Handle) -> Option<BodyIds> {
        let (generation, ids) = self.ids.get(i as usize).copied().flatten()?;
        (generation == g).then_some(ids)
    }
}

/// Checks the island manager against the bodies (see the module docs).
///
/// # Errors
/// [`SphError::InvalidParameter`] with field `"islands"` (or `"bodies"`, for a body's ids or
/// colliders) naming the island, body or link concerned.
pub(crate) fn check_islands(p: &PhysicsWorld) -> Result<(), SphError> {
    let layout = (
        0,
        "the island manager's layout is not the one this build reads (rapier upgraded)",
    );
    let (m, _) = mirror_islands(p).ok_or(bad("islands", layout))?;
    let bodies = Bodies::new(&p.bodies).map_err(|f| bad("bodies", f))?;
    check_active(&m, &bodies).map_err(|f| bad("islands", f))?;
    check_persistent(&m, &bodies).map_err(|f| bad("islands", f))?;
    check_body_colliders(&p.bodies, &p.colliders).map_err(|f| bad("bodies", f))
}

/// The active islands: each body listed is a body of the set whose ids name that island and
/// that place; every body whose ids name an island is listed there; the
/// awake island and the free ids are consistent with the map.
fn check_active(m: &Islands, bodies: &Bodies) -> Result<(), Fault> {
    m.islands
        .check(&m.free_islands.iter().map(|&f| f as u64).collect::<Vec<_>>())?;
    if let Some(a) = m.awake_island
        && m.islands.get(a).is_none()
    {
        return Err((a, "the awake island is not in the island map"));
    }
    for (k, island) in m.islands.iter() {
        // The awake island may be empty: a step that puts two piles to sleep extracts each
        // as its own chunk and leaves the awake island without bodies.
        for (i, &h) in island.bodies.iter().enumerate() {
            let b = bodies
                .get(h)
                .ok_or((k, "an active island names a body that is not in the set"))?;
            if (b.active_island_id as usize, b.active_set_id as usize) != (k, i) {
                return Err((k, "a body's active ids do not name its place in its island"));
            }
        }
    }
    for (i, entry) in bodies.ids.iter().enumerate() {
        let Some((g, ids)) = entry else { continue };
        if ids.active_island_id == NONE && ids.active_set_id == NONE {
            continue;
        }
        let listed = m
            .islands
            .get(ids.active_island_id as usize)
            .and_then(|island| island.bodies.get(ids.active_set_id as usize));
        if listed != Some(&(i as u32, *g)) {
            return Err((i, "a body's active ids name a place it is not at"));
        }
    }
    Ok(())
}

/// The persistent islands, as far as rapier's `assert_consistent` checks structure: each
/// island's bodies bodies of the set whose ids name that island and place, and every body whose
/// ids name an island listed there; an awake island's bodies in the awake active island (a
/// sleep decision extracts them from it, asserting they are there); every link located where
/// the location tables say, with an end in its island, and every location naming a link; free
/// ids and the pending split naming free and existing islands. Rapier's checks of body kinds
/// (no fixed body in an island, every moving body in one) are left out: they hold only after a
/// step, and a game may save between a change and the step that applies it. Persistent
/// islands not yet built (`bootstrapped` off) are rebuilt by rapier from the graphs and are
/// not read.
fn check_persistent(m: &Islands, bodies: &Bodies) -> Result<(), Fault> {
    let p = &m.persistent;
    if !p.bootstrapped {
        return Ok(());
    }
    p.islands.check(&p.free_islands)?;
    if let Some(s) = p.split_island
        && p.islands.get(s as usize).is_none()
    {
        return Err((s as usize, "the pending split names no island"));
    }
    for (k, island) in p.islands.iter() {
        if island.bodies.is_empty() {
            return Err((k, "a persistent island without bodies"));
        }
        for (i, &h) in island.bodies.iter().enumerate() {
            let b = bodies
                .get(h)
                .ok_or((k, "a persistent island names a body that is not in the set"))?;
            if (b.island_id as usize, b.island_index as usize) != (k, i) {
                return Err((k, "a body's island ids do not name its place in its island"));
            }
            if !island.sleeping && m.awake_island != Some(b.active_island_id as usize) {
                return Err((k, "an awake island holds a body outside the awake set"));
            }
        }
    }
    for (i, entry) in bodies.ids.iter().enumerate() {
        let Some((g, ids)) = entry else { continue };
        if ids.island_id == NONE && ids.island_index == NONE {
            continue;
        }
        let listed = p
            .islands
            .get(ids.island_id as usize)
            .and_then(|island| island.bodies.get(ids.island_index as usize));
        if listed != Some(&(i as u32, *g)) {
            return Err((i, "a body's island ids name a place it is not at"));
        }
    }
    check_links(p, bodies)
}

/// The persistent islands' links and their location tables (see [`check_persistent`]).
fn check_links(p: &Persistent, bodies: &Bodies) -> Result<(), Fault> {
    let member = |k: usize, h: Handle| bodies.get(h).is_some_and(|b| b.island_id as usize == k);
    let mut contacts = 0;
    let mut joints = std::collections::BTreeMap::new();
    for (k, island) in p.islands.iter() {
        for (j, link) in island.contact_links.iter().enumerate() {
            let loc = p.contact_link_locs.get(link.edge_id as usize);
            if loc != Some(&(k as u32, j as u32)) {
                return Err((k, "a contact link's location is not where it is"));
            }
            if !member(k, link.body1) && !member(k, link.body2) {
                return Err((k, "a contact link has no end in its island"));
            }
            contacts += 1;
        }
        for (j, link) in island.joint_links.iter().enumerate() {
            if joints.insert(link.key, (k as u32, j as u32)).is_some() {
                return Err((k, "a joint link is listed twice"));
            }
            if !member(k, link.body1) && !member(k, link.body2) {
                return Err((k, "a joint link has no end in its island"));
            }
        }
    }
    let located = p
        .contact_link_locs
        .iter()
        .filter(|&&l| l != (NONE, NONE))
        .count();
    if located != contacts {
        return Err((located, "a contact location names no link"));
    }
    let listed: std::collections::BTreeMap<_, _> = p.joint_link_locs.iter().copied().collect();
    if listed.len() != p.joint_link_locs.len() || listed != joints {
        return Err((
            p.joint_link_locs.len(),
            "the joint link locations are not the joint links",
        ));
    }
    Ok(())
}

/// Each body's colliders are colliders of the set whose parent is that body, and each
/// collider with a parent is in its parent's list once.
fn check_body_colliders(bodies: &RigidBodySet, colliders: &ColliderSet) -> Result<(), Fault> {
    let mut listed = 0;
    for (k, (h, rb)) in bodies.iter().enumerate() {
        for &c in rb.colliders() {
            if colliders.get(c).and_then(|c| c.parent()) != Some(h) {
                return Err((k, "a body lists a collider that is not attached to it"));
            }
        }
        let mut own = rb.colliders().to_vec();
        own.sort_unstable_by_key(|c| c.into_raw_parts());
        own.dedup();
        if own.len() != rb.colliders().len() {
            return Err((k, "a body lists a collider twice"));
        }
        listed += own.len();
    }
    let attached = colliders
        .iter()
        .filter(|(_, c)| c.parent().is_some())
        .count();
    if attached != listed {
        return Err((attached, "a collider is not in its body's list"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Real, Vector};
    use rapier3d::dynamics::{RigidBodyType, SphericalJointBuilder};
    use rapier3d::prelude::{ColliderBuilder, RigidBodyBuilder};

    /// A world whose islands have seen contacts, a joint, sleep, wake-ups, removals, a body
    /// turned fixed and bodies added: boxes falling on a floor in two piles, two of them
    /// jointed; `look` sees it after every step and after every change.
    fn island_world(mut look: impl FnMut(&PhysicsWorld)) -> PhysicsWorld {
        let mut w = PhysicsWorld::new();
        w.insert_collider(ColliderBuilder::cuboid(10.0, 0.1, 10.0), None);
        let add = |w: &mut PhysicsWorld, i: usize| {
            let at = Vector::new(
                (i % 2) as Real * 4.0 - 2.0 + (i % 3) as Real * 0.01,
                0.3 + (i / 2) as Real * 0.25,
                0.0,
            );
            let b = w.insert_body(RigidBodyBuilder::dynamic().translation(at));
            w.insert_collider(ColliderBuilder::cuboid(0.1, 0.1, 0.1), Some(b));
            b
        };
        let bodies: Vec<_> = (0..12).map(|i| add(&mut w, i)).collect();
        let joint = SphericalJointBuilder::new().local_anchor2(Vector::new(0.0, -0.25, 0.0));
        w.impulse_joints.insert(bodies[0], bodies[2], joint, true);
        look(&w);
        for frame in 0..400 {
            w.step();
            look(&w);
            match frame {
                150 => {
                    w.remove_body(bodies[5]);
                    look(&w);
                }
                200 => {
                    w.bodies[bodies[7]].set_body_type(RigidBodyType::Fixed, true);
                    look(&w);
                }
                250 => {
                    add(&mut w, 12);
                    w.islands.wake_up(&mut w.bodies, bodies[1], true);
                    look(&w);
                }
                _ => {}
            }
        }
        w
    }

    /// The mirror reads rapier's island manager exactly (decoded and encoded again, the same
    /// bytes) and a real world's islands and bodies pass the checks after every step and
    /// every change of a busy run, through sleep: a rapier upgrade that changes the layout or
    /// the invariants fails here.
    #[test]
    fn the_mirror_round_trips_real_islands() {
        let (mut checked, mut slept, mut persistent) = (0, 0, 0);
        island_world(|w| {
            let (m, bytes) = mirror_islands(w).expect("the layout");
            assert_eq!(postcard::to_allocvec(&m).unwrap(), bytes);
            check_islands(w).unwrap();
            for (h, rb) in w.bodies.iter() {
                // The ids decoded from the front of a body's encoding are its own: the active
                // set's order is rapier's public `active_bodies`.
                let ids = body_ids(rb).unwrap();
                if let Some(at) = w.islands.active_bodies().position(|a| a == h) {
                    assert_eq!(ids.active_set_id as usize, at);
                    assert_eq!(Some(ids.active_island_id as usize), m.awake_island);
                }
            }
            slept += m
                .islands
                .iter()
                .filter(|(k, _)| Some(*k) != m.awake_island)
                .count();
            persistent += m.persistent.islands.n;
            checked += 1;
        });
        assert_eq!(checked, 404);
        assert!(
            slept > 0,
            "no island fell asleep: the sleeping paths were not checked"
        );
        assert!(persistent > 0);
    }

    /// Each fault the checks name, made in a real world's mirror, is refused.
    #[test]
    fn broken_islands_are_refused() {
        let w = island_world(|_| {});
        let (good, bytes) = mirror_islands(&w).unwrap();
        let bodies = Bodies::new(&w.bodies).unwrap();
        check_active(&good, &bodies).unwrap();
        check_persistent(&good, &bodies).unwrap();
        let refused = |edit: &dyn Fn(&mut Islands)| {
            let mut m: Islands = postcard::from_bytes(&bytes).unwrap();
            edit(&mut m);
            let a = check_active(&m, &bodies);
            let p = check_persistent(&m, &bodies);
            assert!(a.is_err() || p.is_err(), "not refused");
        };
        let (awake, _) = good
            .islands
            .iter()
            .find(|(_, i)| i.bodies.len() > 1)
            .expect("an active island of two bodies");
        let (pk, _) = good
            .persistent
            .islands
            .iter()
            .find(|(_, i)| i.bodies.len() > 1)
            .expect("a persistent island of two bodies");
        refused(&|m| m.islands.v[awake].as_mut().unwrap().bodies.swap(0, 1));
        refused(&|m| m.islands.v[awake].as_mut().unwrap().bodies.push((9999, 0)));
        refused(&|m| {
            m.islands.v[awake].as_mut().unwrap().bodies.pop();
        });
        refused(&|m| m.islands.n += 1);
        refused(&|m| m.awake_island = Some(m.islands.v.len()));
        refused(&|m| m.free_islands.push(awake));
        refused(&|m| {
            m.persistent.islands.v[pk]
                .as_mut()
                .unwrap()
                .bodies
                .reverse()
        });
        refused(&|m| {
            m.persistent.islands.v[pk].as_mut().unwrap().bodies.clear();
        });
        refused(&|m| m.persistent.split_island = Some(u32::MAX - 1));
        refused(&|m| m.persistent.free_islands.push(pk as u32));
        refused(&|m| m.persistent.contact_link_locs.push((0, 0)));
        refused(&|m| {
            let l = m
                .persistent
                .contact_link_locs
                .iter_mut()
                .find(|l| l.0 != NONE);
            l.expect("a contact link").1 += 1;
        });
        refused(&|m| {
            let l = m
                .persistent
                .joint_link_locs
                .first_mut()
                .expect("a joint link");
            l.1.1 += 1;
        });
    }

    /// A body's ids that do not name its place, or a collider list that does not match the
    /// colliders' parents, are refused in a real world.
    #[test]
    fn broken_bodies_are_refused() {
        let w = island_world(|_| {});
        let (m, _) = mirror_islands(&w).unwrap();
        let refused = |edit: &dyn Fn(&mut BodyIds) -> bool| {
            let mut bodies = Bodies::new(&w.bodies).unwrap();
            let edited = bodies.ids.iter_mut().flatten().any(|(_, ids)| edit(ids));
            assert!(edited, "no body to edit");
            let a = check_active(&m, &bodies);
            let p = check_persistent(&m, &bodies);
            assert!(a.is_err() || p.is_err(), "not refused");
        };
        refused(&|ids| {
            let inside = ids.active_island_id != NONE;
            ids.active_set_id = ids.active_set_id.wrapping_add(100) * inside as u32;
            inside
        });
        refused(&|ids| {
            let inside = ids.active_island_id != NONE;
            ids.active_island_id = ids.active_island_id.wrapping_add(inside as u32);
            inside
        });
        refused(&|ids| {
            let inside = ids.island_id != NONE;
            ids.island_index = ids.island_index.wrapping_add(inside as u32 * 7);
            inside
        });
        let mut colliders = w.colliders.clone();
        let mut set = w.bodies.clone();
        let (h, _) = set.iter().find(|(_, b)| !b.colliders().is_empty()).unwrap();
        let c = set[h].colliders()[0];
        colliders.set_parent(c, None, &mut set);
        // `set_parent` keeps both sides in step: still consistent.
        check_body_colliders(&set, &colliders).unwrap();
        // The old body set still lists the collider.
        assert!(check_body_colliders(&w.bodies, &colliders).is_err());
    }
}
