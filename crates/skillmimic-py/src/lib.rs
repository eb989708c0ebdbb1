//! `skillmimic_rs._core`: the Rust environment exposed to Python.
//!
//! The Python package wraps [`CoreEnv`] in a gymnasium `VectorEnv`; this layer only moves data:
//! numpy arrays in, the Rust core steps with the GIL released, results are written into
//! preallocated numpy buffers owned by the Python side. Every user mistake raises `ValueError`
//! (or `RuntimeError` after `close()`), never a crash.

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyReadwriteArray1, PyReadwriteArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use skillmimic_env::{Env, EnvConfig, SkillEnv};

mod consts;
mod nn;
mod train;

fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// The batched environment of any registered task (Rust core). Use `skillmimic_rs.VecEnv`
/// instead.
#[pyclass(module = "skillmimic_rs._core")]
struct CoreEnv {
    env: Option<Box<dyn Env>>,
    cfg: EnvConfig,
    actions: Vec<f32>,
}

impl CoreEnv {
    fn env(&self) -> PyResult<&dyn Env> {
        self.env.as_deref().ok_or_else(|| PyRuntimeError::new_err("the environment is closed"))
    }
    fn env_mut(&mut self) -> PyResult<&mut Box<dyn Env>> {
        self.env.as_mut().ok_or_else(|| PyRuntimeError::new_err("the environment is closed"))
    }
    /// The imitation task's environment (task-specific accessors).
    fn imitation(&self) -> PyResult<&SkillEnv> {
        self.env()?.as_any().downcast_ref::<SkillEnv>().ok_or_else(|| PyValueError::new_err(format!("only the imitation task has this (task is '{}')", self.cfg.task)))
    }
}

fn check_shape(name: &str, got: &[usize], want: &[usize]) -> PyResult<()> {
    if got != want {
        return Err(PyValueError::new_err(format!("{name}: expected shape {want:?}, got {got:?}")));
    }
    Ok(())
}

fn copy_obs(env: &dyn Env, mut out: PyReadwriteArray2<'_, f32>) -> PyResult<()> {
    check_shape("obs buffer", out.shape(), &[env.num_envs(), env.obs_dim()])?;
    out.as_slice_mut().map_err(value_error)?.copy_from_slice(&env.buffers().obs);
    Ok(())
}

fn write_flags(name: &str, out: &mut PyReadwriteArray1<'_, bool>, src: &[u8]) -> PyResult<()> {
    check_shape(name, out.shape(), &[src.len()])?;
    for (o, &s) in out.as_slice_mut().map_err(value_error)?.iter_mut().zip(src) {
        *o = s != 0;
    }
    Ok(())
}

fn to_2d<'py>(py: Python<'py>, data: &[f32], rows: usize, cols: usize) -> PyResult<Bound<'py, PyArray2<f32>>> {
    PyArray1::from_slice(py, data).reshape([rows, cols])
}

#[pymethods]
impl CoreEnv {
    /// Build from a JSON object with the fields of the `[env]` config table.
    #[new]
    #[pyo3(signature = (config_json, autoreset))]
    fn new(py: Python<'_>, config_json: &str, autoreset: bool) -> PyResult<Self> {
        let cfg: EnvConfig = serde_json::from_str(config_json).map_err(|e| PyValueError::new_err(format!("config: {e}")))?;
        let mut env = py.detach(|| skillmimic_env::registry::make(&cfg)).map_err(value_error)?;
        env.set_autoreset(autoreset);
        let n = env.num_envs() * env.act_dim();
        Ok(Self { env: Some(env), cfg, actions: vec![0.0; n] })
    }

    /// The effective configuration as JSON (defaults filled in).
    fn config_json(&self) -> PyResult<String> {
        self.env()?;
        serde_json::to_string(&self.cfg).map_err(value_error)
    }
    #[getter]
    fn num_envs(&self) -> PyResult<usize> {
        Ok(self.env()?.num_envs())
    }
    #[getter]
    fn obs_dim(&self) -> PyResult<usize> {
        Ok(self.env()?.obs_dim())
    }
    #[getter]
    fn act_dim(&self) -> PyResult<usize> {
        Ok(self.env()?.act_dim())
    }
    /// The task's registry name.
    #[getter]
    fn task(&self) -> PyResult<&'static str> {
        Ok(self.env()?.spec().name)
    }
    /// Action space: ("box", dim) or ("discrete", n).
    #[getter]
    fn action_space(&self) -> PyResult<(&'static str, usize)> {
        Ok(match self.env()?.spec().action_space {
            skillmimic_env::ActionSpace::Box { dim } => ("box", dim),
            skillmimic_env::ActionSpace::Discrete { n } => ("discrete", n),
        })
    }
    /// Episode length limit in policy steps.
    #[getter]
    fn max_episode_length(&self) -> PyResult<usize> {
        Ok(self.env()?.spec().max_episode_steps)
    }
    /// Names of the reward terms (columns of `reward_terms()`).
    #[getter]
    fn term_names(&self) -> PyResult<Vec<&'static str>> {
        Ok(self.env()?.spec().term_names.clone())
    }
    /// Names of the task information entries (imitation: the contact-graph entries of the
    /// configured mode; columns of `contact_graph()`).
    #[getter]
    fn cg_names(&self) -> PyResult<Vec<String>> {
        Ok(self.env()?.spec().info_names.clone())
    }
    /// Names of the columns of `frame_metrics()`.
    #[getter]
    fn frame_metric_names(&self) -> PyResult<Vec<&'static str>> {
        Ok(self.env()?.spec().metric_names.clone())
    }
    /// MJCF text of the compiled scene.
    #[getter]
    fn mjcf_xml(&self) -> PyResult<String> {
        Ok(self.env()?.sim().scene().xml().to_string())
    }
    /// (nq, nv) of the MuJoCo model.
    #[getter]
    fn qpos_qvel_sizes(&self) -> PyResult<(usize, usize)> {
        let (nq, nv, _) = self.env()?.sim().scene().sizes();
        Ok((nq, nv))
    }
    /// Names and skill labels of the clips of the motion library.
    fn clips(&self) -> PyResult<Vec<(String, u32, usize)>> {
        let lib = self.imitation()?.library();
        Ok(lib.clips().iter().map(|m| (m.clip.name.clone(), m.clip.skill, m.clip.num_frames)).collect())
    }

    /// Reset every environment (reseeding when `seed` is given); writes the observations.
    #[pyo3(signature = (seed, obs_out))]
    fn reset_all(&mut self, py: Python<'_>, seed: Option<u64>, obs_out: PyReadwriteArray2<'_, f32>) -> PyResult<()> {
        let env = self.env_mut()?;
        py.detach(|| env.reset_all(seed));
        copy_obs(env.as_ref(), obs_out)
    }

    /// Reset the environments where `mask` is true; writes all observations.
    fn reset_mask(&mut self, py: Python<'_>, mask: PyReadonlyArray1<'_, bool>, obs_out: PyReadwriteArray2<'_, f32>) -> PyResult<()> {
        let env = self.env_mut()?;
        check_shape("reset_mask", mask.shape(), &[env.num_envs()])?;
        let m: Vec<bool> = mask.as_slice().map_err(value_error)?.to_vec();
        if !m.iter().any(|&x| x) {
            return Err(PyValueError::new_err("reset_mask selects no environment"));
        }
        py.detach(|| env.reset_envs(&m));
        copy_obs(env.as_ref(), obs_out)
    }

    /// One policy step for all environments. Outputs are written into the given buffers.
    #[allow(clippy::too_many_arguments)]
    fn step(
        &mut self,
        py: Python<'_>,
        actions: PyReadonlyArray2<'_, f32>,
        obs_out: PyReadwriteArray2<'_, f32>,
        mut reward_out: PyReadwriteArray1<'_, f32>,
        mut terminated_out: PyReadwriteArray1<'_, bool>,
        mut truncated_out: PyReadwriteArray1<'_, bool>,
        mut final_obs_out: PyReadwriteArray2<'_, f32>,
        mut final_mask_out: PyReadwriteArray1<'_, bool>,
    ) -> PyResult<()> {
        let Self { env, actions: abuf, .. } = self;
        let env = env.as_deref_mut().ok_or_else(|| PyRuntimeError::new_err("the environment is closed"))?;
        let (n, a, d) = (env.num_envs(), env.act_dim(), env.obs_dim());
        check_shape("actions", actions.shape(), &[n, a])?;
        abuf.copy_from_slice(actions.as_slice().map_err(value_error)?);
        py.detach(|| env.step(abuf)).map_err(value_error)?;
        let b = env.buffers();
        copy_obs(env, obs_out)?;
        check_shape("reward buffer", reward_out.shape(), &[n])?;
        reward_out.as_slice_mut().map_err(value_error)?.copy_from_slice(&b.reward);
        write_flags("terminated buffer", &mut terminated_out, &b.terminated)?;
        write_flags("truncated buffer", &mut truncated_out, &b.truncated)?;
        check_shape("final_obs buffer", final_obs_out.shape(), &[n, d])?;
        check_shape("final_mask buffer", final_mask_out.shape(), &[n])?;
        let fm = final_mask_out.as_slice_mut().map_err(value_error)?;
        let fo = final_obs_out.as_slice_mut().map_err(value_error)?;
        for i in 0..n {
            fm[i] = b.final_mask[i] != 0;
            if fm[i] {
                fo[i * d..(i + 1) * d].copy_from_slice(&b.final_obs[i * d..(i + 1) * d]);
            }
        }
        Ok(())
    }

    /// `(N, terms)` sub-rewards of the last step (columns: `term_names`).
    fn reward_terms<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let env = self.env()?;
        to_2d(py, &env.buffers().terms, env.num_envs(), env.spec().term_names.len())
    }
    /// `(N, info)` task information of the last step (imitation: the simulated contact-graph
    /// entries; columns: `cg_names`).
    fn contact_graph<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let env = self.env()?;
        to_2d(py, &env.buffers().info, env.num_envs(), env.spec().info_names.len())
    }
    /// `(N, 156)` PD targets in [−1, 1] the task applied in the last simulation step (high-level
    /// tasks: the frozen skill policy's clamped actions; `(N, 0)` when the actions are the targets).
    fn pd_targets<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let env = self.env()?;
        let t = env.pd_targets();
        to_2d(py, t, env.num_envs(), t.len() / env.num_envs())
    }
    /// Simulation steps per policy step (3 for the high-level tasks).
    #[getter]
    fn steps_per_action(&self) -> PyResult<usize> {
        Ok(self.env()?.spec().steps_per_action)
    }
    /// Skill label of each discrete choice (high-level tasks); empty otherwise.
    #[getter]
    fn choice_labels(&self) -> PyResult<Vec<u32>> {
        Ok(self.env()?.spec().choice_labels.clone())
    }
    /// Move environment `i`'s goal (values in `cg_names` order: e.g. goal_x, goal_y in world
    /// metres) and write its new observation into `obs_out`.
    fn set_task_info(&mut self, i: usize, values: PyReadonlyArray1<'_, f32>, obs_out: PyReadwriteArray2<'_, f32>) -> PyResult<()> {
        let env = self.env_mut()?;
        env.set_task_info(i, values.as_slice().map_err(value_error)?).map_err(value_error)?;
        copy_obs(env.as_ref(), obs_out)
    }
    /// `(N, metrics)` per-step metrics of the last step (columns: `frame_metric_names`).
    fn frame_metrics<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let env = self.env()?;
        to_2d(py, &env.buffers().metrics, env.num_envs(), env.spec().metric_names.len())
    }
    /// Per-environment episode state: clip index, start frame, reference frame, progress,
    /// length, skill label (int64 arrays).
    fn episode_info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let env = self.imitation()?;
        let d = PyDict::new(py);
        let col = |f: &dyn Fn(&skillmimic_env::episode::Episode) -> i64| -> Vec<i64> { env.episodes().map(f).collect() };
        d.set_item("clip", PyArray1::from_vec(py, col(&|e| e.clip as i64)))?;
        d.set_item("ref_start", PyArray1::from_vec(py, col(&|e| e.ref_start as i64)))?;
        d.set_item("ref_frame", PyArray1::from_vec(py, col(&|e| e.ref_frame() as i64)))?;
        d.set_item("progress", PyArray1::from_vec(py, col(&|e| e.progress as i64)))?;
        d.set_item("length", PyArray1::from_vec(py, col(&|e| e.length as i64)))?;
        d.set_item("skill", PyArray1::from_vec(py, col(&|e| e.skill as i64)))?;
        Ok(d)
    }

    /// MuJoCo `qpos` of environment `i`.
    fn get_qpos<'py>(&self, py: Python<'py>, i: usize) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let env = self.env()?;
        if i >= env.num_envs() {
            return Err(PyValueError::new_err(format!("environment index {i} out of range (num_envs = {})", env.num_envs())));
        }
        Ok(PyArray1::from_slice(py, env.sim().qpos(i)))
    }
    /// MuJoCo `qvel` of environment `i`.
    fn get_qvel<'py>(&self, py: Python<'py>, i: usize) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let env = self.env()?;
        if i >= env.num_envs() {
            return Err(PyValueError::new_err(format!("environment index {i} out of range (num_envs = {})", env.num_envs())));
        }
        Ok(PyArray1::from_slice(py, env.sim().qvel(i)))
    }
    /// Overwrite `qpos`/`qvel` of environment `i` (forward kinematics runs; observations of all
    /// environments are refreshed and written to `obs_out`).
    fn set_state(&mut self, i: usize, qpos: PyReadonlyArray1<'_, f64>, qvel: PyReadonlyArray1<'_, f64>, obs_out: PyReadwriteArray2<'_, f32>) -> PyResult<()> {
        let env = self.env_mut()?;
        let (q, v) = (qpos.as_slice().map_err(value_error)?, qvel.as_slice().map_err(value_error)?);
        env.sim_mut().set_qpos_qvel(i, q, v).map_err(value_error)?;
        env.refresh_observations();
        copy_obs(env.as_ref(), obs_out)
    }

    /// The history window `(k, 316)` of environment `i` (SkillMimic-V2 history encoder), or None
    /// when the encoder is off. Its embedding becomes the last μ observation entries at the next
    /// step.
    fn history_window<'py>(&self, py: Python<'py>, i: usize) -> PyResult<Option<Bound<'py, PyArray2<f32>>>> {
        let env = self.imitation()?;
        if i >= env.num_envs() {
            return Err(PyValueError::new_err(format!("environment index {i} out of range (num_envs {})", env.num_envs())));
        }
        match env.history_window(i) {
            None => Ok(None),
            Some(w) => {
                let f = skillmimic_env::v2::history::FEATURE_DIM;
                Ok(Some(to_2d(py, &w, w.len() / f, f)?))
            }
        }
    }

    /// Release the simulation (further calls raise RuntimeError).
    fn close(&mut self) {
        self.env = None;
    }
    #[getter]
    fn closed(&self) -> bool {
        self.env.is_none()
    }
}

/// A trained policy loaded from a checkpoint, evaluated by the Rust inference path (the one the
/// trainer uses for rollouts).
#[pyclass(module = "skillmimic_rs._core")]
struct Policy {
    policy: skillmimic_learn::policy::Policy,
    buf: skillmimic_learn::policy::InferenceBuffers,
}

#[pymethods]
impl Policy {
    /// Load a checkpoint written by `skillmimic train` or `skillmimic export`.
    #[staticmethod]
    fn load(path: std::path::PathBuf) -> PyResult<Self> {
        let c = skillmimic_learn::checkpoint::load(&path, None).map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(Self { policy: c.policy, buf: Default::default() })
    }
    #[getter]
    fn obs_dim(&self) -> usize {
        self.policy.obs_dim()
    }
    #[getter]
    fn act_dim(&self) -> usize {
        self.policy.act_dim()
    }
    /// Action means `(N, act_dim)` and values `(N,)` for observations `(N, obs_dim)`.
    fn infer<'py>(&mut self, py: Python<'py>, obs: PyReadonlyArray2<'_, f32>) -> PyResult<(Bound<'py, PyArray2<f32>>, Bound<'py, PyArray1<f32>>)> {
        let (n, d) = (obs.shape()[0], obs.shape()[1]);
        check_shape("obs", obs.shape(), &[n, self.policy.obs_dim()])?;
        let x = obs.as_slice().map_err(value_error)?.to_vec();
        let a = self.policy.actor_outputs();
        let (mut mu, mut v) = (vec![0.0f32; n * a], vec![0.0f32; n]);
        let Self { policy, buf } = self;
        py.detach(|| policy.infer(&x, n, buf, &mut mu, &mut v, 0));
        let _ = d;
        Ok((PyArray1::from_vec(py, mu).reshape([n, a])?, PyArray1::from_vec(py, v)))
    }
}

/// A SkillMimic-V2 history encoder file, evaluated by the environment's Rust implementation.
#[pyclass(module = "skillmimic_rs._core")]
struct HistoryEncoder {
    enc: skillmimic_env::v2::history::HistoryEncoder,
}

#[pymethods]
impl HistoryEncoder {
    /// Load an encoder written by `skillmimic history pretrain`.
    #[staticmethod]
    fn load(path: std::path::PathBuf) -> PyResult<Self> {
        let enc = skillmimic_env::v2::history::HistoryEncoder::load(&path).map_err(value_error)?;
        Ok(Self { enc })
    }
    /// History length k.
    #[getter]
    fn length(&self) -> usize {
        self.enc.length()
    }
    /// Embedding width μ.
    #[getter]
    fn embed_dim(&self) -> usize {
        self.enc.embed_dim()
    }
    /// Embeddings `(B, μ)` of windows `(B, k, 316)` (oldest frame first).
    fn embed<'py>(&self, py: Python<'py>, windows: numpy::PyReadonlyArray3<'_, f32>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        use skillmimic_env::v2::history::FEATURE_DIM;
        let b = windows.shape()[0];
        check_shape("windows", windows.shape(), &[b, self.enc.length(), FEATURE_DIM])?;
        let x = windows.as_slice().map_err(value_error)?;
        let (k, mu) = (self.enc.length(), self.enc.embed_dim());
        let mut out = vec![0.0f32; b * mu];
        for (w, o) in x.chunks_exact(k * FEATURE_DIM).zip(out.chunks_exact_mut(mu)) {
            self.enc.embed(w, o);
        }
        to_2d(py, &out, b, mu)
    }
}

/// The trainer's running mean/std normaliser (rl_games update rule), for inspection and tests.
#[pyclass(module = "skillmimic_rs._core")]
struct RunningMeanStd {
    inner: skillmimic_nn::normalizer::RunningMeanStd,
}

#[pymethods]
impl RunningMeanStd {
    #[new]
    #[pyo3(signature = (dim, eps = 1e-5, clip = 5.0))]
    fn new(dim: usize, eps: f64, clip: f64) -> PyResult<Self> {
        if dim == 0 {
            return Err(PyValueError::new_err("dim must be at least 1"));
        }
        Ok(Self { inner: skillmimic_nn::normalizer::RunningMeanStd::new(dim, eps, clip) })
    }
    /// Merge a batch `(N, dim)` (N >= 2) into the statistics.
    fn update(&mut self, x: PyReadonlyArray2<'_, f32>) -> PyResult<()> {
        check_shape("batch", &[x.shape()[1]], &[self.inner.dim()])?;
        if x.shape()[0] < 2 {
            return Err(PyValueError::new_err("a batch needs at least 2 rows"));
        }
        self.inner.update(x.as_slice().map_err(value_error)?);
        Ok(())
    }
    /// Normalised copy of `x` `(N, dim)`.
    fn normalize<'py>(&self, py: Python<'py>, x: PyReadonlyArray2<'_, f32>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        check_shape("x", &[x.shape()[1]], &[self.inner.dim()])?;
        let mut out = vec![0.0f32; x.len()];
        self.inner.normalize_into(x.as_slice().map_err(value_error)?, &mut out);
        PyArray1::from_vec(py, out).reshape([x.shape()[0], self.inner.dim()])
    }
    #[getter]
    fn mean<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.mean)
    }
    #[getter]
    fn var<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.var)
    }
    #[getter]
    fn count(&self) -> f64 {
        self.inner.count
    }
}

/// PPO losses and parameter gradients of a checkpoint's policy on one minibatch (research and
/// cross-checks). `obs_n` are already-normalised observations; returns `(losses, grads)` where
/// `grads` maps the checkpoint tensor names (`actor.0.weight`, …) to arrays.
#[pyfunction]
#[pyo3(signature = (checkpoint, obs_n, actions, old_neglogp, advantages, returns_n, clip = 0.2, critic_coef = 5.0, bounds_coef = 10.0, bound = 1.0, backend = "fast", entropy_coef = 0.0))]
#[allow(clippy::too_many_arguments)]
fn ppo_loss_and_grads<'py>(
    py: Python<'py>,
    checkpoint: std::path::PathBuf,
    obs_n: PyReadonlyArray2<'_, f32>,
    actions: PyReadonlyArray2<'_, f32>,
    old_neglogp: PyReadonlyArray1<'_, f32>,
    advantages: PyReadonlyArray1<'_, f32>,
    returns_n: PyReadonlyArray1<'_, f32>,
    clip: f64,
    critic_coef: f64,
    bounds_coef: f64,
    bound: f64,
    backend: &str,
    entropy_coef: f64,
) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyDict>)> {
    use skillmimic_learn::config::{Backend, PpoConfig};
    let c = skillmimic_learn::checkpoint::load(&checkpoint, None).map_err(|e| PyValueError::new_err(e.to_string()))?;
    let p = &c.policy;
    let n = obs_n.shape()[0];
    check_shape("obs_n", obs_n.shape(), &[n, p.obs_dim()])?;
    check_shape("actions", actions.shape(), &[n, p.act_dim()])?;
    for (name, a) in [("old_neglogp", &old_neglogp), ("advantages", &advantages), ("returns_n", &returns_n)] {
        check_shape(name, a.shape(), &[n])?;
    }
    let backend = match backend {
        "fast" => Backend::Fast,
        "candle" => Backend::Candle,
        other => return Err(PyValueError::new_err(format!("backend '{other}', expected 'fast' or 'candle'"))),
    };
    let cfg = PpoConfig { clip, critic_coef, bounds_coef, bound, backend, entropy_coef, ..Default::default() };
    let mb = skillmimic_learn::ppo::Minibatch {
        n,
        obs_n: obs_n.as_slice().map_err(value_error)?,
        actions: actions.as_slice().map_err(value_error)?,
        old_neglogp: old_neglogp.as_slice().map_err(value_error)?,
        advantages: advantages.as_slice().map_err(value_error)?,
        returns_n: returns_n.as_slice().map_err(value_error)?,
    };
    let (stats, grads) = match backend {
        Backend::Fast if skillmimic_learn::ppo::fast::applies_to(p) => {
            let mut ws = skillmimic_learn::ppo::fast::UpdateWorkspace::default();
            let s = skillmimic_learn::ppo::fast::loss_and_grads_fast(p, &mb, &cfg, &mut ws, 0);
            (s, ws.grads)
        }
        _ => skillmimic_learn::ppo::loss_and_grads(p, &mb, &cfg).map_err(value_error)?,
    };
    let losses = PyDict::new(py);
    for (k, v) in [("actor", stats.actor), ("critic", stats.critic), ("bounds", stats.bounds), ("entropy", stats.entropy), ("total", stats.total), ("clip_frac", stats.clip_frac)] {
        losses.set_item(k, v)?;
    }
    let g = PyDict::new(py);
    let names = p.actor.param_names("actor").into_iter().chain(p.critic.param_names("critic"));
    for ((name, shape), data) in names.zip(grads) {
        let arr = PyArray1::from_vec(py, data);
        if shape.len() == 2 {
            g.set_item(name, arr.reshape([shape[0], shape[1]])?)?;
        } else {
            g.set_item(name, arr)?;
        }
    }
    Ok((losses, g))
}

/// Write a freshly initialised policy checkpoint (policy only, no Adam state): family
/// `family` (`gaussian_mlp` | `categorical_mlp`), observations of `obs_dim`, action space
/// `("box", dim)` or `("discrete", n)`, hidden widths `hidden`, weights drawn from `seed` (the
/// trainer's initialisation). For interop tests and for starting from Python.
#[pyfunction]
#[pyo3(signature = (path, family, obs_dim, actions, hidden, seed = 0))]
fn init_policy(path: std::path::PathBuf, family: &str, obs_dim: usize, actions: (String, usize), hidden: Vec<usize>, seed: u64) -> PyResult<()> {
    use rand::SeedableRng;
    let space = match actions.0.as_str() {
        "box" => skillmimic_env::ActionSpace::Box { dim: actions.1 },
        "discrete" => skillmimic_env::ActionSpace::Discrete { n: actions.1 },
        other => return Err(PyValueError::new_err(format!("actions: kind '{other}', expected 'box' or 'discrete'"))),
    };
    if obs_dim == 0 || actions.1 == 0 || hidden.contains(&0) {
        return Err(PyValueError::new_err("obs_dim, the action size and every hidden width must be positive"));
    }
    let cfg = skillmimic_learn::config::PpoConfig { policy: family.to_string(), hidden, ..Default::default() };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let p = skillmimic_learn::policy::Policy::build(obs_dim, space, &cfg, &mut rng).map_err(value_error)?;
    skillmimic_learn::checkpoint::save(&path, &p, None, &Default::default(), "").map_err(|e| PyValueError::new_err(format!("{}: {e}", path.display())))
}

/// Version of the Rust core.
#[pyfunction]
fn core_version() -> &'static str {
    env!("CARGO_PKG_VERSION")
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<CoreEnv>()?;
    m.add_class::<Policy>()?;
    m.add_class::<RunningMeanStd>()?;
    m.add_class::<HistoryEncoder>()?;
    m.add_class::<train::PyTrainer>()?;
    m.add_function(wrap_pyfunction!(core_version, m)?)?;
    m.add_function(wrap_pyfunction!(ppo_loss_and_grads, m)?)?;
    m.add_function(wrap_pyfunction!(init_policy, m)?)?;
    m.add_function(wrap_pyfunction!(nn::transformer_encoder_layer, m)?)?;
    m.add("OBS_DIM", skillmimic_env::obs::layout::OBS_DIM)?;
    m.add("BUILTIN_DEMO", skillmimic_env::BUILTIN_DEMO)?;
    consts::register(m)?;
    Ok(())
}
