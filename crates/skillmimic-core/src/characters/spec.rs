//! The types of a character description ([`CharacterSpec`]) and the kinematics every character
//! shares (local rotations from dof coordinates and back, forward kinematics).

use std::ops::Range;

use crate::math::Quat;

/// Collision/visual geometry of one body, in the body frame (metres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GeomSpec {
    /// Sphere of `radius` centred at `center`.
    Sphere { radius: f64, center: [f64; 3], density: f64 },
    /// Capsule of `radius` whose axis runs `from` → `to`.
    Capsule { radius: f64, from: [f64; 3], to: [f64; 3], density: f64 },
    /// Box with half extents `half_extents` centred at `center`, turned by the unit quaternion
    /// `quat` (w, x, y, z) from the body frame's axes ([`IDENTITY_WXYZ`] for an axis-aligned box).
    Box { half_extents: [f64; 3], center: [f64; 3], quat: [f64; 4], density: f64 },
}

impl GeomSpec {
    /// A box's eight corners in its body's frame (m); `None` for other shapes.
    pub fn box_corners(&self) -> Option<[[f64; 3]; 8]> {
        let GeomSpec::Box { half_extents: h, center: c, quat, .. } = *self else { return None };
        let turn = Quat::from_wxyz(quat);
        Some(std::array::from_fn(|k| {
            let corner = turn.rotate([
                if k & 4 == 0 { -h[0] } else { h[0] },
                if k & 2 == 0 { -h[1] } else { h[1] },
                if k & 1 == 0 { -h[2] } else { h[2] },
            ]);
            [c[0] + corner[0], c[1] + corner[1], c[2] + corner[2]]
        }))
    }
}

/// The identity rotation as (w, x, y, z), for axis-aligned boxes.
pub const IDENTITY_WXYZ: [f64; 4] = [1.0, 0.0, 0.0, 0.0];

/// Coarse anatomical part of a body, used to classify contacts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BodyPart {
    /// Wrist, hand or finger body.
    Hand,
    /// Ankle, foot or toe body.
    Foot,
    /// Any other body (pelvis, legs, spine, head, arms up to the elbow).
    Trunk,
}

/// How an action entry in [−1, 1] becomes a PD target (rad): `target = map(clamp(a, −1, 1))`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ActionMap {
    /// `scale · a` (SkillMimic: π · a).
    Scaled(f64),
    /// `offset + scale · a` (ASE's map from the joint limits, TokenHSI and PHC).
    Affine { offset: f64, scale: f64 },
}

impl ActionMap {
    /// The PD target of the clamped action `a` (rad).
    #[inline]
    pub fn target(self, a: f64) -> f64 {
        match self {
            ActionMap::Scaled(s) => a * s,
            ActionMap::Affine { offset, scale } => offset + scale * a,
        }
    }
    /// (offset, scale) of the map.
    pub fn offset_scale(self) -> (f64, f64) {
        match self {
            ActionMap::Scaled(s) => (0.0, s),
            ActionMap::Affine { offset, scale } => (offset, scale),
        }
    }
}

/// The PD drive of a joint: a MuJoCo `position` actuator per dof (P term, force-limited) plus
/// the joint's passive damping (D term, target velocity 0, integrated implicitly).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Drive {
    /// Position gain kp (N·m/rad).
    pub kp: f64,
    /// Damping kd (N·m·s/rad).
    pub kd: f64,
    /// Armature (reflected rotor inertia, kg·m²) of every axis.
    pub armature: f64,
    /// Symmetric actuator force limit (N·m).
    pub effort: f64,
    /// The actuators' `ctrlrange` (rad).
    pub ctrlrange: [f64; 2],
}

/// One hinge of a [`JointDef::Hinges`] joint.
#[derive(Clone, Debug, PartialEq)]
pub struct Hinge {
    /// MuJoCo joint (and actuator) name.
    pub name: String,
    /// Axis in the body frame.
    pub axis: [f64; 3],
    /// Joint range (rad); `None` = unlimited.
    pub range: Option<[f64; 2]>,
    /// Action map of this hinge's dof.
    pub action: ActionMap,
}

/// Three hinges `<joint>_x`, `<joint>_y`, `<joint>_z` about the body's x, y and z axes (nested in
/// that order: a 3-DoF joint as Isaac Gym's MJCF characters have it); `per_axis(k)` gives hinge
/// k's range (rad) and action map.
pub fn xyz_hinges(joint: &str, per_axis: impl Fn(usize) -> ([f64; 2], ActionMap)) -> Vec<Hinge> {
    ["x", "y", "z"]
        .iter()
        .enumerate()
        .map(|(k, suffix)| {
            let mut axis = [0.0; 3];
            axis[k] = 1.0;
            let (range, action) = per_axis(k);
            Hinge { name: format!("{joint}_{suffix}"), axis, range: Some(range), action }
        })
        .collect()
}

/// The joint that attaches a body to its parent.
#[derive(Clone, Debug, PartialEq)]
pub enum JointDef {
    /// The root's free joint.
    Free,
    /// No joint: welded to the parent. Its dof slots (if any) read 0 and ignore their actions.
    Welded,
    /// One 3-DoF ball joint named `name`; its coordinates are the rotation vector of the body
    /// relative to its parent, driven per rotation-vector component by actuators
    /// `<name>_x`, `_y`, `_z`.
    Ball { name: String, drive: Drive, action: ActionMap },
    /// One or more hinges (nested in this order), one dof each; actuators are named like the
    /// hinges.
    Hinges { hinges: Vec<Hinge>, drive: Drive },
}

impl JointDef {
    /// Dofs (action entries) the joint drives.
    pub fn dofs(&self) -> usize {
        match self {
            JointDef::Free | JointDef::Welded => 0,
            JointDef::Ball { .. } => 3,
            JointDef::Hinges { hinges, .. } => hinges.len(),
        }
    }
    /// The PD drive, for a driven joint.
    pub fn drive(&self) -> Option<&Drive> {
        match self {
            JointDef::Ball { drive, .. } | JointDef::Hinges { drive, .. } => Some(drive),
            _ => None,
        }
    }
}

/// One named geom of a body.
#[derive(Clone, Debug, PartialEq)]
pub struct GeomDef {
    pub name: String,
    pub spec: GeomSpec,
    /// A material other than the character's default `body` (e.g. `hand`).
    pub material: Option<&'static str>,
}

/// One body of a character.
#[derive(Clone, Debug, PartialEq)]
pub struct BodyDef {
    pub name: &'static str,
    /// Parent body index; `None` for the root (body 0).
    pub parent: Option<usize>,
    /// Position of the body frame in the parent frame (m). Bodies have no rest rotation.
    pub offset: [f64; 3],
    pub part: BodyPart,
    pub joint: JointDef,
    /// This body's slots in the character's dof (action) vector; a welded body may keep slots
    /// (SkillMimic's box hands keep the 156-wide action of the articulated ones).
    pub dofs: Range<usize>,
    pub geoms: Vec<GeomDef>,
}

/// The character part of an observation (ASE's proprioception, in the root's heading frame:
/// world rotated about +z by −heading): optionally the root height (m); the positions of bodies
/// 1… relative to the root (m); the rotations of every body as tan-norm 6D (the root's in the
/// heading frame, or in the world frame); the linear velocities of the bodies' centres of mass
/// (m/s) and their angular velocities (rad/s); then the net contact force on some bodies
/// (**world** frame, N). The formula is `skillmimic_env::proprio`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Proprioception {
    pub root_height: bool,
    pub root_rotation_world: bool,
    /// Bodies whose net contact force is observed.
    pub contact_force_bodies: &'static [usize],
}

impl Proprioception {
    /// Width for a character of `bodies` bodies.
    pub fn width(&self, bodies: usize) -> usize {
        usize::from(self.root_height)
            + 3 * (bodies - 1)
            + 12 * bodies
            + 3 * self.contact_force_bodies.len()
    }
}

/// Everything the simulation and the environments read of a character (see the module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct CharacterSpec {
    /// Registry name (`skillmimic`, `tokenhsi`, `smpl`).
    pub name: &'static str,
    /// The MJCF model name.
    pub model_name: String,
    /// First line comment of the generated MJCF.
    pub title: &'static str,
    /// Bodies in depth-first order (parents before children, body 0 the root).
    pub bodies: Vec<BodyDef>,
    /// Width of the dof (action) vector.
    pub num_dofs: usize,
    /// The root body's MJCF pose: the rest pose standing on the floor (world, m).
    pub root_pos: [f64; 3],
    pub root_quat: Quat,
    /// Colour of the `body` material (and of the `hand` material, where bodies use it).
    pub rgba: [f32; 4],
    pub hand_rgba: Option<[f32; 4]>,
    /// Body pairs whose contacts are excluded (MJCF `<exclude>`), by name.
    pub excludes: Vec<(&'static str, &'static str)>,
    /// Physics step (s) and physics steps per policy step.
    pub timestep: f64,
    pub substeps: usize,
    /// The character part of the observation.
    pub proprio: Proprioception,
    /// Bodies allowed to touch the ground in ASE's fall rule (the feet).
    pub ground_bodies: Vec<usize>,
    /// Bodies the tracking task leaves out of its termination and success distance by default,
    /// by name (SMPL: the ankles and toes, which the released ModSkill/PHC `reset_bodies` omit);
    /// empty: every tracked body counts.
    pub tracking_unjudged: &'static [&'static str],
}

impl CharacterSpec {
    /// Lowest world height (m, Z-up) of the corners of the foot bodies' boxes, for world body
    /// positions `pos` and orientations `rot` (one per body, in body order); +∞ without any.
    pub fn lowest_foot_box(&self, pos: &[[f64; 3]], rot: &[Quat]) -> f64 {
        let mut z = f64::INFINITY;
        for (b, body) in self.bodies.iter().enumerate() {
            if body.part != BodyPart::Foot {
                continue;
            }
            for g in &body.geoms {
                for p in g.spec.box_corners().into_iter().flatten() {
                    z = z.min(pos[b][2] + rot[b].rotate(p)[2]);
                }
            }
        }
        z
    }
    /// Width of the character part of the observation.
    pub fn proprio_dim(&self) -> usize {
        self.proprio.width(self.bodies.len())
    }
    /// Number of bodies.
    pub fn num_bodies(&self) -> usize {
        self.bodies.len()
    }
    /// Index of the body called `name`.
    pub fn body_index(&self, name: &str) -> Option<usize> {
        self.bodies.iter().position(|b| b.name == name)
    }
    /// Bodies of anatomical part `part`, in body order.
    pub fn bodies_of(&self, part: BodyPart) -> Vec<usize> {
        (0..self.bodies.len()).filter(|&b| self.bodies[b].part == part).collect()
    }
    /// Per dof: the action map of its drive (`None` for the slots of welded bodies).
    pub fn action_maps(&self) -> Vec<Option<ActionMap>> {
        let mut out = vec![None; self.num_dofs];
        for b in &self.bodies {
            match &b.joint {
                JointDef::Ball { action, .. } => {
                    for k in b.dofs.clone() {
                        out[k] = Some(*action);
                    }
                }
                JointDef::Hinges { hinges, .. } => {
                    for (k, h) in b.dofs.clone().zip(hinges) {
                        out[k] = Some(h.action);
                    }
                }
                JointDef::Free | JointDef::Welded => {}
            }
        }
        out
    }
    /// Local rotation (relative to the parent) of body `b` for the dof vector `dof`: a ball
    /// joint's rotation vector, hinges composed in their nesting order (three hinges x, y, z:
    /// R_x(q₀)·R_y(q₁)·R_z(q₂)), identity for the root and welded bodies.
    pub fn local_rotation(&self, b: usize, dof: &[f64]) -> Quat {
        let body = &self.bodies[b];
        let k = body.dofs.start;
        match &body.joint {
            JointDef::Ball { .. } => Quat::from_rotvec([dof[k], dof[k + 1], dof[k + 2]]),
            JointDef::Hinges { hinges, .. } => hinges
                .iter()
                .enumerate()
                .fold(Quat::IDENTITY, |q, (i, h)| q.mul(Quat::from_axis_angle(h.axis, dof[k + i]))),
            JointDef::Free | JointDef::Welded => Quat::IDENTITY,
        }
    }

    /// Write into `dof` the coordinates that give body `b` the local rotation `q`: a ball joint's
    /// rotation vector; three hinges about x, y, z the intrinsic x-y-z angles (the middle one in
    /// [−π/2, π/2]); one hinge the signed angle of `q`'s twist about its axis (the swing, which
    /// the hinge cannot follow, is dropped). Nothing for the root and welded bodies.
    pub fn set_local_rotation(&self, b: usize, q: Quat, dof: &mut [f64]) {
        let body = &self.bodies[b];
        let k = body.dofs.start;
        match &body.joint {
            JointDef::Ball { .. } => dof[k..k + 3].copy_from_slice(&q.to_rotvec()),
            JointDef::Hinges { hinges, .. } if hinges.len() == 3 => {
                let [a, b, c] = intrinsic_xyz(q);
                dof[k..k + 3].copy_from_slice(&[a, b, c]);
            }
            JointDef::Hinges { hinges, .. } => {
                let a = hinges[0].axis;
                let s = q.x * a[0] + q.y * a[1] + q.z * a[2];
                dof[k] = crate::math::wrap_angle(2.0 * s.atan2(q.w));
            }
            JointDef::Free | JointDef::Welded => {}
        }
    }

    /// World positions and orientations of every body frame for a root pose and a dof vector
    /// (bodies have no rest rotation): what MuJoCo's forward kinematics gives for the
    /// generated scene.
    pub fn forward_kinematics(
        &self,
        root_pos: [f64; 3],
        root_quat: Quat,
        dof: &[f64],
    ) -> (Vec<[f64; 3]>, Vec<Quat>) {
        let n = self.bodies.len();
        let (mut pos, mut rot) = (vec![root_pos; n], vec![root_quat; n]);
        for b in 1..n {
            let p = self.bodies[b].parent.expect("non-root bodies have a parent");
            pos[b] = crate::math::add(pos[p], rot[p].rotate(self.bodies[b].offset));
            rot[b] = rot[p].mul(self.local_rotation(b, dof));
        }
        (pos, rot)
    }

    /// Check the table: depth-first order, dof slots inside the vector and consistent with the
    /// joints, unique names. Every spec a character module builds passes (tested).
    pub fn check(&self) -> Result<(), String> {
        for (i, b) in self.bodies.iter().enumerate() {
            match (i, b.parent) {
                (0, None) => {}
                (0, Some(_)) => return Err(format!("body 0 ({}) is not the root", b.name)),
                (_, Some(p)) if p < i => {}
                _ => return Err(format!("body {i} ({}) has no parent before it", b.name)),
            }
            if b.dofs.end > self.num_dofs {
                return Err(format!(
                    "body {} has dof slots {:?} beyond {}",
                    b.name, b.dofs, self.num_dofs
                ));
            }
            let n = b.joint.dofs();
            if n > 0 && b.dofs.len() != n {
                return Err(format!(
                    "body {}: joint of {n} dofs in {} slots",
                    b.name,
                    b.dofs.len()
                ));
            }
            if self.bodies[..i].iter().any(|o| o.name == b.name) {
                return Err(format!("body name {} is used twice", b.name));
            }
        }
        Ok(())
    }
}

/// Intrinsic x-y-z angles (a, b, c) of `q` = R_x(a)·R_y(b)·R_z(c), b ∈ [−π/2, π/2].
pub fn intrinsic_xyz(q: Quat) -> [f64; 3] {
    // columns of the rotation matrix: R e_j
    let (ex, ey, ez) =
        (q.rotate([1.0, 0.0, 0.0]), q.rotate([0.0, 1.0, 0.0]), q.rotate([0.0, 0.0, 1.0]));
    // R = Rx(a)Ry(b)Rz(c): R02 = sin b, R12 = −sin a cos b, R22 = cos a cos b, R00 = cos b cos c,
    // R01 = −cos b sin c
    let b = ez[0].clamp(-1.0, 1.0).asin();
    let a = (-ez[1]).atan2(ez[2]);
    let c = (-ey[0]).atan2(ex[0]);
    [a, b, c]
}

/// Options of the SkillMimic humanoid's hands.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum HandModel {
    /// 15 articulated finger bodies per hand (156 actuated dofs).
    #[default]
    Full,
    /// Fingers welded to the wrist in the rest pose (66 actuated dofs, ≈45 % faster).
    Box,
}

impl HandModel {
    /// Short name used in file names and configs.
    pub fn name(self) -> &'static str {
        match self {
            HandModel::Full => "full",
            HandModel::Box => "boxhand",
        }
    }
}
