//! Held actions: a task declaring `steps_per_action = k > 1` (the high-level tasks of skill
//! reuse) has each action applied for `k` physics steps (the task turns it into PD targets
//! before every one of them, e.g. with a frozen skill policy on the current observation).
//!
//! The caller sees one step per action (the buffers of [`Hold::out`]):
//! * reward and terms: the mean over the transition's counted physics steps — those up to and
//!   including the first that ends the episode;
//! * observation, metrics and information: those of the last counted physics step (for an
//!   environment that finished inside the transition, its terminal observation);
//! * terminated / truncated: those of the last counted step; unstable: any counted step;
//! * an environment that finishes inside the transition is simulated for the remaining physics
//!   steps and that part is discarded; it is reset after the transition (the released
//!   SkillMimic code also steps the ended episode to the transition's end and resets it then,
//!   but counts those steps' rewards in the transition's mean);
//! * the transition stops early when every environment has finished.

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
}

impl Hold {
    pub(super) fn new(n: usize, spec: &TaskSpec) -> Self {
        Self {
            out: StepBuffers::for_spec(n, spec),
            steps: spec.steps_per_action,
            counted: vec![0; n],
            done: vec![false; n],
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
    }

    /// Count physics step `b` of the transition (`last`: its final one); `widths` = (obs, terms,
    /// info, metrics). Returns whether every environment has finished.
    pub(super) fn accumulate(&mut self, b: &StepBuffers, widths: [usize; 4], last: bool) -> bool {
        let [d, nt, ni, nm] = widths;
        let out = &mut self.out;
        for i in 0..self.done.len() {
            if self.done[i] {
                continue;
            }
            self.counted[i] += 1;
            out.reward[i] += b.reward[i];
            for k in 0..nt {
                out.terms[i * nt + k] += b.terms[i * nt + k];
            }
            out.terminated[i] = b.terminated[i];
            out.truncated[i] = b.truncated[i];
            out.unstable[i] |= b.unstable[i];
            self.done[i] = b.done(i);
            // the rows of the transition's last counted step only
            if self.done[i] || last {
                copy_row(&mut out.obs, &b.obs, i, d);
                copy_row(&mut out.metrics, &b.metrics, i, nm);
                copy_row(&mut out.info, &b.info, i, ni);
            }
        }
        self.done.iter().all(|&x| x)
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
