//! PPO (reference-facts §7): the minibatch ([`batch`]), the canonical loss with candle autograd
//! ([`loss`]), its fast specialisation for MLP and modular attention policies ([`fast`],
//! [`fast_modular`], tested equal to the canonical loss), one optimisation step ([`update`]) and
//! advantages ([`gae`]).
//!
//! Module dependencies point one way: `update` → `loss`, `fast` → `batch`, `fast` → `fast_modular`
//! → `mlp_grad` (the hand-written MLP gradient kernels both use).

pub mod batch;
pub mod fast;
pub mod fast_modular;
pub mod gae;
pub mod loss;
pub mod mlp_grad;
pub mod update;

pub use batch::{LossStats, Minibatch, RawMinibatch};
pub use loss::{Grads, device, loss_and_grads};
pub use update::{UpdateBuffers, update_minibatch};
