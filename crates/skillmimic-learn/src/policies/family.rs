//! The policy-family trait and what its methods read of a policy.

use candle_core::Tensor;
use rand::RngCore;
use skillmimic_env::ActionSpace;

use crate::config::PpoConfig;

/// What a family reads of a policy besides the actor outputs.
#[derive(Clone, Copy, Debug)]
pub struct Head<'a> {
    /// Actor outputs per row (Gaussian: action dimensions; categorical: choices).
    pub outputs: usize,
    /// Fixed log σ per action dimension (Gaussian; empty otherwise).
    pub log_std: &'a [f32],
}

/// What a family may know of the observation it reads besides its width: the character whose
/// proprioception starts it ([`skillmimic_env::proprio`]) and the task's per-body blocks
/// (`TaskSpec::body_blocks`). ModSkill's part tokens are built from them.
#[derive(Clone, Debug)]
pub struct ObsInfo {
    /// Observation width.
    pub dim: usize,
    pub character: skillmimic_core::characters::Character,
    /// (body, columns) of the task's blocks that describe one body.
    pub body_blocks: Vec<(usize, std::ops::Range<usize>)>,
}

impl ObsInfo {
    /// An observation `dim` wide of the default character (the SkillMimic humanoid) without
    /// per-body task blocks.
    pub fn of_dim(dim: usize) -> Self {
        Self { dim, character: Default::default(), body_blocks: Vec::new() }
    }
    /// The observation of `env`'s task on `character`.
    pub fn of_env(
        env: &dyn skillmimic_env::Env,
        character: skillmimic_core::characters::Character,
    ) -> Self {
        Self { dim: env.obs_dim(), character, body_blocks: env.spec().body_blocks.clone() }
    }
}

/// Extra loss of a family with its diagnostic parts.
pub struct ExtraLoss {
    /// Added to the PPO loss (already weighted).
    pub total: Tensor,
    /// Action-mean bounds loss (Gaussian; unweighted), else zero.
    pub bounds: Option<Tensor>,
    /// Mean entropy of the distribution, when the family computes it.
    pub entropy: Option<Tensor>,
}

/// A policy family (see the module doc).
pub trait PolicyFamily: Send + Sync + 'static {
    /// Registry name (`ppo.policy`).
    fn name(&self) -> &'static str;
    /// Whether the family can act in `space`.
    fn supports(&self, space: &ActionSpace) -> bool;
    /// Whether the family can act in `space` on the observation `obs` describes (its character:
    /// a part-wise family needs the character's body parts and dofs); default [`Self::supports`].
    fn acts_on(&self, space: &ActionSpace, _obs: &ObsInfo) -> bool {
        self.supports(space)
    }
    /// Whether the policy carries a fixed per-dimension log σ (`Policy::log_std`, checkpoint
    /// tensor `log_std`).
    fn uses_log_std(&self) -> bool {
        false
    }
    /// Actor output width for `space`.
    fn actor_outputs(&self, space: &ActionSpace) -> usize;
    /// Build the actor network when it is not an MLP (default: `None`, an MLP
    /// `obs → ppo.hidden → actor_outputs`). `rng` continues the policy's initialisation stream.
    fn build_actor(
        &self,
        _obs: &ObsInfo,
        _space: &ActionSpace,
        _cfg: &PpoConfig,
        _rng: &mut dyn RngCore,
    ) -> Result<Option<crate::actor::ActorNet>, crate::error::LearnError> {
        Ok(None)
    }
    /// Rebuild the actor from checkpoint `f` when it is not an MLP (default: `None`, the MLP
    /// tensors `actor.*`); errors name what is wrong with the file.
    fn read_actor(
        &self,
        _f: &skillmimic_core::tensorfile::TensorFile,
        _obs_dim: usize,
        _space: &ActionSpace,
    ) -> Result<Option<crate::actor::ActorNet>, String> {
        Ok(None)
    }
    /// The description of a non-MLP actor saved as the checkpoint's `actor_net` metadata (what
    /// [`PolicyFamily::read_actor`] rebuilds it from); default: none (an MLP, rebuilt from its
    /// tensors).
    fn describe_actor(&self, _actor: &crate::actor::ActorNet) -> Option<String> {
        None
    }
    /// Re-initialise the actor's output layer after the default initialisation (default: keep
    /// it). `rng` continues the policy's initialisation stream.
    fn init_output_layer(&self, _actor: &mut skillmimic_nn::mlp::Mlp, _rng: &mut dyn RngCore) {}
    /// Sample actions (`n × space.width()`) from actor outputs `out` (`n × head.outputs`) and
    /// write their negative log-probabilities.
    fn sample(
        &self,
        head: Head<'_>,
        out: &[f32],
        n: usize,
        rng: &mut dyn RngCore,
        actions: &mut [f32],
        neglogp: &mut [f32],
    );
    /// Deterministic actions (mean / most likely choice).
    fn mode(&self, head: Head<'_>, out: &[f32], n: usize, actions: &mut [f32]);
    /// Negative log-probabilities `(n,)` of `actions` under actor outputs `out` (candle graph).
    fn neglogp(
        &self,
        head: Head<'_>,
        out: &Tensor,
        actions: &Tensor,
    ) -> candle_core::Result<Tensor>;
    /// The family's extra loss terms (candle graph over the actor outputs).
    fn extra_loss(&self, out: &Tensor, cfg: &PpoConfig) -> candle_core::Result<ExtraLoss>;
}

impl std::fmt::Debug for dyn PolicyFamily {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl PartialEq for dyn PolicyFamily {
    fn eq(&self, o: &Self) -> bool {
        self.name() == o.name()
    }
}
