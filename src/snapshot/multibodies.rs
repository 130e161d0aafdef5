//! Checks of each multibody's vectors, matrices and workspaces against its links and degrees
//! of freedom, as a snapshot restores them.
//!
//! Rapier 0.36 serialises a `Multibody` whole, its workspaces included, and sizes some of them
//! again from the degrees of freedom in each step but not all:
//! - `update_body_jacobians` and `update_acceleration` index `body_jacobians[i]` and
//!   `workspace.accs[i]` for every link (only a body Jacobian's column count is resized);
//! - `update_mass_matrix` reallocates `augmented_mass` and `acc_augmented_mass` together when
//!   the first does not have `ndofs` columns, and the Coriolis workspaces (`coriolis_v`,
//!   `coriolis_w`, `i_coriolis_dt`) together when `coriolis_v` does not have a matrix per link
//!   with `ndofs` columns, the first one read: otherwise it uses all of them as they are;
//! - the generalised velocities, accelerations, damping, armature and friction vectors are
//!   read as `ndofs` long, and the public views of two of them (`generalized_velocity`)
//!   slice them to `ndofs` rows, panicking when they are shorter.
//!
//! The workspace's `ndofs_vec` is never read (and not resized when a root's type changes its
//! degrees of freedom). The LU factorisations are recomputed from the mass matrices before every use, and
//! `solver_id` is assigned by each step before it is read; they need no check. The fields are
//! private: each multibody is encoded again and decoded into [`MultibodyMatrices`], all of it,
//! a mirror pinned by re-encoding a real multibody byte for byte. Nalgebra's decoder already
//! refuses a matrix whose entries are not its rows times its columns.

use super::graphs::Fault;
use rapier3d::dynamics::{Multibody, MultibodyDofCoupling, MultibodyLink, RigidBodyVelocity};
use rapier3d::na::{DMatrix, DVector, Dyn, LU, Matrix3xX, Matrix6xX};
use serde::{Deserialize, Serialize};

type Real = rapier3d::math::Real;

/// Rapier's `Multibody` (3D), as serialised.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub(crate) struct MultibodyMatrices {
    links: Vec<MultibodyLink>,
    velocities: DVector<Real>,
    damping: DVector<Real>,
    armature: DVector<Real>,
    frictions: DVector<Real>,
    accelerations: DVector<Real>,
    body_jacobians: Vec<Matrix6xX<Real>>,
    augmented_mass: DMatrix<Real>,
    inv_augmented_mass: LU<Real, Dyn, Dyn>,
    augmented_mass_indices: (u32, Vec<usize>),
    acc_augmented_mass: DMatrix<Real>,
    acc_inv_augmented_mass: LU<Real, Dyn, Dyn>,
    ndofs: usize,
    root_is_dynamic: bool,
    solver_id: u32,
    self_contacts_enabled: bool,
    couplings: Vec<MultibodyDofCoupling>,
    workspace_accs: Vec<RigidBodyVelocity<Real>>,
    workspace_ndofs: DVector<Real>,
    coriolis_v: Vec<Matrix3xX<Real>>,
    coriolis_w: Vec<Matrix3xX<Real>>,
    i_coriolis_dt: Matrix6xX<Real>,
}

/// Reads a multibody through the mirror. `None`: the layout is not the mirror's.
pub(crate) fn mirror(mb: &Multibody) -> Option<MultibodyMatrices> {
    let bytes = postcard::to_allocvec(mb).ok()?;
    match postcard::take_from_bytes::<MultibodyMatrices>(&bytes) {
        Ok((m, [])) => Some(m),
        _ => None,
    }
}

/// The sizes rapier does not set again before reading them (see the module docs), for a
/// multibody whose links' degrees of freedom sum to its `ndofs` (checked before).
pub(crate) fn check_sizes(m: &MultibodyMatrices) -> Result<(), &'static str> {
    let (n, d) = (m.links.len(), m.ndofs);
    let vectors = [
        &m.velocities,
        &m.damping,
        &m.armature,
        &m.frictions,
        &m.accelerations,
    ];
    if vectors.iter().any(|v| v.len() != d) {
        return Err("a multibody's vectors do not have its links' degrees of freedom");
    }
    if m.body_jacobians.len() != n || m.workspace_accs.len() != n {
        return Err("a multibody's Jacobians or accelerations are not one per link");
    }
    let square = |a: &DMatrix<Real>| a.shape() == (d, d);
    if m.augmented_mass.ncols() == d
        && !(square(&m.augmented_mass) && square(&m.acc_augmented_mass))
    {
        return Err("a multibody's mass matrices are not its degrees of freedom squared");
    }
    let kept = m.coriolis_v.len() == n && m.coriolis_v.first().map(|c| c.ncols()) == Some(d);
    if kept
        && (m.coriolis_w.len() != n
            || m.coriolis_v
                .iter()
                .chain(&m.coriolis_w)
                .any(|c| c.ncols() != d)
            || m.i_coriolis_dt.ncols() != d)
    {
        return Err("a multibody's Coriolis workspaces do not have its degrees of freedom");
    }
    Ok(())
}

/// Checks a multibody's sizes through the mirror.
pub(crate) fn check(mb: &Multibody) -> Result<(), Fault> {
    let m = mirror(mb).ok_or((
        0,
        "a multibody's layout is not the one this build reads (rapier upgraded)",
    ))?;
    check_sizes(&m).map_err(|reason| (0, reason))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A chain of four links on revolute joints, a ball joint and a prismatic one, stepped so
    /// that every workspace has been used.
    fn stepped() -> rapier3d::pipeline::PhysicsWorld {
        use crate::math::Vector;
        use rapier3d::prelude::{
            ColliderBuilder, PhysicsWorld, PrismaticJointBuilder, RevoluteJointBuilder,
            RigidBodyBuilder, SphericalJointBuilder,
        };
        let mut w = PhysicsWorld::new();
        let mut parent = w.insert_body(RigidBodyBuilder::fixed());
        for k in 1..5 {
            let b = w.insert_body(RigidBodyBuilder::dynamic().translation(Vector::new(
                0.2 * k as Real,
                0.0,
                0.0,
            )));
            w.insert_collider(ColliderBuilder::ball(0.05), Some(b));
            let anchor = Vector::new(-0.2, 0.0, 0.0);
            match k {
                1 | 2 => {
                    let j = RevoluteJointBuilder::new(Vector::Z).local_anchor2(anchor);
                    w.multibody_joints.insert(parent, b, j, true).unwrap();
                }
                3 => {
                    let j = SphericalJointBuilder::new().local_anchor2(anchor);
                    w.multibody_joints.insert(parent, b, j, true).unwrap();
                }
                _ => {
                    let j = PrismaticJointBuilder::new(Vector::X).local_anchor2(anchor);
                    w.multibody_joints.insert(parent, b, j, true).unwrap();
                }
            };
            parent = b;
        }
        for _ in 0..20 {
            w.step();
        }
        w
    }

    /// The mirror reads a real multibody whole (re-encoded byte for byte), before and after
    /// its first step, and both pass; each size fault is refused.
    #[test]
    fn the_mirror_reads_real_multibodies_and_sizes_are_checked() {
        let w = stepped();
        let mb = w.multibody_joints.multibodies().next().unwrap();
        let m = mirror(mb).expect("the multibody's layout");
        assert_eq!(
            postcard::to_allocvec(&m).unwrap(),
            postcard::to_allocvec(mb).unwrap()
        );
        check_sizes(&m).unwrap();
        assert_eq!((m.links.len(), m.ndofs), (5, 6));
        assert_eq!(m.augmented_mass.shape(), (6, 6), "the matrices are in use");
        assert_eq!(m.coriolis_v.len(), 5);
        let refused = |edit: &dyn Fn(&mut MultibodyMatrices)| {
            let mut b = m.clone();
            edit(&mut b);
            check_sizes(&b).unwrap_err()
        };
        refused(&|b| b.velocities = DVector::zeros(5));
        refused(&|b| {
            b.body_jacobians.pop();
        });
        refused(&|b| {
            b.workspace_accs.pop();
        });
        refused(&|b| b.acc_augmented_mass = DMatrix::zeros(5, 5));
        refused(&|b| b.augmented_mass = DMatrix::zeros(4, 6));
        refused(&|b| b.coriolis_w[2] = Matrix3xX::zeros(3));
        refused(&|b| b.i_coriolis_dt = Matrix6xX::zeros(2));
        // What rapier reallocates is not refused: a mass matrix of other columns (with the
        // other one of any size), Coriolis workspaces whose first has other columns.
        let mut b = m.clone();
        b.augmented_mass = DMatrix::zeros(0, 0);
        b.acc_augmented_mass = DMatrix::zeros(3, 1);
        b.coriolis_v[0] = Matrix3xX::zeros(1);
        b.coriolis_w.clear();
        check_sizes(&b).unwrap();
    }
}
