//! Rollout storage (time-major `[t][env]` arrays, sized once and reused) and the minibatch gather
//! buffers of the PPO update.

use crate::ppo::UpdateBuffers;

/// Rollout storage, time-major `[t][env]`.
#[derive(Default)]
pub struct Rollout {
    pub obs: Vec<f32>,
    pub actions: Vec<f32>,
    pub neglogp: Vec<f32>,
    pub values: Vec<f32>,
    pub next_values: Vec<f32>,
    pub rewards: Vec<f32>,
    pub dones: Vec<u8>,
    pub advantages: Vec<f32>,
    pub returns: Vec<f32>,
}

/// Minibatch gather buffers.
#[derive(Default)]
pub struct MinibatchBuffers {
    pub obs: Vec<f32>,
    pub update: UpdateBuffers,
    pub actions: Vec<f32>,
    pub neglogp: Vec<f32>,
    pub adv: Vec<f32>,
    pub ret: Vec<f32>,
}

impl Rollout {
    /// Size the buffers for `h` steps of `n` environments (observation width `d`, action width
    /// `a`); a no-op when they already have that size.
    pub fn ensure(&mut self, h: usize, n: usize, d: usize, a: usize) {
        if self.obs.len() != h * n * d || self.actions.len() != h * n * a {
            self.obs = vec![0.0; h * n * d];
            self.actions = vec![0.0; h * n * a];
            for v in [&mut self.neglogp, &mut self.values, &mut self.next_values, &mut self.rewards, &mut self.advantages, &mut self.returns] {
                *v = vec![0.0; h * n];
            }
            self.dones = vec![0; h * n];
        }
    }
}
