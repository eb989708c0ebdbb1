//! Simulation layer of skillmimic-rs.
//!
//! * [`mjcf`]: generator of the humanoid + ball MJCF (full or box hands), with the modelling
//!   choices documented;
//! * [`scene`]: a compiled scene and its index tables (skeleton body → MuJoCo ids, joint
//!   addresses, actuator → action index, geom owners);
//! * [`batch`]: N environments stepped in parallel with rayon (PD targets, sub-steps, state and
//!   contact read-out into contiguous buffers, resets), deterministic for any thread count;
//! * [`hsi_mjcf`], [`hsi_scene`], [`hsi_batch`]: the same three layers for the TokenHSI
//!   character (15 bodies, 32 dofs) and its task objects;
//! * [`state`], [`contacts`]: the read-out layout and the contact-pair kinds.

pub mod batch;
pub mod bounce;
pub mod contacts;
pub mod error;
pub mod hsi_batch;
pub mod hsi_mjcf;
pub mod hsi_scene;
pub mod memory;
pub mod mj_batch;
pub mod mjcf;
pub mod scene;
pub mod state;

pub use batch::BatchSim;
pub use contacts::{ContactPair, NUM_CONTACT_PAIRS};
pub use error::SimError;
pub use hsi_batch::{HsiBatch, HsiEnvState, HsiReset, HsiState, ObjectState};
pub use hsi_mjcf::{HsiObject, ObjectBox};
pub use hsi_scene::{HsiScene, MAX_OBJECTS};
pub use mj_batch::MjBatch;
pub use mjcf::{
    BallParams, BodyContact, HandModel, RootJoint, SceneOptions, Solver, SolverOptions,
};
pub use scene::{BALL, NUM_STATE_BODIES, Scene};
pub use state::{BatchState, EnvState, ResetState};
