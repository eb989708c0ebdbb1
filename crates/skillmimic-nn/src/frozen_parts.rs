//! ModSkill's frozen part controllers for skill reuse (seed 001 §3.5; modskill-tokenhsi-facts
//! §1.7): the per-part controller MLPs of a `modular_attention` checkpoint, driven by embeddings
//! that a high-level policy chooses instead of the attention layer.
//!
//! Input (latent action, `n × P·E`, P parts in the checkpoint's part order, E = its embedding
//! width, 64 in ModSkill): part k's slice `k·E..(k+1)·E` is projected onto the unit sphere with
//! [`unit_sphere`] — the same projection the attention layer applies, so the controllers see
//! embeddings of the kind they were trained on — then its controller gives the part's action
//! means, written to the part's action columns ([`scatter_columns`]). Output: the PD targets
//! `n × act_dim` (156 joint coordinates), clamped to [−1, 1] like [`crate::frozen::FrozenActor`];
//! a row that is not finite gets zero targets. The controllers read nothing but the embedding,
//! so the checkpoint's observation normaliser and attention projections are not needed.

use std::path::{Path, PathBuf};

use skillmimic_core::tensorfile::TensorFile;

use crate::frozen::{FrozenError, open_policy, read_mlp};
use crate::mlp::{Mlp, Workspace};
use crate::modular::{ModularSpec, scatter_columns, unit_sphere};

/// One part's frozen controller.
#[derive(Clone, Debug)]
pub struct FrozenPart {
    pub name: String,
    /// Action columns it writes.
    pub outputs: Vec<usize>,
    /// `E → hidden… → outputs.len()`.
    pub controller: Mlp,
}

/// The part controllers of a `modular_attention` checkpoint, never modified.
#[derive(Clone, Debug)]
pub struct FrozenParts {
    pub parts: Vec<FrozenPart>,
    /// Embedding width E per part.
    pub embed: usize,
    /// Width of the action row (156).
    pub act_dim: usize,
    /// Where it was loaded from.
    pub source: PathBuf,
    /// The training configuration stored with it (TOML text; empty when absent).
    pub config: String,
    z: Vec<f32>,
    ws: Workspace,
    out: Vec<f32>,
}

/// The value of a checkpoint's `policy` metadata (`None` for files written before it existed,
/// which are `gaussian_mlp`).
pub fn policy_family(path: &Path) -> Result<Option<String>, FrozenError> {
    let f = TensorFile::open(path)?;
    Ok(f.meta("policy").ok().map(str::to_string))
}

impl FrozenParts {
    /// Load the controllers of the `modular_attention` checkpoint at `path` (training or exported
    /// policy file); the file, field and expected value are named on error.
    pub fn load(path: &Path) -> Result<Self, FrozenError> {
        let f = open_policy(path)?;
        let invalid = |detail: String| FrozenError::Invalid { path: path.to_path_buf(), detail };
        match f.meta("policy") {
            Ok("modular_attention") => {}
            Ok(other) => {
                return Err(invalid(format!(
                    "metadata 'policy' is '{other}', expected 'modular_attention' (part \
                        controllers)"
                )));
            }
            Err(_) => {
                return Err(invalid(
                    "metadata 'policy' is missing, expected 'modular_attention' (part controllers)"
                        .into(),
                ));
            }
        }
        let act_dim: usize = f.meta_parse("act_dim", "an integer")?;
        let spec: ModularSpec = serde_json::from_str(f.meta("actor_net")?).map_err(|e| {
            invalid(format!("metadata 'actor_net' is not a modular network description: {e}"))
        })?;
        if spec.embed == 0 || spec.parts.is_empty() {
            return Err(invalid(format!(
                "metadata 'actor_net': {} parts with embeddings of {}; expected at least one part \
                    and a positive width",
                spec.parts.len(),
                spec.embed
            )));
        }
        let mut covered = vec![0u32; act_dim];
        let mut parts = Vec::with_capacity(spec.parts.len());
        for (k, (name, _, outputs)) in spec.parts.iter().enumerate() {
            for &o in outputs {
                *covered.get_mut(o).ok_or_else(|| {
                    invalid(format!(
                        "metadata 'actor_net': part \
                    '{name}' writes action column {o}, act_dim is {act_dim}"
                    ))
                })? += 1;
            }
            let mut dims = vec![spec.embed];
            dims.extend(&spec.controller);
            dims.push(outputs.len());
            let controller = read_mlp(&f, &format!("actor.parts.{k}.controller"), dims)?;
            parts.push(FrozenPart { name: name.clone(), outputs: outputs.clone(), controller });
        }
        if let Some(o) = covered.iter().position(|&c| c != 1) {
            return Err(invalid(format!(
                "metadata 'actor_net': action column {o} is written by {} parts, expected exactly \
                    one",
                covered[o]
            )));
        }
        let config = f.metadata().get("config").cloned().unwrap_or_default();
        Ok(Self {
            parts,
            embed: spec.embed,
            act_dim,
            source: path.to_path_buf(),
            config,
            z: Vec::new(),
            ws: Workspace::default(),
            out: Vec::new(),
        })
    }

    /// Width of the latent action: parts × embedding width.
    pub fn latent_dim(&self) -> usize {
        self.parts.len() * self.embed
    }

    /// PD targets for `n` latent rows (`latent`: `n × latent_dim`) into `out` (`n × act_dim`);
    /// see the module doc. `threads` as in [`Mlp::forward_into`].
    pub fn act(&mut self, latent: &[f32], n: usize, threads: usize, out: &mut [f32]) {
        let (d, e, a) = (self.latent_dim(), self.embed, self.act_dim);
        self.out.resize(n * a, 0.0);
        self.z.resize(n * e, 0.0);
        for (k, p) in self.parts.iter().enumerate() {
            for (zrow, lrow) in self.z.chunks_exact_mut(e).zip(latent[..n * d].chunks_exact(d)) {
                zrow.copy_from_slice(&lrow[k * e..(k + 1) * e]);
                unit_sphere(zrow);
            }
            let y = p.controller.forward_into(&self.z, n, &mut self.ws, threads);
            scatter_columns(y, &p.outputs, &mut self.out, a);
        }
        for (orow, mrow) in out[..n * a].chunks_exact_mut(a).zip(self.out.chunks_exact(a)) {
            if mrow.iter().all(|v| v.is_finite()) {
                for (o, &m) in orow.iter_mut().zip(mrow) {
                    *o = m.clamp(-1.0, 1.0);
                }
            } else {
                orow.fill(0.0);
            }
        }
    }
}
