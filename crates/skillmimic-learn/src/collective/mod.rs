//! Data-parallel training: the collective operations the learner needs, and the arithmetic that
//! makes every rank take the identical update.
//!
//! The operations come from outside this crate: in production from `torch.distributed` (the
//! Python package's trainer wraps a process group, gloo on CPU; see `python/skillmimic_rs/
//! distributed.py`), in tests from [`threads::ThreadGroup`]. A single process uses [`Single`],
//! whose operations are the identity, so one code path serves both.
//!
//! What is reduced, and why the update equals one process's:
//! - **minibatch membership**: every rank draws the same permutation of the *global* samples
//!   (`t × N_total + global env`), so minibatch j is the same set of samples whatever the world
//!   size; each rank takes the members it holds ([`crate::shard::Shard`]).
//! - **gradients**: each rank computes the mean-loss gradient over its members and weights it by
//!   `members / minibatch`; the all-reduced sum is the gradient of the minibatch mean (every PPO
//!   loss term is a per-sample mean). Loss statistics are reduced the same way.
//! - **normalisers**: the observation normaliser's per-minibatch batch moments and the value
//!   normaliser's per-rollout moments are reduced as sums of `x − mean` and `(x − mean)²`
//!   ([`update_normalizer`]); the advantage mean and standard deviation as global sums
//!   ([`normalize_advantages`]).
//! - **start**: rank 0 broadcasts parameters, optimiser and normaliser state; a signature of the
//!   configuration is compared first so a mismatch is an error, not a hang.

pub mod bytes;
pub mod threads;

use crate::error::LearnError;
use skillmimic_nn::normalizer::RunningMeanStd;

/// Collective operations over the ranks of one training run. Every rank must call the same
/// operations in the same order with buffers of the same length.
pub trait Collective: Send + Sync {
    /// This process's rank, `0..world_size`.
    fn rank(&self) -> usize;
    /// Number of ranks.
    fn world_size(&self) -> usize;
    /// Element-wise sum over all ranks, in place.
    fn all_reduce_f32(&mut self, buf: &mut [f32]) -> Result<(), LearnError>;
    /// Element-wise sum over all ranks, in place.
    fn all_reduce_f64(&mut self, buf: &mut [f64]) -> Result<(), LearnError>;
    /// Rank 0's buffer copied into every rank's, in place.
    fn broadcast_f32(&mut self, buf: &mut [f32]) -> Result<(), LearnError>;
    /// Rank 0's buffer copied into every rank's, in place.
    fn broadcast_f64(&mut self, buf: &mut [f64]) -> Result<(), LearnError>;
}

/// One process: every operation is the identity.
#[derive(Clone, Copy, Debug, Default)]
pub struct Single;

impl Collective for Single {
    fn rank(&self) -> usize {
        0
    }
    fn world_size(&self) -> usize {
        1
    }
    fn all_reduce_f32(&mut self, _: &mut [f32]) -> Result<(), LearnError> {
        Ok(())
    }
    fn all_reduce_f64(&mut self, _: &mut [f64]) -> Result<(), LearnError> {
        Ok(())
    }
    fn broadcast_f32(&mut self, _: &mut [f32]) -> Result<(), LearnError> {
        Ok(())
    }
    fn broadcast_f64(&mut self, _: &mut [f64]) -> Result<(), LearnError> {
        Ok(())
    }
}

/// A collective that also measures the seconds spent in its operations (the trainer reports
/// them per iteration).
pub struct Timed {
    inner: Box<dyn Collective>,
    /// Seconds spent in collective operations since the last [`Timed::take_seconds`].
    seconds: f64,
}

impl Timed {
    pub fn new(inner: Box<dyn Collective>) -> Self {
        Self { inner, seconds: 0.0 }
    }
    /// Seconds in collective operations since the last call.
    pub fn take_seconds(&mut self) -> f64 {
        std::mem::take(&mut self.seconds)
    }
    /// Run `f` on the inner collective and count its seconds; nothing to do for one process.
    fn timed(
        &mut self,
        f: impl FnOnce(&mut dyn Collective) -> Result<(), LearnError>,
    ) -> Result<(), LearnError> {
        if self.inner.world_size() == 1 {
            return Ok(());
        }
        let t0 = std::time::Instant::now();
        let r = f(self.inner.as_mut());
        self.seconds += t0.elapsed().as_secs_f64();
        r
    }
}

impl Collective for Timed {
    fn rank(&self) -> usize {
        self.inner.rank()
    }
    fn world_size(&self) -> usize {
        self.inner.world_size()
    }
    fn all_reduce_f32(&mut self, buf: &mut [f32]) -> Result<(), LearnError> {
        self.timed(|c| c.all_reduce_f32(buf))
    }
    fn all_reduce_f64(&mut self, buf: &mut [f64]) -> Result<(), LearnError> {
        self.timed(|c| c.all_reduce_f64(buf))
    }
    fn broadcast_f32(&mut self, buf: &mut [f32]) -> Result<(), LearnError> {
        self.timed(|c| c.broadcast_f32(buf))
    }
    fn broadcast_f64(&mut self, buf: &mut [f64]) -> Result<(), LearnError> {
        self.timed(|c| c.broadcast_f64(buf))
    }
}

/// Merge the rows of `x` held by every rank into `norm` (each rank's `norm` must be equal before
/// the call; it is equal after). One all-reduce of `1 + 2·dim` values. With a single process the
/// result is bit for bit that of [`RunningMeanStd::update`].
pub fn update_normalizer(
    norm: &mut RunningMeanStd,
    x: &[f32],
    comm: &mut dyn Collective,
    scratch: &mut Vec<f64>,
) -> Result<(), LearnError> {
    let dim = norm.dim();
    let local = (x.len() / dim) as f64;
    let (s1, s2) = RunningMeanStd::batch_sums(x, dim, &norm.mean);
    scratch.clear();
    scratch.push(local);
    scratch.extend_from_slice(&s1);
    scratch.extend_from_slice(&s2);
    comm.all_reduce_f64(scratch)?;
    let n = scratch[0];
    if n < 2.0 {
        return Err(LearnError::Config(format!(
            "normaliser update over {n} samples in all ranks: at least 2 are needed"
        )));
    }
    norm.merge_sums(n, &scratch[1..1 + dim], &scratch[1 + dim..1 + 2 * dim]);
    Ok(())
}

/// Normalise advantages in place over the samples of all ranks: (A − mean) / (std + 1e-8) with
/// the unbiased standard deviation of the union (two all-reduces of two values).
pub fn normalize_advantages(a: &mut [f32], comm: &mut dyn Collective) -> Result<(), LearnError> {
    let mut s = [a.len() as f64, a.iter().map(|&x| x as f64).sum::<f64>()];
    comm.all_reduce_f64(&mut s)?;
    let (n, mean) = (s[0], s[1] / s[0]);
    let mut ss = [a.iter().map(|&x| (x as f64 - mean).powi(2)).sum::<f64>()];
    comm.all_reduce_f64(&mut ss)?;
    let var = ss[0] / (n - 1.0);
    let inv = 1.0 / (var.sqrt() + 1e-8);
    a.iter_mut().for_each(|x| *x = ((*x as f64 - mean) * inv) as f32);
    Ok(())
}

/// A 64-bit mix of two words (SplitMix64 finaliser over `a ⊕ rotated b`): per-rank and
/// per-epoch seeds derived from the run seed.
pub fn mix_seed(a: u64, b: u64) -> u64 {
    let mut z = a ^ b.rotate_left(32) ^ 0x9e37_79b9_7f4a_7c15;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_process_normalizer_update_is_the_plain_update() {
        let x: Vec<f32> = (0..300).map(|i| ((i * 37 % 101) as f32).sin() * 3.0).collect();
        let mut a = RunningMeanStd::new(3, 1e-5, 5.0);
        let mut b = a.clone();
        a.update(&x);
        update_normalizer(&mut b, &x, &mut Single, &mut Vec::new()).unwrap();
        assert_eq!(a, b);
        let mut adv = vec![1.0f32, 2.0, 3.0];
        normalize_advantages(&mut adv, &mut Single).unwrap();
        assert!((adv[0] + 1.0).abs() < 1e-6 && adv[1].abs() < 1e-6 && (adv[2] - 1.0).abs() < 1e-6);
        assert_ne!(mix_seed(1, 0), mix_seed(1, 1));
        assert_ne!(mix_seed(1, 2), mix_seed(2, 1));
    }
}
