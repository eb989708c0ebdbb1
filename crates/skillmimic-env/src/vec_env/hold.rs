//! Held actions: a task declaring `steps_per_action = k > 1` (the high-level tasks of skill
//! reuse) has each action applied for `k` physics steps (the task turns it into PD targets
//! before every one of them, e.g. with a frozen skill policy on the current observation).
//!
//! The caller sees one step per action (the buffers of [`Hold::out`]). An environment whose
//! episode ends inside the transition is simulated to the transition's end and reset after it;
//! what counts depends on the task's `hold_through_end`:
//! * `true` (the released SkillMimic high-level loop): every physics step counts. Reward and
//!   terms are the mean over all of them (the steps after an episode's end included); terminated
//!   / truncated are set when any step set them (terminated wins: the two stay exclusive);
//!   observation, metrics and information are the last step's; unstable: any step.
//! * `false`: the counted steps are those up to and including the first that ends the episode.
//!   Reward and terms are their mean; observation, metrics, information and flags are the last
//!   counted step's (for a finished environment, its terminal observation); unstable: any
//!   counted step. The transition stops early when every environment has finished.

use super::{StepBuffers, copy_row};
use crate::task::TaskSpec;

/// The aggregation state and the buffers the caller sees.
pub(super) struct Hold {
    pub(super) out: StepBuffers,
    /// Physics steps per action.
    steps: usize,
    /// Physics steps counted in the current transition, per environment.
    counted: Vec<usize>,
    done: Vec<bool>,
    /// The task's `hold_through_end`.
    through_end: bool,
}

impl Hold {
    pub(super) fn new(n: usize, spec: &TaskSpec) -> Self {
        Self {
            out: StepBuffers::for_spec(n, spec),
            steps: spec.steps_per_action,
            counted: vec![0; n],
            done: vec![false; n],
            through_end: spec.hold_through_end,
        }
    }

    /// After environment `i` was reset: its observation and information rows, and its flags
    /// cleared when `clear_flags`.
    pub(super) fn after_reset(
        &mut self,
        buf: &StepBuffers,
        i: usize,
        d: usize,
        ni: usize,
        clear_flags: bool,
    ) {
        copy_row(&mut self.out.obs, &buf.obs, i, d);
        copy_row(&mut self.out.info, &buf.info, i, ni);
        if clear_flags {
            self.out.terminated[i] = 0;
            self.out.truncated[i] = 0;
        }
    }

    /// Physics steps per action.
    pub(super) fn steps(&self) -> usize {
        self.steps
    }

    /// Start a transition.
    pub(super) fn begin(&mut self) {
        self.counted.fill(0);
        self.done.fill(false);
        self.out.reward.fill(0.0);
        self.out.terms.fill(0.0);
        self.out.unstable.fill(0);
        self.out.terminated.fill(0);
        self.out.truncated.fill(0);
    }

    /// Count physics step `b` of the transition (`last`: its final one); `widths` = (obs, terms,
    /// info, metrics). Returns whether every environment has finished.
    pub(super) fn accumulate(&mut self, b: &StepBuffers, widths: [usize; 4], last: bool) -> bool {
        let [d, nt, ni, nm] = widths;
        let out = &mut self.out;
        for i in 0..self.done.len() {
            if self.done[i] && !self.through_end {
                continue;
            }
            self.counted[i] += 1;
            out.reward[i] += b.reward[i];
            for k in 0..nt {
                out.terms[i * nt + k] += b.terms[i * nt + k];
            }
            out.unstable[i] |= b.unstable[i];
            if self.through_end {
                out.terminated[i] |= b.terminated[i];
                let truncated = (out.truncated[i] | b.truncated[i]) != 0;
                out.truncated[i] = u8::from(truncated && out.terminated[i] == 0);
            } else {
                out.terminated[i] = b.terminated[i];
                out.truncated[i] = b.truncated[i];
            }
            self.done[i] |= b.done(i);
            // the rows of the transition's last counted step only
            if last || (self.done[i] && !self.through_end) {
                copy_row(&mut out.obs, &b.obs, i, d);
                copy_row(&mut out.metrics, &b.metrics, i, nm);
                copy_row(&mut out.info, &b.info, i, ni);
            }
        }
        !self.through_end && self.done.iter().all(|&x| x)
    }

    /// End a transition: rewards and terms become means over the counted steps.
    pub(super) fn finish(&mut self, nt: usize) {
        for i in 0..self.counted.len() {
            let c = self.counted[i].max(1) as f32;
            self.out.reward[i] /= c;
            for k in 0..nt {
                self.out.terms[i * nt + k] /= c;
            }
        }
    }
}
