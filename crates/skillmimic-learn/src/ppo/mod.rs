//! PPO (reference-facts §7): the minibatch ([`batch`]), the canonical loss with candle autograd
//! ([`loss`]), its fast specialisation for MLP policies ([`fast`], tested equal to the canonical
//! loss), one optimisation step ([`update`]) and advantages ([`gae`]).
//!
//! Module dependencies point one way: `update` → `loss`, `fast` → `batch`.

pub mod batch;
pub mod fast;
pub mod gae;
pub mod loss;
pub mod update;

pub use batch::{LossStats, Minibatch, RawMinibatch};
pub use loss::{Grads, device, loss_and_grads};
pub use update::{UpdateBuffers, update_minibatch};
