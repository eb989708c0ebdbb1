//! The per-step path of the batched core (step + reset) performs no heap allocation.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use skillmimic_core::characters::skillmimic::NUM_DOFS;
use skillmimic_sim::{BatchSim, HandModel, ResetState, Scene};

struct Counting;
static ALLOCS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        ALLOCS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        unsafe { System.dealloc(p, l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        ALLOCS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.realloc(p, l, n) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn step_and_reset_do_not_allocate() {
    for hands in [HandModel::Full, HandModel::Box] {
        let scene = Arc::new(Scene::default_for(hands).unwrap());
        let n = 8;
        let mut sim = BatchSim::new(scene, n, 2).unwrap();
        let actions: Vec<f32> =
            (0..n * NUM_DOFS).map(|i| ((i * 37 % 101) as f32 / 50.0) - 1.0).collect();
        let states = vec![ResetState::default(); n];
        let mask: Vec<bool> = (0..n).map(|i| i % 3 == 0).collect();
        // warm up: rayon's per-thread latches are created lazily on first use
        for _ in 0..3 {
            sim.step(&actions).unwrap();
            sim.reset(&mask, &states).unwrap();
        }
        let before = ALLOCS.load(Ordering::SeqCst);
        for k in 0..30 {
            sim.step(&actions).unwrap();
            if k % 10 == 0 {
                sim.reset(&mask, &states).unwrap();
            }
        }
        let count = ALLOCS.load(Ordering::SeqCst) - before;
        assert_eq!(count, 0, "{hands:?}: {count} heap allocations in 30 steps + 3 resets");
    }
}
