//! The actor network of a policy: an MLP (every `*_mlp` family) or ModSkill's modular attention
//! network (`modular_attention`). One interface for inference, the candle gradient graph, the
//! optimiser's parameter list and the checkpoint names.

use candle_core::{Device, Tensor, Var};
use skillmimic_nn::mlp::{Mlp, Workspace};
use skillmimic_nn::modular::{ModularAttention, ModularWorkspace};

/// The actor network.
#[derive(Clone, Debug, PartialEq)]
pub enum ActorNet {
    Mlp(Mlp),
    Modular(ModularAttention),
}

/// Buffers of [`ActorNet::forward_into`].
#[derive(Clone, Debug, Default)]
pub struct ActorWorkspace {
    mlp: Workspace,
    modular: ModularWorkspace,
}

impl ActorNet {
    /// Input width (the observation).
    pub fn input_dim(&self) -> usize {
        match self {
            ActorNet::Mlp(m) => m.input_dim(),
            ActorNet::Modular(m) => m.obs_dim,
        }
    }
    /// Output width (Gaussian means or logits).
    pub fn output_dim(&self) -> usize {
        match self {
            ActorNet::Mlp(m) => m.output_dim(),
            ActorNet::Modular(m) => m.act_dim,
        }
    }
    /// The MLP, when the actor is one.
    pub fn as_mlp(&self) -> Option<&Mlp> {
        match self {
            ActorNet::Mlp(m) => Some(m),
            ActorNet::Modular(_) => None,
        }
    }
    /// The MLP, mutably, when the actor is one.
    pub fn as_mlp_mut(&mut self) -> Option<&mut Mlp> {
        match self {
            ActorNet::Mlp(m) => Some(m),
            ActorNet::Modular(_) => None,
        }
    }
    /// Hidden widths of an MLP actor (`None` for the modular network).
    pub fn mlp_hidden(&self) -> Option<&[usize]> {
        self.as_mlp().map(|m| &m.dims[1..m.dims.len() - 1])
    }
    /// `(name, shape)` of every parameter under `prefix`, in [`ActorNet::params`] order.
    pub fn param_names(&self, prefix: &str) -> Vec<(String, Vec<usize>)> {
        match self {
            ActorNet::Mlp(m) => m.param_names(prefix),
            ActorNet::Modular(m) => m.param_names(prefix),
        }
    }
    /// Parameters in optimiser order.
    pub fn params(&self) -> Vec<&[f32]> {
        match self {
            ActorNet::Mlp(m) => m.params(),
            ActorNet::Modular(m) => m.params(),
        }
    }
    /// Mutable parameters in optimiser order.
    pub fn params_mut(&mut self) -> Vec<&mut Vec<f32>> {
        match self {
            ActorNet::Mlp(m) => m.params_mut(),
            ActorNet::Modular(m) => m.params_mut(),
        }
    }
    /// Batched inference of `n` normalised observation rows; returns `n × output_dim`.
    pub fn forward_into<'w>(&self, x: &[f32], n: usize, ws: &'w mut ActorWorkspace, threads: usize) -> &'w [f32] {
        match self {
            ActorNet::Mlp(m) => m.forward_into(x, n, &mut ws.mlp, threads),
            ActorNet::Modular(m) => m.forward_into(x, n, &mut ws.modular, threads),
        }
    }
    /// Candle variables of the parameters ([`ActorNet::params`] order).
    pub fn candle_vars(&self, dev: &Device) -> candle_core::Result<Vec<Var>> {
        match self {
            ActorNet::Mlp(m) => m.candle_vars(dev),
            ActorNet::Modular(m) => m.candle_vars(dev),
        }
    }
    /// Candle forward of `x` (B, input) through `vars`.
    pub fn candle_forward(&self, vars: &[Var], x: &Tensor) -> candle_core::Result<Tensor> {
        match self {
            ActorNet::Mlp(_) => Mlp::candle_forward(vars, x),
            ActorNet::Modular(m) => m.candle_forward(vars, x),
        }
    }
}
