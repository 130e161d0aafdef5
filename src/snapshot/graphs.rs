//! Checks of the narrow phase's two interaction graphs (contacts, intersections) as a snapshot
//! restores them: their nodes' and edges' private list links and the collider → node map.
//!
//! Rapier's graph (a petgraph-style adjacency list with `prev` links for O(1) unlinking)
//! follows `next`, `prev` and endpoint indices without checks when it removes edges and
//! nodes, and the narrow phase's collider → node map (`graph_indices`) names the node a
//! collider's removal takes out (a node whose collider has no entry there reaches an
//! `unreachable!`). The links are private; nodes and edges are public and serialisable, so a
//! node's links are decoded from its encoding (its collider handle, then `next`) and an
//! edge's from the end of its encoding (`next`, `prev`, endpoints after its weight, whose own
//! encoding gives the offset). The map is the narrow phase's third field, after the two graphs
//! whose encodings give its offset.

use crate::error::SphError;
use rapier3d::geometry::{ColliderSet, NarrowPhase};
use serde::{Deserialize, Serialize};

/// Rapier's `u32` for "no index".
const END: u32 = u32::MAX;

/// A collider handle's arena index and generation.
type Handle = (u32, u32);

/// Rapier's `Node<ColliderHandle>`: its collider, then the heads of its outgoing and incoming
/// edge lists.
#[derive(Serialize, Deserialize, Debug, Clone, Copy)]
pub(crate) struct Node {
    pub(crate) weight: Handle,
    next: [u32; 2],
}

/// The links after an `Edge`'s weight: next and previous edge in its source's outgoing and its
/// target's incoming list, and its source and target nodes.
#[derive(Serialize, Deserialize, Debug, Clone, Copy)]
pub(crate) struct EdgeLinks {
    next: [u32; 2],
    prev: [u32; 2],
    pub(crate) node: [u32; 2],
}

/// A graph's links (for a graph whose edges carry no weight, its whole encoding).
#[derive(Serialize, Deserialize, Debug, Clone)]
pub(crate) struct Graph {
    pub(crate) nodes: Vec<Node>,
    pub(crate) edges: Vec<EdgeLinks>,
}

/// What is wrong, and where.
pub(crate) type Fault = (usize, &'static str);

const LAYOUT: Fault = (
    0,
    "the narrow phase's layout is not the one this build reads (rapier upgraded)",
);

/// The links of a rapier interaction graph, read from its nodes' and edges' encodings (its
/// nodes' weights are arena handles: colliders', or bodies' in the joint sets' graphs).
pub(crate) fn mirror_graph<N: Serialize + Copy, E: Serialize>(
    g: &rapier3d::geometry::InteractionGraph<N, E>,
) -> Result<Graph, Fault> {
    let raw = g.raw_graph();
    let nodes = raw
        .raw_nodes()
        .iter()
        .map(|n| {
            let bytes = postcard::to_allocvec(n).ok()?;
            match postcard::take_from_bytes::<Node>(&bytes) {
                Ok((node, [])) => Some(node),
                _ => None,
            }
        })
        .collect::<Option<Vec<_>>>()
        .ok_or(LAYOUT)?;
    let edges = raw
        .raw_edges()
        .iter()
        .map(|e| {
            let bytes = postcard::to_allocvec(e).ok()?;
            let weight = postcard::to_allocvec(&e.weight).ok()?;
            let tail = bytes.get(weight.len()..)?;
            match postcard::take_from_bytes::<EdgeLinks>(tail) {
                Ok((links, []))
                    if [links.node[0], links.node[1]]
                        == [e.source().index() as u32, e.target().index() as u32] =>
                {
                    Some(links)
                }
                _ => None,
            }
        })
        .collect::<Option<Vec<_>>>()
        .ok_or(LAYOUT)?;
    Ok(Graph { nodes, edges })
}

/// Every node's outgoing and incoming list well formed: each link inside the edge array,
/// each edge in exactly one list per direction (its source's outgoing, its target's
/// incoming), its `prev` the edge before it (none for a list's head), no cycle.
pub(crate) fn check_graph(g: &Graph) -> Result<(), Fault> {
    let (nn, ne) = (g.nodes.len(), g.edges.len());
    if let Some(k) = g
        .edges
        .iter()
        .position(|e| e.node.iter().any(|&n| n as usize >= nn))
    {
        return Err((k, "an edge's endpoint is outside the node array"));
    }
    for dir in 0..2 {
        let mut seen = vec![false; ne];
        let mut count = 0;
        for (n, node) in g.nodes.iter().enumerate() {
            let (mut prev, mut e) = (END, node.next[dir]);
            while e != END {
                let edge = g
                    .edges
                    .get(e as usize)
                    .ok_or((n, "an edge list links outside the edge array"))?;
                if std::mem::replace(&mut seen[e as usize], true) {
                    return Err((
                        e as usize,
                        "an edge is linked twice (a cycle or shared list)",
                    ));
                }
                if edge.node[dir] as usize != n || edge.prev[dir] != prev {
                    return Err((
                        e as usize,
                        "an edge's endpoint or back link is not its list's",
                    ));
                }
                count += 1;
                (prev, e) = (e, edge.next[dir]);
            }
        }
        if count != ne {
            return Err((count, "an edge is in no list of its endpoint"));
        }
    }
    Ok(())
}

/// Each node's collider, when it is a collider of the set, maps back to that node (`which`:
/// 0 the contact graph's index, 1 the intersection graph's); every collider of the set that
/// the map gives a node is that node's collider.
fn check_map(
    g: &Graph,
    map: &[(u32, (u32, u32))],
    which: usize,
    colliders: &ColliderSet,
) -> Result<(), Fault> {
    let index = |e: &(u32, (u32, u32))| if which == 0 { e.1.0 } else { e.1.1 };
    let live = |(i, gen_): Handle| {
        colliders
            .get_unknown_gen(i)
            .is_some_and(|(_, h)| h.into_raw_parts() == (i, gen_))
    };
    for (k, node) in g.nodes.iter().enumerate() {
        let (i, gen_) = node.weight;
        let entry = map.get(i as usize).filter(|e| e.0 == gen_);
        if entry.map(index) != Some(k as u32) {
            return Err((k, "a graph node's collider does not map to it"));
        }
    }
    for (i, e) in map.iter().enumerate() {
        let k = index(e);
        if k != END
            && live((i as u32, e.0))
            && g.nodes.get(k as usize).map(|n| n.weight) != Some((i as u32, e.0))
        {
            return Err((i, "a collider maps to a graph node that is not its own"));
        }
    }
    Ok(())
}

/// Checks both interaction graphs and the collider → node map (see the module docs).
///
/// # Errors
/// [`SphError::InvalidParameter`] with field `"narrow_phase"`, the node, edge or collider
/// index concerned and the fault.
pub(crate) fn check_narrow_phase(
    np: &NarrowPhase,
    colliders: &ColliderSet,
) -> Result<(), SphError> {
    check(np, colliders).map_err(|(at, reason)| SphError::InvalidParameter {
        field: "narrow_phase",
        value: at as f64,
        reason,
    })
}

fn check(np: &NarrowPhase, colliders: &ColliderSet) -> Result<(), Fault> {
    let contacts = mirror_graph(np.contact_graph())?;
    let intersections = mirror_graph(np.intersection_graph())?;
    check_graph(&contacts)?;
    check_graph(&intersections)?;
    let map = graph_indices(np).ok_or(LAYOUT)?;
    check_map(&contacts, &map, 0, colliders)?;
    check_map(&intersections, &map, 1, colliders)
}

/// The narrow phase's collider → node map (rapier's `Coarena<ColliderGraphIndices>`: per
/// collider slot, the generation and the two graphs' node indices), decoded after the two
/// graphs in the narrow phase's encoding.
pub(crate) fn graph_indices(np: &NarrowPhase) -> Option<Vec<(u32, (u32, u32))>> {
    let all = postcard::to_allocvec(np).ok()?;
    let contacts = postcard::to_allocvec(np.contact_graph()).ok()?;
    let intersections = postcard::to_allocvec(np.intersection_graph()).ok()?;
    let rest = all.strip_prefix(contacts.as_slice())?;
    let rest = rest.strip_prefix(intersections.as_slice())?;
    postcard::take_from_bytes(rest).ok().map(|(map, _)| map)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Real, Vector};
    use rapier3d::prelude::{ColliderBuilder, PhysicsWorld, RigidBodyBuilder};

    /// A world whose graphs have seen pairs found and lost, sensors, and colliders removed
    /// (nodes swap-removed): balls falling through a sensor onto a floor; `look` sees it
    /// after every step and every change.
    fn graph_world(mut look: impl FnMut(&PhysicsWorld)) {
        let mut w = PhysicsWorld::new();
        w.insert_collider(ColliderBuilder::cuboid(4.0, 0.1, 4.0), None);
        w.insert_collider(
            ColliderBuilder::cuboid(4.0, 0.3, 4.0)
                .translation(Vector::new(0.0, 1.0, 0.0))
                .sensor(true),
            None,
        );
        let mut balls = Vec::new();
        for i in 0..30 {
            let at = Vector::new(
                (i % 6) as Real * 0.25 - 0.6,
                1.5 + (i / 6) as Real * 0.3,
                0.0,
            );
            let b = w.insert_body(RigidBodyBuilder::dynamic().translation(at));
            balls.push(w.insert_collider(ColliderBuilder::ball(0.1), Some(b)));
        }
        for frame in 0..150 {
            w.step();
            look(&w);
            if frame % 30 == 29 {
                for h in balls.drain(..5) {
                    w.remove_collider(h);
                }
                look(&w);
            }
        }
    }

    /// The links read from a real world's graphs are the graphs' own (a node's and an edge's
    /// re-encoded links equal the encoding; edges' endpoints rapier's), and they pass the
    /// checks after every step and change of a busy run; the collider → node map is found.
    #[test]
    fn the_mirror_reads_real_graphs() {
        let (mut checked, mut edges, mut sensors) = (0, 0, 0);
        graph_world(|w| {
            let np = &w.narrow_phase;
            for e in np.contact_graph().raw_graph().raw_edges() {
                let bytes = postcard::to_allocvec(e).unwrap();
                let weight = postcard::to_allocvec(&e.weight).unwrap().len();
                let (links, _): (EdgeLinks, _) =
                    postcard::take_from_bytes(&bytes[weight..]).unwrap();
                assert_eq!(postcard::to_allocvec(&links).unwrap(), bytes[weight..]);
            }
            check(np, &w.colliders).unwrap();
            edges += np.contact_graph().raw_graph().raw_edges().len();
            sensors += np.intersection_graph().raw_graph().raw_edges().len();
            // Nodes are made with a collider's first pair: the map covers those colliders.
            let nodes = np.contact_graph().raw_graph().raw_nodes();
            let map = graph_indices(np).unwrap();
            assert!(
                nodes
                    .iter()
                    .all(|n| (n.weight.into_raw_parts().0 as usize) < map.len())
            );
            checked += 1;
        });
        assert_eq!(checked, 155);
        assert!(
            edges > 0 && sensors > 0,
            "{edges} contacts, {sensors} intersections"
        );
    }

    /// Each fault the checks name, made in a real graph's links, is refused.
    #[test]
    fn broken_graphs_are_refused() {
        let mut last = None;
        graph_world(|w| last = Some(mirror_graph(w.narrow_phase.contact_graph()).unwrap()));
        let good = last.unwrap();
        assert!(good.edges.len() > 2);
        check_graph(&good).unwrap();
        let refused = |edit: &dyn Fn(&mut Graph)| {
            let mut g = Graph {
                nodes: good.nodes.clone(),
                edges: good.edges.clone(),
            };
            edit(&mut g);
            check_graph(&g).unwrap_err()
        };
        refused(&|g| g.edges[0].node[0] = g.nodes.len() as u32);
        refused(&|g| g.edges[0].prev[1] ^= 1);
        refused(&|g| g.edges[1].next[0] = g.edges.len() as u32);
        refused(&|g| g.edges.push(g.edges[0]));
        refused(&|g| {
            let head = g.nodes.iter().position(|n| n.next[0] != END).unwrap();
            let first = g.nodes[head].next[0];
            g.edges[first as usize].next[0] = first;
        });
        refused(&|g| {
            let head = g.nodes.iter().position(|n| n.next[1] != END).unwrap();
            g.nodes[head].next[1] = END;
        });
    }

    /// A collider → node map naming another node, or a stale generation, is refused.
    #[test]
    fn a_wrong_collider_map_is_refused() {
        let mut last = None;
        graph_world(|w| {
            let np = &w.narrow_phase;
            let g = mirror_graph(np.contact_graph()).unwrap();
            last = Some((g, graph_indices(np).unwrap(), w.colliders.clone()));
        });
        let (g, map, colliders) = last.unwrap();
        check_map(&g, &map, 0, &colliders).unwrap();
        let k = g.nodes[0].weight.0 as usize;
        let mut other = map.clone();
        other[k].1.0 = (other[k].1.0 + 1) % g.nodes.len() as u32;
        assert!(check_map(&g, &other, 0, &colliders).is_err());
        let mut stale = map.clone();
        stale[k].0 += 1;
        assert!(check_map(&g, &stale, 0, &colliders).is_err());
    }
}
