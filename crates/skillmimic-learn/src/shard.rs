//! Which environments and which samples of a data-parallel run a rank holds.
//!
//! `env.num_envs` is the run's total over all ranks: the configuration describes the experiment,
//! the world size only how it is spread. Rank r holds the contiguous global environments
//! `offset..offset + local` (⌊N/W⌋ each, the first N mod W ranks one more). A rollout sample is
//! named by its global index `t × N + e` (time-major, e the global environment); every rank draws
//! the same permutation of all `H × N` global indices per mini-epoch ([`epoch_order`]) and takes
//! from each minibatch the members it holds ([`Shard::local_index`]), so the minibatches are the
//! same sets of samples for any world size.

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

use crate::collective::mix_seed;
use crate::error::LearnError;

/// This rank's part of the run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub rank: usize,
    pub world: usize,
    /// Environments of all ranks (`env.num_envs`).
    pub total_envs: usize,
    /// First global environment held here.
    pub offset: usize,
    /// Environments held here.
    pub local: usize,
}

impl Shard {
    /// Rank `rank` of `world` over `total_envs` environments.
    pub fn new(total_envs: usize, rank: usize, world: usize) -> Result<Self, LearnError> {
        if world == 0 || rank >= world {
            return Err(LearnError::Config(format!(
                "distributed: rank {rank} is not in a world of {world}"
            )));
        }
        if total_envs < world {
            return Err(LearnError::Config(format!(
                "config field 'env.num_envs': {total_envs} environments cannot be spread over \
                    {world} ranks (env.num_envs is the total of all ranks; at least one per rank)"
            )));
        }
        let (base, extra) = (total_envs / world, total_envs % world);
        let offset = rank * base + rank.min(extra);
        Ok(Self { rank, world, total_envs, offset, local: base + usize::from(rank < extra) })
    }

    /// The whole run in one process.
    pub fn single(total_envs: usize) -> Self {
        Self { rank: 0, world: 1, total_envs, offset: 0, local: total_envs }
    }

    /// The index in this rank's time-major rollout (`t × local + e − offset`) of global sample
    /// `g`, if this rank holds it.
    #[inline]
    pub fn local_index(&self, g: usize) -> Option<usize> {
        let (t, e) = (g / self.total_envs, g % self.total_envs);
        (e >= self.offset && e < self.offset + self.local).then(|| t * self.local + e - self.offset)
    }
}

/// The order of the `samples` global rollout samples in mini-epoch `epoch` of iteration
/// `iteration` (0-based, counted over the whole run) of a run seeded `seed`: the same on every
/// rank, independent of the world size and of any other random stream.
pub fn epoch_order(
    seed: u64,
    iteration: u64,
    epoch: usize,
    samples: usize,
    order: &mut Vec<usize>,
) {
    order.clear();
    order.extend(0..samples);
    let mut rng = ChaCha8Rng::seed_from_u64(mix_seed(mix_seed(seed, iteration), epoch as u64));
    order.shuffle(&mut rng);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_cover_every_sample_once() {
        let (n, h) = (7, 3);
        let shards: Vec<Shard> = (0..3).map(|r| Shard::new(n, r, 3).unwrap()).collect();
        assert_eq!(shards.iter().map(|s| s.local).collect::<Vec<_>>(), [3, 2, 2]);
        assert_eq!(shards.iter().map(|s| s.offset).collect::<Vec<_>>(), [0, 3, 5]);
        let mut seen = vec![Vec::new(); 3];
        for g in 0..n * h {
            let holders: Vec<usize> =
                (0..3).filter(|&r| shards[r].local_index(g).is_some()).collect();
            assert_eq!(holders.len(), 1, "sample {g}");
            seen[holders[0]].push(shards[holders[0]].local_index(g).unwrap());
        }
        for (r, s) in seen.iter().enumerate() {
            assert_eq!(*s, (0..shards[r].local * h).collect::<Vec<_>>());
        }
        assert_eq!(Shard::single(7).local_index(9), Some(9));
        assert!(Shard::new(1, 0, 2).is_err() && Shard::new(4, 2, 2).is_err());
        let (mut a, mut b) = (Vec::new(), Vec::new());
        epoch_order(5, 2, 1, 100, &mut a);
        epoch_order(5, 2, 1, 100, &mut b);
        assert_eq!(a, b);
        epoch_order(5, 2, 2, 100, &mut b);
        assert_ne!(a, b);
    }
}
