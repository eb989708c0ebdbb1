//! Policy families, chosen by name (`ppo.policy`): the distribution an actor's outputs define,
//! how actions are sampled, their log-probability as a candle graph (for the one canonical PPO
//! loss), the family's extra loss terms, and the checkpoint's family tensors.
//!
//! Adding a family = one module implementing [`PolicyFamily`] and one line in [`FAMILIES`] (plus
//! its PyTorch mirror in `python/skillmimic_rs/policy.py`).
//!
//! * [`gaussian_mlp`]: fixed-σ diagonal Gaussian over MLP action means (SkillMimic's policy);
//! * [`categorical_mlp`]: categorical distribution over MLP logits (discrete actions, e.g. a
//!   high-level policy choosing skills);
//! * [`modular_attention`]: ModSkill's per-part attention actor with the fixed-σ Gaussian;
//! * [`token_transformer`]: TokenHSI's token transformer with the fixed-σ Gaussian
//!   (`token_transformer`) or a categorical head (`token_transformer_categorical`).

pub mod categorical_mlp;
pub mod family;
pub mod gaussian_mlp;
pub mod modular_attention;
pub mod token_transformer;

pub use family::{ExtraLoss, Head, ObsInfo, PolicyFamily};

use crate::error::LearnError;

/// Every family, in listing order.
pub const FAMILIES: &[&dyn PolicyFamily] = &[
    &gaussian_mlp::GaussianMlp,
    &categorical_mlp::CategoricalMlp,
    &modular_attention::ModularAttentionFamily,
    &token_transformer::GAUSSIAN,
    &token_transformer::CATEGORICAL,
];

/// The family named `name`.
pub fn family(name: &str) -> Result<&'static dyn PolicyFamily, LearnError> {
    FAMILIES.iter().copied().find(|f| f.name() == name).ok_or_else(|| {
        let known: Vec<&str> = FAMILIES.iter().map(|f| f.name()).collect();
        LearnError::Config(format!(
            "config field 'ppo.policy': unknown policy family '{name}'; registered: {}",
            known.join(", ")
        ))
    })
}
