//! Checks of the joint sets as a snapshot restores them: the impulse joints' graph, its
//! handle → edge arena and body → node map, and the multibody joints' multibodies, their
//! body → link map and connectivity graph.
//!
//! What rapier 0.36 follows without checks, and so what a file crafted to pass the checksum
//! could make panic or loop:
//! - `ImpulseJointSet`: the joint graph's list links (as the narrow phase's, see the `graphs`
//!   module); the solver's `bodies[joint.body1]`; `joint_ids` (an `Arena` of edge indices:
//!   `remove` and `set_bodies` write `joint_ids[edge.handle]` for the edge swapped into a
//!   removed one's slot, `remove_joints_attached_to_rigid_body` unwraps `joint_ids.remove`);
//!   `rb_graph_ids` (the node a body's removal takes out); the arena's free list (the next
//!   insertion follows it: `panic!("corrupt free list")` on an occupied slot, an index out of
//!   range, or an endless insertion on a cycle is not possible there, but a shared slot is).
//! - `MultibodyJointSet`: `multibodies[link.multibody]` (`iter`, the solver) for every body
//!   the `rb2mb` map names, `mb.link(id).unwrap()`, each link's parent (`links[parent]`), each
//!   link's degrees of freedom inside the multibody's vectors (`assembly_id..assembly_id +
//!   ndofs`), the connectivity graph (as above), and the multibodies' arena free list.
//!
//! The sets' fields are private; as for the islands and trees, they are read through mirrors
//! of their serde layout (the set encoded again and decoded into [`ImpulseJoints`] and
//! [`MultibodyJoints`]), pinned by tests that decode real worlds' sets and re-encode them
//! byte for byte.

use super::graphs::{self, Fault, Graph};
use rapier3d::dynamics::{ImpulseJointSet, Multibody, MultibodyJointSet, RigidBodySet};
use serde::{Deserialize, Serialize};

/// An arena handle's index and generation.
type Handle = (u32, u32);

/// Rapier's `u32` for "no index".
const NONE: u32 = u32::MAX;

const LAYOUT: Fault = (
    0,
    "the joint sets' layout is not the one this build reads (rapier upgraded)",
);

/// Rapier's arena entry.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub(crate) enum Entry<T> {
    Free { next_free: Option<u32> },
    Occupied { generation: u32, value: T },
}

/// Rapier's `Arena<T>`: entries, the generation, the free list's head, the occupied count.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub(crate) struct Arena<T> {
    items: Vec<Entry<T>>,
    generation: u32,
    free_list_head: Option<u32>,
    len: usize,
}

impl<T> Arena<T> {
    /// The occupied entries: index, generation, value.
    fn occupied(&self) -> impl Iterator<Item = (usize, u32, &T)> {
        self.items.iter().enumerate().filter_map(|(i, e)| match e {
            Entry::Occupied { generation, value } => Some((i, *generation, value)),
            Entry::Free { .. } => None,
        })
    }

    /// The value at a handle (index and generation), if occupied with that generation.
    fn get(&self, (i, generation): Handle) -> Option<&T> {
        match self.items.get(i as usize) {
            Some(Entry::Occupied {
                generation: g,
                value,
            }) if *g == generation => Some(value),
            _ => None,
        }
    }

    /// The count is the occupied entries', and the free list runs from its head through
    /// every free entry once, inside the array, and ends.
    pub(crate) fn check(&self) -> Result<(), Fault> {
        if self.occupied().count() != self.len {
            return Err((self.len, "an arena's count is not its number of entries"));
        }
        let mut seen = vec![false; self.items.len()];
        let (mut at, mut free) = (self.free_list_head, 0);
        while let Some(i) = at {
            let first = seen
                .get_mut(i as usize)
                .is_some_and(|s| !std::mem::replace(s, true));
            match self.items.get(i as usize) {
                Some(Entry::Free { next_free }) if first => {
                    at = *next_free;
                    free += 1;
                }
                _ => {
                    return Err((
                        i as usize,
                        "an arena's free list leaves the array, names an entry in use or loops",
                    ));
                }
            }
        }
        if free + self.len != self.items.len() {
            return Err((free, "an arena's free entry is not on its free list"));
        }
        Ok(())
    }
}

/// The front of rapier's `ImpulseJointSet` encoding: the body → node map (`Coarena`: per
/// body slot, a generation and a node index) and the joint handle → edge arena.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub(crate) struct ImpulseFront {
    rb_graph_ids: Vec<(u32, u32)>,
    joint_ids: Arena<u32>,
}

/// The end of both joint sets' encodings: bodies to wake and pairs to join next step.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub(crate) struct Pending {
    to_wake_up: Vec<Handle>,
    to_join: Vec<(Handle, Handle)>,
}

/// The impulse joints: the front, the graph's links, each edge's joint (its handle and
/// bodies), the pending sets.
pub(crate) struct ImpulseJoints {
    front: ImpulseFront,
    graph: Graph,
    /// Per edge: the joint's handle, `body1`, `body2`.
    joints: Vec<[Handle; 3]>,
}

/// Reads an `ImpulseJointSet` through the mirror. `None`: the layout is not the mirror's.
pub(crate) fn mirror_impulse(set: &ImpulseJointSet) -> Option<ImpulseJoints> {
    let all = postcard::to_allocvec(set).ok()?;
    let (front, rest) = postcard::take_from_bytes::<ImpulseFront>(&all).ok()?;
    let graph_bytes = postcard::to_allocvec(set.joint_graph()).ok()?;
    let rest = rest.strip_prefix(graph_bytes.as_slice())?;
    match postcard::take_from_bytes::<Pending>(rest) {
        Ok((_, [])) => {}
        _ => return None,
    }
    let graph = graphs::mirror_graph(set.joint_graph()).ok()?;
    let joints = set
        .iter()
        .map(|(h, j)| {
            [
                h.0.into_raw_parts(),
                j.body1().0.into_raw_parts(),
                j.body2().0.into_raw_parts(),
            ]
        })
        .collect();
    Some(ImpulseJoints {
        front,
        graph,
        joints,
    })
}

/// The graph well formed; each joint's bodies its edge's endpoints' and bodies of the set;
/// its handle an entry of the arena naming its edge, and each arena entry an edge naming it;
/// each node's body mapping to that node, and each body the map gives a node that node's.
pub(crate) fn check_impulse(j: &ImpulseJoints, bodies: &RigidBodySet) -> Result<(), Fault> {
    graphs::check_graph(&j.graph)?;
    j.front.joint_ids.check()?;
    let nodes = &j.graph.nodes;
    for (e, (links, &[handle, b1, b2])) in j.graph.edges.iter().zip(&j.joints).enumerate() {
        if [
            nodes[links.node[0] as usize].weight,
            nodes[links.node[1] as usize].weight,
        ] != [b1, b2]
        {
            return Err((e, "a joint's bodies are not its graph edge's endpoints"));
        }
        let live = |(i, g): Handle| {
            bodies
                .get_unknown_gen(i)
                .is_some_and(|(_, h)| h.0.into_raw_parts() == (i, g))
        };
        if !live(b1) || !live(b2) {
            return Err((e, "a joint names a body that is not in the set"));
        }
        if j.front.joint_ids.get(handle) != Some(&(e as u32)) {
            return Err((e, "a joint's handle does not map to its edge"));
        }
    }
    for (i, generation, &e) in j.front.joint_ids.occupied() {
        if j.joints.get(e as usize).map(|j| j[0]) != Some((i as u32, generation)) {
            return Err((i, "a joint handle maps to an edge that is not its joint"));
        }
    }
    check_body_map(&j.graph, &j.front.rb_graph_ids, |&(g, k)| (g, k))
}

/// Each node's body maps to that node in `map` (per body slot: generation and node index,
/// read by `entry`), and every valid index the map holds is a node of that body.
fn check_body_map<T>(g: &Graph, map: &[T], entry: impl Fn(&T) -> (u32, u32)) -> Result<(), Fault> {
    for (k, node) in g.nodes.iter().enumerate() {
        let (i, generation) = node.weight;
        if map.get(i as usize).map(&entry) != Some((generation, k as u32)) {
            return Err((k, "a joint graph node's body does not map to it"));
        }
    }
    for (i, e) in map.iter().enumerate() {
        let (generation, k) = entry(e);
        if k != NONE && g.nodes.get(k as usize).map(|n| n.weight) != Some((i as u32, generation)) {
            return Err((i, "a body maps to a joint graph node that is not its own"));
        }
    }
    Ok(())
}

/// Rapier's `MultibodyLinkId`: the body's node in the connectivity graph, its multibody, its
/// link in it.
#[derive(Serialize, Deserialize, Debug, Clone, Copy)]
pub(crate) struct LinkId {
    graph_id: u32,
    multibody: Handle,
    id: usize,
}

/// Rapier's `MultibodyJointSet`, all of it.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub(crate) struct MultibodyJoints {
    multibodies: Arena<Multibody>,
    rb2mb: Vec<(u32, LinkId)>,
    graph: Graph,
    pending: Pending,
    topology_epoch: u32,
}

/// Reads a `MultibodyJointSet` through the mirror. `None`: the layout is not the mirror's.
pub(crate) fn mirror_multibody(set: &MultibodyJointSet) -> Option<MultibodyJoints> {
    let all = postcard::to_allocvec(set).ok()?;
    match postcard::take_from_bytes::<MultibodyJoints>(&all) {
        Ok((m, [])) => Some(m),
        _ => None,
    }
}

/// The multibody set's topology epoch (the last field of its encoding), which rapier bumps
/// whenever a body joins or leaves a multibody.
pub(crate) fn topology_epoch(set: &MultibodyJointSet) -> Option<u32> {
    mirror_multibody(set).map(|m| m.topology_epoch)
}

/// The arena and the graph well formed; every body the map names (with its generation, a
/// body of the set) is a link of a multibody of the arena, that link's body, at its graph
/// node; each multibody's links well formed ([`check_links`]), each link's body mapping back
/// to it, and every link but the root dynamic (rapier asserts it in every step).
pub(crate) fn check_multibody(m: &MultibodyJoints, bodies: &RigidBodySet) -> Result<(), Fault> {
    m.multibodies.check()?;
    graphs::check_graph(&m.graph)?;
    check_body_map(&m.graph, &m.rb2mb, |(g, l)| (*g, l.graph_id))?;
    for (i, (generation, link)) in m.rb2mb.iter().enumerate() {
        if *generation == NONE {
            continue;
        }
        let body = (i as u32, *generation);
        let named = m
            .multibodies
            .get(link.multibody)
            .and_then(|mb| mb.link(link.id))
            .map(|l| l.rigid_body_handle().0.into_raw_parts());
        if named != Some(body) {
            return Err((i, "a body maps to a multibody link that is not its own"));
        }
    }
    for (k, generation, mb) in m.multibodies.occupied() {
        check_links(mb).map_err(|reason| (k, reason))?;
        super::multibodies::check(mb).map_err(|(_, reason)| (k, reason))?;
        for l in mb.links() {
            let (i, g) = l.rigid_body_handle().0.into_raw_parts();
            let back = m.rb2mb.get(i as usize).filter(|e| e.0 == g).map(|e| e.1);
            if back.map(|b| (b.multibody, b.id)) != Some(((k as u32, generation), l.link_id())) {
                return Err((k, "a multibody link's body does not map to it"));
            }
            let Some((body, _)) = bodies
                .get_unknown_gen(i)
                .filter(|(_, h)| h.0.into_raw_parts() == (i, g))
            else {
                return Err((k, "a multibody link names a body that is not in the set"));
            };
            // Rapier asserts it in every step (`Multibody::update_body_jacobians`).
            if !l.is_root() && !body.is_dynamic() {
                return Err((
                    k,
                    "a multibody link that is not its root has a body that is not dynamic",
                ));
            }
        }
    }
    Ok(())
}

/// A multibody's links and couplings: at least the root; each link's id its place, its parent an earlier
/// link, its degrees of freedom the next ones of the multibody's vectors (`assembly_id` the
/// sum of the earlier links'), which sum to the multibody's `ndofs`; each coupling's two
/// degrees of freedom among its links'.
fn check_links(mb: &Multibody) -> Result<(), &'static str> {
    if mb.num_links() == 0 {
        return Err("a multibody has no link");
    }
    let mut dofs = 0;
    for (k, l) in mb.links().enumerate() {
        if l.link_id() != k || l.parent_id().is_some_and(|p| p >= k) {
            return Err("a multibody link's id or parent is out of order");
        }
        if l.assembly_id() != dofs {
            return Err("a multibody link's degrees of freedom are not the next ones");
        }
        dofs += l.joint().ndofs();
    }
    // The vectors' lengths are the matrices' check's (`super::multibodies`): the public
    // views of two of them slice them to `ndofs` rows and would panic on shorter ones.
    if mb.ndofs() != dofs {
        return Err("a multibody's degrees of freedom are not its links'");
    }
    let dof_of = |link: usize, dof: usize, axis: usize| {
        mb.link(link)
            .is_some_and(|l| dof < l.joint().ndofs() && axis < 6)
    };
    if mb
        .couplings()
        .iter()
        .any(|c| !dof_of(c.link1, c.dof1, c.axis1) || !dof_of(c.link2, c.dof2, c.axis2))
    {
        return Err("a multibody's coupling names a degree of freedom it does not have");
    }
    Ok(())
}

/// The body and collider sets' arenas (the first field of each set's encoding): their counts
/// and free lists ([`Arena::check`]), which the next `insert` follows (rapier's
/// `try_alloc_next_index` indexes the slot the list names and panics on one in use).
///
/// # Errors
/// [`crate::SphError::InvalidParameter`] with field `"bodies"` or `"colliders"`.
pub(crate) fn check_set_arenas(
    p: &rapier3d::pipeline::PhysicsWorld,
) -> Result<(), crate::SphError> {
    fn front<T: serde::de::DeserializeOwned>(set: &impl Serialize) -> Result<(), Fault> {
        let all = postcard::to_allocvec(set).map_err(|_| LAYOUT)?;
        let (arena, _) = postcard::take_from_bytes::<Arena<T>>(&all).map_err(|_| LAYOUT)?;
        arena.check()
    }
    let fault = |field| {
        move |(at, reason): Fault| crate::SphError::InvalidParameter {
            field,
            value: at as f64,
            reason,
        }
    };
    front::<rapier3d::dynamics::RigidBody>(&p.bodies).map_err(fault("bodies"))?;
    front::<rapier3d::geometry::Collider>(&p.colliders).map_err(fault("colliders"))
}

/// Checks both joint sets (see the module docs).
///
/// # Errors
/// [`crate::SphError::InvalidParameter`] with field `"impulse_joints"` or
/// `"multibody_joints"`, the index concerned and the fault.
pub(crate) fn check_joints(p: &rapier3d::pipeline::PhysicsWorld) -> Result<(), crate::SphError> {
    let fault = |field| {
        move |(at, reason): Fault| crate::SphError::InvalidParameter {
            field,
            value: at as f64,
            reason,
        }
    };
    mirror_impulse(&p.impulse_joints)
        .ok_or(LAYOUT)
        .and_then(|j| check_impulse(&j, &p.bodies))
        .map_err(fault("impulse_joints"))?;
    mirror_multibody(&p.multibody_joints)
        .ok_or(LAYOUT)
        .and_then(|m| check_multibody(&m, &p.bodies))
        .map_err(fault("multibody_joints"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Real, Vector};
    use rapier3d::prelude::{
        ColliderBuilder, PhysicsWorld, RevoluteJointBuilder, RigidBodyBuilder, RigidBodyHandle,
        SphericalJointBuilder,
    };

    /// A world with ropes of balls on impulse joints, a door on a hinge, and a multibody
    /// chain, where joints, bodies and whole multibodies are removed as it runs (edges and
    /// nodes swap-removed, arena slots freed and reused); `look` sees it after every step and
    /// every change.
    fn joint_world(mut look: impl FnMut(&PhysicsWorld)) {
        let mut w = PhysicsWorld::new();
        w.insert_collider(ColliderBuilder::cuboid(4.0, 0.1, 4.0), None);
        let link = |w: &mut PhysicsWorld, at: Vector, fixed: bool| -> RigidBodyHandle {
            let b = if fixed {
                RigidBodyBuilder::fixed()
            } else {
                RigidBodyBuilder::dynamic()
            };
            let h = w.insert_body(b.translation(at));
            w.insert_collider(ColliderBuilder::ball(0.05), Some(h));
            h
        };
        let mut ropes = Vec::new();
        for r in 0..3 {
            let mut prev = link(&mut w, Vector::new(r as Real, 2.0, 0.0), true);
            for k in 1..6 {
                let b = link(
                    &mut w,
                    Vector::new(r as Real, 2.0 - 0.15 * k as Real, 0.0),
                    false,
                );
                let joint = SphericalJointBuilder::new()
                    .local_anchor1(Vector::new(0.0, -0.075, 0.0))
                    .local_anchor2(Vector::new(0.0, 0.075, 0.0));
                ropes.push(w.impulse_joints.insert(prev, b, joint, true));
                prev = b;
            }
        }
        let post = link(&mut w, Vector::new(-1.0, 1.0, 0.0), true);
        let door =
            w.insert_body(RigidBodyBuilder::dynamic().translation(Vector::new(-0.6, 1.0, 0.0)));
        w.insert_collider(ColliderBuilder::cuboid(0.4, 0.5, 0.02), Some(door));
        let hinge = RevoluteJointBuilder::new(Vector::Y).local_anchor2(Vector::new(-0.4, 0.0, 0.0));
        w.impulse_joints.insert(post, door, hinge, true);
        let mut chain = vec![link(&mut w, Vector::new(0.0, 3.0, 1.0), true)];
        for k in 1..5 {
            let b = link(&mut w, Vector::new(0.2 * k as Real, 3.0, 1.0), false);
            let joint =
                RevoluteJointBuilder::new(Vector::Z).local_anchor2(Vector::new(-0.2, 0.0, 0.0));
            w.multibody_joints
                .insert(chain[k - 1], b, joint, true)
                .unwrap();
            chain.push(b);
        }
        look(&w);
        for frame in 0..120 {
            w.step();
            look(&w);
            match frame {
                30 => {
                    // A joint in the middle of the first rope.
                    w.impulse_joints.remove(ropes[2], true);
                }
                50 => {
                    // A body in the middle of the second rope: its two joints and its node.
                    let (b1, b2) = {
                        let j = w.impulse_joints.get(ropes[7]).unwrap();
                        (j.body1(), j.body2())
                    };
                    w.remove_body(b2);
                    let _ = b1;
                }
                70 => {
                    // A multibody link in the middle: the chain splits in two multibodies.
                    w.remove_body(chain[2]);
                }
                90 => {
                    // New joints into the freed slots.
                    let a = link(&mut w, Vector::new(2.0, 1.0, 2.0), false);
                    let b = link(&mut w, Vector::new(2.0, 0.8, 2.0), false);
                    w.impulse_joints
                        .insert(a, b, SphericalJointBuilder::new(), true);
                    w.multibody_joints
                        .insert(chain[3], a, SphericalJointBuilder::new(), true);
                }
                _ => continue,
            }
            look(&w);
        }
    }

    /// The mirrors read real sets whole (re-encoded byte for byte) and the sets pass the
    /// checks after every step and change.
    #[test]
    fn the_mirrors_read_real_joint_sets() {
        let (mut checked, mut joints, mut links) = (0, 0, 0);
        joint_world(|w| {
            let j = mirror_impulse(&w.impulse_joints).expect("impulse joints' layout");
            let front = postcard::to_allocvec(&j.front).unwrap();
            let all = postcard::to_allocvec(&w.impulse_joints).unwrap();
            assert!(all.starts_with(&front));
            check_impulse(&j, &w.bodies).unwrap();
            let m = mirror_multibody(&w.multibody_joints).expect("multibody joints' layout");
            assert_eq!(
                postcard::to_allocvec(&m).unwrap(),
                postcard::to_allocvec(&w.multibody_joints).unwrap()
            );
            check_multibody(&m, &w.bodies).unwrap();
            joints += j.joints.len();
            links += m.rb2mb.iter().filter(|e| e.0 != NONE).count();
            checked += 1;
        });
        assert_eq!(checked, 125);
        assert!(joints > 0 && links > 0, "{joints} joints, {links} links");
    }

    /// The last state of [`joint_world`], mirrored.
    fn last() -> (ImpulseJoints, MultibodyJoints, RigidBodySet) {
        let mut out = None;
        joint_world(|w| {
            out = Some((
                mirror_impulse(&w.impulse_joints).unwrap(),
                mirror_multibody(&w.multibody_joints).unwrap(),
                w.bodies.clone(),
            ))
        });
        out.unwrap()
    }

    /// Each fault the impulse joints' checks name, made in a real set, is refused.
    #[test]
    fn broken_impulse_joints_are_refused() {
        let (good, _, bodies) = last();
        check_impulse(&good, &bodies).unwrap();
        let refused = |edit: &dyn Fn(&mut ImpulseJoints)| {
            let mut j = ImpulseJoints {
                front: good.front.clone(),
                graph: good.graph.clone(),
                joints: good.joints.clone(),
            };
            edit(&mut j);
            check_impulse(&j, &bodies).unwrap_err()
        };
        // A joint's handle naming another edge; an arena entry naming an edge out of range.
        refused(&|j| j.joints.swap(0, 1));
        refused(&|j| {
            let (i, _, _) = j.front.joint_ids.occupied().next().unwrap();
            if let Entry::Occupied { value, .. } = &mut j.front.joint_ids.items[i] {
                *value = u32::MAX - 1;
            }
        });
        // The free list: looping, through an occupied slot, missing a free slot.
        refused(&|j| {
            let head = j.front.joint_ids.free_list_head.unwrap();
            j.front.joint_ids.items[head as usize] = Entry::Free {
                next_free: Some(head),
            };
        });
        refused(&|j| {
            let (i, _, _) = j.front.joint_ids.occupied().next().unwrap();
            j.front.joint_ids.free_list_head = Some(i as u32);
        });
        refused(&|j| j.front.joint_ids.free_list_head = None);
        refused(&|j| j.front.joint_ids.len += 1);
        // A body → node map naming another node; a joint's body not its edge's endpoint.
        refused(&|j| {
            let i = j.graph.nodes[0].weight.0 as usize;
            j.front.rb_graph_ids[i].1 = 1;
        });
        refused(&|j| j.joints[0][1] = j.joints[0][2]);
        // A graph link out of range.
        refused(&|j| j.graph.edges[0].node[0] = j.graph.nodes.len() as u32);
    }

    /// The body and collider arenas of a world with removed bodies pass; a free list naming
    /// an occupied slot is refused.
    #[test]
    fn set_arenas_are_checked() {
        let mut last = None;
        joint_world(|w| {
            check_set_arenas(w).unwrap();
            last = Some(w.bodies.clone());
        });
        let bodies = last.unwrap();
        let all = postcard::to_allocvec(&bodies).unwrap();
        let (mut arena, rest) =
            postcard::take_from_bytes::<Arena<rapier3d::dynamics::RigidBody>>(&all).unwrap();
        let mut again = postcard::to_allocvec(&arena).unwrap();
        again.extend_from_slice(rest);
        assert_eq!(again, all, "the arena's mirror re-encodes the set");
        assert!(arena.free_list_head.is_some(), "bodies were removed");
        arena.check().unwrap();
        let used = arena.occupied().next().map(|(i, _, _)| i as u32);
        arena.free_list_head = used;
        assert!(arena.check().is_err());
    }

    /// Each fault the multibody checks name, made in a real set, is refused.
    #[test]
    fn broken_multibodies_are_refused() {
        let (_, good, bodies) = last();
        check_multibody(&good, &bodies).unwrap();
        let refused = |edit: &dyn Fn(&mut MultibodyJoints)| {
            let mut m = good.clone();
            edit(&mut m);
            check_multibody(&m, &bodies).unwrap_err()
        };
        let linked = good
            .rb2mb
            .iter()
            .position(|e| e.0 != NONE && e.1.id > 0)
            .unwrap();
        refused(&|m| m.rb2mb[linked].1.id = 1000);
        refused(&|m| m.rb2mb[linked].1.multibody.0 = 1000);
        refused(&|m| m.rb2mb[linked].1.graph_id = NONE - 1);
        refused(&|m| m.multibodies.len += 1);
        refused(&|m| m.graph.edges[0].node[1] = NONE);
        // A link's body made fixed: rapier's step would assert.
        let (i, g) = good
            .multibodies
            .occupied()
            .next()
            .unwrap()
            .2
            .links()
            .nth(1)
            .unwrap()
            .rigid_body_handle()
            .0
            .into_raw_parts();
        let mut fixed = bodies.clone();
        let (_, h) = fixed.get_unknown_gen(i).unwrap();
        assert_eq!(h.0.into_raw_parts(), (i, g));
        fixed[h].set_body_type(rapier3d::dynamics::RigidBodyType::Fixed, false);
        assert!(check_multibody(&good, &fixed).is_err());
    }
}
