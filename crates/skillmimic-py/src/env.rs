//! The batched environment of any registered task (`CoreEnv`), wrapped by the Python package's
//! gymnasium `VectorEnv`: numpy arrays in, the Rust core steps with the GIL released, results
//! written into preallocated numpy buffers owned by the Python side.

use numpy::{
    PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2, PyReadwriteArray1, PyReadwriteArray2,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use skillmimic_env::{Env, EnvConfig};

use crate::convert::{check_shape, detach_guarded, to_2d, value_error};

/// The batched environment of any registered task (Rust core). Use `skillmimic_rs.VecEnv`
/// instead.
#[pyclass(module = "skillmimic_rs._core")]
pub(crate) struct CoreEnv {
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
    /// Run `f` on the environment with the GIL released; after a panic inside the core the
    /// environment's state is unknown, so it is closed and the error says so.
    fn run_core<T: Send>(
        &mut self,
        py: Python<'_>,
        what: &str,
        f: impl FnOnce(&mut dyn Env) -> T + Send,
    ) -> PyResult<T> {
        let env = self
            .env
            .as_deref_mut()
            .ok_or_else(|| PyRuntimeError::new_err("the environment is closed"))?;
        match detach_guarded(py, what, || f(env)) {
            Ok(v) => Ok(v),
            Err(e) => {
                self.env = None;
                Err(PyRuntimeError::new_err(format!("{}; the environment was closed", e.value(py))))
            }
        }
    }
    /// Refuse an environment index out of range.
    fn check_index(&self, i: usize) -> PyResult<()> {
        let n = self.env()?.num_envs();
        if i >= n {
            return Err(PyValueError::new_err(format!(
                "environment index {i} out of range (num_envs = {n})"
            )));
        }
        Ok(())
    }
}

/// One observation block for Python: `(name, start, end, low, high)`.
type BlockRow = (String, usize, usize, f32, f32);

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

#[pymethods]
impl CoreEnv {
    /// Build from a JSON object with the fields of the `[env]` config table.
    #[new]
    #[pyo3(signature = (config_json, autoreset))]
    fn new(py: Python<'_>, config_json: &str, autoreset: bool) -> PyResult<Self> {
        let cfg: EnvConfig = serde_json::from_str(config_json)
            .map_err(|e| PyValueError::new_err(format!("config: {e}")))?;
        let mut env = detach_guarded(py, "VecEnv()", || skillmimic_env::registry::make(&cfg))?
            .map_err(value_error)?;
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
    fn term_names(&self) -> PyResult<Vec<String>> {
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
    fn frame_metric_names(&self) -> PyResult<Vec<String>> {
        Ok(self.env()?.spec().metric_names.clone())
    }
    /// MJCF text of the compiled scene.
    #[getter]
    fn mjcf_xml(&self) -> PyResult<String> {
        Ok(self.env()?.mujoco().env_xml(0).to_string())
    }
    /// MJCF text of environment `i`'s compiled scene (tasks with several object variants compile
    /// one scene per variant; `mjcf_xml` is environment 0's).
    fn env_mjcf_xml(&self, i: usize) -> PyResult<String> {
        let env = self.env()?;
        if i >= env.num_envs() {
            return Err(PyValueError::new_err(format!(
                "environment index {i} out of range (num_envs = {})",
                env.num_envs()
            )));
        }
        Ok(env.mujoco().env_xml(i).to_string())
    }
    /// (nq, nv) of the MuJoCo model.
    #[getter]
    fn qpos_qvel_sizes(&self) -> PyResult<(usize, usize)> {
        let m = self.env()?.mujoco().env_model(0).ffi();
        let (nq, nv) = (m.nq as usize, m.nv as usize);
        Ok((nq, nv))
    }
    /// Names, skill labels and frame counts of the clips of the task's motion library.
    fn clips(&self) -> PyResult<Vec<(String, u32, usize)>> {
        let lib = self.env()?.library().ok_or_else(|| {
            PyValueError::new_err(format!(
                "task '{}' keeps no motion library of its own",
                self.cfg.task
            ))
        })?;
        Ok(lib
            .clips()
            .iter()
            .map(|m| (m.clip.name.clone(), m.clip.skill, m.clip.num_frames))
            .collect())
    }

    /// Reset every environment (reseeding when `seed` is given); writes the observations.
    #[pyo3(signature = (seed, obs_out))]
    fn reset_all(
        &mut self,
        py: Python<'_>,
        seed: Option<u64>,
        obs_out: PyReadwriteArray2<'_, f32>,
    ) -> PyResult<()> {
        self.run_core(py, "VecEnv.reset", |env| env.reset_all(seed))?;
        copy_obs(self.env()?, obs_out)
    }

    /// Reset the environments where `mask` is true; writes all observations.
    fn reset_mask(
        &mut self,
        py: Python<'_>,
        mask: PyReadonlyArray1<'_, bool>,
        obs_out: PyReadwriteArray2<'_, f32>,
    ) -> PyResult<()> {
        check_shape("reset_mask", mask.shape(), &[self.env()?.num_envs()])?;
        let m: Vec<bool> = mask.as_slice().map_err(value_error)?.to_vec();
        if !m.iter().any(|&x| x) {
            return Err(PyValueError::new_err("reset_mask selects no environment"));
        }
        self.run_core(py, "VecEnv.reset", |env| env.reset_envs(&m))?;
        copy_obs(self.env()?, obs_out)
    }

    /// Close the episodes of the environments where `mask` is true (the task's end-of-episode
    /// bookkeeping, e.g. SkillMimic-V2's ATS) before `reset_mask` resets them.
    fn end_episodes(&mut self, mask: PyReadonlyArray1<'_, bool>) -> PyResult<()> {
        let env = self.env_mut()?;
        check_shape("end_episodes mask", mask.shape(), &[env.num_envs()])?;
        env.end_episodes(mask.as_slice().map_err(value_error)?);
        Ok(())
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
        let (n, a, d) = {
            let env = self.env()?;
            (env.num_envs(), env.act_dim(), env.obs_dim())
        };
        check_shape("actions", actions.shape(), &[n, a])?;
        let mut abuf = std::mem::take(&mut self.actions);
        abuf.copy_from_slice(actions.as_slice().map_err(value_error)?);
        let stepped = self.run_core(py, "VecEnv.step", |env| env.step(&abuf));
        self.actions = abuf;
        stepped?.map_err(value_error)?;
        let env = self.env()?;
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

    /// `(N,)` bool: MuJoCo reported a numerical instability in that environment during the last
    /// step (its physics was reset and the episode terminated).
    fn unstable<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let b = self.env()?.buffers();
        Ok(PyArray1::from_iter(py, b.unstable.iter().map(|&u| u != 0)))
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
    /// tasks: the frozen skill policy's clamped actions; `(N, 0)` when the actions are the
    /// targets).
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
    fn set_task_info(
        &mut self,
        i: usize,
        values: PyReadonlyArray1<'_, f32>,
        obs_out: PyReadwriteArray2<'_, f32>,
    ) -> PyResult<()> {
        let env = self.env_mut()?;
        env.set_task_info(i, values.as_slice().map_err(value_error)?).map_err(value_error)?;
        copy_obs(env.as_ref(), obs_out)
    }
    /// `(N, metrics)` per-step metrics of the last step (columns: `frame_metric_names`).
    fn frame_metrics<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let env = self.env()?;
        to_2d(py, &env.buffers().metrics, env.num_envs(), env.spec().metric_names.len())
    }
    /// Per-environment episode fields the task declares (`episode_names`; the imitation task:
    /// clip index, start frame, reference frame, progress, length, skill label), int64 arrays;
    /// empty for a task that declares none.
    fn episode_info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let env = self.env()?;
        let names = &env.spec().episode_names;
        let rows: Vec<Vec<i64>> = (0..env.num_envs()).map(|i| env.episode_info(i)).collect();
        let d = PyDict::new(py);
        for (k, name) in names.iter().enumerate() {
            let col: Vec<i64> = rows.iter().map(|r| r[k]).collect();
            d.set_item(*name, PyArray1::from_vec(py, col))?;
        }
        Ok(d)
    }
    /// Names of `episode_info()`'s entries.
    #[getter]
    fn episode_names(&self) -> PyResult<Vec<&'static str>> {
        Ok(self.env()?.spec().episode_names.clone())
    }
    /// The key under which the task information is reported (`"contact_graph"` for the
    /// imitation task, `"task_info"` otherwise).
    #[getter]
    fn info_label(&self) -> PyResult<&'static str> {
        Ok(self.env()?.spec().info_label)
    }
    /// The observation's named blocks: `(name, start, end, low, high)`, with ±inf where a block
    /// is not bounded by construction.
    #[getter]
    fn obs_blocks(&self) -> PyResult<Vec<BlockRow>> {
        Ok(self
            .env()?
            .spec()
            .obs_blocks
            .iter()
            .map(|b| {
                let (lo, hi) = b.bounds.unwrap_or((f32::NEG_INFINITY, f32::INFINITY));
                (b.name.clone(), b.range.start, b.range.end, lo, hi)
            })
            .collect())
    }
    /// The task's visual markers for one information row (`task_info_names` order): a list of
    /// dicts with `kind` ("sphere", "segment", "box"), positions in world metres and `rgba`.
    fn markers<'py>(
        &self,
        py: Python<'py>,
        info: PyReadonlyArray1<'_, f32>,
    ) -> PyResult<Vec<Bound<'py, PyDict>>> {
        use skillmimic_env::markers::Marker;
        let env = self.env()?;
        let row = info.as_slice().map_err(value_error)?;
        let mut out = Vec::new();
        for m in env.markers(row) {
            let d = PyDict::new(py);
            match m {
                Marker::Sphere { pos, radius, rgba } => {
                    d.set_item("kind", "sphere")?;
                    d.set_item("pos", pos)?;
                    d.set_item("radius", radius)?;
                    d.set_item("rgba", rgba)?;
                }
                Marker::Segment { from, to, radius, rgba } => {
                    d.set_item("kind", "segment")?;
                    d.set_item("from", from)?;
                    d.set_item("to", to)?;
                    d.set_item("radius", radius)?;
                    d.set_item("rgba", rgba)?;
                }
                Marker::Box { pos, half, rgba } => {
                    d.set_item("kind", "box")?;
                    d.set_item("pos", pos)?;
                    d.set_item("half", half)?;
                    d.set_item("rgba", rgba)?;
                }
            }
            out.push(d);
        }
        Ok(out)
    }

    /// MuJoCo `qpos` of environment `i`.
    fn get_qpos<'py>(&self, py: Python<'py>, i: usize) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let env = self.env()?;
        if i >= env.num_envs() {
            return Err(PyValueError::new_err(format!(
                "environment index {i} out of range (num_envs = {})",
                env.num_envs()
            )));
        }
        Ok(PyArray1::from_slice(py, env.mujoco().env_qpos(i)))
    }
    /// MuJoCo `qvel` of environment `i`.
    fn get_qvel<'py>(&self, py: Python<'py>, i: usize) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let env = self.env()?;
        if i >= env.num_envs() {
            return Err(PyValueError::new_err(format!(
                "environment index {i} out of range (num_envs = {})",
                env.num_envs()
            )));
        }
        Ok(PyArray1::from_slice(py, env.mujoco().env_qvel(i)))
    }
    /// Overwrite `qpos`/`qvel` of environment `i` (forward kinematics runs; observations of all
    /// environments are refreshed and written to `obs_out`).
    fn set_state(
        &mut self,
        i: usize,
        qpos: PyReadonlyArray1<'_, f64>,
        qvel: PyReadonlyArray1<'_, f64>,
        obs_out: PyReadwriteArray2<'_, f32>,
    ) -> PyResult<()> {
        let env = self.env_mut()?;
        let (q, v) = (qpos.as_slice().map_err(value_error)?, qvel.as_slice().map_err(value_error)?);
        env.mujoco_mut().set_env_qpos_qvel(i, q, v).map_err(value_error)?;
        env.refresh_observations();
        copy_obs(env.as_ref(), obs_out)
    }

    /// The history window `(k, 316)` of environment `i` (SkillMimic-V2 history encoder), or None
    /// when the encoder is off. Its embedding becomes the last μ observation entries at the next
    /// step.
    fn history_window<'py>(
        &self,
        py: Python<'py>,
        i: usize,
    ) -> PyResult<Option<Bound<'py, PyArray2<f32>>>> {
        self.check_index(i)?;
        match self.env()?.history_window(i) {
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
