//! Batched state buffers read out after every step, and the state used to reset an environment.
//!
//! All arrays are `f64`, contiguous, environment-major (`[env][…]`). Rigid bodies are indexed
//! 0…52 for the humanoid (skeleton order) and 53 ([`BALL`](crate::scene::BALL)) for the ball.
//! Frames and units:
//! * positions: world frame, metres (body frame origin);
//! * rotations: world frame quaternions **(w, x, y, z)**;
//! * linear velocities: world frame, m/s, of the body's **centre of mass** (PhysX link semantics;
//!   for the pelvis and the ball the centre of mass is the frame origin);
//! * angular velocities: world frame, rad/s;
//! * joint positions: 52 × 3 rotation-vector (exp-map) components of each body relative to its
//!   parent, angle in (−π, π] (what the position actuators measure); joint velocities: 52 × 3
//!   local angular velocities (the ball joints' `qvel`); zero for welded fingers;
//! * contact forces: net force (N, world frame) that all contacts of the last physics sub-step
//!   exerted on each body;
//! * contact pairs: one 0/1 flag per [`ContactPair`](crate::contacts::ContactPair) kind.
//!
//! Timing: kinematic quantities describe the state *after* the step (forward kinematics and
//! velocities are recomputed); contacts and their forces are those solved in the last sub-step.

use skillmimic_core::math::Quat;
use skillmimic_core::skeleton::NUM_DOFS;

use crate::contacts::NUM_CONTACT_PAIRS;
use crate::scene::NUM_STATE_BODIES;

/// Full physical state used to (re)initialise one environment.
#[derive(Clone, Debug, PartialEq)]
pub struct ResetState {
    /// Root (pelvis) position, world (m).
    pub root_pos: [f64; 3],
    /// Root orientation, world, (w, x, y, z).
    pub root_quat: Quat,
    /// Root linear velocity, world (m/s).
    pub root_linvel: [f64; 3],
    /// Root angular velocity in the **root body frame** (rad/s) — MuJoCo's free-joint convention.
    pub root_angvel_local: [f64; 3],
    /// 52 × 3 joint rotation vectors (rad), skeleton order.
    pub dof_pos: [f64; NUM_DOFS],
    /// 52 × 3 joint local angular velocities (rad/s).
    pub dof_vel: [f64; NUM_DOFS],
    /// Ball centre, world (m).
    pub ball_pos: [f64; 3],
    /// Ball orientation (w, x, y, z).
    pub ball_quat: Quat,
    /// Ball linear velocity, world (m/s).
    pub ball_linvel: [f64; 3],
    /// Ball angular velocity in the ball frame (rad/s).
    pub ball_angvel_local: [f64; 3],
}

impl Default for ResetState {
    /// Upright zero pose (skeleton Y-up turned to Z-up), pelvis at 0.95 m, ball on the floor in
    /// front of the character, everything at rest.
    fn default() -> Self {
        Self {
            root_pos: [0.0, 0.0, 0.95],
            root_quat: Quat::from_rotvec([std::f64::consts::FRAC_PI_2, 0.0, 0.0]),
            root_linvel: [0.0; 3],
            root_angvel_local: [0.0; 3],
            dof_pos: [0.0; NUM_DOFS],
            dof_vel: [0.0; NUM_DOFS],
            ball_pos: [0.0, 0.6, 0.12],
            ball_quat: Quat::IDENTITY,
            ball_linvel: [0.0; 3],
            ball_angvel_local: [0.0; 3],
        }
    }
}

/// Widths of one environment's rows in each buffer.
pub mod width {
    use super::*;
    pub const BODY_POS: usize = NUM_STATE_BODIES * 3;
    pub const BODY_QUAT: usize = NUM_STATE_BODIES * 4;
    pub const BODY_VEL: usize = NUM_STATE_BODIES * 3;
    pub const DOF: usize = NUM_DOFS;
    pub const CONTACT_FORCE: usize = NUM_STATE_BODIES * 3;
    pub const CONTACT_PAIRS: usize = NUM_CONTACT_PAIRS;
}

/// Batched read-out buffers (see the module docs for frames and units).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BatchState {
    pub num_envs: usize,
    /// `[N][54][3]`
    pub body_pos: Vec<f64>,
    /// `[N][54][4]` (w, x, y, z)
    pub body_quat: Vec<f64>,
    /// `[N][54][3]`
    pub body_linvel: Vec<f64>,
    /// `[N][54][3]`
    pub body_angvel: Vec<f64>,
    /// `[N][156]`
    pub dof_pos: Vec<f64>,
    /// `[N][156]`
    pub dof_vel: Vec<f64>,
    /// `[N][54][3]`
    pub contact_force: Vec<f64>,
    /// `[N][7]`
    pub contact_pairs: Vec<u8>,
    /// `[N]`: 1 if MuJoCo reported a numerical instability (a non-finite or huge `qpos`, `qvel`
    /// or `qacc`) during the last step or reset (MuJoCo then resets that environment's data to
    /// the model default pose).
    pub unstable: Vec<u8>,
}

impl BatchState {
    /// Zeroed buffers for `n` environments.
    pub fn new(n: usize) -> Self {
        Self {
            num_envs: n,
            body_pos: vec![0.0; n * width::BODY_POS],
            body_quat: vec![0.0; n * width::BODY_QUAT],
            body_linvel: vec![0.0; n * width::BODY_VEL],
            body_angvel: vec![0.0; n * width::BODY_VEL],
            dof_pos: vec![0.0; n * width::DOF],
            dof_vel: vec![0.0; n * width::DOF],
            contact_force: vec![0.0; n * width::CONTACT_FORCE],
            contact_pairs: vec![0; n * width::CONTACT_PAIRS],
            unstable: vec![0; n],
        }
    }

    /// Read-only view of environment `i`.
    pub fn env(&self, i: usize) -> EnvState<'_> {
        EnvState {
            body_pos: &self.body_pos[i * width::BODY_POS..(i + 1) * width::BODY_POS],
            body_quat: &self.body_quat[i * width::BODY_QUAT..(i + 1) * width::BODY_QUAT],
            body_linvel: &self.body_linvel[i * width::BODY_VEL..(i + 1) * width::BODY_VEL],
            body_angvel: &self.body_angvel[i * width::BODY_VEL..(i + 1) * width::BODY_VEL],
            dof_pos: &self.dof_pos[i * width::DOF..(i + 1) * width::DOF],
            dof_vel: &self.dof_vel[i * width::DOF..(i + 1) * width::DOF],
            contact_force: &self.contact_force
                [i * width::CONTACT_FORCE..(i + 1) * width::CONTACT_FORCE],
            contact_pairs: &self.contact_pairs
                [i * width::CONTACT_PAIRS..(i + 1) * width::CONTACT_PAIRS],
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
    pub contact_force: &'a [f64],
    pub contact_pairs: &'a [u8],
    pub unstable: bool,
}

impl EnvState<'_> {
    /// Position of body `b` (0…53).
    #[inline]
    pub fn pos(&self, b: usize) -> [f64; 3] {
        [self.body_pos[3 * b], self.body_pos[3 * b + 1], self.body_pos[3 * b + 2]]
    }
    /// Orientation of body `b`.
    #[inline]
    pub fn quat(&self, b: usize) -> Quat {
        Quat::from_wxyz([
            self.body_quat[4 * b],
            self.body_quat[4 * b + 1],
            self.body_quat[4 * b + 2],
            self.body_quat[4 * b + 3],
        ])
    }
    /// Linear velocity of body `b`.
    #[inline]
    pub fn linvel(&self, b: usize) -> [f64; 3] {
        [self.body_linvel[3 * b], self.body_linvel[3 * b + 1], self.body_linvel[3 * b + 2]]
    }
    /// Angular velocity of body `b`.
    #[inline]
    pub fn angvel(&self, b: usize) -> [f64; 3] {
        [self.body_angvel[3 * b], self.body_angvel[3 * b + 1], self.body_angvel[3 * b + 2]]
    }
    /// Net contact force on body `b`.
    #[inline]
    pub fn contact_force(&self, b: usize) -> [f64; 3] {
        [self.contact_force[3 * b], self.contact_force[3 * b + 1], self.contact_force[3 * b + 2]]
    }
    /// Whether a contact of `kind` exists.
    #[inline]
    pub fn has_contact(&self, kind: crate::contacts::ContactPair) -> bool {
        self.contact_pairs[kind as usize] != 0
    }
}
