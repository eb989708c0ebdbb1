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
}
