//! The reference-window draw both schedules share, and the released AMP/ASE/TokenHSI agent's
//! discriminator schedule (`ppo.amp.schedule = "per_minibatch"`).
//!
//! Per-minibatch schedule, step by step:
//! * Rollout: every environment's window after each step is kept, in the rollout's sample order
//!   (time-major: step t of environment i at `t · n + i`; `horizon × n × width` floats).
//! * After each PPO minibatch step: per discriminator, the first `batch` of the minibatch's
//!   samples that belong to its environment rows (the minibatch order is already a random
//!   permutation, so these are a random subset) give the current windows; as many replay
//!   windows are drawn uniformly with replacement from the replay buffer (the current windows
//!   again while it is empty, as the released agent does); as many reference windows are drawn
//!   ([`Prior::draw_reference`]). One discriminator step on the reference windows against the
//!   current and replay windows together.
//! * After the update: the rollout's windows go into the replay buffer (a ring of `buffer`
//!   windows). While it is not full, every window goes in; once full, each with probability
//!   `replay_keep`; if more windows remain than the buffer holds, a random subset of `buffer` of
//!   them. The iteration reports the mean loss over its minibatch steps.
//!
//! Differences from the released agent, chosen for a CPU run and written down here: the released
//! keep rule starts once the buffer's total count *exceeds* its size (here once it is full: the
//! resume state keeps only the fill level, and the two differ for the one rollout that fills the
//! buffer exactly); its replay draws are without replacement within a pass; its reference windows
//! come from a demo buffer refreshed with `amp_batch_size` windows per iteration (here drawn fresh
//! from the clips each time); its discriminator shares the policy's Adam (same learning rate,
//! no gradient clipping: separate Adams take the same steps).

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use skillmimic_env::amp::window_of;

use super::{AmpReward, Prior};
use crate::amp::DiscLoss;
use crate::collective::Collective;
use crate::error::LearnError;

impl Prior {
    /// One reference window into `x` (`window · fdim + cond` entries): a task by its share of the
    /// environments (conditional prior), one of its clips uniformly, an end frame uniformly
    /// (frames before the clip start repeat its first frame), then the task's one-hot.
    pub(super) fn draw_reference(
        &self,
        rng: &mut ChaCha8Rng,
        fdim: usize,
        window: usize,
        cond: usize,
        x: &mut [f32],
    ) {
        let clips = if self.by_label.len() > 1 {
            let mut u = rng.random::<f64>();
            let pick = self.by_label.iter().position(|(_, share)| {
                u -= share;
                u < 0.0
            });
            &self.by_label[pick.unwrap_or(self.by_label.len() - 1)].0
        } else {
            &self.by_label[0].0
        };
        let c = clips[rng.random_range(0..clips.len())];
        let end = rng.random_range(0..self.reference[c].len() / fdim);
        let wf = window * fdim;
        window_of(&self.reference[c], fdim, end, window, &mut x[..wf]);
        x[wf..].fill(0.0);
        if cond > 0 {
            x[wf + self.labels[c]] = 1.0;
        }
    }
}

impl AmpReward {
    /// Rollout step `t`: keep every environment's window (`rings`, after this step's frame).
    pub(super) fn keep_step(&mut self, t: usize) {
        let len = self.rings.len();
        let dst = self.replay.as_mut().and_then(|rp| rp.steps.get_mut(t * len..(t + 1) * len));
        if let Some(dst) = dst {
            dst.copy_from_slice(&self.rings);
        }
    }

    /// One discriminator step per prior on this PPO minibatch's samples `members` (rollout
    /// indices `t · n + i`), with as many replay and reference windows (module doc).
    pub(super) fn minibatch_step(
        &mut self,
        members: &[usize],
        comm: &mut dyn Collective,
    ) -> Result<(), LearnError> {
        let (w, n, b) = (self.width(), self.fresh.len(), self.cfg.batch);
        let (fdim, window, cond) = (self.fdim, self.cfg.window, self.cond);
        let Some(rp) = self.replay.as_mut() else { return Ok(()) };
        for p in self.priors.iter_mut() {
            rp.picks.clear();
            rp.picks.extend(members.iter().copied().filter(|&s| p.rows.contains(&(s % n))).take(b));
            let k = rp.picks.len();
            if k == 0 {
                continue;
            }
            rp.xr.resize(k * w, 0.0);
            rp.xs.resize(2 * k * w, 0.0);
            for (j, &s) in rp.picks.iter().enumerate() {
                rp.xs[j * w..(j + 1) * w].copy_from_slice(&rp.steps[s * w..(s + 1) * w]);
            }
            for j in 0..k {
                let (cur, rep) = rp.xs.split_at_mut(k * w);
                let dst = &mut rep[j * w..(j + 1) * w];
                if p.filled == 0 {
                    dst.copy_from_slice(&cur[j * w..(j + 1) * w]);
                } else {
                    let r = self.rng.random_range(0..p.filled);
                    dst.copy_from_slice(&p.buffer[r * w..(r + 1) * w]);
                }
            }
            for j in 0..k {
                p.draw_reference(&mut self.rng, fdim, window, cond, &mut rp.xr[j * w..(j + 1) * w]);
            }
            let l = p.disc.update_with(&rp.xr, k, &rp.xs, 2 * k, comm)?;
            rp.sum.add_divided(&l, 1.0);
            rp.count += 1;
        }
        Ok(())
    }

    /// After the PPO update: the rollout's windows into the replay buffers (keep rule in the
    /// module doc); returns the mean loss of the iteration's minibatch steps (zero when none).
    pub(super) fn store_replay(&mut self) -> DiscLoss {
        let (w, n) = (self.width(), self.fresh.len());
        let (cap, keep) = (self.cfg.buffer, self.cfg.replay_keep);
        let Some(rp) = self.replay.as_mut() else { return DiscLoss::default() };
        let total = rp.steps.len() / w.max(1);
        for p in self.priors.iter_mut() {
            let full = p.filled == cap;
            rp.picks.clear();
            for s in (0..total).filter(|s| p.rows.contains(&(s % n))) {
                if !full || self.rng.random::<f64>() < keep {
                    rp.picks.push(s);
                }
            }
            let m = rp.picks.len();
            let take = m.min(cap);
            if m > cap {
                super::shuffle_first(&mut self.rng, &mut rp.picks, take);
            }
            for &s in &rp.picks[..take] {
                p.push_window(&rp.steps[s * w..(s + 1) * w]);
            }
        }
        let mut mean = DiscLoss::default();
        if rp.count > 0 {
            mean.add_divided(&rp.sum, rp.count as f64);
        }
        (rp.sum, rp.count) = (DiscLoss::default(), 0);
        mean
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{AmpSchedule, TrainConfig};

    /// A per-minibatch prior of 8 environments with a rollout of 32 steps (256 windows), each
    /// rollout window marked with its sample index + 1 in its first entry.
    fn marked(buffer: usize, keep: f64) -> AmpReward {
        let mut c = TrainConfig::preset("tiny").unwrap();
        c.env.motion = vec![std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../motions")];
        c.ppo.horizon = 32;
        c.ppo.amp.enabled = true;
        c.ppo.amp.hidden = vec![8];
        c.ppo.amp.buffer = buffer;
        c.ppo.amp.schedule = AmpSchedule::PerMinibatch;
        c.ppo.amp.replay_keep = keep;
        let dim = skillmimic_env::obs::layout::HUMANOID_DIM;
        let mut a = AmpReward::new(&c, dim, 8, 1, &[]).unwrap();
        let w = a.width();
        let rp = a.replay.as_mut().unwrap();
        assert_eq!(rp.steps.len(), 256 * w);
        for s in 0..256 {
            rp.steps[s * w] = (s + 1) as f32;
        }
        a
    }

    /// The first entries of the buffer's windows.
    fn marks(a: &AmpReward) -> Vec<f32> {
        let w = a.width();
        a.priors[0].buffer.chunks_exact(w).map(|x| x[0]).collect()
    }

    /// Sets every buffer window's mark to -1 (unwritten).
    fn clear(a: &mut AmpReward) {
        let w = a.width();
        for x in a.priors[0].buffer.chunks_exact_mut(w) {
            x[0] = -1.0;
        }
    }

    #[test]
    fn every_window_goes_in_while_the_buffer_is_not_full() {
        let mut a = marked(1000, 0.0);
        a.store_replay();
        let m = marks(&a);
        assert_eq!(a.priors[0].filled, 256);
        assert!(m[..256].iter().enumerate().all(|(i, &x)| x == (i + 1) as f32), "in order");
        for _ in 0..3 {
            a.store_replay();
        }
        // 1024 windows offered, all kept until the buffer filled: the ring wrapped by 24
        assert_eq!((a.priors[0].filled, a.priors[0].next), (1000, 24));
        assert!(marks(&a)[..24].iter().enumerate().all(|(i, &x)| x == (232 + i + 1) as f32));
    }

    #[test]
    fn more_windows_than_the_buffer_holds_go_in_as_a_random_subset() {
        let mut a = marked(100, 0.0);
        clear(&mut a);
        a.store_replay();
        let mut m = marks(&a);
        assert_eq!(a.priors[0].filled, 100);
        m.sort_by(f32::total_cmp);
        m.dedup();
        assert_eq!(m.len(), 100, "100 distinct windows");
        assert!(m[0] >= 1.0 && m[99] <= 256.0);
        assert!(m[99] > 100.0, "not just the first 100: {m:?}");
    }

    #[test]
    fn once_full_each_window_goes_in_with_the_keep_probability() {
        for (keep, want) in [(0.0, 0.0), (0.25, 64.0), (1.0, 100.0)] {
            let mut a = marked(100, keep);
            a.store_replay();
            let reps = 400;
            let mut written = 0usize;
            for _ in 0..reps {
                clear(&mut a);
                a.store_replay();
                written += marks(&a).iter().filter(|&&x| x >= 0.0).count();
            }
            let mean = written as f64 / reps as f64;
            // Binomial(256, 0.25): sd 6.93 per rollout, 0.35 for the mean of 400
            assert!((mean - want).abs() < 1.5, "keep {keep}: {mean} windows per rollout");
        }
    }
}
