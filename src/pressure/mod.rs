//! Stages 3 and 4: pressure from density (equation of state), then the pressure force.
//!
//! Only the weakly-compressible method of the Unity paper (WCSPH, its Algorithm 1) exists
//! so far; incompressible solvers will sit beside it, one file each, named after their paper.

pub mod eos;
pub(crate) mod fused;
pub mod wcsph;
