//! Rollout storage (time-major `[t][env]` arrays, sized once and reused) and the minibatch gather
//! buffers of the PPO update.

use crate::ppo::UpdateBuffers;

/// Rollout storage, time-major `[t][env]`.
#[derive(Clone, Default)]
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
            for v in [
                &mut self.neglogp,
                &mut self.values,
                &mut self.next_values,
                &mut self.rewards,
                &mut self.advantages,
                &mut self.returns,
            ] {
                *v = vec![0.0; h * n];
            }
            self.dones = vec![0; h * n];
        }
    }

    /// Copy environments `offset..offset + n` of `src` (a rollout of `h` steps of `src_n`
    /// environments) into this rollout (sized for `h` × `n`).
    #[allow(clippy::too_many_arguments)]
    pub fn copy_envs_from(
        &mut self,
        src: &Rollout,
        h: usize,
        src_n: usize,
        offset: usize,
        n: usize,
        d: usize,
        a: usize,
    ) {
        for t in 0..h {
            let (s0, t0) = (t * src_n + offset, t * n);
            self.obs[t0 * d..(t0 + n) * d].copy_from_slice(&src.obs[s0 * d..(s0 + n) * d]);
            self.actions[t0 * a..(t0 + n) * a].copy_from_slice(&src.actions[s0 * a..(s0 + n) * a]);
            for (dst, from) in [
                (&mut self.neglogp, &src.neglogp),
                (&mut self.values, &src.values),
                (&mut self.next_values, &src.next_values),
                (&mut self.rewards, &src.rewards),
                (&mut self.advantages, &src.advantages),
                (&mut self.returns, &src.returns),
            ] {
                dst[t0..t0 + n].copy_from_slice(&from[s0..s0 + n]);
            }
            self.dones[t0..t0 + n].copy_from_slice(&src.dones[s0..s0 + n]);
        }
    }
}
