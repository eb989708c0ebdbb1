//! ModSkill skill reuse in one ONNX graph ([`fused_latent_model`]): a high-level policy's mean part
//! embeddings through the frozen part controllers of its `modular_attention` skill policy.

use skillmimic_nn::modular::ModularAttention;

use super::graph::{Elem, Graph};
use super::meta::{DeployMeta, Source};
use super::{Exported, Ports, actor, check_exportable, normalizer_meta};
use crate::error::LearnError;
use crate::policy::Policy;

/// The PD-target actions of ModSkill skill reuse from the latent `(batch, P·E)` value: each part's
/// E-wide slice projected onto the unit sphere, that part's controller, action-column order,
/// clamp to [−1, 1] into `actions` (what `skillmimic_nn::frozen_parts::FrozenParts::act` does).
fn part_controllers(g: &mut Graph, latent: &str, m: &ModularAttention) {
    let (np, e) = (m.parts.len() as i64, m.shape.embed as i64);
    let grouped = g.reshape(latent, &[0, np, e]);
    let z = g.l2_normalize_last(&grouped, 1e-12);
    let mu = super::modular::controllers(g, "skill.actor", &z, m);
    g.clip(&mu, -1.0, 1.0, Some("actions"));
}

/// Export a high-level `gaussian_mlp` policy over part embeddings fused with the frozen part
/// controllers of its `modular_attention` skill policy: `obs` → normaliser → actor → `latent`
/// (the Gaussian means, P·E wide) → `part_controllers` → `actions`.
pub fn fused_latent_model(
    hl: &Policy,
    skill: &Policy,
    mut meta: DeployMeta,
    skill_source: Source,
) -> Result<Exported, LearnError> {
    check_exportable(hl, &meta.source.file)?;
    let Some(m) = skill.actor.downcast_ref::<skillmimic_nn::modular::ModularAttention>() else {
        return Err(LearnError::Config(format!(
            "{}: a high-level policy over part embeddings needs a modular_attention skill policy, \
                not a '{}' one",
            skill_source.file,
            skill.family.name()
        )));
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
    Ports { g: &mut g, meta: &mut meta }.input(
        "obs",
        Elem::F32,
        &[d],
        "high-level observation (see obs_blocks)",
    );
    actor(&mut g, "hl", "obs", hl, Some("latent"));
    part_controllers(&mut g, "latent", m);
    let mut ports = Ports { g: &mut g, meta: &mut meta };
    ports.output(
        "actions",
        Elem::F32,
        &[m.act_dim],
        "clamp of the frozen part controllers' \
        output for the policy's mean embeddings (see action_to_pd_target)",
    );
    ports.output(
        "latent",
        Elem::F32,
        &[latent],
        "the high-level policy's mean part embeddings \
        (before the unit-sphere projection), part-major",
    );
    let doc = format!("skillmimic-rs fused part-embedding graph from {}", meta.source.file);
    Ok(Exported { model: g.into_model(&doc, &meta.props()), meta })
}
