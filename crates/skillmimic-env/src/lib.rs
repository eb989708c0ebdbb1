//! The environments of skillmimic-rs: one batched driver, a registry of tasks (one
//! implementation each for training, evaluation and Python).
//!
//! * [`task`]: the task seam (spaces, term names, reset plans, observe, reward, done, metrics);
//! * [`vec_env`]: the batched driver shared by every task, and its object-safe face [`Env`];
//! * [`registry`]: task name → constructor ([`registry::make`]);
//! * [`tasks`]: `imitation` (SkillMimic + V2), `stand` (the worked example) and the high-level
//!   tasks of skill reuse over a frozen skill policy (`heading`, `circling`, `throwing`, `scoring`);
//! * [`config`], [`config_v2`], [`config_table`]: typed configuration with the papers' defaults —
//!   the driver's and the imitation task's keys, and the tables each task owns;
//! * [`compat`]: the `env.compat` profile (paper vs released code where they differ);
//! * [`markers`]: visual-only task markers (goal spheres, rings, hoops) for videos and viewers;
//! * [`obs_blocks`]: named observation blocks and the layouts tasks declare (ONNX metadata,
//!   gymnasium bounds);
//! * [`obs`]: the 902-wide skill-policy observation and its index table;
//! * [`hoi`]: HOI states (simulated and reference) and contact-graph states;
//! * [`reward`]: the unified HOI imitation reward, every sub-term and the ablation variants;
//! * [`episode`]: reference-state initialisation and episode bookkeeping;
//! * [`replay`]: kinematic replay of clips scored against themselves;
//! * [`synth`]: procedural demo clips (IK stand-and-dribble) shipped in `motions/`;
//! * [`metrics`]: evaluation metrics (Acc, MPJPE, E_cg, skill success rules of V1 and V2);
//! * [`v2`]: SkillMimic-V2 — history features, State Transition Field, Stitched Trajectory Graph,
//!   Adaptive Trajectory Sampling (the history encoder network is `skillmimic_nn::history`).

pub mod amp;
pub mod clip_state;
pub mod compat;
pub mod config;
pub mod config_physics;
pub mod config_range;
pub mod config_table;
pub mod config_v2;
pub mod episode;
pub mod error;
pub mod hoi;
pub mod markers;
pub mod metrics;
pub mod obs;
pub mod obs_blocks;
pub mod proprio;
pub mod registry;
pub mod replay;
pub mod reward;
pub mod synth;
pub mod task;
pub mod tasks;
pub mod v2;
pub mod vec_env;

pub use compat::Compat;
pub use config::{ContactGraphMode, EnvConfig, RewardConfig, RewardVariant, StateInit};
pub use error::EnvError;
pub use task::{ActionSpace, Task, TaskSpec};
pub use tasks::imitation::{
    BUILTIN_DEMO, FRAME_METRIC_NAMES, ImitationSlot, NUM_FRAME_METRICS, ResetPlan, SkillEnv,
    load_motion_library,
};
pub use vec_env::{Env, StepBuffers, VecEnv};
