//! `modular_attention`: ModSkill's policy (seed 001 §3.2–3.3; modskill-tokenhsi-facts §1.3–1.4) on
//! any character with ModSkill body parts — the actor is
//! [`skillmimic_nn::modular::ModularAttention`], the distribution the fixed-σ Gaussian of
//! [`super::gaussian_mlp`] (same log σ, sampling, log-probability and bounds loss), the critic an
//! MLP over the whole observation (`ppo.hidden`).
//!
//! **Parts** (`ppo.modular.parts`, the character's `body_parts`): on SMPL `five` = ModSkill's
//! left leg (L_Hip…L_Toe), right leg, torso (Pelvis…Head), left arm (L_Thorax…L_Hand), right arm;
//! on the SkillMimic humanoid `five` = the same with each hand's fingers in its arm, `seven` =
//! each hand (wrist and fingers) its own part. A part drives the dofs of its bodies.
//!
//! **Tokens**, as the released code builds them (`PartAttentionLayer`): part k's token = its own
//! state — the root height for the part holding the root, then, for each of its bodies in body
//! order, the body's proprioception blocks (position (bodies after the root; 3), rotation (6),
//! linear velocity (3), angular velocity (3) and, for a contact-force body, its force (3);
//! [`skillmimic_env::proprio::body_columns`]) — then the task's blocks of its bodies
//! (`TaskSpec::body_blocks`: on `tracking` each body's 24-wide reference block), then the
//! **shared** columns that describe no body, appended to every token (imitation: the ball (15),
//! the 64-wide skill condition, a SkillMimic-V2 history embedding; a high-level task: the ball
//! and the task part; `stand`: its task entries). On SMPL tracking the widths are the released
//! 156, 156, 232, 195, 195.
//!
//! Checkpoint: tensors `actor.parts.{k}.{q,k,v}.{0,1}.{weight,bias}`,
//! `actor.parts.{k}.controller.{0,2,…}.{weight,bias}`, critic and `log_std` as `gaussian_mlp`;
//! metadata `actor_net` = [`ModularSpec`] as JSON (the token columns written out, so a checkpoint
//! needs no layout knowledge to load). PyTorch mirror: `skillmimic_rs.policy.ModularAttentionPolicy`.

use candle_core::Tensor;
use rand::RngCore;
use skillmimic_env::ActionSpace;
use skillmimic_nn::modular::{ModularAttention, ModularShape};

use super::family::{ExtraLoss, Head, ObsInfo, PolicyFamily};
use super::gaussian_mlp::GaussianMlp;
use crate::actor::ActorNet;
use crate::config::{ModularConfig, PpoConfig};
use crate::error::LearnError;

/// The network description stored in a checkpoint's metadata `actor_net` (defined below the
/// environment, where the frozen part controllers of skill reuse read it).
pub use skillmimic_nn::modular::ModularSpec;

/// The part definitions of `cfg.parts` for the observation `obs` describes (see the module doc):
/// each part's name, token columns and action columns.
pub fn spec(cfg: &ModularConfig, obs: &ObsInfo) -> Result<ModularSpec, LearnError> {
    let character = obs.character.spec();
    let bad = |msg: String| LearnError::Config(format!("config field 'ppo.modular.parts': {msg}"));
    let parts = obs.character.body_parts(&cfg.parts).ok_or_else(|| {
        let known: Vec<String> = ["five", "seven"]
            .iter()
            .filter(|k| obs.character.body_parts(k).is_some())
            .map(|k| format!("\"{k}\""))
            .collect();
        bad(format!(
            "the {} character has no body split '{}'; it has {}",
            character.name,
            cfg.parts,
            if known.is_empty() { "none".to_string() } else { known.join(", ") }
        ))
    })?;
    let (p, n) = (character.proprio_dim(), character.bodies.len());
    if obs.dim < p {
        return Err(LearnError::Config(format!(
            "ppo.policy = \"modular_attention\" needs an observation that starts with the {p} \
                proprioception entries of the {} character; this task's has {}",
            character.name, obs.dim
        )));
    }
    let own = |b: usize| skillmimic_env::proprio::body_columns(&character.proprio, n, b);
    let root_height = character.proprio.root_height;
    let mut described = vec![false; obs.dim];
    described[..p].iter_mut().for_each(|d| *d = true);
    for (_, cols) in &obs.body_blocks {
        described[cols.clone()].iter_mut().for_each(|d| *d = true);
    }
    let shared: Vec<usize> = (0..obs.dim).filter(|&c| !described[c]).collect();
    let parts = parts
        .into_iter()
        .map(|(name, bodies)| {
            let mut inputs: Vec<usize> = Vec::new();
            if root_height && bodies.contains(&0) {
                inputs.push(0);
            }
            inputs.extend(bodies.iter().flat_map(|&b| own(b)));
            for &b in &bodies {
                for (_, cols) in obs.body_blocks.iter().filter(|(k, _)| *k == b) {
                    inputs.extend(cols.clone());
                }
            }
            inputs.extend(&shared);
            let outputs = bodies.iter().flat_map(|&b| character.bodies[b].dofs.clone()).collect();
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

impl PolicyFamily for ModularAttentionFamily {
    fn name(&self) -> &'static str {
        "modular_attention"
    }
    /// Continuous actions; their width is checked against the character's dofs when the network
    /// is built.
    fn supports(&self, space: &ActionSpace) -> bool {
        matches!(space, ActionSpace::Box { .. })
    }
    /// The character's dofs, on a character with ModSkill body parts.
    fn acts_on(&self, space: &ActionSpace, obs: &ObsInfo) -> bool {
        self.supports(space)
            && space.width() == obs.character.spec().num_dofs
            && obs.character.body_parts("five").is_some()
    }
    fn uses_log_std(&self) -> bool {
        true
    }
    fn actor_outputs(&self, space: &ActionSpace) -> usize {
        space.width()
    }
    fn build_actor(
        &self,
        obs: &ObsInfo,
        space: &ActionSpace,
        cfg: &PpoConfig,
        rng: &mut dyn RngCore,
    ) -> Result<Option<ActorNet>, LearnError> {
        let dofs = obs.character.spec().num_dofs;
        if space.width() != dofs {
            return Err(LearnError::Config(format!(
                "ppo.policy = \"modular_attention\" drives the {dofs} dofs of the {} character; \
                    this task's actions are {} wide",
                obs.character.name(),
                space.width()
            )));
        }
        let s = spec(&cfg.modular, obs)?;
        Ok(Some(ActorNet::from(build(&s, obs.dim, space.width(), rng)?)))
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
