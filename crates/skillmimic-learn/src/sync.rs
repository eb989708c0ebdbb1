//! Start-of-run agreement between the ranks of a data-parallel run: a signature check of the
//! configuration and the model sizes (so a mismatch is a clear error, not a hang or a silently
//! different update), then rank 0's training state broadcast to all.

use crate::adam::Adam;
use crate::checkpoint::Progress;
use crate::collective::Collective;
use crate::config::TrainConfig;
use crate::error::LearnError;
use crate::policy::Policy;

/// FNV-1a 64 of `bytes`.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes
        .iter()
        .fold(0xcbf2_9ce4_8422_2325u64, |h, &b| (h ^ b as u64).wrapping_mul(0x0100_0000_01b3))
}

/// What must be equal on every rank, as exact small numbers, with names for the error (not the
/// optimiser's step count: only rank 0 reads a checkpoint to resume from).
fn signature(cfg: &TrainConfig, policy: &Policy, adam: &Adam) -> Vec<(&'static str, f64)> {
    // fields that may differ per machine: the thread counts and where rank 0 writes
    let mut c = cfg.clone();
    c.run.out_dir = Default::default();
    c.run.learner_threads = 0;
    c.env.threads = 0;
    let h = fnv1a(c.to_toml().as_bytes());
    vec![
        ("configuration (TOML hash, high half)", (h >> 32) as f64),
        ("configuration (TOML hash, low half)", (h & 0xffff_ffff) as f64),
        ("observation size", policy.obs_dim() as f64),
        ("action width", policy.act_dim() as f64),
        ("actor parameters", policy.actor.params().iter().map(|p| p.len()).sum::<usize>() as f64),
        ("critic parameters", policy.critic.params().iter().map(|p| p.len()).sum::<usize>() as f64),
        ("optimizer tensors", adam.m.len() as f64),
    ]
}

/// Compare every rank's signature with rank 0's; when any rank differs, every rank returns an
/// error naming the first rank that differs and the first field it differs in (a broadcast and
/// one all-reduce, so no rank is left waiting).
pub fn check_agreement(
    cfg: &TrainConfig,
    policy: &Policy,
    adam: &Adam,
    comm: &mut dyn Collective,
) -> Result<(), LearnError> {
    if cfg.run.active.enabled {
        // every rank sees the same configuration, so every rank stops here (no rank waits)
        return Err(LearnError::Config(
            "config field 'run.active.enabled': active skill learning runs in one process for now \
                (a round rebuilds the environments from clips that rank 0 writes); train it \
                without torchrun"
                .into(),
        ));
    }
    let mine = signature(cfg, policy, adam);
    let mut theirs: Vec<f64> = mine.iter().map(|(_, v)| *v).collect();
    comm.broadcast_f64(&mut theirs)?;
    // per rank: 1 + the index of the first differing field, 0 when it agrees
    let mut verdict = vec![0.0f64; comm.world_size()];
    if let Some(k) = mine.iter().zip(&theirs).position(|((_, v), r0)| v != r0) {
        verdict[comm.rank()] = (k + 1) as f64;
    }
    comm.all_reduce_f64(&mut verdict)?;
    match verdict.iter().position(|&v| v > 0.0) {
        None => Ok(()),
        Some(rank) => {
            let k = verdict[rank] as usize - 1;
            let detail = if rank == comm.rank() {
                format!(" ({} vs {})", mine[k].1, theirs[k])
            } else {
                String::new()
            };
            Err(LearnError::Config(format!(
                "distributed: rank {rank} disagrees with rank 0 on the {}{detail}; every rank \
                    must start with the same configuration, clips and checkpoint",
                mine[k].0
            )))
        }
    }
}

/// Rank 0's parameters, σ, optimiser state and settings, normaliser statistics and switches, and
/// progress copied into every rank (two broadcasts).
pub fn broadcast_state(
    policy: &mut Policy,
    adam: &mut Adam,
    progress: &mut Progress,
    comm: &mut dyn Collective,
) -> Result<(), LearnError> {
    let mut flat: Vec<f32> = Vec::new();
    {
        let params = policy.actor.params_mut().into_iter().chain(policy.critic.params_mut());
        for p in params {
            flat.extend_from_slice(p);
        }
    }
    flat.extend_from_slice(&policy.log_std);
    for m in adam.m.iter().chain(&adam.v) {
        flat.extend_from_slice(m);
    }
    comm.broadcast_f32(&mut flat)?;
    let mut at = 0;
    let mut take = |dst: &mut [f32]| {
        dst.copy_from_slice(&flat[at..at + dst.len()]);
        at += dst.len();
    };
    for p in policy.actor.params_mut().into_iter().chain(policy.critic.params_mut()) {
        take(p);
    }
    take(&mut policy.log_std);
    for m in adam.m.iter_mut().chain(adam.v.iter_mut()) {
        take(m);
    }
    let mut f64s: Vec<f64> = Vec::new();
    for n in [&policy.obs_norm, &policy.value_norm] {
        f64s.extend_from_slice(&n.mean);
        f64s.extend_from_slice(&n.var);
        f64s.push(n.count);
    }
    // rank 0 may have resumed from a checkpoint whose optimiser settings and normaliser switches
    // differ from the configuration the other ranks built from: rank 0's win
    f64s.extend([
        adam.step as f64,
        progress.iteration as f64,
        progress.samples as f64,
        adam.lr,
        adam.beta1,
        adam.beta2,
        adam.eps,
    ]);
    f64s.extend([
        f64::from(u8::from(policy.normalize_input)),
        f64::from(u8::from(policy.normalize_value)),
    ]);
    comm.broadcast_f64(&mut f64s)?;
    let mut at = 0;
    for n in [&mut policy.obs_norm, &mut policy.value_norm] {
        let d = n.mean.len();
        n.mean.copy_from_slice(&f64s[at..at + d]);
        n.var.copy_from_slice(&f64s[at + d..at + 2 * d]);
        n.count = f64s[at + 2 * d];
        at += 2 * d + 1;
    }
    adam.step = f64s[at] as u64;
    progress.iteration = f64s[at + 1] as u64;
    progress.samples = f64s[at + 2] as u64;
    (adam.lr, adam.beta1, adam.beta2, adam.eps) =
        (f64s[at + 3], f64s[at + 4], f64s[at + 5], f64s[at + 6]);
    (policy.normalize_input, policy.normalize_value) = (f64s[at + 7] != 0.0, f64s[at + 8] != 0.0);
    Ok(())
}
