//! The hook interface of the trainer's extensions: parts that ride along the PPO loop without
//! being PPO — today the motion prior's discriminator and style reward ([`crate::amp_reward`]).
//! The trainer calls every extension at fixed points of an iteration, in the order they were
//! added: before the policy acts, after each environment step (where an extension may reshape the
//! rewards the PPO update sees), after each PPO minibatch step, after the PPO update (its own
//! update), when checkpoints are written and when the environments are rebuilt.
//!
//! What is not an extension, and why: the SkillMimic-V2 history encoder and token adaptation act
//! once, while the trainer is built (a copy of the encoder kept with the run; a policy adapted
//! from a trained one, [`super::setup`]); the data-parallel collective is the
//! [`crate::collective::Collective`] every part reduces through; active skill learning works on
//! the whole trainer between iterations (an [`super::IterationHook`] the runner calls).

use std::any::Any;

use skillmimic_core::tensorfile::OwnedTensor;

use crate::collective::Collective;
use crate::error::LearnError;
use crate::iteration_stats::IterationStats;

/// What an extension sees of the environments before or after a step.
pub struct StepView<'a> {
    /// The rollout step (`0..ppo.horizon`).
    pub t: usize,
    /// Observations (`n × obs_dim`): before a step the ones the policy acts on; after it the
    /// step's (terminal observations where an episode ended).
    pub obs: &'a [f32],
    pub obs_dim: usize,
    /// 1 where the step ended an episode (terminated or truncated), per environment (empty
    /// before a step).
    pub done: &'a [u8],
    /// The environments' style features of the same states (`n × style_dim`,
    /// [`skillmimic_env::Env::style_features`]; empty when the task computes none).
    pub style: &'a [f32],
    pub style_dim: usize,
    /// The task (index into [`skillmimic_env::Env::task_rows`]) each environment runs now, where
    /// environments change task between episodes ([`skillmimic_env::Env::row_tasks`]); empty
    /// where each task keeps its rows.
    pub tasks: &'a [u16],
}

/// A part of training beside PPO (see the module doc). Every hook has a do-nothing default.
pub trait Extension: Any + Send + Sync {
    /// Short name (logs, errors).
    fn name(&self) -> &'static str;
    /// Names of the per-step sums [`Extension::after_step`] adds up; the iteration reports each
    /// as a reward term (mean per environment step over all ranks).
    fn step_terms(&self) -> &'static [&'static str] {
        &[]
    }
    /// Step t's observations (and style features), before the policy acts on them.
    fn begin_step(&mut self, _step: &StepView<'_>) {}
    /// After the environments stepped: `rewards` (`n`) may be reshaped in place (they are what
    /// the rollout stores); add this step's contributions to `sums` (one per
    /// [`Extension::step_terms`] name).
    fn after_step(&mut self, _step: &StepView<'_>, _rewards: &mut [f32], _sums: &mut [f64]) {}
    /// After each PPO minibatch step: `members` are the minibatch's samples of this rank, as
    /// indices into the rollout (time-major: step t of environment i is `t · n + i`). An extension
    /// that trains beside the policy in every minibatch (the released AMP agent's discriminator,
    /// `ppo.amp.schedule = "per_minibatch"`) takes its step here. Default: nothing.
    fn minibatch(
        &mut self,
        _members: &[usize],
        _comm: &mut dyn Collective,
    ) -> Result<(), LearnError> {
        Ok(())
    }
    /// After the PPO update of the iteration: the extension's own update; its statistics go into
    /// `stats`. A non-finite loss is a [`LearnError::Diverged`].
    fn update(
        &mut self,
        _comm: &mut dyn Collective,
        _stats: &mut IterationStats,
    ) -> Result<(), LearnError> {
        Ok(())
    }
    /// Tensors saved with every training checkpoint (and read back by the extension on resume).
    fn tensors(&self) -> Vec<OwnedTensor> {
        Vec::new()
    }
    /// Everything else a later iteration depends on (random streams, buffers, per-environment
    /// windows), encoded for an exact resume ([`Extension::restore_resume`]; saved with every
    /// training checkpoint beside [`Extension::tensors`]). Default: nothing.
    fn save_resume(&self) -> Vec<u8> {
        Vec::new()
    }
    /// Restore what [`Extension::save_resume`] wrote; a state of another size is an error saying
    /// what differs.
    fn restore_resume(&mut self, bytes: &[u8]) -> Result<(), String> {
        if bytes.is_empty() {
            Ok(())
        } else {
            Err(format!(
                "extension '{}' keeps no resume state, got {} bytes",
                self.name(),
                bytes.len()
            ))
        }
    }
    /// The environments were rebuilt: forget per-episode state.
    fn restart(&mut self) {}
    /// Typed access ([`super::Trainer::extension`]).
    fn as_any(&self) -> &dyn Any;
    fn as_any_mut(&mut self) -> &mut dyn Any;
}
