//! The SkillMimic environment of skillmimic-rs (one implementation for training, evaluation and
//! Python).
//!
//! * [`config`]: typed configuration with the paper's defaults;
//! * [`obs`]: the 902-wide skill-policy observation and its index table;
//! * [`hoi`]: HOI states (simulated and reference) and contact-graph states;
//! * [`reward`]: the unified HOI imitation reward, every sub-term and the ablation variants;
//! * [`episode`]: reference-state initialisation and episode bookkeeping;
//! * [`env`]: the batched environment;
//! * [`replay`]: kinematic replay of clips scored against themselves;
//! * [`synth`]: procedural demo clips (IK stand-and-dribble) shipped in `motions/`;
//! * [`metrics`]: evaluation metrics (Acc, MPJPE, E_cg, skill success rules of V1 and V2);
//! * [`v2`]: SkillMimic-V2 — history encoder, State Transition Field, Stitched Trajectory Graph,
//!   Adaptive Trajectory Sampling.

pub mod config;
pub mod env;
pub mod episode;
pub mod hoi;
pub mod metrics;
pub mod obs;
pub mod replay;
pub mod reward;
pub mod synth;
pub mod v2;

pub use config::{ContactGraphMode, EnvConfig, RewardConfig, RewardVariant, StateInit};
pub use env::{BUILTIN_DEMO, EnvError, ResetPlan, SkillEnv, StepBuffers, load_motion_library};
