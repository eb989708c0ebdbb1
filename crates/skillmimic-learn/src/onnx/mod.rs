//! ONNX export of trained policies (opset [`graph::OPSET`], float32, dynamic batch), written from
//! Rust with the `onnx-protobuf` messages — no Python involved.
//!
//! Graphs (every input and output has the symbolic first dimension `batch`):
//!
//! * **skill policy** (`gaussian_mlp`, or `modular_attention` with its attention actor, see
//!   [`modular`]): `obs (batch, D)` → normaliser → actor →
//!   `mu (batch, A)` (the Gaussian means, what `skillmimic infer` gives) and
//!   `actions (batch, A) = clamp(mu, −1, 1)` (what the simulator applies: PD target = π·a).
//! * **high-level policy** (`categorical_mlp`): `obs (batch, 838 + task)` → normaliser → actor →
//!   `logits (batch, n)`, `choice (batch,)` int64 = argmax (first on ties), and
//!   `skill_label (batch,)` int64 = the task's choice → label table.
//! * **fused high-level graph**: the high-level graph, then the one-hot of the chosen label
//!   (64 wide, a constant table row per choice) appended to `obs[:, :838]` and fed to the frozen
//!   skill policy's normaliser and actor: outputs `actions`, `mu`, `choice`, `skill_label`,
//!   `logits` — one call per control step gives the PD targets, as the high-level task does
//!   (the task holds a choice for `env.hlc.llc_steps` steps; a deployment that wants the same
//!   calls the graph every step and holds `choice` itself, or feeds fresh observations and
//!   accepts a new choice each step).
//!
//! The normaliser is folded into float32 constants (`mean`, `1/√(var + ε)`;
//! [`graph::Graph::normalizer`]); the critic is not exported. Every export carries
//! [`meta::DeployMeta`] as metadata properties and as a JSON sidecar (`<file>.json`).

pub mod export;
pub mod graph;
pub mod latent;
pub mod meta;
pub mod meta_character;
pub mod modular;

use std::path::{Path, PathBuf};

use onnx_protobuf::{Message, ModelProto};
use skillmimic_core::tensorfile::write_bytes_atomic;
use skillmimic_env::obs::layout;
use skillmimic_motion::SKILL_WIDTH;

use crate::error::{LearnError, io};
use crate::policy::Policy;
use graph::{Elem, Graph};
use meta::{DeployMeta, Dim, Io, Normalizer};
use skillmimic_nn::modular::ModularAttention;

/// A model ready to be written and the metadata it carries.
pub struct Exported {
    pub model: ModelProto,
    pub meta: DeployMeta,
}

fn io_doc(name: &str, elem: Elem, width: &[usize], doc: &str) -> Io {
    let mut shape = vec![Dim::Symbol(graph::BATCH.to_string())];
    shape.extend(width.iter().map(|&w| Dim::Size(w)));
    Io {
        name: name.to_string(),
        dtype: if elem == Elem::F32 { "float32" } else { "int64" }.to_string(),
        shape,
        doc: doc.to_string(),
    }
}

/// Records the graph's inputs and outputs in the graph and in the metadata at once.
struct Ports<'a> {
    g: &'a mut Graph,
    meta: &'a mut DeployMeta,
}

impl Ports<'_> {
    fn input(&mut self, name: &str, elem: Elem, width: &[usize], doc: &str) {
        self.g.input(name, elem, width, doc);
        self.meta.inputs.push(io_doc(name, elem, width, doc));
    }
    fn output(&mut self, name: &str, elem: Elem, width: &[usize], doc: &str) {
        self.g.output(name, elem, width, doc);
        self.meta.outputs.push(io_doc(name, elem, width, doc));
    }
}

/// `p` has an MLP actor and every weight and normaliser statistic is finite (a file with NaN
/// weights is refused).
fn check_exportable(p: &Policy, what: &str) -> Result<(), LearnError> {
    if p.actor.as_mlp().is_none() && p.actor.downcast_ref::<ModularAttention>().is_none() {
        return Err(LearnError::Config(format!(
            "{what}: ONNX export covers MLP and modular attention actors; a '{}' actor is not \
                supported yet",
            p.family.name()
        )));
    }
    let params = p.actor.params();
    let stats = [&p.obs_norm.mean, &p.obs_norm.var];
    let bad_param = params.iter().position(|w| w.iter().any(|v| !v.is_finite()));
    let bad_stat = stats.iter().position(|s| s.iter().any(|v| !v.is_finite()));
    if let Some(k) = bad_param {
        return Err(LearnError::Config(format!(
            "{what}: actor tensor {} has non-finite values; refusing to export",
            p.actor.param_names("actor")[k].0
        )));
    }
    if let Some(k) = bad_stat {
        return Err(LearnError::Config(format!(
            "{what}: obs_norm.{} has non-finite values; refusing to export",
            ["mean", "var"][k]
        )));
    }
    Ok(())
}

/// The normaliser (when the policy uses one) and the actor of `p` over the value `x`.
fn actor(g: &mut Graph, prefix: &str, x: &str, p: &Policy, out: Option<&str>) -> String {
    let xn = if p.normalize_input {
        g.normalizer(&format!("{prefix}.obs_norm"), x, &p.obs_norm)
    } else {
        x.to_string()
    };
    match p.actor.downcast_ref::<ModularAttention>() {
        Some(m) => modular::modular_actor(g, &format!("{prefix}.actor"), &xn, m, out),
        None => g.mlp(
            &format!("{prefix}.actor"),
            &xn,
            p.actor.as_mlp().expect("checked by check_exportable"),
            out,
        ),
    }
}

fn normalizer_meta(p: &Policy) -> Normalizer {
    Normalizer {
        in_graph: p.normalize_input,
        eps: p.obs_norm.eps,
        clip: p.obs_norm.clip,
        formula: "x_n = clamp((obs - mean) * inv_std, -clip, clip) in float32; mean = \
            float32(obs_norm.mean), inv_std = float32(1 / sqrt(obs_norm.var + eps)) computed in \
            float64"
            .to_string(),
    }
}

/// The high-level part over the value `x`: outputs `logits`, `choice` and (when the task's
/// choice table fits) `skill_label`. Returns the `choice` value name.
fn high_level_head(g: &mut Graph, meta: &mut DeployMeta, hl: &Policy, x: &str) -> String {
    let n = hl.actor.output_dim();
    actor(g, "hl", x, hl, Some("logits"));
    let choice = g.argmax("logits", Some("choice"));
    let labels: Vec<i64> = meta.choices.iter().map(|c| c.label as i64).collect();
    let has_labels = labels.len() == n;
    if has_labels {
        let table = g.const_i64("choice_labels", &[n], &labels);
        g.gather(&table, &choice, Some("skill_label"));
    }
    let mut ports = Ports { g, meta };
    ports.output("logits", Elem::F32, &[n], "high-level logits (categorical, unnormalised)");
    ports.output("choice", Elem::I64, &[], "argmax of the logits (first index on ties)");
    if has_labels {
        ports.output(
            "skill_label",
            Elem::I64,
            &[],
            "skill label of the choice (the task's choice -> label table)",
        );
    }
    choice
}

/// Export a policy alone: a `gaussian_mlp` skill policy or a `categorical_mlp` high-level one.
pub fn policy_model(p: &Policy, mut meta: DeployMeta) -> Result<Exported, LearnError> {
    check_exportable(p, &meta.source.file)?;
    let (d, a) = (p.obs_dim(), p.actor.output_dim());
    let mut g = Graph::new("skillmimic_policy");
    meta.normalizer = normalizer_meta(p);
    Ports { g: &mut g, meta: &mut meta }.input(
        "obs",
        Elem::F32,
        &[d],
        "observation (see obs_blocks)",
    );
    match p.family.name() {
        "gaussian_mlp" | "modular_attention" => {
            meta.graph = "skill_policy".to_string();
            actor(&mut g, "skill", "obs", p, Some("mu"));
            g.clip("mu", -1.0, 1.0, Some("actions"));
            let mut ports = Ports { g: &mut g, meta: &mut meta };
            ports.output(
                "actions",
                Elem::F32,
                &[a],
                "clamp(mu, -1, 1): the action row the simulator applies (see action_to_pd_target)",
            );
            ports.output(
                "mu",
                Elem::F32,
                &[a],
                "Gaussian mean of the policy (deterministic action before the clamp)",
            );
        }
        "categorical_mlp" => {
            meta.graph = "high_level_policy".to_string();
            high_level_head(&mut g, &mut meta, p, "obs");
        }
        other => {
            return Err(LearnError::Config(format!(
                "ONNX export supports the gaussian_mlp, modular_attention and categorical_mlp \
                    families, not '{other}'"
            )));
        }
    }
    let doc = format!("skillmimic-rs {} exported from {}", meta.graph, meta.source.file);
    Ok(Exported { model: g.into_model(&doc, &meta.props()), meta })
}

/// Export a high-level policy fused with its frozen skill policy (high-level argmax → skill
/// label → one-hot → skill policy), so one graph maps an observation to PD-target actions.
/// `meta` is the high-level policy's; `skill_source` identifies the skill checkpoint.
pub fn fused_model(
    hl: &Policy,
    skill: &Policy,
    mut meta: DeployMeta,
    skill_source: meta::Source,
) -> Result<Exported, LearnError> {
    check_exportable(hl, &meta.source.file)?;
    check_exportable(skill, &skill_source.file)?;
    if hl.family.name() != "categorical_mlp" {
        return Err(LearnError::Config(format!(
            "--fused needs a high-level (categorical_mlp) checkpoint; {} is a '{}' policy",
            meta.source.file,
            hl.family.name()
        )));
    }
    if !matches!(skill.family.name(), "gaussian_mlp" | "modular_attention")
        || skill.obs_dim() != layout::OBS_DIM
    {
        return Err(LearnError::Config(format!(
            "{}: the skill policy of a fused graph must be a gaussian_mlp or modular_attention \
                policy with {} observations, not a '{}' one with {}",
            skill_source.file,
            layout::OBS_DIM,
            skill.family.name(),
            skill.obs_dim()
        )));
    }
    if meta.choices.len() != hl.actor.output_dim() || hl.obs_dim() < layout::STATE_DIM {
        return Err(LearnError::Config(format!(
            "{}: a high-level policy of task '{}' with {} choices and {} observations; the task \
                has {} choices over {}+ observations",
            meta.source.file,
            meta.task,
            hl.actor.output_dim(),
            hl.obs_dim(),
            meta.choices.len(),
            layout::STATE_DIM
        )));
    }
    let (d, a, n) = (hl.obs_dim(), skill.actor.output_dim(), hl.actor.output_dim());
    let mut g = Graph::new("skillmimic_fused_high_level");
    meta.graph = "fused_high_level".to_string();
    meta.act_dim = a;
    meta.normalizer = normalizer_meta(hl);
    meta.skill_source = Some(skill_source);
    Ports { g: &mut g, meta: &mut meta }.input(
        "obs",
        Elem::F32,
        &[d],
        "high-level observation (see obs_blocks)",
    );
    let choice = high_level_head(&mut g, &mut meta, hl, "obs");
    let mut onehot = vec![0.0f32; n * SKILL_WIDTH];
    for (k, c) in meta.choices.iter().enumerate() {
        onehot[k * SKILL_WIDTH + c.label as usize] = 1.0;
    }
    let table = g.const_f32("choice_onehot", &[n, SKILL_WIDTH], &onehot);
    let skill_part = g.gather(&table, &choice, None);
    let state = g.columns("obs", 0, layout::STATE_DIM);
    let skill_obs = g.concat(&state, &skill_part);
    actor(&mut g, "skill", &skill_obs, skill, Some("mu"));
    g.clip("mu", -1.0, 1.0, Some("actions"));
    let mut ports = Ports { g: &mut g, meta: &mut meta };
    ports.output(
        "actions",
        Elem::F32,
        &[a],
        "clamp(mu, -1, 1) of the skill policy for the chosen skill (see action_to_pd_target)",
    );
    ports.output("mu", Elem::F32, &[a], "Gaussian mean of the skill policy");
    let doc = format!("skillmimic-rs fused high-level graph from {}", meta.source.file);
    Ok(Exported { model: g.into_model(&doc, &meta.props()), meta })
}

/// The JSON sidecar path of an exported model: `<path>.json` (`policy.onnx` → `policy.onnx.json`).
pub fn sidecar_path(path: &Path) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".json");
    PathBuf::from(s)
}

/// Write the model and its JSON sidecar, each atomically (never a partial file).
pub fn write(path: &Path, e: &Exported) -> Result<PathBuf, LearnError> {
    let bytes = e
        .model
        .write_to_bytes()
        .map_err(|x| LearnError::Config(format!("cannot encode the ONNX model: {x}")))?;
    write_bytes_atomic(path, &bytes).map_err(io(path))?;
    let side = sidecar_path(path);
    let json = serde_json::to_string_pretty(&e.meta).expect("metadata is plain data");
    write_bytes_atomic(&side, json.as_bytes()).map_err(io(&side))?;
    Ok(side)
}
