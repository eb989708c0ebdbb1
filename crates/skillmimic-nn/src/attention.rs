//! Attention building blocks for the policy families to come (ModSkill's per-part attention,
//! TokenHSI's transformer over task tokens), on candle-nn.
//!
//! Conventions follow PyTorch so that weights move both ways by name:
//! * [`MultiHeadAttention`] = `nn.MultiheadAttention(E, H, batch_first=True)`: packed input
//!   projection `in_proj_weight` (3E, E) / `in_proj_bias` (3E) (query, key, value rows in that
//!   order), `out_proj.weight` (E, E) / `out_proj.bias` (E); scaled dot-product attention with
//!   scale 1/√(E/H); an optional key padding mask (B, S) where 1 marks a key to ignore.
//! * [`TransformerEncoderLayer`] = `nn.TransformerEncoderLayer(E, H, F, dropout=0,
//!   activation="relu", batch_first=True, norm_first=False)`: post-norm,
//!   x ← LN1(x + SA(x)); x ← LN2(x + W2 ReLU(W1 x)); names `self_attn.*`, `linear1.*`,
//!   `linear2.*`, `norm1.*`, `norm2.*`; LayerNorm ε 1e-5.
//!
//! Shapes: inputs (B, S, E) batch-first; dropout is not modelled (inference and PPO updates run
//! with dropout 0, as the reference policies do).

use candle_core::{D, Tensor};
use rand::Rng;

use crate::network::{NamedTensor, Network, prefixed};

/// Parameters of one dense layer `y = x Wᵀ + b`, PyTorch layout.
#[derive(Clone, Debug, PartialEq)]
pub struct Dense {
    pub out: usize,
    pub inp: usize,
    pub weight: Vec<f32>,
    pub bias: Vec<f32>,
}

impl Dense {
    /// PyTorch's default initialisation: weight and bias U(±1/√fan_in).
    pub fn new<R: Rng>(inp: usize, out: usize, rng: &mut R) -> Self {
        let b = 1.0 / (inp as f32).sqrt();
        Self {
            out,
            inp,
            weight: (0..out * inp).map(|_| rng.random_range(-b..b)).collect(),
            bias: (0..out).map(|_| rng.random_range(-b..b)).collect(),
        }
    }
    fn named(&self, prefix: &str) -> Vec<NamedTensor> {
        vec![
            NamedTensor {
                name: format!("{prefix}.weight"),
                shape: vec![self.out, self.inp],
                data: self.weight.clone(),
            },
            NamedTensor {
                name: format!("{prefix}.bias"),
                shape: vec![self.out],
                data: self.bias.clone(),
            },
        ]
    }
}

/// Multi-head self/cross attention (see the module doc for the layout).
#[derive(Clone, Debug, PartialEq)]
pub struct MultiHeadAttention {
    pub embed_dim: usize,
    pub num_heads: usize,
    /// `in_proj_weight` (3E, E) and `in_proj_bias` (3E).
    pub in_proj: Dense,
    pub out_proj: Dense,
}

impl MultiHeadAttention {
    /// A new layer with PyTorch-like initialisation; `embed_dim` must be a multiple of `num_heads`.
    pub fn new<R: Rng>(embed_dim: usize, num_heads: usize, rng: &mut R) -> Self {
        assert!(
            num_heads > 0 && embed_dim.is_multiple_of(num_heads),
            "embed_dim {embed_dim} is not a multiple of num_heads {num_heads}"
        );
        let mut in_proj = Dense::new(embed_dim, 3 * embed_dim, rng);
        in_proj.bias.fill(0.0);
        let mut out_proj = Dense::new(embed_dim, embed_dim, rng);
        out_proj.bias.fill(0.0);
        Self { embed_dim, num_heads, in_proj, out_proj }
    }

    /// Attention of queries `q` (B, L, E) over keys/values `kv` (B, S, E); `key_padding_mask`
    /// (B, S) with 1 = ignore that key. Returns (B, L, E).
    pub fn attend(
        &self,
        q: &Tensor,
        kv: &Tensor,
        key_padding_mask: Option<&Tensor>,
    ) -> candle_core::Result<Tensor> {
        let dev = q.device();
        let e = self.embed_dim;
        let p = [
            Tensor::from_slice(&self.in_proj.weight, (3 * e, e), dev)?,
            Tensor::from_slice(&self.in_proj.bias, 3 * e, dev)?,
            Tensor::from_slice(&self.out_proj.weight, (e, e), dev)?,
            Tensor::from_slice(&self.out_proj.bias, e, dev)?,
        ];
        mha(q, kv, &p, self.num_heads, key_padding_mask)
    }
}

/// `x Wᵀ + b` for `x` (B, n, in) or (B, in), `w` (out, in), `b` (out).
pub fn dense(x: &Tensor, w: &Tensor, b: &Tensor) -> candle_core::Result<Tensor> {
    x.broadcast_matmul(&w.t()?)?.broadcast_add(b)
}

/// Multi-head attention over parameter tensors `p` = [in_proj_weight (3E, E), in_proj_bias (3E),
/// out_proj.weight (E, E), out_proj.bias (E)] (PyTorch's packing; any of them may be a candle
/// `Var`, gradients flow): queries `q` (B, L, E), keys/values `kv` (B, S, E), `heads` heads of
/// width E/heads, scale 1/√(E/heads), optional key padding mask (B, S) float or integer with
/// nonzero = ignore (the score gets −1e30, which underflows to a zero weight as PyTorch's −∞
/// does). Softmax as exp/sum (differentiable). Returns (B, L, E).
pub fn mha(
    q: &Tensor,
    kv: &Tensor,
    p: &[Tensor],
    heads: usize,
    key_padding_mask: Option<&Tensor>,
) -> candle_core::Result<Tensor> {
    let e = p[2].dim(0)?;
    let hd = e / heads;
    let proj = |x: &Tensor, part: usize| -> candle_core::Result<Tensor> {
        let (bs, n, _) = x.dims3()?;
        dense(x, &p[0].narrow(0, part * e, e)?, &p[1].narrow(0, part * e, e)?)?
            .reshape((bs, n, heads, hd))?
            .transpose(1, 2)?
            .contiguous()
    };
    let (qh, kh, vh) = (proj(q, 0)?, proj(kv, 1)?, proj(kv, 2)?); // (B, H, n, hd)
    let mut scores = (qh.matmul(&kh.t()?.contiguous()?)? / (hd as f64).sqrt())?; // (B, H, L, S)
    if let Some(mask) = key_padding_mask {
        let (bs, s) = mask.dims2()?;
        let neg = mask
            .to_dtype(scores.dtype())?
            .ne(0.0)?
            .to_dtype(scores.dtype())?
            .affine(-1e30, 0.0)?
            .reshape((bs, 1, 1, s))?;
        scores = scores.broadcast_add(&neg)?;
    }
    let att = candle_nn::ops::softmax(&scores, D::Minus1)?;
    let y = att.matmul(&vh)?; // (B, H, L, hd)
    let (bs, _, l, _) = y.dims4()?;
    dense(&y.transpose(1, 2)?.reshape((bs, l, e))?, &p[2], &p[3])
}

/// LayerNorm over the last axis with weight `w` and bias `b` (ε [`LAYER_NORM_EPS`], biased
/// variance as PyTorch), written with differentiable candle ops.
pub fn layer_norm(x: &Tensor, w: &Tensor, b: &Tensor) -> candle_core::Result<Tensor> {
    let mean = x.mean_keepdim(D::Minus1)?;
    let xc = x.broadcast_sub(&mean)?;
    let var = xc.sqr()?.mean_keepdim(D::Minus1)?;
    xc.broadcast_div(&(var + LAYER_NORM_EPS)?.sqrt()?)?.broadcast_mul(w)?.broadcast_add(b)
}

/// A post-norm encoder layer over parameter tensors `p` in [`TransformerEncoderLayer`]'s
/// `state_dict` order (self_attn in_proj_weight, in_proj_bias, out_proj.weight, out_proj.bias,
/// linear1.weight, linear1.bias, linear2.weight, linear2.bias, norm1.weight, norm1.bias,
/// norm2.weight, norm2.bias): x ← LN1(x + SA(x)); x ← LN2(x + W2 ReLU(W1 x)). `x` (B, S, E).
pub fn encoder_layer(
    x: &Tensor,
    p: &[Tensor],
    heads: usize,
    key_padding_mask: Option<&Tensor>,
) -> candle_core::Result<Tensor> {
    let sa = mha(x, x, &p[0..4], heads, key_padding_mask)?;
    let x = layer_norm(&(x + sa)?, &p[8], &p[9])?;
    let ff = dense(&dense(&x, &p[4], &p[5])?.relu()?, &p[6], &p[7])?;
    layer_norm(&(x + ff)?, &p[10], &p[11])
}

impl Network for MultiHeadAttention {
    fn state_dict(&self) -> Vec<NamedTensor> {
        let mut v = vec![
            NamedTensor {
                name: "in_proj_weight".into(),
                shape: vec![3 * self.embed_dim, self.embed_dim],
                data: self.in_proj.weight.clone(),
            },
            NamedTensor {
                name: "in_proj_bias".into(),
                shape: vec![3 * self.embed_dim],
                data: self.in_proj.bias.clone(),
            },
        ];
        v.extend(self.out_proj.named("out_proj"));
        v
    }
    /// Self-attention of `x` (B, S, E) without a mask.
    fn forward(&self, x: &Tensor) -> candle_core::Result<Tensor> {
        self.attend(x, x, None)
    }
}

/// Post-norm transformer encoder layer (see the module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct TransformerEncoderLayer {
    pub self_attn: MultiHeadAttention,
    pub linear1: Dense,
    pub linear2: Dense,
    /// LayerNorm (weight, bias) pairs, each of width E.
    pub norm1: (Vec<f32>, Vec<f32>),
    pub norm2: (Vec<f32>, Vec<f32>),
}

/// LayerNorm epsilon of PyTorch's default.
pub const LAYER_NORM_EPS: f64 = 1e-5;

impl TransformerEncoderLayer {
    /// A new layer: width `embed_dim`, `num_heads` heads, feed-forward width `ff_dim`.
    pub fn new<R: Rng>(embed_dim: usize, num_heads: usize, ff_dim: usize, rng: &mut R) -> Self {
        let ones = || (vec![1.0; embed_dim], vec![0.0; embed_dim]);
        Self {
            self_attn: MultiHeadAttention::new(embed_dim, num_heads, rng),
            linear1: Dense::new(embed_dim, ff_dim, rng),
            linear2: Dense::new(ff_dim, embed_dim, rng),
            norm1: ones(),
            norm2: ones(),
        }
    }

    /// The layer on `x` (B, S, E) with an optional key padding mask (B, S), 1 = ignore.
    pub fn forward_masked(
        &self,
        x: &Tensor,
        key_padding_mask: Option<&Tensor>,
    ) -> candle_core::Result<Tensor> {
        let dev = x.device();
        let p = self
            .state_dict()
            .into_iter()
            .map(|t| Tensor::from_vec(t.data, t.shape, dev))
            .collect::<candle_core::Result<Vec<_>>>()?;
        encoder_layer(x, &p, self.self_attn.num_heads, key_padding_mask)
    }
}

impl Network for TransformerEncoderLayer {
    fn state_dict(&self) -> Vec<NamedTensor> {
        let mut v = prefixed("self_attn", self.self_attn.state_dict());
        v.extend(self.linear1.named("linear1"));
        v.extend(self.linear2.named("linear2"));
        for (name, p) in [("norm1", &self.norm1), ("norm2", &self.norm2)] {
            v.push(NamedTensor {
                name: format!("{name}.weight"),
                shape: vec![p.0.len()],
                data: p.0.clone(),
            });
            v.push(NamedTensor {
                name: format!("{name}.bias"),
                shape: vec![p.1.len()],
                data: p.1.clone(),
            });
        }
        v
    }
    fn forward(&self, x: &Tensor) -> candle_core::Result<Tensor> {
        self.forward_masked(x, None)
    }
}

/// Mean over the last axis ignoring nothing — a helper for token pooling: (B, S, E) → (B, E).
pub fn mean_pool(x: &Tensor) -> candle_core::Result<Tensor> {
    x.mean(D::Minus2)
}
