//! What a deployment needs besides the graph: the observation layout, the action → PD target
//! mapping with the gains, the time steps, the skill labels and where the policy came from.
//! Written twice with the same content: as the ONNX model's `metadata_props` (one property per
//! field; strings as they are, everything else as compact JSON) and as a JSON sidecar.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use skillmimic_core::characters::skillmimic::{BODIES, NUM_BODIES, is_finger};
use skillmimic_env::obs::OBS_LAYOUT_VERSION;
use skillmimic_motion::clip::skill_name;

pub use super::meta_character::Gain;
use crate::config::TrainConfig;
use crate::error::{LearnError, io};

/// Value of the `format` field.
pub const FORMAT: &str = "skillmimic-onnx";
/// Version of this metadata layout.
pub const FORMAT_VERSION: u32 = 1;
/// How an action entry becomes a joint target (the simulator's rule,
/// `skillmimic_sim::BatchSim::step`).
pub const PD_TARGET_DOC: &str = "action row = 156 float32 in joint_order, 3 per joint (x, y, z of \
    the joint's rotation vector = exp map of the body relative to its parent, skeleton frame, \
    Y-up); PD target (rad) = pi * clamp(a, -1, 1); torque = kp * (target - q) - kd * qdot per \
    axis, clamped to +-force_limit_nm; entries of welded_joints are ignored";

/// A named range of observation columns `[start, end)`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Block {
    pub name: String,
    pub start: usize,
    pub end: usize,
}

/// One discrete choice of a high-level policy.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Choice {
    pub choice: usize,
    pub label: u32,
    pub skill: String,
}

/// One dimension of a graph input or output: the symbolic batch or a fixed size.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Dim {
    Symbol(String),
    Size(usize),
}

/// A graph input or output.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Io {
    pub name: String,
    pub dtype: String,
    /// `"batch"` first, then fixed sizes.
    pub shape: Vec<Dim>,
    pub doc: String,
}

/// The observation normaliser inside the graph.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Normalizer {
    /// Whether the graph normalises its input (false: the policy was trained on raw observations).
    pub in_graph: bool,
    pub eps: f64,
    pub clip: f64,
    pub formula: String,
}

/// Where an exported network came from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Source {
    /// The checkpoint file name (no directory).
    pub file: String,
    /// SHA-256 of the checkpoint file (hex).
    pub sha256: String,
    pub iteration: u64,
    pub samples: u64,
}

/// Everything an exported policy carries besides its weights.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DeployMeta {
    pub format: String,
    pub format_version: u32,
    /// `skill_policy`, `high_level_policy` or `fused_high_level`.
    pub graph: String,
    /// Policy family of the (outer) network.
    pub policy: String,
    /// `env.task` of the training run.
    pub task: String,
    pub obs_layout_version: String,
    pub obs_dim: usize,
    /// Width of the action row the graph's `actions` output drives the character with (156 for
    /// the SkillMimic humanoid, 32 TokenHSI, 69 SMPL), or, for a high-level policy exported
    /// alone, its number of choices.
    pub act_dim: usize,
    pub obs_blocks: Vec<Block>,
    pub inputs: Vec<Io>,
    pub outputs: Vec<Io>,
    pub normalizer: Normalizer,
    /// The actuated joints in action order (SkillMimic humanoid: the 52 ball joints, joint j =
    /// body j + 1, actions 3j..3j+3; other characters: `action_to_pd_target` lists each joint's
    /// action entries).
    pub joint_order: Vec<String>,
    pub action_to_pd_target: String,
    /// Per action entry `[offset, scale]` of `target = offset + scale · clamp(a, −1, 1)` (rad)
    /// for every character but the SkillMimic humanoid (whose map is π·a); empty for it.
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub action_offset_scale: Vec<[f64; 2]>,
    pub pd_gains: Vec<Gain>,
    /// `env.hands` of the training run (`full` or `box`; empty for a character with one hand
    /// model).
    pub hands: String,
    /// Joints without actuators in this hand model (their action entries are ignored).
    pub welded_joints: Vec<String>,
    /// The actuators' force limit (N·m); for a character with per-joint limits (`pd_gains`),
    /// the largest of them.
    pub force_limit_nm: f64,
    /// Seconds per policy step (the simulator runs `substeps` steps of `sim_dt` per action).
    pub control_dt: f64,
    pub sim_dt: f64,
    pub substeps: usize,
    /// Every known BallPlay-M skill label with its name (the one-hot position in the skill block).
    pub skill_labels: BTreeMap<String, String>,
    /// A high-level policy's choices → skill labels (empty for a skill policy).
    pub choices: Vec<Choice>,
    pub source: Source,
    /// The frozen skill policy inside a fused graph (absent otherwise).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub skill_source: Option<Source>,
}

/// SHA-256 (hex) and file name of `path`.
pub fn source_of(path: &Path, iteration: u64, samples: u64) -> Result<Source, LearnError> {
    let bytes = std::fs::read(path).map_err(io(path))?;
    let digest = Sha256::digest(&bytes);
    let sha256 = digest.iter().map(|b| format!("{b:02x}")).collect();
    let file = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    Ok(Source { file, sha256, iteration, samples })
}

/// The observation blocks of a policy with `obs_dim` inputs trained with `cfg`: the layout its
/// task declares in the registry, on the character it was trained on.
pub fn obs_blocks(cfg: &TrainConfig, obs_dim: usize) -> Result<Vec<Block>, LearnError> {
    let blocks = skillmimic_env::registry::obs_blocks(&cfg.env, obs_dim)
        .map_err(|e| LearnError::Config(e.to_string()))?;
    Ok(blocks
        .into_iter()
        .map(|b| Block { name: b.name, start: b.range.start, end: b.range.end })
        .collect())
}

impl DeployMeta {
    /// The fields every export shares, from the training configuration `cfg`.
    pub fn new(
        graph: &str,
        policy: &str,
        cfg: &TrainConfig,
        obs_dim: usize,
        act_dim: usize,
        source: Source,
    ) -> Result<Self, LearnError> {
        let scene = skillmimic_env::registry::scene_options(&cfg.env)
            .map_err(|e| LearnError::Config(e.to_string()))?;
        let spec = scene.character.spec();
        let box_hands = cfg.env.hand_model().map_err(|e| LearnError::Config(e.to_string()))?
            == skillmimic_sim::HandModel::Box;
        let joints = &BODIES[1..NUM_BODIES];
        let entry = skillmimic_env::registry::entry(&cfg.env.task);
        let choices = entry.and_then(|e| e.high_level).map_or(&[][..], |h| h.choices);
        let name_of = |l: u32| skill_name(l).unwrap_or("unnamed").to_string();
        let mut m = Self {
            format: FORMAT.to_string(),
            format_version: FORMAT_VERSION,
            graph: graph.to_string(),
            policy: policy.to_string(),
            task: cfg.env.task.clone(),
            obs_layout_version: OBS_LAYOUT_VERSION.to_string(),
            obs_dim,
            act_dim,
            obs_blocks: obs_blocks(cfg, obs_dim)?,
            inputs: Vec::new(),
            outputs: Vec::new(),
            normalizer: Normalizer { in_graph: false, eps: 0.0, clip: 0.0, formula: String::new() },
            joint_order: joints.iter().map(|b| b.name.to_string()).collect(),
            action_to_pd_target: PD_TARGET_DOC.to_string(),
            action_offset_scale: Vec::new(),
            pd_gains: joints
                .iter()
                .map(|b| Gain {
                    joint: b.name.to_string(),
                    kp: b.group.gains().0,
                    kd: b.group.gains().1,
                    force_limit_nm: None,
                })
                .collect(),
            hands: cfg.env.hands.clone(),
            welded_joints: (1..NUM_BODIES)
                .filter(|&b| box_hands && is_finger(b))
                .map(|b| BODIES[b].name.to_string())
                .collect(),
            force_limit_nm: skillmimic_core::characters::skillmimic::FORCE_LIMIT,
            control_dt: spec.timestep * spec.substeps as f64,
            sim_dt: spec.timestep,
            substeps: spec.substeps,
            skill_labels: skillmimic_motion::clip::SKILL_NAMES
                .iter()
                .map(|(l, n)| (l.to_string(), n.to_string()))
                .collect(),
            choices: choices
                .iter()
                .enumerate()
                .map(|(choice, &label)| Choice { choice, label, skill: name_of(label) })
                .collect(),
            source,
            skill_source: None,
        };
        if scene.character.name() != skillmimic_core::characters::skillmimic::ENTRY.name {
            let c = super::meta_character::describe_character(&spec);
            m.obs_layout_version = c.obs_layout_version;
            m.joint_order = c.joint_order;
            m.action_to_pd_target = c.action_to_pd_target;
            m.action_offset_scale = c.action_offset_scale;
            m.pd_gains = c.pd_gains;
            m.hands = String::new();
            m.welded_joints = c.welded_joints;
            m.force_limit_nm = c.force_limit_nm;
            m.skill_labels.clear();
        }
        Ok(m)
    }

    /// One `(key, value)` per field: strings as they are, numbers and structures as compact JSON.
    pub fn props(&self) -> Vec<(String, String)> {
        let value = serde_json::to_value(self).expect("metadata is plain data");
        let serde_json::Value::Object(map) = value else {
            unreachable!("a struct serialises to an object")
        };
        map.into_iter()
            .map(|(k, v)| {
                let text = match v {
                    serde_json::Value::String(s) => s,
                    other => other.to_string(),
                };
                (k, text)
            })
            .collect()
    }
}
