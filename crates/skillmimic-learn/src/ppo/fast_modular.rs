//! The fast path's forward (activations kept) and backward for the `modular_attention` actor
//! (`skillmimic_nn::modular`, module doc there for the forward). Shapes per minibatch of n rows:
//! token t_k (n × in_k), projection hidden h (n × proj), q/k/v_k (n × E), attention weights
//! A (n × H × P × P), mixed embeddings u_k (n × E), unit embeddings z_k = u_k / max(‖u_k‖, 1e-12),
//! controller activations.
//!
//! Backward from the gradient of the action means g (n × act_dim):
//! * controller k: the MLP backward of [`super::mlp_grad`] on g[:, outputs_k], then
//!   g_z = g_h0 · W0 (z is not a ReLU output: no mask);
//! * normalisation: g_u = (g_z − z (z · g_z)) / ‖u‖ (g_u = g_z / 1e-12 where the norm is clamped);
//! * attention, per row and head, s_ij = c q_i · k_j, a = softmax_j(s), u_i = Σ_j a_ij v_j:
//!   g_v_j = Σ_i a_ij g_u_i, g_a_ij = g_u_i · v_j, g_s_ij = a_ij (g_a_ij − Σ_l a_il g_a_il),
//!   g_q_i = c Σ_j g_s_ij k_j, g_k_j = c Σ_i g_s_ij q_i;
//! * projections y = (t W0ᵀ + b0) W1ᵀ + b1 (no activation): dW1 = g_yᵀ h, g_h = g_y W1,
//!   dW0 = g_hᵀ t; the token gradient is never formed.
//!
//! Parameter gradients land in [`ModularAttention::params`] order. Tested against candle
//! autograd (`tests/fast_grads.rs`).

use rayon::prelude::*;
use skillmimic_nn::mlp::Mlp;
use skillmimic_nn::modular::{ModularAttention, attend_row, scatter_columns, unit_sphere};

use super::mlp_grad::{
    Mm, backward, bias_grad, forward_keep, input_grad_plain, linear, weight_grad,
};

/// Most parts a network may have on this path (ModSkill: 5 or 7).
pub const MAX_PARTS: usize = 16;

/// Activations of one minibatch.
#[derive(Default)]
pub struct ModularCache {
    tokens: Vec<Vec<f32>>,
    /// Per part and q/k/v: projection hidden (n × proj) and output (n × E).
    hidden: Vec<Vec<f32>>,
    qkv: Vec<Vec<f32>>,
    /// (n, H, P, P) attention weights.
    attn: Vec<f32>,
    /// (n, P, E) mixed embeddings before and after the projection onto the sphere; norms (n, P).
    u: Vec<f32>,
    z: Vec<f32>,
    norms: Vec<f32>,
    /// Per part: its z_k (n × E) and the controller's activations.
    zk: Vec<Vec<f32>>,
    ctrl_h: Vec<Vec<Vec<f32>>>,
    /// The action means (n × act_dim).
    pub out: Vec<f32>,
    g_part: Vec<f32>,
    scratch: Vec<f32>,
    g_u: Vec<f32>,
    /// Per row: the gradients of its q, k, v rows (3 · P · E).
    g_rows: Vec<f32>,
    g_qkv: Vec<Vec<f32>>,
}

fn linear_keep(m: &Mlp, x: &[f32], n: usize, out: &mut Vec<f32>, mm: Mm) {
    out.resize(n * m.dims[1], 0.0);
    linear(x, n, &m.weights[0], &m.biases[0], m.dims[0], out, mm);
}

impl ModularCache {
    /// Forward of `m` on `x` (n × obs_dim, normalised), keeping what the backward needs; the
    /// means are in [`ModularCache::out`].
    pub fn forward(&mut self, m: &ModularAttention, x: &[f32], n: usize, mm: Mm) {
        let (np, e, heads, scale) = (m.parts.len(), m.shape.embed, m.shape.heads, m.score_scale());
        self.tokens.resize_with(np, Vec::new);
        self.hidden.resize_with(3 * np, Vec::new);
        self.qkv.resize_with(3 * np, Vec::new);
        for (k, p) in m.parts.iter().enumerate() {
            let t = &mut self.tokens[k];
            t.resize(n * p.inputs.len(), 0.0);
            for (row, trow) in x.chunks_exact(m.obs_dim).zip(t.chunks_exact_mut(p.inputs.len())) {
                for (o, &c) in trow.iter_mut().zip(&p.inputs) {
                    *o = row[c];
                }
            }
            for (j, pair) in [&p.q, &p.k, &p.v].into_iter().enumerate() {
                linear_keep(&pair[0], &self.tokens[k], n, &mut self.hidden[3 * k + j], mm);
                linear_keep(&pair[1], &self.hidden[3 * k + j], n, &mut self.qkv[3 * k + j], mm);
            }
        }
        self.attn.resize(n * heads * np * np, 0.0);
        self.u.resize(n * np * e, 0.0);
        self.z.resize(n * np * e, 0.0);
        self.norms.resize(n * np, 0.0);
        let qkv = &self.qkv;
        self.attn
            .par_chunks_mut(heads * np * np)
            .zip(self.u.par_chunks_mut(np * e))
            .zip(self.z.par_chunks_mut(np * e).zip(self.norms.par_chunks_mut(np)))
            .enumerate()
            .for_each(|(r, ((a, u), (z, norms)))| {
                attend_row(
                    |which, part| &qkv[3 * part + which][r * e..(r + 1) * e],
                    np,
                    e,
                    heads,
                    scale,
                    a,
                    u,
                );
                z.copy_from_slice(u);
                for i in 0..np {
                    norms[i] = u[i * e..(i + 1) * e].iter().map(|v| v * v).sum::<f32>().sqrt();
                    unit_sphere(&mut z[i * e..(i + 1) * e]);
                }
            });
        self.zk.resize_with(np, Vec::new);
        self.ctrl_h.resize_with(np, Vec::new);
        self.out.resize(n * m.act_dim, 0.0);
        for (k, p) in m.parts.iter().enumerate() {
            let zk = &mut self.zk[k];
            zk.resize(n * e, 0.0);
            for (dst, src) in zk.chunks_exact_mut(e).zip(self.z.chunks_exact(np * e)) {
                dst.copy_from_slice(&src[k * e..(k + 1) * e]);
            }
            forward_keep(&p.controller, &self.zk[k], n, &mut self.ctrl_h[k], mm);
            scatter_columns(
                self.ctrl_h[k].last().expect("controller layers"),
                &p.outputs,
                &mut self.out,
                m.act_dim,
            );
        }
    }

    /// Parameter gradients for the mean gradient `g` (n × act_dim) into `grads`
    /// ([`ModularAttention::params`] order), after [`ModularCache::forward`] on the same rows.
    pub fn backward(
        &mut self,
        m: &ModularAttention,
        g: &[f32],
        n: usize,
        grads: &mut [Vec<f32>],
        mm: Mm,
    ) {
        let (np, e, heads, scale) = (m.parts.len(), m.shape.embed, m.shape.heads, m.score_scale());
        let dh = e / heads;
        // per part: 12 projection tensors, then the controller's
        let mut offsets = Vec::with_capacity(np);
        let mut at = 0;
        for p in &m.parts {
            offsets.push(at);
            at += 12 + 2 * p.controller.num_layers();
        }
        // controllers → g_u (n, P, E)
        self.g_u.resize(n * np * e, 0.0);
        for (k, p) in m.parts.iter().enumerate() {
            let a = p.outputs.len();
            self.g_part.resize(n * a, 0.0);
            for (dst, src) in self.g_part.chunks_exact_mut(a).zip(g.chunks_exact(m.act_dim)) {
                for (d, &c) in dst.iter_mut().zip(&p.outputs) {
                    *d = src[c];
                }
            }
            let c = &p.controller;
            // leaves the gradient at the first layer's output in g_part
            backward(
                c,
                &self.zk[k],
                n,
                &self.ctrl_h[k],
                &mut self.g_part,
                &mut self.scratch,
                &mut grads[offsets[k] + 12..],
                mm,
            );
            // g_z = g0 · W0 (n × E)
            self.scratch.resize(n * e, 0.0);
            input_grad_plain(&self.g_part, &c.weights[0], n, e, c.dims[1], &mut self.scratch, mm);
            for (r, gz) in self.scratch.chunks_exact(e).enumerate() {
                self.g_u[(r * np + k) * e..(r * np + k + 1) * e].copy_from_slice(gz);
            }
        }
        // normalisation and attention, row by row → g_q, g_k, g_v (per part, n × E)
        self.g_qkv.resize_with(3 * np, Vec::new);
        for gq in self.g_qkv.iter_mut() {
            gq.clear();
            gq.resize(n * e, 0.0);
        }
        let (qkv, attn, z, norms) = (&self.qkv, &self.attn, &self.z, &self.norms);
        self.g_rows.resize(n * 3 * np * e, 0.0);
        self.g_rows
            .par_chunks_mut(3 * np * e)
            .zip(self.g_u.par_chunks_mut(np * e))
            .enumerate()
            .for_each(|(r, (out, gu))| {
                for i in 0..np {
                    let (zi, gi) =
                        (&z[(r * np + i) * e..(r * np + i + 1) * e], &mut gu[i * e..(i + 1) * e]);
                    let nrm = norms[r * np + i];
                    if nrm > 1e-12 {
                        let dot: f32 = zi.iter().zip(gi.iter()).map(|(a, b)| a * b).sum();
                        gi.iter_mut().zip(zi).for_each(|(g, &zv)| *g = (*g - zv * dot) / nrm);
                    } else {
                        gi.iter_mut().for_each(|g| *g /= 1e-12);
                    }
                }
                out.fill(0.0);
                let row_of = |which: usize, part: usize| &qkv[3 * part + which][r * e..(r + 1) * e];
                let mut ga = [0.0f32; MAX_PARTS];
                for h in 0..heads {
                    let cols = h * dh..(h + 1) * dh;
                    for i in 0..np {
                        let a = &attn
                            [((r * heads + h) * np + i) * np..((r * heads + h) * np + i + 1) * np];
                        let gui = &gu[i * e..(i + 1) * e][cols.clone()];
                        for j in 0..np {
                            ga[j] = gui
                                .iter()
                                .zip(&row_of(2, j)[cols.clone()])
                                .map(|(x, y)| x * y)
                                .sum();
                            let gv = &mut out[(2 * np + j) * e..(2 * np + j + 1) * e][cols.clone()];
                            gv.iter_mut().zip(gui).for_each(|(o, &x)| *o += a[j] * x);
                        }
                        let mean: f32 = a.iter().zip(&ga).map(|(x, y)| x * y).sum();
                        for j in 0..np {
                            let gs = a[j] * (ga[j] - mean) * scale;
                            let (kj, qi) =
                                (&row_of(1, j)[cols.clone()], &row_of(0, i)[cols.clone()]);
                            let gq = &mut out[i * e..(i + 1) * e][cols.clone()];
                            gq.iter_mut().zip(kj).for_each(|(o, &x)| *o += gs * x);
                            let gk = &mut out[(np + j) * e..(np + j + 1) * e][cols.clone()];
                            gk.iter_mut().zip(qi).for_each(|(o, &x)| *o += gs * x);
                        }
                    }
                }
            });
        for (r, row) in self.g_rows.chunks_exact(3 * np * e).enumerate() {
            for which in 0..3 {
                for k in 0..np {
                    self.g_qkv[3 * k + which][r * e..(r + 1) * e]
                        .copy_from_slice(&row[(which * np + k) * e..(which * np + k + 1) * e]);
                }
            }
        }
        // the projections (Linear → Linear, no activation)
        for (k, p) in m.parts.iter().enumerate() {
            for (j, pair) in [&p.q, &p.k, &p.v].into_iter().enumerate() {
                let base = offsets[k] + 4 * j;
                let (d0, d1, d2) = (pair[0].dims[0], pair[0].dims[1], pair[1].dims[1]);
                let (gy, h, x) = (&self.g_qkv[3 * k + j], &self.hidden[3 * k + j], &self.tokens[k]);
                let (g0, g1) = grads[base..base + 4].split_at_mut(2);
                weight_grad(gy, h, n, d1, d2, &mut g1[0], mm);
                bias_grad(gy, n, d2, &mut g1[1]);
                self.scratch.resize(n * d1, 0.0);
                input_grad_plain(gy, &pair[1].weights[0], n, d1, d2, &mut self.scratch, mm);
                weight_grad(&self.scratch, x, n, d0, d1, &mut g0[0], mm);
                bias_grad(&self.scratch, n, d1, &mut g0[1]);
            }
        }
    }
}
