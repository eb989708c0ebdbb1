//! Networks of skillmimic-rs, below the environment so that an environment can run a frozen
//! network (the SkillMimic-V2 history encoder; a skill policy inside a high-level task) and the
//! learner can train the same definition.
//!
//! * [`network`]: the [`Network`] trait — PyTorch `state_dict` names/shapes and a candle forward;
//! * [`mlp`]: Linear+ReLU MLPs with fast batched CPU inference ([`kernel`]: small-batch kernels);
//! * [`bf16`]: bf16 × bf16 → float32 matrix products (AVX512-BF16) for the reduced-precision
//!   update;
//! * [`normalizer`]: running mean/std normalisers (observations, values);
//! * [`frozen`]: a frozen skill policy's deterministic actor with its normaliser (high-level
//!   tasks);
//! * [`frozen_parts`]: the frozen part controllers of a modular checkpoint (ModSkill skill reuse);
//! * [`history`]: the SkillMimic-V2 history encoder (candle forward, plain pass, online buffer);
//! * [`modular`]: ModSkill's modular attention actor (per-part tokens, attention, controllers);
//! * [`attention`]: multi-head attention and a transformer encoder layer (candle-nn), with the
//!   parameter names of PyTorch's `nn.MultiheadAttention` / `nn.TransformerEncoderLayer`;
//! * [`token`]: TokenHSI's token transformer actor (tokenizers, masked encoder, adapters).

pub mod attention;
pub mod bf16;
pub mod frozen;
pub mod frozen_parts;
pub mod history;
pub mod history_reference;
pub mod kernel;
pub mod mlp;
pub mod modular;
pub mod network;
pub mod normalizer;
pub mod policy_net;
pub mod token;

pub use network::{NamedTensor, Network};
