//! Import of rl_games `torch.save` checkpoints (the SkillMimic authors' `.pth` files) into this
//! project's policy checkpoints, without running pickle code.
//!
//! The archive's pickle program is first interpreted by the bounded, restricted pickle machine of
//! `skillmimic_motion::pickle`, which builds a graph of plain values and never imports or calls
//! anything; every class the program names must be one a torch/numpy checkpoint uses
//! ([`ALLOWED`]), otherwise the file is rejected (a `.pth` whose pickle would run code names e.g.
//! `posix.system`). The tensors of the entries used are then read with
//! `skillmimic_motion::torch_zip` (every size checked against the archive before allocating;
//! float32, float64, int64 and int32 storages; other dtypes are refused naming the tensor).
//!
//! Layout (reference-facts §7.5, §8.3): `model` = state_dict with prefix `a2c_network.`: skill
//! policy `actor_mlp.{0,2,4}` (the depth is read from the file), `mu` (156 outputs),
//! `critic_mlp.{0,2,4}`, `value`, `sigma` (log σ, fixed); high-level policy `actor_mlp.{0,2}`,
//! `logits` (3 or 7 outputs), `critic_mlp.{0,2}`, `value`. `running_mean_std` (observation
//! normaliser) and `reward_mean_std` (value normaliser): `running_mean`, `running_var` (float64),
//! `count` (float64 scalar); the normalisers are applied as (x − mean)/√(var + 1e-5), clamped to
//! ±5, ReLU between layers — exactly this project's `gaussian_mlp` / `categorical_mlp` families.

use std::path::Path;

use skillmimic_motion::pickle::Pickle;
use skillmimic_motion::torch_zip::{self, TensorRef, TorchError, TorchZip};
use skillmimic_nn::mlp::Mlp;
use skillmimic_nn::normalizer::RunningMeanStd;

use crate::config::PpoConfig;
use crate::error::{LearnError, bad_checkpoint};
use crate::policies;
use crate::policy::Policy;

/// Which policy the file holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// The skill (low-level) policy: 902 (SkillMimic) or 905 (SkillMimic-V2) observations, 156
    /// actions, fixed-σ Gaussian.
    Skill,
    /// A high-level controller: 838 + task observations, 3 or 7 discrete choices.
    Hlc,
}

/// Classes a torch checkpoint's pickle may name (module, class).
pub const ALLOWED: &[(&str, &str)] = &[
    ("collections", "OrderedDict"),
    ("torch._utils", "_rebuild_tensor_v2"),
    ("torch._utils", "_rebuild_parameter"),
    ("torch", "FloatStorage"),
    ("torch", "DoubleStorage"),
    ("torch", "HalfStorage"),
    ("torch", "BFloat16Storage"),
    ("torch", "LongStorage"),
    ("torch", "IntStorage"),
    ("torch", "ShortStorage"),
    ("torch", "CharStorage"),
    ("torch", "ByteStorage"),
    ("torch", "BoolStorage"),
    ("torch", "Size"),
    ("numpy.core.multiarray", "scalar"),
    ("numpy._core.multiarray", "scalar"),
    ("numpy", "dtype"),
    ("_codecs", "encode"),
    ("builtins", "set"),
];

/// A named tensor read from the file: name, shape, values (as f64).
type Named = (String, Vec<usize>, Vec<f64>);
/// A linear layer: weight shape, weight, bias.
type Layer = (Vec<usize>, Vec<f64>, Vec<f64>);

/// An imported policy, the progress the file records and the configuration to save with it.
pub struct Imported {
    pub policy: Policy,
    pub epoch: u64,
    pub frame: u64,
    pub ppo: PpoConfig,
}

type Archive = TorchZip<std::io::BufReader<std::fs::File>>;

/// Largest pickle accepted (a real rl_games checkpoint's is tens of kilobytes).
const MAX_PICKLE: u64 = 64 << 20;

/// The archive at `path` with its pickle after the class check; its top-level keys.
fn checked_keys(path: &Path) -> Result<(Vec<String>, Archive), String> {
    let tz = torch_zip::open(path, MAX_PICKLE).map_err(|e| match e {
        TorchError::Io(e) => format!("cannot read file: {e}"),
        TorchError::NotZip(e) => format!("not a torch.save zip archive: {e}"),
        TorchError::Format(e) => e,
    })?;
    let p = &tz.pickle;
    for (module, class) in p.globals() {
        if !ALLOWED.iter().any(|(m, c)| *m == module && *c == class) {
            return Err(format!(
                "the pickle names '{module}.{class}', which a checkpoint does not need (a .pth \
                    that would run code when loaded by torch.load); refused, nothing was executed"
            ));
        }
    }
    let items =
        p.dict(p.root).ok_or("the top level is not a dict; expected an rl_games checkpoint")?;
    let keys = items.iter().filter_map(|(k, _)| p.str(*k).map(str::to_owned)).collect();
    Ok((keys, tz))
}

fn scalar_u64(p: &Pickle, key: &str) -> u64 {
    p.dict_get(p.root, key).and_then(|v| p.int(v)).and_then(|i| u64::try_from(i).ok()).unwrap_or(0)
}

/// Tensors of top-level entry `key` (a dict of name → tensor) as f64 vectors with their shapes;
/// entries that are not tensors are skipped, as torch's `load_state_dict` would ignore them.
fn tensors(tz: &mut Archive, key: &str) -> Result<Vec<Named>, String> {
    let p = &tz.pickle;
    let dict = p.dict_get(p.root, key).ok_or_else(|| format!("entry '{key}' is missing"))?;
    let items = p.dict(dict).ok_or_else(|| {
        format!("entry '{key}' is {}, expected a dict of tensors", torch_zip::kind(p.get(dict)))
    })?;
    let refs: Vec<(String, Result<TensorRef, String>)> = items
        .iter()
        .filter(|(_, v)| torch_zip::is_tensor(p, *v))
        .filter_map(|(k, v)| p.str(*k).map(|n| (n.to_owned(), torch_zip::tensor_ref(p, *v))))
        .collect();
    let mut out = Vec::new();
    for (name, t) in refs {
        let t = t.map_err(|d| format!("{key}.{name}: {d}"))?;
        let v = tz.read_f64(&t).map_err(|d| format!("{key}.{name}: {d}"))?;
        out.push((name, t.shape(), v));
    }
    Ok(out)
}

fn get<'a>(ts: &'a [Named], name: &str, what: &str) -> Result<&'a Named, String> {
    ts.iter()
        .find(|(n, _, _)| n == name)
        .ok_or_else(|| format!("{what}: tensor '{name}' is missing"))
}

fn f32s(v: &[f64]) -> Vec<f32> {
    v.iter().map(|&x| x as f32).collect()
}

/// A normaliser from entry `key` (`running_mean`, `running_var`, `count`) of width `dim`.
fn normalizer(tz: &mut Archive, key: &str, dim: usize) -> Result<RunningMeanStd, String> {
    let ts = tensors(tz, key)?;
    let mean = get(&ts, "running_mean", key)?;
    let var = get(&ts, "running_var", key)?;
    let count = get(&ts, "count", key)?;
    if mean.2.len() != dim || var.2.len() != dim || count.2.len() != 1 {
        return Err(format!(
            "{key}: running_mean {:?}, running_var {:?}, count {:?}; expected ({dim},), ({dim},), \
                ()",
            mean.1, var.1, count.1
        ));
    }
    if mean.2.iter().chain(&var.2).chain(&count.2).any(|x| !x.is_finite())
        || var.2.iter().any(|&v| v < 0.0)
    {
        return Err(format!("{key}: non-finite statistics or a negative variance"));
    }
    let mut n = RunningMeanStd::new(dim, 1e-5, 5.0);
    n.mean.clone_from(&mean.2);
    n.var.clone_from(&var.2);
    n.count = count.2[0];
    Ok(n)
}

/// Read the rl_games checkpoint at `path` as a policy of `kind`.
pub fn import(path: &Path, kind: Kind) -> Result<Imported, LearnError> {
    let fail = |m: String| bad_checkpoint(path)(format!("{}: {m}", path.display()));
    let (keys, mut tz) = checked_keys(path).map_err(fail)?;
    for k in ["model", "running_mean_std"] {
        if !keys.iter().any(|x| x == k) {
            return Err(fail(format!(
                "no '{k}' entry (top-level keys: {keys:?}); expected an rl_games checkpoint"
            )));
        }
    }
    let model = tensors(&mut tz, "model").map_err(fail)?;
    let head = match kind {
        Kind::Skill => "mu",
        Kind::Hlc => "logits",
    };
    // hidden layers: actor_mlp.0, .2, .4, … as far as they go (the papers use 3 for the skill
    // policy, 2 for the high-level controllers)
    let has = |n: String| model.iter().any(|(k, _, _)| *k == n);
    let hidden_layers =
        (0..).take_while(|k| has(format!("a2c_network.actor_mlp.{}.weight", 2 * k))).count();
    if hidden_layers == 0 {
        return Err(fail(
            "model: no 'a2c_network.actor_mlp.0.weight'; expected an rl_games A2C network".into(),
        ));
    }
    let layer = |prefix: &str, i: usize| -> Result<Layer, String> {
        let w = get(&model, &format!("a2c_network.{prefix}.{i}.weight"), "model")?;
        let b = get(&model, &format!("a2c_network.{prefix}.{i}.bias"), "model")?;
        Ok((w.1.clone(), w.2.clone(), b.2.clone()))
    };
    let named = |name: &str| -> Result<Layer, String> {
        let w = get(&model, &format!("a2c_network.{name}.weight"), "model")?;
        let b = get(&model, &format!("a2c_network.{name}.bias"), "model")?;
        Ok((w.1.clone(), w.2.clone(), b.2.clone()))
    };
    let build = |trunk: &str, out: &str| -> Result<Mlp, String> {
        let mut layers =
            (0..hidden_layers).map(|k| layer(trunk, 2 * k)).collect::<Result<Vec<_>, _>>()?;
        layers.push(named(out)?);
        let mut dims = vec![layers[0].0.get(1).copied().unwrap_or(0)];
        for (k, (shape, w, b)) in layers.iter().enumerate() {
            if shape.len() != 2
                || shape[1] != *dims.last().expect("non-empty")
                || b.len() != shape[0]
                || w.len() != shape[0] * shape[1]
            {
                return Err(format!(
                    "{trunk} layer {k}: weight {shape:?} does not follow width {}",
                    dims.last().expect("non-empty")
                ));
            }
            dims.push(shape[0]);
        }
        let (ws, bs) = layers.iter().map(|(_, w, b)| (f32s(w), f32s(b))).unzip();
        Ok(Mlp::from_parts(dims, ws, bs))
    };
    let actor = build("actor_mlp", head).map_err(fail)?;
    let critic = build("critic_mlp", "value").map_err(fail)?;
    let (obs, outputs) = (actor.dims[0], *actor.dims.last().expect("layers"));
    if critic.dims[0] != obs || *critic.dims.last().expect("layers") != 1 {
        return Err(fail(format!(
            "critic dims {:?} do not match the actor's input {obs} and a single value",
            critic.dims
        )));
    }
    let (family, log_std) = match kind {
        Kind::Skill => {
            if obs != 902 && obs != 905 {
                return Err(fail(format!(
                    "skill policy with {obs} observations; expected 902 (SkillMimic) or 905 \
                        (SkillMimic-V2)"
                )));
            }
            if outputs != 156 {
                return Err(fail(format!("skill policy with {outputs} actions; expected 156")));
            }
            let sigma = get(&model, "a2c_network.sigma", "model").map_err(fail)?;
            if sigma.2.len() != 156 {
                return Err(fail(format!(
                    "a2c_network.sigma has shape {:?}; expected (156,)",
                    sigma.1
                )));
            }
            (policies::family("gaussian_mlp")?, f32s(&sigma.2))
        }
        Kind::Hlc => {
            if obs <= 838 {
                return Err(fail(format!(
                    "high-level policy with {obs} observations; expected 838 + the task's part"
                )));
            }
            if outputs != 3 && outputs != 7 {
                return Err(fail(format!(
                    "high-level policy with {outputs} choices; expected 3 or 7"
                )));
            }
            (policies::family("categorical_mlp")?, Vec::new())
        }
    };
    let obs_norm = normalizer(&mut tz, "running_mean_std", obs).map_err(fail)?;
    let value_norm = if keys.iter().any(|k| k == "reward_mean_std") {
        Some(normalizer(&mut tz, "reward_mean_std", 1).map_err(fail)?)
    } else {
        None
    };
    let space = match kind {
        Kind::Skill => skillmimic_env::ActionSpace::Box { dim: outputs },
        Kind::Hlc => skillmimic_env::ActionSpace::Discrete { n: outputs },
    };
    let hidden = actor.dims[1..actor.dims.len() - 1].to_vec();
    let ppo = PpoConfig {
        policy: family.name().to_string(),
        hidden,
        normalize_value: value_norm.is_some(),
        ..Default::default()
    };
    let policy = Policy {
        family,
        space,
        actor: crate::actor::ActorNet::from(actor),
        critic,
        log_std,
        obs_norm,
        normalize_value: value_norm.is_some(),
        value_norm: value_norm.unwrap_or_else(|| RunningMeanStd::new(1, 1e-5, 5.0)),
        normalize_input: true,
    };
    Ok(Imported {
        policy,
        epoch: scalar_u64(&tz.pickle, "epoch"),
        frame: scalar_u64(&tz.pickle, "frame"),
        ppo,
    })
}
