//! The per-environment state read-out of a batch (`f64`, environment-major) and the state a reset
//! writes.
//!
//! State bodies are the character's bodies followed by the scene's objects ([`crate::scene`]):
//! * positions: world frame, m, of each body frame's origin;
//! * rotations: world frame, quaternion **w, x, y, z**;
//! * linear velocities: world frame, m/s, of the body's **centre of mass** (PhysX link
//!   semantics; for the SkillMimic pelvis and the ball the centre of mass is the frame origin);
//! * angular velocities: world frame, rad/s;
//! * joint positions: the character's dof vector — a ball joint's three rotation-vector
//!   (exp-map) components of the body relative to its parent, angle in (−π, π]; a hinge's angle;
//!   joint velocities: a ball joint's local angular velocity, a hinge's rate (rad/s); zero in the
//!   slots of welded bodies;
//! * dof forces: the PD drive's generalized force per dof (N·m): the position actuator's force of
//!   the last physics step plus the joint damping's at the read-out velocity;
//! * contact forces: net force (N, world frame) that all contacts of the last physics sub-step
//!   exerted on each state body;
//! * contact pairs: one 0/1 flag per [`ContactPair`](crate::contacts::ContactPair) kind;
//! * touch: per character body, 1 if it touched anything that is not the character (the floor,
//!   a prop, the ball, an object) in the last physics sub-step.
//!
//! Timing: kinematic quantities describe the state *after* the step (forward kinematics and
//! velocities are recomputed); contacts and their forces are those solved in the last sub-step.

use skillmimic_core::characters::skillmimic::NUM_DOFS;
use skillmimic_core::math::Quat;

use crate::contacts::NUM_CONTACT_PAIRS;
use crate::scene::Scene;

/// Pose and velocity of one object (world frame; angular velocity in the object frame, MuJoCo's
/// free-joint convention; only the pose applies to a static object).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ObjectState {
    pub pos: [f64; 3],
    pub quat: Quat,
    pub linvel: [f64; 3],
    pub angvel_local: [f64; 3],
}

impl Default for ObjectState {
    /// Parked below the floor, out of the way.
    fn default() -> Self {
        Self {
            pos: [0.0, 0.0, -10.0],
            quat: Quat::IDENTITY,
            linvel: [0.0; 3],
            angvel_local: [0.0; 3],
        }
    }
}

/// Full physical state used to (re)initialise one environment.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ResetState {
    /// Root position, world (m).
    pub root_pos: [f64; 3],
    /// Root orientation, world.
    pub root_quat: Quat,
    /// Root linear velocity, world (m/s).
    pub root_linvel: [f64; 3],
    /// Root angular velocity in the **root body frame** (rad/s) — MuJoCo's free-joint convention.
    pub root_angvel_local: [f64; 3],
    /// The character's dof vector (see the module doc; rad).
    pub dof_pos: Vec<f64>,
    /// Its velocities (rad/s).
    pub dof_vel: Vec<f64>,
    /// The objects in state-body order (the ball first where there is one).
    pub objects: Vec<ObjectState>,
}

impl ResetState {
    /// The scene's rest state: the character's MJCF rest pose (every joint at 0) at rest, the
    /// ball (if any) on the floor in front of it, the other objects parked.
    pub fn rest(scene: &Scene) -> Self {
        let mut s = Self::of(scene.character(), scene.objects.len());
        if let Some(b) = scene.options().ball {
            s.objects[0] = ObjectState { pos: [0.0, 0.6, b.radius], ..ObjectState::default() };
        }
        s
    }

    /// The rest pose of `character` at rest, with `objects` parked objects.
    pub fn of(character: &skillmimic_core::characters::CharacterSpec, objects: usize) -> Self {
        Self {
            root_pos: character.root_pos,
            root_quat: character.root_quat,
            root_linvel: [0.0; 3],
            root_angvel_local: [0.0; 3],
            dof_pos: vec![0.0; character.num_dofs],
            dof_vel: vec![0.0; character.num_dofs],
            objects: vec![ObjectState::default(); objects],
        }
    }

    /// Back to the state `rest` describes without reallocating: the root at `root_pos` /
    /// `root_quat`, joints and velocities zero; the objects keep their count and are parked.
    pub fn clear(&mut self, root_pos: [f64; 3], root_quat: Quat) {
        self.root_pos = root_pos;
        self.root_quat = root_quat;
        self.root_linvel = [0.0; 3];
        self.root_angvel_local = [0.0; 3];
        self.dof_pos.fill(0.0);
        self.dof_vel.fill(0.0);
        self.objects.fill(ObjectState::default());
    }

    /// The ball (object 0 of a scene with a ball).
    pub fn ball(&self) -> &ObjectState {
        &self.objects[0]
    }
    /// The ball, mutably.
    pub fn ball_mut(&mut self) -> &mut ObjectState {
        &mut self.objects[0]
    }
}

impl Default for ResetState {
    /// The SkillMimic scene's rest state: upright zero pose (skeleton Y-up turned to Z-up),
    /// pelvis at 0.95 m, the ball on the floor in front of the character, everything at rest.
    fn default() -> Self {
        Self {
            root_pos: [0.0, 0.0, 0.95],
            root_quat: skillmimic_core::characters::skillmimic::upright(),
            root_linvel: [0.0; 3],
            root_angvel_local: [0.0; 3],
            dof_pos: vec![0.0; NUM_DOFS],
            dof_vel: vec![0.0; NUM_DOFS],
            objects: vec![ObjectState { pos: [0.0, 0.6, 0.12], ..ObjectState::default() }],
        }
    }
}

/// Batched read-out buffers (see the module docs for frames and units).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BatchState {
    pub num_envs: usize,
    /// State bodies per environment (character bodies, then objects).
    pub bodies: usize,
    /// Character bodies per environment.
    pub character_bodies: usize,
    /// Dof slots per environment.
    pub dofs: usize,
    /// `[N][bodies][3]`
    pub body_pos: Vec<f64>,
    /// `[N][bodies][4]` (w, x, y, z)
    pub body_quat: Vec<f64>,
    /// `[N][bodies][3]`
    pub body_linvel: Vec<f64>,
    /// `[N][bodies][3]`
    pub body_angvel: Vec<f64>,
    /// `[N][dofs]`
    pub dof_pos: Vec<f64>,
    /// `[N][dofs]`
    pub dof_vel: Vec<f64>,
    /// `[N][dofs]`: the PD drive's generalized force on each dof (N·m): the position actuator's
    /// force over the last physics step plus the joint damping's at the read-out velocity
    /// (`qfrc_actuator + qfrc_damper`), what Isaac Gym's dof-force tensor reports for a PD drive.
    pub dof_force: Vec<f64>,
    /// `[N][bodies][3]`
    pub contact_force: Vec<f64>,
    /// `[N][7]`
    pub contact_pairs: Vec<u8>,
    /// `[N][character bodies]`
    pub touch: Vec<u8>,
    /// `[N]`: 1 if MuJoCo reported a numerical instability (a non-finite or huge `qpos`, `qvel`
    /// or `qacc`) during the last step or reset (MuJoCo then resets that environment's data to
    /// the model default pose).
    pub unstable: Vec<u8>,
}

impl BatchState {
    /// Zeroed buffers for `n` environments of `scene`.
    pub fn new(n: usize, scene: &Scene) -> Self {
        let (b, c, d) = (scene.num_state_bodies(), scene.num_character_bodies(), scene.num_dofs());
        Self {
            num_envs: n,
            bodies: b,
            character_bodies: c,
            dofs: d,
            body_pos: vec![0.0; n * b * 3],
            body_quat: vec![0.0; n * b * 4],
            body_linvel: vec![0.0; n * b * 3],
            body_angvel: vec![0.0; n * b * 3],
            dof_pos: vec![0.0; n * d],
            dof_vel: vec![0.0; n * d],
            dof_force: vec![0.0; n * d],
            contact_force: vec![0.0; n * b * 3],
            contact_pairs: vec![0; n * NUM_CONTACT_PAIRS],
            touch: vec![0; n * c],
            unstable: vec![0; n],
        }
    }

    /// Read-only view of environment `i`.
    pub fn env(&self, i: usize) -> EnvState<'_> {
        let (b3, b4, d, c, p) =
            (3 * self.bodies, 4 * self.bodies, self.dofs, self.character_bodies, NUM_CONTACT_PAIRS);
        EnvState {
            body_pos: &self.body_pos[i * b3..(i + 1) * b3],
            body_quat: &self.body_quat[i * b4..(i + 1) * b4],
            body_linvel: &self.body_linvel[i * b3..(i + 1) * b3],
            body_angvel: &self.body_angvel[i * b3..(i + 1) * b3],
            dof_pos: &self.dof_pos[i * d..(i + 1) * d],
            dof_vel: &self.dof_vel[i * d..(i + 1) * d],
            dof_force: &self.dof_force[i * d..(i + 1) * d],
            contact_force: &self.contact_force[i * b3..(i + 1) * b3],
            contact_pairs: &self.contact_pairs[i * p..(i + 1) * p],
            touch: &self.touch[i * c..(i + 1) * c],
            unstable: self.unstable[i] != 0,
        }
    }
}

/// Read-only view of one environment's state.
#[derive(Clone, Copy, Debug)]
pub struct EnvState<'a> {
    pub body_pos: &'a [f64],
    pub body_quat: &'a [f64],
    pub body_linvel: &'a [f64],
    pub body_angvel: &'a [f64],
    pub dof_pos: &'a [f64],
    pub dof_vel: &'a [f64],
    /// The PD drive's force per dof (N·m; see [`BatchState::dof_force`]).
    pub dof_force: &'a [f64],
    pub contact_force: &'a [f64],
    pub contact_pairs: &'a [u8],
    pub touch: &'a [u8],
    pub unstable: bool,
}

impl EnvState<'_> {
    /// Mechanical power of the joint drives, Σ_k |τ_k · q̇_k| (W) over the character's dofs: the
    /// read-out's drive forces ([`EnvState::dof_force`]) times the joint rates — what the power
    /// penalties of ModSkill/PHC and TokenHSI integrate (Isaac Gym's `dof_force_tensor`).
    pub fn drive_power(&self) -> f64 {
        self.dof_force.iter().zip(self.dof_vel).map(|(t, v)| (t * v).abs()).sum()
    }

    /// Position of state body `b`.
    #[inline]
    pub fn pos(&self, b: usize) -> [f64; 3] {
        [self.body_pos[3 * b], self.body_pos[3 * b + 1], self.body_pos[3 * b + 2]]
    }
    /// Orientation of state body `b`.
    #[inline]
    pub fn quat(&self, b: usize) -> Quat {
        Quat::from_wxyz([
            self.body_quat[4 * b],
            self.body_quat[4 * b + 1],
            self.body_quat[4 * b + 2],
            self.body_quat[4 * b + 3],
        ])
    }
    /// Linear velocity of state body `b`.
    #[inline]
    pub fn linvel(&self, b: usize) -> [f64; 3] {
        [self.body_linvel[3 * b], self.body_linvel[3 * b + 1], self.body_linvel[3 * b + 2]]
    }
    /// Angular velocity of state body `b`.
    #[inline]
    pub fn angvel(&self, b: usize) -> [f64; 3] {
        [self.body_angvel[3 * b], self.body_angvel[3 * b + 1], self.body_angvel[3 * b + 2]]
    }
    /// Net contact force on state body `b`.
    #[inline]
    pub fn contact_force(&self, b: usize) -> [f64; 3] {
        [self.contact_force[3 * b], self.contact_force[3 * b + 1], self.contact_force[3 * b + 2]]
    }
    /// Whether a contact of `kind` exists.
    #[inline]
    pub fn has_contact(&self, kind: crate::contacts::ContactPair) -> bool {
        self.contact_pairs[kind as usize] != 0
    }
    /// Whether character body `b` touched something that is not the character.
    #[inline]
    pub fn touches(&self, b: usize) -> bool {
        self.touch[b] != 0
    }
}
