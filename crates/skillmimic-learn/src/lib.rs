//! Learning for skillmimic-rs: PPO with a fixed-σ Gaussian policy (SkillMimic's rl_games
//! settings) in candle.
//!
//! * [`config`]: PPO / run configuration with the paper's defaults and presets;
//! * [`normalizer`]: running mean/std of observations and values;
//! * [`mlp`], [`policy`]: actor–critic MLPs (PyTorch layout), batched inference;
//! * [`ppo`]: losses and gradients (candle autograd); [`adam`]: Adam with exposed state;
//! * [`gae`]: advantages and returns;
//! * [`checkpoint`]: safetensors checkpoints that load into the PyTorch module;
//! * [`trainer`]: rollouts on the environment, updates, logs and checkpoints;
//! * [`tblog`]: TensorBoard scalar event files.

pub mod adam;
pub mod checkpoint;
pub mod config;
pub mod eval;
pub mod fast;
pub mod gae;
pub mod history_pretrain;
pub mod kernel;
pub mod mlp;
pub mod normalizer;
pub mod policy;
pub mod ppo;
pub mod tblog;
pub mod trainer;
