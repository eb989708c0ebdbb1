//! Adam with its state exposed (PyTorch's update rule, weight decay 0), so training resumes with
//! the optimiser state of the checkpoint.
//!
//! For step t: m ← β₁m + (1−β₁)g, v ← β₂v + (1−β₂)g²,
//! w ← w − (lr / (1−β₁ᵗ)) · m / (√v / √(1−β₂ᵗ) + ε).

use rayon::prelude::*;

/// Adam state for a list of parameter tensors.
#[derive(Clone, Debug, PartialEq)]
pub struct Adam {
    pub lr: f64,
    pub beta1: f64,
    pub beta2: f64,
    pub eps: f64,
    /// Steps taken.
    pub step: u64,
    /// First and second moments, one vector per parameter tensor.
    pub m: Vec<Vec<f32>>,
    pub v: Vec<Vec<f32>>,
}

impl Adam {
    /// Zero state for parameters of the given lengths.
    pub fn new(sizes: &[usize], lr: f64, eps: f64) -> Self {
        Self {
            lr,
            beta1: 0.9,
            beta2: 0.999,
            eps,
            step: 0,
            m: sizes.iter().map(|&n| vec![0.0; n]).collect(),
            v: sizes.iter().map(|&n| vec![0.0; n]).collect(),
        }
    }

    /// Apply one update to `params` with gradients `grads` (same order and sizes).
    pub fn update(&mut self, params: &mut [&mut Vec<f32>], grads: &[Vec<f32>]) {
        self.step += 1;
        let t = self.step as i32;
        let (b1, b2) = (self.beta1 as f32, self.beta2 as f32);
        let bc1 = 1.0 - self.beta1.powi(t);
        let bc2 = 1.0 - self.beta2.powi(t);
        let step_size = (self.lr / bc1) as f32;
        let sqrt_bc2 = bc2.sqrt() as f32;
        let eps = self.eps as f32;
        for (i, p) in params.iter_mut().enumerate() {
            let (m, v, g) = (&mut self.m[i], &mut self.v[i], &grads[i]);
            p.par_chunks_mut(4096)
                .zip(m.par_chunks_mut(4096))
                .zip(v.par_chunks_mut(4096))
                .zip(g.par_chunks(4096))
                .for_each(|(((p, m), v), g)| {
                    for k in 0..p.len() {
                        m[k] = b1 * m[k] + (1.0 - b1) * g[k];
                        v[k] = b2 * v[k] + (1.0 - b2) * g[k] * g[k];
                        p[k] -= step_size * m[k] / (v[k].sqrt() / sqrt_bc2 + eps);
                    }
                });
        }
    }
}

/// Global L2 norm of gradients.
pub fn global_norm(grads: &[Vec<f32>]) -> f64 {
    grads.iter().flat_map(|g| g.iter()).map(|&x| (x as f64) * (x as f64)).sum::<f64>().sqrt()
}

/// Scale gradients so their global norm is at most `max_norm` (PyTorch's `clip_grad_norm_`).
pub fn clip_global_norm(grads: &mut [Vec<f32>], max_norm: f64) -> f64 {
    let n = global_norm(grads);
    let scale = max_norm / (n + 1e-6);
    if scale < 1.0 {
        for g in grads.iter_mut() {
            g.iter_mut().for_each(|x| *x = (*x as f64 * scale) as f32);
        }
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_steps_match_the_pytorch_rule_by_hand() {
        let mut p = vec![1.0f32, -2.0];
        let mut adam = Adam::new(&[2], 0.1, 1e-8);
        adam.update(&mut [&mut p], &[vec![0.5, -4.0]]);
        // step 1: m/(1-b1) = g, sqrt(v/(1-b2)) = |g| -> w -= lr * sign(g)
        assert!((p[0] - 0.9).abs() < 1e-6 && (p[1] + 1.9).abs() < 1e-6, "{p:?}");
        adam.update(&mut [&mut p], &[vec![0.5, 0.0]]);
        // second step, coordinate 1: m = 0.9*0.1*(-4) ... = -0.36, v = 0.999*0.001*16 = 0.015984
        let (m, v) = (0.9 * 0.1 * -4.0f64, 0.999 * 0.001 * 16.0);
        let want = -1.9 - 0.1 / (1.0 - 0.81) * m / ((v / (1.0 - 0.999f64.powi(2))).sqrt() + 1e-8);
        assert!((p[1] as f64 - want).abs() < 1e-5, "{} vs {want}", p[1]);
        assert_eq!(adam.step, 2);
        let mut g = vec![vec![3.0f32, 4.0]];
        assert!((clip_global_norm(&mut g, 1.0) - 5.0).abs() < 1e-9);
        assert!((global_norm(&g) - 1.0).abs() < 1e-5);
    }
}
