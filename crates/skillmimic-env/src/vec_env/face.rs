//! [`Env`]: the object-safe face of a batched environment, used by the learner, evaluation and
//! the Python package for any registered task (`Box<dyn Env>` from
//! [`crate::registry::make`]).

use std::any::Any;

use skillmimic_sim::MjBatch;

use super::StepBuffers;
use crate::error::EnvError;
use crate::task::TaskSpec;

/// A batched environment of any task.
pub trait Env: Send + Sync {
    /// The task's sizes and names.
    fn spec(&self) -> &TaskSpec;
    fn num_envs(&self) -> usize;
    fn obs_dim(&self) -> usize {
        self.spec().obs_dim
    }
    fn act_dim(&self) -> usize {
        self.spec().act_dim()
    }
    fn buffers(&self) -> &StepBuffers;
    fn step(&mut self, actions: &[f32]) -> Result<(), EnvError>;
    fn reset_all(&mut self, seed: Option<u64>);
    fn reset_envs(&mut self, mask: &[bool]);
    fn reset_done(&mut self);
    /// Close the episodes of the environments in `mask` without resetting them: the task's
    /// end-of-episode bookkeeping (SkillMimic-V2's ATS statistics), as `reset_done` and SAME_STEP
    /// autoreset do before a reset. For callers that reset through
    /// [`reset_envs`](Env::reset_envs) (gymnasium's NEXT_STEP and DISABLED modes).
    fn end_episodes(&mut self, _mask: &[bool]) {}
    fn set_autoreset(&mut self, on: bool);
    fn refresh_observations(&mut self);
    /// Raw MuJoCo access and the state read-out, whatever the character (rendering, recording,
    /// state edits).
    fn mujoco(&self) -> &dyn MjBatch;
    fn mujoco_mut(&mut self) -> &mut dyn MjBatch;
    /// Overwrite environment `i`'s task information entries (`TaskSpec::info_names`; the
    /// high-level tasks: move the goal, e.g. in interactive play) and recompute its observation.
    fn set_task_info(&mut self, _i: usize, _values: &[f32]) -> Result<(), EnvError> {
        Err(EnvError::Unsupported(format!(
            "task '{}' has no settable task information",
            self.spec().name
        )))
    }
    /// PD targets (`N × dofs`, [−1, 1]) a task's action transform gave in the last simulation
    /// step (high-level tasks: the frozen skill policy's actions); empty when the actions are the
    /// targets.
    fn pd_targets(&self) -> &[f32];
    /// The tasks of a multi-task environment with their environment rows (empty: one task); the
    /// motion prior keeps one discriminator per entry. Where environments change task between
    /// episodes ([`row_tasks`](Env::row_tasks) not empty) the ranges are the split of the
    /// environments by the tasks' shares (their lengths are the shares; `row_tasks` says which
    /// task each environment runs).
    fn task_rows(&self) -> Vec<(String, std::ops::Range<usize>)> {
        Vec::new()
    }
    /// The task index (into [`task_rows`](Env::task_rows)) each environment runs now, for a
    /// multi-task environment whose environments change task between episodes
    /// (`env.multi.assign = "per_episode"`); empty where each task keeps its rows.
    fn row_tasks(&self) -> &[u16] {
        &[]
    }
    /// Pause (`true`) or resume (`false`) environment `i`: a paused environment is not simulated
    /// and never done (`vec_env::pause`); where offered.
    fn set_paused(&mut self, _i: usize, _paused: bool) -> Result<(), EnvError> {
        Err(EnvError::Unsupported(format!(
            "task '{}': this environment cannot pause an environment",
            self.spec().name
        )))
    }
    /// Environment `i`'s episode fields in [`TaskSpec::episode_names`] order (empty when the
    /// task declares none). `i` < `num_envs()`.
    fn episode_info(&self, _i: usize) -> Vec<i64> {
        Vec::new()
    }
    /// The motion library the task plays, where it loads one.
    fn library(&self) -> Option<&std::sync::Arc<skillmimic_motion::MotionLibrary>> {
        None
    }
    /// The reference state of frame `frame` of clip `clip` (the `clip` and `ref_frame` episode
    /// fields), where the task plays reference clips ([`crate::Task::reference_state`]).
    fn reference_state(&self, _clip: usize, _frame: usize) -> Option<skillmimic_sim::ResetState> {
        None
    }
    /// Environment `i`'s SkillMimic-V2 history window (`k × 316`), where the task keeps one.
    fn history_window(&self, _i: usize) -> Option<Vec<f32>> {
        None
    }
    /// The task's visual markers for an information row (`spec().info_names` order).
    fn markers(&self, _info: &[f32]) -> Vec<crate::markers::Marker> {
        Vec::new()
    }
    /// Width of the per-frame style features of the task's motion prior computed from the
    /// simulation state (0: none; TokenHSI: the released discriminator's 129 features).
    fn style_dim(&self) -> usize {
        0
    }
    /// Every environment's style features (`num_envs × style_dim`) from its current simulation
    /// state: after a step, the state the step ended in (before any reset of a finished episode).
    /// A paused environment's entries are left as they are.
    fn style_features(&self, _out: &mut [f32]) {}
    /// Everything later steps depend on — simulation state, every environment's episode (task
    /// slot), the streams of episode starts, the output buffers, the task's own state — encoded
    /// for [`Env::restore_state`] (an exact resume continues bit for bit; [`super::saved`]).
    /// Whether [`Env::save_state`] is offered (the registry's environments; an environment
    /// written elsewhere that does not offer it is trained with checkpoints whose resumes start
    /// fresh episodes).
    fn can_save_state(&self) -> bool {
        false
    }
    fn save_state(&self) -> Result<Vec<u8>, EnvError> {
        Err(EnvError::Unsupported(format!(
            "task '{}': this environment cannot save its state",
            self.spec().name
        )))
    }
    /// Restore what [`Env::save_state`] wrote for an environment of the same task, scene and
    /// size; anything else is an error naming the difference. The checks run before anything is
    /// changed, except in a multi-task environment whose later sub-batch fails them: reset an
    /// environment whose restore failed ([`Env::reset_all`]) before using it.
    fn restore_state(&mut self, _bytes: &[u8]) -> Result<(), EnvError> {
        Err(EnvError::Unsupported(format!(
            "task '{}': this environment cannot restore a saved state",
            self.spec().name
        )))
    }
    /// Downcast to the concrete `VecEnv<T>` (task-specific accessors).
    fn as_any(&self) -> &dyn Any;
    fn as_any_mut(&mut self) -> &mut dyn Any;
}
