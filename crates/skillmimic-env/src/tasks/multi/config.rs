//! `[env.multi]`: the multi-task environment (`hsi_multi`, `hlc_multi`; TokenHSI's multi-task
//! training, seed 004 §C; modskill-tokenhsi-facts §2.4).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Which tasks share one batch, in what proportion, and the token layout of the observation.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct MultiConfig {
    /// Registered task names, one sub-batch each (all on the same character, one action space).
    /// Empty (default): `hsi_multi` trains TokenHSI's four tasks (follow, sit, carry, climb),
    /// `hlc_multi` heading and circling.
    pub tasks: Vec<String>,
    /// Share of the environments per task (normalised; largest remainder, at least one each).
    /// Empty (default): TokenHSI's mix follow 0.1, sit 0.3, carry 0.3, climb 0.3 for the default
    /// `hsi_multi` tasks, equal shares otherwise.
    #[schemars(extend("items" = {"type": "number", "format": "double", "exclusiveMinimum": 0}))]
    pub mix: Vec<f64>,
    /// Task observation groups of the observation, in column order (each task's own group is
    /// named after the task). Empty = every group of `tasks`, in order of first appearance. Name
    /// more groups than the tasks fill to keep a trained policy's layout (evaluating one task
    /// of a multi-task policy; adaptation to a new task keeps the old groups first).
    pub groups: Vec<String>,
    /// How environments get their tasks. `"fixed"` (default): each task keeps a block of
    /// environments sized by `mix`, so every rollout holds each task's share of the samples
    /// exactly. `"per_episode"`: TokenHSI's released rule (`_reset_task_indicator`), each episode's
    /// task drawn from `mix` when the environment resets, so a task whose episodes last longer
    /// gets more of the samples; every task's batch then keeps a row for every environment and
    /// pauses the rows of the environments running another task (`hsi_multi` only).
    pub assign: Assign,
}

/// `env.multi.assign`: how the environments of a multi-task batch get their tasks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Assign {
    /// A fixed block of environments per task, sized by the mix (largest remainder).
    #[default]
    Fixed,
    /// The task drawn from the mix at every reset (TokenHSI's released multi-task training).
    PerEpisode,
}

impl crate::config_table::TaskConfig for MultiConfig {
    const KEY: &'static str = "multi";
    const DOC: &'static str = "Options of the multi-task environments (`hsi_multi`, `hlc_multi`).";
}

/// A registered multi-task environment: its name, the kind of tasks it splits its batch
/// across, and its defaults when `[env.multi]` names no tasks.
pub struct Kind {
    pub name: &'static str,
    /// High-level tasks (over a frozen skill policy) rather than low-level ones.
    pub high_level: bool,
    pub default_tasks: &'static [&'static str],
    /// Empty: equal shares.
    pub default_mix: &'static [f64],
}

/// `hsi_multi`: TokenHSI's four tasks with its mix (follow 0.1, sit 0.3, carry 0.3, climb 0.3).
pub const HSI: Kind = Kind {
    name: "hsi_multi",
    high_level: false,
    default_tasks: &["hsi_follow", "hsi_sit", "hsi_carry", "hsi_climb"],
    default_mix: &[0.1, 0.3, 0.3, 0.3],
};

/// `hlc_multi`: heading and circling, equal shares.
pub const HLC: Kind = Kind {
    name: "hlc_multi",
    high_level: true,
    default_tasks: &["heading", "circling"],
    default_mix: &[],
};

impl MultiConfig {
    /// The tasks and mix in effect for a multi-task environment whose defaults are `kind`'s.
    pub fn effective(&self, kind: &Kind) -> (Vec<String>, Vec<f64>) {
        if !self.tasks.is_empty() {
            return (self.tasks.clone(), self.mix.clone());
        }
        let mix = if self.mix.is_empty() { kind.default_mix.to_vec() } else { self.mix.clone() };
        (kind.default_tasks.iter().map(|s| s.to_string()).collect(), mix)
    }
}

/// Environments per task for `n` environments and weights `mix` (empty = equal): largest
/// remainder, each task at least one. Errors name the field.
pub fn split(n: usize, tasks: usize, mix: &[f64]) -> Result<Vec<usize>, crate::error::ConfigError> {
    use crate::error::bad;
    let w: Vec<f64> = if mix.is_empty() { vec![1.0; tasks] } else { mix.to_vec() };
    if w.len() != tasks {
        return Err(bad("env.multi.mix", format!("has {} weights for {tasks} tasks", w.len())));
    }
    if w.iter().any(|&x| !(x.is_finite() && x > 0.0)) {
        return Err(bad("env.multi.mix", format!("is {w:?}; expected positive finite weights")));
    }
    if n < tasks {
        return Err(bad(
            "env.num_envs",
            format!("is {n}; the multi-task environment needs at least one per task ({tasks})"),
        ));
    }
    let total: f64 = w.iter().sum();
    let spare = n - tasks;
    let exact: Vec<f64> = w.iter().map(|x| x / total * spare as f64).collect();
    let mut counts: Vec<usize> = exact.iter().map(|x| x.floor() as usize).collect();
    let mut order: Vec<usize> = (0..tasks).collect();
    order.sort_by(|&a, &b| {
        (exact[b] - exact[b].floor()).total_cmp(&(exact[a] - exact[a].floor())).then(a.cmp(&b))
    });
    let left = spare - counts.iter().sum::<usize>();
    for &k in order.iter().take(left) {
        counts[k] += 1;
    }
    Ok(counts.into_iter().map(|c| c + 1).collect())
}

#[cfg(test)]
mod tests {
    #[test]
    fn split_follows_the_mix() {
        assert_eq!(super::split(64, 4, &[0.1, 0.3, 0.3, 0.3]).unwrap(), vec![7, 19, 19, 19]);
        assert_eq!(super::split(4, 4, &[0.1, 0.3, 0.3, 0.3]).unwrap(), vec![1, 1, 1, 1]);
        assert_eq!(super::split(10, 2, &[]).unwrap(), vec![5, 5]);
        assert!(super::split(3, 4, &[]).unwrap_err().to_string().contains("env.num_envs"));
        assert!(super::split(8, 2, &[1.0]).unwrap_err().to_string().contains("env.multi.mix"));
    }
}
