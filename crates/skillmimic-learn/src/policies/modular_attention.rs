//! `modular_attention`: ModSkill's policy (seed 001 §3.2–3.3; modskill-tokenhsi-facts §1.3–1.4) on
//! the SkillMimic humanoid — the actor is [`skillmimic_nn::modular::ModularAttention`], the
//! distribution the fixed-σ Gaussian of [`super::gaussian_mlp`] (same log σ, sampling,
//! log-probability and bounds loss), the critic an MLP over the whole observation (`ppo.hidden`).
//!
//! **Parts** (`ppo.modular.parts`): `five` = left leg (L_Hip…L_Toe), right leg, torso (Pelvis,
//! Torso, Spine, Spine2, Chest, Neck, Head), left arm with its hand (L_Thorax…L_Thumb3), right arm
//! with its hand — ModSkill's split; `seven` = the same with each hand (wrist and fingers) as its
//! own part. A part drives the 3 joint coordinates of each of its non-root bodies.
//!
//! **Tokens** (our choice, the observation has no per-part reference block as PHC's has): part k's
//! token = for each of its bodies b, in body order, the body's blocks of the observation —
//! position (b ≥ 1; 3), rotation (6), linear velocity (3), angular velocity (3) and, for a
//! fingertip, its contact force (3) — followed by the **shared** features appended to every
//! token: root height (1) and every column after the 823 humanoid entries (imitation: the ball
//! (15), the 64-wide skill condition, a SkillMimic-V2 history embedding; a high-level task: the
//! ball and the task part; `stand`: its task entries). Columns: `skillmimic_env::obs::layout`.
//!
//! Checkpoint: tensors `actor.parts.{k}.{q,k,v}.{0,1}.{weight,bias}`,
//! `actor.parts.{k}.controller.{0,2,…}.{weight,bias}`, critic and `log_std` as `gaussian_mlp`;
//! metadata `actor_net` = [`ModularSpec`] as JSON. PyTorch mirror:
//! `skillmimic_rs.policy.ModularAttentionPolicy`.

use candle_core::Tensor;
use rand::RngCore;
use skillmimic_core::characters::skillmimic::{BODIES, FINGERTIPS, dof_range};
use skillmimic_env::ActionSpace;
use skillmimic_env::obs::layout;
use skillmimic_nn::modular::{ModularAttention, ModularShape};

use super::family::{ExtraLoss, Head, PolicyFamily};
use super::gaussian_mlp::GaussianMlp;
use crate::actor::ActorNet;
use crate::config::{ModularConfig, PpoConfig};
use crate::error::LearnError;

/// The network description stored in a checkpoint's metadata `actor_net` (defined below the
/// environment, where the frozen part controllers of skill reuse read it).
pub use skillmimic_nn::modular::ModularSpec;

/// Bodies of each part of a split (`five` / `seven`; `skillmimic_core::characters::skillmimic::body_parts`).
pub fn part_bodies(split: &str) -> Result<Vec<(&'static str, Vec<usize>)>, LearnError> {
    skillmimic_core::characters::skillmimic::body_parts(split).ok_or_else(|| {
        LearnError::Config(format!(
            "config field \
        'ppo.modular.parts': '{split}' is not a body split, expected \"five\" or \"seven\""
        ))
    })
}

/// Observation columns of body `b`'s own blocks (see the module doc).
pub fn body_columns(b: usize) -> Vec<usize> {
    let mut c = Vec::new();
    if b >= 1 {
        c.extend(layout::BODY_POS.start + 3 * (b - 1)..layout::BODY_POS.start + 3 * b);
    }
    c.extend(layout::BODY_ROT.start + 6 * b..layout::BODY_ROT.start + 6 * (b + 1));
    c.extend(layout::BODY_LINVEL.start + 3 * b..layout::BODY_LINVEL.start + 3 * (b + 1));
    c.extend(layout::BODY_ANGVEL.start + 3 * b..layout::BODY_ANGVEL.start + 3 * (b + 1));
    if let Some(f) = FINGERTIPS.iter().position(|&t| t == b) {
        c.extend(
            layout::FINGERTIP_FORCE.start + 3 * f..layout::FINGERTIP_FORCE.start + 3 * (f + 1),
        );
    }
    c
}

/// Columns appended to every token of an observation of width `obs_dim`: the root height and
/// everything after the humanoid entries.
pub fn shared_columns(obs_dim: usize) -> Vec<usize> {
    layout::ROOT_HEIGHT.chain(layout::HUMANOID_DIM..obs_dim).collect()
}

/// The part definitions of `split` for observations of width `obs_dim` (the 823 humanoid
/// entries first) and the 156 joint coordinates.
pub fn spec(cfg: &ModularConfig, obs_dim: usize) -> Result<ModularSpec, LearnError> {
    if obs_dim < layout::HUMANOID_DIM {
        return Err(LearnError::Config(format!(
            "ppo.policy = \"modular_attention\" needs an observation that starts with the {} \
                humanoid entries; this task's has {obs_dim}",
            layout::HUMANOID_DIM
        )));
    }
    let shared = shared_columns(obs_dim);
    let parts = part_bodies(&cfg.parts)?
        .into_iter()
        .map(|(name, bodies)| {
            let mut inputs: Vec<usize> = bodies.iter().flat_map(|&b| body_columns(b)).collect();
            inputs.extend(&shared);
            let outputs = bodies.iter().filter(|&&b| b >= 1).flat_map(|&b| dof_range(b)).collect();
            (name.to_string(), inputs, outputs)
        })
        .collect();
    Ok(ModularSpec {
        embed: cfg.embed,
        proj_hidden: cfg.proj_hidden,
        heads: cfg.heads,
        scaled: cfg.scaled,
        controller: cfg.controller.clone(),
        parts,
    })
}

/// A freshly initialised network for `spec` (obs `obs_dim`, `act_dim` actions).
pub fn build(
    spec: &ModularSpec,
    obs_dim: usize,
    act_dim: usize,
    rng: &mut dyn RngCore,
) -> Result<ModularAttention, LearnError> {
    let shape = ModularShape {
        embed: spec.embed,
        proj_hidden: spec.proj_hidden,
        heads: spec.heads,
        scaled: spec.scaled,
        controller: spec.controller.clone(),
    };
    ModularAttention::new(shape, &spec.parts, obs_dim, act_dim, rng)
        .map_err(|e| LearnError::Config(format!("config field 'ppo.modular': {e}")))
}

/// The modular attention family (Gaussian over the modular actor's means).
pub struct ModularAttentionFamily;

/// Names of the bodies (for messages and docs).
pub fn body_names(bodies: &[usize]) -> Vec<&'static str> {
    bodies.iter().map(|&b| BODIES[b].name).collect()
}

impl PolicyFamily for ModularAttentionFamily {
    fn name(&self) -> &'static str {
        "modular_attention"
    }
    fn supports(&self, space: &ActionSpace) -> bool {
        matches!(space, ActionSpace::Box { dim } if *dim == skillmimic_core::characters::skillmimic::NUM_DOFS)
    }
    fn uses_log_std(&self) -> bool {
        true
    }
    fn actor_outputs(&self, space: &ActionSpace) -> usize {
        space.width()
    }
    fn build_actor(
        &self,
        obs_dim: usize,
        space: &ActionSpace,
        cfg: &PpoConfig,
        rng: &mut dyn RngCore,
    ) -> Result<Option<ActorNet>, LearnError> {
        let s = spec(&cfg.modular, obs_dim)?;
        Ok(Some(ActorNet::from(build(&s, obs_dim, space.width(), rng)?)))
    }
    fn read_actor(
        &self,
        f: &skillmimic_core::tensorfile::TensorFile,
        obs_dim: usize,
        space: &ActionSpace,
    ) -> Result<Option<ActorNet>, String> {
        let text = f.meta("actor_net").map_err(|e| e.to_string())?;
        Ok(Some(ActorNet::from(read(f, text, obs_dim, space.width())?)))
    }
    /// The network's description ([`spec_of`]) as JSON.
    fn describe_actor(&self, actor: &ActorNet) -> Option<String> {
        let m = actor.downcast_ref::<ModularAttention>()?;
        Some(serde_json::to_string(&spec_of(m)).expect("a serialisable description"))
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
        GaussianMlp.sample(head, out, n, rng, actions, neglogp)
    }
    fn mode(&self, head: Head<'_>, out: &[f32], n: usize, actions: &mut [f32]) {
        GaussianMlp.mode(head, out, n, actions)
    }
    fn neglogp(
        &self,
        head: Head<'_>,
        out: &Tensor,
        actions: &Tensor,
    ) -> candle_core::Result<Tensor> {
        GaussianMlp.neglogp(head, out, actions)
    }
    fn extra_loss(&self, out: &Tensor, cfg: &PpoConfig) -> candle_core::Result<ExtraLoss> {
        GaussianMlp.extra_loss(out, cfg)
    }
}

/// The description of a built network (what [`build`] needs to rebuild it).
pub fn spec_of(m: &ModularAttention) -> ModularSpec {
    let s = &m.shape;
    let parts =
        m.parts.iter().map(|p| (p.name.clone(), p.inputs.clone(), p.outputs.clone())).collect();
    ModularSpec {
        embed: s.embed,
        proj_hidden: s.proj_hidden,
        heads: s.heads,
        scaled: s.scaled,
        controller: s.controller.clone(),
        parts,
    }
}

/// Rebuild the network described by the metadata text `spec_json` and fill its parameters from
/// the tensors `actor.*` of `f` (shapes checked).
pub fn read(
    f: &skillmimic_core::tensorfile::TensorFile,
    spec_json: &str,
    obs_dim: usize,
    act_dim: usize,
) -> Result<ModularAttention, String> {
    let spec: ModularSpec = serde_json::from_str(spec_json)
        .map_err(|e| format!("metadata 'actor_net' is not a modular network description: {e}"))?;
    let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(0);
    let mut net = build(&spec, obs_dim, act_dim, &mut rng)
        .map_err(|e| format!("metadata 'actor_net': {e}"))?;
    let names = net.param_names("actor");
    for ((name, shape), dst) in names.iter().zip(net.params_mut()) {
        let want: Vec<Option<usize>> = shape.iter().map(|&d| Some(d)).collect();
        *dst = f.f32(name, &want).map_err(|e| e.to_string())?.1;
    }
    Ok(net)
}
