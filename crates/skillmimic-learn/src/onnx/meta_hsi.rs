//! Deployment metadata of a policy of a TokenHSI task
//! ([`skillmimic_core::characters::tokenhsi::CHARACTER`]): the 32-DoF TokenHSI character replaces
//! the SkillMimic humanoid in every character-specific field of [`DeployMeta`] — joint order, the
//! action → PD target map with its per-entry offset and scale, gains and torque limits per joint,
//! and the time steps (1/120 s physics, 4 steps per 30 Hz action).

use skillmimic_core::characters::tokenhsi::{BODIES, JointSpec, action_offset_scale};

use super::meta::{DeployMeta, Gain};

/// Value of `obs_layout_version` for the TokenHSI tasks.
pub const HSI_OBS_LAYOUT_VERSION: &str = "tokenhsi-obs-1";

/// Rewrite the character-specific fields of `m` (built for the SkillMimic humanoid) for the
/// TokenHSI character (the observation blocks come from the task's declared layout).
pub fn describe_tokenhsi(m: &mut DeployMeta) {
    m.obs_layout_version = HSI_OBS_LAYOUT_VERSION.to_string();
    let joints: Vec<_> = BODIES.iter().filter(|b| b.joint.dofs() > 0).collect();
    let mut ranges = Vec::new();
    let mut k = 0;
    for b in &joints {
        let n = b.joint.dofs();
        ranges.push(if n == 3 {
            format!("{} {}-{}", b.joint_name, k, k + 2)
        } else {
            format!("{} {k}", b.joint_name)
        });
        k += n;
    }
    m.joint_order = joints.iter().map(|b| b.joint_name.to_string()).collect();
    m.action_to_pd_target = format!(
        "action row = 32 float32 in joint_order ({}); ball joints take 3 entries (x, y, z of the \
            joint's rotation vector = exp map of the body relative to its parent, Z-up), the \
            elbows 1 (hinge angle about the forearm's y axis); PD target (rad) = \
            action_offset_scale[i][0] + action_offset_scale[i][1] * clamp(a_i, -1, 1); torque = \
            kp * (target - q) - kd * qdot per axis, clamped to +-force_limit_nm of the joint",
        ranges.join(", ")
    );
    m.action_offset_scale = action_offset_scale().iter().map(|&(o, s)| [o, s]).collect();
    m.pd_gains = joints
        .iter()
        .map(|b| {
            let (kp, kd) = b.joint.gains();
            let effort = match b.joint {
                JointSpec::Triple { effort, .. } | JointSpec::HingeY { effort, .. } => Some(effort),
                _ => None,
            };
            Gain { joint: b.joint_name.to_string(), kp, kd, force_limit_nm: effort }
        })
        .collect();
    m.hands = String::new();
    m.welded_joints = Vec::new();
    // the largest per-joint limit (each joint's own is in pd_gains)
    m.force_limit_nm = m.pd_gains.iter().filter_map(|g| g.force_limit_nm).fold(0.0, f64::max);
    let spec = skillmimic_core::characters::tokenhsi::spec();
    m.sim_dt = spec.timestep;
    m.substeps = spec.substeps;
    m.control_dt = spec.timestep * spec.substeps as f64;
    m.skill_labels.clear();
}
