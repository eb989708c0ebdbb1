//! The actor network of a policy: an MLP (every `*_mlp` family), ModSkill's modular attention
//! network (`modular_attention`) or TokenHSI's token transformer (`token_transformer*`). One
//! interface for inference, the candle gradient graph, the optimiser's parameter list and the
//! checkpoint names.

use candle_core::{Device, Tensor, Var};
use skillmimic_nn::mlp::{Mlp, Workspace};
use skillmimic_nn::modular::{ModularAttention, ModularWorkspace};
use skillmimic_nn::token::{TokenTransformer, TokenWorkspace};

/// The actor network.
#[derive(Clone, Debug, PartialEq)]
pub enum ActorNet {
    Mlp(Mlp),
    Modular(ModularAttention),
    Token(TokenTransformer),
}

/// Buffers of [`ActorNet::forward_into`].
#[derive(Clone, Debug, Default)]
pub struct ActorWorkspace {
    mlp: Workspace,
    modular: ModularWorkspace,
    token: TokenWorkspace,
}

impl ActorNet {
    /// Input width (the observation).
    pub fn input_dim(&self) -> usize {
        match self {
            ActorNet::Mlp(m) => m.input_dim(),
            ActorNet::Modular(m) => m.obs_dim,
            ActorNet::Token(t) => t.obs_dim(),
        }
    }
    /// Output width (Gaussian means or logits).
    pub fn output_dim(&self) -> usize {
        match self {
            ActorNet::Mlp(m) => m.output_dim(),
            ActorNet::Modular(m) => m.act_dim,
            ActorNet::Token(t) => t.act_dim,
        }
    }
    /// The MLP, when the actor is one.
    pub fn as_mlp(&self) -> Option<&Mlp> {
        match self {
            ActorNet::Mlp(m) => Some(m),
            _ => None,
        }
    }
    /// The MLP, mutably, when the actor is one.
    pub fn as_mlp_mut(&mut self) -> Option<&mut Mlp> {
        match self {
            ActorNet::Mlp(m) => Some(m),
            _ => None,
        }
    }
    /// Hidden widths of an MLP actor (`None` for the other networks).
    pub fn mlp_hidden(&self) -> Option<&[usize]> {
        self.as_mlp().map(|m| &m.dims[1..m.dims.len() - 1])
    }
    /// `(name, shape)` of every parameter under `prefix`, in [`ActorNet::params`] order.
    pub fn param_names(&self, prefix: &str) -> Vec<(String, Vec<usize>)> {
        match self {
            ActorNet::Mlp(m) => m.param_names(prefix),
            ActorNet::Modular(m) => m.param_names(prefix),
            ActorNet::Token(t) => t.param_names(prefix),
        }
    }
    /// Parameters in optimiser order.
    pub fn params(&self) -> Vec<&[f32]> {
        match self {
            ActorNet::Mlp(m) => m.params(),
            ActorNet::Modular(m) => m.params(),
            ActorNet::Token(t) => t.params(),
        }
    }
    /// Mutable parameters in optimiser order.
    pub fn params_mut(&mut self) -> Vec<&mut Vec<f32>> {
        match self {
            ActorNet::Mlp(m) => m.params_mut(),
            ActorNet::Modular(m) => m.params_mut(),
            ActorNet::Token(t) => t.params_mut(),
        }
    }
    /// Batched inference of `n` normalised observation rows; returns `n × output_dim`.
    pub fn forward_into<'w>(
        &self,
        x: &[f32],
        n: usize,
        ws: &'w mut ActorWorkspace,
        threads: usize,
    ) -> &'w [f32] {
        match self {
            ActorNet::Mlp(m) => m.forward_into(x, n, &mut ws.mlp, threads),
            ActorNet::Modular(m) => m.forward_into(x, n, &mut ws.modular, threads),
            ActorNet::Token(t) => t.forward_into(x, n, &mut ws.token),
        }
    }
    /// Candle variables of the parameters ([`ActorNet::params`] order).
    pub fn candle_vars(&self, dev: &Device) -> candle_core::Result<Vec<Var>> {
        match self {
            ActorNet::Mlp(m) => m.candle_vars(dev),
            ActorNet::Modular(m) => m.candle_vars(dev),
            ActorNet::Token(t) => t.candle_vars(dev),
        }
    }
    /// Candle forward of `x` (B, input) through `vars`.
    pub fn candle_forward(&self, vars: &[Var], x: &Tensor) -> candle_core::Result<Tensor> {
        match self {
            ActorNet::Mlp(_) => Mlp::candle_forward(vars, x),
            ActorNet::Modular(m) => m.candle_forward(vars, x),
            ActorNet::Token(t) => t.candle_forward(vars, x),
        }
    }
    /// Tensors that are saved but not trained (`(name under prefix, shape, data)`; adaptation).
    pub fn frozen_tensors(&self, prefix: &str) -> Vec<(String, Vec<usize>, &[f32])> {
        match self {
            ActorNet::Token(t) => t.frozen_tensors(prefix),
            _ => Vec::new(),
        }
    }
    /// Observation columns the policy passes to the actor unnormalised (the token mask).
    pub fn raw_columns(&self) -> std::ops::Range<usize> {
        match self {
            ActorNet::Token(t) => t.spec.mask_columns(),
            _ => 0..0,
        }
    }
    /// Observation columns whose normaliser statistics stay fixed (adaptation).
    pub fn frozen_obs_columns(&self) -> &[usize] {
        match self {
            ActorNet::Token(t) => &t.spec.frozen_obs,
            _ => &[],
        }
    }
}
