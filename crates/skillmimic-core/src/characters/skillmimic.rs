//! The SkillMimic humanoid skeleton.
//!
//! 53 rigid bodies in depth-first order of the original MJCF (this order is also the order of
//! the clip columns, of the 52 joint triples and of the 156 action entries). Body 0 (`Pelvis`) is
//! the root with a free joint; every other body has one 3-dof rotational joint whose coordinates
//! are the **rotation vector (exponential map) of the body relative to its parent**.
//!
//! Frames: the skeleton is authored **Y-up** (legs hang along −y, spine along +y, +x is the
//! character's left, +z forward). The Y-up → Z-up tilt lives in each clip's root rotation, so the
//! root quaternion of a clip goes onto the free joint unchanged.
//!
//! Lengths are metres, densities kg/m³, gains N·m/rad and N·m·s/rad. The numbers are facts of the
//! SkillMimic humanoid (BallPlay-M mocap skeleton); the table layout is ours.

use super::entry::{Character, CharacterEntry};
use super::spec::{
    ActionMap, BodyDef, BodyPart, CharacterSpec, Drive, GeomDef, GeomSpec, HandModel,
    IDENTITY_WXYZ, JointDef, Proprioception,
};

/// Number of rigid bodies of the humanoid (root included).
pub const NUM_BODIES: usize = 53;
/// Number of non-root bodies, each with one 3-dof rotational joint.
pub const NUM_JOINTS: usize = 52;
/// Number of actuated degrees of freedom (= action size) = 3 × [`NUM_JOINTS`].
pub const NUM_DOFS: usize = 3 * NUM_JOINTS;

/// PD gain group of a joint (all three axes of a body share kp/kd).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JointGroup {
    /// The root (free joint, not actuated).
    Root,
    /// Hips and knees: kp 500, kd 50.
    HipKnee,
    /// Ankles: kp 400, kd 40.
    Ankle,
    /// Toes: kp 200, kd 20.
    Toe,
    /// Torso, Spine, Spine2, Chest: kp 1000, kd 100.
    Spine,
    /// Neck and head: kp 100, kd 10.
    NeckHead,
    /// Thorax and shoulders: kp 400, kd 40.
    Arm,
    /// Elbows: kp 300, kd 30.
    Elbow,
    /// Wrists and the 30 finger bodies: kp 100, kd 10.
    HandFinger,
}

impl JointGroup {
    /// Every actuated group, for tests that sweep all of them.
    pub const ACTUATED: [JointGroup; 8] = [
        JointGroup::HipKnee,
        JointGroup::Ankle,
        JointGroup::Toe,
        JointGroup::Spine,
        JointGroup::NeckHead,
        JointGroup::Arm,
        JointGroup::Elbow,
        JointGroup::HandFinger,
    ];

    /// Position gain kp (N·m/rad) and damping kd (N·m·s/rad) of the joint drive.
    pub const fn gains(self) -> (f64, f64) {
        match self {
            JointGroup::Root => (0.0, 0.0),
            JointGroup::HipKnee => (500.0, 50.0),
            JointGroup::Ankle => (400.0, 40.0),
            JointGroup::Toe => (200.0, 20.0),
            JointGroup::Spine => (1000.0, 100.0),
            JointGroup::NeckHead => (100.0, 10.0),
            JointGroup::Arm => (400.0, 40.0),
            JointGroup::Elbow => (300.0, 30.0),
            JointGroup::HandFinger => (100.0, 10.0),
        }
    }
}

/// Armature (reflected rotor inertia, kg·m²) of every joint axis.
pub const JOINT_ARMATURE: f64 = 0.02;

/// Symmetric force limit of every P actuator (N·m). The original code sets no explicit limit,
/// but the reference model's motors have `gear = 500` with `ctrlrange ±1`, the effort limit the
/// Isaac Gym MJCF importer derives for each dof — our choice for a careful port.
pub const FORCE_LIMIT: f64 = 500.0;

/// The skill observation's humanoid part (823): root height, heading-local root rotation, the
/// ten fingertips' contact forces.
pub const PROPRIO: Proprioception = Proprioception {
    root_height: true,
    root_rotation_world: false,
    contact_force_bodies: &FINGERTIPS,
};

/// Pelvis height (m) of the MJCF rest pose (the upright zero pose's feet on the floor).
pub const REST_ROOT_HEIGHT: f64 = 0.95;

/// The MJCF root orientation: the skeleton is authored Y-up; a quarter turn about x stands it
/// up in MuJoCo's Z-up world.
pub fn upright() -> crate::math::Quat {
    crate::math::Quat::from_rotvec([std::f64::consts::FRAC_PI_2, 0.0, 0.0])
}

/// The registry entry (listed in `REGISTERED` of the characters module).
pub const ENTRY: CharacterEntry = CharacterEntry {
    name: "skillmimic",
    summary: "SkillMimic humanoid: 53 bodies (BallPlay-M), 156 dofs, articulated or box hands",
    hands: &[HandModel::Full, HandModel::Box],
    ballplay: true,
    spec,
    body_parts,
};

/// The humanoid with a hand model.
pub const fn humanoid(hands: HandModel) -> Character {
    Character::new(&ENTRY, hands)
}

/// The humanoid as a [`CharacterSpec`]: one ball joint per non-root body (armature 0.02,
/// damping kd of its group), driven by three force-limited position actuators with the
/// group's kp (PD target = π · a, `ctrlrange` ±π); box hands weld the 30 finger bodies (their
/// dof slots stay in the 156-wide action and are ignored); the two permanently overlapping
/// Thumb1–Thumb3 pairs of the articulated hands are excluded from collisions; 1/120 s physics,
/// two steps per 60 Hz policy step.
pub fn spec(hands: HandModel) -> CharacterSpec {
    let pi = std::f64::consts::PI;
    let bodies = BODIES
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let (kp, kd) = b.group.gains();
            let joint = if i == 0 {
                JointDef::Free
            } else if hands == HandModel::Box && is_finger(i) {
                JointDef::Welded
            } else {
                let drive = Drive {
                    kp,
                    kd,
                    armature: JOINT_ARMATURE,
                    effort: FORCE_LIMIT,
                    ctrlrange: [-pi, pi],
                };
                JointDef::Ball { name: b.name.to_string(), drive, action: ActionMap::Scaled(pi) }
            };
            let material = (body_part(i) == BodyPart::Hand).then_some("hand");
            BodyDef {
                name: b.name,
                parent: b.parent,
                offset: b.offset,
                part: body_part(i),
                joint,
                dofs: if i == 0 { 0..0 } else { dof_range(i) },
                geoms: vec![GeomDef { name: b.name.to_string(), spec: b.geom, material }],
            }
        })
        .collect();
    let excludes = match hands {
        HandModel::Full => vec![("L_Thumb1", "L_Thumb3"), ("R_Thumb1", "R_Thumb3")],
        HandModel::Box => Vec::new(),
    };
    CharacterSpec {
        name: "skillmimic",
        model_name: format!("skillmimic_humanoid_ball_{}", hands.name()),
        title: "SkillMimic humanoid",
        bodies,
        num_dofs: NUM_DOFS,
        root_pos: [0.0, 0.0, REST_ROOT_HEIGHT],
        root_quat: upright(),
        rgba: [0.78, 0.62, 0.5, 1.0],
        hand_rgba: Some([0.85, 0.7, 0.58, 1.0]),
        excludes,
        timestep: 1.0 / 120.0,
        substeps: 2,
        proprio: PROPRIO,
        ground_bodies: vec![3, 4, 7, 8],
        tracking_unjudged: &[],
    }
}

/// One body of the skeleton.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodySpec {
    /// Body name as in the original model (clip columns follow this order).
    pub name: &'static str,
    /// Index of the parent body; `None` for the root.
    pub parent: Option<usize>,
    /// Position of the body frame in the parent frame (m). Bodies have no rest rotation.
    pub offset: [f64; 3],
    /// PD gain group of this body's joint.
    pub group: JointGroup,
    /// The body's single geom.
    pub geom: GeomSpec,
}

/// The 53 bodies in depth-first order.
#[rustfmt::skip]
pub const BODIES: [BodySpec; NUM_BODIES] = [
    BodySpec { name: "Pelvis", parent: None, offset: [0.0, 0.0, 0.0], group: JointGroup::Root,
        geom: GeomSpec::Sphere { radius: 0.0985, density: 4629.6296296296305,
            center: [0.0, 0.0, 0.0] } },
    BodySpec { name: "L_Hip", parent: Some(0), offset: [0.109716, -0.0365719, 0.0],
        group: JointGroup::HipKnee, geom: GeomSpec::Capsule { radius: 0.0605, density: 2040.816327,
            from: [0.0, -0.1, 0.0], to: [0.0, -0.461208, 0.0256003] } },
    BodySpec { name: "L_Knee", parent: Some(1), offset: [0.0, -0.461208, 0.0256003],
        group: JointGroup::HipKnee, geom: GeomSpec::Capsule { radius: 0.0533, density: 1234.567901,
            from: [0.0, -0.1, 0.0], to: [0.0, -0.364385, -0.0256003] } },
    BodySpec { name: "L_Ankle", parent: Some(2), offset: [0.0, -0.364385, -0.0256003],
        group: JointGroup::Ankle, geom: GeomSpec::Box { density: 1000.0, quat: IDENTITY_WXYZ,
            half_extents: [0.0498, 0.0464, 0.0857], center: [0.0, -0.07, 0.0142] } },
    BodySpec { name: "L_Toe", parent: Some(3), offset: [0.0, -0.0986496, 0.156582],
        group: JointGroup::Toe, geom: GeomSpec::Box { density: 1000.0, quat: IDENTITY_WXYZ,
            half_extents: [0.0478, 0.02, 0.0495], center: [0.0, 0.0, 0.0] } },
    BodySpec { name: "R_Hip", parent: Some(0), offset: [-0.109716, -0.0365719, 0.0],
        group: JointGroup::HipKnee, geom: GeomSpec::Capsule { radius: 0.0598, density: 2040.816327,
            from: [0.0, -0.1, 0.0], to: [0.0, -0.461208, 0.0256003] } },
    BodySpec { name: "R_Knee", parent: Some(5), offset: [0.0, -0.461208, 0.0256003],
        group: JointGroup::HipKnee, geom: GeomSpec::Capsule { radius: 0.0551, density: 1234.567901,
            from: [0.0, -0.1, 0.0], to: [0.0, -0.364385, -0.0256003] } },
    BodySpec { name: "R_Ankle", parent: Some(6), offset: [0.0, -0.364385, -0.0256003],
        group: JointGroup::Ankle, geom: GeomSpec::Box { density: 1000.0, quat: IDENTITY_WXYZ,
            half_extents: [0.0498, 0.0464, 0.0857], center: [0.0, -0.07, 0.0142] } },
    BodySpec { name: "R_Toe", parent: Some(7), offset: [0.0, -0.0986496, 0.156582],
        group: JointGroup::Toe, geom: GeomSpec::Box { density: 1000.0, quat: IDENTITY_WXYZ,
            half_extents: [0.0478, 0.02, 0.0495], center: [0.0, 0.0, 0.0] } },
    BodySpec { name: "Torso", parent: Some(0), offset: [0.0, 0.0877726, -0.0279775],
        group: JointGroup::Spine, geom: GeomSpec::Sphere { radius: 0.05011, density: 1000.0,
            center: [0.0, 0.05, 0.0279775] } },
    BodySpec { name: "Spine", parent: Some(9), offset: [0.0, 0.106124, 0.0],
        group: JointGroup::Spine, geom: GeomSpec::Sphere { radius: 0.06011, density: 1000.0,
            center: [0.0, 0.05, 0.0279775] } },
    BodySpec { name: "Spine2", parent: Some(10), offset: [0.0, 0.106124, 0.0],
        group: JointGroup::Spine, geom: GeomSpec::Sphere { radius: 0.07011, density: 1000.0,
            center: [0.0, 0.05, 0.0279775] } },
    BodySpec { name: "Chest", parent: Some(11), offset: [0.0, 0.166951, 0.0],
        group: JointGroup::Spine, geom: GeomSpec::Sphere { radius: 0.011, density: 1000.0,
            center: [0.0, -0.05, 0.0279775] } },
    BodySpec { name: "Neck", parent: Some(12), offset: [0.0, 0.084247, 0.0146288],
        group: JointGroup::NeckHead, geom: GeomSpec::Capsule { radius: 0.0419, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [0.0, 0.0509716, 0.0] } },
    BodySpec { name: "Head", parent: Some(13), offset: [0.0, 0.109716, 0.0],
        group: JointGroup::NeckHead, geom: GeomSpec::Sphere { radius: 0.1011, density: 1000.0,
            center: [0.0, 0.03, 0.0279775] } },
    BodySpec { name: "L_Thorax", parent: Some(12), offset: [0.018286, -0.0295385, 0.0365719],
        group: JointGroup::Arm, geom: GeomSpec::Capsule { radius: 0.0488, density: 1000.0,
            from: [0.1, 0.0, 0.0], to: [0.166499, 0.0, 0.0] } },
    BodySpec { name: "L_Shoulder", parent: Some(15), offset: [0.166499, 0.0, 0.0],
        group: JointGroup::Arm, geom: GeomSpec::Capsule { radius: 0.0522, density: 1000.0,
            from: [0.1, 0.0, 0.0], to: [0.252505, 0.0, 0.0] } },
    BodySpec { name: "L_Elbow", parent: Some(16), offset: [0.252505, 0.0, 0.0],
        group: JointGroup::Elbow, geom: GeomSpec::Capsule { radius: 0.0401, density: 1000.0,
            from: [0.1, 0.0, 0.0], to: [0.223894, 0.0, 0.0] } },
    BodySpec { name: "L_Wrist", parent: Some(17), offset: [0.243894, 0.0, 0.0],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0103, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [0.06, 0.0, 0.0] } },
    BodySpec { name: "L_Index1", parent: Some(18), offset: [0.100362, 0.0, 0.0561204],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0092, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [0.0343, 0.0, 0.0] } },
    BodySpec { name: "L_Index2", parent: Some(19), offset: [0.0343, 0.0, 0.0],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0075, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [0.02401, 0.0, 0.0] } },
    BodySpec { name: "L_Index3", parent: Some(20), offset: [0.02401, 0.0, 0.0],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0068, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [0.0149205, 0.0, 0.0] } },
    BodySpec { name: "L_Middle1", parent: Some(18), offset: [0.0927298, 0.0, 0.029047],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0094, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [0.04116, 0.0, 0.0] } },
    BodySpec { name: "L_Middle2", parent: Some(22), offset: [0.04116, 0.0, 0.0],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.007, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [0.028812, 0.0, 0.0] } },
    BodySpec { name: "L_Middle3", parent: Some(23), offset: [0.028812, 0.0, 0.0],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0063, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [0.0179046, 0.0, 0.0] } },
    BodySpec { name: "L_Pinky1", parent: Some(18), offset: [0.0774654, 0.0, -0.0250997],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.007, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [0.0267662, 0.0, 0.0] } },
    BodySpec { name: "L_Pinky2", parent: Some(25), offset: [0.0267662, 0.0, 0.0],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0063, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [0.0187364, 0.0, 0.0] } },
    BodySpec { name: "L_Pinky3", parent: Some(26), offset: [0.0187364, 0.0, 0.0],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0051, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [0.0116433, 0.0, 0.0] } },
    BodySpec { name: "L_Ring1", parent: Some(18), offset: [0.0850976, 0.0, 0.00197363],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0079, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [0.039445, 0.0, 0.0] } },
    BodySpec { name: "L_Ring2", parent: Some(28), offset: [0.039445, 0.0, 0.0],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0072, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [0.0276115, 0.0, 0.0] } },
    BodySpec { name: "L_Ring3", parent: Some(29), offset: [0.0276115, 0.0, 0.0],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.006, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [0.0171586, 0.0, 0.0] } },
    BodySpec { name: "L_Thumb1", parent: Some(18), offset: [0.0444569, 0.0, 0.0673445],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0122, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [0.0294, 0.0, 0.01] } },
    BodySpec { name: "L_Thumb2", parent: Some(31), offset: [0.0294, 0.0, 0.01],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0093, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [0.02058, 0.0, 0.0] } },
    BodySpec { name: "L_Thumb3", parent: Some(32), offset: [0.02058, 0.0, 0.0],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0087, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [0.012789, 0.0, 0.0] } },
    BodySpec { name: "R_Thorax", parent: Some(12), offset: [-0.018286, -0.0295385, 0.0365719],
        group: JointGroup::Arm, geom: GeomSpec::Capsule { radius: 0.0536, density: 1000.0,
            from: [-0.1, 0.0, 0.0], to: [-0.166499, 0.0, 0.0] } },
    BodySpec { name: "R_Shoulder", parent: Some(34), offset: [-0.166499, 0.0, 0.0],
        group: JointGroup::Arm, geom: GeomSpec::Capsule { radius: 0.0521, density: 1000.0,
            from: [-0.1, 0.0, 0.0], to: [-0.252505, 0.0, 0.0] } },
    BodySpec { name: "R_Elbow", parent: Some(35), offset: [-0.252505, 0.0, 0.0],
        group: JointGroup::Elbow, geom: GeomSpec::Capsule { radius: 0.0404, density: 1000.0,
            from: [-0.1, 0.0, 0.0], to: [-0.223894, 0.0, 0.0] } },
    BodySpec { name: "R_Wrist", parent: Some(36), offset: [-0.243894, 0.0, 0.0],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.01, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [-0.06, 0.0, 0.0] } },
    BodySpec { name: "R_Index1", parent: Some(37), offset: [-0.0953267, 0.0, 0.0454889],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0092, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [-0.0343, 0.0, 0.0] } },
    BodySpec { name: "R_Index2", parent: Some(38), offset: [-0.0343, 0.0, 0.0],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0076, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [-0.02401, 0.0, 0.0] } },
    BodySpec { name: "R_Index3", parent: Some(39), offset: [-0.02401, 0.0, 0.0],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0069, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [-0.0149205, 0.0, 0.0] } },
    BodySpec { name: "R_Middle1", parent: Some(37), offset: [-0.0891353, 0.0, 0.0223232],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0094, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [-0.04116, 0.0, 0.0] } },
    BodySpec { name: "R_Middle2", parent: Some(41), offset: [-0.04116, 0.0, 0.0],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0071, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [-0.028812, 0.0, 0.0] } },
    BodySpec { name: "R_Middle3", parent: Some(42), offset: [-0.028812, 0.0, 0.0],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0064, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [-0.0179046, 0.0, 0.0] } },
    BodySpec { name: "R_Pinky1", parent: Some(37), offset: [-0.0767525, 0.0, -0.0240082],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.007, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [-0.0267662, 0.0, 0.0] } },
    BodySpec { name: "R_Pinky2", parent: Some(44), offset: [-0.0267662, 0.0, 0.0],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0063, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [-0.0187364, 0.0, 0.0] } },
    BodySpec { name: "R_Pinky3", parent: Some(45), offset: [-0.0187364, 0.0, 0.0],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0052, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [-0.0116433, 0.0, 0.0] } },
    BodySpec { name: "R_Ring1", parent: Some(37), offset: [-0.0829439, 0.0, -0.000842496],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0079, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [-0.039445, 0.0, 0.0] } },
    BodySpec { name: "R_Ring2", parent: Some(47), offset: [-0.039445, 0.0, 0.0],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0072, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [-0.0276115, 0.0, 0.0] } },
    BodySpec { name: "R_Ring3", parent: Some(48), offset: [-0.0276115, 0.0, 0.0],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.006, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [-0.0171586, 0.0, 0.0] } },
    BodySpec { name: "R_Thumb1", parent: Some(37), offset: [-0.0430198, 0.0, 0.0545867],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0122, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [-0.0294, 0.0, 0.01] } },
    BodySpec { name: "R_Thumb2", parent: Some(50), offset: [-0.0294, 0.0, 0.01],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.0093, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [-0.02058, 0.0, 0.0] } },
    BodySpec { name: "R_Thumb3", parent: Some(51), offset: [-0.02058, 0.0, 0.0],
        group: JointGroup::HandFinger, geom: GeomSpec::Capsule { radius: 0.009, density: 1000.0,
            from: [0.0, 0.0, 0.0], to: [-0.012789, 0.0, 0.0] } },
];

/// The 17 key bodies of the position and interaction-graph rewards and of the HOI vector, in the
/// reference order: Head, knees, elbows, ankles, then the ten fingertips.
pub const KEY_BODIES: [usize; 17] =
    [14, 2, 6, 17, 36, 3, 7, 21, 24, 27, 30, 33, 40, 43, 46, 49, 52];

/// The ten fingertip bodies whose net contact force enters the policy observation
/// (left Index3, Middle3, Pinky3, Ring3, Thumb3, then the right hand in the same order).
pub const FINGERTIPS: [usize; 10] = [21, 24, 27, 30, 33, 40, 43, 46, 49, 52];

/// The bodies of the reference "body" contact node (force-threshold compatibility mode): pelvis,
/// hips, knees, spine chain, neck, head, thoraxes, shoulders, elbows. Feet, wrists and fingers
/// are not members, so foot–floor and hand–ball contacts never count as body contact there.
pub const REFERENCE_BODY_NODE: [usize; 17] =
    [0, 1, 2, 5, 6, 9, 10, 11, 12, 13, 14, 15, 16, 17, 34, 35, 36];

/// Left wrist body index; the left hand is bodies `18..=33` (wrist and 15 finger bodies).
pub const L_WRIST: usize = 18;
/// Right wrist body index; the right hand is bodies `37..=52`.
pub const R_WRIST: usize = 37;

/// Anatomical part of body `b`.
pub const fn body_part(b: usize) -> BodyPart {
    match b {
        18..=33 | 37..=52 => BodyPart::Hand,
        3 | 4 | 7 | 8 => BodyPart::Foot,
        _ => BodyPart::Trunk,
    }
}

/// True for the 30 finger bodies (not the wrists).
pub const fn is_finger(b: usize) -> bool {
    matches!(b, 19..=33 | 38..=52)
}

/// Index of the body called `name`.
pub fn body_index(name: &str) -> Option<usize> {
    BODIES.iter().position(|b| b.name == name)
}

/// World positions (m) of the 53 body frames for a root pose and the 156 joint exp maps
/// (`dof`, skeleton order): body b's frame = its parent's frame moved by `offset` and turned by
/// exp(dof of b) (bodies have no rest rotation). The same kinematics MuJoCo computes for the
/// generated scene.
pub fn forward_kinematics(
    root_pos: [f64; 3],
    root_quat: crate::math::Quat,
    dof: &[f32],
) -> [[f64; 3]; NUM_BODIES] {
    let mut pos = [[0.0; 3]; NUM_BODIES];
    let mut rot = [root_quat; NUM_BODIES];
    pos[0] = root_pos;
    for b in 1..NUM_BODIES {
        let p = BODIES[b].parent.expect("non-root bodies have a parent");
        let d = dof_range(b);
        let local = crate::math::Quat::from_rotvec([
            dof[d.start] as f64,
            dof[d.start + 1] as f64,
            dof[d.start + 2] as f64,
        ]);
        pos[b] = crate::math::add(pos[p], rot[p].rotate(BODIES[b].offset));
        rot[b] = rot[p].mul(local);
    }
    pos
}

/// The body parts of ModSkill's splits on this skeleton: `five` = left leg, right leg, torso
/// (with the pelvis), left arm with its hand, right arm with its hand; `seven` = the same with
/// each hand (wrist and fingers) separate. `None` for another name.
pub fn body_parts(split: &str) -> Option<Vec<(&'static str, Vec<usize>)>> {
    let torso: Vec<usize> = std::iter::once(0).chain(9..=14).collect();
    match split {
        "five" => Some(vec![
            ("l_leg", (1..=4).collect()),
            ("r_leg", (5..=8).collect()),
            ("torso", torso),
            ("l_arm", (15..=33).collect()),
            ("r_arm", (34..=52).collect()),
        ]),
        "seven" => Some(vec![
            ("l_leg", (1..=4).collect()),
            ("r_leg", (5..=8).collect()),
            ("torso", torso),
            ("l_arm", (15..=17).collect()),
            ("l_hand", (18..=33).collect()),
            ("r_arm", (34..=36).collect()),
            ("r_hand", (37..=52).collect()),
        ]),
        _ => None,
    }
}

/// The left/right partner of body `b` (`L_*` ↔ `R_*`; bodies on the midline are their own).
pub fn mirror_body(b: usize) -> usize {
    let name = BODIES[b].name;
    let other = if let Some(rest) = name.strip_prefix("L_") {
        format!("R_{rest}")
    } else if let Some(rest) = name.strip_prefix("R_") {
        format!("L_{rest}")
    } else {
        return b;
    };
    body_index(&other).expect("every L_/R_ body has a partner")
}

/// Index range of body `b`'s three joint coordinates in the 156-wide dof vector (`b ≥ 1`).
pub const fn dof_range(b: usize) -> std::ops::Range<usize> {
    3 * (b - 1)..3 * b
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_is_depth_first_with_parents_before_children() {
        assert_eq!(BODIES[0].parent, None);
        for (i, b) in BODIES.iter().enumerate().skip(1) {
            let p = b.parent.expect("non-root body without parent");
            assert!(p < i, "{} has parent {} after it", b.name, p);
            assert_ne!(b.group, JointGroup::Root);
        }
        // names are unique
        for (i, a) in BODIES.iter().enumerate() {
            assert_eq!(body_index(a.name), Some(i));
        }
    }

    #[test]
    fn named_sets_point_at_the_expected_bodies() {
        let names: Vec<_> = KEY_BODIES.iter().map(|&b| BODIES[b].name).collect();
        assert_eq!(
            &names[..7],
            &["Head", "L_Knee", "R_Knee", "L_Elbow", "R_Elbow", "L_Ankle", "R_Ankle"]
        );
        assert!(FINGERTIPS.iter().all(|&b| BODIES[b].name.ends_with('3')));
        assert_eq!(BODIES[L_WRIST].name, "L_Wrist");
        assert_eq!(BODIES[R_WRIST].name, "R_Wrist");
        assert_eq!(BODIES[11].name, "Spine2");
        assert_eq!(dof_range(1), 0..3);
        assert_eq!(dof_range(52), 153..156);
        let hands = (0..NUM_BODIES).filter(|&b| body_part(b) == BodyPart::Hand).count();
        assert_eq!(hands, 32);
        assert_eq!((0..NUM_BODIES).filter(|&b| is_finger(b)).count(), 30);
    }

    #[test]
    fn gains_follow_the_reference_groups() {
        let g = |n: &str| BODIES[body_index(n).unwrap()].group.gains();
        assert_eq!(g("L_Hip"), (500.0, 50.0));
        assert_eq!(g("R_Ankle"), (400.0, 40.0));
        assert_eq!(g("L_Toe"), (200.0, 20.0));
        assert_eq!(g("Chest"), (1000.0, 100.0));
        assert_eq!(g("Head"), (100.0, 10.0));
        assert_eq!(g("R_Shoulder"), (400.0, 40.0));
        assert_eq!(g("L_Elbow"), (300.0, 30.0));
        assert_eq!(g("R_Thumb3"), (100.0, 10.0));
    }
}
