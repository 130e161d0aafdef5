//! Corrupted snapshots (proptest): loading never panics; a corrupted file is refused; a state
//! that loads steps without panic.
//!
//! Two kinds of corruption: random bytes changed, cut or added anywhere in a file (the
//! checksum refuses them), and random bytes changed in the fluids' part of the payload with
//! the header's length and checksum rewritten to match, as a file crafted to pass the checksum
//! would be (the decoder and the state's validation must then refuse it, or the state must
//! step). The same, resealed, in rapier's broad phase, its island manager and bodies, its
//! narrow phase's solver caches and multibodies' matrices, and anywhere in the payload:
//! loading's checks refuse it or the world steps.
//! `resealed_corruption_outcomes` (ignored; `PART=physics N=2000 cargo test --release
//! --features snapshot --test snapshot_fuzz -- --ignored --nocapture`, fixed seed; `PART` =
//! `fluids`, `physics`, `broad_phase`, `islands`, `bodies`, `joints`, `narrow_phase`,
//! `multibodies` or the whole payload when unset; `joints` corrupts the joint sets of the same
//! world with a rope, a hinged door and a multibody chain added; `narrow_phase` and
//! `multibodies` corrupt the narrow phase or the multibody set of that world with, beside the
//! tank, boxes resting on a floor, a sensor, force events and a multibody lying on it;
//! `PANICS=1` prints each panic, `PANICS=bt` with a backtrace) counts what resealed
//! corruptions do.
#![cfg(feature = "snapshot")]

use proptest::prelude::*;
use rapier_sph::math::Vector;
use rapier_sph::rapier3d::prelude::{ColliderBuilder, RigidBodyBuilder};
use rapier_sph::scenes::{DamBreakConfig, dam_break};
use rapier_sph::snapshot::{self, SnapshotError};
use rapier_sph::solver::{Clavet, Solver, Springs};
use rapier_sph::{Emitter, Fluid, FluidParamsBuilder, FluidWorld, Nozzle, Region, Sink};
use std::sync::OnceLock;

const HEADER: usize = 32;

/// A small world with every kind of state: a DFSPH dam break with a dynamic ball, an emitter,
/// a sink and a capacity, and a Clavet fluid with springs; stepped a few frames.
fn snapshot_bytes() -> &'static [u8] {
    static BYTES: OnceLock<Vec<u8>> = OnceLock::new();
    BYTES.get_or_init(|| world_bytes(false))
}

/// The same world with joints ([`add_joints`]).
fn joint_snapshot_bytes() -> &'static [u8] {
    static BYTES: OnceLock<Vec<u8>> = OnceLock::new();
    BYTES.get_or_init(|| world_bytes(true))
}

/// A rope of five balls on spherical impulse joints hanging from a fixed anchor into the
/// water, a door on a revolute impulse joint, and a multibody chain of three links.
fn add_joints(w: &mut FluidWorld) {
    use rapier_sph::rapier3d::prelude::{RevoluteJointBuilder, SphericalJointBuilder};
    let p = &mut w.physics;
    let ball = |p: &mut rapier_sph::rapier3d::prelude::PhysicsWorld, at: Vector, fixed: bool| {
        let b = if fixed {
            RigidBodyBuilder::fixed()
        } else {
            RigidBodyBuilder::dynamic()
        };
        let h = p.insert_body(b.translation(at));
        p.insert_collider(ColliderBuilder::ball(0.03).density(800.0), Some(h));
        h
    };
    let mut prev = ball(p, Vector::new(0.8, 0.6, 0.1), true);
    for k in 1..6 {
        let b = ball(p, Vector::new(0.8, 0.6 - 0.07 * k as f32, 0.1), false);
        let joint = SphericalJointBuilder::new()
            .local_anchor1(Vector::new(0.0, -0.035, 0.0))
            .local_anchor2(Vector::new(0.0, 0.035, 0.0));
        p.impulse_joints.insert(prev, b, joint, true);
        prev = b;
    }
    let post = ball(p, Vector::new(1.2, 0.3, 0.1), true);
    let door = p.insert_body(RigidBodyBuilder::dynamic().translation(Vector::new(1.35, 0.3, 0.1)));
    p.insert_collider(ColliderBuilder::cuboid(0.15, 0.1, 0.01), Some(door));
    let hinge = RevoluteJointBuilder::new(Vector::Y).local_anchor2(Vector::new(-0.15, 0.0, 0.0));
    p.impulse_joints.insert(post, door, hinge, true);
    let mut parent = ball(p, Vector::new(0.4, 0.7, 0.1), true);
    for k in 1..4 {
        let b = ball(p, Vector::new(0.4 + 0.08 * k as f32, 0.7, 0.1), false);
        let joint =
            RevoluteJointBuilder::new(Vector::Z).local_anchor2(Vector::new(-0.08, 0.0, 0.0));
        p.multibody_joints.insert(parent, b, joint, true).unwrap();
        parent = b;
    }
}

/// The joints' world with resting contacts, a sensor, contact-force events and a multibody
/// lying on a floor ([`add_resting`]), stepped until they rest: what the narrow phase keeps
/// for the solver (per-pair hints, the solver contact graph's buckets, the force-event list)
/// and the multibodies' matrices are all in use.
fn cache_snapshot_bytes() -> &'static [u8] {
    static BYTES: OnceLock<Vec<u8>> = OnceLock::new();
    BYTES.get_or_init(|| {
        let mut w = world(true);
        add_resting(&mut w);
        for _ in 0..40 {
            w.step().unwrap();
        }
        snapshot::to_bytes(&w).unwrap()
    })
}

/// Beside the tank, on a floor of its own: a stack of two boxes (a dynamic pair), a box with
/// contact-force events at threshold 0, a box inside a sensor, and a multibody chain of
/// three balls on revolute joints lying on the floor (its contacts are solved by the
/// generic path).
fn add_resting(w: &mut FluidWorld) {
    use rapier_sph::rapier3d::prelude::{ActiveEvents, RevoluteJointBuilder};
    let p = &mut w.physics;
    p.insert_collider(
        ColliderBuilder::cuboid(0.6, 0.05, 0.3).translation(Vector::new(-2.0, 0.0, 0.0)),
        None,
    );
    let cube = |p: &mut rapier_sph::rapier3d::prelude::PhysicsWorld, x: f32, y: f32| {
        let h = p.insert_body(RigidBodyBuilder::dynamic().translation(Vector::new(x, y, 0.0)));
        p.insert_collider(ColliderBuilder::cuboid(0.05, 0.05, 0.05), Some(h));
        h
    };
    cube(p, -2.4, 0.1);
    cube(p, -2.4, 0.2);
    let loud = p.insert_body(RigidBodyBuilder::dynamic().translation(Vector::new(-2.2, 0.1, 0.0)));
    p.insert_collider(
        ColliderBuilder::cuboid(0.05, 0.05, 0.05)
            .active_events(ActiveEvents::CONTACT_FORCE_EVENTS)
            .contact_force_event_threshold(0.0),
        Some(loud),
    );
    cube(p, -2.0, 0.1);
    p.insert_collider(
        ColliderBuilder::cuboid(0.1, 0.1, 0.1)
            .translation(Vector::new(-2.0, 0.1, 0.0))
            .sensor(true),
        None,
    );
    let root = p.insert_body(RigidBodyBuilder::fixed().translation(Vector::new(-1.8, 0.1, 0.0)));
    p.insert_collider(ColliderBuilder::ball(0.05), Some(root));
    let mut parent = root;
    for k in 1..4 {
        let b = p.insert_body(RigidBodyBuilder::dynamic().translation(Vector::new(
            -1.8 + 0.11 * k as f32,
            0.1,
            0.0,
        )));
        p.insert_collider(ColliderBuilder::ball(0.05), Some(b));
        let joint =
            RevoluteJointBuilder::new(Vector::Z).local_anchor2(Vector::new(-0.11, 0.0, 0.0));
        p.multibody_joints.insert(parent, b, joint, true).unwrap();
        parent = b;
    }
}

/// [`snapshot_bytes`]'s world, with joints or without.
fn world_bytes(joints: bool) -> Vec<u8> {
    let mut w = world(joints);
    for _ in 0..6 {
        w.step().unwrap();
    }
    snapshot::to_bytes(&w).unwrap()
}

/// [`snapshot_bytes`]'s world before it steps.
fn world(joints: bool) -> FluidWorld {
    {
        let params = FluidParamsBuilder::water(0.05).build().unwrap();
        let mut d = dam_break(&DamBreakConfig::tower(params, 0.4)).unwrap();
        let w = &mut d.world;
        let ball = w
            .physics
            .insert_body(RigidBodyBuilder::dynamic().translation(Vector::new(0.3, 0.4, 0.1)));
        w.physics
            .insert_collider(ColliderBuilder::ball(0.05).density(500.0), Some(ball));
        let f = &mut w.fluids[d.fluid];
        f.add_emitter(
            Emitter::new(
                Nozzle::Disk { radius: 0.05 },
                Vector::new(0.5, 0.4, 0.1),
                Vector::new(0.0, -1.0, 0.0),
                1.0,
                100.0,
            )
            .budget(40),
        )
        .unwrap();
        f.add_sink(Sink::new(Region::Ball {
            center: Vector::new(0.9, 0.0, 0.1),
            radius: 0.1,
        }))
        .unwrap();
        f.set_capacity(Some(2000)).unwrap();
        let clavet = FluidParamsBuilder::water(0.05)
            .solver(Solver::Clavet(Clavet {
                springs: Some(Springs::default()),
                ..Clavet::default()
            }))
            .build()
            .unwrap();
        let mut c = Fluid::new(clavet).unwrap();
        c.add_block(Vector::new(0.6, 0.1, 0.0), Vector::new(0.2, 0.2, 0.2))
            .unwrap();
        w.fluids.insert(c);
        w.physics.integration_parameters.dt = 1.0 / 120.0;
        if joints {
            add_joints(w);
        }
        d.world
    }
}

/// Where the fluids' part of the payload ends and rapier's world begins (the world is the
/// payload's last field).
fn fluid_end() -> usize {
    static END: OnceLock<usize> = OnceLock::new();
    *END.get_or_init(|| {
        let world = snapshot::from_bytes(snapshot_bytes()).unwrap();
        snapshot_bytes().len() - postcard::to_allocvec(&world.physics).unwrap().len()
    })
}

/// Where a part of rapier's world lies in the file: its own encoding, found once after the
/// fluids.
fn span_of(part: Vec<u8>) -> (usize, usize) {
    let bytes = snapshot_bytes();
    let mut at =
        (fluid_end()..=bytes.len() - part.len()).filter(|&i| bytes[i..].starts_with(&part));
    let start = at.next().expect("the part's bytes are in the file");
    assert!(at.next().is_none(), "found twice");
    (start, start + part.len())
}

/// Where rapier's broad phase (its tree, pairs and counters) lies in the file.
fn broad_phase_span() -> (usize, usize) {
    static SPAN: OnceLock<(usize, usize)> = OnceLock::new();
    *SPAN.get_or_init(|| {
        let world = snapshot::from_bytes(snapshot_bytes()).unwrap();
        span_of(postcard::to_allocvec(&world.physics.broad_phase).unwrap())
    })
}

/// Where rapier's island manager (active and persistent islands) lies in the file.
fn islands_span() -> (usize, usize) {
    static SPAN: OnceLock<(usize, usize)> = OnceLock::new();
    *SPAN.get_or_init(|| {
        let world = snapshot::from_bytes(snapshot_bytes()).unwrap();
        span_of(postcard::to_allocvec(&world.physics.islands).unwrap())
    })
}

/// Where rapier's bodies lie in the file.
fn bodies_span() -> (usize, usize) {
    static SPAN: OnceLock<(usize, usize)> = OnceLock::new();
    *SPAN.get_or_init(|| {
        let world = snapshot::from_bytes(snapshot_bytes()).unwrap();
        span_of(postcard::to_allocvec(&world.physics.bodies).unwrap())
    })
}

/// Where rapier's two joint sets (impulse and multibody joints, one after the other) lie in
/// [`joint_snapshot_bytes`].
fn joints_span() -> (usize, usize) {
    static SPAN: OnceLock<(usize, usize)> = OnceLock::new();
    *SPAN.get_or_init(|| {
        let bytes = joint_snapshot_bytes();
        let world = snapshot::from_bytes(bytes).unwrap();
        let mut part = postcard::to_allocvec(&world.physics.impulse_joints).unwrap();
        part.extend(postcard::to_allocvec(&world.physics.multibody_joints).unwrap());
        let mut at = (HEADER..=bytes.len() - part.len()).filter(|&i| bytes[i..].starts_with(&part));
        let start = at.next().expect("the joints' bytes are in the file");
        assert!(at.next().is_none(), "found twice");
        (start, start + part.len())
    })
}

/// Where a part of rapier's world lies in [`cache_snapshot_bytes`]: its own encoding, found
/// once.
fn cache_span_of(part: Vec<u8>) -> (usize, usize) {
    let bytes = cache_snapshot_bytes();
    let mut at = (HEADER..=bytes.len() - part.len()).filter(|&i| bytes[i..].starts_with(&part));
    let start = at.next().expect("the part's bytes are in the file");
    assert!(at.next().is_none(), "found twice");
    (start, start + part.len())
}

/// Where the narrow phase (its graphs, the collider → node map and the solver's caches)
/// lies in [`cache_snapshot_bytes`].
fn narrow_phase_span() -> (usize, usize) {
    static SPAN: OnceLock<(usize, usize)> = OnceLock::new();
    *SPAN.get_or_init(|| {
        let world = snapshot::from_bytes(cache_snapshot_bytes()).unwrap();
        cache_span_of(postcard::to_allocvec(&world.physics.narrow_phase).unwrap())
    })
}

/// Where the multibody joint set (its multibodies' links, vectors, matrices and
/// workspaces) lies in [`cache_snapshot_bytes`].
fn multibodies_span() -> (usize, usize) {
    static SPAN: OnceLock<(usize, usize)> = OnceLock::new();
    *SPAN.get_or_init(|| {
        let world = snapshot::from_bytes(cache_snapshot_bytes()).unwrap();
        cache_span_of(postcard::to_allocvec(&world.physics.multibody_joints).unwrap())
    })
}

/// Rewrites the header's payload length and CRC-32 to match the payload.
fn reseal(bytes: &mut [u8]) {
    let length = (bytes.len() - HEADER) as u64;
    let crc = crc32(&bytes[HEADER..]);
    bytes[20..28].copy_from_slice(&length.to_le_bytes());
    bytes[28..32].copy_from_slice(&crc.to_le_bytes());
}

fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// An edit of a byte string.
#[derive(Clone, Debug)]
enum Edit {
    /// Set the byte at this fraction of the length.
    Set(f64, u8),
    /// Flip one bit.
    Flip(f64, u8),
    /// Cut everything after.
    Truncate(f64),
    /// Remove a run of bytes.
    Remove(f64, usize),
    /// Insert bytes.
    Insert(f64, Vec<u8>),
}

fn edit() -> impl Strategy<Value = Edit> {
    let at = 0.0..1.0f64;
    prop_oneof![
        4 => (at.clone(), any::<u8>()).prop_map(|(a, b)| Edit::Set(a, b)),
        4 => (at.clone(), 0..8u8).prop_map(|(a, b)| Edit::Flip(a, b)),
        1 => at.clone().prop_map(Edit::Truncate),
        1 => (at.clone(), 1..16usize).prop_map(|(a, n)| Edit::Remove(a, n)),
        1 => (at, prop::collection::vec(any::<u8>(), 1..16)).prop_map(|(a, v)| Edit::Insert(a, v)),
    ]
}

/// Applies `edits` to the bytes from `from` on.
fn apply(bytes: &mut Vec<u8>, from: usize, edits: &[Edit]) {
    for e in edits {
        let span = bytes.len().saturating_sub(from).max(1);
        let pos = |f: f64| (from + (f * span as f64) as usize).min(bytes.len().saturating_sub(1));
        match e {
            Edit::Set(a, b) => {
                let i = pos(*a);
                if let Some(x) = bytes.get_mut(i) {
                    *x = *b;
                }
            }
            Edit::Flip(a, bit) => {
                let i = pos(*a);
                if let Some(x) = bytes.get_mut(i) {
                    *x ^= 1 << bit;
                }
            }
            Edit::Truncate(a) => {
                let i = pos(*a);
                bytes.truncate(i);
            }
            Edit::Remove(a, n) => {
                let i = pos(*a);
                let end = (i + n).min(bytes.len());
                bytes.drain(i..end);
            }
            Edit::Insert(a, v) => {
                let i = pos(*a).min(bytes.len());
                bytes.splice(i..i, v.iter().copied());
            }
        }
    }
}

/// Loads `bytes`; when a world comes back, steps it two frames (which must not panic).
fn load_and_step(bytes: &[u8]) -> Result<(), SnapshotError> {
    let mut world: FluidWorld = snapshot::from_bytes(bytes)?;
    for _ in 0..2 {
        // A typed error from the step (e.g. rapier's broad-phase) is an answer, not a panic.
        if world.step().is_err() {
            break;
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Random edits anywhere in the file: always refused (by the tag, the version, the length
    /// or the checksum), unless the edits left the file as it was.
    #[test]
    fn corrupted_files_are_refused(edits in prop::collection::vec(edit(), 1..4)) {
        let original = snapshot_bytes();
        let mut bytes = original.to_vec();
        apply(&mut bytes, 0, &edits);
        let result = load_and_step(&bytes);
        if bytes == original {
            prop_assert!(result.is_ok());
        } else {
            prop_assert!(result.is_err(), "a corrupted file loaded: {edits:?}");
        }
    }

    /// Random bytes changed in the fluids' part of the payload, the header rewritten to
    /// match (as a file crafted to pass the checksum): the decoder or the state's validation
    /// refuses it, or the state steps without panic. (Rapier's part is restored as rapier
    /// wrote it: see `resealed_corruption_outcomes` for what corrupting it does.)
    #[test]
    fn resealed_fluid_corruptions_never_panic(
        edits in prop::collection::vec(edit(), 1..4)
            .prop_map(|v| v.into_iter().filter(|e| matches!(e, Edit::Set(..) | Edit::Flip(..))).collect::<Vec<_>>())
    ) {
        let joints = std::env::var("PART").as_deref() == Ok("joints");
        let mut bytes = if joints {
            joint_snapshot_bytes()
        } else {
            snapshot_bytes()
        }
        .to_vec();
        let mut tail = bytes.split_off(fluid_end());
        apply(&mut bytes, HEADER, &edits);
        bytes.append(&mut tail);
        reseal(&mut bytes);
        let _ = load_and_step(&bytes);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..ProptestConfig::default() })]

    /// Random bytes changed in rapier's broad phase (its tree of colliders' boxes, its
    /// pairs), the header rewritten to match: loading refuses it with a typed error, or the
    /// world steps without panic. Parry indexes its tree without checks, so this holds only
    /// because loading checks every index of the tree.
    #[test]
    fn resealed_broad_phase_corruptions_never_panic(
        edits in prop::collection::vec(edit(), 1..4)
            .prop_map(|v| v.into_iter().filter(|e| matches!(e, Edit::Set(..) | Edit::Flip(..))).collect::<Vec<_>>())
    ) {
        let (start, end) = broad_phase_span();
        let joints = std::env::var("PART").as_deref() == Ok("joints");
        let mut bytes = if joints {
            joint_snapshot_bytes()
        } else {
            snapshot_bytes()
        }
        .to_vec();
        let mut tail = bytes.split_off(end);
        apply(&mut bytes, start, &edits);
        bytes.append(&mut tail);
        reseal(&mut bytes);
        let _ = load_and_step(&bytes);
    }
}

/// Random bytes changed in `from..to` of the file, the header rewritten to match.
fn resealed(from: usize, to: usize, edits: &[Edit]) -> Vec<u8> {
    resealed_in(snapshot_bytes(), from, to, edits)
}

/// [`resealed`] in another file.
fn resealed_in(base: &[u8], from: usize, to: usize, edits: &[Edit]) -> Vec<u8> {
    let mut bytes = base.to_vec();
    let mut tail = bytes.split_off(to);
    apply(&mut bytes, from, edits);
    bytes.append(&mut tail);
    reseal(&mut bytes);
    bytes
}

/// Byte edits only (no cuts or insertions), as a crafted file keeps its layout.
fn byte_edits() -> impl Strategy<Value = Vec<Edit>> {
    prop::collection::vec(edit(), 1..4).prop_map(|v| {
        v.into_iter()
            .filter(|e| matches!(e, Edit::Set(..) | Edit::Flip(..)))
            .collect::<Vec<_>>()
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Random edits (changed, cut or inserted bytes) anywhere in the payload, the header
    /// rewritten to match: loading refuses the file with a typed error, or the world steps
    /// without panic. This holds only because loading checks what rapier and parry index
    /// without checks (trees, islands, bodies' ids and colliders).
    #[test]
    fn resealed_payload_corruptions_never_panic(edits in prop::collection::vec(edit(), 1..4)) {
        let _ = load_and_step(&resealed(HEADER, snapshot_bytes().len(), &edits));
    }

    /// Random bytes changed in rapier's island manager or bodies, the header rewritten to
    /// match: refused, or the world steps without panic.
    #[test]
    fn resealed_island_and_body_corruptions_never_panic(edits in byte_edits(), bodies in any::<bool>()) {
        let (from, to) = if bodies { bodies_span() } else { islands_span() };
        let _ = load_and_step(&resealed(from, to, &edits));
    }

    /// Random bytes changed in rapier's joint sets (a rope, a hinged door, a multibody chain),
    /// the header rewritten to match: refused, or the world steps without panic.
    #[test]
    fn resealed_joint_corruptions_never_panic(edits in byte_edits()) {
        let (from, to) = joints_span();
        let _ = load_and_step(&resealed_in(joint_snapshot_bytes(), from, to, &edits));
    }

    /// Random bytes changed in the narrow phase (its graphs and what it keeps for the solver:
    /// hints, the solver contact graph, the force-event list, manifolds' solver contacts) or
    /// in the multibody set (its multibodies' vectors, matrices and workspaces) of a world
    /// with resting contacts, a sensor, force events and a multibody on a floor, the header
    /// rewritten to match: refused, or the world steps without panic.
    #[test]
    fn resealed_solver_cache_corruptions_never_panic(edits in byte_edits(), multibodies in any::<bool>()) {
        let (from, to) = if multibodies { multibodies_span() } else { narrow_phase_span() };
        let _ = load_and_step(&resealed_in(cache_snapshot_bytes(), from, to, &edits));
    }
}

/// A resealed file whose dynamic body's place in the active set is outside it (rapier's
/// solver would index its arrays out of bounds in the first step) is refused, naming the
/// island manager.
#[test]
fn a_body_outside_the_active_set_is_refused() {
    let world = snapshot::from_bytes(snapshot_bytes()).unwrap();
    let (_, ball) = world
        .physics
        .bodies
        .iter()
        .find(|(_, b)| b.is_dynamic())
        .expect("the ball");
    let (start, _) = span_of(postcard::to_allocvec(ball).unwrap());
    let mut bytes = snapshot_bytes().to_vec();
    // The body's ids lead its encoding: its active island, then its place in it (one byte
    // each in a world this small).
    assert!(bytes[start] < 128 && bytes[start + 1] < 128);
    bytes[start + 1] = 113;
    reseal(&mut bytes);
    match snapshot::from_bytes(&bytes) {
        Err(SnapshotError::Invalid(rapier_sph::SphError::InvalidParameter { field, .. })) => {
            assert_eq!(field, "islands");
        }
        other => panic!("expected a refused body, got {:?}", other.map(|_| ())),
    }
}

/// A resealed file whose solver contact names a point its manifold does not have (rapier's
/// solver would read and write the point out of bounds in the first step) is refused, naming
/// the narrow phase.
#[test]
fn a_solver_contact_past_its_points_is_refused() {
    let world = snapshot::from_bytes(cache_snapshot_bytes()).unwrap();
    let (m, c) = world
        .physics
        .narrow_phase
        .contact_pairs()
        .filter_map(|p| p.rigid())
        .flat_map(|r| &r.manifolds)
        .find_map(|m| m.data.solver_contacts.first().map(|c| (m, c)))
        .expect("a manifold with solver contacts");
    // A solver contact's encoding: anchors, distance, tangent velocity, then its point's
    // index (a varint, with the "new contact" bit 31 kept so its length stays) and padding.
    let contact = postcard::to_allocvec(c).unwrap();
    let front = postcard::to_allocvec(&(c.anchor1, c.anchor2, c.dist, c.tangent_velocity)).unwrap();
    assert!(contact.starts_with(&front));
    let id = postcard::to_allocvec(&c.contact_id).unwrap();
    let past = [(c.contact_id[0] & (1 << 31)) | m.points.len() as u32];
    let past = postcard::to_allocvec(&past).unwrap();
    assert_eq!(id.len(), past.len());
    let mut bytes = cache_snapshot_bytes().to_vec();
    let at = bytes
        .windows(contact.len())
        .position(|w| w == contact.as_slice())
        .expect("the solver contact is in the file")
        + front.len();
    bytes[at..at + id.len()].copy_from_slice(&past);
    reseal(&mut bytes);
    match snapshot::from_bytes(&bytes) {
        Err(SnapshotError::Invalid(rapier_sph::SphError::InvalidParameter {
            field,
            reason,
            ..
        })) => {
            assert_eq!(field, "narrow_phase");
            assert!(reason.contains("solver contact"), "{reason}");
        }
        other => panic!(
            "expected a refused solver contact, got {:?}",
            other.map(|_| ())
        ),
    }
}

/// The world before corruption loads and steps, with joints and without.
#[test]
fn the_fuzzed_snapshot_loads() {
    load_and_step(snapshot_bytes()).unwrap();
    load_and_step(joint_snapshot_bytes()).unwrap();
    load_and_step(cache_snapshot_bytes()).unwrap();
}

/// Counts the outcomes of many resealed corruptions (prints; `--ignored --nocapture`).
#[test]
#[ignore = "a measurement, not a check: prints the outcomes of many resealed corruptions (run with --ignored --nocapture)"]
fn resealed_corruption_outcomes() {
    use rand::{Rng, SeedableRng};
    let n: usize = std::env::var("N").map_or(20_000, |v| v.parse().unwrap());
    let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
    let (mut encoding, mut invalid, mut ok, mut panics) = (0, 0, 0, 0);
    let mut reasons = std::collections::BTreeMap::<String, usize>::new();
    std::panic::set_hook(Box::new(|info| match std::env::var("PANICS").as_deref() {
        Ok("bt") => eprintln!(
            "PANIC {info}\n{}",
            std::backtrace::Backtrace::force_capture()
        ),
        Ok(_) => eprintln!("PANIC {info}"),
        Err(_) => {}
    }));
    for _ in 0..n {
        let part = std::env::var("PART");
        let mut bytes = match part.as_deref() {
            Ok("joints") => joint_snapshot_bytes(),
            Ok("narrow_phase" | "multibodies") => cache_snapshot_bytes(),
            _ => snapshot_bytes(),
        }
        .to_vec();
        let edits: Vec<Edit> = (0..rng.random_range(1..4))
            .map(|_| {
                let a = rng.random::<f64>();
                match rng.random_range(0..11) {
                    0..4 => Edit::Set(a, rng.random()),
                    4..8 => Edit::Flip(a, rng.random_range(0..8)),
                    8 => Edit::Truncate(a),
                    9 => Edit::Remove(a, rng.random_range(1..16)),
                    _ => Edit::Insert(a, vec![rng.random(); rng.random_range(1..16)]),
                }
            })
            .collect();
        let (from, to) = match std::env::var("PART").as_deref() {
            Ok("fluids") => (HEADER, fluid_end()),
            Ok("physics") => (fluid_end(), snapshot_bytes().len()),
            Ok("broad_phase") => broad_phase_span(),
            Ok("islands") => islands_span(),
            Ok("bodies") => bodies_span(),
            Ok("joints") => joints_span(),
            Ok("narrow_phase") => narrow_phase_span(),
            Ok("multibodies") => multibodies_span(),
            _ => (HEADER, snapshot_bytes().len()),
        };
        let mut tail = bytes.split_off(to);
        apply(&mut bytes, from, &edits);
        bytes.append(&mut tail);
        reseal(&mut bytes);
        if std::env::var("TRACE").is_ok() {
            eprintln!("{edits:?}");
        }
        match std::panic::catch_unwind(|| load_and_step(&bytes)) {
            Ok(Ok(())) => ok += 1,
            Ok(Err(SnapshotError::Invalid(e))) => {
                invalid += 1;
                *reasons.entry(e.to_string()).or_default() += 1;
            }
            Ok(Err(_)) => encoding += 1,
            Err(_) => panics += 1,
        }
    }
    let _ = std::panic::take_hook();
    println!(
        "{n} resealed corruptions: {encoding} not decodable, {invalid} invalid, {ok} loaded and stepped, {panics} panicked"
    );
    for (r, c) in reasons {
        println!("  {c:6}  {r}");
    }
}

/// A resealed file whose triangle mesh names a vertex it does not have is refused at load
/// (parry would index out of bounds in the first contact query), naming the collider.
#[test]
fn a_mesh_index_outside_its_vertices_is_refused() {
    use rapier_sph::rapier3d::parry::shape::TriMesh;
    let vertices = vec![
        Vector::new(0.0, 0.0, 0.0),
        Vector::new(1.0, 0.0, 0.0),
        Vector::new(0.0, 0.0, 1.0),
        Vector::new(1.0, 0.0, 1.0),
    ];
    let indices = vec![[0, 1, 2], [1, 3, 2]];
    let mesh = TriMesh::new(vertices.clone(), indices.clone()).unwrap();
    let mut world = FluidWorld::new();
    world
        .physics
        .insert_collider(ColliderBuilder::trimesh(vertices, indices).unwrap(), None);
    let mut bytes = snapshot::to_bytes(&world).unwrap();
    snapshot::from_bytes(&bytes).unwrap();
    // The mesh's vertices and indices as postcard writes them: the vertex count and twelve
    // floats, then the triangle count (2) and six one-byte indices.
    let vertices = postcard::to_allocvec(mesh.vertices()).unwrap();
    let both = postcard::to_allocvec(&(mesh.vertices(), mesh.indices())).unwrap();
    let at = bytes
        .windows(both.len())
        .position(|w| w == both.as_slice())
        .expect("the mesh's vertices and indices are in the file");
    let last = at + vertices.len() + 1 + 5; // the last triangle's third vertex
    assert_eq!(bytes[last], 2);
    bytes[last] = 100; // of 4
    reseal(&mut bytes);
    match snapshot::from_bytes(&bytes) {
        Err(SnapshotError::Invalid(rapier_sph::SphError::InvalidParameter {
            field,
            reason,
            ..
        })) => {
            assert_eq!(field, "colliders");
            assert!(reason.contains("vertex index"), "{reason}");
        }
        other => panic!("expected a refused mesh, got {:?}", other.map(|_| ())),
    }
}
