//! The actor–critic of every policy family: an actor network ([`ActorNet`]: an MLP, or the modular
//! attention network) and a critic MLP over the normalised observation, the observation and value
//! normalisers, and the family ([`crate::policies`]) that turns actor outputs into a distribution
//! over actions (SkillMimic's fixed-σ Gaussian keeps its log σ here).
//!
//! The critic predicts the value in normalised space; [`Policy::value_from_output`] maps it back
//! (clamp ±5, scale, shift).

use rand::RngCore;
use skillmimic_env::ActionSpace;

use crate::actor::{ActorNet, ActorWorkspace};
use crate::config::PpoConfig;
use crate::error::LearnError;
use crate::policies::{self, Head, ObsInfo, PolicyFamily};
use skillmimic_nn::mlp::{Mlp, Workspace};
use skillmimic_nn::normalizer::RunningMeanStd;

/// Family, actor, critic, σ and normalisers.
#[derive(Clone, Debug, PartialEq)]
pub struct Policy {
    pub family: &'static dyn PolicyFamily,
    /// The action space the policy acts in.
    pub space: ActionSpace,
    pub actor: ActorNet,
    pub critic: Mlp,
    /// Per-dimension log σ (fixed; `gaussian_mlp` only, empty otherwise).
    pub log_std: Vec<f32>,
    pub obs_norm: RunningMeanStd,
    pub value_norm: RunningMeanStd,
    pub normalize_input: bool,
    pub normalize_value: bool,
}

/// Preallocated buffers of batched inference.
#[derive(Clone, Debug, Default)]
pub struct InferenceBuffers {
    pub obs_n: Vec<f32>,
    actor_ws: ActorWorkspace,
    critic_ws: Workspace,
}

impl Policy {
    /// A freshly initialised `gaussian_mlp` policy for `obs_dim` → `act_dim` continuous actions.
    pub fn new<R: rand::Rng>(obs_dim: usize, act_dim: usize, cfg: &PpoConfig, rng: &mut R) -> Self {
        Self::init(
            &policies::gaussian_mlp::GaussianMlp,
            &ObsInfo::of_dim(obs_dim),
            ActionSpace::Box { dim: act_dim },
            cfg,
            rng,
        )
        .expect("an MLP actor always builds")
    }

    /// A freshly initialised policy of the family `cfg.policy` for `space`, over an observation
    /// `obs_dim` wide of the default character ([`ObsInfo::of_dim`]).
    pub fn build<R: rand::Rng>(
        obs_dim: usize,
        space: ActionSpace,
        cfg: &PpoConfig,
        rng: &mut R,
    ) -> Result<Self, LearnError> {
        Self::build_for(&ObsInfo::of_dim(obs_dim), space, cfg, rng)
    }

    /// [`Policy::build`] for the observation `obs` describes (its character and per-body
    /// blocks: ModSkill's part tokens).
    pub fn build_for<R: rand::Rng>(
        obs: &ObsInfo,
        space: ActionSpace,
        cfg: &PpoConfig,
        rng: &mut R,
    ) -> Result<Self, LearnError> {
        let family = policies::family(&cfg.policy)?;
        if !family.supports(&space) {
            return Err(LearnError::Config(format!(
                "config field 'ppo.policy': the family '{}' cannot act in the task's action space \
                    {space:?}",
                family.name()
            )));
        }
        // a part-wise family on a character it cannot split says why when it builds its actor
        Self::init(family, obs, space, cfg, rng)
    }

    /// Actor MLP `obs_dim → hidden… → actor outputs` (or the family's own actor network), critic
    /// `obs_dim → hidden… → 1` (drawn in that order from `rng`), log σ for the families that use
    /// one.
    fn init<R: rand::Rng + rand::RngCore>(
        family: &'static dyn PolicyFamily,
        obs: &ObsInfo,
        space: ActionSpace,
        cfg: &PpoConfig,
        rng: &mut R,
    ) -> Result<Self, LearnError> {
        let obs_dim = obs.dim;
        let mut dims = vec![obs_dim];
        dims.extend(&cfg.hidden);
        let mut adims = dims.clone();
        adims.push(family.actor_outputs(&space));
        let mut cdims = dims;
        cdims.push(1);
        // MLP families draw the actor, the critic, then the output-layer re-initialisation (the
        // order every existing seed reproduces); a family's own network is drawn first
        let own = family.build_actor(obs, &space, cfg, rng)?;
        let mlp = if own.is_none() { Some(Mlp::new(&adims, rng)) } else { None };
        let critic = Mlp::new(&cdims, rng);
        let actor = match (own, mlp) {
            (Some(net), _) => net,
            (None, Some(mut m)) => {
                family.init_output_layer(&mut m, rng);
                ActorNet::from(m)
            }
            (None, None) => {
                unreachable!("an MLP is built when the family has no network of its own")
            }
        };
        Ok(Self {
            family,
            space,
            actor,
            critic,
            log_std: if family.uses_log_std() {
                vec![cfg.log_std as f32; space.width()]
            } else {
                Vec::new()
            },
            obs_norm: RunningMeanStd::new(obs_dim, cfg.norm_eps, cfg.norm_clip),
            value_norm: RunningMeanStd::new(1, cfg.norm_eps, cfg.norm_clip),
            normalize_input: cfg.normalize_input,
            normalize_value: cfg.normalize_value,
        })
    }

    pub fn obs_dim(&self) -> usize {
        self.actor.input_dim()
    }
    /// Width of one action row (continuous: the action dimension; discrete: 1).
    pub fn act_dim(&self) -> usize {
        self.space.width()
    }
    /// What the family reads of this policy.
    pub fn head(&self) -> Head<'_> {
        Head { outputs: self.actor.output_dim(), log_std: &self.log_std }
    }
    /// Width of the actor's output (Gaussian: means; categorical: logits).
    pub fn actor_outputs(&self) -> usize {
        self.actor.output_dim()
    }

    /// Normalised observation rows (or a copy when input normalisation is off); the actor's raw
    /// columns (the token transformer's mask) are copied unnormalised.
    pub fn normalize_obs_into(&self, obs: &[f32], out: &mut [f32]) {
        if self.normalize_input {
            self.obs_norm.normalize_into(obs, out);
            let raw = self.actor.raw_columns();
            if !raw.is_empty() {
                let d = self.obs_dim();
                for (o, x) in out.chunks_exact_mut(d).zip(obs.chunks_exact(d)) {
                    o[raw.clone()].copy_from_slice(&x[raw.clone()]);
                }
            }
        } else {
            out.copy_from_slice(obs);
        }
    }

    /// Critic output (normalised space) → value.
    pub fn value_from_output(&self, y: f64) -> f64 {
        if self.normalize_value { self.value_norm.denormalize_scalar(y) } else { y }
    }

    /// Batched deterministic inference: actor outputs `mu` (n × actor outputs: Gaussian means,
    /// categorical logits) and values `values` (n).
    /// With two or more threads the actor and the critic run concurrently, each on half of them.
    pub fn infer(
        &self,
        obs: &[f32],
        n: usize,
        buf: &mut InferenceBuffers,
        mu: &mut [f32],
        values: &mut [f32],
        threads: usize,
    ) {
        let d = self.obs_dim();
        if buf.obs_n.len() < n * d {
            buf.obs_n.resize(n * d, 0.0);
        }
        let InferenceBuffers { obs_n, actor_ws, critic_ws } = buf;
        let obs_n = &mut obs_n[..n * d];
        self.normalize_obs_into(&obs[..n * d], obs_n);
        let obs_n: &[f32] = obs_n;
        let a = self.actor_outputs();
        let mut run_actor =
            |t: usize| mu[..n * a].copy_from_slice(self.actor.forward_into(obs_n, n, actor_ws, t));
        let mut run_critic = |t: usize| {
            let v = self.critic.forward_into(obs_n, n, critic_ws, t);
            for (o, &y) in values[..n].iter_mut().zip(v) {
                *o = self.value_from_output(y as f64) as f32;
            }
        };
        if threads >= 2 {
            let ta = threads / 2;
            rayon::join(|| run_actor(ta), || run_critic(threads - ta));
        } else {
            run_actor(threads);
            run_critic(threads);
        }
    }

    /// Values only (for bootstrapping on next observations).
    pub fn infer_values(
        &self,
        obs: &[f32],
        n: usize,
        buf: &mut InferenceBuffers,
        values: &mut [f32],
        threads: usize,
    ) {
        let d = self.obs_dim();
        if buf.obs_n.len() < n * d {
            buf.obs_n.resize(n * d, 0.0);
        }
        let obs_n = &mut buf.obs_n[..n * d];
        self.normalize_obs_into(&obs[..n * d], obs_n);
        let v = self.critic.forward_into(obs_n, n, &mut buf.critic_ws, threads);
        for (o, &y) in values[..n].iter_mut().zip(v) {
            *o = self.value_from_output(y as f64) as f32;
        }
    }

    /// Sample actions for `n` rows from actor outputs `out` (the family's distribution) and
    /// their negative log-probabilities.
    pub fn sample<R: RngCore>(
        &self,
        out: &[f32],
        n: usize,
        rng: &mut R,
        actions: &mut [f32],
        neglogp: &mut [f32],
    ) {
        self.family.sample(self.head(), out, n, rng, actions, neglogp);
    }

    /// Deterministic actions (Gaussian: the mean; categorical: the most likely choice).
    pub fn mode(&self, out: &[f32], n: usize, actions: &mut [f32]) {
        self.family.mode(self.head(), out, n, actions);
    }
}

pub use crate::policies::gaussian_mlp::{HALF_LN_2PI, neglogp_row};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neglogp_matches_the_gaussian_density() {
        // one dimension, σ = e^-1: a - μ = σ -> z = 1 -> 0.5 - 1 + 0.9189...
        let v = neglogp_row(&[1.0 + (-1.0f32).exp()], &[1.0], &[-1.0]);
        assert!((v - (0.5 - 1.0 + HALF_LN_2PI)).abs() < 1e-6);
        assert!((HALF_LN_2PI - 0.5 * (2.0 * std::f64::consts::PI).ln()).abs() < 1e-15);
    }
}
