//! `[ppo.token]`: TokenHSI's token transformer policy (`ppo.policy = "token_transformer"` or
//! `"token_transformer_categorical"`) and its policy adaptation (modskill-tokenhsi-facts
//! §2.3, §2.5; `skillmimic_nn::token`).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// The token transformer's sizes, its observation groups and adaptation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct TokenConfig {
    /// Hidden widths of every tokenizer MLP (TokenHSI: [256, 128]).
    #[schemars(inner(range(min = 1)))]
    pub tokenizer: Vec<usize>,
    /// Token width d_model (TokenHSI: 64).
    #[schemars(range(min = 1))]
    pub embed: usize,
    /// Transformer encoder layers (TokenHSI: 4).
    #[schemars(range(min = 1))]
    pub layers: usize,
    /// Attention heads (TokenHSI: 2); `embed` must be a multiple.
    #[schemars(range(min = 1))]
    pub heads: usize,
    /// Feed-forward width of every encoder layer (TokenHSI: 512).
    #[schemars(range(min = 1))]
    pub feedforward: usize,
    /// Hidden widths of the action head after the output token (TokenHSI: [1024, 512]).
    #[schemars(inner(range(min = 1)))]
    pub head: Vec<usize>,
    /// Observation groups as "name:width" in column order, group 0 the proprioception, then
    /// "mask:K" when the observation ends with a token mask. Empty (default): taken from the
    /// task's observation layout (`multi_*` tasks: every task group and the mask).
    pub groups: Vec<String>,
    /// Policy adaptation (seed 004 §E): a `token_transformer` checkpoint whose every tensor and
    /// observation statistic is frozen; the task's new groups get new tokenizers, the head
    /// zero-initialised adapters, and the critic is new. Empty = train from scratch.
    pub adapt_from: std::path::PathBuf,
    /// Adaptation: the adapters act only where a new task group is active, so the base tasks keep
    /// the base policy's actions (one network for old and new tasks; our choice). false = adapters
    /// on every row (the released code, which runs only the new task after adaptation).
    pub gate_adapters: bool,
}

impl Default for TokenConfig {
    fn default() -> Self {
        Self {
            tokenizer: vec![256, 128],
            embed: 64,
            layers: 4,
            heads: 2,
            feedforward: 512,
            head: vec![1024, 512],
            groups: Vec::new(),
            adapt_from: std::path::PathBuf::new(),
            gate_adapters: true,
        }
    }
}

impl TokenConfig {
    /// The groups as (name, width) and the mask width, parsed from `groups`.
    pub fn parsed_groups(&self) -> Result<(Vec<(String, usize)>, usize), String> {
        let mut groups = Vec::new();
        let mut mask = 0;
        for (k, g) in self.groups.iter().enumerate() {
            let parsed = g.rsplit_once(':').and_then(|(n, w)| {
                w.trim().parse::<usize>().ok().filter(|&w| w > 0).map(|w| (n.trim().to_string(), w))
            });
            let Some((name, w)) = parsed else {
                return Err(format!(
                    "config field 'ppo.token.groups' entry {k} is '{g}', expected \"name:width\" \
                        with a positive width"
                ));
            };
            if name == "mask" {
                if k + 1 != self.groups.len() {
                    return Err(format!(
                        "config field 'ppo.token.groups': \"mask:{w}\" must be the last entry"
                    ));
                }
                mask = w;
            } else {
                groups.push((name, w));
            }
        }
        Ok((groups, mask))
    }
}
