//! The multi-task environment's moves under per-episode tasks (`env.multi.assign =
//! "per_episode"`, [`super::episodes`]): drawing tasks, pausing and resuming rows in the
//! sub-batches, resetting and closing episodes where they run.

use super::MultiEnv;

impl MultiEnv {
    /// Draw a new task for every environment in `mask` (in environment order), moving it between
    /// sub-batches (pause in the old task's, resume in the new one's); returns whether any moved.
    /// The environments still need a reset in their new task.
    pub(super) fn redraw(&mut self, mask: &[bool]) -> bool {
        let Some(ep) = self.episodes.as_mut() else { return false };
        let mut moved = false;
        for (r, _) in mask.iter().enumerate().filter(|m| *m.1) {
            let (old, new) = (ep.now[r] as usize, ep.draw());
            if new as usize != old {
                self.subs[old].env.set_paused(r, true).expect(PAUSE);
                self.subs[new as usize].env.set_paused(r, false).expect(PAUSE);
                ep.now[r] = new;
                moved = true;
            }
        }
        moved
    }

    /// Per-episode rule: reset the environments in `mask` in the sub-batches of their current
    /// tasks; with `settle` their step outputs now come from there too (not after an autoreset,
    /// whose step outputs are the finished episode's).
    pub(super) fn reset_in_place(&mut self, mask: &[bool], settle: bool) {
        let Some(ep) = self.episodes.as_mut() else { return };
        for (k, s) in self.subs.iter_mut().enumerate() {
            if select(&mut ep.scratch, mask, &ep.now, k) {
                s.env.reset_envs(&ep.scratch);
            }
        }
        if settle {
            for (r, _) in mask.iter().enumerate().filter(|m| *m.1) {
                ep.then[r] = ep.now[r];
            }
        }
    }

    /// Per-episode rule: close the episodes of the environments in `mask` in the sub-batches that
    /// ran them.
    pub(super) fn end_in_place(&mut self, mask: &[bool]) {
        let Some(ep) = self.episodes.as_mut() else { return };
        for (k, s) in self.subs.iter_mut().enumerate() {
            if select(&mut ep.scratch, mask, &ep.then, k) {
                s.env.end_episodes(&ep.scratch);
            }
        }
    }

    /// Pause every environment in every sub-batch but its current task's (after the tasks were
    /// drawn anew or restored). Errors when a sub-batch cannot pause (checked at construction).
    pub(super) fn apply_pauses(&mut self) -> Result<(), crate::error::EnvError> {
        let Some(ep) = self.episodes.as_ref() else { return Ok(()) };
        for (k, s) in self.subs.iter_mut().enumerate() {
            for (r, &t) in ep.now.iter().enumerate() {
                s.env.set_paused(r, t as usize != k)?;
            }
        }
        Ok(())
    }

    /// Draw every environment's task anew (construction, `reset_all`): no pause or reset yet.
    pub(super) fn draw_all(&mut self) {
        if let Some(ep) = self.episodes.as_mut() {
            for r in 0..ep.now.len() {
                ep.now[r] = ep.draw();
            }
            ep.then.clone_from(&ep.now);
        }
    }
}

/// `out` = `mask` ∧ (`task` = k) per environment; whether any is set.
fn select(out: &mut [bool], mask: &[bool], task: &[u16], k: usize) -> bool {
    let mut any = false;
    for ((o, &m), &t) in out.iter_mut().zip(mask).zip(task) {
        *o = m && t as usize == k;
        any |= *o;
    }
    any
}

/// The sub-batches are the registry's environments, which pause (checked when the multi-task
/// environment is built, by `apply_pauses`).
const PAUSE: &str = "every sub-batch pauses environments (checked at construction)";
