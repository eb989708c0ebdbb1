//! The multi-task environment (`hsi_multi`, `hlc_multi`): TokenHSI's multi-task training (seed
//! 004 §C; modskill-tokenhsi-facts §2.4) — one batch whose environments are split across
//! registered tasks by `[env.multi]` (`mix`), every sub-batch a task's own environment, one
//! shared policy.
//!
//! **Observation** (per environment, width `P + Σ groups + K`): `[shared part P | group_1 |
//! … | group_K | mask K]`. The shared part is every task's first group (TokenHSI: the 222-d
//! proprioception; high-level tasks: the 838 state entries), which all tasks must agree on. Each
//! task group (`env.multi.groups`, default: the tasks' groups in order) holds a task's own
//! observation where that task runs and zeros elsewhere; mask entry k is 1 where group k is
//! active, 0 elsewhere (TokenHSI's task one-hot; a composition task activates several groups).
//! `TaskSpec::token_groups` describes this layout to the token policy.
//!
//! **Actions**: the tasks must share the action space (and, for high-level tasks, the choice
//! table and `steps_per_action`); rows go to the sub-batches in order.
//!
//! **Terms and metrics**: per task t, `t/reward` and `t/<term>` for each of its reward terms,
//! multiplied by N / N_t on t's environments and 0 elsewhere — so their mean over all
//! environments (what the trainer logs) is t's own per-step mean; metrics `t/<metric>` hold t's
//! values on its environments and 0 elsewhere (not rescaled). Info entries likewise prefixed.
//!
//! **Assignment** (`env.multi.assign`): `"fixed"` (default) gives each task a block of
//! environments sized by the mix; `"per_episode"` (TokenHSI's released rule) draws each
//! episode's task from the mix at its reset, every sub-batch then holding a row for every
//! environment with the rows of the other tasks paused (`episodes`).
//!
//! **MuJoCo access** (`mujoco()`: state reads and edits, rendering) is routed to the sub-batch
//! holding environment i. Not multiplexed: `pd_targets` is empty.

mod assign;
pub mod config;
mod episodes;
mod face;
mod saved;

use crate::config::EnvConfig;
use crate::error::{EnvError, bad};
use crate::obs_blocks::ObsBlock;
use crate::task::TaskSpec;
use crate::tasks::multi::config::MultiConfig;
use crate::vec_env::{Env, StepBuffers};
use config::split;
pub use config::{Assign, HLC, HSI, Kind};

/// The `[env.multi]` table.
pub const TABLE: crate::config_table::TableEntry =
    crate::config_table::TableEntry::of::<config::MultiConfig>();

/// One task's sub-batch and where its columns go.
struct Sub {
    env: Box<dyn Env>,
    /// First environment row in the combined batch.
    start: usize,
    /// (source column, destination column, width) of the shared part and each of its groups.
    copies: Vec<(usize, usize, usize)>,
    /// Mask entries set to 1 (indices into the mask block).
    active: Vec<usize>,
    /// First combined term, metric and info column.
    term_at: usize,
    metric_at: usize,
    info_at: usize,
    /// N / N_t (per-episode tasks: N / the environments whose last step ran t).
    scale: f32,
}

/// The multi-task environment (see the module doc).
pub struct MultiEnv {
    spec: TaskSpec,
    subs: Vec<Sub>,
    n: usize,
    mask_at: usize,
    buf: StepBuffers,
    /// `env.multi.assign = "per_episode"`: each environment's task (`episodes`).
    episodes: Option<episodes::Episodes>,
    /// The sub-batches' split by the mix (`task_rows`; the rows themselves under `"fixed"`).
    split_rows: Vec<std::ops::Range<usize>>,
    autoreset: bool,
    /// Per-episode tasks: a mask over the environments (reused).
    mask: Vec<bool>,
    /// Per-episode tasks: one sub-batch's style features (reused).
    style_rows: std::sync::Mutex<Vec<f32>>,
}

/// What the multi-task environment needs of the task registry, handed in by the registry (so
/// this module does not import it).
pub struct Tasks {
    /// Build a registered task's environment.
    pub make: fn(&EnvConfig) -> Result<Box<dyn Env>, EnvError>,
    /// `Some(high_level)` for a registered single task, `Some(..)` also for multi-task ones
    /// (refused separately), `None` for an unknown name.
    pub high_level: fn(&str) -> Option<bool>,
    /// Whether a registered name is itself a multi-task environment.
    pub is_multi: fn(&str) -> bool,
    /// The characters a registered task runs on (empty for an unknown name).
    pub characters: fn(&str) -> &'static [&'static str],
    /// Every registered name (error messages).
    pub names: fn() -> Vec<&'static str>,
}

/// Build the multi-task environment `kind` from `cfg.multi` (registry constructor of
/// `hsi_multi` and `hlc_multi`).
pub fn build(cfg: &EnvConfig, kind: &Kind, tasks: &Tasks) -> Result<Box<dyn Env>, EnvError> {
    Ok(Box::new(MultiEnv::new(cfg, kind, tasks)?))
}

impl MultiEnv {
    /// Build every task's sub-batch (environment counts from `env.multi.mix`; sub-batch k's episode
    /// starts of batch row r seeded with `start_seed(0) + r`) and lay out the combined observation.
    pub fn new(cfg: &EnvConfig, kind: &Kind, reg: &Tasks) -> Result<Self, EnvError> {
        let m = cfg.table::<MultiConfig>();
        let (tasks, mix) = m.effective(kind);
        let counts = split(cfg.num_envs, tasks.len(), &mix)?;
        let per_episode = m.assign == Assign::PerEpisode;
        if per_episode && kind.high_level {
            return Err(bad(
                "env.multi.assign",
                format!(
                    "\"per_episode\" is TokenHSI's rule (hsi_multi); '{}' keeps \"fixed\"",
                    cfg.task
                ),
            )
            .into());
        }
        let base_seed = cfg.start_seed(0);
        let mut envs = Vec::new();
        for (k, (task, &n)) in tasks.iter().zip(&counts).enumerate() {
            let Some(high_level) = (reg.high_level)(task) else {
                return Err(bad(
                    "env.multi.tasks",
                    format!(
                        "'{task}' is not a registered task; registered: {}",
                        (reg.names)().join(", ")
                    ),
                )
                .into());
            };
            if (reg.is_multi)(task) {
                return Err(bad(
                    "env.multi.tasks",
                    format!("'{task}' is itself a multi-task environment"),
                )
                .into());
            }
            let want_hl = kind.high_level;
            if high_level != want_hl {
                let kind = if want_hl {
                    "high-level (heading, circling, …)"
                } else {
                    "TokenHSI (hsi_*)"
                };
                return Err(bad(
                    "env.multi.tasks",
                    format!("'{task}' cannot run in '{}': it takes {kind} tasks", cfg.task),
                )
                .into());
            }
            // the registry's constructor filled in the multi-task environment's character
            let runs_on = (reg.characters)(task);
            if !runs_on.contains(&cfg.character.as_str()) {
                return Err(bad(
                    "env.multi.tasks",
                    format!(
                        "'{task}' cannot run in '{}': it runs on {}, this environment on '{}'",
                        cfg.task,
                        runs_on.join(", "),
                        cfg.character
                    ),
                )
                .into());
            }
            let mut c = cfg.clone();
            c.task = task.clone();
            // row r of the batch draws from the stream `seed + r`, as in one task's batch
            // (per-episode tasks: every sub-batch has every row, k's row r `seed + k·N + r`)
            let offset = if per_episode { k * cfg.num_envs } else { counts[..k].iter().sum() };
            c.num_envs = if per_episode { cfg.num_envs } else { n };
            c.seed = Some(base_seed.wrapping_add(offset as u64));
            envs.push((reg.make)(&c)?);
        }
        let first = envs[0].spec().clone();
        let Some(shared) = first.token_groups.first().cloned() else {
            return Err(bad(
                "env.multi.tasks",
                format!("task '{}' declares no observation groups", first.name),
            )
            .into());
        };
        let mut groups: Vec<(String, usize)> = Vec::new();
        let named = !m.groups.is_empty();
        for e in &envs {
            let s = e.spec();
            if s.token_groups.first() != Some(&shared)
                || s.action_space != first.action_space
                || s.steps_per_action != first.steps_per_action
                || s.choice_labels != first.choice_labels
            {
                return Err(bad(
                    "env.multi.tasks",
                    format!(
                        "'{}' and '{}' do not share the \
                    observed character part, the action space or the choice table",
                        first.name, s.name
                    ),
                )
                .into());
            }
            for g in &s.token_groups[1..] {
                if !groups.iter().any(|x| x.0 == g.0) {
                    groups.push(g.clone());
                }
            }
        }
        if named {
            let mut ordered = Vec::new();
            for name in &m.groups {
                // a group no task fills keeps the width the policy expects: known task widths
                let width = groups
                    .iter()
                    .find(|g| &g.0 == name)
                    .map(|g| g.1)
                    .or_else(|| group_width(cfg, reg, name));
                let Some(w) = width else {
                    return Err(bad(
                        "env.multi.groups",
                        format!("'{name}' is not a task observation group of a registered task"),
                    )
                    .into());
                };
                ordered.push((name.clone(), w));
            }
            if let Some(g) = groups.iter().find(|g| !ordered.iter().any(|o| o.0 == g.0)) {
                return Err(bad(
                    "env.multi.groups",
                    format!("misses '{}', a group of the configured tasks", g.0),
                )
                .into());
            }
            groups = ordered;
        }
        let k = groups.len();
        let offsets: Vec<usize> =
            groups.iter().scan(shared.1, |at, g| Some(std::mem::replace(at, *at + g.1))).collect();
        let mask_at = shared.1 + groups.iter().map(|g| g.1).sum::<usize>();
        let n = cfg.num_envs;
        let (mut term_names, mut metric_names, mut info_names) =
            (Vec::new(), Vec::new(), Vec::new());
        let mut subs = Vec::new();
        let mut start = 0;
        for env in envs {
            let s = env.spec().clone();
            let mut copies = vec![(0, 0, shared.1)];
            let mut active = Vec::new();
            let mut src = shared.1;
            for g in &s.token_groups[1..] {
                let j =
                    groups.iter().position(|x| x.0 == g.0).expect("every task group is laid out");
                copies.push((src, offsets[j], g.1));
                active.push(j);
                src += g.1;
            }
            let (term_at, metric_at, info_at) =
                (term_names.len(), metric_names.len(), info_names.len());
            term_names.push(format!("{}/reward", s.name));
            term_names.extend(s.term_names.iter().map(|t| format!("{}/{t}", s.name)));
            metric_names.extend(s.metric_names.iter().map(|t| format!("{}/{t}", s.name)));
            info_names.extend(s.info_names.iter().map(|t| format!("{}/{t}", s.name)));
            let nt = env.num_envs();
            subs.push(Sub {
                env,
                start,
                copies,
                active,
                term_at,
                metric_at,
                info_at,
                scale: n as f32 / nt as f32,
            });
            if !per_episode {
                start += nt;
            }
        }
        // blocks: the shared part's as the first task declares them, one per task group, the mask
        let mut obs_blocks: Vec<ObsBlock> =
            first.obs_blocks.iter().filter(|b| b.range.end <= shared.1).cloned().collect();
        for (g, &at) in groups.iter().zip(&offsets) {
            obs_blocks.push(ObsBlock::new(g.0.clone(), at..at + g.1));
        }
        obs_blocks.push(ObsBlock::bounded("mask", mask_at..mask_at + k, 0.0, 1.0));
        let mut token_groups = vec![shared];
        token_groups.extend(groups);
        token_groups.push(("mask".to_string(), k));
        let obs_dim = mask_at + k;
        let spec = TaskSpec {
            name: kind.name,
            obs_dim,
            action_space: first.action_space,
            max_episode_steps: subs
                .iter()
                .map(|s| s.env.spec().max_episode_steps)
                .max()
                .unwrap_or(0),
            term_names,
            metric_names,
            info_names,
            steps_per_action: first.steps_per_action,
            choice_labels: first.choice_labels.clone(),
            token_groups,
            obs_blocks,
            ..TaskSpec::default()
        };
        let buf = StepBuffers::for_spec(n, &spec);
        let split_rows = counts
            .iter()
            .scan(0, |at, &c| {
                let first = *at;
                *at += c;
                Some(first..*at)
            })
            .collect();
        let episodes =
            per_episode.then(|| episodes::Episodes::new(&mix, counts.len(), n, base_seed));
        let mut me = Self {
            spec,
            subs,
            n,
            mask_at,
            buf,
            episodes,
            split_rows,
            autoreset: false,
            mask: Vec::with_capacity(n),
            style_rows: Default::default(),
        };
        me.draw_all();
        me.apply_pauses().map_err(|e| bad("env.multi.assign", e.to_string()))?;
        me.gather();
        Ok(me)
    }

    /// Rows `start..start + n_t` of every combined buffer from each sub-batch's buffers
    /// (per-episode tasks: each row's observation and information from its current task's
    /// sub-batch, its step outputs from the sub-batch that ran the step; `episodes`).
    fn gather(&mut self) {
        if let Some(ep) = &self.episodes {
            for (k, s) in self.subs.iter_mut().enumerate() {
                let ran = ep.then.iter().filter(|&&t| t as usize == k).count();
                s.scale = if ran == 0 { 0.0 } else { self.n as f32 / ran as f32 };
            }
        }
        let d = self.spec.obs_dim;
        let (nt, nm, ni) =
            (self.spec.term_names.len(), self.spec.metric_names.len(), self.spec.info_names.len());
        let b = &mut self.buf;
        b.terms.fill(0.0);
        b.metrics.fill(0.0);
        b.info.fill(0.0);
        for (k, s) in self.subs.iter().enumerate() {
            let sb = s.env.buffers();
            let sd = s.env.spec().obs_dim;
            let (st, sm, si) = (
                s.env.spec().term_names.len(),
                s.env.spec().metric_names.len(),
                s.env.spec().info_names.len(),
            );
            for i in 0..s.env.num_envs() {
                let r = s.start + i;
                let (now, then) = match &self.episodes {
                    None => (true, true),
                    Some(ep) => (ep.now[r] as usize == k, ep.then[r] as usize == k),
                };
                for (obs, src, here) in
                    [(&mut b.obs, &sb.obs, now), (&mut b.final_obs, &sb.final_obs, then)]
                {
                    if !here {
                        continue;
                    }
                    let row = &mut obs[r * d..(r + 1) * d];
                    row.fill(0.0);
                    for &(from, to, w) in &s.copies {
                        row[to..to + w].copy_from_slice(&src[i * sd + from..i * sd + from + w]);
                    }
                    for &j in &s.active {
                        row[self.mask_at + j] = 1.0;
                    }
                }
                if now {
                    b.info[r * ni + s.info_at..r * ni + s.info_at + si]
                        .copy_from_slice(&sb.info[i * si..(i + 1) * si]);
                }
                if !then {
                    continue;
                }
                b.reward[r] = sb.reward[i];
                b.terminated[r] = sb.terminated[i];
                b.truncated[r] = sb.truncated[i];
                b.unstable[r] = sb.unstable[i];
                b.final_mask[r] = sb.final_mask[i];
                let t = &mut b.terms[r * nt + s.term_at..r * nt + s.term_at + 1 + st];
                t[0] = sb.reward[i] * s.scale;
                for (o, &v) in t[1..].iter_mut().zip(&sb.terms[i * st..(i + 1) * st]) {
                    *o = v * s.scale;
                }
                b.metrics[r * nm + s.metric_at..r * nm + s.metric_at + sm]
                    .copy_from_slice(&sb.metrics[i * sm..(i + 1) * sm]);
            }
        }
    }

    /// The sub-batch holding environment `i` and `i`'s index in it.
    fn locate(&self, i: usize) -> (usize, usize) {
        if let Some(ep) = &self.episodes {
            return (ep.now[i] as usize, i);
        }
        let k = self.subs.iter().rposition(|s| s.start <= i).unwrap_or(0);
        (k, i - self.subs[k].start)
    }
}

/// The task observation width of group `name` (a registered task's own group) when no
/// configured task fills it: built from a one-environment instance of that task.
fn group_width(cfg: &EnvConfig, reg: &Tasks, name: &str) -> Option<usize> {
    (reg.high_level)(name)?;
    let mut c = cfg.clone();
    c.task = name.to_string();
    c.num_envs = 1;
    let env = (reg.make)(&c).ok()?;
    env.spec().token_groups.iter().find(|g| g.0 == name).map(|g| g.1)
}
