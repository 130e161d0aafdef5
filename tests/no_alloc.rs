//! The step never allocates once warm: every buffer lives in the fluid's workspace and is
//! reused. (Buffers grow, geometrically, only when a fluid occupies more cells or has more
//! neighbours than ever before; a fluid in a steady state allocates nothing.)

mod common;

use common::on_threads;
use rapier_sph::FluidParamsBuilder;
use rapier_sph::scenes::{DamBreakConfig, dam_break};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

struct Counting;
static COUNTING: AtomicBool = AtomicBool::new(false);
static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if COUNTING.load(Ordering::Relaxed) {
            ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        }
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if COUNTING.load(Ordering::Relaxed) {
            ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        }
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn a_warm_step_allocates_nothing() {
    // A wide, shallow pool (the dam-break tank with the column already spread: tank as long
    // as the column) settles quickly, so its cells and neighbour counts stop growing.
    let params = FluidParamsBuilder::water(0.05).build().unwrap();
    let mut config = DamBreakConfig::tower(params.clone(), 0.6);
    config.tank_length_ratio = 1.0;
    let mut scene = dam_break(&config).unwrap();
    let dt = params.acoustic_time_step();
    scene.world.physics.integration_parameters.dt = dt;
    scene.world.physics.step();
    on_threads(2, || {
        let w = &mut scene.world;
        for _ in 0..300 {
            w.step_fluids().unwrap();
        }
        COUNTING.store(true, Ordering::SeqCst);
        for _ in 0..50 {
            w.step_fluids().unwrap();
        }
        COUNTING.store(false, Ordering::SeqCst);
    });
    assert_eq!(
        ALLOCATIONS.load(Ordering::SeqCst),
        0,
        "allocations during 50 warm steps"
    );
}
