//! The per-minibatch discriminator schedule's state (`ppo.amp.schedule = "per_minibatch"`):
//! the rollout's windows, the iteration's loss sums and scratch buffers; the schedule itself is
//! [`super::replay`]'s.

use crate::amp::DiscLoss;

/// The per-minibatch schedule's rollout windows, loss sums and scratch buffers.
pub(super) struct Replay {
    /// `horizon × n × width`: every environment's window after each rollout step.
    pub(super) steps: Vec<f32>,
    /// Loss sums and count of the iteration's minibatch steps.
    pub(super) sum: DiscLoss,
    pub(super) count: usize,
    pub(super) xr: Vec<f32>,
    pub(super) xs: Vec<f32>,
    pub(super) picks: Vec<usize>,
}

impl Replay {
    /// Room for a rollout of `horizon` steps of `n` environments' windows of `width` entries.
    pub(super) fn new(horizon: usize, n: usize, width: usize) -> Self {
        Self {
            steps: vec![0.0; horizon * n * width],
            sum: DiscLoss::default(),
            count: 0,
            xr: Vec::new(),
            xs: Vec::new(),
            picks: Vec::new(),
        }
    }
}
