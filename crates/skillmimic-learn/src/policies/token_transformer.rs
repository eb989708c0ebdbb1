//! `token_transformer` / `token_transformer_categorical`: TokenHSI's transformer policy (seed 004
//! §C–E; modskill-tokenhsi-facts §2.3) — the actor is [`skillmimic_nn::token::TokenTransformer`]
//! (one tokenizer per observation group, a learnable output token, a masked transformer encoder,
//! the action head); the distribution is the fixed-σ Gaussian of [`super::gaussian_mlp`]
//! (`token_transformer`: TokenHSI's log σ = −2.9 is `ppo.log_std`'s default) or the categorical of
//! [`super::categorical_mlp`] over the head's logits (`token_transformer_categorical`: a
//! multi-task high-level controller over a frozen skill policy). The critic is an MLP over the
//! whole normalised observation (`ppo.hidden`; TokenHSI: [2048, 1024, 512]).
//!
//! Observation groups come from `ppo.token.groups` or, when that is empty, from the task's
//! layout (`TaskSpec::token_groups`, filled in by the trainer). The mask block is passed to the
//! actor raw (the policy does not normalise it).
//!
//! Checkpoint: tensors `actor.<state_dict name>` (frozen ones included), critic and `log_std`
//! as the MLP families; metadata `actor_net` = [`TokenSpec`] as JSON. PyTorch mirror:
//! `skillmimic_rs.policy.TokenTransformerPolicy`.

use candle_core::Tensor;
use rand::RngCore;
use skillmimic_env::ActionSpace;
use skillmimic_nn::token::{TokenSpec, TokenTransformer};

use super::categorical_mlp::CategoricalMlp;
use super::family::{ExtraLoss, Head, PolicyFamily};
use super::gaussian_mlp::GaussianMlp;
use crate::actor::ActorNet;
use crate::config::PpoConfig;
use crate::error::LearnError;

/// `cfg` with `token.groups` filled in from the task when empty: the task's declared
/// observation groups (`TaskSpec::token_groups`), or one group `obs` of the whole observation
/// for a task that declares none.
pub fn with_task_groups(cfg: &PpoConfig, spec: &skillmimic_env::TaskSpec) -> PpoConfig {
    let mut c = cfg.clone();
    if c.token.groups.is_empty() {
        c.token.groups = if spec.token_groups.is_empty() {
            vec![format!("obs:{}", spec.obs_dim)]
        } else {
            spec.token_groups.iter().map(|(n, w)| format!("{n}:{w}")).collect()
        };
    }
    c
}

/// The network description for observations of width `obs_dim` from `[ppo.token]`.
pub fn spec(
    cfg: &crate::config_token::TokenConfig,
    obs_dim: usize,
) -> Result<TokenSpec, LearnError> {
    let (groups, mask) = cfg.parsed_groups().map_err(LearnError::Config)?;
    if groups.is_empty() {
        return Err(LearnError::Config(
            "config field 'ppo.token.groups' is empty and the task \
            declares no observation groups: set it to \"name:width\" entries (proprioception \
            first, \"mask:K\" last)"
                .into(),
        ));
    }
    let s = TokenSpec {
        groups,
        mask,
        tokenizer: cfg.tokenizer.clone(),
        embed: cfg.embed,
        layers: cfg.layers,
        heads: cfg.heads,
        feedforward: cfg.feedforward,
        head: cfg.head.clone(),
        adapters: false,
        adapter_gate: Vec::new(),
        frozen: Vec::new(),
        frozen_obs: Vec::new(),
    };
    s.check().map_err(|e| LearnError::Config(format!("config field 'ppo.token': {e}")))?;
    if s.obs_dim() != obs_dim {
        return Err(LearnError::Config(format!(
            "config field 'ppo.token.groups': the groups {:?} and mask {} cover {} observation \
                columns, the task's observation has {obs_dim}",
            cfg.groups,
            s.mask,
            s.obs_dim()
        )));
    }
    Ok(s)
}

/// Rebuild the network described by the metadata text `spec_json` and fill every tensor (frozen
/// ones included) from `actor.*` of `f` (shapes checked).
pub fn read(
    f: &skillmimic_core::tensorfile::TensorFile,
    spec_json: &str,
    obs_dim: usize,
    act_dim: usize,
) -> Result<TokenTransformer, String> {
    let spec: TokenSpec = serde_json::from_str(spec_json)
        .map_err(|e| format!("metadata 'actor_net' is not a token transformer description: {e}"))?;
    if spec.obs_dim() != obs_dim {
        return Err(format!(
            "metadata 'actor_net' describes observations of {}, obs_dim is {obs_dim}",
            spec.obs_dim()
        ));
    }
    let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(0);
    let mut net = TokenTransformer::new(spec, act_dim, &mut rng)
        .map_err(|e| format!("metadata 'actor_net': {e}"))?;
    for t in net.tensors.iter_mut() {
        let want: Vec<Option<usize>> = t.shape.iter().map(|&d| Some(d)).collect();
        t.data = f.f32(&format!("actor.{}", t.name), &want).map_err(|e| e.to_string())?.1;
    }
    Ok(net)
}

/// A token transformer family: the network of this module with the distribution of `dist`
/// (action space, σ, sampling, log-probability and extra loss are `dist`'s).
pub struct TokenFamily {
    name: &'static str,
    dist: &'static dyn PolicyFamily,
}

/// The Gaussian token transformer (TokenHSI's policy).
pub static GAUSSIAN: TokenFamily = TokenFamily { name: "token_transformer", dist: &GaussianMlp };
/// The categorical token transformer (discrete choices: a multi-task high-level controller).
pub static CATEGORICAL: TokenFamily =
    TokenFamily { name: "token_transformer_categorical", dist: &CategoricalMlp };

impl PolicyFamily for TokenFamily {
    fn name(&self) -> &'static str {
        self.name
    }
    fn supports(&self, space: &ActionSpace) -> bool {
        self.dist.supports(space)
    }
    fn uses_log_std(&self) -> bool {
        self.dist.uses_log_std()
    }
    fn actor_outputs(&self, space: &ActionSpace) -> usize {
        self.dist.actor_outputs(space)
    }
    fn build_actor(
        &self,
        obs: &super::family::ObsInfo,
        space: &ActionSpace,
        cfg: &PpoConfig,
        rng: &mut dyn RngCore,
    ) -> Result<Option<ActorNet>, LearnError> {
        let s = spec(&cfg.token, obs.dim)?;
        let net = TokenTransformer::new(s, self.actor_outputs(space), rng)
            .map_err(|e| LearnError::Config(format!("config field 'ppo.token': {e}")))?;
        Ok(Some(ActorNet::from(net)))
    }
    fn read_actor(
        &self,
        f: &skillmimic_core::tensorfile::TensorFile,
        obs_dim: usize,
        space: &ActionSpace,
    ) -> Result<Option<ActorNet>, String> {
        let text = f.meta("actor_net").map_err(|e| e.to_string())?;
        Ok(Some(ActorNet::from(read(f, text, obs_dim, self.actor_outputs(space))?)))
    }
    /// The network's [`TokenSpec`] as JSON.
    fn describe_actor(&self, actor: &ActorNet) -> Option<String> {
        let t = actor.downcast_ref::<skillmimic_nn::token::TokenTransformer>()?;
        Some(serde_json::to_string(&t.spec).expect("a serialisable description"))
    }
    fn sample(
        &self,
        head: Head<'_>,
        out: &[f32],
        n: usize,
        rng: &mut dyn RngCore,
        actions: &mut [f32],
        neglogp: &mut [f32],
    ) {
        self.dist.sample(head, out, n, rng, actions, neglogp)
    }
    fn mode(&self, head: Head<'_>, out: &[f32], n: usize, actions: &mut [f32]) {
        self.dist.mode(head, out, n, actions)
    }
    fn neglogp(
        &self,
        head: Head<'_>,
        out: &Tensor,
        actions: &Tensor,
    ) -> candle_core::Result<Tensor> {
        self.dist.neglogp(head, out, actions)
    }
    fn extra_loss(&self, out: &Tensor, cfg: &PpoConfig) -> candle_core::Result<ExtraLoss> {
        self.dist.extra_loss(out, cfg)
    }
}
