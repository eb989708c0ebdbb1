//! The batched simulation core: N independent MuJoCo environments stepped in parallel.
//!
//! One [`BatchSim::step`] call applies an `N × 156` action matrix (PD target = π·action, clamped
//! to [−1, 1]), runs the physics sub-steps of one policy step in every environment, computes the
//! kinematics and velocities of the new state, and writes the state into the contiguous
//! buffers of [`BatchState`]. Environments run on a rayon pool of a fixed size; each owns its
//! `MjData`, so results are bit-identical for any thread count. The step and reset paths do not
//! allocate (checked by a test with a counting allocator).

use std::sync::Arc;

use mujoco_rs::mujoco_c::mjtWarning;
use mujoco_rs::prelude::*;
use rayon::prelude::*;
use skillmimic_core::math::Quat;
use skillmimic_core::skeleton::{NUM_DOFS, NUM_JOINTS};

use crate::bounce::BounceState;
use crate::contacts::ContactPair;
use crate::error::SimError;
use crate::scene::{GeomOwner, NUM_STATE_BODIES, Scene};
use crate::state::{BatchState, ResetState, width};

/// Physics sub-steps per policy step (1/120 s each → 60 Hz policy).
pub const DEFAULT_SUBSTEPS: usize = 2;

type Data = MjData<Arc<MjModel>>;

struct EnvSlot {
    data: Data,
    /// The floor bounce-threshold rule's state (`crate::bounce`).
    bounce: BounceState,
}

/// Mutable rows of one environment in every output buffer.
struct Rows<'a> {
    body_pos: &'a mut [f64],
    body_quat: &'a mut [f64],
    body_linvel: &'a mut [f64],
    body_angvel: &'a mut [f64],
    dof_pos: &'a mut [f64],
    dof_vel: &'a mut [f64],
    contact_force: &'a mut [f64],
    contact_pairs: &'a mut [u8],
    unstable: &'a mut u8,
}

/// N environments of one scene, stepped in parallel.
pub struct BatchSim {
    scene: Arc<Scene>,
    envs: Vec<EnvSlot>,
    pool: rayon::ThreadPool,
    state: BatchState,
    substeps: usize,
}

impl BatchSim {
    /// `num_envs` environments on a pool of `num_threads` worker threads (0 = one per core).
    /// Every environment starts in [`ResetState::default`].
    pub fn new(scene: Arc<Scene>, num_envs: usize, num_threads: usize) -> Result<Self, SimError> {
        if num_envs == 0 {
            return Err(SimError::Config("num_envs must be at least 1".into()));
        }
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(num_threads)
            .thread_name(|i| format!("skillmimic-sim-{i}"))
            .build()
            .map_err(|e| {
                SimError::Config(format!("cannot start {num_threads} simulation threads: {e}"))
            })?;
        let make = || {
            MjData::try_new(Arc::clone(scene.model()))
                .map(|data| EnvSlot { data, bounce: BounceState::default() })
                .map_err(|e| SimError::Config(format!("cannot allocate MuJoCo data: {e}")))
        };
        let first = make()?;
        crate::memory::check_batch(
            num_envs,
            crate::memory::data_bytes(first.data.ffi()),
            "the SkillMimic scene",
        )?;
        let envs = std::iter::once(Ok(first))
            .chain((1..num_envs).map(|_| make()))
            .collect::<Result<Vec<_>, _>>()?;
        let mut sim = Self {
            scene,
            envs,
            pool,
            state: BatchState::new(num_envs),
            substeps: DEFAULT_SUBSTEPS,
        };
        let mask = vec![true; num_envs];
        let init = vec![ResetState::default(); num_envs];
        sim.reset(&mask, &init)?;
        Ok(sim)
    }

    /// Number of environments.
    pub fn num_envs(&self) -> usize {
        self.envs.len()
    }
    /// Number of worker threads.
    pub fn num_threads(&self) -> usize {
        self.pool.current_num_threads()
    }
    /// The scene shared by all environments.
    pub fn scene(&self) -> &Arc<Scene> {
        &self.scene
    }
    /// State after the last step or reset.
    pub fn state(&self) -> &BatchState {
        &self.state
    }
    /// Physics sub-steps per policy step.
    pub fn substeps(&self) -> usize {
        self.substeps
    }
    /// Change the number of physics sub-steps per policy step (≥ 1).
    pub fn set_substeps(&mut self, n: usize) -> Result<(), SimError> {
        if n == 0 {
            return Err(SimError::Config("substeps must be at least 1".into()));
        }
        self.substeps = n;
        Ok(())
    }
    /// Run `op` inside the simulation thread pool (for per-environment work of the layers above,
    /// e.g. observations and rewards, parallelised with rayon on the same threads).
    pub fn install<OP, R>(&self, op: OP) -> R
    where
        OP: FnOnce() -> R + Send,
        R: Send,
    {
        self.pool.install(op)
    }

    /// Raw MuJoCo data of environment `i` (read-only; e.g. for rendering).
    pub fn data(&self, i: usize) -> &Data {
        &self.envs[i].data
    }
    /// Generalised positions of environment `i`.
    pub fn qpos(&self, i: usize) -> &[f64] {
        self.envs[i].data.qpos()
    }
    /// Generalised velocities of environment `i`.
    pub fn qvel(&self, i: usize) -> &[f64] {
        self.envs[i].data.qvel()
    }

    /// Advance every environment by one policy step.
    ///
    /// `actions` is `N × 156` (row-major, skeleton dof order); each entry is clamped to [−1, 1]
    /// and scaled by π to the exp-map PD target. Entries of welded joints are ignored.
    pub fn step(&mut self, actions: &[f32]) -> Result<(), SimError> {
        let n = self.num_envs();
        check_len("actions", actions.len(), n * NUM_DOFS, || format!("{n} x {NUM_DOFS}"))?;
        if let Some(k) = actions.iter().position(|a| !a.is_finite()) {
            return Err(SimError::NonFinite {
                what: "actions",
                env: k / NUM_DOFS,
                index: k % NUM_DOFS,
            });
        }
        let scene = &*self.scene;
        let substeps = self.substeps;
        Self::for_each_env(&self.pool, &mut self.envs, &mut self.state, |i, slot, mut rows| {
            let row = &actions[i * NUM_DOFS..(i + 1) * NUM_DOFS];
            let d = &mut slot.data;
            let ctrl = d.ctrl_mut();
            for (c, &k) in ctrl.iter_mut().zip(&scene.actuator_action) {
                *c = (row[k] as f64).clamp(-1.0, 1.0) * std::f64::consts::PI;
            }
            clear_bad_state(d);
            let bounce = &mut slot.bounce;
            // The data always holds the position/velocity stages of its current state (computed
            // by the previous step's mj_step1 or by the reset's mj_forward), so the first sub-step
            // only needs mj_step2. The same MuJoCo stages run in the same order as in mj_step,
            // hence the trajectory is bit-identical to a plain mj_step loop.
            d.step2();
            apply_bounce(scene, d, bounce);
            for _ in 1..substeps {
                d.step();
                apply_bounce(scene, d, bounce);
            }
            // contacts and forces of the last sub-step are still in place: read them, then
            // compute the position/velocity stages of the new state (mj_step1) for the read-out
            // and for the next call
            read_contacts(scene, d, &mut rows);
            d.step1();
            *rows.unstable = u8::from(bad_state(d));
            read_kinematics(scene, d, &mut rows);
        });
        Ok(())
    }

    /// Reset the environments whose `mask` entry is true to `states[i]` (other entries of
    /// `states` are ignored), then run forward dynamics so that kinematics, contacts and the
    /// read-out buffers describe the new state.
    ///
    /// Reset clears time, controls and the solver warm start, so a reset environment evolves
    /// exactly like a fresh `MjData` given the same `qpos`/`qvel`.
    pub fn reset(&mut self, mask: &[bool], states: &[ResetState]) -> Result<(), SimError> {
        let n = self.num_envs();
        check_len("reset mask", mask.len(), n, || n.to_string())?;
        check_len("reset states", states.len(), n, || n.to_string())?;
        for (i, s) in states.iter().enumerate() {
            if mask[i] {
                check_reset_state(i, s)?;
            }
        }
        let scene = &*self.scene;
        Self::for_each_env(&self.pool, &mut self.envs, &mut self.state, |i, slot, mut rows| {
            if !mask[i] {
                return;
            }
            slot.bounce = BounceState::default();
            let d = &mut slot.data;
            write_reset_state(scene, d, &states[i]);
            clear_bad_state(d);
            d.forward();
            *rows.unstable = u8::from(bad_state(d));
            read_contacts(scene, d, &mut rows);
            read_kinematics(scene, d, &mut rows);
        });
        Ok(())
    }

    /// Overwrite the raw MuJoCo `qpos`/`qvel` of environment `i` (same clearing as
    /// [`reset`](Self::reset)).
    pub fn set_qpos_qvel(&mut self, i: usize, qpos: &[f64], qvel: &[f64]) -> Result<(), SimError> {
        let n = self.num_envs();
        if i >= n {
            return Err(SimError::Config(format!(
                "environment index {i} out of range (num_envs = {n})"
            )));
        }
        let (nq, nv, _) = self.scene.sizes();
        check_len("qpos", qpos.len(), nq, || nq.to_string())?;
        check_len("qvel", qvel.len(), nv, || nv.to_string())?;
        if let Some(k) = qpos.iter().chain(qvel).position(|x| !x.is_finite()) {
            return Err(SimError::NonFinite { what: "qpos/qvel", env: i, index: k });
        }
        let scene = &*self.scene;
        Self::for_each_env(&self.pool, &mut self.envs, &mut self.state, |j, slot, mut rows| {
            if j != i {
                return;
            }
            slot.bounce = BounceState::default();
            let d = &mut slot.data;
            clear_for_reset(d);
            d.qpos_mut().copy_from_slice(qpos);
            d.qvel_mut().copy_from_slice(qvel);
            clear_bad_state(d);
            d.forward();
            *rows.unstable = u8::from(bad_state(d));
            read_contacts(scene, d, &mut rows);
            read_kinematics(scene, d, &mut rows);
        });
        Ok(())
    }

    /// Run `f(env index, env, rows)` for every environment on the pool.
    fn for_each_env<F>(pool: &rayon::ThreadPool, envs: &mut [EnvSlot], st: &mut BatchState, f: F)
    where
        F: Fn(usize, &mut EnvSlot, Rows<'_>) + Sync,
    {
        pool.install(|| {
            (
                envs.par_iter_mut(),
                st.body_pos.par_chunks_mut(width::BODY_POS),
                st.body_quat.par_chunks_mut(width::BODY_QUAT),
                st.body_linvel.par_chunks_mut(width::BODY_VEL),
                st.body_angvel.par_chunks_mut(width::BODY_VEL),
                st.dof_pos.par_chunks_mut(width::DOF),
                st.dof_vel.par_chunks_mut(width::DOF),
                st.contact_force.par_chunks_mut(width::CONTACT_FORCE),
                st.contact_pairs.par_chunks_mut(width::CONTACT_PAIRS),
                st.unstable.par_iter_mut(),
            )
                .into_par_iter()
                .enumerate()
                .for_each(|(i, (slot, bp, bq, blv, bav, dp, dv, cf, cp, un))| {
                    let rows = Rows {
                        body_pos: bp,
                        body_quat: bq,
                        body_linvel: blv,
                        body_angvel: bav,
                        dof_pos: dp,
                        dof_vel: dv,
                        contact_force: cf,
                        contact_pairs: cp,
                        unstable: un,
                    };
                    f(i, slot, rows)
                });
        });
    }
}

/// Length check; the shape text is only built on the error path (the step path must not allocate).
fn check_len(
    what: &'static str,
    got: usize,
    expected: usize,
    shape: impl FnOnce() -> String,
) -> Result<(), SimError> {
    if got == expected {
        Ok(())
    } else {
        Err(SimError::Shape { what, expected, shape: shape(), got })
    }
}

fn check_reset_state(env: usize, s: &ResetState) -> Result<(), SimError> {
    let (rq, bq) = (s.root_quat.to_wxyz(), s.ball_quat.to_wxyz());
    let all = s
        .root_pos
        .iter()
        .chain(&rq)
        .chain(&s.root_linvel)
        .chain(&s.root_angvel_local)
        .chain(&s.dof_pos)
        .chain(&s.dof_vel)
        .chain(&s.ball_pos)
        .chain(&bq)
        .chain(&s.ball_linvel)
        .chain(&s.ball_angvel_local);
    for (index, x) in all.enumerate() {
        if !x.is_finite() {
            return Err(SimError::NonFinite { what: "reset state", env, index });
        }
    }
    Ok(())
}

/// MuJoCo's warnings of a bad state: a non-finite or huge `qpos`, `qvel` or `qacc`. On each of
/// them MuJoCo resets that environment's data (auto-reset), so the step's outcome is not physics.
const BAD_STATE: [mjtWarning; 3] =
    [mjtWarning::mjWARN_BADQPOS, mjtWarning::mjWARN_BADQVEL, mjtWarning::mjWARN_BADQACC];

/// Zero the [`BAD_STATE`] warning counters before a step, reset or forward pass.
pub(crate) fn clear_bad_state(d: &mut Data) {
    for w in BAD_STATE {
        // SAFETY: the warning statistics are plain counters of mjData, read only by callers.
        unsafe { d.ffi_mut().warning[w as usize].number = 0 };
    }
}

/// Whether MuJoCo reported a bad state since [`clear_bad_state`] (the environment's `unstable`
/// flag). Clearing first, rather than comparing counts, also catches a repeat of the same
/// warning after MuJoCo's auto-reset set its counter back to 1.
pub(crate) fn bad_state(d: &Data) -> bool {
    BAD_STATE.iter().any(|&w| d.ffi().warning[w as usize].number > 0)
}

/// Clear the parts of `mjData` that carry over between steps besides `qpos`/`qvel`.
fn clear_for_reset(d: &mut Data) {
    // SAFETY: `time` is a plain scalar field of mjData; writing it has no other invariant.
    unsafe { d.ffi_mut().time = 0.0 };
    d.ctrl_mut().fill(0.0);
    d.qacc_warmstart_mut().fill(0.0);
}

/// The floor bounce-threshold rule after one sub-step (`crate::bounce`).
#[inline]
fn apply_bounce(scene: &Scene, d: &mut Data, b: &mut BounceState) {
    let ball = &scene.options().ball;
    if ball.bounce_threshold <= 0.0 {
        return;
    }
    let z = d.qpos()[scene.ball_qpos + 2];
    let vz = &mut d.qvel_mut()[scene.ball_dof + 2];
    b.apply(z, vz, ball.radius, ball.bounce_threshold);
}

fn write_reset_state(scene: &Scene, d: &mut Data, s: &ResetState) {
    clear_for_reset(d);
    let qpos = d.qpos_mut();
    if let Some(a) = scene.root_qpos {
        qpos[a..a + 3].copy_from_slice(&s.root_pos);
        qpos[a + 3..a + 7].copy_from_slice(&s.root_quat.normalized().to_wxyz());
    }
    for j in 0..NUM_JOINTS {
        if let Some(a) = scene.joint_qpos[j] {
            let v = [s.dof_pos[3 * j], s.dof_pos[3 * j + 1], s.dof_pos[3 * j + 2]];
            qpos[a..a + 4].copy_from_slice(&Quat::from_rotvec(v).to_wxyz());
        }
    }
    let b = scene.ball_qpos;
    qpos[b..b + 3].copy_from_slice(&s.ball_pos);
    qpos[b + 3..b + 7].copy_from_slice(&s.ball_quat.normalized().to_wxyz());

    let qvel = d.qvel_mut();
    qvel.fill(0.0);
    if let Some(a) = scene.root_dof {
        qvel[a..a + 3].copy_from_slice(&s.root_linvel);
        qvel[a + 3..a + 6].copy_from_slice(&s.root_angvel_local);
    }
    for j in 0..NUM_JOINTS {
        if let Some(a) = scene.joint_dof[j] {
            qvel[a..a + 3].copy_from_slice(&s.dof_vel[3 * j..3 * j + 3]);
        }
    }
    let b = scene.ball_dof;
    qvel[b..b + 3].copy_from_slice(&s.ball_linvel);
    qvel[b + 3..b + 6].copy_from_slice(&s.ball_angvel_local);
}

/// Copy one environment's kinematic state into its buffer rows (no allocation). Requires the
/// position and velocity stages of the current `qpos`/`qvel` (mj_step1 or mj_forward).
fn read_kinematics(scene: &Scene, d: &Data, rows: &mut Rows<'_>) {
    let (xpos, xquat, xipos) = (d.xpos(), d.xquat(), d.xipos());
    let (cvel, subtree_com) = (d.cvel(), d.subtree_com());
    for b in 0..NUM_STATE_BODIES {
        let id = scene.body_ids[b];
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

    let qpos = d.qpos();
    let qvel = d.qvel();
    for j in 0..NUM_JOINTS {
        let (p, v) = (&mut rows.dof_pos[3 * j..3 * j + 3], &mut rows.dof_vel[3 * j..3 * j + 3]);
        match (scene.joint_qpos[j], scene.joint_dof[j]) {
            (Some(a), Some(dv)) => {
                let q =
                    Quat::from_wxyz([qpos[a], qpos[a + 1], qpos[a + 2], qpos[a + 3]]).normalized();
                p.copy_from_slice(&q.to_rotvec());
                v.copy_from_slice(&qvel[dv..dv + 3]);
            }
            _ => {
                p.fill(0.0);
                v.fill(0.0);
            }
        }
    }
}

/// Classify the active contacts and accumulate per-body net contact forces (world frame) from the
/// last constraint solve (no allocation).
fn read_contacts(scene: &Scene, d: &Data, rows: &mut Rows<'_>) {
    rows.contact_force.fill(0.0);
    rows.contact_pairs.fill(0);
    for (c, con) in d.contact().iter().enumerate() {
        if con.efc_address < 0 {
            continue; // excluded or inactive: no constraint force
        }
        let (g1, g2) = (con.geom[0], con.geom[1]);
        if g1 < 0 || g2 < 0 {
            continue; // flex contacts (none in this scene)
        }
        let (o1, o2) = (scene.geom_owner[g1 as usize], scene.geom_owner[g2 as usize]);
        if let Some(kind) = ContactPair::classify(o1, o2) {
            rows.contact_pairs[kind as usize] = 1;
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
                GeomOwner::Ball => crate::scene::BALL,
                GeomOwner::Floor => continue,
            };
            for k in 0..3 {
                rows.contact_force[3 * b + k] += sign * w[k];
            }
        }
    }
}
