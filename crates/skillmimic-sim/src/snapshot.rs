//! The whole simulation state of a batch, for a resume that continues bit for bit.
//!
//! What a later [`BatchSim::step`] depends on, per environment:
//! * MuJoCo's integration state (`mjSTATE_INTEGRATION`: time, `qpos`, `qvel`, actuator
//!   activations, the solver's warm start `qacc_warmstart`, controls, applied forces, mocap and
//!   equality flags, user and plugin data) — what MuJoCo documents as needed to reproduce
//!   `mj_step`;
//! * the position/velocity stages of that state, which [`BatchSim::step`] expects to be computed
//!   (it starts with `mj_step2`): a restore recomputes them with `mj_step1`, a pure function of
//!   the state, as the step that produced the state did;
//! * the floor bounce rule's state ([`crate::bounce`]);
//! * the read-out buffers ([`BatchState`]): their contacts and forces are those of the last
//!   physics sub-step, which the state alone does not determine, so they are saved as they are.
//!
//! A snapshot is plain data (serde); the layers above encode it with the rest of a training
//! run's state.

use serde::{Deserialize, Serialize};

use crate::batch::BatchSim;
use crate::bounce::BounceState;
use crate::error::SimError;
use crate::state::BatchState;

/// MuJoCo's state signature saved per environment.
const SIGNATURE: u32 = mujoco_rs::mujoco_c::mjtState::mjSTATE_INTEGRATION as u32;

/// The saved state of a [`BatchSim`] (see the module doc).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SimSnapshot {
    /// Values of MuJoCo's integration state per environment (`mj_stateSize` of the signature).
    pub state_size: usize,
    /// `[N][state_size]`, environment-major.
    pub mujoco: Vec<f64>,
    /// The bounce rule's state per environment.
    pub bounce: Vec<BounceState>,
    /// Physics sub-steps per policy step.
    pub substeps: usize,
    /// The read-out buffers of the last step or reset.
    pub readout: BatchState,
}

impl BatchSim {
    /// The batch's state (see the module doc).
    pub fn snapshot(&self) -> SimSnapshot {
        let size = self.envs.first().map_or(0, |e| e.data.model().state_size(SIGNATURE));
        let mut mujoco = vec![0.0; self.envs.len() * size];
        for (e, row) in self.envs.iter().zip(mujoco.chunks_exact_mut(size.max(1))) {
            e.data.read_state_into(SIGNATURE, row);
        }
        SimSnapshot {
            state_size: size,
            mujoco,
            bounce: self.envs.iter().map(|e| e.bounce).collect(),
            substeps: self.substeps(),
            readout: self.state.clone(),
        }
    }

    /// Restore a [`snapshot`](Self::snapshot) of a batch of the same scene and size; a snapshot
    /// of another batch (environments, state layout, read-out widths) is an error naming what
    /// differs, and leaves this batch unchanged.
    pub fn restore(&mut self, s: &SimSnapshot) -> Result<(), SimError> {
        let n = self.envs.len();
        let size = self.envs.first().map_or(0, |e| e.data.model().state_size(SIGNATURE));
        let r = &s.readout;
        let st = &self.state;
        let checks = [
            ("environments", s.bounce.len(), n),
            ("MuJoCo state values per environment", s.state_size, size),
            ("MuJoCo state values", s.mujoco.len(), n * size),
            ("read-out environments", r.num_envs, st.num_envs),
            ("read-out bodies", r.bodies, st.bodies),
            ("read-out character bodies", r.character_bodies, st.character_bodies),
            ("read-out dofs", r.dofs, st.dofs),
            ("read-out positions", r.body_pos.len(), st.body_pos.len()),
            ("read-out rotations", r.body_quat.len(), st.body_quat.len()),
            ("read-out linear velocities", r.body_linvel.len(), st.body_linvel.len()),
            ("read-out angular velocities", r.body_angvel.len(), st.body_angvel.len()),
            ("read-out dof positions", r.dof_pos.len(), st.dof_pos.len()),
            ("read-out dof velocities", r.dof_vel.len(), st.dof_vel.len()),
            ("read-out dof forces", r.dof_force.len(), st.dof_force.len()),
            ("read-out contact forces", r.contact_force.len(), st.contact_force.len()),
            ("read-out contact pairs", r.contact_pairs.len(), st.contact_pairs.len()),
            ("read-out touches", r.touch.len(), st.touch.len()),
            ("read-out instability flags", r.unstable.len(), st.unstable.len()),
        ];
        for (what, got, want) in checks {
            if got != want {
                return Err(SimError::Config(format!(
                    "saved simulation state: {what} {got}, this batch has {want}"
                )));
            }
        }
        if let Some(k) = s.mujoco.iter().position(|x| !x.is_finite()) {
            return Err(SimError::NonFinite {
                what: "saved MuJoCo state",
                env: k / size,
                index: k % size,
            });
        }
        self.set_substeps(s.substeps)?;
        for ((e, row), b) in
            self.envs.iter_mut().zip(s.mujoco.chunks_exact(size.max(1))).zip(&s.bounce)
        {
            e.data
                .set_state(row, SIGNATURE)
                .map_err(|x| SimError::Config(format!("saved MuJoCo state: {x}")))?;
            e.data.step1();
            e.bounce = *b;
        }
        self.state.clone_from(r);
        Ok(())
    }
}
