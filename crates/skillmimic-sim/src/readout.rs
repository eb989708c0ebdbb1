//! Reading one environment's state out of its `MjData` into its rows of the batch's output
//! buffers (`crate::state::BatchState`): body poses and velocities (world frame, metres,
//! wxyz quaternions), joint positions as rotation vectors (radians), joint velocities and forces,
//! contact pairs and per-body net contact forces (world frame, newtons). No allocation.

use std::sync::Arc;

use mujoco_rs::prelude::*;
use skillmimic_core::math::Quat;

use crate::contacts::ContactPair;
use crate::scene::{GeomOwner, Scene};

type Data = MjData<Arc<MjModel>>;

/// Mutable rows of one environment in every output buffer.
pub(crate) struct Rows<'a> {
    pub(crate) body_pos: &'a mut [f64],
    pub(crate) body_quat: &'a mut [f64],
    pub(crate) body_linvel: &'a mut [f64],
    pub(crate) body_angvel: &'a mut [f64],
    pub(crate) dof_pos: &'a mut [f64],
    pub(crate) dof_vel: &'a mut [f64],
    pub(crate) dof_force: &'a mut [f64],
    pub(crate) contact_force: &'a mut [f64],
    pub(crate) contact_pairs: &'a mut [u8],
    pub(crate) touch: &'a mut [u8],
    pub(crate) unstable: &'a mut u8,
}

/// Copy one environment's kinematic state into its buffer rows (no allocation). Requires the
/// position and velocity stages of the current `qpos`/`qvel` (mj_step1 or mj_forward).
pub(crate) fn read_kinematics(scene: &Scene, d: &Data, rows: &mut Rows<'_>) {
    let (xpos, xquat, xipos) = (d.xpos(), d.xquat(), d.xipos());
    let (cvel, subtree_com) = (d.cvel(), d.subtree_com());
    for (b, &id) in scene.body_ids.iter().enumerate() {
        rows.body_pos[3 * b..3 * b + 3].copy_from_slice(&xpos[id]);
        rows.body_quat[4 * b..4 * b + 4].copy_from_slice(&xquat[id]);
        // cvel = [ω; v] of the body, linear part at its tree's subtree centre of mass c, world
        // orientation. Velocity of the body's own centre of mass: v + ω × (xipos − c) (what
        // mj_objectVelocity(mjOBJ_BODY, world orientation) computes, without the 6×6 transform).
        let (w, v) = (&cvel[id][..3], &cvel[id][3..]);
        let c = subtree_com[scene.tree_root[b]];
        let r = [xipos[id][0] - c[0], xipos[id][1] - c[1], xipos[id][2] - c[2]];
        let lin = [
            v[0] + w[1] * r[2] - w[2] * r[1],
            v[1] + w[2] * r[0] - w[0] * r[2],
            v[2] + w[0] * r[1] - w[1] * r[0],
        ];
        rows.body_angvel[3 * b..3 * b + 3].copy_from_slice(w);
        rows.body_linvel[3 * b..3 * b + 3].copy_from_slice(&lin);
    }
    let (qpos, qvel) = (d.qpos(), d.qvel());
    let (actuator, damper) = (d.qfrc_actuator(), d.qfrc_damper());
    for j in &scene.joints {
        let k = j.dof;
        let n = if j.ball { 3 } else { 1 };
        if j.ball {
            let a = j.qpos;
            let q = Quat::from_wxyz([qpos[a], qpos[a + 1], qpos[a + 2], qpos[a + 3]]).normalized();
            rows.dof_pos[k..k + 3].copy_from_slice(&q.to_rotvec());
        } else {
            rows.dof_pos[k] = qpos[j.qpos];
        }
        rows.dof_vel[k..k + n].copy_from_slice(&qvel[j.qvel..j.qvel + n]);
        for a in 0..n {
            rows.dof_force[k + a] = actuator[j.qvel + a] + damper[j.qvel + a];
        }
    }
}

/// Classify the active contacts, flag the character bodies that touch something else and
/// accumulate per-body net contact forces (world frame) from the last constraint solve (no
/// allocation).
pub(crate) fn read_contacts(scene: &Scene, d: &Data, rows: &mut Rows<'_>) {
    rows.contact_force.fill(0.0);
    rows.contact_pairs.fill(0);
    rows.touch.fill(0);
    for (c, con) in d.contact().iter().enumerate() {
        if con.efc_address < 0 {
            continue; // excluded or inactive: no constraint force
        }
        let (g1, g2) = (con.geom[0], con.geom[1]);
        if g1 < 0 || g2 < 0 {
            continue; // flex contacts (none in these scenes)
        }
        let (o1, o2) = (scene.geom_owner[g1 as usize], scene.geom_owner[g2 as usize]);
        if let Some(kind) = ContactPair::classify(o1, o2, &scene.body_part) {
            rows.contact_pairs[kind as usize] = 1;
        }
        match (o1, o2) {
            (GeomOwner::Body(_), GeomOwner::Body(_)) => {}
            (GeomOwner::Body(x), _) | (_, GeomOwner::Body(x)) => rows.touch[x] = 1,
            _ => {}
        }
        // force of geom1 on geom2, contact frame -> world (frame rows: normal, tangent, tangent)
        let f = d.contact_force(c);
        let fr = &con.frame;
        let w = [
            f[0] * fr[0] + f[1] * fr[3] + f[2] * fr[6],
            f[0] * fr[1] + f[1] * fr[4] + f[2] * fr[7],
            f[0] * fr[2] + f[1] * fr[5] + f[2] * fr[8],
        ];
        for (owner, sign) in [(o2, 1.0), (o1, -1.0)] {
            let b = match owner {
                GeomOwner::Body(b) => b,
                GeomOwner::Ball => scene.num_character_bodies(),
                GeomOwner::Object(k) => scene.object_body(k),
                GeomOwner::Floor => continue,
            };
            for k in 0..3 {
                rows.contact_force[3 * b + k] += sign * w[k];
            }
        }
    }
}
