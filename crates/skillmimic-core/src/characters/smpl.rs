//! The SMPL humanoid of PHC, ModSkill and ProtoMotions: 24 rigid bodies of SMPL's neutral mean
//! body (β = 0), 23 joints of three hinges each = 69 actuated dofs.
//!
//! Numbers (facts of PHC's `phc/data/assets/mjcf/smpl_humanoid.xml`, SMPLSim's gain table
//! `GAINS_PHC` and ModSkill's robot configuration; the table layout is ours):
//! * body offsets and geoms are the file's, which is authored **Y-up** (SMPL's frame: legs along
//!   −y, +x the character's left, +z forward). PHC and ModSkill simulate the same body **Z-up**
//!   (`has_upright_start`: SMPLSim poses the rest body turned by 120° about (1, 1, 1)/√3, which
//!   maps a vector (x, y, z) to (z, x, y)), so the rest pose is a standing T-pose facing +x with
//!   the character's left along +y. This module keeps the file's numbers and turns them with
//!   [`zup`]; bodies have no rest rotation;
//! * each non-root body has three hinges `<Body>_x`, `_y`, `_z` about its own (world-aligned at
//!   rest) x, y, z axes, nested in that order (the body's rotation is R_x(q_x)·R_y(q_y)·R_z(q_z),
//!   intrinsic x-y-z angles); ranges ±180°, shoulders and elbows ±720° (ModSkill's
//!   `has_jt_limit: False`);
//! * PD gains (kp N·m/rad, kd N·m·s/rad): hips, knees, ankles 800/80; toes 500/50; torso, spine,
//!   chest 1000/100; neck, head, thoraxes, shoulders, elbows 500/50; wrists, hands 300/30;
//!   armature 0.02 on every hinge; actuator force limit ±500 N·m (the asset's motor gear; the
//!   released code leaves the Isaac Gym importer's effort in place — our choice, documented);
//! * action → PD target: `min(1.2 · max |range|, π) · a = π · a` per hinge, except the knee
//!   flexion hinges `L_Knee_y`, `R_Knee_y`, whose scale is 5 rad (the released code's override);
//! * geometry: capsules, spheres and boxes with the file's densities (total mass 71.79 kg);
//!   character geoms `condim = 1` (frictionless self-contact, the project's convention) with
//!   friction 1 against the floor; the file's ten body-pair exclusions;
//! * 1/120 s physics (PhysX's 1/60 s with two substeps), four physics steps per 30 Hz policy
//!   step (`controlFrequencyInv: 2`).

use super::entry::{Character, CharacterEntry};
use super::spec::{
    ActionMap, BodyDef, BodyPart, CharacterSpec, Drive, GeomDef, GeomSpec, HandModel,
    IDENTITY_WXYZ, JointDef, Proprioception, xyz_hinges,
};

/// Number of rigid bodies.
pub const NUM_BODIES: usize = 24;
/// Number of actuated dofs (= action width): 23 joints × 3 hinges.
pub const NUM_DOFS: usize = 69;
/// Pelvis height (m) of the rest T-pose standing on the floor (the lowest foot-box corner at
/// z = 0, measured with MuJoCo on the generated scene).
pub const REST_ROOT_HEIGHT: f64 = 0.937;
/// Armature (kg·m²) of every hinge.
pub const ARMATURE: f64 = 0.02;
/// Symmetric actuator force limit (N·m).
pub const FORCE_LIMIT: f64 = 500.0;
/// PD target scale (rad) of the knee flexion hinges (the released code's override of π).
pub const KNEE_FLEXION_SCALE: f64 = 5.0;

/// SMPL's Y-up frame → the simulation's Z-up frame: (x, y, z) ↦ (z, x, y).
pub const fn zup(v: [f64; 3]) -> [f64; 3] {
    [v[2], v[0], v[1]]
}

/// [`zup`] as a rotation (120° about (1, 1, 1)/√3): SMPL's Y-up body frames turned into the
/// simulated upright ones (PHC's upright start).
pub fn upright() -> crate::math::Quat {
    let a = 1.0 / 3f64.sqrt();
    crate::math::Quat::from_axis_angle([a, a, a], 2.0 * std::f64::consts::FRAC_PI_3)
}

/// Geometry in the file's Y-up body frame (turned with [`zup`] when the spec is built).
#[derive(Clone, Copy, Debug, PartialEq)]
enum YupGeom {
    Sphere(f64),
    Capsule { radius: f64, from: [f64; 3], to: [f64; 3] },
    Box { half: [f64; 3], center: [f64; 3] },
}

/// One body: name, parent, offset (Y-up, m), geom, density (kg/m³), (kp, kd).
struct Row(&'static str, Option<usize>, [f64; 3], YupGeom, f64, (f64, f64));

const LEG: (f64, f64) = (800.0, 80.0);
const TOE: (f64, f64) = (500.0, 50.0);
const SPINE: (f64, f64) = (1000.0, 100.0);
const UPPER: (f64, f64) = (500.0, 50.0);
const HAND: (f64, f64) = (300.0, 30.0);

const fn cap(radius: f64, from: [f64; 3], to: [f64; 3]) -> YupGeom {
    YupGeom::Capsule { radius, from, to }
}

const fn bx(half: [f64; 3], center: [f64; 3]) -> YupGeom {
    YupGeom::Box { half, center }
}

/// The 24 bodies in depth-first order (PHC's `SMPL_MUJOCO_NAMES`).
#[rustfmt::skip]
const ROWS: [Row; NUM_BODIES] = [
    Row("Pelvis", None, [0.0, 0.0, 0.0], YupGeom::Sphere(0.0942), 4629.6296296296305, (0.0, 0.0)),
    Row("L_Hip", Some(0), [0.0695, -0.0914, -0.0068],
        cap(0.0615, [0.0069, -0.075, -0.0009], [0.0274, -0.3002, -0.0036]), 2040.816327, LEG),
    Row("L_Knee", Some(1), [0.0343, -0.3752, -0.0045],
        cap(0.0541, [-0.0027, -0.0796, -0.0087], [-0.0109, -0.3184, -0.035]), 1234.567901, LEG),
    Row("L_Ankle", Some(2), [-0.0136, -0.398, -0.0437],
        bx([0.0483, 0.0464, 0.085], [0.0233, -0.0239, 0.0242]), 449.071569, LEG),
    Row("L_Toe", Some(3), [0.0264, -0.0558, 0.1193],
        bx([0.0478, 0.02, 0.0496], [-0.003, 0.0055, 0.0248]), 423.206892, TOE),
    Row("R_Hip", Some(0), [-0.0677, -0.0905, -0.0043],
        cap(0.0606, [-0.0077, -0.0765, -0.0018], [-0.0306, -0.3061, -0.0071]), 2040.816327, LEG),
    Row("R_Knee", Some(5), [-0.0383, -0.3826, -0.0089],
        cap(0.0541, [0.0032, -0.0797, -0.0085], [0.0126, -0.3187, -0.0338]), 1234.567901, LEG),
    Row("R_Ankle", Some(6), [0.0158, -0.3984, -0.0423],
        bx([0.0483, 0.0478, 0.0865], [-0.0212, -0.0174, 0.0256]), 434.700981, LEG),
    Row("R_Toe", Some(7), [-0.0254, -0.0481, 0.1233],
        bx([0.0479, 0.0216, 0.0493], [0.0042, 0.0045, 0.0227]), 407.384095, TOE),
    Row("Torso", Some(0), [-0.0025, 0.109, -0.0267],
        cap(0.0769, [0.0025, 0.0608, 0.0005], [0.003, 0.0743, 0.0006]), 2040.816327, SPINE),
    Row("Spine", Some(9), [0.0055, 0.1352, 0.0011],
        cap(0.0755, [0.0007, 0.0238, 0.0114], [0.0008, 0.0291, 0.014]), 2040.816327, SPINE),
    Row("Chest", Some(10), [0.0015, 0.0529, 0.0254],
        cap(0.1002, [-0.0009, 0.0682, -0.0173], [-0.001, 0.0833, -0.0212]), 2040.816327, SPINE),
    Row("Neck", Some(11), [-0.0028, 0.2139, -0.0429],
        cap(0.0436, [0.001, 0.013, 0.0103], [0.0041, 0.052, 0.0411]), 1000.0, UPPER),
    Row("Head", Some(12), [0.0052, 0.065, 0.0513], YupGeom::Sphere(0.1011), 1000.0, UPPER),
    Row("L_Thorax", Some(11), [0.0788, 0.1217, -0.0341],
        cap(0.0521, [0.0182, 0.0061, -0.0018], [0.0728, 0.0244, -0.0071]), 1000.0, UPPER),
    Row("L_Shoulder", Some(14), [0.091, 0.0305, -0.0089],
        cap(0.0517, [0.0519, -0.0026, -0.0055], [0.2077, -0.0102, -0.022]), 1000.0, UPPER),
    Row("L_Elbow", Some(15), [0.2596, -0.0128, -0.0275],
        cap(0.0405, [0.0498, 0.0018, -0.0002], [0.1994, 0.0072, -0.0009]), 1000.0, UPPER),
    Row("L_Wrist", Some(16), [0.2492, 0.009, -0.0012],
        cap(0.0318, [0.0168, -0.0016, -0.003], [0.0672, -0.0065, -0.012]), 1000.0, HAND),
    Row("L_Hand", Some(17), [0.084, -0.0082, -0.0149],
        bx([0.0585, 0.0158, 0.0538], [0.0493, 0.001, -0.0058]), 400.552564, HAND),
    Row("R_Thorax", Some(11), [-0.0818, 0.1188, -0.0386],
        cap(0.0511, [-0.0192, 0.0065, -0.0018], [-0.0768, 0.026, -0.0073]), 1000.0, UPPER),
    Row("R_Shoulder", Some(19), [-0.096, 0.0326, -0.0091],
        cap(0.0531, [-0.0507, -0.0027, -0.0043], [-0.203, -0.0107, -0.0171]), 1000.0, UPPER),
    Row("R_Elbow", Some(20), [-0.2537, -0.0133, -0.0214],
        cap(0.0408, [-0.0511, 0.0016, -0.0011], [-0.2042, 0.0062, -0.0044]), 1000.0, UPPER),
    Row("R_Wrist", Some(21), [-0.2553, 0.0078, -0.0056],
        cap(0.0326, [-0.0169, -0.0012, -0.0021], [-0.0677, -0.0049, -0.0083]), 1000.0, HAND),
    Row("R_Hand", Some(22), [-0.0846, -0.0061, -0.0103],
        bx([0.0569, 0.0164, 0.0546], [-0.0462, -0.0009, -0.0079]), 403.679611, HAND),
];

/// Body names in depth-first order.
pub fn body_names() -> [&'static str; NUM_BODIES] {
    std::array::from_fn(|b| ROWS[b].0)
}

/// Index of the body called `name`.
pub fn body_index(name: &str) -> Option<usize> {
    ROWS.iter().position(|r| r.0 == name)
}

/// Anatomical part of body `b`: the wrists and hands are the hand, ankles and toes the feet.
pub fn body_part(b: usize) -> BodyPart {
    match b {
        17 | 18 | 22 | 23 => BodyPart::Hand,
        3 | 4 | 7 | 8 => BodyPart::Foot,
        _ => BodyPart::Trunk,
    }
}

/// ModSkill's body parts on SMPL (`five`): left leg, right leg, torso with the pelvis, left
/// arm, right arm (the released code's `[4, 4, 5, 5, 5]` split of the 23 driven bodies). `None`
/// for another name.
pub fn body_parts(split: &str) -> Option<Vec<(&'static str, Vec<usize>)>> {
    (split == "five").then(|| {
        vec![
            ("l_leg", (1..=4).collect()),
            ("r_leg", (5..=8).collect()),
            ("torso", std::iter::once(0).chain(9..=13).collect()),
            ("l_arm", (14..=18).collect()),
            ("r_arm", (19..=23).collect()),
        ]
    })
}

fn geom(g: YupGeom, density: f64) -> GeomSpec {
    match g {
        YupGeom::Sphere(radius) => GeomSpec::Sphere { radius, center: [0.0; 3], density },
        YupGeom::Capsule { radius, from, to } => {
            GeomSpec::Capsule { radius, from: zup(from), to: zup(to), density }
        }
        YupGeom::Box { half, center } => GeomSpec::Box {
            half_extents: zup(half),
            center: zup(center),
            quat: IDENTITY_WXYZ,
            density,
        },
    }
}

/// The registry entry (listed in `REGISTERED` of the characters module).
// ANCHOR: entry
pub const ENTRY: CharacterEntry = CharacterEntry {
    name: "smpl",
    summary: "SMPL humanoid of PHC/ModSkill: 24 bodies, 23 joints of three hinges, 69 dofs",
    hands: &[HandModel::Full],
    ballplay: false,
    spec: |_| spec(),
    body_parts,
};
// ANCHOR_END: entry

/// The humanoid.
pub const CHARACTER: Character = Character::new(&ENTRY, HandModel::Full);

/// The humanoid as a [`CharacterSpec`] (see the module doc).
pub fn spec() -> CharacterSpec {
    let pi = std::f64::consts::PI;
    let bodies = ROWS
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let Row(name, parent, offset, g, density, (kp, kd)) = *r;
            let joint = if i == 0 {
                JointDef::Free
            } else {
                let wide = name.ends_with("Shoulder") || name.ends_with("Elbow");
                let limit = if wide { 4.0 * pi } else { pi };
                let hinges = xyz_hinges(name, |k| {
                    let knee = name.ends_with("Knee") && k == 1;
                    let scale = if knee { KNEE_FLEXION_SCALE } else { (1.2 * limit).min(pi) };
                    ([-limit, limit], ActionMap::Affine { offset: 0.0, scale })
                });
                let drive = Drive {
                    kp,
                    kd,
                    armature: ARMATURE,
                    effort: FORCE_LIMIT,
                    ctrlrange: [-2.0 * pi, 2.0 * pi],
                };
                JointDef::Hinges { hinges, drive }
            };
            BodyDef {
                name,
                parent,
                offset: zup(offset),
                part: body_part(i),
                joint,
                dofs: if i == 0 { 0..0 } else { 3 * (i - 1)..3 * i },
                geoms: vec![GeomDef {
                    name: name.to_string(),
                    spec: geom(g, density),
                    material: None,
                }],
            }
        })
        .collect();
    CharacterSpec {
        name: "smpl",
        model_name: "smpl_humanoid".into(),
        title: "SMPL humanoid (PHC, ModSkill)",
        bodies,
        num_dofs: NUM_DOFS,
        root_pos: [0.0, 0.0, REST_ROOT_HEIGHT],
        root_quat: crate::math::Quat::IDENTITY,
        rgba: [0.62, 0.72, 0.58, 1.0],
        hand_rgba: None,
        excludes: vec![
            ("L_Knee", "L_Toe"),
            ("L_Knee", "R_Ankle"),
            ("L_Knee", "R_Toe"),
            ("L_Ankle", "R_Knee"),
            ("L_Toe", "R_Knee"),
            ("R_Knee", "R_Toe"),
            ("Torso", "Chest"),
            ("Chest", "Head"),
            ("Chest", "L_Shoulder"),
            ("Chest", "R_Shoulder"),
        ],
        timestep: 1.0 / 120.0,
        substeps: 4,
        // PHC's self observation (358): root height, heading-local rotations
        proprio: Proprioception {
            root_height: true,
            root_rotation_world: false,
            contact_force_bodies: &[],
        },
        ground_bodies: vec![3, 4, 7, 8],
        tracking_unjudged: &["L_Ankle", "R_Ankle", "L_Toe", "R_Toe"],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_has_69_dofs_and_the_released_knee_override() {
        let s = spec();
        assert_eq!(s.bodies.len(), NUM_BODIES);
        assert_eq!(s.bodies.iter().map(|b| b.joint.dofs()).sum::<usize>(), NUM_DOFS);
        let maps = s.action_maps();
        let knee_y = 3 * (body_index("L_Knee").unwrap() - 1) + 1;
        assert_eq!(maps[knee_y], Some(ActionMap::Affine { offset: 0.0, scale: 5.0 }));
        assert_eq!(maps[0], Some(ActionMap::Affine { offset: 0.0, scale: std::f64::consts::PI }));
        assert_eq!(zup([1.0, 2.0, 3.0]), [3.0, 1.0, 2.0]);
        let parts = body_parts("five").unwrap();
        assert_eq!(parts.iter().map(|p| p.1.len()).collect::<Vec<_>>(), [4, 4, 6, 5, 5]);
    }
}
