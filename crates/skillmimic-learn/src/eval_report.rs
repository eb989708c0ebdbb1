//! The evaluation's report ([`EvalReport`], the `eval` command's JSON, with a [`SkillReport`]
//! per skill) and the per-episode bookkeeping that fills it: a running episode's success
//! trackers and sums ([`EpisodeTracker`]) and the finished episodes per skill
//! ([`EpisodeTally`]): NR, lengths, fall rates and fall frames, success rates, distinct
//! trajectories. [`crate::eval`] runs the episodes.

use std::collections::BTreeMap;

use serde::Serialize;
use skillmimic_env::metrics::{FrameState, V1Success, V2Success, skill_kind};

/// Per-skill results.
#[derive(Clone, Debug, Default, Serialize)]
pub struct SkillReport {
    pub episodes: usize,
    /// Mean episode length (steps).
    pub mean_length: f64,
    /// Mean per-step reward of the skill's episodes.
    pub nr: f64,
    /// Fraction of episodes that ended early (fall).
    pub fall_rate: f64,
    /// SkillMimic's rules applied to the episodes as played (a project measure, not the paper's
    /// success rate: the dribble fraction divides by the frames played and the other rules are
    /// judged at the episode's end; the paper's 10-s trials are
    /// [`crate::eval_skillmimic::evaluate_skillmimic`]), mean over episodes; null if the skill has
    /// no rule.
    pub v1_score: Option<f64>,
    /// SkillMimic-V2 success rate (the rule holds at the episode's end and the episode did not
    /// end in a fall); null if the skill has no rule.
    pub v2_success_rate: Option<f64>,
    /// Distinct trajectories among the episodes (episodes whose root and ball positions agree at
    /// every step are one trajectory counted once here): equal to `episodes` when every episode
    /// is a distinct trial.
    pub distinct_episodes: usize,
    /// Where in the clip the skill's terminated episodes (falls) ended: quartiles of the clip
    /// frame (the reference frame index, 0 = the clip's first frame) at termination; null when
    /// no episode fell or the task reports no reference frame. The evidence of *where* a policy
    /// fails a skill (a layup that falls at take-off, a pickup that falls when it bends down).
    pub fall_frames: Option<FrameQuartiles>,
}

/// Evaluation results (the `eval` command's JSON).
#[derive(Clone, Debug, Default, Serialize)]
pub struct EvalReport {
    pub episodes: usize,
    pub seed: u64,
    pub deterministic: bool,
    /// Acc in percent (ball error < 0.2 m ∧ body error < 0.1 m ∧ contact graph correct).
    pub acc_percent: f64,
    /// Acc of a kinematic replay of the evaluated clips, scored the same way: the highest Acc a
    /// policy can reach (the clips' contact labels and the simulated contact graph disagree in
    /// some frames of the reference motion itself). Set by the `eval` command; null otherwise.
    pub acc_ceiling_percent: Option<f64>,
    pub e_b_mpjpe_mm: f64,
    pub e_o_mpjpe_mm: f64,
    pub e_cg: f64,
    /// Mean per-step reward over finished episodes.
    pub nr: f64,
    pub mean_episode_length: f64,
    pub fall_rate: f64,
    pub per_skill: BTreeMap<String, SkillReport>,
}

/// Quartiles of a set of clip frames (nearest rank: the value at index round(q · (n − 1)) of the
/// sorted frames, so every field is a frame that occurred).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct FrameQuartiles {
    /// How many frames were summarised (the falls).
    pub count: usize,
    pub min: usize,
    pub q1: usize,
    pub median: usize,
    pub q3: usize,
    pub max: usize,
}

impl FrameQuartiles {
    /// The quartiles of `frames` (any order); `None` when it is empty.
    pub fn of(frames: &[usize]) -> Option<Self> {
        let mut v = frames.to_vec();
        v.sort_unstable();
        let at = |q: f64| v[(q * (v.len() - 1) as f64).round() as usize];
        (!v.is_empty()).then(|| Self {
            count: v.len(),
            min: v[0],
            q1: at(0.25),
            median: at(0.5),
            q3: at(0.75),
            max: v[v.len() - 1],
        })
    }
}

/// One environment's running episode: the success trackers of its skill (none when the skill
/// has no rule) and its reward and step sums.
#[derive(Clone, Debug)]
pub struct EpisodeTracker {
    v1: Option<V1Success>,
    v2: Option<V2Success>,
    steps: usize,
    reward: f64,
    /// Hash of the root and ball positions of every step (FNV-1a over their bits).
    fingerprint: u64,
}

impl EpisodeTracker {
    /// A fresh episode scored with the rules of `skill` (the condition's skill: the target skill
    /// of a transition run); `target_height` (m) is the shot/layup target ball height.
    pub fn new(skill: u32, target_height: f64) -> Self {
        let kind = skill_kind(skill);
        Self {
            v1: kind.map(|k| V1Success::new(k, target_height)),
            v2: kind.map(|k| V2Success::new(k, target_height)),
            steps: 0,
            reward: 0.0,
            fingerprint: 0xcbf2_9ce4_8422_2325,
        }
    }

    /// Feed the state after the episode's next step and that step's reward.
    pub fn step(&mut self, fs: &FrameState, reward: f32) {
        if let Some(v) = self.v1.as_mut() {
            v.update(fs);
        }
        if let Some(v) = self.v2.as_mut() {
            v.update(self.steps, fs);
        }
        self.steps += 1;
        self.reward += reward as f64;
        for x in fs.root_pos.iter().chain(&fs.ball_pos) {
            self.fingerprint = (self.fingerprint ^ x.to_bits()).wrapping_mul(0x100_0000_01b3);
        }
    }

    /// Steps fed so far.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// SkillMimic-V2 success of the episode ending now (`fell`: it ended by termination); `None`
    /// when the skill has no rule. A fall ends the attempt: success must be sustained to the end
    /// (P2: "the skill sustained for 10 s"), not latched before the fall.
    pub fn v2_success(&self, fell: bool) -> Option<bool> {
        self.v2.as_ref().map(|v| v.success() && !fell)
    }
}

/// Per-skill sums of finished episodes.
#[derive(Clone, Debug, Default)]
struct SkillSums {
    episodes: usize,
    len: f64,
    reward: f64,
    steps: f64,
    falls: usize,
    v1: Vec<f64>,
    v2: Vec<f64>,
    trajectories: std::collections::BTreeSet<u64>,
    fall_frames: Vec<usize>,
}

/// Finished episodes, per skill and in total; [`EpisodeTally::write_into`] turns them into the
/// report's NR (Σ rewards / Σ steps of the finished episodes, i.e. step-weighted), mean lengths,
/// fall rates and success rates.
#[derive(Clone, Debug, Default)]
pub struct EpisodeTally {
    per: BTreeMap<u32, SkillSums>,
    episodes: usize,
    total_reward: f64,
    total_steps: f64,
    total_len: f64,
    falls: usize,
}

impl EpisodeTally {
    /// Count the finished episode `tr` under `skill` (`fell`: it ended by termination).
    pub fn finish(&mut self, skill: u32, tr: &EpisodeTracker, fell: bool) {
        self.finish_at(skill, tr, fell, None);
    }

    /// [`Self::finish`] with the clip frame the episode ended at (the reference frame index;
    /// `None` where the task reports none), kept for the skill's fall frames when `fell`.
    pub fn finish_at(&mut self, skill: u32, tr: &EpisodeTracker, fell: bool, frame: Option<usize>) {
        let e = self.per.entry(skill).or_default();
        if let (true, Some(f)) = (fell, frame) {
            e.fall_frames.push(f);
        }
        e.episodes += 1;
        e.len += tr.steps as f64;
        e.reward += tr.reward;
        e.steps += tr.steps as f64;
        e.falls += usize::from(fell);
        e.trajectories.insert(tr.fingerprint);
        if let Some(v) = &tr.v1 {
            e.v1.push(v.score());
        }
        if let Some(ok) = tr.v2_success(fell) {
            e.v2.push(f64::from(u8::from(ok)));
        }
        self.episodes += 1;
        self.total_reward += tr.reward;
        self.total_steps += tr.steps as f64;
        self.total_len += tr.steps as f64;
        self.falls += usize::from(fell);
    }

    /// Finished episodes counted so far.
    pub fn episodes(&self) -> usize {
        self.episodes
    }

    /// Write `episodes`, `nr`, `mean_episode_length`, `fall_rate` and `per_skill` of `rep`.
    pub fn write_into(self, rep: &mut EvalReport) {
        let mean = |v: &[f64]| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
        rep.episodes = self.episodes;
        rep.nr = self.total_reward / self.total_steps.max(1.0);
        rep.mean_episode_length = self.total_len / self.episodes.max(1) as f64;
        rep.fall_rate = self.falls as f64 / self.episodes.max(1) as f64;
        for (skill, e) in self.per {
            rep.per_skill.insert(
                format!("{skill:03}"),
                SkillReport {
                    episodes: e.episodes,
                    mean_length: e.len / e.episodes as f64,
                    nr: e.reward / e.steps.max(1.0),
                    fall_rate: e.falls as f64 / e.episodes as f64,
                    v1_score: mean(&e.v1),
                    v2_success_rate: mean(&e.v2),
                    distinct_episodes: e.trajectories.len(),
                    fall_frames: FrameQuartiles::of(&e.fall_frames),
                },
            );
        }
    }
}
