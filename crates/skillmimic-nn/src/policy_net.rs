//! The interface a learner trains a policy network through, whatever its architecture: the
//! parameters with their PyTorch `state_dict` names (under a module prefix such as `actor`), the
//! fast batched forward for inference, and the candle forward over variables in the same order
//! for gradients. The MLP, ModSkill's modular attention network and TokenHSI's token transformer
//! implement it here; a learner holds a `Box<dyn PolicyNet>` and never matches on the kind.
//!
//! What a network can declare beyond that: observation columns it takes unnormalised
//! ([`PolicyNet::raw_columns`]), tensors saved but not trained ([`PolicyNet::frozen_tensors`]),
//! observation columns whose normaliser statistics stay fixed, and the hand-derived gradient the
//! fast PPO update has for it ([`PolicyNet::fast_gradient`]).

use std::any::Any;
use std::ops::Range;

use candle_core::{Device, Tensor, Var};

use crate::mlp::{Mlp, Workspace};
use crate::modular::{ModularAttention, ModularWorkspace};
use crate::token::{TokenTransformer, TokenWorkspace};

/// Scratch buffers of a network's batched forward, created by the network on first use (each
/// architecture keeps its own kind). Cloning gives fresh, empty scratch.
#[derive(Default)]
pub struct Scratch(Option<Box<dyn Any + Send + Sync>>);

impl Scratch {
    /// The scratch as `W`, created (or replaced, when it held another kind) on first use.
    pub fn get<W: Default + Send + Sync + 'static>(&mut self) -> &mut W {
        if !self.0.as_ref().is_some_and(|b| b.is::<W>()) {
            self.0 = Some(Box::new(W::default()));
        }
        self.0.as_mut().and_then(|b| b.downcast_mut::<W>()).expect("just created")
    }
}

impl Clone for Scratch {
    fn clone(&self) -> Self {
        Scratch(None)
    }
}

impl std::fmt::Debug for Scratch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Scratch")
    }
}

/// A hand-derived gradient of the fast PPO update (`skillmimic_learn::ppo::fast`): the network
/// declares which one computes its backward pass.
#[derive(Clone, Copy, Debug)]
pub enum FastGradient<'a> {
    /// ReLU MLP (`ppo::mlp_grad`).
    Mlp(&'a Mlp),
    /// Modular attention (`ppo::fast_modular`).
    Modular(&'a ModularAttention),
}

/// A trainable policy network (see the module doc).
pub trait PolicyNet: NetObject + Any + Send + Sync + std::fmt::Debug {
    /// Input width (the observation).
    fn input_dim(&self) -> usize;
    /// Output width (Gaussian means or logits).
    fn output_dim(&self) -> usize;
    /// `(state_dict name under prefix, shape)` of every trained parameter, in
    /// [`PolicyNet::params`] order (`actor.0.weight`, …).
    fn param_names(&self, prefix: &str) -> Vec<(String, Vec<usize>)>;
    /// Trained parameters (row-major, PyTorch layout).
    fn params(&self) -> Vec<&[f32]>;
    fn params_mut(&mut self) -> Vec<&mut Vec<f32>>;
    /// Batched forward of `n` normalised rows of `x`; returns `n × output_dim`.
    fn forward_into<'w>(
        &self,
        x: &[f32],
        n: usize,
        scratch: &'w mut Scratch,
        threads: usize,
    ) -> &'w [f32];
    /// Candle variables of the parameters ([`PolicyNet::params`] order).
    fn candle_vars(&self, dev: &Device) -> candle_core::Result<Vec<Var>>;
    /// Candle forward of `x` (B, input) through `vars`.
    fn candle_forward(&self, vars: &[Var], x: &Tensor) -> candle_core::Result<Tensor>;
    /// Tensors saved with the network but not trained (`(name under prefix, shape, data)`).
    fn frozen_tensors(&self, _prefix: &str) -> Vec<(String, Vec<usize>, &[f32])> {
        Vec::new()
    }
    /// Observation columns passed to the network unnormalised.
    fn raw_columns(&self) -> Range<usize> {
        0..0
    }
    /// Observation columns whose normaliser statistics stay fixed while training.
    fn frozen_obs_columns(&self) -> &[usize] {
        &[]
    }
    /// The hand-derived gradient of the fast update for this network, if it has one.
    fn fast_gradient(&self) -> Option<FastGradient<'_>> {
        None
    }
}

/// What a boxed network needs besides its architecture (comparison, cloning, downcasts); every
/// `PolicyNet + Clone + PartialEq` has it.
pub trait NetObject {
    /// Whether `other` is the same network with the same parameters.
    fn same_as(&self, other: &dyn PolicyNet) -> bool;
    fn clone_box(&self) -> Box<dyn PolicyNet>;
    fn as_any(&self) -> &dyn Any;
    fn as_any_mut(&mut self) -> &mut dyn Any;
}

impl<T: PolicyNet + Clone + PartialEq> NetObject for T {
    fn same_as(&self, other: &dyn PolicyNet) -> bool {
        other.as_any().downcast_ref::<T>() == Some(self)
    }
    fn clone_box(&self) -> Box<dyn PolicyNet> {
        Box::new(self.clone())
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

impl PolicyNet for Mlp {
    fn input_dim(&self) -> usize {
        Mlp::input_dim(self)
    }
    fn output_dim(&self) -> usize {
        Mlp::output_dim(self)
    }
    fn param_names(&self, prefix: &str) -> Vec<(String, Vec<usize>)> {
        Mlp::param_names(self, prefix)
    }
    fn params(&self) -> Vec<&[f32]> {
        Mlp::params(self)
    }
    fn params_mut(&mut self) -> Vec<&mut Vec<f32>> {
        Mlp::params_mut(self)
    }
    fn forward_into<'w>(
        &self,
        x: &[f32],
        n: usize,
        s: &'w mut Scratch,
        threads: usize,
    ) -> &'w [f32] {
        Mlp::forward_into(self, x, n, s.get::<Workspace>(), threads)
    }
    fn candle_vars(&self, dev: &Device) -> candle_core::Result<Vec<Var>> {
        Mlp::candle_vars(self, dev)
    }
    fn candle_forward(&self, vars: &[Var], x: &Tensor) -> candle_core::Result<Tensor> {
        Mlp::candle_forward(vars, x)
    }
    fn fast_gradient(&self) -> Option<FastGradient<'_>> {
        Some(FastGradient::Mlp(self))
    }
}

impl PolicyNet for ModularAttention {
    fn input_dim(&self) -> usize {
        self.obs_dim
    }
    fn output_dim(&self) -> usize {
        self.act_dim
    }
    fn param_names(&self, prefix: &str) -> Vec<(String, Vec<usize>)> {
        ModularAttention::param_names(self, prefix)
    }
    fn params(&self) -> Vec<&[f32]> {
        ModularAttention::params(self)
    }
    fn params_mut(&mut self) -> Vec<&mut Vec<f32>> {
        ModularAttention::params_mut(self)
    }
    fn forward_into<'w>(
        &self,
        x: &[f32],
        n: usize,
        s: &'w mut Scratch,
        threads: usize,
    ) -> &'w [f32] {
        ModularAttention::forward_into(self, x, n, s.get::<ModularWorkspace>(), threads)
    }
    fn candle_vars(&self, dev: &Device) -> candle_core::Result<Vec<Var>> {
        ModularAttention::candle_vars(self, dev)
    }
    fn candle_forward(&self, vars: &[Var], x: &Tensor) -> candle_core::Result<Tensor> {
        ModularAttention::candle_forward(self, vars, x)
    }
    fn fast_gradient(&self) -> Option<FastGradient<'_>> {
        Some(FastGradient::Modular(self))
    }
}

impl PolicyNet for TokenTransformer {
    fn input_dim(&self) -> usize {
        self.obs_dim()
    }
    fn output_dim(&self) -> usize {
        self.act_dim
    }
    fn param_names(&self, prefix: &str) -> Vec<(String, Vec<usize>)> {
        TokenTransformer::param_names(self, prefix)
    }
    fn params(&self) -> Vec<&[f32]> {
        TokenTransformer::params(self)
    }
    fn params_mut(&mut self) -> Vec<&mut Vec<f32>> {
        TokenTransformer::params_mut(self)
    }
    /// (Single-threaded: the token forward parallelises inside its attention kernels.)
    fn forward_into<'w>(
        &self,
        x: &[f32],
        n: usize,
        s: &'w mut Scratch,
        _threads: usize,
    ) -> &'w [f32] {
        TokenTransformer::forward_into(self, x, n, s.get::<TokenWorkspace>())
    }
    fn candle_vars(&self, dev: &Device) -> candle_core::Result<Vec<Var>> {
        TokenTransformer::candle_vars(self, dev)
    }
    fn candle_forward(&self, vars: &[Var], x: &Tensor) -> candle_core::Result<Tensor> {
        TokenTransformer::candle_forward(self, vars, x)
    }
    fn frozen_tensors(&self, prefix: &str) -> Vec<(String, Vec<usize>, &[f32])> {
        TokenTransformer::frozen_tensors(self, prefix)
    }
    /// The task mask.
    fn raw_columns(&self) -> Range<usize> {
        self.spec.mask_columns()
    }
    fn frozen_obs_columns(&self) -> &[usize] {
        &self.spec.frozen_obs
    }
}
