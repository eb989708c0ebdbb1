//! The TokenHSI character (TokenHSI supplementary §A; numbers from the released
//! `phys_humanoid_v3_box_foot.xml`): 15 rigid bodies, ten 3-DoF joints and two 1-DoF elbows,
//! 32 action dimensions. Z-up, the character faces +x in its rest pose, metres, radians.
//!
//! As in the released asset, each 3-DoF joint is three nested hinges about the body's x, y and
//! z axes (local rotation `R_x(q₀)·R_y(q₁)·R_z(q₂)`), each with the asset's own range (the knee's
//! x and z ±5.625°, its y 0–160°), so a PD target beyond a range stops at the joint limit.
//!
//! Bodies are in depth-first order (the order Isaac Gym gives them, so the 222-d proprioception
//! and the 32-d action follow the original's column order):
//!
//! | # | body | joint | dofs |
//! |---|------|-------|------|
//! | 0 | pelvis | free (root) | – |
//! | 1 | torso | abdomen, 3-DoF | 0–2 |
//! | 2 | head | neck, 3-DoF | 3–5 |
//! | 3 | right_upper_arm | right_shoulder, 3-DoF | 6–8 |
//! | 4 | right_lower_arm | right_elbow, hinge about y | 9 |
//! | 5 | right_hand | – | – |
//! | 6 | left_upper_arm | left_shoulder, 3-DoF | 10–12 |
//! | 7 | left_lower_arm | left_elbow, hinge about y | 13 |
//! | 8 | left_hand | – | – |
//! | 9 | right_thigh | right_hip, 3-DoF | 14–16 |
//! | 10 | right_shin | right_knee, 3-DoF | 17–19 |
//! | 11 | right_foot | right_ankle, 3-DoF | 20–22 |
//! | 12 | left_thigh | left_hip, 3-DoF | 23–25 |
//! | 13 | left_shin | left_knee, 3-DoF | 26–28 |
//! | 14 | left_foot | left_ankle, 3-DoF | 29–31 |
//!
//! The lower-body offsets (hips, knees, ankles) are the SMPL neutral-shape ones of the original.
//! The feet are the released box-foot variant's single box per foot, turned slightly about y
//! (≈ 1.77 kg each; the asset's commented-out sole + toe boxes are not used): the mesh feet of
//! `phys_humanoid_v3.xml` come from SMPL and cannot be redistributed. The rest pose stands with
//! the pelvis at 0.94 m, the released spawn height.

use super::entry::{Character, CharacterEntry};
use super::spec::{
    ActionMap, BodyDef, BodyPart, CharacterSpec, Drive, GeomDef, GeomSpec, HandModel, Hinge,
    JointDef, Proprioception, xyz_hinges,
};

/// Number of rigid bodies.
pub const NUM_BODIES: usize = 15;
/// Number of action dimensions (and actuated dofs).
pub const NUM_DOFS: usize = 32;
/// Bodies whose contacts do not count as a fall (the feet).
pub const CONTACT_BODIES: [usize; 2] = [11, 14];
/// The hands (carry reward: mean hand position).
pub const HANDS: [usize; 2] = [5, 8];
/// The feet (climb reward: mean foot height).
pub const FEET: [usize; 2] = [11, 14];
/// Key bodies of the adversarial motion prior's features (hands and feet, as in AMP/ASE).
pub const KEY_BODIES: [usize; 4] = [5, 8, 11, 14];
/// TokenHSI's 222-d proprioception: ASE's observation without the root height, the root
/// rotation in the world frame.
pub const PROPRIO: Proprioception =
    Proprioception { root_height: false, root_rotation_world: true, contact_force_bodies: &[] };
/// Pelvis height (m) of the rest pose standing on the floor: the released spawn height
/// (`_char_h`); the lowest foot-box corner is then 1.6 mm below z = 0.
pub const STANDING_ROOT_HEIGHT: f64 = 0.94;

/// The joint that attaches a body to its parent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum JointSpec {
    /// The root: a free joint.
    Free,
    /// No joint: the body is welded to its parent (the hands).
    Welded,
    /// 3-DoF joint: three nested hinges about x, y, z with the asset's per-axis limits
    /// `range_deg` (degrees; joint limits in the simulation and the action scale); `kp`/`kd` the
    /// PD gains (N·m/rad, N·m·s/rad); `armature` kg·m²; `effort` the torque limit (N·m, the
    /// original's motor gear).
    Triple { range_deg: [[f64; 2]; 3], kp: f64, kd: f64, armature: f64, effort: f64 },
    /// 1-DoF hinge about the body's y axis (the elbows), limits in degrees.
    HingeY { range_deg: [f64; 2], kp: f64, kd: f64, armature: f64, effort: f64 },
}

impl JointSpec {
    /// Number of dofs (action entries) of the joint.
    pub const fn dofs(&self) -> usize {
        match self {
            JointSpec::Free | JointSpec::Welded => 0,
            JointSpec::Triple { .. } => 3,
            JointSpec::HingeY { .. } => 1,
        }
    }
    /// PD gains (kp, kd); zero for joints without a drive.
    pub const fn gains(&self) -> (f64, f64) {
        match *self {
            JointSpec::Triple { kp, kd, .. } | JointSpec::HingeY { kp, kd, .. } => (kp, kd),
            _ => (0.0, 0.0),
        }
    }

    /// Action → PD target map `target = offset + scale · clamp(a, −1, 1)` (rad) of this joint, as
    /// ASE/TokenHSI build it from the joint limits:
    /// * 3-DoF joint: offset 0, scale `min(1.2 · max_axis max(|lo|, |hi|), π)` for each of its
    ///   three hinges (ASE's rule: one scale for the joint, from its widest limit);
    /// * hinge: centre `m = (lo + hi)/2`, half-width `0.7 · (hi − lo)`: offset `m`,
    ///   scale `0.7 · (hi − lo)` (the elbow's [−160°, 0°] gives −80° ± 112°).
    pub fn action_map(&self) -> Option<(f64, f64)> {
        let rad = std::f64::consts::PI / 180.0;
        match *self {
            JointSpec::Triple { range_deg, .. } => {
                let m = range_deg.iter().flat_map(|r| [r[0].abs(), r[1].abs()]).fold(0.0, f64::max);
                Some((0.0, (1.2 * m * rad).min(std::f64::consts::PI)))
            }
            JointSpec::HingeY { range_deg: [lo, hi], .. } => {
                Some((0.5 * (lo + hi) * rad, 0.7 * (hi - lo) * rad))
            }
            _ => None,
        }
    }
}

/// One body of the character.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HsiBody {
    /// Body name as in the original model.
    pub name: &'static str,
    /// Index of the parent body; `None` for the root.
    pub parent: Option<usize>,
    /// Position of the body frame in the parent frame (m). No rest rotations.
    pub offset: [f64; 3],
    /// The joint to the parent.
    pub joint: JointSpec,
    /// The joint's name prefix (`abdomen`, `right_knee`, …; empty for the root and hands).
    pub joint_name: &'static str,
    /// Collision geoms in the body frame (each with its density, kg/m³).
    pub geoms: &'static [(&'static str, GeomSpec)],
}

const fn triple(
    x: [f64; 2],
    y: [f64; 2],
    z: [f64; 2],
    kp: f64,
    kd: f64,
    armature: f64,
    effort: f64,
) -> JointSpec {
    JointSpec::Triple { range_deg: [x, y, z], kp, kd, armature, effort }
}

const fn sphere(radius: f64, center: [f64; 3], density: f64) -> GeomSpec {
    GeomSpec::Sphere { radius, center, density }
}

const fn capsule(radius: f64, from: [f64; 3], to: [f64; 3], density: f64) -> GeomSpec {
    GeomSpec::Capsule { radius, from, to, density }
}

/// A foot box: half extents, centre and turn (w, x, y, z) in the foot frame, 1141 kg/m³.
const fn foot_box(half_extents: [f64; 3], center: [f64; 3], quat: [f64; 4]) -> GeomSpec {
    GeomSpec::Box { half_extents, center, quat, density: 1141.0 }
}

const ABDOMEN: JointSpec =
    triple([-60.0, 60.0], [-60.0, 90.0], [-50.0, 50.0], 1000.0, 100.0, 0.02, 200.0);
const NECK: JointSpec =
    triple([-50.0, 50.0], [-40.0, 60.0], [-45.0, 45.0], 100.0, 10.0, 0.01, 50.0);
const R_SHOULDER: JointSpec =
    triple([-180.0, 45.0], [-180.0, 60.0], [-90.0, 90.0], 400.0, 40.0, 0.02, 100.0);
const L_SHOULDER: JointSpec =
    triple([-45.0, 180.0], [-180.0, 60.0], [-90.0, 90.0], 400.0, 40.0, 0.02, 100.0);
const ELBOW: JointSpec = JointSpec::HingeY {
    range_deg: [-160.0, 0.0],
    kp: 300.0,
    kd: 30.0,
    armature: 0.01,
    effort: 70.0,
};
const R_HIP: JointSpec =
    triple([-60.0, 15.0], [-140.0, 60.0], [-60.0, 35.0], 500.0, 50.0, 0.02, 200.0);
const L_HIP: JointSpec =
    triple([-15.0, 60.0], [-140.0, 60.0], [-35.0, 60.0], 500.0, 50.0, 0.02, 200.0);
const KNEE: JointSpec =
    triple([-5.625, 5.625], [0.0, 160.0], [-5.625, 5.625], 500.0, 50.0, 0.02, 150.0);
const ANKLE: JointSpec =
    triple([-30.0, 30.0], [-55.0, 55.0], [-40.0, 40.0], 400.0, 40.0, 0.01, 90.0);

/// The 15 bodies in depth-first order.
pub const BODIES: [HsiBody; NUM_BODIES] = [
    HsiBody {
        name: "pelvis",
        parent: None,
        offset: [0.0, 0.0, 0.0],
        joint: JointSpec::Free,
        joint_name: "",
        geoms: &[
            ("pelvis", sphere(0.0942, [0.0, 0.0, 0.0], 2226.0)),
            ("upper_waist", sphere(0.078, [0.0, 0.0, 0.17], 2226.0)),
        ],
    },
    HsiBody {
        name: "torso",
        parent: Some(0),
        offset: [0.0, 0.0, 0.236151],
        joint: ABDOMEN,
        joint_name: "abdomen",
        geoms: &[
            ("torso", sphere(0.11, [0.0, 0.0, 0.12], 1794.0)),
            (
                "right_clavicle",
                capsule(
                    0.045,
                    [-0.0060125, -0.0457775, 0.2287955],
                    [-0.016835, -0.128177, 0.2376182],
                    1100.0,
                ),
            ),
            (
                "left_clavicle",
                capsule(
                    0.045,
                    [-0.0060125, 0.0457775, 0.2287955],
                    [-0.016835, 0.128177, 0.2376182],
                    1100.0,
                ),
            ),
        ],
    },
    HsiBody {
        name: "head",
        parent: Some(1),
        offset: [0.0, 0.0, 0.223894],
        joint: NECK,
        joint_name: "neck",
        geoms: &[("head", sphere(0.095, [0.0, 0.0, 0.175], 1081.0))],
    },
    HsiBody {
        name: "right_upper_arm",
        parent: Some(1),
        offset: [-0.02405, -0.18311, 0.2435],
        joint: R_SHOULDER,
        joint_name: "right_shoulder",
        geoms: &[("right_upper_arm", capsule(0.045, [0.0, 0.0, -0.05], [0.0, 0.0, -0.23], 982.0))],
    },
    HsiBody {
        name: "right_lower_arm",
        parent: Some(3),
        offset: [0.0, 0.0, -0.274788],
        joint: ELBOW,
        joint_name: "right_elbow",
        geoms: &[(
            "right_lower_arm",
            capsule(0.04, [0.0, 0.0, -0.0525], [0.0, 0.0, -0.1875], 1056.0),
        )],
    },
    HsiBody {
        name: "right_hand",
        parent: Some(4),
        offset: [0.0, 0.0, -0.258947],
        joint: JointSpec::Welded,
        joint_name: "",
        geoms: &[("right_hand", sphere(0.04, [0.0, 0.0, 0.0], 1865.0))],
    },
    HsiBody {
        name: "left_upper_arm",
        parent: Some(1),
        offset: [-0.02405, 0.18311, 0.2435],
        joint: L_SHOULDER,
        joint_name: "left_shoulder",
        geoms: &[("left_upper_arm", capsule(0.045, [0.0, 0.0, -0.05], [0.0, 0.0, -0.23], 982.0))],
    },
    HsiBody {
        name: "left_lower_arm",
        parent: Some(6),
        offset: [0.0, 0.0, -0.274788],
        joint: ELBOW,
        joint_name: "left_elbow",
        geoms: &[(
            "left_lower_arm",
            capsule(0.04, [0.0, 0.0, -0.0525], [0.0, 0.0, -0.1875], 1056.0),
        )],
    },
    HsiBody {
        name: "left_hand",
        parent: Some(7),
        offset: [0.0, 0.0, -0.258947],
        joint: JointSpec::Welded,
        joint_name: "",
        geoms: &[("left_hand", sphere(0.04, [0.0, 0.0, 0.0], 1865.0))],
    },
    HsiBody {
        name: "right_thigh",
        parent: Some(0),
        offset: [-0.0043, -0.0677, -0.0905],
        joint: R_HIP,
        joint_name: "right_hip",
        geoms: &[(
            "right_thigh",
            capsule(0.055, [-0.0009, -0.0038, -0.0383], [-0.008, -0.0345, -0.3443], 1269.0),
        )],
    },
    HsiBody {
        name: "right_shin",
        parent: Some(9),
        offset: [-0.0089, -0.0383, -0.3826],
        joint: KNEE,
        joint_name: "right_knee",
        geoms: &[(
            "right_shin",
            capsule(0.05, [-0.0085, 0.0032, -0.0797], [-0.0338, 0.0126, -0.3187], 1014.0),
        )],
    },
    HsiBody {
        name: "right_foot",
        parent: Some(10),
        offset: [-0.0423, 0.0158, -0.3984],
        joint: ANKLE,
        joint_name: "right_ankle",
        geoms: &[(
            "right_foot",
            foot_box(
                [0.10862014, 0.04908623, 0.03632472],
                [0.04840836, -0.02035321, -0.02758488],
                [0.99958537, 0.0, 0.02879395, 0.0],
            ),
        )],
    },
    HsiBody {
        name: "left_thigh",
        parent: Some(0),
        offset: [-0.0068, 0.0695, -0.0914],
        joint: L_HIP,
        joint_name: "left_hip",
        geoms: &[(
            "left_thigh",
            capsule(0.055, [-0.0004, 0.0034, -0.0375], [-0.004, 0.0308, -0.3377], 1269.0),
        )],
    },
    HsiBody {
        name: "left_shin",
        parent: Some(12),
        offset: [-0.0045, 0.0343, -0.3752],
        joint: KNEE,
        joint_name: "left_knee",
        geoms: &[(
            "left_shin",
            capsule(0.05, [-0.0087, -0.0027, -0.0796], [-0.035, -0.0109, -0.3184], 1014.0),
        )],
    },
    HsiBody {
        name: "left_foot",
        parent: Some(13),
        offset: [-0.0437, -0.0136, -0.398],
        joint: ANKLE,
        joint_name: "left_ankle",
        geoms: &[(
            "left_foot",
            foot_box(
                [0.10764448, 0.04873052, 0.03569894],
                [0.04736847, 0.02286634, -0.03430487],
                [0.99976203, 0.0, 0.02181489, 0.0],
            ),
        )],
    },
];

/// First action index of each body's joint (`None` for bodies without an actuated joint).
pub fn dof_start(b: usize) -> Option<usize> {
    let mut k = 0;
    for (i, body) in BODIES.iter().enumerate() {
        if i == b {
            return (body.joint.dofs() > 0).then_some(k);
        }
        k += body.joint.dofs();
    }
    None
}

/// Per action entry: (offset, scale) of `target = offset + scale · clamp(a, −1, 1)` (rad).
pub fn action_offset_scale() -> [(f64, f64); NUM_DOFS] {
    let mut out = [(0.0, 0.0); NUM_DOFS];
    let mut k = 0;
    for b in &BODIES {
        if let Some(m) = b.joint.action_map() {
            for _ in 0..b.joint.dofs() {
                out[k] = m;
                k += 1;
            }
        }
    }
    out
}

/// Anatomical part of body `b` (hands 5, 8; feet 11, 14).
pub fn body_part(b: usize) -> BodyPart {
    if HANDS.contains(&b) {
        BodyPart::Hand
    } else if FEET.contains(&b) {
        BodyPart::Foot
    } else {
        BodyPart::Trunk
    }
}

/// The registry entry (listed in `REGISTERED` of the characters module).
pub const ENTRY: CharacterEntry = CharacterEntry {
    name: "tokenhsi",
    summary: "TokenHSI character: 15 bodies, ten 3-DoF joints and two elbow hinges, 32 dofs",
    hands: &[HandModel::Full],
    ballplay: false,
    spec: |_| spec(),
    body_parts: |_| None,
};

/// The character.
pub const CHARACTER: Character = Character::new(&ENTRY, HandModel::Full);

/// The character as a [`CharacterSpec`]: each 3-DoF joint is three limited hinges
/// `<joint>_x`, `_y`, `_z` (as in the released asset) driven by position actuators (`ctrlrange`
/// ±π); the elbows are hinges about y with their range [−160°, 0°] (`ctrlrange` ±2π); gains,
/// armature and torque limits (the original's motor gears) per joint; targets
/// `offset + scale · a` from the joint limits ([`JointSpec::action_map`]); the hands are welded.
/// 1/120 s physics, four steps per 30 Hz policy step.
pub fn spec() -> CharacterSpec {
    let pi = std::f64::consts::PI;
    let mut k = 0;
    let bodies = BODIES
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let n = b.joint.dofs();
            let dofs = k..k + n;
            k += n;
            let joint = match b.joint {
                JointSpec::Free => JointDef::Free,
                JointSpec::Welded => JointDef::Welded,
                JointSpec::Triple { range_deg, kp, kd, armature, effort } => {
                    let (offset, scale) = b.joint.action_map().expect("a driven joint");
                    let hinges = xyz_hinges(b.joint_name, |a| {
                        let [lo, hi] = range_deg[a];
                        ([lo.to_radians(), hi.to_radians()], ActionMap::Affine { offset, scale })
                    });
                    JointDef::Hinges {
                        hinges,
                        drive: Drive { kp, kd, armature, effort, ctrlrange: [-pi, pi] },
                    }
                }
                JointSpec::HingeY { range_deg: [lo, hi], kp, kd, armature, effort } => {
                    let (offset, scale) = b.joint.action_map().expect("a driven joint");
                    JointDef::Hinges {
                        hinges: vec![Hinge {
                            name: b.joint_name.to_string(),
                            axis: [0.0, 1.0, 0.0],
                            range: Some([lo.to_radians(), hi.to_radians()]),
                            action: ActionMap::Affine { offset, scale },
                        }],
                        drive: Drive { kp, kd, armature, effort, ctrlrange: [-2.0 * pi, 2.0 * pi] },
                    }
                }
            };
            let geoms = b
                .geoms
                .iter()
                .map(|(name, g)| GeomDef { name: name.to_string(), spec: *g, material: None })
                .collect();
            BodyDef {
                name: b.name,
                parent: b.parent,
                offset: b.offset,
                part: body_part(i),
                joint,
                dofs,
                geoms,
            }
        })
        .collect();
    CharacterSpec {
        name: "tokenhsi",
        model_name: "tokenhsi_character".into(),
        title: "TokenHSI character",
        bodies,
        num_dofs: NUM_DOFS,
        root_pos: [0.0, 0.0, STANDING_ROOT_HEIGHT],
        root_quat: crate::math::Quat::IDENTITY,
        rgba: [0.55, 0.62, 0.78, 1.0],
        hand_rgba: None,
        excludes: Vec::new(),
        timestep: 1.0 / 120.0,
        substeps: 4,
        proprio: PROPRIO,
        ground_bodies: CONTACT_BODIES.to_vec(),
        tracking_unjudged: &[],
    }
}

/// Index of the body called `name`.
pub fn body_index(name: &str) -> Option<usize> {
    BODIES.iter().position(|b| b.name == name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_has_32_dofs_and_depth_first_parents() {
        assert_eq!(BODIES.iter().map(|b| b.joint.dofs()).sum::<usize>(), NUM_DOFS);
        for (i, b) in BODIES.iter().enumerate().skip(1) {
            assert!(b.parent.unwrap() < i, "{}", b.name);
        }
        assert_eq!(dof_start(4), Some(9));
        assert_eq!(dof_start(14), Some(29));
        assert_eq!(dof_start(5), None);
    }
}
