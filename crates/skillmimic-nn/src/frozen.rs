//! A frozen skill policy inside an environment: the deterministic actor of a `gaussian_mlp`
//! checkpoint (`skillmimic-policy` safetensors, layout in `skillmimic_learn::checkpoint`) with
//! its own frozen observation normaliser.
//!
//! [`FrozenActor::act`] = clamp(μ(normalise(obs)), −1, 1): the same normaliser
//! ([`RunningMeanStd::normalize_into`]) and forward ([`Mlp::forward_into`]) as the learner's
//! batched inference, so a high-level task drives the humanoid with exactly the actions the
//! checkpoint gives standalone (tested bit for bit). The readers of the checkpoint's tensors
//! ([`read_mlp`], [`read_normalizer`]) are the ones the learner's loader uses.

use std::path::{Path, PathBuf};

use skillmimic_core::tensorfile::{TensorFile, TensorFileError};

use crate::mlp::{Mlp, Workspace};
use crate::normalizer::RunningMeanStd;

/// Value of the `format` metadata field of policy checkpoints.
pub const POLICY_FORMAT: &str = "skillmimic-policy";

/// Error loading a frozen policy.
#[derive(Debug, thiserror::Error)]
pub enum FrozenError {
    #[error(transparent)]
    File(#[from] TensorFileError),
    #[error("{path}: {detail}")]
    Invalid { path: PathBuf, detail: String },
}

/// The MLP `prefix.{0,2,4,…}.{weight,bias}` with layer widths `dims` (PyTorch layout:
/// weight `(out, in)`).
pub fn read_mlp(f: &TensorFile, prefix: &str, dims: Vec<usize>) -> Result<Mlp, TensorFileError> {
    let (mut weights, mut biases) = (Vec::new(), Vec::new());
    for (k, w) in dims.windows(2).enumerate() {
        weights.push(f.f32(&format!("{prefix}.{}.weight", 2 * k), &[Some(w[1]), Some(w[0])])?.1);
        biases.push(f.f32(&format!("{prefix}.{}.bias", 2 * k), &[Some(w[1])])?.1);
    }
    Ok(Mlp::from_parts(dims, weights, biases))
}

/// The normaliser `prefix.{mean,var,count}` (F64) of width `dim`.
pub fn read_normalizer(
    f: &TensorFile,
    prefix: &str,
    dim: usize,
    eps: f64,
    clip: f64,
) -> Result<RunningMeanStd, TensorFileError> {
    let mean = f.f64(&format!("{prefix}.mean"), &[Some(dim)])?.1;
    let var = f.f64(&format!("{prefix}.var"), &[Some(dim)])?.1;
    let count = f.f64(&format!("{prefix}.count"), &[])?.1[0];
    Ok(RunningMeanStd { mean, var, count, eps, clip })
}

/// Open the policy checkpoint at `path`, checking its `format` metadata.
pub fn open_policy(path: &Path) -> Result<TensorFile, FrozenError> {
    let f = TensorFile::open(path)?;
    match f.meta("format")? {
        POLICY_FORMAT => Ok(f),
        other => Err(FrozenError::Invalid {
            path: path.to_path_buf(),
            detail: format!(
                "metadata 'format' is '{other}', expected '{POLICY_FORMAT}' (a skill policy \
                    written by `skillmimic train`)"
            ),
        }),
    }
}

/// The deterministic actor of a skill-policy checkpoint, never modified.
#[derive(Clone, Debug)]
pub struct FrozenActor {
    /// `obs_dim → hidden… → act_dim` (the Gaussian means).
    pub actor: Mlp,
    /// The checkpoint's observation normaliser (`None` when it was trained without one).
    pub obs_norm: Option<RunningMeanStd>,
    /// Where it was loaded from.
    pub source: PathBuf,
    /// The training configuration stored with it (TOML text; empty when absent).
    pub config: String,
    ws: Workspace,
    obs_n: Vec<f32>,
}

impl FrozenActor {
    /// Load the actor part of a `gaussian_mlp` checkpoint (training or exported policy file).
    pub fn load(path: &Path) -> Result<Self, FrozenError> {
        let f = open_policy(path)?;
        let invalid = |detail: String| FrozenError::Invalid { path: path.to_path_buf(), detail };
        if let Ok(family) = f.meta("policy")
            && family != "gaussian_mlp"
        {
            return Err(invalid(format!(
                "metadata 'policy' is '{family}': a skill policy inside a high-level task must be \
                    a 'gaussian_mlp' checkpoint"
            )));
        }
        let obs_dim: usize = f.meta_parse("obs_dim", "an integer")?;
        let act_dim: usize = f.meta_parse("act_dim", "an integer")?;
        let hidden: Vec<usize> = serde_json::from_str(f.meta("hidden")?).map_err(|e| {
            invalid(format!(
                "metadata 'hidden' is not a JSON list of integers like [1024, 512, 512]: {e}"
            ))
        })?;
        let eps: f64 = f.meta_parse("norm_eps", "a number")?;
        let clip: f64 = f.meta_parse("norm_clip", "a number")?;
        let normalize: bool = f.meta_parse("normalize_input", "true/false")?;
        let mut dims = vec![obs_dim];
        dims.extend(hidden);
        dims.push(act_dim);
        let actor = read_mlp(&f, "actor", dims)?;
        let obs_norm = if normalize {
            Some(read_normalizer(&f, "obs_norm", obs_dim, eps, clip)?)
        } else {
            None
        };
        if let Some(n) = &obs_norm {
            n.check("obs_norm").map_err(invalid)?;
        }
        let config = f.metadata().get("config").cloned().unwrap_or_default();
        Ok(Self {
            actor,
            obs_norm,
            source: path.to_path_buf(),
            config,
            ws: Workspace::default(),
            obs_n: Vec::new(),
        })
    }

    /// Observation width the policy takes.
    pub fn obs_dim(&self) -> usize {
        self.actor.input_dim()
    }
    /// Action width it gives.
    pub fn act_dim(&self) -> usize {
        self.actor.output_dim()
    }

    /// Actions for `n` observation rows: clamp(μ(normalise(obs)), −1, 1) into `out`
    /// (`n × act_dim`). A row whose result is not finite (an unstable simulation state) gets zero
    /// targets instead. `threads` as in [`Mlp::forward_into`].
    pub fn act(&mut self, obs: &[f32], n: usize, threads: usize, out: &mut [f32]) {
        let (d, a) = (self.obs_dim(), self.act_dim());
        let x: &[f32] = match &self.obs_norm {
            Some(norm) => {
                self.obs_n.resize(n * d, 0.0);
                norm.normalize_into(&obs[..n * d], &mut self.obs_n);
                &self.obs_n
            }
            None => &obs[..n * d],
        };
        let mu = self.actor.forward_into(x, n, &mut self.ws, threads);
        for (orow, mrow) in out[..n * a].chunks_exact_mut(a).zip(mu.chunks_exact(a)) {
            if mrow.iter().all(|v| v.is_finite()) {
                for (o, &m) in orow.iter_mut().zip(mrow) {
                    *o = m.clamp(-1.0, 1.0);
                }
            } else {
                orow.fill(0.0);
            }
        }
    }
}
