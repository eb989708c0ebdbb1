//! Simulation layer of skillmimic-rs: one stack for every character.
//!
//! * [`mjcf`]: the MJCF generator — a character (`skillmimic_core::characters`) plus the ball,
//!   box objects and props a task asks for, with the modelling choices documented;
//! * [`ball`]: the basketball's parameters and its PhysX-like restitution;
//! * [`scene`]: a compiled scene and its index tables (character body → MuJoCo ids, joint
//!   addresses, actuator → dof and action map, geom owners, objects);
//! * [`batch`]: N environments stepped in parallel with rayon (PD targets, sub-steps, state and
//!   contact read-out into contiguous buffers, resets), deterministic for any thread count;
//! * [`state`], [`contacts`]: the read-out layout and the contact-pair kinds;
//! * [`snapshot`]: the whole simulation state of a batch, saved and restored bit for bit (exact
//!   resume of training);
//! * [`bounce`]: PhysX's ball bounce threshold; [`memory`]: the memory check before a batch is
//!   allocated; [`mj_batch`]: raw MuJoCo access.

pub mod ball;
pub mod batch;
pub mod bounce;
pub mod contacts;
pub mod error;
pub mod memory;
pub mod mj_batch;
pub mod mjcf;
pub mod pause;
mod readout;
pub mod scene;
pub mod scene_options;
pub mod snapshot;
pub mod state;

pub use ball::{BallParams, BodyContact};
pub use batch::BatchSim;
pub use contacts::{ContactPair, NUM_CONTACT_PAIRS};
pub use error::SimError;
pub use mj_batch::MjBatch;
pub use mjcf::{
    BoxObject, ObjectBox, Prop, PropKind, RootJoint, SceneOptions, Solver, SolverOptions,
};
pub use scene::{BALL, NUM_STATE_BODIES, Scene};
pub use skillmimic_core::characters::{Character, HandModel};
pub use snapshot::SimSnapshot;
pub use state::{BatchState, EnvState, ObjectState, ResetState};
