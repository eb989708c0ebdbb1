//! `categorical_mlp`: a discrete choice among n, π(k|s) = softmax(ℓ(s))_k with logits ℓ from the
//! actor MLP (n outputs). For discrete action spaces (a high-level policy choosing skills).
//!
//! The logits layer starts Glorot-uniform (gain 1: U(±√(6/(fan_in + fan_out)))) with zero bias,
//! as the SkillMimic high-level controller (reference-facts §8.3). Actions are sent as the index
//! k in one float. `neglogp(k) = logsumexp(ℓ) − ℓ_k`. Extra loss:
//! −c_e · mean entropy, entropy = −Σ_k π_k ln π_k (`ppo.entropy_coef`, 0 by default as in the
//! papers' PPO settings). No family tensor in the checkpoint. PyTorch mirror:
//! `skillmimic_rs.policy.CategoricalMlpPolicy`.

use candle_core::{D, Tensor};
use rand::{Rng, RngCore};
use skillmimic_env::ActionSpace;

use super::family::{ExtraLoss, Head, PolicyFamily};
use crate::config::PpoConfig;

/// The categorical family.
pub struct CategoricalMlp;

/// (log-sum-exp of `logits`, its maximum), in f64.
fn logsumexp(logits: &[f32]) -> f64 {
    let m = logits.iter().fold(f32::NEG_INFINITY, |a, &b| a.max(b)) as f64;
    m + logits.iter().map(|&l| (l as f64 - m).exp()).sum::<f64>().ln()
}

impl PolicyFamily for CategoricalMlp {
    fn name(&self) -> &'static str {
        "categorical_mlp"
    }
    fn supports(&self, space: &ActionSpace) -> bool {
        matches!(space, ActionSpace::Discrete { .. })
    }
    fn actor_outputs(&self, space: &ActionSpace) -> usize {
        match *space {
            ActionSpace::Discrete { n } => n,
            ActionSpace::Box { dim } => dim,
        }
    }

    fn init_output_layer(&self, actor: &mut skillmimic_nn::mlp::Mlp, rng: &mut dyn RngCore) {
        let (fan_in, fan_out) = (actor.dims[actor.dims.len() - 2], actor.output_dim());
        let a = (6.0 / (fan_in + fan_out) as f64).sqrt();
        let mut params = actor.params_mut();
        let k = params.len();
        for w in params[k - 2].iter_mut() {
            *w = rng.random_range(-a..a) as f32;
        }
        params[k - 1].fill(0.0);
    }

    /// Inverse-CDF sampling with one uniform draw per environment.
    fn sample(
        &self,
        head: Head<'_>,
        logits: &[f32],
        n: usize,
        rng: &mut dyn RngCore,
        actions: &mut [f32],
        neglogp: &mut [f32],
    ) {
        let k = head.outputs;
        for i in 0..n {
            let row = &logits[i * k..(i + 1) * k];
            let lse = logsumexp(row);
            let u: f64 = rng.random();
            let (mut acc, mut pick) = (0.0, k - 1);
            for (j, &l) in row.iter().enumerate() {
                acc += (l as f64 - lse).exp();
                if u < acc {
                    pick = j;
                    break;
                }
            }
            actions[i] = pick as f32;
            neglogp[i] = (lse - row[pick] as f64) as f32;
        }
    }

    fn mode(&self, head: Head<'_>, logits: &[f32], n: usize, actions: &mut [f32]) {
        let k = head.outputs;
        for i in 0..n {
            let row = &logits[i * k..(i + 1) * k];
            let best = (0..k).fold(0, |b, j| if row[j] > row[b] { j } else { b });
            actions[i] = best as f32;
        }
    }

    fn neglogp(
        &self,
        _head: Head<'_>,
        logits: &Tensor,
        actions: &Tensor,
    ) -> candle_core::Result<Tensor> {
        let logp = candle_nn::ops::log_softmax(logits, D::Minus1)?;
        let idx = actions.flatten_all()?.to_dtype(candle_core::DType::U32)?.unsqueeze(1)?;
        logp.gather(&idx, 1)?.squeeze(1)?.neg()
    }

    fn extra_loss(&self, logits: &Tensor, cfg: &PpoConfig) -> candle_core::Result<ExtraLoss> {
        let logp = candle_nn::ops::log_softmax(logits, D::Minus1)?;
        let entropy = (logp.exp()? * &logp)?.sum(1)?.neg()?.mean_all()?;
        Ok(ExtraLoss {
            total: (&entropy * -cfg.entropy_coef)?,
            bounds: None,
            entropy: Some(entropy),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn sampling_follows_the_softmax_and_neglogp_agrees_with_the_candle_graph() {
        let logits = [0.5f32, -1.0, 2.0, 0.0];
        let head = Head { outputs: 4, log_std: &[] };
        let z: f64 = logits.iter().map(|&l| (l as f64).exp()).sum();
        let probs: Vec<f64> = logits.iter().map(|&l| (l as f64).exp() / z).collect();
        let n = 40_000;
        let rows: Vec<f32> = logits.iter().copied().cycle().take(4 * n).collect();
        let (mut a, mut nl) = (vec![0.0f32; n], vec![0.0f32; n]);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        CategoricalMlp.sample(head, &rows, n, &mut rng, &mut a, &mut nl);
        for (k, p) in probs.iter().enumerate() {
            let f = a.iter().filter(|&&x| x == k as f32).count() as f64 / n as f64;
            assert!((f - p).abs() < 0.01, "choice {k}: frequency {f} vs {p}");
        }
        let dev = candle_core::Device::Cpu;
        let out = Tensor::from_slice(&rows[..16], (4, 4), &dev).unwrap();
        let act = Tensor::from_slice(&a[..4], (4, 1), &dev).unwrap();
        let g: Vec<f32> = CategoricalMlp.neglogp(head, &out, &act).unwrap().to_vec1().unwrap();
        for i in 0..4 {
            assert!(
                (g[i] - nl[i]).abs() < 1e-5
                    && (nl[i] as f64 + probs[a[i] as usize].ln()).abs() < 1e-5
            );
        }
        let mut m = [0.0f32; 1];
        CategoricalMlp.mode(head, &logits, 1, &mut m);
        assert_eq!(m[0], 2.0);
        let ent: f32 = CategoricalMlp
            .extra_loss(&out, &PpoConfig { entropy_coef: 1.0, ..Default::default() })
            .unwrap()
            .entropy
            .unwrap()
            .to_scalar()
            .unwrap();
        let want: f64 = -probs.iter().map(|p| p * p.ln()).sum::<f64>();
        assert!((ent as f64 - want).abs() < 1e-5);
    }
}
