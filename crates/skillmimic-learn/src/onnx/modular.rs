//! The `modular_attention` actor as an ONNX sub-graph (the same computation as
//! `skillmimic_nn::modular::ModularAttention::forward_into`, module doc there):
//!
//! 1. per part k: token `Gather(x, inputs_k, axis 1)` (B, in_k); q/k/v = two `Gemm`s each (no
//!    activation), `Unsqueeze` to (B, 1, E), `Concat` over the parts → Q, K, V (B, P, E);
//! 2. heads: `Reshape` (B, P, H, E/H), `Transpose` → (B, H, P, E/H); scores = `MatMul(Q, Kᵀ)`
//!    (× 1/√(E/H) when the network is `scaled`), `Softmax` over the keys, `MatMul` with V, back
//!    to (B, P, E);
//! 3. each embedding `x / max(ReduceL2(x), 1e-12)`;
//! 4. per part: `Gather(z, k, axis 1)` → controller MLP (`Gemm`/`Relu`); the part outputs are
//!    concatenated and put into action-column order by one `Gather` with the inverse permutation.
//!
//! Constant names follow the checkpoint's tensors (`actor.parts.{k}.q.0.weight`, …).

use skillmimic_nn::modular::ModularAttention;

use super::graph::Graph;

/// The modular actor over the (normalised) value `x`; the means are written to `out`.
pub fn modular_actor(
    g: &mut Graph,
    prefix: &str,
    x: &str,
    m: &ModularAttention,
    out: Option<&str>,
) -> String {
    let (np, e, h) = (m.parts.len() as i64, m.shape.embed as i64, m.shape.heads as i64);
    let dh = e / h;
    let mut qkv: [Vec<String>; 3] = Default::default();
    for (k, p) in m.parts.iter().enumerate() {
        let cols: Vec<i64> = p.inputs.iter().map(|&c| c as i64).collect();
        let token = g.take(x, 1, &cols, false);
        for (j, (tag, pair)) in [("q", &p.q), ("k", &p.k), ("v", &p.v)].into_iter().enumerate() {
            let hidden = g.mlp(&format!("{prefix}.parts.{k}.{tag}.0"), &token, &pair[0], None);
            let y = g.mlp(&format!("{prefix}.parts.{k}.{tag}.1"), &hidden, &pair[1], None);
            qkv[j].push(g.unsqueeze(&y, 1));
        }
    }
    let heads = |g: &mut Graph, parts: &[String], perm: &[i64]| {
        let stacked = g.concat_all(parts, 1);
        let split = g.reshape(&stacked, &[0, np, h, dh]);
        g.transpose(&split, perm)
    };
    let q = heads(g, &qkv[0], &[0, 2, 1, 3]);
    let kt = heads(g, &qkv[1], &[0, 2, 3, 1]);
    let v = heads(g, &qkv[2], &[0, 2, 1, 3]);
    let mut scores = g.op("MatMul", &[&q, &kt], None, Vec::new());
    if m.shape.scaled {
        scores = g.scale(&scores, 1.0 / (dh as f32).sqrt());
    }
    let attn = g.softmax_last(&scores);
    let mixed = g.op("MatMul", &[&attn, &v], None, Vec::new());
    let back = g.transpose(&mixed, &[0, 2, 1, 3]);
    let z = g.reshape(&back, &[0, np, e]);
    let z = g.l2_normalize_last(&z, 1e-12);
    let mu = controllers(g, prefix, &z, m);
    match out {
        Some(o) => g.identity(&mu, o),
        None => mu,
    }
}

/// The part controllers over unit embeddings `z` (batch, P, E): part k's controller on `z[:, k]`,
/// the outputs concatenated and put into action-column order by one `Gather` with the inverse
/// permutation. Returns the means (batch, act_dim).
pub fn controllers(g: &mut Graph, prefix: &str, z: &str, m: &ModularAttention) -> String {
    let mut ys = Vec::with_capacity(m.parts.len());
    let mut order: Vec<usize> = Vec::new();
    for (k, p) in m.parts.iter().enumerate() {
        let zk = g.take(z, 1, &[k as i64], true);
        ys.push(g.mlp(&format!("{prefix}.parts.{k}.controller"), &zk, &p.controller, None));
        order.extend(&p.outputs);
    }
    let cat = g.concat_all(&ys, 1);
    let mut inverse = vec![0i64; m.act_dim];
    for (pos, &c) in order.iter().enumerate() {
        inverse[c] = pos as i64;
    }
    g.take(&cat, 1, &inverse, false)
}
