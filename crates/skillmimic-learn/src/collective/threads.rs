//! An in-process group of ranks on threads (shared memory + barriers): the test double of a
//! `torch.distributed` process group. Training across processes or machines uses the Python
//! package's torch.distributed group; this one exists so the Rust tests can check the
//! data-parallel update (every task, every policy family) without PyTorch.
//!
//! Sums are taken in rank order on every rank, so all ranks get bit-identical results.

use std::sync::{Arc, Barrier, Mutex};

use super::Collective;
use crate::error::LearnError;

struct Shared {
    barrier: Barrier,
    slots: Mutex<Vec<Vec<f64>>>,
}

/// One member of an in-process group.
pub struct ThreadGroup {
    rank: usize,
    world: usize,
    shared: Arc<Shared>,
}

impl ThreadGroup {
    /// `world` members of one group; hand member `r` to the thread that plays rank `r`.
    pub fn new_group(world: usize) -> Vec<ThreadGroup> {
        let shared = Arc::new(Shared {
            barrier: Barrier::new(world),
            slots: Mutex::new(vec![Vec::new(); world]),
        });
        (0..world).map(|rank| ThreadGroup { rank, world, shared: Arc::clone(&shared) }).collect()
    }

    /// Deposit `mine`, wait for everyone, read everyone's deposits, wait again.
    fn exchange(&self, mine: Vec<f64>, read: impl FnOnce(&[Vec<f64>])) {
        self.shared.slots.lock().expect("group lock")[self.rank] = mine;
        self.shared.barrier.wait();
        read(&self.shared.slots.lock().expect("group lock"));
        self.shared.barrier.wait();
    }
}

impl Collective for ThreadGroup {
    fn rank(&self) -> usize {
        self.rank
    }
    fn world_size(&self) -> usize {
        self.world
    }
    fn all_reduce_f32(&mut self, buf: &mut [f32]) -> Result<(), LearnError> {
        self.exchange(buf.iter().map(|&x| x as f64).collect(), |all| {
            for (j, b) in buf.iter_mut().enumerate() {
                let mut s = 0.0f32;
                for v in all {
                    s += v[j] as f32;
                }
                *b = s;
            }
        });
        Ok(())
    }
    fn all_reduce_f64(&mut self, buf: &mut [f64]) -> Result<(), LearnError> {
        self.exchange(buf.to_vec(), |all| {
            for (j, b) in buf.iter_mut().enumerate() {
                *b = all.iter().map(|v| v[j]).sum();
            }
        });
        Ok(())
    }
    fn broadcast_f32(&mut self, buf: &mut [f32]) -> Result<(), LearnError> {
        self.exchange(buf.iter().map(|&x| x as f64).collect(), |all| {
            for (b, &v) in buf.iter_mut().zip(&all[0]) {
                *b = v as f32;
            }
        });
        Ok(())
    }
    fn broadcast_f64(&mut self, buf: &mut [f64]) -> Result<(), LearnError> {
        self.exchange(buf.to_vec(), |all| buf.copy_from_slice(&all[0]));
        Ok(())
    }
}
