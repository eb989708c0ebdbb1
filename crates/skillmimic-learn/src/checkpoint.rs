//! Checkpoints in safetensors with the tensor names of the PyTorch module
//! `skillmimic_rs.policy.SkillMimicPolicy` (its `state_dict` keys):
//!
//! | tensor | dtype | shape |
//! |---|---|---|
//! | `actor.{0,2,4,…}.weight` / `.bias` | F32 | (out, in) / (out,) |
//! | `critic.{0,2,4,…}.weight` / `.bias` | F32 | (out, in) / (out,) |
//! | `log_std` | F32 | (act,) — `gaussian_mlp` only |
//! | `obs_norm.mean`, `obs_norm.var` | F64 | (obs,) |
//! | `obs_norm.count` | F64 | () |
//! | `value_norm.mean`, `value_norm.var` | F64 | (1,) |
//! | `value_norm.count` | F64 | () |
//!
//! Training checkpoints add the Adam state: `optim.step` (I64, ()) and `optim.m.<param>`,
//! `optim.v.<param>` (F32) for every actor/critic parameter; `export` writes the policy part only.
//! Metadata: `format = "skillmimic-policy"`, `format_version = "1"` (another version is refused),
//! `kind` (`train`/`policy`),
//! `obs_dim`, `act_dim`, `hidden` (JSON list), `iteration`, `samples`, `config` (TOML text), and
//! the normaliser switches and settings; `policy` = the family (`gaussian_mlp` when absent, as in
//! files written before families existed) and `actions` = the action space (`box:<dim>` or
//! `discrete:<n>`; absent = `box:<act_dim>`); `actor_net` = the description of an actor that is
//! not an MLP (`modular_attention`: tensors `actor.parts.*`; `token_transformer*`: the token
//! network's tensors, frozen ones included), read back by the family (`PolicyFamily::read_actor`).
//!
//! Loading checks what would otherwise give silent NaN or a panic later: the normaliser
//! statistics (`RunningMeanStd::check`: finite, variance ≥ 0, `norm_eps` > 0, `norm_clip` > 0)
//! and every number of the stored `config` against its documented range
//! (`TrainConfig::validate_ranges`).

use std::collections::BTreeMap;

use skillmimic_env::ActionSpace;
use std::path::Path;

use skillmimic_core::tensorfile::{OwnedTensor, TensorFile, write_atomic};

use crate::actor::ActorNet;
use crate::adam::Adam;
use crate::policy::Policy;
use skillmimic_nn::frozen::{read_mlp, read_normalizer};
use skillmimic_nn::mlp::Mlp;
use skillmimic_nn::normalizer::RunningMeanStd;

/// Value of the `format` metadata field.
pub const FORMAT: &str = skillmimic_nn::frozen::POLICY_FORMAT;
/// Format version.
pub const VERSION: u32 = 1;

/// Training progress stored with a checkpoint.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Progress {
    pub iteration: u64,
    pub samples: u64,
}

/// What a checkpoint holds.
#[derive(Clone, Debug)]
pub struct Checkpoint {
    pub policy: Policy,
    pub adam: Option<Adam>,
    pub progress: Progress,
    /// Effective training configuration (TOML text).
    pub config: String,
}

fn param_names(p: &Policy) -> Vec<(String, Vec<usize>)> {
    let mut v = p.actor.param_names("actor");
    v.extend(p.critic.param_names("critic"));
    v
}

/// `box:<dim>` / `discrete:<n>` → the action space.
fn parse_space(text: &str) -> Option<ActionSpace> {
    let (kind, n) = text.split_once(':')?;
    let n: usize = n.parse().ok().filter(|&n| n > 0)?;
    match kind {
        "box" => Some(ActionSpace::Box { dim: n }),
        "discrete" => Some(ActionSpace::Discrete { n }),
        _ => None,
    }
}

fn norm_tensors(prefix: &str, n: &RunningMeanStd, out: &mut Vec<OwnedTensor>) {
    out.push(OwnedTensor::f64(&format!("{prefix}.mean"), &[n.dim()], &n.mean));
    out.push(OwnedTensor::f64(&format!("{prefix}.var"), &[n.dim()], &n.var));
    out.push(OwnedTensor::f64(&format!("{prefix}.count"), &[], &[n.count]));
}

/// Metadata `network`: layer order and activation.
pub const NETWORK_DOC: &str = "actor and critic are separate MLPs over the normalised \
    observation: actor.{0,2,..,2L}.weight (out, in) / .bias, critic likewise; y = x W^T + b; ReLU \
    after every layer but the last; actor output = Gaussian means (gaussian_mlp, sigma = \
    exp(log_std), fixed) or categorical logits (categorical_mlp); critic output = 1 value in \
    normalised space";
/// Metadata `obs_normalizer`: the formula and its precision.
pub const OBS_NORM_DOC: &str = "if normalize_input: x_n = clamp((x - obs_norm.mean) / \
    sqrt(obs_norm.var + norm_eps), -norm_clip, norm_clip), computed in float64 from the float64 \
    statistics, then cast to float32 (rl_games computes the same in float32)";
/// Metadata `value_output`: how the critic output becomes a value.
pub const VALUE_DOC: &str = "if normalize_value: value = clamp(critic_out, -norm_clip, norm_clip) \
    * sqrt(value_norm.var + norm_eps) + value_norm.mean; else value = critic_out";

/// Save `policy` (and `adam` for a training checkpoint) atomically; refuses (`InvalidData`, nothing
/// written) when a float tensor is not finite.
pub fn save(
    path: &Path,
    policy: &Policy,
    adam: Option<&Adam>,
    progress: &Progress,
    config_toml: &str,
) -> std::io::Result<()> {
    save_with(path, policy, adam, progress, config_toml, Vec::new())
}

/// [`save`] with further tensors of the run (the motion prior's `amp.*`).
pub fn save_with(
    path: &Path,
    policy: &Policy,
    adam: Option<&Adam>,
    progress: &Progress,
    config_toml: &str,
    extra: Vec<OwnedTensor>,
) -> std::io::Result<()> {
    let mut tensors = extra;
    let names = param_names(policy);
    let params: Vec<&[f32]> =
        policy.actor.params().into_iter().chain(policy.critic.params()).collect();
    for ((name, shape), data) in names.iter().zip(&params) {
        tensors.push(OwnedTensor::f32(name, shape, data));
    }
    for (name, shape, data) in policy.actor.frozen_tensors("actor") {
        tensors.push(OwnedTensor::f32(&name, &shape, data));
    }
    if !policy.log_std.is_empty() {
        tensors.push(OwnedTensor::f32("log_std", &[policy.log_std.len()], &policy.log_std));
    }
    norm_tensors("obs_norm", &policy.obs_norm, &mut tensors);
    norm_tensors("value_norm", &policy.value_norm, &mut tensors);
    if let Some(a) = adam {
        tensors.push(OwnedTensor::i64("optim.step", &[], &[a.step as i64]));
        for (k, (name, shape)) in names.iter().enumerate() {
            tensors.push(OwnedTensor::f32(&format!("optim.m.{name}"), shape, &a.m[k]));
            tensors.push(OwnedTensor::f32(&format!("optim.v.{name}"), shape, &a.v[k]));
        }
    }
    let mut meta = BTreeMap::new();
    meta.insert("format".to_string(), FORMAT.to_string());
    meta.insert("format_version".to_string(), VERSION.to_string());
    meta.insert("kind".to_string(), if adam.is_some() { "train" } else { "policy" }.to_string());
    meta.insert("obs_dim".to_string(), policy.obs_dim().to_string());
    meta.insert("act_dim".to_string(), policy.act_dim().to_string());
    if policy.family.name() != crate::config::DEFAULT_FAMILY {
        // written only where they differ from the defaults, so Gaussian files keep their bytes
        meta.insert("policy".to_string(), policy.family.name().to_string());
        let actions = match policy.space {
            ActionSpace::Box { dim } => format!("box:{dim}"),
            ActionSpace::Discrete { n } => format!("discrete:{n}"),
        };
        meta.insert("actions".to_string(), actions);
    }
    // the critic's widths (an MLP actor has the same ones)
    let hidden = &policy.critic.dims[1..policy.critic.dims.len() - 1];
    meta.insert("hidden".to_string(), serde_json::to_string(hidden).unwrap());
    if let Some(description) = policy.family.describe_actor(&policy.actor) {
        meta.insert("actor_net".to_string(), description);
    }
    meta.insert("iteration".to_string(), progress.iteration.to_string());
    meta.insert("samples".to_string(), progress.samples.to_string());
    meta.insert("normalize_input".to_string(), policy.normalize_input.to_string());
    meta.insert("normalize_value".to_string(), policy.normalize_value.to_string());
    meta.insert("norm_eps".to_string(), policy.obs_norm.eps.to_string());
    meta.insert("norm_clip".to_string(), policy.obs_norm.clip.to_string());
    // the network and the normalisers in words, so a reader needs no other source
    meta.insert("network".to_string(), NETWORK_DOC.to_string());
    meta.insert("obs_normalizer".to_string(), OBS_NORM_DOC.to_string());
    meta.insert("value_output".to_string(), VALUE_DOC.to_string());
    if let Some(a) = adam {
        meta.insert("adam_lr".to_string(), a.lr.to_string());
        meta.insert("adam_eps".to_string(), a.eps.to_string());
    }
    meta.insert("config".to_string(), config_toml.to_string());
    refuse_non_finite(&tensors)?;
    write_atomic(path, &tensors, &meta)
}

/// The last line of defence against a diverged run (training itself stops earlier, see
/// [`crate::divergence`]): an `InvalidData` error naming the tensor, the index and the value if
/// a float tensor holds a NaN or an infinity; nothing is written then.
fn refuse_non_finite(tensors: &[OwnedTensor]) -> std::io::Result<()> {
    use safetensors::tensor::Dtype;
    for t in tensors {
        let bad = match t.dtype {
            Dtype::F32 => t
                .bytes
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes(b.try_into().unwrap()) as f64)
                .enumerate()
                .find(|(_, x)| !x.is_finite()),
            Dtype::F64 => t
                .bytes
                .chunks_exact(8)
                .map(|b| f64::from_le_bytes(b.try_into().unwrap()))
                .enumerate()
                .find(|(_, x)| !x.is_finite()),
            _ => None,
        };
        if let Some((i, x)) = bad {
            let msg = format!(
                "refusing to write a checkpoint with non-finite values: tensor '{}' holds {x} at \
                    index {i}",
                t.name
            );
            return Err(std::io::Error::new(std::io::ErrorKind::InvalidData, msg));
        }
    }
    Ok(())
}

/// A normaliser of the file, its statistics checked ([`RunningMeanStd::check`]).
fn load_norm(
    f: &TensorFile,
    prefix: &str,
    dim: usize,
    eps: f64,
    clip: f64,
) -> Result<RunningMeanStd, String> {
    let n = read_normalizer(f, prefix, dim, eps, clip).map_err(|e| e.to_string())?;
    n.check(prefix).map_err(|detail| format!("{}: {detail}", f.path().display()))?;
    Ok(n)
}

/// The training configuration stored in checkpoint `path` (metadata `config`, TOML over the
/// defaults), every number checked against its documented range
/// ([`TrainConfig::validate_ranges`](crate::config::TrainConfig::validate_ranges)).
pub fn stored_config(
    path: &Path,
    text: &str,
) -> Result<crate::config::TrainConfig, crate::error::LearnError> {
    use crate::config::TrainConfig;
    let cfg = TrainConfig::from_toml_over(&TrainConfig::default(), text, path)?;
    check_stored(path, &cfg).map_err(crate::error::bad_checkpoint(path))?;
    Ok(cfg)
}

fn check_stored(path: &Path, cfg: &crate::config::TrainConfig) -> Result<(), String> {
    cfg.validate_ranges().map_err(|e| {
        format!("{}: metadata 'config' (the stored training configuration): {e}", path.display())
    })
}

/// A checkpoint and the training configuration stored in it (the defaults when it has none).
pub fn load_with_config(
    path: &Path,
) -> Result<(Checkpoint, crate::config::TrainConfig), crate::error::LearnError> {
    use crate::config::TrainConfig;
    let c = load(path, None)?;
    let cfg =
        if c.config.is_empty() { TrainConfig::default() } else { stored_config(path, &c.config)? };
    Ok((c, cfg))
}

/// Load a checkpoint; `expect` = (obs_dim, act_dim) must match when given.
pub fn load(
    path: &Path,
    expect: Option<(usize, usize)>,
) -> Result<Checkpoint, crate::error::LearnError> {
    load_raw(path, expect).map_err(crate::error::bad_checkpoint(path))
}

fn load_raw(path: &Path, expect: Option<(usize, usize)>) -> Result<Checkpoint, String> {
    let f = TensorFile::open(path).map_err(|e| e.to_string())?;
    let e = |e: skillmimic_core::tensorfile::TensorFileError| e.to_string();
    let fmt = f.meta("format").map_err(e)?;
    if fmt != FORMAT {
        return Err(format!(
            "{}: format '{fmt}', expected '{FORMAT}' (a skillmimic checkpoint)",
            path.display()
        ));
    }
    let version: u32 = f.meta_parse("format_version", "an integer").map_err(e)?;
    if version != VERSION {
        return Err(format!(
            "{}: metadata field 'format_version' is {version}, this build reads version {VERSION} \
                only{}",
            path.display(),
            if version > VERSION { " (the file was written by a newer skillmimic)" } else { "" }
        ));
    }
    // the stored configuration: a value outside its range is refused; a text this build cannot
    // parse (keys of another version) is left to the readers of the configuration
    let config = f.metadata().get("config").cloned().unwrap_or_default();
    if let Ok(cfg) = crate::config::TrainConfig::from_toml_over(&Default::default(), &config, path)
    {
        check_stored(path, &cfg)?;
    }
    let obs_dim: usize = f.meta_parse("obs_dim", "an integer").map_err(e)?;
    let act_dim: usize = f.meta_parse("act_dim", "an integer").map_err(e)?;
    if let Some((o, a)) = expect
        && (o, a) != (obs_dim, act_dim)
    {
        return Err(format!(
            "{}: checkpoint is for observations of {obs_dim} and actions of {act_dim}, this \
                environment has {o} and {a}",
            path.display()
        ));
    }
    let hidden: Vec<usize> = serde_json::from_str(f.meta("hidden").map_err(e)?).map_err(|x| {
        format!("{}: metadata 'hidden' is not a JSON list of integers: {x}", path.display())
    })?;
    let eps: f64 = f.meta_parse("norm_eps", "a number").map_err(e)?;
    let clip: f64 = f.meta_parse("norm_clip", "a number").map_err(e)?;
    let mlp = |prefix: &str, out: usize| -> Result<Mlp, String> {
        let mut dims = vec![obs_dim];
        dims.extend(&hidden);
        dims.push(out);
        read_mlp(&f, prefix, dims).map_err(e)
    };
    let family = crate::policies::family(f.meta("policy").unwrap_or(crate::config::DEFAULT_FAMILY))
        .map_err(|x| format!("{}: metadata 'policy': {x}", path.display()))?;
    let space = match f.meta("actions") {
        Err(_) => ActionSpace::Box { dim: act_dim },
        Ok(text) => parse_space(text).ok_or_else(|| {
            format!(
                "{}: metadata 'actions' is '{text}', expected 'box:<dim>' or 'discrete:<n>'",
                path.display()
            )
        })?,
    };
    if space.width() != act_dim || !family.supports(&space) {
        return Err(format!(
            "{}: metadata 'actions' {space:?} does not fit act_dim {act_dim} and policy '{}'",
            path.display(),
            family.name()
        ));
    }
    let actor = match family
        .read_actor(&f, obs_dim, &space)
        .map_err(|x| format!("{}: {x}", path.display()))?
    {
        Some(net) => net,
        None => ActorNet::from(mlp("actor", family.actor_outputs(&space))?),
    };
    let critic = mlp("critic", 1)?;
    let policy = Policy {
        family,
        space,
        actor,
        critic,
        log_std: if family.uses_log_std() {
            f.f32("log_std", &[Some(act_dim)]).map_err(e)?.1
        } else {
            Vec::new()
        },
        obs_norm: load_norm(&f, "obs_norm", obs_dim, eps, clip)?,
        value_norm: load_norm(&f, "value_norm", 1, eps, clip)?,
        normalize_input: f.meta_parse("normalize_input", "true/false").map_err(e)?,
        normalize_value: f.meta_parse("normalize_value", "true/false").map_err(e)?,
    };
    let adam = if f.meta("kind").map_err(e)? == "train" {
        let names = param_names(&policy);
        let mut a = Adam::new(
            &[],
            f.meta_parse("adam_lr", "a number").map_err(e)?,
            f.meta_parse("adam_eps", "a number").map_err(e)?,
        );
        a.step = f.i64("optim.step", &[]).map_err(e)?.1[0] as u64;
        for (name, shape) in &names {
            let want: Vec<Option<usize>> = shape.iter().map(|&s| Some(s)).collect();
            a.m.push(f.f32(&format!("optim.m.{name}"), &want).map_err(e)?.1);
            a.v.push(f.f32(&format!("optim.v.{name}"), &want).map_err(e)?.1);
        }
        Some(a)
    } else {
        None
    };
    Ok(Checkpoint {
        policy,
        adam,
        progress: Progress {
            iteration: f.meta_parse("iteration", "an integer").map_err(e)?,
            samples: f.meta_parse("samples", "an integer").map_err(e)?,
        },
        config,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::PpoConfig;
    use rand::SeedableRng;

    #[test]
    fn round_trip_and_mismatch_errors() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
        let cfg = PpoConfig { hidden: vec![16, 8], ..Default::default() };
        let mut p = Policy::new(10, 4, &cfg, &mut rng);
        p.obs_norm.update(&(0..30).map(|i| i as f32).collect::<Vec<_>>());
        let sizes: Vec<usize> =
            p.actor.params().iter().chain(p.critic.params().iter()).map(|x| x.len()).collect();
        let mut adam = Adam::new(&sizes, 1e-3, 1e-8);
        adam.step = 7;
        adam.m[0][3] = 0.25;
        let dir = std::env::temp_dir().join(format!("sm-ckpt-{}", std::process::id()));
        let path = dir.join("c.safetensors");
        save(&path, &p, Some(&adam), &Progress { iteration: 3, samples: 99 }, "[ppo]\n").unwrap();
        let c = load(&path, Some((10, 4))).unwrap();
        assert_eq!(c.policy, p);
        assert_eq!(c.adam.unwrap(), adam);
        assert_eq!(c.progress, Progress { iteration: 3, samples: 99 });
        assert_eq!(c.config, "[ppo]\n");
        let e = load(&path, Some((902, 156))).unwrap_err();
        assert!(
            e.to_string().contains("observations of 10") && e.to_string().contains("902"),
            "{e}"
        );
        save(&path, &p, None, &Progress::default(), "").unwrap();
        assert!(load(&path, None).unwrap().adam.is_none());
        // non-finite values are never written: the file keeps its previous content
        let mut bad = p.clone();
        bad.critic.params_mut()[0][2] = f32::NAN;
        let e = save(&path, &bad, None, &Progress::default(), "").unwrap_err().to_string();
        assert!(e.contains("'critic.0.weight'") && e.contains("NaN at index 2"), "{e}");
        assert!(load(&path, None).unwrap().adam.is_none());
        bad.critic.params_mut()[0][2] = 0.0;
        bad.obs_norm.var[1] = f64::INFINITY;
        assert!(
            save(&path, &bad, None, &Progress::default(), "")
                .unwrap_err()
                .to_string()
                .contains("'obs_norm.var'")
        );
        std::fs::write(&path, b"garbage").unwrap();
        assert!(load(&path, None).unwrap_err().to_string().contains("not a safetensors file"));
    }
}
