//! External forces: gravity (the Unity paper's `ρg` term, as the acceleration `g`).

use crate::math::Vector;
use crate::par::CHUNK;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Adds the uniform acceleration `g` to every particle.
pub fn add_gravity(gravity: Vector, accelerations: &mut [Vector]) {
    crate::par_chunks_mut!(accelerations, CHUNK).for_each(|out| {
        for a in out {
            *a += gravity;
        }
    });
}
