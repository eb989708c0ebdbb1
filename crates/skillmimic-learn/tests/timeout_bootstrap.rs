//! The trainer's time-out bootstrap (reference-facts §7.4): a step whose episode was truncated
//! (time limit) stores next value V(terminal observation), a step whose episode terminated (fall)
//! stores 0, a step inside an episode stores the value of the following step, and the rollout's
//! last step bootstraps on the observation it returned.
//!
//! The episode ends are scripted: a wrapper around the real imitation environment replaces its
//! done flags with a fixed schedule (each environment's flags set at known steps) and records
//! the observation every step returned, so the expected next values can be recomputed with the
//! critic outside the trainer.

use std::any::Any;

use skillmimic_core::shared_data::workspace_root;
use skillmimic_env::{Env, EnvError, StepBuffers, TaskSpec, registry};
use skillmimic_learn::config::TrainConfig;
use skillmimic_learn::policy::InferenceBuffers;
use skillmimic_learn::trainer::Trainer;
use skillmimic_sim::MjBatch;

/// How environment `i`'s episode ends after step `t` (0-based step of the rollout), if it does.
#[derive(Clone, Copy, Debug, PartialEq)]
enum End {
    Truncated,
    Terminated,
}

/// The schedule: env 0 is truncated at step 3 and terminated at step 9, env 1 the other way
/// round, env 2 terminated at steps 5 and 6 (two episodes back to back); the others run through.
fn scripted_end(t: usize, i: usize) -> Option<End> {
    match (i, t) {
        (0, 3) | (1, 9) => Some(End::Truncated),
        (0, 9) | (1, 3) | (2, 5) | (2, 6) => Some(End::Terminated),
        _ => None,
    }
}

/// The real environment with scripted done flags; `after` holds the observation returned by
/// every step, `[t][env][obs_dim]`.
struct Scripted {
    inner: Box<dyn Env>,
    buf: StepBuffers,
    t: usize,
    after: Vec<f32>,
}

impl Scripted {
    fn new(inner: Box<dyn Env>) -> Self {
        let buf = inner.buffers().clone();
        Self { inner, buf, t: 0, after: Vec::new() }
    }
}

impl Env for Scripted {
    fn spec(&self) -> &TaskSpec {
        self.inner.spec()
    }
    fn num_envs(&self) -> usize {
        self.inner.num_envs()
    }
    fn buffers(&self) -> &StepBuffers {
        &self.buf
    }
    fn step(&mut self, actions: &[f32]) -> Result<(), EnvError> {
        self.inner.step(actions)?;
        self.buf = self.inner.buffers().clone();
        for i in 0..self.num_envs() {
            let end = scripted_end(self.t, i);
            self.buf.truncated[i] = u8::from(end == Some(End::Truncated));
            self.buf.terminated[i] = u8::from(end == Some(End::Terminated));
        }
        self.after.extend_from_slice(&self.buf.obs);
        self.t += 1;
        Ok(())
    }
    fn reset_all(&mut self, seed: Option<u64>) {
        self.inner.reset_all(seed);
        self.buf = self.inner.buffers().clone();
    }
    fn reset_envs(&mut self, mask: &[bool]) {
        self.inner.reset_envs(mask);
        self.buf.obs.copy_from_slice(&self.inner.buffers().obs);
    }
    /// Resets the environments the schedule ended (not those the real task would end).
    fn reset_done(&mut self) {
        let mask: Vec<bool> = (0..self.num_envs())
            .map(|i| self.buf.terminated[i] != 0 || self.buf.truncated[i] != 0)
            .collect();
        if mask.iter().any(|&m| m) {
            self.reset_envs(&mask);
        }
        self.buf.terminated.fill(0);
        self.buf.truncated.fill(0);
    }
    fn set_autoreset(&mut self, on: bool) {
        assert!(!on, "the trainer resets at the top of the next step");
    }
    fn refresh_observations(&mut self) {
        self.inner.refresh_observations();
        self.buf.obs.copy_from_slice(&self.inner.buffers().obs);
    }
    fn mujoco(&self) -> &dyn MjBatch {
        self.inner.mujoco()
    }
    fn mujoco_mut(&mut self) -> &mut dyn MjBatch {
        self.inner.mujoco_mut()
    }
    fn pd_targets(&self) -> &[f32] {
        self.inner.pd_targets()
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

#[test]
fn truncated_steps_bootstrap_on_the_terminal_value_and_terminated_steps_do_not() {
    let mut c = TrainConfig::preset("tiny").unwrap();
    c.env.motion = vec![workspace_root().join("motions")];
    c.env.num_envs = 4;
    c.env.threads = 1;
    c.ppo.minibatch = 64;
    c.run.iterations = 1;
    c.run.out_dir = std::env::temp_dir().join(format!("sm-bootstrap-{}", std::process::id()));
    let mut t = Trainer::new(c.clone(), None).unwrap();
    let mut env_cfg = t.cfg.env.clone();
    env_cfg.num_envs = 4;
    t.env = Box::new(Scripted::new(registry::make(&env_cfg).unwrap()));
    t.collect_rollout().unwrap();
    let (h, n, d) = (c.ppo.horizon, 4, t.env.obs_dim());
    let after = t.env.as_any().downcast_ref::<Scripted>().unwrap().after.clone();
    assert_eq!(after.len(), h * n * d);
    // V(observation returned by step t) for every step and environment, with the trainer's critic
    let mut v_after = vec![0.0f32; h * n];
    t.policy.infer_values(&after, h * n, &mut InferenceBuffers::default(), &mut v_after, 1);
    let r = t.rollout_storage();
    let close = |x: f32, y: f32| (x - y).abs() <= 1e-5 * y.abs().max(1.0);
    let mut counts = [0usize; 4]; // truncated, terminated, inside an episode, last step
    for step in 0..h {
        for i in 0..n {
            let k = step * n + i;
            let (next, v) = (r.next_values[k], v_after[k]);
            match scripted_end(step, i) {
                Some(end) => {
                    assert_eq!(r.dones[k], 1, "step {step} env {i}: the scripted end is a done");
                    if end == End::Truncated {
                        // the bootstrap must be visible: the critic's value is clearly non-zero
                        assert!(
                            v.abs() > 1e-3,
                            "step {step} env {i}: V(terminal) = {v} cannot tell a bootstrap from \
                                none"
                        );
                        assert!(
                            close(next, v),
                            "step {step} env {i}: truncated, next value {next} must be V(terminal \
                                obs) = {v}"
                        );
                        counts[0] += 1;
                    } else {
                        assert_eq!(
                            next, 0.0,
                            "step {step} env {i}: terminated (V(terminal obs) = {v}), next value \
                                must be 0"
                        );
                        counts[1] += 1;
                    }
                }
                None if step + 1 == h => {
                    assert_eq!(r.dones[k], 0);
                    assert!(
                        close(next, v),
                        "step {step} env {i}: last step, next value {next} must be V(last obs) = \
                            {v}"
                    );
                    counts[3] += 1;
                }
                None => {
                    assert_eq!(r.dones[k], 0, "step {step} env {i}: not scripted to end");
                    // inside an episode the next value is the value the next step stored
                    assert_eq!(next, r.values[k + n], "step {step} env {i}");
                    assert!(close(next, v), "step {step} env {i}: {next} vs V(next obs) {v}");
                    counts[2] += 1;
                }
            }
        }
    }
    assert_eq!(counts, [2, 4, h * n - 6 - n, n]);
    let _ = std::fs::remove_dir_all(&c.run.out_dir);
}
