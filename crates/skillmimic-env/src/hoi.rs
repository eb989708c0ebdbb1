//! Human–object-interaction (HOI) state of one frame, simulated or reference (reference-facts
//! §4.3), and the contact-graph states compared by the reward.
//!
//! All quantities are world frame, metres, radians, seconds. Simulated and reference states use
//! the same fields; the reference comes from the clip (stored key-body positions, finite-
//! difference velocities), the simulated one from the state read-out after the step.

use skillmimic_core::characters::skillmimic::{KEY_BODIES, NUM_DOFS, REFERENCE_BODY_NODE};
use skillmimic_core::math::{Quat, norm};
use skillmimic_motion::reference::vec3_at;
use skillmimic_motion::{MotionClip, NUM_KEY};
use skillmimic_sim::{BALL, ContactPair, EnvState};

use crate::config::ContactGraphMode;

/// HOI state of one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct HoiState {
    pub root_pos: [f64; 3],
    /// Root exp map, angle in (−π, π].
    pub root_rotvec: [f64; 3],
    /// 156 joint exp-map components.
    pub dof_pos: [f64; NUM_DOFS],
    /// 156 joint velocities (simulated: local angular velocity; reference: exp-map difference).
    pub dof_vel: [f64; NUM_DOFS],
    pub ball_pos: [f64; 3],
    pub ball_quat: Quat,
    pub ball_linvel: [f64; 3],
    /// Ball angular velocity, world frame.
    pub ball_angvel: [f64; 3],
    /// Positions of the 17 key bodies.
    pub key_pos: [[f64; 3]; NUM_KEY],
    /// Linear velocities of the 17 key bodies.
    pub key_vel: [[f64; 3]; NUM_KEY],
}

impl HoiState {
    /// The simulated state from the batch read-out.
    pub fn from_sim(st: &EnvState<'_>) -> Self {
        let mut dof_pos = [0.0; NUM_DOFS];
        let mut dof_vel = [0.0; NUM_DOFS];
        dof_pos.copy_from_slice(st.dof_pos);
        dof_vel.copy_from_slice(st.dof_vel);
        Self {
            root_pos: st.pos(0),
            root_rotvec: st.quat(0).normalized().to_rotvec(),
            dof_pos,
            dof_vel,
            ball_pos: st.pos(BALL),
            ball_quat: st.quat(BALL),
            ball_linvel: st.linvel(BALL),
            ball_angvel: st.angvel(BALL),
            key_pos: std::array::from_fn(|k| st.pos(KEY_BODIES[k])),
            key_vel: std::array::from_fn(|k| st.linvel(KEY_BODIES[k])),
        }
    }

    /// The reference state of frame `t` of a clip.
    pub fn from_reference(m: &MotionClip, t: usize) -> Self {
        let (c, r) = (&m.clip, &m.reference);
        let dof = c.dof_at(t);
        let ball_quat = c.ball_quat_at(t);
        let key = |a: &[f32], k: usize| vec3_at(a, t * NUM_KEY + k);
        Self {
            root_pos: c.root_pos_at(t),
            root_rotvec: vec3_at(&r.root_rotvec, t),
            dof_pos: std::array::from_fn(|j| dof[j] as f64),
            dof_vel: std::array::from_fn(|j| r.dof_vel[t * NUM_DOFS + j] as f64),
            ball_pos: c.ball_pos_at(t),
            ball_quat,
            ball_linvel: vec3_at(&r.ball_linvel, t),
            ball_angvel: ball_quat.rotate(vec3_at(&r.ball_angvel_local, t)),
            key_pos: std::array::from_fn(|k| key(&r.key_pos, k)),
            key_vel: std::array::from_fn(|k| key(&r.key_vel, k)),
        }
    }

    /// The 380-wide HOI vector of the reference layout: root pos (3), root exp map (3), dofs (156),
    /// dof velocities (156), ball pos (3), ball quaternion **(x, y, z, w)** (4), ball velocity (3),
    /// key-body positions (51), contact (1).
    pub fn to_vec380(&self, contact: f64, out: &mut [f64]) {
        let mut i = 0;
        let mut put = |v: &[f64]| {
            out[i..i + v.len()].copy_from_slice(v);
            i += v.len();
        };
        put(&self.root_pos);
        put(&self.root_rotvec);
        put(&self.dof_pos);
        put(&self.dof_vel);
        put(&self.ball_pos);
        put(&self.ball_quat.to_xyzw());
        put(&self.ball_linvel);
        for k in &self.key_pos {
            put(k);
        }
        put(&[contact]);
        debug_assert_eq!(i, HOI_DIM);
    }
}

/// Width of the HOI vector.
pub const HOI_DIM: usize = 380;

/// Maximum number of contact-graph entries.
pub const MAX_CG: usize = 4;

/// Contact-graph state: 0/1 per edge (exact mode) or per node (force-threshold mode).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactGraph {
    pub values: [f64; MAX_CG],
    pub len: usize,
}

/// Entry names of each mode, in order.
pub fn cg_names(mode: ContactGraphMode) -> &'static [&'static str] {
    match mode {
        ContactGraphMode::Exact => &["hand_ball", "body_ball", "hand_body", "body_floor"],
        ContactGraphMode::ForceThreshold => &["ball_node", "body_node"],
    }
}

impl ContactGraph {
    /// Simulated contact graph of the last step.
    pub fn from_sim(st: &EnvState<'_>, mode: ContactGraphMode, force_threshold: f64) -> Self {
        let f = |c: bool| if c { 1.0 } else { 0.0 };
        match mode {
            ContactGraphMode::Exact => Self {
                values: [
                    f(st.has_contact(ContactPair::HandBall)),
                    f(st.has_contact(ContactPair::BodyBall)),
                    f(st.has_contact(ContactPair::HandBody)),
                    f(st.has_contact(ContactPair::BodyFloor)),
                ],
                len: 4,
            },
            ContactGraphMode::ForceThreshold => {
                let fb = st.contact_force(BALL);
                let ball = fb[0].abs() > force_threshold || fb[1].abs() > force_threshold;
                let body = REFERENCE_BODY_NODE
                    .iter()
                    .any(|&b| st.contact_force(b).iter().any(|c| c.abs() >= force_threshold));
                Self { values: [f(ball), f(body), 0.0, 0.0], len: 2 }
            }
        }
    }

    /// Reference contact graph: the hand–ball (ball-node) entry is the clip label, all others 0.
    pub fn reference(label: f64, mode: ContactGraphMode) -> Self {
        match mode {
            ContactGraphMode::Exact => Self { values: [label, 0.0, 0.0, 0.0], len: 4 },
            ContactGraphMode::ForceThreshold => Self { values: [label, 0.0, 0.0, 0.0], len: 2 },
        }
    }

    /// Mean squared difference to another graph (E_cg of one frame).
    pub fn sq_error(&self, other: &ContactGraph) -> f64 {
        (0..self.len).map(|i| (self.values[i] - other.values[i]).powi(2)).sum::<f64>()
            / self.len as f64
    }

    /// True when every entry matches.
    pub fn matches(&self, other: &ContactGraph) -> bool {
        (0..self.len).all(|i| self.values[i] == other.values[i])
    }
}

/// Euclidean distance between two points.
#[inline]
pub fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    norm([a[0] - b[0], a[1] - b[1], a[2] - b[2]])
}

/// A rigid ground-plane transform applied to a reference trajectory (used when a reference is
/// re-anchored at another root, e.g. SkillMimic-V2 skill switching): positions
/// p' = R_z(yaw)·(p − pivot) + target with heights kept, orientations q' = R_z(yaw)·q,
/// velocities rotated. Joint rotations are local and unchanged.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RefAlign {
    pub yaw: f64,
    pub pivot: [f64; 2],
    pub target: [f64; 2],
}

impl RefAlign {
    /// The identity transform.
    pub const IDENTITY: RefAlign = RefAlign { yaw: 0.0, pivot: [0.0; 2], target: [0.0; 2] };

    /// True for the identity.
    pub fn is_identity(&self) -> bool {
        *self == Self::IDENTITY
    }

    /// Transform a point.
    pub fn point(&self, p: [f64; 3]) -> [f64; 3] {
        let (s, c) = self.yaw.sin_cos();
        let (x, y) = (p[0] - self.pivot[0], p[1] - self.pivot[1]);
        [c * x - s * y + self.target[0], s * x + c * y + self.target[1], p[2]]
    }

    /// Rotate a vector.
    pub fn vector(&self, v: [f64; 3]) -> [f64; 3] {
        Quat::about_z(self.yaw).rotate(v)
    }
}

impl HoiState {
    /// This reference state under a ground-plane transform.
    pub fn aligned(&self, a: &RefAlign) -> HoiState {
        if a.is_identity() {
            return self.clone();
        }
        let rz = Quat::about_z(a.yaw);
        let mut out = self.clone();
        out.root_pos = a.point(self.root_pos);
        out.root_rotvec = rz.mul(Quat::from_rotvec(self.root_rotvec)).to_rotvec();
        out.ball_pos = a.point(self.ball_pos);
        out.ball_quat = rz.mul(self.ball_quat);
        out.ball_linvel = a.vector(self.ball_linvel);
        out.ball_angvel = a.vector(self.ball_angvel);
        for k in 0..NUM_KEY {
            out.key_pos[k] = a.point(self.key_pos[k]);
            out.key_vel[k] = a.vector(self.key_vel[k]);
        }
        out
    }
}
