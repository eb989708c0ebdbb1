//! The actor network of a policy: any [`PolicyNet`] — an MLP (every `*_mlp` family), ModSkill's
//! modular attention network (`modular_attention`) or TokenHSI's token transformer
//! (`token_transformer*`), built by the policy family. The learner reaches it only through that
//! interface (parameters with their `state_dict` names, batched and candle forwards, what the
//! network declares); architecture-specific code (ONNX graphs, checkpoint descriptions,
//! adaptation) asks for the concrete type with [`ActorNet::downcast_ref`].

use candle_core::{Device, Tensor, Var};
use skillmimic_nn::mlp::Mlp;
use skillmimic_nn::policy_net::{FastGradient, PolicyNet, Scratch};

/// The actor network.
#[derive(Debug)]
pub struct ActorNet(Box<dyn PolicyNet>);

/// Buffers of [`ActorNet::forward_into`].
#[derive(Clone, Debug, Default)]
pub struct ActorWorkspace(Scratch);

impl Clone for ActorNet {
    fn clone(&self) -> Self {
        ActorNet(self.0.clone_box())
    }
}

impl PartialEq for ActorNet {
    fn eq(&self, o: &Self) -> bool {
        self.0.same_as(o.0.as_ref())
    }
}

impl<N: PolicyNet> From<N> for ActorNet {
    fn from(net: N) -> Self {
        ActorNet(Box::new(net))
    }
}

impl ActorNet {
    /// The network as its concrete type `N`, when it is one.
    pub fn downcast_ref<N: PolicyNet>(&self) -> Option<&N> {
        self.0.as_any().downcast_ref::<N>()
    }
    /// The network as its concrete type `N`, mutably, when it is one.
    pub fn downcast_mut<N: PolicyNet>(&mut self) -> Option<&mut N> {
        self.0.as_any_mut().downcast_mut::<N>()
    }
    /// Input width (the observation).
    pub fn input_dim(&self) -> usize {
        self.0.input_dim()
    }
    /// Output width (Gaussian means or logits).
    pub fn output_dim(&self) -> usize {
        self.0.output_dim()
    }
    /// The MLP, when the actor is one.
    pub fn as_mlp(&self) -> Option<&Mlp> {
        self.downcast_ref::<Mlp>()
    }
    /// The MLP, mutably, when the actor is one.
    pub fn as_mlp_mut(&mut self) -> Option<&mut Mlp> {
        self.0.as_any_mut().downcast_mut::<Mlp>()
    }
    /// Hidden widths of an MLP actor (`None` for the other networks).
    pub fn mlp_hidden(&self) -> Option<&[usize]> {
        self.as_mlp().map(|m| &m.dims[1..m.dims.len() - 1])
    }
    /// `(name, shape)` of every parameter under `prefix`, in [`ActorNet::params`] order.
    pub fn param_names(&self, prefix: &str) -> Vec<(String, Vec<usize>)> {
        self.0.param_names(prefix)
    }
    /// Parameters in optimiser order.
    pub fn params(&self) -> Vec<&[f32]> {
        self.0.params()
    }
    /// Mutable parameters in optimiser order.
    pub fn params_mut(&mut self) -> Vec<&mut Vec<f32>> {
        self.0.params_mut()
    }
    /// Batched inference of `n` normalised observation rows; returns `n × output_dim`.
    pub fn forward_into<'w>(
        &self,
        x: &[f32],
        n: usize,
        ws: &'w mut ActorWorkspace,
        threads: usize,
    ) -> &'w [f32] {
        self.0.forward_into(x, n, &mut ws.0, threads)
    }
    /// Candle variables of the parameters ([`ActorNet::params`] order).
    pub fn candle_vars(&self, dev: &Device) -> candle_core::Result<Vec<Var>> {
        self.0.candle_vars(dev)
    }
    /// Candle forward of `x` (B, input) through `vars`.
    pub fn candle_forward(&self, vars: &[Var], x: &Tensor) -> candle_core::Result<Tensor> {
        self.0.candle_forward(vars, x)
    }
    /// Tensors that are saved but not trained (`(name under prefix, shape, data)`; adaptation).
    pub fn frozen_tensors(&self, prefix: &str) -> Vec<(String, Vec<usize>, &[f32])> {
        self.0.frozen_tensors(prefix)
    }
    /// Observation columns the policy passes to the actor unnormalised (the token mask).
    pub fn raw_columns(&self) -> std::ops::Range<usize> {
        self.0.raw_columns()
    }
    /// Observation columns whose normaliser statistics stay fixed (adaptation).
    pub fn frozen_obs_columns(&self) -> &[usize] {
        self.0.frozen_obs_columns()
    }
    /// The hand-derived gradient of the fast update, when the network declares one.
    pub fn fast_gradient(&self) -> Option<FastGradient<'_>> {
        self.0.fast_gradient()
    }
}
