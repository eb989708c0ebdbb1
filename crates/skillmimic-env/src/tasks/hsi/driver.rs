//! [`HsiVecEnv`]: the batched driver of the TokenHSI tasks (see the [module doc](super)).

use std::any::Any;
use std::sync::Arc;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use skillmimic_core::hsi_character::{CONTACT_BODIES, NUM_BODIES};
use skillmimic_sim::{BatchSim, HsiBatch, HsiReset, HsiScene, MjBatch};

use super::proprio::{PROPRIO_DIM, write_proprio};
use super::{Ctx, HsiTask, TaskOut};
use crate::error::EnvError;
use crate::task::TaskSpec;
use crate::vec_env::{Env, StepBuffers, rows};

#[derive(Clone, Default)]
struct Slot<G> {
    goal: G,
    steps: usize,
    prev_root: [f64; 3],
    prev_obj: [f64; 3],
}

/// The batched environment of TokenHSI task `T`.
pub struct HsiVecEnv<T: HsiTask> {
    task: T,
    slots: Vec<Slot<T::Goal>>,
    sim: HsiBatch,
    /// One stream of episode starts per environment (`crate::vec_env::env_streams`).
    rngs: Vec<ChaCha8Rng>,
    buf: StepBuffers,
    autoreset: bool,
    reset_mask: Vec<bool>,
    reset_states: Vec<HsiReset>,
    episode_length: usize,
    termination_height: f64,
}

impl<T: HsiTask> HsiVecEnv<T> {
    /// Compile `variants` object variants (sizes from `object_seed`), build `num_envs`
    /// environments on `threads` simulation threads (0 = one per core) and reset them all
    /// (episode starts seeded with `seed`).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        task: T,
        variants: usize,
        object_seed: u64,
        num_envs: usize,
        threads: usize,
        seed: u64,
        episode_length: usize,
        termination_height: f64,
    ) -> Result<Self, EnvError> {
        let mut orng = ChaCha8Rng::seed_from_u64(object_seed);
        let scenes = (0..variants.clamp(1, num_envs.max(1)))
            .map(|_| HsiScene::new(task.objects(&mut orng)).map(Arc::new))
            .collect::<Result<Vec<_>, _>>()?;
        let sim = HsiBatch::new(
            scenes,
            num_envs,
            crate::config_range::capped_threads(threads, "env.threads"),
        )?;
        let spec = task.spec().clone();
        let n = num_envs;
        let buf = StepBuffers::for_spec(n, &spec);
        let mut env = Self {
            task,
            slots: vec![Slot::default(); n],
            sim,
            rngs: crate::vec_env::env_streams(seed, n),
            buf,
            autoreset: false,
            reset_mask: vec![false; n],
            reset_states: vec![HsiReset::default(); n],
            episode_length,
            termination_height,
        };
        env.reset_all(None);
        Ok(env)
    }

    /// The task.
    pub fn task(&self) -> &T {
        &self.task
    }
    /// The simulation batch.
    pub fn hsi_sim(&self) -> &HsiBatch {
        &self.sim
    }

    fn plan(&mut self, i: usize) {
        let scene = Arc::clone(self.sim.scene(i));
        let slot = &mut self.slots[i];
        self.task.plan(&scene, &mut self.rngs[i], &mut self.reset_states[i], &mut slot.goal);
    }

    fn apply_resets(&mut self, clear_flags: bool) {
        self.sim
            .reset(&self.reset_mask, &self.reset_states)
            .expect("reset states are planned by the task");
        let d = self.task.spec().obs_dim;
        let ni = self.task.spec().info_names.len();
        let Self { sim, slots, buf, reset_mask, task, .. } = self;
        let (state, task, mask) = (sim.state(), &*task, &*reset_mask);
        sim.install(|| {
            (slots.par_iter_mut(), buf.obs.par_chunks_mut(d)).into_par_iter().enumerate().for_each(
                |(i, (slot, obs))| {
                    if mask[i] {
                        let st = state.env(i);
                        slot.steps = 0;
                        slot.prev_root = st.pos(0);
                        slot.prev_obj =
                            if state.bodies > NUM_BODIES { st.pos(NUM_BODIES) } else { [0.0; 3] };
                        write_proprio(&st, &mut obs[..PROPRIO_DIM]);
                        task.observe(&slot.goal, &st, 0, &mut obs[PROPRIO_DIM..]);
                    }
                },
            );
        });
        for (i, &m) in mask.iter().enumerate() {
            if m {
                if ni > 0 {
                    task.info(&slots[i].goal, 0, &mut buf.info[i * ni..(i + 1) * ni]);
                }
                if clear_flags {
                    buf.terminated[i] = 0;
                    buf.truncated[i] = 0;
                }
            }
        }
    }

    fn step_impl(&mut self, actions: &[f32]) -> Result<(), EnvError> {
        self.sim.step(actions)?;
        let spec = self.task.spec();
        let (d, nt, ni, nm) =
            (spec.obs_dim, spec.term_names.len(), spec.info_names.len(), spec.metric_names.len());
        let (limit, th) = (self.episode_length, self.termination_height);
        let Self { sim, slots, buf, task, .. } = self;
        let (state, task) = (sim.state(), &*task);
        let n = slots.len();
        let (terms, metrics, info) = (
            rows(&mut buf.terms, n, nt),
            rows(&mut buf.metrics, n, nm),
            rows(&mut buf.info, n, ni),
        );
        sim.install(|| {
            (
                slots.par_iter_mut(),
                buf.obs.par_chunks_mut(d),
                buf.reward.par_iter_mut(),
                terms,
                metrics,
                info,
                buf.terminated.par_iter_mut(),
                buf.truncated.par_iter_mut(),
            )
                .into_par_iter()
                .enumerate()
                .for_each(
                    |(i, (slot, obs, reward, terms, metrics, info, terminated, truncated))| {
                        let st = state.env(i);
                        slot.steps += 1;
                        let fallen = slot.steps > 1
                            && (0..NUM_BODIES).any(|b| {
                                !CONTACT_BODIES.contains(&b)
                                    && st.contact[b] != 0
                                    && st.pos(b)[2] < th
                            });
                        let ctx = Ctx {
                            st: &st,
                            prev_root: slot.prev_root,
                            prev_obj: slot.prev_obj,
                            steps: slot.steps,
                            fallen,
                        };
                        let mut out = TaskOut { terms, metrics, fail: false, finish: false };
                        task.step(&mut slot.goal, &ctx, &mut out);
                        *reward = out.terms[nt - 1];
                        *terminated = u8::from(fallen || out.fail || st.unstable);
                        *truncated =
                            u8::from(*terminated == 0 && (out.finish || slot.steps >= limit));
                        slot.prev_root = st.pos(0);
                        if state.bodies > NUM_BODIES {
                            slot.prev_obj = st.pos(NUM_BODIES);
                        }
                        write_proprio(&st, &mut obs[..PROPRIO_DIM]);
                        task.observe(&slot.goal, &st, slot.steps, &mut obs[PROPRIO_DIM..]);
                        task.info(&slot.goal, slot.steps, info);
                    },
                );
        });
        buf.unstable.copy_from_slice(&state.unstable);
        if self.autoreset {
            let n = self.slots.len();
            let mut any = false;
            for i in 0..n {
                let done = self.buf.terminated[i] != 0 || self.buf.truncated[i] != 0;
                self.buf.final_mask[i] = u8::from(done);
                self.reset_mask[i] = done;
                if done {
                    any = true;
                    self.buf.final_obs[i * d..(i + 1) * d]
                        .copy_from_slice(&self.buf.obs[i * d..(i + 1) * d]);
                    self.plan(i);
                }
            }
            if any {
                self.apply_resets(false);
            }
        }
        Ok(())
    }
}

impl<T: HsiTask> Env for HsiVecEnv<T> {
    fn spec(&self) -> &TaskSpec {
        self.task.spec()
    }
    fn num_envs(&self) -> usize {
        self.slots.len()
    }
    fn buffers(&self) -> &StepBuffers {
        &self.buf
    }
    fn step(&mut self, actions: &[f32]) -> Result<(), EnvError> {
        let n = self.slots.len();
        if actions.len() != n * self.act_dim() {
            return Err(EnvError::ActionShape { expected: n * self.act_dim(), got: actions.len() });
        }
        self.step_impl(actions)
    }
    fn reset_all(&mut self, seed: Option<u64>) {
        if let Some(s) = seed {
            self.rngs = crate::vec_env::env_streams(s, self.slots.len());
        }
        let mask = vec![true; self.slots.len()];
        self.reset_envs(&mask);
    }
    fn reset_envs(&mut self, mask: &[bool]) {
        assert_eq!(mask.len(), self.slots.len(), "reset mask length");
        for (i, &m) in mask.iter().enumerate() {
            self.reset_mask[i] = m;
            if m {
                self.plan(i);
            }
        }
        self.apply_resets(true);
    }
    fn reset_done(&mut self) {
        let mut any = false;
        for i in 0..self.slots.len() {
            let done = self.buf.terminated[i] != 0 || self.buf.truncated[i] != 0;
            self.reset_mask[i] = done;
            if done {
                any = true;
                self.plan(i);
            }
        }
        if any {
            self.apply_resets(true);
        }
    }
    fn set_autoreset(&mut self, on: bool) {
        self.autoreset = on;
    }
    /// Recompute the observations from the current states (after raw state edits). The previous
    /// root and object positions — between steps always the current ones — are taken anew, so
    /// the next step's finite-difference velocities start from an edited state, not from where
    /// the character was before the edit.
    fn refresh_observations(&mut self) {
        let d = self.task.spec().obs_dim;
        let Self { sim, slots, buf, task, .. } = self;
        let (state, task) = (sim.state(), &*task);
        sim.install(|| {
            (slots.par_iter_mut(), buf.obs.par_chunks_mut(d)).into_par_iter().enumerate().for_each(
                |(i, (slot, obs))| {
                    let st = state.env(i);
                    slot.prev_root = st.pos(0);
                    if state.bodies > NUM_BODIES {
                        slot.prev_obj = st.pos(NUM_BODIES);
                    }
                    write_proprio(&st, &mut obs[..PROPRIO_DIM]);
                    task.observe(&slot.goal, &st, slot.steps, &mut obs[PROPRIO_DIM..]);
                },
            );
        });
    }
    fn humanoid_sim(&self) -> Option<&BatchSim> {
        None
    }
    fn mujoco(&self) -> &dyn MjBatch {
        &self.sim
    }
    fn mujoco_mut(&mut self) -> &mut dyn MjBatch {
        &mut self.sim
    }
    fn pd_targets(&self) -> &[f32] {
        &[]
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}
