//! Learning for skillmimic-rs: PPO with a fixed-σ Gaussian policy (SkillMimic's rl_games
//! settings) in candle.
//!
//! * [`config`]: PPO / run configuration with the paper's defaults and presets;
//! * [`config_doc`]: the generated configuration reference `docs/config.md`;
//! * [`policies`]: policy families by name (`gaussian_mlp`, `categorical_mlp`);
//! * [`policy`]: the actor–critic over `skillmimic_nn` MLPs (PyTorch layout), batched inference;
//! * [`ppo`]: the canonical loss (candle autograd), its fast specialisation, the update, GAE;
//! * [`adapt`]: policy adaptation of a token transformer (TokenHSI: frozen base, new tokenizer,
//!   adapters);
//! * [`active`]: active skill learning (clip evaluation, generation, failure-weighted sampling);
//! * [`amp`]: the adversarial motion prior's discriminator (style reward);
//! * [`adam`]: Adam with exposed state; [`storage`]: rollout buffers; [`error`]: typed errors;
//! * [`eval`]: SkillMimic / SkillMimic-V2 metrics; [`episode_eval`]: any task's episode report;
//!   [`tracking_eval`]: PHC's and ModSkill's tracking evaluation (every motion once);
//! * [`checkpoint`]: safetensors checkpoints that load into the PyTorch module;
//! * [`onnx`]: ONNX export (normaliser folded in, deployment metadata), [`rlgames`]: rl_games
//!   import;
//! * [`trainer`]: rollouts on any registered task's environment and PPO updates;
//! * [`runner`]: the training loop — logs, checkpoints, end-of-run evaluation, hooks, summary;
//!   [`divergence`]: when training stops as diverged; [`run_dir`]: the run folder on start and
//!   resume;
//! * [`collective`], [`shard`], [`sync`]: data-parallel training (the collective operations, which
//!   environments and samples a rank holds, the start-of-run agreement);
//! * [`tblog`]: TensorBoard scalar event files.

pub mod active;
pub mod active_resume;
pub mod actor;
pub mod adam;
pub mod adapt;
pub mod amp;
pub mod amp_reward;
#[cfg(feature = "args")]
pub mod args;
pub mod checkpoint;
pub mod collective;
pub mod config;
pub mod config_active;
pub mod config_doc;
pub mod config_file;
pub mod config_policies;
pub mod config_presets;
pub mod config_token;
pub mod divergence;
pub mod episode_eval;
pub mod error;
pub mod eval;
pub mod eval_report;
pub mod eval_skillmimic;
pub mod history_pretrain;
pub mod iteration_stats;
pub mod onnx;
pub mod policies;
pub mod policy;
pub mod ppo;
pub mod rlgames;
pub mod run_dir;
pub mod runner;
pub mod shard;
pub mod storage;
pub mod sync;
pub mod tblog;
pub mod tracking_eval;
pub mod trainer;

pub use error::LearnError;
