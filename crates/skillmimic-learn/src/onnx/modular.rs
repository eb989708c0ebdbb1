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
//!
//! [`fused_latent_model`]: ModSkill skill reuse in one graph — a high-level policy's mean part
//! embeddings through the frozen part controllers of its modular skill policy.

use skillmimic_nn::modular::ModularAttention;

use super::graph::{Elem, Graph};
use super::meta::{DeployMeta, Source};
use super::{Exported, Ports, actor, check_exportable, normalizer_meta};
use crate::actor::ActorNet;
use crate::error::LearnError;
use crate::policy::Policy;

/// The modular actor over the (normalised) value `x`; the means are written to `out`.
pub fn modular_actor(g: &mut Graph, prefix: &str, x: &str, m: &ModularAttention, out: Option<&str>) -> String {
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
    let mut ys = Vec::with_capacity(m.parts.len());
    let mut order: Vec<usize> = Vec::new();
    for (k, p) in m.parts.iter().enumerate() {
        let zk = g.take(&z, 1, &[k as i64], true);
        ys.push(g.mlp(&format!("{prefix}.parts.{k}.controller"), &zk, &p.controller, None));
        order.extend(&p.outputs);
    }
    let cat = g.concat_all(&ys, 1);
    let mut inverse = vec![0i64; m.act_dim];
    for (pos, &c) in order.iter().enumerate() {
        inverse[c] = pos as i64;
    }
    let name = out.map(str::to_string);
    let picked = g.take(&cat, 1, &inverse, false);
    match name {
        Some(o) => g.identity(&picked, &o),
        None => picked,
    }
}

/// The PD-target actions of ModSkill skill reuse from the latent `(batch, P·E)` value: each part's
/// E-wide slice projected onto the unit sphere, that part's controller, action-column order,
/// clamp to [−1, 1] into `actions` (what `skillmimic_nn::frozen_parts::FrozenParts::act` does).
fn part_controllers(g: &mut Graph, latent: &str, m: &ModularAttention) {
    let (np, e) = (m.parts.len() as i64, m.shape.embed as i64);
    let grouped = g.reshape(latent, &[0, np, e]);
    let z = g.l2_normalize_last(&grouped, 1e-12);
    let mut ys = Vec::with_capacity(m.parts.len());
    let mut order: Vec<usize> = Vec::new();
    for (k, p) in m.parts.iter().enumerate() {
        let zk = g.take(&z, 1, &[k as i64], true);
        ys.push(g.mlp(&format!("skill.actor.parts.{k}.controller"), &zk, &p.controller, None));
        order.extend(&p.outputs);
    }
    let cat = g.concat_all(&ys, 1);
    let mut inverse = vec![0i64; m.act_dim];
    for (pos, &c) in order.iter().enumerate() {
        inverse[c] = pos as i64;
    }
    let mu = g.take(&cat, 1, &inverse, false);
    g.clip(&mu, -1.0, 1.0, Some("actions"));
}

/// Export a high-level `gaussian_mlp` policy over part embeddings fused with the frozen part
/// controllers of its `modular_attention` skill policy: `obs` → normaliser → actor → `latent`
/// (the Gaussian means, P·E wide) → [`part_controllers`] → `actions`.
pub fn fused_latent_model(hl: &Policy, skill: &Policy, mut meta: DeployMeta, skill_source: Source) -> Result<Exported, LearnError> {
    check_exportable(hl, &meta.source.file)?;
    let ActorNet::Modular(m) = &skill.actor else {
        return Err(LearnError::Config(format!("{}: a high-level policy over part embeddings needs a modular_attention skill policy, not a '{}' one", skill_source.file, skill.family.name())));
    };
    let latent = m.parts.len() * m.shape.embed;
    if hl.actor.output_dim() != latent || hl.family.name() != "gaussian_mlp" {
        return Err(LearnError::Config(format!(
            "{}: a '{}' policy with {} actions; the part controllers of {} take {} ({} parts × {})",
            meta.source.file,
            hl.family.name(),
            hl.actor.output_dim(),
            skill_source.file,
            latent,
            m.parts.len(),
            m.shape.embed
        )));
    }
    let d = hl.obs_dim();
    let mut g = Graph::new("skillmimic_fused_part_embeddings");
    meta.graph = "fused_part_embeddings".to_string();
    meta.act_dim = m.act_dim;
    meta.normalizer = normalizer_meta(hl);
    meta.skill_source = Some(skill_source);
    meta.choices.clear();
    Ports { g: &mut g, meta: &mut meta }.input("obs", Elem::F32, &[d], "high-level observation (see obs_blocks)");
    actor(&mut g, "hl", "obs", hl, Some("latent"));
    part_controllers(&mut g, "latent", m);
    let mut ports = Ports { g: &mut g, meta: &mut meta };
    ports.output("actions", Elem::F32, &[m.act_dim], "clamp of the frozen part controllers' output for the policy's mean embeddings (see action_to_pd_target)");
    ports.output("latent", Elem::F32, &[latent], "the high-level policy's mean part embeddings (before the unit-sphere projection), part-major");
    let doc = format!("skillmimic-rs fused part-embedding graph from {}", meta.source.file);
    Ok(Exported { model: g.into_model(&doc, &meta.props()), meta })
}
