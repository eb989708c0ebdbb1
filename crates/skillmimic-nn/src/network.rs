//! The network seam: what every network of skillmimic-rs offers, whatever its architecture.
//!
//! A network owns float32 parameters that are named and shaped exactly like the `state_dict` of
//! its PyTorch mirror module (so a safetensors file written from [`Network::state_dict`] loads with
//! `module.load_state_dict`), and has a candle forward pass over those parameters (the definition
//! used for gradients and in tests; fast CPU paths of a network are checked against it).

use candle_core::Tensor;

/// One named parameter tensor in PyTorch layout (row-major, `shape` as PyTorch reports it).
#[derive(Clone, Debug, PartialEq)]
pub struct NamedTensor {
    pub name: String,
    pub shape: Vec<usize>,
    pub data: Vec<f32>,
}

/// A network with PyTorch-named parameters and a candle forward pass.
pub trait Network {
    /// Parameters in a fixed order with their `state_dict` names (without a module prefix).
    fn state_dict(&self) -> Vec<NamedTensor>;
    /// Forward pass with candle on `x` (the device of `x`); shapes are the network's own (an MLP
    /// maps (B, in) → (B, out), the history encoder (B, k, 316) → (B, μ)).
    fn forward(&self, x: &Tensor) -> candle_core::Result<Tensor>;
    /// Number of scalar parameters.
    fn num_parameters(&self) -> usize {
        self.state_dict().iter().map(|t| t.data.len()).sum()
    }
}

/// Prefix every name of a state dict (`"actor"` + `"0.weight"` → `"actor.0.weight"`).
pub fn prefixed(prefix: &str, tensors: Vec<NamedTensor>) -> Vec<NamedTensor> {
    tensors.into_iter().map(|t| NamedTensor { name: format!("{prefix}.{}", t.name), ..t }).collect()
}
