//! The batched simulation core: N independent MuJoCo environments of one character stepped in
//! parallel.
//!
//! One [`BatchSim::step`] call applies an `N × dofs` action matrix (each entry clamped to
//! [−1, 1] and mapped to its PD target by the character's action map), runs the physics
//! sub-steps of one policy step in every environment, computes the kinematics and velocities of
//! the new state, and writes the state into the contiguous buffers of [`BatchState`].
//! Environment `i` uses scene variant `i % variants` (the same character and object names with,
//! e.g., different object sizes). Environments run on a rayon pool of a fixed size; each owns its
//! `MjData`, so results are bit-identical for any thread count. The step and reset paths do not
//! allocate (checked by a test with a counting allocator).

use std::sync::Arc;

use mujoco_rs::mujoco_c::mjtWarning;
use mujoco_rs::prelude::*;
use rayon::prelude::*;
use skillmimic_core::math::Quat;

use crate::bounce::BounceState;
use crate::contacts::NUM_CONTACT_PAIRS;
use crate::error::SimError;
use crate::readout::{Rows, read_contacts, read_kinematics};
use crate::scene::{ObjectAddr, Scene};
use crate::state::{BatchState, ResetState};

/// Physics sub-steps per policy step of the SkillMimic humanoid (1/120 s each → 60 Hz policy).
pub const DEFAULT_SUBSTEPS: usize = 2;

type Data = MjData<Arc<MjModel>>;

pub(crate) struct EnvSlot {
    pub(crate) variant: usize,
    pub(crate) data: Data,
    /// The floor bounce-threshold rule's state (`crate::bounce`).
    pub(crate) bounce: BounceState,
    /// Not stepped (`crate::pause`).
    pub(crate) paused: bool,
}

/// N environments of one character, stepped in parallel.
pub struct BatchSim {
    variants: Vec<Arc<Scene>>,
    pub(crate) envs: Vec<EnvSlot>,
    pool: rayon::ThreadPool,
    pub(crate) state: BatchState,
    substeps: usize,
}

impl BatchSim {
    /// `num_envs` environments of `scene` on a pool of `num_threads` worker threads (0 = one per
    /// core). Every environment starts in the scene's rest state ([`ResetState::rest`]).
    pub fn new(scene: Arc<Scene>, num_envs: usize, num_threads: usize) -> Result<Self, SimError> {
        Self::with_variants(vec![scene], num_envs, num_threads)
    }

    /// `num_envs` environments; environment `i` uses `variants[i % variants.len()]`. Every
    /// variant must have the same character and the same objects (names and kinds; sizes may
    /// differ).
    pub fn with_variants(
        variants: Vec<Arc<Scene>>,
        num_envs: usize,
        num_threads: usize,
    ) -> Result<Self, SimError> {
        if num_envs == 0 {
            return Err(SimError::Config("num_envs must be at least 1".into()));
        }
        let Some(first) = variants.first() else {
            return Err(SimError::Config("a batch needs at least one scene".into()));
        };
        let same = |s: &Scene| {
            s.character() == first.character()
                && s.objects.len() == first.objects.len()
                && s.sizes() == first.sizes()
        };
        if !variants.iter().all(|s| same(s)) {
            return Err(SimError::Config(
                "every scene variant of a batch must hold the same character and objects".into(),
            ));
        }
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(num_threads)
            .thread_name(|i| format!("skillmimic-sim-{i}"))
            .build()
            .map_err(|e| {
                SimError::Config(format!("cannot start {num_threads} simulation threads: {e}"))
            })?;
        let make = |i: usize| {
            let variant = i % variants.len();
            MjData::try_new(Arc::clone(variants[variant].model()))
                .map(|data| EnvSlot {
                    variant,
                    data,
                    bounce: BounceState::default(),
                    paused: false,
                })
                .map_err(|e| SimError::Config(format!("cannot allocate MuJoCo data: {e}")))
        };
        let probe = make(0)?;
        let what = format!("the {} scene", first.character().name);
        crate::memory::check_batch(num_envs, crate::memory::data_bytes(probe.data.ffi()), &what)?;
        let envs = std::iter::once(Ok(probe))
            .chain((1..num_envs).map(make))
            .collect::<Result<Vec<_>, _>>()?;
        let state = BatchState::new(num_envs, first);
        let substeps = first.substeps();
        let rest = ResetState::rest(first);
        let mut sim = Self { variants, envs, pool, state, substeps };
        sim.reset(&vec![true; num_envs], &vec![rest; num_envs])?;
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
    /// The scene of environment 0 (every environment's, for a batch of one variant).
    pub fn scene(&self) -> &Arc<Scene> {
        &self.variants[0]
    }
    /// The scene of environment `i`.
    pub fn scene_of(&self, i: usize) -> &Arc<Scene> {
        &self.variants[self.envs[i].variant]
    }
    /// The scene variants.
    pub fn variants(&self) -> &[Arc<Scene>] {
        &self.variants
    }
    /// Width of the dof (action) vector.
    pub fn num_dofs(&self) -> usize {
        self.state.dofs
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
    /// `actions` is `N × dofs` (row-major, the character's dof order); each entry is clamped to
    /// [−1, 1] and mapped to its PD target. Entries of welded joints are ignored. Paused
    /// environments ([`set_paused`](Self::set_paused)) keep their state and read-out.
    pub fn step(&mut self, actions: &[f32]) -> Result<(), SimError> {
        let (n, nd) = (self.num_envs(), self.num_dofs());
        check_len("actions", actions.len(), n * nd, || format!("{n} x {nd}"))?;
        if let Some(k) = actions.iter().position(|a| !a.is_finite()) {
            return Err(SimError::NonFinite { what: "actions", env: k / nd, index: k % nd });
        }
        let (variants, substeps) = (&self.variants, self.substeps);
        Self::for_each_env(&self.pool, &mut self.envs, &mut self.state, |i, slot, mut rows| {
            if slot.paused {
                return;
            }
            let scene = &*variants[slot.variant];
            let row = &actions[i * nd..(i + 1) * nd];
            let d = &mut slot.data;
            for (c, &(k, map)) in d.ctrl_mut().iter_mut().zip(&scene.actuators) {
                *c = map.target((row[k] as f64).clamp(-1.0, 1.0));
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
        let (nd, no) = (self.num_dofs(), self.variants[0].objects.len());
        for (i, s) in states.iter().enumerate() {
            if mask[i] {
                check_reset_state(i, s, nd, no)?;
            }
        }
        let variants = &self.variants;
        Self::for_each_env(&self.pool, &mut self.envs, &mut self.state, |i, slot, mut rows| {
            if !mask[i] {
                return;
            }
            let scene = &*variants[slot.variant];
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

    /// Overwrite the raw MuJoCo `qpos`/`qvel` of environment `i` (same clearing as [`reset`](Self::reset)).
    pub fn set_qpos_qvel(&mut self, i: usize, qpos: &[f64], qvel: &[f64]) -> Result<(), SimError> {
        let n = self.num_envs();
        if i >= n {
            return Err(SimError::Config(format!(
                "environment index {i} out of range (num_envs = {n})"
            )));
        }
        let (nq, nv, _) = self.scene_of(i).sizes();
        check_len("qpos", qpos.len(), nq, || nq.to_string())?;
        check_len("qvel", qvel.len(), nv, || nv.to_string())?;
        if let Some(k) = qpos.iter().chain(qvel).position(|x| !x.is_finite()) {
            return Err(SimError::NonFinite { what: "qpos/qvel", env: i, index: k });
        }
        let variants = &self.variants;
        Self::for_each_env(&self.pool, &mut self.envs, &mut self.state, |j, slot, mut rows| {
            if j != i {
                return;
            }
            let scene = &*variants[slot.variant];
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
        let (b, d, c) = (st.bodies, st.dofs, st.character_bodies);
        pool.install(|| {
            (
                envs.par_iter_mut(),
                st.body_pos.par_chunks_mut(3 * b),
                st.body_quat.par_chunks_mut(4 * b),
                st.body_linvel.par_chunks_mut(3 * b),
                st.body_angvel.par_chunks_mut(3 * b),
                st.dof_pos.par_chunks_mut(d),
                st.dof_vel.par_chunks_mut(d),
                st.dof_force.par_chunks_mut(d),
                st.contact_force.par_chunks_mut(3 * b),
                st.contact_pairs.par_chunks_mut(NUM_CONTACT_PAIRS),
                st.touch.par_chunks_mut(c),
                st.unstable.par_iter_mut(),
            )
                .into_par_iter()
                .enumerate()
                .for_each(
                    |(i, (slot, bp, bq, blv, bav, dp, dv, df, cf, cp, touch, un))| {
                        let rows = Rows {
                            body_pos: bp,
                            body_quat: bq,
                            body_linvel: blv,
                            body_angvel: bav,
                            dof_pos: dp,
                            dof_vel: dv,
                            dof_force: df,
                            contact_force: cf,
                            contact_pairs: cp,
                            touch,
                            unstable: un,
                        };
                        f(i, slot, rows)
                    },
                );
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

fn check_reset_state(
    env: usize,
    s: &ResetState,
    dofs: usize,
    objects: usize,
) -> Result<(), SimError> {
    check_len("reset state dof_pos", s.dof_pos.len(), dofs, || dofs.to_string())?;
    check_len("reset state dof_vel", s.dof_vel.len(), dofs, || dofs.to_string())?;
    check_len("reset state objects", s.objects.len(), objects, || objects.to_string())?;
    let rq = s.root_quat.to_wxyz();
    let root = s.root_pos.iter().chain(&rq).chain(&s.root_linvel).chain(&s.root_angvel_local);
    let objs = s.objects.iter().flat_map(|o| {
        o.pos.into_iter().chain(o.quat.to_wxyz()).chain(o.linvel).chain(o.angvel_local)
    });
    let all =
        root.copied().chain(s.dof_pos.iter().copied()).chain(s.dof_vel.iter().copied()).chain(objs);
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
fn clear_bad_state(d: &mut Data) {
    for w in BAD_STATE {
        // SAFETY: the warning statistics are plain counters of mjData, read only by callers.
        unsafe { d.ffi_mut().warning[w as usize].number = 0 };
    }
}

/// Whether MuJoCo reported a bad state since [`clear_bad_state`] (the environment's `unstable`
/// flag). Clearing first, rather than comparing counts, also catches a repeat of the same
/// warning after MuJoCo's auto-reset set its counter back to 1.
fn bad_state(d: &Data) -> bool {
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
    let Some(r) = scene.bounce else { return };
    if r.threshold <= 0.0 {
        return;
    }
    let z = d.qpos()[r.z];
    let vz = &mut d.qvel_mut()[r.vz];
    b.apply(z, vz, r.radius, r.threshold);
}

fn write_reset_state(scene: &Scene, d: &mut Data, s: &ResetState) {
    clear_for_reset(d);
    let qpos = d.qpos_mut();
    if let Some(a) = scene.root_qpos {
        qpos[a..a + 3].copy_from_slice(&s.root_pos);
        qpos[a + 3..a + 7].copy_from_slice(&s.root_quat.normalized().to_wxyz());
    }
    for j in &scene.joints {
        let k = j.dof;
        if j.ball {
            let v = [s.dof_pos[k], s.dof_pos[k + 1], s.dof_pos[k + 2]];
            qpos[j.qpos..j.qpos + 4].copy_from_slice(&Quat::from_rotvec(v).to_wxyz());
        } else {
            qpos[j.qpos] = s.dof_pos[k];
        }
    }
    let qvel = d.qvel_mut();
    qvel.fill(0.0);
    if let Some(a) = scene.root_dof {
        qvel[a..a + 3].copy_from_slice(&s.root_linvel);
        qvel[a + 3..a + 6].copy_from_slice(&s.root_angvel_local);
    }
    for j in &scene.joints {
        let n = if j.ball { 3 } else { 1 };
        qvel[j.qvel..j.qvel + n].copy_from_slice(&s.dof_vel[j.dof..j.dof + n]);
    }
    for (o, addr) in s.objects.iter().zip(&scene.objects) {
        match *addr {
            ObjectAddr::Mocap(m) => {
                d.mocap_pos_mut()[m] = o.pos;
                d.mocap_quat_mut()[m] = o.quat.normalized().to_wxyz();
            }
            ObjectAddr::Free { qpos, qvel } => {
                let q = d.qpos_mut();
                q[qpos..qpos + 3].copy_from_slice(&o.pos);
                q[qpos + 3..qpos + 7].copy_from_slice(&o.quat.normalized().to_wxyz());
                let v = d.qvel_mut();
                v[qvel..qvel + 3].copy_from_slice(&o.linvel);
                v[qvel + 3..qvel + 6].copy_from_slice(&o.angvel_local);
            }
        }
    }
}
