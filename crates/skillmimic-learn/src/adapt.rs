//! Policy adaptation of a token transformer (TokenHSI seed 004 §E; modskill-tokenhsi-facts §2.5):
//! a stage-1 `token_transformer` checkpoint is frozen whole and extended for a new task.
//!
//! * The new task's observation must keep the base policy's groups first, in order, with their
//!   widths (`env.multi.groups` names them), followed by one or more new groups and the mask.
//! * Every base tensor (output token, tokenizers, encoder, head, output layer) is copied and
//!   frozen: it is not an optimiser parameter and not a candle variable.
//! * New: one tokenizer per new group (PyTorch default initialisation), zero-initialised adapter
//!   layers parallel to the head's hidden layers (so the initial actions equal the base
//!   policy's wherever the new tokens are masked out), a fresh critic and value normaliser.
//! * With `gate` (`ppo.token.gate_adapters`, default), the adapters act only on rows where a new
//!   group is active (mask entry 1): the adapted policy keeps the base policy's actions on the
//!   base tasks after training too, one network for old and new tasks. Without, the adapters act
//!   on every row (the released code, which evaluates the adapted policy on the new task only).
//! * The observation statistics of the base groups are copied from the base checkpoint and stay
//!   fixed during training (the frozen tokenizers keep seeing inputs normalised as in stage 1);
//!   the new groups' statistics are learnt.
//! * Network sizes come from the base checkpoint (`[ppo.token]` sizes are ignored).

use std::path::Path;

use rand::RngCore;
use skillmimic_nn::token::{TokenSpec, TokenTransformer};

use crate::actor::ActorNet;
use crate::checkpoint;
use crate::error::{LearnError, bad_checkpoint};
use crate::policy::Policy;

/// Replace `policy`'s actor (freshly built for the new task's layout) by the base checkpoint
/// `from`, frozen and extended; see the module doc. `rng` draws the new tokenizers.
pub fn adapt(
    policy: &mut Policy,
    from: &Path,
    gate: bool,
    rng: &mut dyn RngCore,
) -> Result<(), LearnError> {
    let err = |m: String| bad_checkpoint(from)(format!("{}: {m}", from.display()));
    let base = checkpoint::load(from, None)?.policy;
    let (Some(old), Some(new)) = (
        base.actor.downcast_ref::<TokenTransformer>(),
        policy.actor.downcast_ref::<TokenTransformer>(),
    ) else {
        return Err(err(format!(
            "policy adaptation needs a token transformer checkpoint and ppo.policy = \
                \"token_transformer\"; the checkpoint's policy is '{}'",
            base.family.name()
        )));
    };
    if base.family.name() != policy.family.name() || base.space != policy.space {
        return Err(err(format!(
            "the checkpoint's policy '{}' over {:?} differs from this run's '{}' over {:?}",
            base.family.name(),
            base.space,
            policy.family.name(),
            policy.space
        )));
    }
    let (g0, g1) = (&old.spec.groups, &new.spec.groups);
    if g1.len() <= g0.len() || g1[..g0.len()] != g0[..] {
        return Err(err(format!(
            "the task's observation groups {g1:?} must start with the checkpoint's {g0:?} and add \
                at least one new group (set env.multi.groups to the old groups followed by the \
                new task's)"
        )));
    }
    // the new groups' mask entries switch the adapters on (group g ≥ 1 is mask entry g − 1)
    let adapter_gate =
        if gate && new.spec.mask > 0 { (g0.len() - 1..g1.len() - 1).collect() } else { Vec::new() };
    let mut spec = TokenSpec {
        groups: g1.clone(),
        mask: new.spec.mask,
        adapters: true,
        adapter_gate,
        frozen: old.tensors.iter().map(|t| t.name.clone()).collect(),
        frozen_obs: Vec::new(),
        ..old.spec.clone()
    };
    let old_cols = old.spec.obs_dim() - old.spec.mask;
    spec.frozen_obs = (0..old_cols).collect();
    let mut net = TokenTransformer::new(spec, old.act_dim, rng).map_err(err)?;
    for t in net.tensors.iter_mut() {
        if let Some(o) = old.tensors.iter().find(|o| o.name == t.name) {
            t.data.clone_from(&o.data);
        }
    }
    // the base groups' statistics (columns 0..old_cols in both layouts), the rest fresh
    let mut norm = policy.obs_norm.clone();
    norm.mean[..old_cols].copy_from_slice(&base.obs_norm.mean[..old_cols]);
    norm.var[..old_cols].copy_from_slice(&base.obs_norm.var[..old_cols]);
    norm.count = base.obs_norm.count;
    policy.obs_norm = norm;
    policy.log_std.clone_from(&base.log_std);
    policy.normalize_input = base.normalize_input;
    policy.actor = ActorNet::from(net);
    Ok(())
}
