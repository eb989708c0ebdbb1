//! The raw `mj_step` anchor of the benchmarks: a workload of random PD targets and a loop of
//! plain `MjData`s (no read-out, no task), shared by `bench sim`, `bench solver` and
//! `bench train`.

use std::sync::Arc;

use mujoco_rs::prelude::*;
use rand::{Rng, SeedableRng};
use skillmimic_core::characters::skillmimic::NUM_DOFS;
use skillmimic_sim::{BatchSim, HandModel, Scene};

#[derive(clap::Args)]
pub struct SimArgs {
    /// Environments per batch (a training-sized batch: thread scaling needs enough work per step).
    #[arg(long, default_value_t = 256)]
    pub envs: usize,
    /// Policy steps per round.
    #[arg(long, default_value_t = 60)]
    pub steps: usize,
    /// Policy steps a variant runs before the next variant takes over (interleaving grain).
    #[arg(long, default_value_t = 10)]
    pub chunk: usize,
    /// Measured rounds (after one warm-up round).
    #[arg(long, default_value_t = 3)]
    pub rounds: usize,
    /// Hand models to measure: full, box or both.
    #[arg(long, default_value = "both")]
    pub hands: String,
}

impl SimArgs {
    /// The hand models named by `--hands`.
    pub fn hand_models(&self) -> anyhow::Result<Vec<HandModel>> {
        Ok(match self.hands.as_str() {
            "both" => vec![HandModel::Full, HandModel::Box],
            h => vec![crate::cmd_trace::parse_hands(h)?],
        })
    }
}

/// The workload: every environment starts upright at rest and follows the same random targets.
pub(crate) struct Workload {
    actions: Vec<f32>, // steps × envs × 156
    envs: usize,
    steps: usize,
}

impl Workload {
    pub(crate) fn new(envs: usize, steps: usize) -> Self {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let actions =
            (0..steps * envs * NUM_DOFS).map(|_| 0.15 * rng.random_range(-1.0f32..=1.0)).collect();
        Self { actions, envs, steps }
    }
    pub(crate) fn steps(&self) -> usize {
        self.steps
    }
    pub(crate) fn step_actions(&self, k: usize) -> &[f32] {
        &self.actions[k * self.envs * NUM_DOFS..(k + 1) * self.envs * NUM_DOFS]
    }
}

/// (a) the anchor: plain `MjData`s, set `ctrl`, `mj_step` twice per policy step, no read-out.
/// With a pool the environments are spread over its threads (to show MuJoCo's own scaling).
pub(crate) struct RawLoop {
    pub(crate) datas: Vec<MjData<Arc<MjModel>>>,
    pool: Option<rayon::ThreadPool>,
}

impl RawLoop {
    pub(crate) fn new(scene: &Scene, envs: usize, threads: Option<usize>) -> anyhow::Result<Self> {
        let datas = (0..envs).map(|_| MjData::new(Arc::clone(scene.model()))).collect();
        let pool = match threads {
            Some(n) => Some(rayon::ThreadPoolBuilder::new().num_threads(n).build()?),
            None => None,
        };
        Ok(Self { datas, pool })
    }

    /// MuJoCo data bytes of one environment.
    pub(crate) fn data_bytes(&self) -> u64 {
        self.datas.first().map_or(0, |d| skillmimic_sim::memory::data_bytes(d.ffi()))
    }

    /// Start from exactly the state of a freshly reset batch.
    pub(crate) fn reset_from(&mut self, init: &BatchSim) {
        for (i, d) in self.datas.iter_mut().enumerate() {
            d.qpos_mut().copy_from_slice(init.qpos(i));
            d.qvel_mut().copy_from_slice(init.qvel(i));
            d.qacc_warmstart_mut().fill(0.0);
            d.ctrl_mut().fill(0.0);
            d.forward();
        }
    }

    pub(crate) fn step(&mut self, scene: &Scene, a: &[f32]) {
        use rayon::prelude::*;
        let step_env = |i: usize, d: &mut MjData<Arc<MjModel>>| {
            let row = &a[i * NUM_DOFS..(i + 1) * NUM_DOFS];
            for (c, &(j, map)) in d.ctrl_mut().iter_mut().zip(&scene.actuators) {
                *c = map.target((row[j] as f64).clamp(-1.0, 1.0));
            }
            d.step();
            d.step();
        };
        match &self.pool {
            None => self.datas.iter_mut().enumerate().for_each(|(i, d)| step_env(i, d)),
            Some(p) => {
                let datas = &mut self.datas;
                p.install(|| datas.par_iter_mut().enumerate().for_each(|(i, d)| step_env(i, d)))
            }
        }
    }
}
