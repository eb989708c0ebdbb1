//! Deployment metadata of a policy trained on a character other than the SkillMimic humanoid
//! (the TokenHSI character, the SMPL humanoid, any character registered later): every
//! character-specific field of `DeployMeta` is read from the character's
//! [`CharacterSpec`], so it describes exactly what the simulator builds — joint order, the
//! per-entry action → PD target map, gains and torque limits per joint and welded joints (the
//! time steps `DeployMeta::new` reads from the spec for every character). The SkillMimic
//! humanoid keeps its own description (`DeployMeta::new`: one global force limit, π·a, box-hand
//! welds), unchanged since format version 1.

use serde::{Deserialize, Serialize};
use skillmimic_core::characters::{BodyDef, CharacterSpec, JointDef};

/// PD gains of one joint (the same on its 3 axes).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Gain {
    pub joint: String,
    /// N·m/rad.
    pub kp: f64,
    /// N·m·s/rad.
    pub kd: f64,
    /// Torque limit of this joint (N·m) where joints differ (every character but the SkillMimic
    /// humanoid); absent where one `force_limit_nm` holds for every joint.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub force_limit_nm: Option<f64>,
}

/// The character-specific fields of the deployment metadata (`DeployMeta`: the same names and
/// units); its time steps come from the spec for every character, so they are not repeated here.
#[derive(Clone, Debug, PartialEq)]
pub struct CharacterMeta {
    pub obs_layout_version: String,
    pub joint_order: Vec<String>,
    pub action_to_pd_target: String,
    pub action_offset_scale: Vec<[f64; 2]>,
    pub pd_gains: Vec<Gain>,
    pub welded_joints: Vec<String>,
    pub force_limit_nm: f64,
}

/// `obs_layout_version` of a policy on character `name` (`tokenhsi-obs-1`, `smpl-obs-1`); the
/// blocks themselves are the task's declared layout on that character.
pub fn obs_layout_version(name: &str) -> String {
    format!("{name}-obs-1")
}

/// The name a driven joint goes by in `joint_order` and `pd_gains`: a ball joint's own name; for
/// three hinges `<j>_x`, `<j>_y`, `<j>_z` the common `<j>`; a single hinge's name; otherwise the
/// body's name. `None` for the root and bodies without actuators.
pub fn joint_name(body: &BodyDef) -> Option<String> {
    match &body.joint {
        JointDef::Free | JointDef::Welded => None,
        JointDef::Ball { name, .. } => Some(name.clone()),
        JointDef::Hinges { hinges, .. } if hinges.len() == 1 => Some(hinges[0].name.clone()),
        JointDef::Hinges { hinges, .. } => {
            let stem = hinges[0].name.strip_suffix("_x");
            let triple = stem.is_some_and(|s| {
                hinges.iter().zip(["x", "y", "z"]).all(|(h, a)| h.name == format!("{s}_{a}"))
            });
            Some(match (triple, stem) {
                (true, Some(s)) => s.to_string(),
                _ => body.name.to_string(),
            })
        }
    }
}

/// The character-specific metadata fields of a policy on the character `spec` describes.
/// Action entries of a joint are its dof slots in body order; three hinges are nested about the
/// body's x, y, z axes (local rotation `R_x(q₀)·R_y(q₁)·R_z(q₂)`, Z-up), angles in radians.
pub fn describe_character(spec: &CharacterSpec) -> CharacterMeta {
    let mut order = Vec::new();
    let mut ranges = Vec::new();
    let mut maps = vec![[0.0, 0.0]; spec.num_dofs];
    let mut gains = Vec::new();
    for body in &spec.bodies {
        let (Some(name), Some(drive)) = (joint_name(body), body.joint.drive()) else { continue };
        let d = &body.dofs;
        ranges.push(if d.len() == 1 {
            format!("{name} {}", d.start)
        } else {
            format!("{name} {}-{}", d.start, d.end - 1)
        });
        let actions: Vec<_> = match &body.joint {
            JointDef::Ball { action, .. } => vec![*action; 3],
            JointDef::Hinges { hinges, .. } => hinges.iter().map(|h| h.action).collect(),
            JointDef::Free | JointDef::Welded => Vec::new(),
        };
        for (slot, a) in d.clone().zip(actions) {
            let (o, s) = a.offset_scale();
            maps[slot] = [o, s];
        }
        gains.push(Gain {
            joint: name.clone(),
            kp: drive.kp,
            kd: drive.kd,
            force_limit_nm: Some(drive.effort),
        });
        order.push(name);
    }
    let action_to_pd_target = format!(
        "action row = {} float32 in joint_order ({}); a 3-entry joint drives three nested hinges \
            about the body's x, y, z axes (local rotation R_x(q0) R_y(q1) R_z(q2), Z-up), a \
            1-entry joint its single hinge; PD target (rad) = action_offset_scale[i][0] + \
            action_offset_scale[i][1] * clamp(a_i, -1, 1); torque = kp * (target - q) - kd * \
            qdot per hinge, clamped to +-force_limit_nm of the joint",
        spec.num_dofs,
        ranges.join(", ")
    );
    // bodies whose joint is welded but keep action slots (the entries are ignored)
    let welded_joints = spec
        .bodies
        .iter()
        .filter(|b| matches!(b.joint, JointDef::Welded) && !b.dofs.is_empty())
        .map(|b| b.name.to_string())
        .collect();
    // the largest per-joint limit (each joint's own is in pd_gains)
    let force_limit_nm = gains.iter().filter_map(|g| g.force_limit_nm).fold(0.0, f64::max);
    CharacterMeta {
        obs_layout_version: obs_layout_version(spec.name),
        joint_order: order,
        action_to_pd_target,
        action_offset_scale: maps,
        pd_gains: gains,
        welded_joints,
        force_limit_nm,
    }
}
