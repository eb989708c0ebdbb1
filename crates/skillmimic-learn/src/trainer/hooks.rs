//! Hooks on the whole trainer between iterations (the runner calls them; active skill learning
//! is one, [`crate::active::Rounds`]).

use super::state::Trainer;
use crate::error::LearnError;

/// Work on the whole trainer between iterations (after an iteration is logged, before its
/// checkpoint is written; not after the last one). Each hook decides itself at which iterations
/// it acts.
pub trait IterationHook {
    /// Act on the trainer after its iteration `t.progress.iteration`.
    fn after_iteration(&mut self, t: &mut Trainer) -> Result<(), LearnError>;

    /// Act on a resumed trainer before its first iteration: the work of the checkpoint's
    /// iteration that the checkpoint was written without (an interrupt's checkpoint and the last
    /// iteration's are written without running the hooks). Default: nothing.
    fn on_resume(&mut self, _t: &mut Trainer) -> Result<(), LearnError> {
        Ok(())
    }
}
