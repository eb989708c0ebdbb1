//! N TokenHSI environments stepped in parallel (the character's counterpart of
//! [`BatchSim`](crate::BatchSim)).
//!
//! Each environment uses one of a few compiled scene variants (the same objects with different
//! sampled sizes), owns its `MjData` and is stepped on a rayon pool of a fixed size, so results
//! are bit-identical for any thread count. One [`HsiBatch::step`] maps the `N × 32` actions to PD
//! targets (`ctrl = offset + scale · clamp(a, −1, 1)`, [`action_offset_scale`]), runs
//! [`HSI_SUBSTEPS`](crate::hsi_mjcf::HSI_SUBSTEPS) physics steps and reads the state out.
//!
//! Read-out (`f64`, environment-major; bodies 0…14 the character, then the scene's objects):
//! positions (world, m, body frame origin), rotations (world, **w x y z**), linear velocities of
//! each body's centre of mass (world, m/s), angular velocities (world, rad/s), the 32 joint
//! coordinates (rotation-vector components of the 3-DoF joints, hinge angles; rad) and their
//! velocities (local angular velocity, rad/s), and per character body a flag "touches something
//! that is not the character" (floor or object) in the last physics step.
//!
//! [`action_offset_scale`]: skillmimic_core::hsi_character::action_offset_scale

use std::sync::Arc;

use mujoco_rs::prelude::*;
use rayon::prelude::*;
use skillmimic_core::hsi_character::{NUM_BODIES, NUM_DOFS, STANDING_ROOT_HEIGHT};
use skillmimic_core::math::Quat;

use crate::batch::{bad_state, clear_bad_state};
use crate::error::SimError;
use crate::hsi_mjcf::HSI_SUBSTEPS;
use crate::hsi_scene::{HsiScene, MAX_OBJECTS, ObjectAddr};

type Data = MjData<Arc<MjModel>>;

/// Pose and velocity of one object (world frame; angular velocity in the object frame, MuJoCo's
/// free-joint convention; ignored for static objects).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectState {
    pub pos: [f64; 3],
    pub quat: Quat,
    pub linvel: [f64; 3],
    pub angvel_local: [f64; 3],
}

impl Default for ObjectState {
    fn default() -> Self {
        Self {
            pos: [0.0, 0.0, -10.0],
            quat: Quat::IDENTITY,
            linvel: [0.0; 3],
            angvel_local: [0.0; 3],
        }
    }
}

/// Full state to (re)initialise one TokenHSI environment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HsiReset {
    /// Pelvis position, world (m).
    pub root_pos: [f64; 3],
    /// Pelvis orientation, world.
    pub root_quat: Quat,
    /// Pelvis linear velocity, world (m/s).
    pub root_linvel: [f64; 3],
    /// Pelvis angular velocity in the pelvis frame (rad/s).
    pub root_angvel_local: [f64; 3],
    /// The 32 joint coordinates (rad): rotation vectors of the 3-DoF joints, hinge angles.
    pub dof_pos: [f64; NUM_DOFS],
    /// Their velocities (rad/s).
    pub dof_vel: [f64; NUM_DOFS],
    /// Object states, in the scene's object order (extra entries ignored).
    pub objects: [ObjectState; MAX_OBJECTS],
}

impl Default for HsiReset {
    /// Rest pose standing at the origin facing +x, at rest.
    fn default() -> Self {
        Self {
            root_pos: [0.0, 0.0, STANDING_ROOT_HEIGHT],
            root_quat: Quat::IDENTITY,
            root_linvel: [0.0; 3],
            root_angvel_local: [0.0; 3],
            dof_pos: [0.0; NUM_DOFS],
            dof_vel: [0.0; NUM_DOFS],
            objects: [ObjectState::default(); MAX_OBJECTS],
        }
    }
}

/// Read-out buffers of all environments.
#[derive(Clone, Debug, Default)]
pub struct HsiState {
    /// Bodies per environment: 15 + objects.
    pub bodies: usize,
    /// `[N][bodies][3]`
    pub body_pos: Vec<f64>,
    /// `[N][bodies][4]` (w, x, y, z)
    pub body_quat: Vec<f64>,
    /// `[N][bodies][3]`
    pub body_linvel: Vec<f64>,
    /// `[N][bodies][3]`
    pub body_angvel: Vec<f64>,
    /// `[N][32]`
    pub dof_pos: Vec<f64>,
    /// `[N][32]`
    pub dof_vel: Vec<f64>,
    /// `[N][15]`: 1 if the body touched the floor or an object in the last physics step.
    pub contact: Vec<u8>,
    /// `[N]`: 1 if MuJoCo reported an instability (bad `qpos`/`qvel`/`qacc`) in the last step or
    /// reset.
    pub unstable: Vec<u8>,
}

/// Read-only view of one environment's state.
#[derive(Clone, Copy, Debug)]
pub struct HsiEnvState<'a> {
    pub body_pos: &'a [f64],
    pub body_quat: &'a [f64],
    pub body_linvel: &'a [f64],
    pub body_angvel: &'a [f64],
    pub dof_pos: &'a [f64],
    pub dof_vel: &'a [f64],
    pub contact: &'a [u8],
    pub unstable: bool,
}

impl HsiEnvState<'_> {
    /// Position of body `b` (world, m).
    #[inline]
    pub fn pos(&self, b: usize) -> [f64; 3] {
        [self.body_pos[3 * b], self.body_pos[3 * b + 1], self.body_pos[3 * b + 2]]
    }
    /// Orientation of body `b`.
    #[inline]
    pub fn quat(&self, b: usize) -> Quat {
        let q = &self.body_quat[4 * b..4 * b + 4];
        Quat::from_wxyz([q[0], q[1], q[2], q[3]])
    }
    /// Linear velocity of body `b`'s centre of mass (world, m/s).
    #[inline]
    pub fn linvel(&self, b: usize) -> [f64; 3] {
        [self.body_linvel[3 * b], self.body_linvel[3 * b + 1], self.body_linvel[3 * b + 2]]
    }
    /// Angular velocity of body `b` (world, rad/s).
    #[inline]
    pub fn angvel(&self, b: usize) -> [f64; 3] {
        [self.body_angvel[3 * b], self.body_angvel[3 * b + 1], self.body_angvel[3 * b + 2]]
    }
}

impl HsiState {
    fn new(n: usize, bodies: usize) -> Self {
        Self {
            bodies,
            body_pos: vec![0.0; n * bodies * 3],
            body_quat: vec![0.0; n * bodies * 4],
            body_linvel: vec![0.0; n * bodies * 3],
            body_angvel: vec![0.0; n * bodies * 3],
            dof_pos: vec![0.0; n * NUM_DOFS],
            dof_vel: vec![0.0; n * NUM_DOFS],
            contact: vec![0; n * NUM_BODIES],
            unstable: vec![0; n],
        }
    }
    /// View of environment `i`.
    pub fn env(&self, i: usize) -> HsiEnvState<'_> {
        let (b3, b4) = (self.bodies * 3, self.bodies * 4);
        HsiEnvState {
            body_pos: &self.body_pos[i * b3..(i + 1) * b3],
            body_quat: &self.body_quat[i * b4..(i + 1) * b4],
            body_linvel: &self.body_linvel[i * b3..(i + 1) * b3],
            body_angvel: &self.body_angvel[i * b3..(i + 1) * b3],
            dof_pos: &self.dof_pos[i * NUM_DOFS..(i + 1) * NUM_DOFS],
            dof_vel: &self.dof_vel[i * NUM_DOFS..(i + 1) * NUM_DOFS],
            contact: &self.contact[i * NUM_BODIES..(i + 1) * NUM_BODIES],
            unstable: self.unstable[i] != 0,
        }
    }
}

struct Slot {
    variant: usize,
    data: Data,
}

struct Rows<'a> {
    pos: &'a mut [f64],
    quat: &'a mut [f64],
    linvel: &'a mut [f64],
    angvel: &'a mut [f64],
    dof_pos: &'a mut [f64],
    dof_vel: &'a mut [f64],
    contact: &'a mut [u8],
    unstable: &'a mut u8,
}

/// N TokenHSI environments.
pub struct HsiBatch {
    variants: Vec<Arc<HsiScene>>,
    envs: Vec<Slot>,
    pool: rayon::ThreadPool,
    state: HsiState,
    substeps: usize,
}

impl HsiBatch {
    /// `num_envs` environments; environment `i` uses scene `variants[i % variants.len()]` (all
    /// variants must hold the same number of objects); `num_threads` workers (0 = one per core).
    pub fn new(
        variants: Vec<Arc<HsiScene>>,
        num_envs: usize,
        num_threads: usize,
    ) -> Result<Self, SimError> {
        if num_envs == 0 || variants.is_empty() {
            return Err(SimError::Config(
                "a TokenHSI batch needs at least one environment and one scene".into(),
            ));
        }
        let k = variants[0].objects().len();
        if variants.iter().any(|v| v.objects().len() != k) {
            return Err(SimError::Config(
                "every scene variant of a batch must hold the same objects".into(),
            ));
        }
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(num_threads)
            .thread_name(|i| format!("skillmimic-hsi-{i}"))
            .build()
            .map_err(|e| {
                SimError::Config(format!("cannot start {num_threads} simulation threads: {e}"))
            })?;
        let probe = MjData::try_new(Arc::clone(variants[0].model()))
            .map_err(|e| SimError::Config(format!("cannot allocate MuJoCo data: {e}")))?;
        crate::memory::check_batch(
            num_envs,
            crate::memory::data_bytes(probe.ffi()),
            "the TokenHSI scene",
        )?;
        drop(probe);
        let envs = (0..num_envs)
            .map(|i| {
                let variant = i % variants.len();
                MjData::try_new(Arc::clone(variants[variant].model()))
                    .map(|data| Slot { variant, data })
                    .map_err(|e| SimError::Config(format!("cannot allocate MuJoCo data: {e}")))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let state = HsiState::new(num_envs, NUM_BODIES + k);
        let mut sim = Self { variants, envs, pool, state, substeps: HSI_SUBSTEPS };
        sim.reset(&vec![true; num_envs], &vec![HsiReset::default(); num_envs])?;
        Ok(sim)
    }

    /// Number of environments.
    pub fn num_envs(&self) -> usize {
        self.envs.len()
    }
    /// The scene of environment `i`.
    pub fn scene(&self, i: usize) -> &Arc<HsiScene> {
        &self.variants[self.envs[i].variant]
    }
    /// The scene variants.
    pub fn variants(&self) -> &[Arc<HsiScene>] {
        &self.variants
    }
    /// State after the last step or reset.
    pub fn state(&self) -> &HsiState {
        &self.state
    }
    /// Physics steps per policy step.
    pub fn substeps(&self) -> usize {
        self.substeps
    }
    /// Raw MuJoCo data of environment `i`.
    pub fn data(&self, i: usize) -> &Data {
        &self.envs[i].data
    }
    /// Run `op` inside the simulation pool.
    pub fn install<OP: FnOnce() -> R + Send, R: Send>(&self, op: OP) -> R {
        self.pool.install(op)
    }

    /// Advance every environment by one policy step; `actions` is `N × 32`, entries clamped to
    /// [−1, 1].
    pub fn step(&mut self, actions: &[f32]) -> Result<(), SimError> {
        let n = self.num_envs();
        if actions.len() != n * NUM_DOFS {
            return Err(SimError::Shape {
                what: "actions",
                expected: n * NUM_DOFS,
                shape: format!("{n} x {NUM_DOFS}"),
                got: actions.len(),
            });
        }
        if let Some(k) = actions.iter().position(|a| !a.is_finite()) {
            return Err(SimError::NonFinite {
                what: "actions",
                env: k / NUM_DOFS,
                index: k % NUM_DOFS,
            });
        }
        let (variants, substeps) = (&self.variants, self.substeps);
        Self::for_each(&self.pool, &mut self.envs, &mut self.state, |i, slot, mut rows| {
            let scene = &*variants[slot.variant];
            let row = &actions[i * NUM_DOFS..(i + 1) * NUM_DOFS];
            let d = &mut slot.data;
            for (c, &(k, off, sc)) in d.ctrl_mut().iter_mut().zip(&scene.actuator_map) {
                *c = off + sc * (row[k] as f64).clamp(-1.0, 1.0);
            }
            clear_bad_state(d);
            // the data holds the position/velocity stages of its state (previous mj_step1 or the
            // reset's mj_forward): same stages, same order as a plain mj_step loop
            d.step2();
            for _ in 1..substeps {
                d.step();
            }
            read_contacts(scene, d, &mut rows);
            d.step1();
            *rows.unstable = u8::from(bad_state(d));
            read_state(scene, d, &mut rows);
        });
        Ok(())
    }

    /// Reset the environments whose `mask` entry is true to `states[i]`.
    pub fn reset(&mut self, mask: &[bool], states: &[HsiReset]) -> Result<(), SimError> {
        let n = self.num_envs();
        if mask.len() != n || states.len() != n {
            return Err(SimError::Config(format!(
                "reset needs {n} mask entries and states, got {} and {}",
                mask.len(),
                states.len()
            )));
        }
        for (i, s) in states.iter().enumerate().filter(|(i, _)| mask[*i]) {
            let objs = s.objects.iter().flat_map(|o| {
                o.pos.into_iter().chain(o.quat.to_wxyz()).chain(o.linvel).chain(o.angvel_local)
            });
            let all = s
                .root_pos
                .into_iter()
                .chain(s.root_quat.to_wxyz())
                .chain(s.root_linvel)
                .chain(s.root_angvel_local)
                .chain(s.dof_pos)
                .chain(s.dof_vel)
                .chain(objs);
            if let Some(index) = all.enumerate().find(|(_, x)| !x.is_finite()).map(|(k, _)| k) {
                return Err(SimError::NonFinite { what: "reset state", env: i, index });
            }
        }
        let variants = &self.variants;
        Self::for_each(&self.pool, &mut self.envs, &mut self.state, |i, slot, mut rows| {
            if !mask[i] {
                return;
            }
            let scene = &*variants[slot.variant];
            let d = &mut slot.data;
            write_reset(scene, d, &states[i]);
            clear_bad_state(d);
            d.forward();
            *rows.unstable = u8::from(bad_state(d));
            read_contacts(scene, d, &mut rows);
            read_state(scene, d, &mut rows);
        });
        Ok(())
    }

    /// Overwrite the raw `qpos`/`qvel` of environment `i` (same clearing as a reset).
    pub fn set_qpos_qvel(&mut self, i: usize, qpos: &[f64], qvel: &[f64]) -> Result<(), SimError> {
        let n = self.num_envs();
        if i >= n {
            return Err(SimError::Config(format!(
                "environment index {i} out of range (num_envs = {n})"
            )));
        }
        let (nq, nv, _) = self.scene(i).sizes();
        if qpos.len() != nq || qvel.len() != nv {
            return Err(SimError::Config(format!(
                "qpos/qvel need {nq}/{nv} entries, got {}/{}",
                qpos.len(),
                qvel.len()
            )));
        }
        if let Some(k) = qpos.iter().chain(qvel).position(|x| !x.is_finite()) {
            return Err(SimError::NonFinite { what: "qpos/qvel", env: i, index: k });
        }
        let variants = &self.variants;
        Self::for_each(&self.pool, &mut self.envs, &mut self.state, |j, slot, mut rows| {
            if j != i {
                return;
            }
            let scene = &*variants[slot.variant];
            let d = &mut slot.data;
            clear(d);
            d.qpos_mut().copy_from_slice(qpos);
            d.qvel_mut().copy_from_slice(qvel);
            d.forward();
            read_contacts(scene, d, &mut rows);
            read_state(scene, d, &mut rows);
        });
        Ok(())
    }

    fn for_each<F>(pool: &rayon::ThreadPool, envs: &mut [Slot], st: &mut HsiState, f: F)
    where
        F: Fn(usize, &mut Slot, Rows<'_>) + Sync,
    {
        let b = st.bodies;
        pool.install(|| {
            (
                envs.par_iter_mut(),
                st.body_pos.par_chunks_mut(3 * b),
                st.body_quat.par_chunks_mut(4 * b),
                st.body_linvel.par_chunks_mut(3 * b),
                st.body_angvel.par_chunks_mut(3 * b),
                st.dof_pos.par_chunks_mut(NUM_DOFS),
                st.dof_vel.par_chunks_mut(NUM_DOFS),
                st.contact.par_chunks_mut(NUM_BODIES),
                st.unstable.par_iter_mut(),
            )
                .into_par_iter()
                .enumerate()
                .for_each(
                    |(
                        i,
                        (slot, pos, quat, linvel, angvel, dof_pos, dof_vel, contact, unstable),
                    )| {
                        f(
                            i,
                            slot,
                            Rows { pos, quat, linvel, angvel, dof_pos, dof_vel, contact, unstable },
                        )
                    },
                );
        });
    }
}

fn clear(d: &mut Data) {
    // SAFETY: `time` is a plain scalar of mjData with no other invariant.
    unsafe { d.ffi_mut().time = 0.0 };
    d.ctrl_mut().fill(0.0);
    d.qacc_warmstart_mut().fill(0.0);
}

fn write_reset(scene: &HsiScene, d: &mut Data, s: &HsiReset) {
    clear(d);
    let (rq, rv) = (scene.root_qpos, scene.root_qvel);
    {
        let qpos = d.qpos_mut();
        qpos[rq..rq + 3].copy_from_slice(&s.root_pos);
        qpos[rq + 3..rq + 7].copy_from_slice(&s.root_quat.normalized().to_wxyz());
        for j in &scene.joints {
            if j.dofs == 3 {
                let a = j.action;
                qpos[j.qpos..j.qpos + 4].copy_from_slice(
                    &Quat::from_rotvec([s.dof_pos[a], s.dof_pos[a + 1], s.dof_pos[a + 2]])
                        .to_wxyz(),
                );
            } else {
                qpos[j.qpos] = s.dof_pos[j.action];
            }
        }
    }
    {
        let qvel = d.qvel_mut();
        qvel.fill(0.0);
        qvel[rv..rv + 3].copy_from_slice(&s.root_linvel);
        qvel[rv + 3..rv + 6].copy_from_slice(&s.root_angvel_local);
        for j in &scene.joints {
            qvel[j.qvel..j.qvel + j.dofs].copy_from_slice(&s.dof_vel[j.action..j.action + j.dofs]);
        }
    }
    for (o, addr) in s.objects.iter().zip(&scene.object_addr) {
        match *addr {
            ObjectAddr::Mocap(m) => {
                d.mocap_pos_mut()[m] = o.pos;
                d.mocap_quat_mut()[m] = o.quat.normalized().to_wxyz();
            }
            ObjectAddr::Free { qpos, qvel } => {
                d.qpos_mut()[qpos..qpos + 3].copy_from_slice(&o.pos);
                d.qpos_mut()[qpos + 3..qpos + 7].copy_from_slice(&o.quat.normalized().to_wxyz());
                d.qvel_mut()[qvel..qvel + 3].copy_from_slice(&o.linvel);
                d.qvel_mut()[qvel + 3..qvel + 6].copy_from_slice(&o.angvel_local);
            }
        }
    }
}

/// Kinematic read-out (needs the position/velocity stages of the current state).
fn read_state(scene: &HsiScene, d: &Data, rows: &mut Rows<'_>) {
    let (xpos, xquat, xipos, cvel, com) =
        (d.xpos(), d.xquat(), d.xipos(), d.cvel(), d.subtree_com());
    for (b, &id) in scene.body_ids.iter().enumerate() {
        rows.pos[3 * b..3 * b + 3].copy_from_slice(&xpos[id]);
        rows.quat[4 * b..4 * b + 4].copy_from_slice(&xquat[id]);
        // cvel = [ω; v] with v at the tree's subtree centre of mass c: v_com = v + ω × (xipos − c)
        let (w, v) = (&cvel[id][..3], &cvel[id][3..]);
        let c = com[scene.tree_root[b]];
        let r = [xipos[id][0] - c[0], xipos[id][1] - c[1], xipos[id][2] - c[2]];
        rows.angvel[3 * b..3 * b + 3].copy_from_slice(w);
        rows.linvel[3 * b..3 * b + 3].copy_from_slice(&[
            v[0] + w[1] * r[2] - w[2] * r[1],
            v[1] + w[2] * r[0] - w[0] * r[2],
            v[2] + w[0] * r[1] - w[1] * r[0],
        ]);
    }
    let (qpos, qvel) = (d.qpos(), d.qvel());
    for j in &scene.joints {
        let a = j.action;
        if j.dofs == 3 {
            let q = Quat::from_wxyz([
                qpos[j.qpos],
                qpos[j.qpos + 1],
                qpos[j.qpos + 2],
                qpos[j.qpos + 3],
            ])
            .normalized();
            rows.dof_pos[a..a + 3].copy_from_slice(&q.to_rotvec());
        } else {
            rows.dof_pos[a] = qpos[j.qpos];
        }
        rows.dof_vel[a..a + j.dofs].copy_from_slice(&qvel[j.qvel..j.qvel + j.dofs]);
    }
}

/// Flag the character bodies that touch the floor or an object (contacts with a constraint).
fn read_contacts(scene: &HsiScene, d: &Data, rows: &mut Rows<'_>) {
    rows.contact.fill(0);
    for con in d.contact() {
        if con.efc_address < 0 || con.geom[0] < 0 || con.geom[1] < 0 {
            continue;
        }
        let (a, b) = (
            scene.geom_character_body[con.geom[0] as usize],
            scene.geom_character_body[con.geom[1] as usize],
        );
        match (a, b) {
            (Some(x), None) | (None, Some(x)) => rows.contact[x] = 1,
            _ => {}
        }
    }
}
