//! The learner's pieces exposed for Python use and cross-checks against PyTorch: a policy
//! checkpoint evaluated by the Rust inference path, the SkillMimic-V2 history encoder, the
//! running normaliser, the PPO loss and gradients, and freshly initialised policies.

use numpy::{
    PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{check_shape, to_2d, value_error};

/// A trained policy loaded from a checkpoint, evaluated by the Rust inference path (the one the
/// trainer uses for rollouts).
#[pyclass(module = "skillmimic_rs._core")]
pub(crate) struct Policy {
    policy: skillmimic_learn::policy::Policy,
    buf: skillmimic_learn::policy::InferenceBuffers,
}

/// Actor outputs `(N, outputs)` and values `(N,)`.
type MeansValues<'py> = (Bound<'py, PyArray2<f32>>, Bound<'py, PyArray1<f32>>);

#[pymethods]
impl Policy {
    /// Load a checkpoint written by `skillmimic train` or `skillmimic export`.
    #[staticmethod]
    fn load(path: std::path::PathBuf) -> PyResult<Self> {
        let c = skillmimic_learn::checkpoint::load(&path, None)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
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
    fn infer<'py>(
        &mut self,
        py: Python<'py>,
        obs: PyReadonlyArray2<'_, f32>,
    ) -> PyResult<MeansValues<'py>> {
        let n = obs.shape()[0];
        check_shape("obs", obs.shape(), &[n, self.policy.obs_dim()])?;
        let x = obs.as_slice().map_err(value_error)?.to_vec();
        let a = self.policy.actor_outputs();
        let (mut mu, mut v) = (vec![0.0f32; n * a], vec![0.0f32; n]);
        let Self { policy, buf } = self;
        crate::convert::detach_guarded(py, "Policy.infer", || {
            policy.infer(&x, n, buf, &mut mu, &mut v, 0)
        })?;
        Ok((PyArray1::from_vec(py, mu).reshape([n, a])?, PyArray1::from_vec(py, v)))
    }
}

/// A SkillMimic-V2 history encoder file, evaluated by the environment's Rust implementation.
#[pyclass(module = "skillmimic_rs._core")]
pub(crate) struct HistoryEncoder {
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
    fn embed<'py>(
        &self,
        py: Python<'py>,
        windows: numpy::PyReadonlyArray3<'_, f32>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
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
pub(crate) struct RunningMeanStd {
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
        if !(eps.is_finite() && eps > 0.0) {
            return Err(PyValueError::new_err(format!(
                "eps is {eps}, expected a finite number > 0 (it is added to the variance under \
                    the square root)"
            )));
        }
        if !(clip > 0.0) {
            return Err(PyValueError::new_err(format!(
                "clip is {clip}, expected a number > 0 (normalised values are clamped to ±clip)"
            )));
        }
        Ok(Self { inner: skillmimic_nn::normalizer::RunningMeanStd::new(dim, eps, clip) })
    }
    /// Merge a batch `(N, dim)` (N >= 2) into the statistics.
    fn update(&mut self, x: PyReadonlyArray2<'_, f32>) -> PyResult<()> {
        check_shape("batch", &[x.shape()[1]], &[self.inner.dim()])?;
        if x.shape()[0] < 2 {
            return Err(PyValueError::new_err("a batch needs at least 2 rows"));
        }
        let x = x.as_slice().map_err(value_error)?;
        if let Some(k) = x.iter().position(|v| !v.is_finite()) {
            let d = self.inner.dim();
            return Err(PyValueError::new_err(format!(
                "batch: non-finite value {} at row {}, column {}; the statistics were left \
                    unchanged",
                x[k],
                k / d,
                k % d
            )));
        }
        self.inner.update(x);
        Ok(())
    }
    /// Normalised copy of `x` `(N, dim)`.
    fn normalize<'py>(
        &self,
        py: Python<'py>,
        x: PyReadonlyArray2<'_, f32>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
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
#[pyo3(signature = (
    checkpoint, obs_n, actions, old_neglogp, advantages, returns_n, clip = 0.2, critic_coef = 5.0,
    bounds_coef = 10.0, bound = 1.0, backend = "fast", entropy_coef = 0.0
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn ppo_loss_and_grads<'py>(
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
    let c = skillmimic_learn::checkpoint::load(&checkpoint, None)
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let p = &c.policy;
    let n = obs_n.shape()[0];
    check_shape("obs_n", obs_n.shape(), &[n, p.obs_dim()])?;
    check_shape("actions", actions.shape(), &[n, p.act_dim()])?;
    for (name, a) in
        [("old_neglogp", &old_neglogp), ("advantages", &advantages), ("returns_n", &returns_n)]
    {
        check_shape(name, a.shape(), &[n])?;
    }
    let backend = match backend {
        "fast" => Backend::Fast,
        "candle" => Backend::Candle,
        other => {
            return Err(PyValueError::new_err(format!(
                "backend '{other}', expected 'fast' or 'candle'"
            )));
        }
    };
    let cfg = PpoConfig {
        clip,
        critic_coef,
        bounds_coef,
        bound,
        backend,
        entropy_coef,
        ..Default::default()
    };
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
    for (k, v) in [
        ("actor", stats.actor),
        ("critic", stats.critic),
        ("bounds", stats.bounds),
        ("entropy", stats.entropy),
        ("total", stats.total),
        ("clip_frac", stats.clip_frac),
    ] {
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
/// `family` (`gaussian_mlp` | `categorical_mlp` | `modular_attention`), observations of
/// `obs_dim`, action space `("box", dim)` or `("discrete", n)`, hidden widths `hidden`, weights
/// drawn from `seed` (the trainer's initialisation); `overrides` = `--set`-style assignments
/// applied first (e.g. `"ppo.modular.controller=[32]"`). For interop tests and for starting from
/// Python.
#[pyfunction]
#[pyo3(signature = (path, family, obs_dim, actions, hidden, seed = 0, overrides = Vec::new()))]
pub(crate) fn init_policy(
    path: std::path::PathBuf,
    family: &str,
    obs_dim: usize,
    actions: (String, usize),
    hidden: Vec<usize>,
    seed: u64,
    overrides: Vec<String>,
) -> PyResult<()> {
    use rand::SeedableRng;
    let space = match actions.0.as_str() {
        "box" => skillmimic_env::ActionSpace::Box { dim: actions.1 },
        "discrete" => skillmimic_env::ActionSpace::Discrete { n: actions.1 },
        other => {
            return Err(PyValueError::new_err(format!(
                "actions: kind '{other}', expected 'box' or 'discrete'"
            )));
        }
    };
    if obs_dim == 0 || actions.1 == 0 || hidden.contains(&0) {
        return Err(PyValueError::new_err(
            "obs_dim, the action size and every hidden width must be positive",
        ));
    }
    let mut train = skillmimic_learn::config::TrainConfig::default();
    for o in &overrides {
        train.set(o).map_err(value_error)?;
    }
    let cfg =
        skillmimic_learn::config::PpoConfig { policy: family.to_string(), hidden, ..train.ppo };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let p = skillmimic_learn::policy::Policy::build(obs_dim, space, &cfg, &mut rng)
        .map_err(value_error)?;
    skillmimic_learn::checkpoint::save(&path, &p, None, &Default::default(), "")
        .map_err(|e| PyValueError::new_err(format!("{}: {e}", path.display())))
}
