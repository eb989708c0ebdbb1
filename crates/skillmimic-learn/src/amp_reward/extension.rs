//! The motion prior as a trainer extension ([`crate::trainer::Extension`]).

use skillmimic_core::tensorfile::OwnedTensor;

use super::AmpReward;
use crate::collective::Collective;
use crate::error::LearnError;

/// The motion prior as a trainer extension: it reads every step's observations, mixes the style
/// reward into the rewards PPO sees (reporting the task and style parts), trains its
/// discriminators after each PPO update (or in every PPO minibatch, `ppo.amp.schedule =
/// "per_minibatch"`) and saves them with the checkpoints.
impl crate::trainer::Extension for AmpReward {
    fn name(&self) -> &'static str {
        "amp"
    }
    /// The task reward before mixing and the style reward.
    fn step_terms(&self) -> &'static [&'static str] {
        &["task", "style"]
    }
    fn begin_step(&mut self, step: &crate::trainer::StepView<'_>) {
        AmpReward::begin_step(self, step);
    }
    fn after_step(
        &mut self,
        step: &crate::trainer::StepView<'_>,
        rewards: &mut [f32],
        sums: &mut [f64],
    ) {
        let (task, style) = AmpReward::after_step(self, step, rewards);
        sums[0] += task;
        sums[1] += style;
    }
    fn minibatch(
        &mut self,
        members: &[usize],
        comm: &mut dyn Collective,
    ) -> Result<(), LearnError> {
        self.minibatch_step(members, comm)
    }
    fn update(
        &mut self,
        comm: &mut dyn Collective,
        stats: &mut crate::iteration_stats::IterationStats,
    ) -> Result<(), LearnError> {
        let l = AmpReward::update(self, comm)?;
        if !l.total.is_finite() {
            return Err(LearnError::Diverged(format!("the discriminator loss is {}", l.total)));
        }
        (stats.disc_loss, stats.disc_ref, stats.disc_sim) = (l.total, l.mean_ref, l.mean_sim);
        Ok(())
    }
    fn tensors(&self) -> Vec<OwnedTensor> {
        AmpReward::tensors(self)
    }
    fn save_resume(&self) -> Vec<u8> {
        super::resume::save(self)
    }
    fn restore_resume(&mut self, bytes: &[u8]) -> Result<(), String> {
        super::resume::restore(self, bytes)
    }
    fn restart(&mut self) {
        AmpReward::restart(self);
    }
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
    fn as_any_mut(&mut self) -> &mut dyn std::any::Any {
        self
    }
}
