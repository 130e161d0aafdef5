//! Stage 8: contact with the colliders of a rapier `ColliderSet`, through parry queries.
//!
//! 1. **Candidates** ([`candidates`]): for every occupied grid cell, the box swept by its
//!    particles during the step (grown by the contact radius) is looked up in rapier's
//!    broad-phase BVH. Only colliders found there are tested, never a loop over all
//!    colliders; cells far from every collider get an empty list and cost nothing more.
//! 2. **Resolution** ([`contact`]): every particle with candidates has its motion of the step
//!    swept (a ray cast) against them, so it cannot cross a surface however thin or fast;
//!    then it is pushed to one contact radius off any surface it came closer to. The normal
//!    velocity is reflected with the restitution, the tangential velocity reduced by Coulomb
//!    friction. A final sweep from the start of the step verifies the new position; if it
//!    fails, the particle stays where it started (counted as a fallback).
//!
//! Works for every parry shape: cuboid, ball, capsule, cylinder, cone, convex polyhedron,
//! triangle mesh (open or closed, either face), heightfield and compound. Sensors are
//! ignored; the fluid's collision groups are respected.

pub(crate) mod adhesion;
pub mod bodies;
pub mod candidates;
pub mod contact;
pub mod forces;
pub mod teleport;
pub mod wall;

pub use bodies::Coupling;
pub use candidates::ContactWorkspace;
pub use wall::WallWorkspace;
