//! ModSkill's modular attention actor (seed 001 §3.2, Eq. 5; modskill-tokenhsi-facts §1.3–1.4).
//!
//! The body is split into P parts. Part k reads its own observation columns `inputs[k]` (the
//! token x_k, width in_k) and drives its own action entries `outputs[k]`:
//!
//! * projections, one set per part (input widths differ): q_k = Q2_k(Q1_k(x_k)), likewise k_k and
//!   v_k, each `Linear(in_k → proj) → Linear(proj → E)` with **no** activation between
//!   (`nn.Sequential(Linear, Linear)`, names `parts.{k}.q.0.*`, `parts.{k}.q.1.*`);
//! * attention over the P part tokens: with H heads of width E/H, for every query part i,
//!   a_ij = softmax_j(q_i · k_j · s) and z_i = Σ_j a_ij v_j, heads concatenated; s = 1/√(E/H) when
//!   `scaled` (the paper's Eq. 5) or 1 (the released code);
//! * each z_i is L2-normalised onto the unit sphere: z_i / max(‖z_i‖, 1e-12) (`F.normalize`);
//! * a controller MLP per part (`parts.{k}.controller`, ReLU between layers) maps z_k to the
//!   part's action means; the means are written to the columns `outputs[k]` of the action row.
//!
//! Shapes: input (B, obs_dim) — already normalised by the policy — output (B, act_dim). Two forward
//! paths over the same parameters: [`ModularAttention::forward_into`] (batched inference into
//! preallocated buffers) and [`ModularAttention::candle_forward`] (candle graph over `Var`s for the
//! PPO gradients), tested equal.

use candle_core::{D, Device, Tensor, Var};
use rand::Rng;

use crate::mlp::{Mlp, Workspace};
use crate::network::{NamedTensor, Network};

/// Shape of the network apart from the part definitions.
#[derive(Clone, Debug, PartialEq)]
pub struct ModularShape {
    /// Width of the embedding z_k (64 in ModSkill).
    pub embed: usize,
    /// Hidden width of the Q/K/V projections (256 in ModSkill).
    pub proj_hidden: usize,
    /// Attention heads (1 in ModSkill); `embed` must be a multiple.
    pub heads: usize,
    /// Divide the scores by √(embed / heads) (paper Eq. 5) or not (released code).
    pub scaled: bool,
    /// Hidden widths of every part controller ([2048, 1536, 1024, 512] in ModSkill's code).
    pub controller: Vec<usize>,
}

/// One body part: its token columns, action columns and networks.
#[derive(Clone, Debug, PartialEq)]
pub struct Part {
    pub name: String,
    /// Observation columns of the token, in order.
    pub inputs: Vec<usize>,
    /// Action columns the controller writes, in order.
    pub outputs: Vec<usize>,
    /// Two single-layer projections each (`*.0`, `*.1`).
    pub q: [Mlp; 2],
    pub k: [Mlp; 2],
    pub v: [Mlp; 2],
    pub controller: Mlp,
}

/// The modular attention actor (see the module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct ModularAttention {
    pub shape: ModularShape,
    pub parts: Vec<Part>,
    pub obs_dim: usize,
    pub act_dim: usize,
}

/// Buffers of [`ModularAttention::forward_into`].
#[derive(Clone, Debug, Default)]
pub struct ModularWorkspace {
    tokens: Vec<Vec<f32>>,
    qkv: Vec<Vec<f32>>,
    z: Vec<Vec<f32>>,
    ws: Vec<Workspace>,
    /// Attention weights (H·P·P) and mixed embeddings (P·E) of the current row.
    scores: Vec<f32>,
    u: Vec<f32>,
    out: Vec<f32>,
}

/// A single `Linear(inp → out)` with PyTorch's default initialisation (weight and bias U(±1/√inp)).
fn linear<R: Rng + ?Sized>(inp: usize, out: usize, rng: &mut R) -> Mlp {
    let b = 1.0 / (inp as f32).sqrt();
    let w = (0..out * inp).map(|_| rng.random_range(-b..b)).collect();
    let bias = (0..out).map(|_| rng.random_range(-b..b)).collect();
    Mlp::from_parts(vec![inp, out], vec![w], vec![bias])
}

/// Softmax attention of one row over the P part tokens: `qkv(which, part)` is that part's q (0),
/// k (1) or v (2) row (E wide); with H heads of width d = E/H, writes the weights
/// a\[h\]\[i\]\[j\] = softmax_j(q_i · k_j · scale) into `attn` (H·P·P) and the mixed embeddings
/// u_i = Σ_j a_ij v_j (heads side by side) into `u` (P·E). Shared by inference and the training
/// forward, which keeps `attn` for its backward.
pub fn attend_row<'a>(
    qkv: impl Fn(usize, usize) -> &'a [f32],
    np: usize,
    e: usize,
    heads: usize,
    scale: f32,
    attn: &mut [f32],
    u: &mut [f32],
) {
    let dh = e / heads;
    u.fill(0.0);
    for h in 0..heads {
        let cols = h * dh..(h + 1) * dh;
        for i in 0..np {
            let q = &qkv(0, i)[cols.clone()];
            let a = &mut attn[(h * np + i) * np..(h * np + i + 1) * np];
            for (j, aj) in a.iter_mut().enumerate() {
                *aj =
                    q.iter().zip(&qkv(1, j)[cols.clone()]).map(|(x, y)| x * y).sum::<f32>() * scale;
            }
            let mx = a.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            a.iter_mut().for_each(|v| *v = (*v - mx).exp());
            let sum: f32 = a.iter().sum();
            a.iter_mut().for_each(|v| *v /= sum);
            let ui = &mut u[i * e..(i + 1) * e][cols.clone()];
            for (j, &w) in a.iter().enumerate() {
                for (o, &v) in ui.iter_mut().zip(&qkv(2, j)[cols.clone()]) {
                    *o += w * v;
                }
            }
        }
    }
}

/// Project an embedding onto the unit sphere in place: z / max(‖z‖, 1e-12) (`F.normalize`).
pub fn unit_sphere(z: &mut [f32]) {
    let norm = z.iter().map(|v| v * v).sum::<f32>().sqrt().max(1e-12);
    z.iter_mut().for_each(|v| *v /= norm);
}

/// Write the rows of `y` (`n × cols.len()`) into the columns `cols` of the rows of `out`
/// (`n × width`).
pub fn scatter_columns(y: &[f32], cols: &[usize], out: &mut [f32], width: usize) {
    for (orow, yrow) in out.chunks_exact_mut(width).zip(y.chunks_exact(cols.len())) {
        for (&c, &v) in cols.iter().zip(yrow) {
            orow[c] = v;
        }
    }
}

/// The network description stored in a checkpoint's metadata `actor_net` (JSON): the shape and,
/// per part, (name, observation columns, action columns).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ModularSpec {
    pub embed: usize,
    pub proj_hidden: usize,
    pub heads: usize,
    pub scaled: bool,
    pub controller: Vec<usize>,
    /// (name, observation columns, action columns) per part.
    pub parts: Vec<(String, Vec<usize>, Vec<usize>)>,
}

impl ModularAttention {
    /// A new network: part k reads `parts[k].1` and writes `parts[k].2`. Projections get PyTorch's
    /// `nn.Linear` initialisation, controllers the policy MLPs' (U(±1/√fan_in) weights, zero
    /// biases). Errors name what is wrong with the parts.
    pub fn new<R: Rng + ?Sized>(
        shape: ModularShape,
        parts: &[(String, Vec<usize>, Vec<usize>)],
        obs_dim: usize,
        act_dim: usize,
        rng: &mut R,
    ) -> Result<Self, String> {
        if shape.heads == 0 || !shape.embed.is_multiple_of(shape.heads) {
            return Err(format!(
                "embedding width {} is not a multiple of the {} heads",
                shape.embed, shape.heads
            ));
        }
        let mut covered = vec![0u32; act_dim];
        for (name, inputs, outputs) in parts {
            if inputs.is_empty() || outputs.is_empty() {
                return Err(format!("part '{name}' has no observation or no action columns"));
            }
            if let Some(c) = inputs.iter().find(|&&c| c >= obs_dim) {
                return Err(format!(
                    "part '{name}' reads observation column {c}, the observation has {obs_dim}"
                ));
            }
            for &o in outputs {
                *covered.get_mut(o).ok_or_else(|| {
                    format!("part '{name}' writes action column {o}, the action has {act_dim}")
                })? += 1;
            }
        }
        if let Some(o) = covered.iter().position(|&c| c != 1) {
            return Err(format!(
                "action column {o} is written by {} parts; every column needs exactly one",
                covered[o]
            ));
        }
        let (e, h) = (shape.embed, shape.proj_hidden);
        let mut built = Vec::new();
        for (name, inputs, outputs) in parts {
            let n = inputs.len();
            let pair = |rng: &mut R| [linear(n, h, rng), linear(h, e, rng)];
            let (q, k, v) = (pair(rng), pair(rng), pair(rng));
            let mut dims = vec![e];
            dims.extend(&shape.controller);
            dims.push(outputs.len());
            let controller = Mlp::new(&dims, &mut &mut *rng);
            built.push(Part {
                name: name.clone(),
                inputs: inputs.clone(),
                outputs: outputs.clone(),
                q,
                k,
                v,
                controller,
            });
        }
        Ok(Self { shape, parts: built, obs_dim, act_dim })
    }

    /// The factor of the attention scores: 1/√(E/H) when `scaled`, else 1.
    pub fn score_scale(&self) -> f32 {
        if self.shape.scaled {
            1.0 / ((self.shape.embed / self.shape.heads) as f32).sqrt()
        } else {
            1.0
        }
    }

    /// `(name, shape)` of every parameter in [`ModularAttention::params`] order.
    pub fn param_names(&self, prefix: &str) -> Vec<(String, Vec<usize>)> {
        let mut v = Vec::new();
        for (k, p) in self.parts.iter().enumerate() {
            for (tag, pair) in [("q", &p.q), ("k", &p.k), ("v", &p.v)] {
                for (j, m) in pair.iter().enumerate() {
                    let (i, o) = (m.dims[0], m.dims[1]);
                    v.push((format!("{prefix}.parts.{k}.{tag}.{j}.weight"), vec![o, i]));
                    v.push((format!("{prefix}.parts.{k}.{tag}.{j}.bias"), vec![o]));
                }
            }
            v.extend(p.controller.param_names(&format!("{prefix}.parts.{k}.controller")));
        }
        v
    }

    fn mlps(&self) -> impl Iterator<Item = &Mlp> {
        self.parts
            .iter()
            .flat_map(|p| p.q.iter().chain(&p.k).chain(&p.v).chain(std::iter::once(&p.controller)))
    }

    /// Parameters: per part q.0, q.1, k.0, k.1, v.0, v.1 (weight, bias each), then the controller.
    pub fn params(&self) -> Vec<&[f32]> {
        self.mlps().flat_map(|m| m.params()).collect()
    }

    /// Mutable parameters in [`ModularAttention::params`] order.
    pub fn params_mut(&mut self) -> Vec<&mut Vec<f32>> {
        self.parts
            .iter_mut()
            .flat_map(|p| {
                p.q.iter_mut()
                    .chain(p.k.iter_mut())
                    .chain(p.v.iter_mut())
                    .chain(std::iter::once(&mut p.controller))
            })
            .flat_map(|m| m.params_mut())
            .collect()
    }

    /// Batched inference of `n` rows of `x` (`n × obs_dim`, normalised); returns `n × act_dim`.
    pub fn forward_into<'w>(
        &self,
        x: &[f32],
        n: usize,
        ws: &'w mut ModularWorkspace,
        threads: usize,
    ) -> &'w [f32] {
        let (np, e) = (self.parts.len(), self.shape.embed);
        ws.tokens.resize_with(np, Vec::new);
        ws.qkv.resize_with(3 * np, Vec::new);
        ws.z.resize_with(np, Vec::new);
        ws.ws.resize_with(7 * np, Workspace::default);
        for (k, p) in self.parts.iter().enumerate() {
            let t = &mut ws.tokens[k];
            t.resize(n * p.inputs.len(), 0.0);
            for (row, trow) in x[..n * self.obs_dim]
                .chunks_exact(self.obs_dim)
                .zip(t.chunks_exact_mut(p.inputs.len()))
            {
                for (o, &c) in trow.iter_mut().zip(&p.inputs) {
                    *o = row[c];
                }
            }
            for (j, pair) in [&p.q, &p.k, &p.v].into_iter().enumerate() {
                let (w0, rest) = ws.ws[7 * k + 2 * j..].split_at_mut(1);
                let hidden = pair[0].forward_into(t, n, &mut w0[0], threads);
                let y = pair[1].forward_into(hidden, n, &mut rest[0], threads);
                let dst = &mut ws.qkv[3 * k + j];
                dst.clear();
                dst.extend_from_slice(y);
            }
        }
        let (heads, scale) = (self.shape.heads, self.score_scale());
        for z in ws.z.iter_mut() {
            z.resize(n * e, 0.0);
        }
        ws.scores.resize(heads * np * np, 0.0);
        ws.u.resize(np * e, 0.0);
        for r in 0..n {
            let qkv = &ws.qkv;
            attend_row(
                |which, part| &qkv[3 * part + which][r * e..(r + 1) * e],
                np,
                e,
                heads,
                scale,
                &mut ws.scores,
                &mut ws.u,
            );
            for (i, zi) in ws.z.iter_mut().enumerate() {
                let zi = &mut zi[r * e..(r + 1) * e];
                zi.copy_from_slice(&ws.u[i * e..(i + 1) * e]);
                unit_sphere(zi);
            }
        }
        ws.out.resize(n * self.act_dim, 0.0);
        for (k, p) in self.parts.iter().enumerate() {
            let y = p.controller.forward_into(&ws.z[k], n, &mut ws.ws[7 * k + 6], threads);
            scatter_columns(y, &p.outputs, &mut ws.out, self.act_dim);
        }
        &ws.out[..n * self.act_dim]
    }

    /// Candle variables of the parameters ([`ModularAttention::params`] order).
    pub fn candle_vars(&self, dev: &Device) -> candle_core::Result<Vec<Var>> {
        let mut v = Vec::new();
        for m in self.mlps() {
            v.extend(m.candle_vars(dev)?);
        }
        Ok(v)
    }

    /// Candle forward of `x` (B, obs_dim) through `vars` (from [`ModularAttention::candle_vars`]).
    pub fn candle_forward(&self, vars: &[Var], x: &Tensor) -> candle_core::Result<Tensor> {
        let dev = x.device();
        let (b, np, e) = (x.dim(0)?, self.parts.len(), self.shape.embed);
        let (heads, dh) = (self.shape.heads, e / self.shape.heads);
        let lin = |h: &Tensor, w: &Var, bias: &Var| {
            h.matmul(&w.as_tensor().t()?)?.broadcast_add(bias.as_tensor())
        };
        let (mut qs, mut ks, mut vs) = (Vec::new(), Vec::new(), Vec::new());
        let mut at = 0;
        let mut ctrl_vars = Vec::new();
        for p in &self.parts {
            let idx: Vec<u32> = p.inputs.iter().map(|&c| c as u32).collect();
            let t = x.index_select(&Tensor::from_slice(&idx, idx.len(), dev)?, 1)?;
            for dst in [&mut qs, &mut ks, &mut vs] {
                let w = &vars[at..at + 4];
                dst.push(lin(&lin(&t, &w[0], &w[1])?, &w[2], &w[3])?);
                at += 4;
            }
            let nc = 2 * p.controller.num_layers();
            ctrl_vars.push(&vars[at..at + nc]);
            at += nc;
        }
        // (B, P, E) → (B, H, P, dh)
        let split = |t: Vec<Tensor>| -> candle_core::Result<Tensor> {
            Tensor::stack(&t, 1)?.reshape((b, np, heads, dh))?.transpose(1, 2)?.contiguous()
        };
        let (q, k, v) = (split(qs)?, split(ks)?, split(vs)?);
        let mut scores = q.matmul(&k.transpose(2, 3)?.contiguous()?)?;
        if self.shape.scaled {
            scores = (scores * (1.0 / (dh as f64).sqrt()))?;
        }
        let att = candle_nn::ops::softmax(&scores, D::Minus1)?;
        let z = att.matmul(&v)?.transpose(1, 2)?.contiguous()?.reshape((b, np, e))?;
        let norm = z.sqr()?.sum_keepdim(2)?.sqrt()?.maximum(1e-12)?;
        let z = z.broadcast_div(&norm)?;
        let mut outs = Vec::new();
        let mut order: Vec<usize> = Vec::new();
        for (k, p) in self.parts.iter().enumerate() {
            let zk = z.narrow(1, k, 1)?.squeeze(1)?;
            outs.push(Mlp::candle_forward(ctrl_vars[k], &zk)?);
            order.extend(&p.outputs);
        }
        let cat = Tensor::cat(&outs, 1)?;
        if order.iter().enumerate().all(|(j, &c)| j == c) {
            return Ok(cat);
        }
        let mut inv = vec![0u32; order.len()];
        for (j, &c) in order.iter().enumerate() {
            inv[c] = j as u32;
        }
        cat.index_select(&Tensor::from_slice(&inv, inv.len(), dev)?, 1)
    }
}

impl Network for ModularAttention {
    fn state_dict(&self) -> Vec<NamedTensor> {
        let names = self.param_names("");
        names
            .into_iter()
            .zip(self.params())
            .map(|((name, shape), data)| NamedTensor {
                name: name[1..].to_string(),
                shape,
                data: data.to_vec(),
            })
            .collect()
    }
    fn forward(&self, x: &Tensor) -> candle_core::Result<Tensor> {
        self.candle_forward(&self.candle_vars(x.device())?, x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn net(scaled: bool, heads: usize) -> ModularAttention {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let shape =
            ModularShape { embed: 8, proj_hidden: 6, heads, scaled, controller: vec![10, 7] };
        // three parts over 12 inputs and 7 actions, outputs interleaved (not in part order)
        let parts = vec![
            ("a".to_string(), vec![0, 1, 2, 11], vec![0, 3]),
            ("b".to_string(), vec![3, 4, 5, 6, 0], vec![1, 2, 6]),
            ("c".to_string(), vec![7, 8, 9, 10], vec![4, 5]),
        ];
        ModularAttention::new(shape, &parts, 12, 7, &mut rng).unwrap()
    }

    #[test]
    fn plain_forward_equals_candle_forward() {
        for (scaled, heads) in [(false, 1), (true, 2)] {
            let m = net(scaled, heads);
            let x: Vec<f32> = (0..9 * 12).map(|i| ((i * 37 % 23) as f32 - 11.0) * 0.2).collect();
            let plain = m.forward_into(&x, 9, &mut ModularWorkspace::default(), 1).to_vec();
            let xt = Tensor::from_slice(&x, (9, 12), &Device::Cpu).unwrap();
            let c: Vec<f32> = m.forward(&xt).unwrap().flatten_all().unwrap().to_vec1().unwrap();
            let err = plain.iter().zip(&c).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
            assert!(err < 1e-5, "scaled {scaled} heads {heads}: max diff {err}");
        }
    }

    #[test]
    fn names_follow_the_pytorch_module_and_bad_parts_are_refused() {
        let m = net(false, 1);
        let names = m.param_names("actor");
        assert_eq!(names[0], ("actor.parts.0.q.0.weight".to_string(), vec![6, 4]));
        assert_eq!(names[3], ("actor.parts.0.q.1.bias".to_string(), vec![8]));
        assert_eq!(names[12], ("actor.parts.0.controller.0.weight".to_string(), vec![10, 8]));
        assert_eq!(names.len(), m.params().len());
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let shape = m.shape.clone();
        let twice =
            vec![("a".to_string(), vec![0], vec![0, 1]), ("b".to_string(), vec![1], vec![1])];
        let err = ModularAttention::new(shape.clone(), &twice, 2, 2, &mut rng).unwrap_err();
        assert!(err.contains("action column 1 is written by 2 parts"), "{err}");
        let outside = vec![("a".to_string(), vec![5], vec![0])];
        assert!(
            ModularAttention::new(shape, &outside, 2, 1, &mut rng)
                .unwrap_err()
                .contains("column 5")
        );
    }
}
