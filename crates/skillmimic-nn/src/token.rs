//! TokenHSI's token transformer actor (seed 004 §C–E; modskill-tokenhsi-facts §2.3, §2.5).
//!
//! **Observation** (B, obs_dim), already normalised by the policy except the mask entries (the
//! policy copies them raw), is a row of groups in column order: group 0 = the character's
//! proprioception (TokenHSI: 222), groups 1..G = task observations (one token each), then
//! `mask` entries, one per task group (0 = no mask block: every token attends).
//!
//! **Forward**:
//! * tokenizer g (an MLP `width_g → tokenizer… → E`, ReLU after **every** layer, the 64-wide
//!   token included — rl_games' MLP builder convention, which TokenHSI's network builder uses)
//!   turns group g into one token (B, E);
//! * the sequence is `[output token, token_0, token_1, …, token_{G-1}]` (B, 1+G, E); the output
//!   token is a learnable (1, 1, E) parameter (zero-initialised: its first query then pools the
//!   attended tokens uniformly — our choice); there is no positional embedding;
//! * key padding mask (B, 1+G): the output token and group 0 always attend; task token k is
//!   ignored where its mask entry is ≤ 0.5 (TokenHSI: from the task one-hot; a composition task
//!   sets several entries);
//! * `layers` post-norm encoder layers ([`crate::attention::encoder_layer`]: E, `heads` heads,
//!   feed-forward `feedforward`, ReLU, dropout 0) — PyTorch's `nn.TransformerEncoder` without
//!   a final norm;
//! * the encoded output token → the action head: hidden layers `head` (ReLU), each with an
//!   optional zero-initialised **adapter** `Linear` in parallel (adaptation, seed 004 §E:
//!   h_l = ReLU(W_l h + b_l + g (A_l h + c_l)), g = 1, or — with `adapter_gate` — the largest
//!   of the new task groups' mask entries, so base-task rows keep the base policy's actions),
//!   then the linear output `mu` (the Gaussian means, or logits for the categorical variant).
//!
//! **Parameters** in [`TokenTransformer::tensors`] order, named like the PyTorch mirror
//! `skillmimic_rs.policy.TokenTransformerActor`'s `state_dict`: `output_token` (1, 1, E);
//! `tokenizers.{g}.{0,2,4}.{weight,bias}`; `encoder.layers.{l}.{self_attn.in_proj_weight,
//! self_attn.in_proj_bias, self_attn.out_proj.*, linear1.*, linear2.*, norm1.*, norm2.*}`;
//! `head.{0,2}.*`; `adapters.{0,1}.*` (when present); `mu.*`.
//!
//! **Freezing** (adaptation): tensors named in `spec.frozen` are constants — not in
//! [`TokenTransformer::params`] (the optimiser's list) and not candle `Var`s, so no step can
//! change them; they are still saved and loaded with the checkpoint.

use candle_core::{Device, Tensor, Var};
use rand::Rng;

use crate::attention::{dense, encoder_layer};
use crate::network::{NamedTensor, Network};

/// The network description stored in a checkpoint's metadata `actor_net` (JSON).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TokenSpec {
    /// (name, width) of every observation group in column order; group 0 is always attended.
    pub groups: Vec<(String, usize)>,
    /// Mask entries after the groups: 0 or `groups.len() - 1` (one per task group, 1 = attend).
    pub mask: usize,
    /// Hidden widths of every tokenizer (TokenHSI: [256, 128]).
    pub tokenizer: Vec<usize>,
    /// Token width d_model (64).
    pub embed: usize,
    /// Encoder layers (4).
    pub layers: usize,
    /// Attention heads (2).
    pub heads: usize,
    /// Feed-forward width of each encoder layer (512).
    pub feedforward: usize,
    /// Hidden widths of the action head ([1024, 512]).
    pub head: Vec<usize>,
    /// Zero-initialised adapters parallel to the head's hidden layers (adaptation).
    pub adapters: bool,
    /// Mask entries that switch the adapters on: a row's adapters are multiplied by the largest
    /// of these entries (0/1), so rows of the base tasks (the new groups masked out) act exactly
    /// as the frozen base policy. Empty: adapters on for every row (the released code, which
    /// runs only the new task during adaptation).
    #[serde(default)]
    pub adapter_gate: Vec<usize>,
    /// Names of the frozen tensors (adaptation; empty = all train).
    #[serde(default)]
    pub frozen: Vec<String>,
    /// Observation columns whose normaliser statistics stay fixed (the frozen tokenizers'
    /// inputs; adaptation).
    #[serde(default)]
    pub frozen_obs: Vec<usize>,
}

impl TokenSpec {
    /// Observation width: the groups plus the mask.
    pub fn obs_dim(&self) -> usize {
        self.groups.iter().map(|g| g.1).sum::<usize>() + self.mask
    }
    /// First column of each group.
    pub fn offsets(&self) -> Vec<usize> {
        self.groups.iter().scan(0, |at, g| Some(std::mem::replace(at, *at + g.1))).collect()
    }
    /// Columns of the mask block (copied unnormalised by the policy).
    pub fn mask_columns(&self) -> std::ops::Range<usize> {
        let d = self.obs_dim();
        d - self.mask..d
    }
    /// Errors name what is inconsistent.
    pub fn check(&self) -> Result<(), String> {
        if self.groups.is_empty() || self.groups.iter().any(|g| g.1 == 0) {
            return Err(format!(
                "the token groups {:?} must be non-empty with positive widths (group 0: \
                    proprioception)",
                self.groups
            ));
        }
        if self.mask != 0 && self.mask + 1 != self.groups.len() {
            return Err(format!(
                "the mask has {} entries, expected one per task group ({})",
                self.mask,
                self.groups.len() - 1
            ));
        }
        if self.heads == 0 || !self.embed.is_multiple_of(self.heads) {
            return Err(format!(
                "token width {} is not a multiple of the {} heads",
                self.embed, self.heads
            ));
        }
        Ok(())
    }
    /// `(name, shape)` of every tensor in canonical order for `act_dim` outputs.
    pub fn layout(&self, act_dim: usize) -> Vec<(String, Vec<usize>)> {
        let (e, f) = (self.embed, self.feedforward);
        let mut v = vec![("output_token".to_string(), vec![1, 1, e])];
        let mlp = |prefix: &str, dims: &[usize], v: &mut Vec<(String, Vec<usize>)>| {
            for (l, w) in dims.windows(2).enumerate() {
                v.push((format!("{prefix}.{}.weight", 2 * l), vec![w[1], w[0]]));
                v.push((format!("{prefix}.{}.bias", 2 * l), vec![w[1]]));
            }
        };
        for (g, (_, w)) in self.groups.iter().enumerate() {
            let mut dims = vec![*w];
            dims.extend(&self.tokenizer);
            dims.push(e);
            mlp(&format!("tokenizers.{g}"), &dims, &mut v);
        }
        for l in 0..self.layers {
            let p = format!("encoder.layers.{l}");
            for (n, s) in [
                ("self_attn.in_proj_weight", vec![3 * e, e]),
                ("self_attn.in_proj_bias", vec![3 * e]),
                ("self_attn.out_proj.weight", vec![e, e]),
                ("self_attn.out_proj.bias", vec![e]),
                ("linear1.weight", vec![f, e]),
                ("linear1.bias", vec![f]),
                ("linear2.weight", vec![e, f]),
                ("linear2.bias", vec![e]),
                ("norm1.weight", vec![e]),
                ("norm1.bias", vec![e]),
                ("norm2.weight", vec![e]),
                ("norm2.bias", vec![e]),
            ] {
                v.push((format!("{p}.{n}"), s));
            }
        }
        let mut dims = vec![e];
        dims.extend(&self.head);
        mlp("head", &dims, &mut v);
        if self.adapters {
            for (l, w) in dims.windows(2).enumerate() {
                v.push((format!("adapters.{l}.weight"), vec![w[1], w[0]]));
                v.push((format!("adapters.{l}.bias"), vec![w[1]]));
            }
        }
        let last = *dims.last().unwrap();
        v.push(("mu.weight".to_string(), vec![act_dim, last]));
        v.push(("mu.bias".to_string(), vec![act_dim]));
        v
    }
}

/// The token transformer actor (see the module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct TokenTransformer {
    pub spec: TokenSpec,
    pub act_dim: usize,
    /// Every tensor in [`TokenSpec::layout`] order.
    pub tensors: Vec<NamedTensor>,
    /// Per tensor: trained (not in `spec.frozen`).
    pub trainable: Vec<bool>,
}

/// Buffers of [`TokenTransformer::forward_into`].
#[derive(Clone, Debug, Default)]
pub struct TokenWorkspace {
    out: Vec<f32>,
}

fn uniform<R: Rng + ?Sized>(n: usize, bound: f32, rng: &mut R) -> Vec<f32> {
    (0..n).map(|_| rng.random_range(-bound..bound)).collect()
}

impl TokenTransformer {
    /// A freshly initialised network: `Linear` layers of tokenizers, head and `mu` and the
    /// encoders' feed-forward layers get PyTorch's default U(±1/√fan_in) (weights and biases),
    /// the attention projections U(±1/√E) with zero biases, LayerNorms ones/zeros, the output
    /// token and the adapters zeros.
    pub fn new<R: Rng + ?Sized>(
        spec: TokenSpec,
        act_dim: usize,
        rng: &mut R,
    ) -> Result<Self, String> {
        spec.check()?;
        let layout = spec.layout(act_dim);
        let mut tensors = Vec::with_capacity(layout.len());
        let mut fan_in = 1usize;
        for (name, shape) in layout {
            let n: usize = shape.iter().product();
            let data = if name == "output_token"
                || name.starts_with("adapters.")
                || name.ends_with("_proj_bias")
                || name.ends_with("out_proj.bias")
                || name.ends_with("norm1.bias")
                || name.ends_with("norm2.bias")
            {
                vec![0.0; n]
            } else if name.ends_with("norm1.weight") || name.ends_with("norm2.weight") {
                vec![1.0; n]
            } else if name.ends_with("in_proj_weight") || name.ends_with("out_proj.weight") {
                uniform(n, 1.0 / (spec.embed as f32).sqrt(), rng)
            } else {
                if name.ends_with(".weight") {
                    fan_in = shape[1];
                }
                uniform(n, 1.0 / (fan_in as f32).sqrt(), rng)
            };
            tensors.push(NamedTensor { name, shape, data });
        }
        let trainable = tensors.iter().map(|t| !spec.frozen.contains(&t.name)).collect();
        Ok(Self { spec, act_dim, tensors, trainable })
    }

    /// Observation width.
    pub fn obs_dim(&self) -> usize {
        self.spec.obs_dim()
    }

    /// `(name, shape)` of the trained tensors under `prefix` ([`TokenTransformer::params`] order).
    pub fn param_names(&self, prefix: &str) -> Vec<(String, Vec<usize>)> {
        self.tensors
            .iter()
            .zip(&self.trainable)
            .filter(|&(_, &t)| t)
            .map(|(t, _)| (format!("{prefix}.{}", t.name), t.shape.clone()))
            .collect()
    }
    /// The trained tensors (the optimiser's list).
    pub fn params(&self) -> Vec<&[f32]> {
        self.tensors
            .iter()
            .zip(&self.trainable)
            .filter(|&(_, &t)| t)
            .map(|(t, _)| t.data.as_slice())
            .collect()
    }
    /// The trained tensors, mutably.
    pub fn params_mut(&mut self) -> Vec<&mut Vec<f32>> {
        self.tensors
            .iter_mut()
            .zip(&self.trainable)
            .filter(|&(_, &t)| t)
            .map(|(t, _)| &mut t.data)
            .collect()
    }
    /// The frozen tensors with their names under `prefix`.
    pub fn frozen_tensors(&self, prefix: &str) -> Vec<(String, Vec<usize>, &[f32])> {
        self.tensors
            .iter()
            .zip(&self.trainable)
            .filter(|&(_, &t)| !t)
            .map(|(t, _)| (format!("{prefix}.{}", t.name), t.shape.clone(), t.data.as_slice()))
            .collect()
    }

    /// Candle variables of the trained tensors.
    pub fn candle_vars(&self, dev: &Device) -> candle_core::Result<Vec<Var>> {
        self.tensors
            .iter()
            .zip(&self.trainable)
            .filter(|&(_, &t)| t)
            .map(|(t, _)| Var::from_tensor(&Tensor::from_slice(&t.data, t.shape.as_slice(), dev)?))
            .collect()
    }

    /// Candle forward of `x` (B, obs_dim) → (B, act_dim), the trained tensors taken from `vars`
    /// ([`TokenTransformer::candle_vars`]; gradients flow into them), the frozen ones constants.
    pub fn candle_forward(&self, vars: &[Var], x: &Tensor) -> candle_core::Result<Tensor> {
        let dev = x.device();
        let mut vi = vars.iter();
        let all = self
            .tensors
            .iter()
            .zip(&self.trainable)
            .map(|(t, &tr)| match tr {
                true => Ok(vi.next().expect("one variable per trained tensor").as_tensor().clone()),
                false => Tensor::from_slice(&t.data, t.shape.as_slice(), dev),
            })
            .collect::<candle_core::Result<Vec<_>>>()?;
        self.forward_tensors(&all, x)
    }

    /// The forward pass over every tensor `p` in canonical order.
    fn forward_tensors(&self, p: &[Tensor], x: &Tensor) -> candle_core::Result<Tensor> {
        let s = &self.spec;
        let b = x.dim(0)?;
        let mut at = 1; // after output_token
        let mut seq =
            vec![p[0].reshape((1, 1, s.embed))?.broadcast_as((b, 1, s.embed))?.contiguous()?];
        let layers_per_mlp = s.tokenizer.len() + 1;
        for ((_, w), off) in s.groups.iter().zip(s.offsets()) {
            let mut h = x.narrow(1, off, *w)?;
            for _ in 0..layers_per_mlp {
                h = dense(&h, &p[at], &p[at + 1])?.relu()?;
                at += 2;
            }
            seq.push(h.unsqueeze(1)?);
        }
        let mut z = Tensor::cat(&seq, 1)?;
        let mask = if s.mask > 0 {
            let ignore = x.narrow(1, s.obs_dim() - s.mask, s.mask)?.le(0.5)?.to_dtype(x.dtype())?;
            Some(Tensor::cat(&[Tensor::zeros((b, 2), x.dtype(), x.device())?, ignore], 1)?)
        } else {
            None
        };
        for _ in 0..s.layers {
            z = encoder_layer(&z, &p[at..at + 12], s.heads, mask.as_ref())?;
            at += 12;
        }
        let mut h = z.narrow(1, 0, 1)?.squeeze(1)?;
        let nh = s.head.len();
        let gate =
            match (s.adapters && !s.adapter_gate.is_empty() && s.mask > 0, s.obs_dim() - s.mask) {
                (true, at) => {
                    let cols = s
                        .adapter_gate
                        .iter()
                        .map(|&k| x.narrow(1, at + k, 1))
                        .collect::<candle_core::Result<Vec<_>>>()?;
                    Some(Tensor::cat(&cols, 1)?.max_keepdim(1)?)
                }
                (false, _) => None,
            };
        let adapters = if s.adapters { at + 2 * nh } else { at };
        for l in 0..nh {
            let mut y = dense(&h, &p[at + 2 * l], &p[at + 2 * l + 1])?;
            if s.adapters {
                let a = dense(&h, &p[adapters + 2 * l], &p[adapters + 2 * l + 1])?;
                y = match &gate {
                    Some(g) => (y + a.broadcast_mul(g)?)?,
                    None => (y + a)?,
                };
            }
            h = y.relu()?;
        }
        let mu = if s.adapters { adapters + 2 * nh } else { at + 2 * nh };
        dense(&h, &p[mu], &p[mu + 1])
    }

    /// Batched inference of `n` rows of `x` (`n × obs_dim`; normalised, mask raw) on the CPU;
    /// returns `n × act_dim`. Runs the candle graph (the transformer is small; the tensors are
    /// copied into candle each call).
    pub fn forward_into<'w>(&self, x: &[f32], n: usize, ws: &'w mut TokenWorkspace) -> &'w [f32] {
        let d = self.obs_dim();
        let run = || -> candle_core::Result<Vec<f32>> {
            let dev = Device::Cpu;
            let all = self
                .tensors
                .iter()
                .map(|t| Tensor::from_slice(&t.data, t.shape.as_slice(), &dev))
                .collect::<candle_core::Result<Vec<_>>>()?;
            let xt = Tensor::from_slice(&x[..n * d], (n, d), &dev)?;
            self.forward_tensors(&all, &xt)?.flatten_all()?.to_vec1()
        };
        // shapes are fixed by construction; a failure here is a programming error
        ws.out = run().expect("token transformer forward on the CPU");
        &ws.out[..n * self.act_dim]
    }
}

impl Network for TokenTransformer {
    fn state_dict(&self) -> Vec<NamedTensor> {
        self.tensors.clone()
    }
    fn forward(&self, x: &Tensor) -> candle_core::Result<Tensor> {
        let all = self
            .tensors
            .iter()
            .map(|t| Tensor::from_slice(&t.data, t.shape.as_slice(), x.device()))
            .collect::<candle_core::Result<Vec<_>>>()?;
        self.forward_tensors(&all, x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    pub(crate) fn small(adapters: bool) -> TokenSpec {
        TokenSpec {
            groups: vec![("proprio".into(), 7), ("a".into(), 3), ("b".into(), 4)],
            mask: 2,
            tokenizer: vec![12, 10],
            embed: 8,
            layers: 2,
            heads: 2,
            feedforward: 16,
            head: vec![20, 14],
            adapters,
            adapter_gate: Vec::new(),
            frozen: Vec::new(),
            frozen_obs: Vec::new(),
        }
    }

    #[test]
    fn masked_task_tokens_do_not_change_the_output() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let net = TokenTransformer::new(small(false), 5, &mut rng).unwrap();
        let d = net.obs_dim();
        assert_eq!(d, 16);
        let mut x: Vec<f32> = (0..2 * d).map(|i| ((i * 31 % 17) as f32 - 8.0) * 0.2).collect();
        // row 0 and row 1 share proprioception and group a; only a attends
        x.copy_within(0..d, d);
        x[14] = 1.0;
        x[15] = 0.0;
        x[d + 14] = 1.0;
        x[d + 15] = 0.0;
        for c in 10..14 {
            x[d + c] += 3.0; // group b differs but is masked
        }
        let y = net.forward_into(&x, 2, &mut TokenWorkspace::default()).to_vec();
        assert!(y[..5].iter().zip(&y[5..]).all(|(a, b)| (a - b).abs() < 1e-6), "{y:?}");
        x[d + 15] = 1.0; // now b attends: the output changes
        let y2 = net.forward_into(&x, 2, &mut TokenWorkspace::default()).to_vec();
        assert!(y2[..5].iter().zip(&y2[5..]).any(|(a, b)| (a - b).abs() > 1e-4));
    }

    #[test]
    fn frozen_tensors_are_not_parameters() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut spec = small(true);
        let all = TokenTransformer::new(spec.clone(), 5, &mut rng).unwrap();
        spec.frozen = all
            .tensors
            .iter()
            .filter(|t| !t.name.starts_with("adapters."))
            .map(|t| t.name.clone())
            .collect();
        let net = TokenTransformer::new(spec, 5, &mut rng).unwrap();
        let names: Vec<String> = net.param_names("actor").into_iter().map(|n| n.0).collect();
        assert_eq!(
            names,
            [
                "actor.adapters.0.weight",
                "actor.adapters.0.bias",
                "actor.adapters.1.weight",
                "actor.adapters.1.bias"
            ]
        );
        assert_eq!(net.frozen_tensors("actor").len() + 4, net.tensors.len());
        let x = Tensor::from_slice(&[0.5f32; 16], (1, 16), &Device::Cpu).unwrap();
        let vars = net.candle_vars(&Device::Cpu).unwrap();
        assert_eq!(vars.len(), 4);
        let y = net.candle_forward(&vars, &x).unwrap();
        let g = y.sum_all().unwrap().backward().unwrap();
        assert!(vars.iter().all(|v| g.get(v).is_some()));
    }
}
