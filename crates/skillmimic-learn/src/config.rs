//! PPO configuration with the SkillMimic defaults (rl_games config of the paper, reference-facts
//! §7) and the top-level training configuration (env + PPO + run); the named presets are in
//! [`crate::config_presets`].

use std::path::{Path, PathBuf};

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

pub use crate::config_policies::{AmpConfig, AmpLoss, AmpNormalizer, AmpSchedule, ModularConfig};
use crate::error::LearnError;
use skillmimic_env::EnvConfig;
use skillmimic_env::tasks::hlc::config::HlcConfig;

/// How the PPO gradients are computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Backend {
    /// Dedicated forward/backward of the two MLPs into reused buffers (`fast` module).
    #[default]
    Fast,
    /// candle's generic autograd (the reference; also the path of the `cuda` feature).
    Candle,
}

/// Precision of the matrix products of the fast PPO update (`ppo.precision`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Precision {
    /// float32 throughout (the papers' setting).
    #[default]
    F32,
    /// The backward matrix products of the update (weight and input gradients) take bf16 inputs
    /// (round to nearest even) with float32 accumulation ([`skillmimic_nn::bf16`]); the forward,
    /// weights, Adam state, normalisers, loss terms and the gradients leaving each product stay
    /// float32. The forward stays float32 because the PPO ratio compares its log-probability with
    /// the rollout's: over 156 action dimensions with σ = e^−2.9 a bf16 forward moves the log-ratio
    /// by a standard deviation of 0.04–1.0 (tests/bf16_update.rs). Needs AVX512-BF16 (detected at
    /// run time; without it the update runs in float32 and a warning says so). Only the `fast`
    /// backend uses it.
    Bf16,
}

/// The policy family of configs and checkpoint files that name none (SkillMimic's policy).
pub const DEFAULT_FAMILY: &str = "gaussian_mlp";

/// PPO hyper-parameters. Every field defaults to the paper's value.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct PpoConfig {
    /// Policy family (`gaussian_mlp`: fixed-σ Gaussian, SkillMimic's; `categorical_mlp`: discrete
    /// actions). It must support the task's action space.
    pub policy: String,
    /// Hidden layer widths of the actor and of the critic (separate networks), ReLU.
    #[schemars(inner(range(min = 1)))]
    pub hidden: Vec<usize>,
    /// Fixed log standard deviation of the Gaussian policy (σ = e^−2.9 ≈ 0.055).
    #[schemars(range(min = -20, max = 2))]
    pub log_std: f64,
    /// Rollout length per environment per iteration.
    #[schemars(range(min = 1))]
    pub horizon: usize,
    /// Minibatch size (samples).
    #[schemars(range(min = 1))]
    pub minibatch: usize,
    /// Passes over the rollout per iteration.
    #[schemars(range(min = 1))]
    pub mini_epochs: usize,
    /// Adam learning rate (constant).
    #[schemars(range(max = 1000), extend("exclusiveMinimum" = 0))]
    pub lr: f64,
    /// Adam epsilon.
    #[schemars(range(max = 1), extend("exclusiveMinimum" = 0))]
    pub adam_eps: f64,
    /// Discount γ.
    #[schemars(range(max = 1), extend("exclusiveMinimum" = 0))]
    pub gamma: f64,
    /// GAE λ.
    #[schemars(range(max = 1), extend("exclusiveMinimum" = 0))]
    pub lam: f64,
    /// PPO clip ε.
    #[schemars(range(max = 1), extend("exclusiveMinimum" = 0))]
    pub clip: f64,
    /// Critic loss coefficient.
    #[schemars(range(min = 0))]
    pub critic_coef: f64,
    /// Bounds loss coefficient.
    #[schemars(range(min = 0))]
    pub bounds_coef: f64,
    /// Soft bound of the action mean: the bounds loss penalises |μ| beyond it.
    #[schemars(range(min = 0))]
    pub bound: f64,
    /// Entropy bonus coefficient c_e (families that compute an entropy: `categorical_mlp`; the
    /// papers' PPO settings use 0).
    #[schemars(range(min = 0))]
    pub entropy_coef: f64,
    /// Global gradient-norm limit, applied only when `truncate_grads` is true (the paper's
    /// rl_games config sets 1.0 with `truncate_grads: False`, i.e. never applied).
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub grad_norm: f64,
    /// Clip the global gradient norm to `grad_norm` (off in the paper's config).
    pub truncate_grads: bool,
    /// Running mean/std normalisation of observations.
    pub normalize_input: bool,
    /// Running mean/std normalisation of values.
    pub normalize_value: bool,
    /// Batch advantage normalisation.
    pub normalize_advantage: bool,
    /// Normaliser epsilon.
    #[schemars(range(max = 1), extend("exclusiveMinimum" = 0))]
    pub norm_eps: f64,
    /// Normaliser clamp: normalised values are clamped to ±norm_clip.
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub norm_clip: f64,
    /// Gradient implementation (results agree to float rounding).
    pub backend: Backend,
    /// Matrix-product precision of the `fast` update (`f32` or the opt-in `bf16`).
    pub precision: Precision,
    /// Device of the candle backend: "cpu", or "cuda" (needs the `cuda` cargo feature).
    pub device: String,
    /// The modular attention network (`policy = "modular_attention"`; ModSkill).
    pub modular: ModularConfig,
    /// The token transformer (`policy = "token_transformer[_categorical]"`; TokenHSI).
    pub token: crate::config_token::TokenConfig,
    /// The adversarial motion prior (style reward; ModSkill, TokenHSI).
    pub amp: AmpConfig,
}

impl Default for PpoConfig {
    fn default() -> Self {
        Self {
            policy: DEFAULT_FAMILY.into(),
            hidden: vec![1024, 512, 512],
            log_std: -2.9,
            horizon: 32,
            minibatch: 16384,
            mini_epochs: 6,
            lr: 2e-5,
            adam_eps: 1e-8,
            gamma: 0.99,
            lam: 0.95,
            clip: 0.2,
            critic_coef: 5.0,
            bounds_coef: 10.0,
            bound: 1.0,
            entropy_coef: 0.0,
            grad_norm: 1.0,
            truncate_grads: false,
            normalize_input: true,
            normalize_value: true,
            normalize_advantage: true,
            norm_eps: 1e-5,
            norm_clip: 5.0,
            backend: Backend::Fast,
            precision: Precision::F32,
            device: "cpu".into(),
            modular: Default::default(),
            token: Default::default(),
            amp: Default::default(),
        }
    }
}

/// Run-level settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct RunConfig {
    /// Training iterations (one rollout + update each).
    pub iterations: usize,
    /// Seed of network initialisation, action noise and minibatch shuffling.
    pub seed: u64,
    /// Output folder (checkpoints, logs, plots, video).
    #[schemars(extend("format" = "path"))]
    pub out_dir: PathBuf,
    /// Save a checkpoint every this many iterations (and at the end).
    #[schemars(range(min = 1))]
    pub save_every: usize,
    /// Threads of the learner's matrix products (0 = all cores; a count above four per core is
    /// capped to that).
    #[schemars(range(max = skillmimic_env::config_range::MAX_THREADS))]
    pub learner_threads: usize,
    /// Evaluate and render a short video at the end of training.
    pub final_video: bool,
    /// Episodes of the end-of-training evaluation.
    pub eval_episodes: usize,
    /// Active skill learning with generative adaptive sampling (tracking; ModSkill).
    pub active: crate::config_active::ActiveConfig,
    /// On `--resume`: start fresh episodes instead of continuing the environments saved in the
    /// checkpoint. By default a resume continues them exactly (the run goes on as if it had
    /// never stopped) and refuses a checkpoint whose environment configuration differs; set this
    /// to resume such a checkpoint anyway, with new episodes (no longer the same run).
    pub fresh_episodes: bool,
    /// Save the run's state (environments, streams, the motion prior's replay buffer) with every
    /// checkpoint, so that a resume continues exactly. Measured at preset `small` on 256
    /// environments: 8.1 MB per checkpoint (0.58 × the policy-only file), 189 MB with the motion
    /// prior on (its 8192-window replay buffer; docs/results/exact-resume). `false` writes
    /// checkpoints without it (their resumes start fresh episodes).
    pub save_run_state: bool,
}

impl Default for RunConfig {
    fn default() -> Self {
        Self {
            iterations: 100,
            seed: 0,
            out_dir: PathBuf::from("runs/skillmimic"),
            save_every: 50,
            learner_threads: 0,
            final_video: true,
            eval_episodes: 16,
            active: Default::default(),
            fresh_episodes: false,
            save_run_state: true,
        }
    }
}

/// The whole training configuration: `[env]`, `[ppo]` and `[run]` tables of one TOML file.
#[derive(Clone, Debug, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct TrainConfig {
    /// Environment: clips, parallel environments, reward, ball, SkillMimic-V2 options.
    pub env: EnvConfig,
    /// PPO hyper-parameters.
    pub ppo: PpoConfig,
    /// Run-level settings.
    pub run: RunConfig,
}

impl TrainConfig {
    /// The high-level controller's settings (reference-facts §8.3) for a high-level task:
    /// `categorical_mlp`, hidden [1024, 512] when the widths are still the defaults, and
    /// two minibatches per iteration (four for `scoring`), as 65 536 samples with
    /// minibatch 32 768 (16 384) in the original; the released 2 000 iterations (6 000 for
    /// `scoring`) when `run.iterations` is still the default 100 (`HighLevel::iterations` of the registry; a
    /// preset's, a file's or a flag's count stays). Horizon 32, 6 mini-epochs, lr 2e-5, γ 0.99,
    /// λ 0.95, clip 0.2 and critic coefficient 5 are the skill policy's defaults already; the
    /// categorical loss has no bounds term.
    ///
    /// Over a `modular_attention` checkpoint (ModSkill skill reuse, continuous part embeddings)
    /// the family stays `gaussian_mlp` — the paper's high-level policy is a Gaussian with fixed
    /// σ — with the same hidden widths and minibatches on CPU (the paper's MLP is
    /// [2048, 1024, 512]: `--set 'ppo.hidden=[2048, 1024, 512]'`). An unreadable `env.hlc.llc`
    /// is reported when the environment is built.
    pub fn use_high_level_defaults(&mut self) {
        let latent = skillmimic_nn::frozen_parts::policy_family(&self.env.table::<HlcConfig>().llc)
            .ok()
            .flatten()
            .as_deref()
            == Some("modular_attention");
        self.ppo.policy = if latent { "gaussian_mlp" } else { "categorical_mlp" }.into();
        if self.ppo.hidden == PpoConfig::default().hidden {
            self.ppo.hidden = vec![1024, 512];
        }
        let high_level = skillmimic_env::registry::entry(&self.env.task).and_then(|e| e.high_level);
        let parts = high_level.map_or(2, |h| h.minibatches);
        self.ppo.minibatch = (self.batch_size() / parts).max(1);
        if let Some(h) =
            high_level.filter(|_| self.run.iterations == RunConfig::default().iterations)
        {
            self.run.iterations = h.iterations;
        }
    }

    /// Samples collected per iteration.
    pub fn batch_size(&self) -> usize {
        self.env.num_envs * self.ppo.horizon
    }

    /// Parse a TOML document over the preset `base` (fields absent from the file keep the
    /// preset's values).
    pub fn from_toml_over(
        base: &TrainConfig,
        text: &str,
        source: &Path,
    ) -> Result<Self, LearnError> {
        let mut doc = toml::Table::try_from(base).map_err(|e| LearnError::Config(e.to_string()))?;
        let user: toml::Table = text.parse().map_err(|e: toml::de::Error| {
            LearnError::Config(format!("{}: {e}", source.display()))
        })?;
        merge(&mut doc, user);
        let cfg: TrainConfig = doc.try_into().map_err(|e: toml::de::Error| {
            LearnError::Config(format!("{}: {e}", source.display()))
        })?;
        Ok(cfg)
    }

    /// Apply one `key.path=value` override (value in TOML syntax; bare words are strings).
    pub fn set(&mut self, assignment: &str) -> Result<(), LearnError> {
        let (key, value) = assignment.split_once('=').ok_or_else(|| {
            LearnError::Config(format!("override '{assignment}' is not key=value"))
        })?;
        let value_toml: toml::Value = match format!("v = {value}").parse::<toml::Table>() {
            Ok(t) => t["v"].clone(),
            Err(_) => toml::Value::String(value.to_string()),
        };
        let mut doc =
            toml::Table::try_from(&*self).map_err(|e| LearnError::Config(e.to_string()))?;
        let mut table = &mut doc;
        let parts: Vec<&str> = key.trim().split('.').collect();
        for p in &parts[..parts.len() - 1] {
            table = table
                .get_mut(*p)
                .and_then(|v| v.as_table_mut())
                .ok_or_else(|| LearnError::Config(format!("override '{key}': no table '{p}'")))?;
        }
        let last = parts[parts.len() - 1];
        // optional fields that are unset (e.g. `env.seed`) are absent from the serialised table:
        // the typed deserialisation decides whether an absent key exists
        let known = table.contains_key(last);
        table.insert(last.to_string(), value_toml);
        match doc.try_into::<TrainConfig>() {
            Ok(c) => *self = c,
            Err(e) if !known && e.to_string().contains("unknown field") => {
                return Err(LearnError::Config(format!(
                    "override '{key}': unknown field '{last}'"
                )));
            }
            Err(e) => return Err(LearnError::Config(format!("override '{assignment}': {e}"))),
        }
        Ok(())
    }

    /// The configuration as TOML text (saved next to every checkpoint).
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).expect("serialisable config")
    }

    /// Check the documented range of every number ([`Self::validate_ranges`]), then the
    /// environment's and the cross-field rules.
    pub fn validate(&self) -> Result<(), LearnError> {
        self.validate_ranges()?;
        self.env.validate().map_err(|e| LearnError::Config(e.to_string()))?;
        self.run.active.validate(&self.env.task).map_err(LearnError::Config)?;
        if self.run.active.enabled && self.run.active.disc_score_min > 0.0 && !self.ppo.amp.enabled
        {
            return Err(LearnError::Config(
                "config field 'run.active.disc_score_min': the \
                discriminator filter needs the motion prior (--set ppo.amp.enabled=true)"
                    .into(),
            ));
        }
        let p = &self.ppo;
        if p.hidden.is_empty() {
            return Err(LearnError::Config(
                "config field 'ppo.hidden': needs at least one non-zero layer width".into(),
            ));
        }
        let a = &p.amp;
        if a.enabled && (a.buffer < a.batch || a.hidden.is_empty()) {
            return Err(LearnError::Config(
                "config fields 'ppo.amp.buffer', 'ppo.amp.hidden': \
                buffer must be >= batch, hidden non-empty"
                    .into(),
            ));
        }
        if p.minibatch > self.batch_size() {
            return Err(LearnError::Config(format!(
                "config field 'ppo.minibatch': {} exceeds the samples per iteration (num_envs {} \
                    x horizon {} = {})",
                p.minibatch,
                self.env.num_envs,
                p.horizon,
                self.batch_size()
            )));
        }
        match (p.device.as_str(), p.backend) {
            ("cpu", _) => {}
            ("cuda", Backend::Candle) if cfg!(feature = "cuda") => {}
            ("cuda", Backend::Candle) => {
                return Err(LearnError::Config(
                    "config field 'ppo.device': \"cuda\" needs a build \
                    with the `cuda` cargo feature (cargo build --features cuda)"
                        .into(),
                ));
            }
            ("cuda", Backend::Fast) => {
                return Err(LearnError::Config(
                    "config field 'ppo.device': \
                \"cuda\" runs on the candle backend; set ppo.backend = \"candle\""
                        .into(),
                ));
            }
            (other, _) => {
                return Err(LearnError::Config(format!(
                    "config field 'ppo.device': \
                '{other}' is not a device, expected \"cpu\" or \"cuda\""
                )));
            }
        }
        Ok(())
    }

    /// Check every number of the configuration against its documented range (the schemars
    /// attributes on the fields, shown in `docs/config.md`) and finiteness; the error names the
    /// key (`ppo.gamma`), the value and the range. Also the check of configurations stored in
    /// checkpoints.
    pub fn validate_ranges(&self) -> Result<(), LearnError> {
        skillmimic_env::config_range::check_ranges(self, "")
            .map_err(|e| LearnError::Config(e.to_string()))
    }
}

fn merge(base: &mut toml::Table, user: toml::Table) {
    for (k, v) in user {
        match (base.get_mut(&k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(u)) => merge(b, u),
            (_, v) => {
                base.insert(k, v);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn toml_overrides_keep_preset_values_and_reject_typos() {
        let base = TrainConfig::preset("tiny").unwrap();
        let c = TrainConfig::from_toml_over(
            &base,
            "[ppo]\nlr = 3e-4\n[env]\nnum_envs = 8\n",
            Path::new("x.toml"),
        )
        .unwrap();
        assert_eq!(c.ppo.lr, 3e-4);
        assert_eq!(c.ppo.hidden, vec![256, 128]);
        assert_eq!(c.env.num_envs, 8);
        let e =
            TrainConfig::from_toml_over(&base, "[ppo]\nlearning_rate = 1\n", Path::new("x.toml"))
                .unwrap_err();
        assert!(e.to_string().contains("x.toml") && e.to_string().contains("learning_rate"), "{e}");
        let mut c = base.clone();
        c.set("ppo.mini_epochs=3").unwrap();
        c.set("env.reward.variant=additive").unwrap();
        c.set("env.hands=\"box\"").unwrap();
        assert_eq!(c.ppo.mini_epochs, 3);
        assert_eq!(c.env.hands, "box");
        assert!(c.set("ppo.nope=1").unwrap_err().to_string().contains("unknown field 'nope'"));
        // an optional field that is unset by default can be set
        c.set("env.seed=3").unwrap();
        assert_eq!(c.env.seed, Some(3));
        assert!(c.set("env.seed=-1").is_err());
        assert!(c.set("ppo.lr=fast").is_err());
        let round =
            TrainConfig::from_toml_over(&TrainConfig::default(), &c.to_toml(), Path::new("r.toml"))
                .unwrap();
        assert_eq!(round, c);
    }
}
