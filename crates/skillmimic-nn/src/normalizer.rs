//! Running mean/variance normaliser (rl_games' `RunningMeanStd`, reference-facts §4.2).
//!
//! State in f64: mean 0, variance 1, count 1 at start. A training batch updates the statistics
//! with its mean and **unbiased** variance through the parallel-variance merge
//!   δ = m_b − m, n' = n + n_b, m' = m + δ n_b / n',
//!   v' = (v n + v_b n_b + δ² n n_b / n') / n',
//! and is then normalised with the updated statistics: y = clamp((x − m) / √(v + ε), ±clip).
//! Batch moments are computed over fixed row blocks combined in block order, so results do not
//! depend on the number of threads.

use rayon::prelude::*;

/// Per-feature running statistics.
#[derive(Clone, Debug, PartialEq)]
pub struct RunningMeanStd {
    pub mean: Vec<f64>,
    pub var: Vec<f64>,
    pub count: f64,
    pub eps: f64,
    pub clip: f64,
}

const BLOCKS: usize = 32;

impl RunningMeanStd {
    /// Fresh statistics for `dim` features.
    pub fn new(dim: usize, eps: f64, clip: f64) -> Self {
        Self { mean: vec![0.0; dim], var: vec![1.0; dim], count: 1.0, eps, clip }
    }

    /// Check statistics read from a file: every mean finite, every variance finite and ≥ 0, the
    /// count finite and > 0, `eps` finite and > 0 (with a negative variance or ε, √(v + ε) is NaN)
    /// and `clip` > 0 (the clamp to ±clip needs it). The error names the field (`var[3]`, `eps`)
    /// and the value; `prefix` (e.g. `obs_norm`) is put before tensor names.
    pub fn check(&self, prefix: &str) -> Result<(), String> {
        if let Some((j, m)) = self.mean.iter().enumerate().find(|(_, m)| !m.is_finite()) {
            return Err(format!(
                "tensor '{prefix}.mean' entry {j} is {m}, expected a finite number"
            ));
        }
        if let Some((j, v)) =
            self.var.iter().enumerate().find(|(_, v)| !(v.is_finite() && **v >= 0.0))
        {
            return Err(format!(
                "tensor '{prefix}.var' entry {j} is {v}, expected a finite variance >= 0"
            ));
        }
        if !(self.count.is_finite() && self.count > 0.0) {
            return Err(format!(
                "tensor '{prefix}.count' is {}, expected a finite count > 0",
                self.count
            ));
        }
        if !(self.eps.is_finite() && self.eps > 0.0) {
            return Err(format!(
                "metadata field 'norm_eps' is {}, expected a finite number > 0",
                self.eps
            ));
        }
        if !(self.clip > 0.0) {
            return Err(format!(
                "metadata field 'norm_clip' is {}, expected a number > 0",
                self.clip
            ));
        }
        Ok(())
    }

    /// Feature count.
    pub fn dim(&self) -> usize {
        self.mean.len()
    }

    /// Sums of `x − shift` and `(x − shift)²` per feature over the rows of `x` (row-major, `dim`
    /// columns), in f64. Rows are summed in fixed blocks combined in block order, so the result
    /// does not depend on the number of threads. The sums of several batches add up to the sums of
    /// their union (data-parallel training all-reduces them; see [`Self::merge_sums`]).
    pub fn batch_sums(x: &[f32], dim: usize, shift: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let n = x.len() / dim;
        let rows_per = n.div_ceil(BLOCKS).max(1);
        let partial: Vec<(Vec<f64>, Vec<f64>)> = (0..BLOCKS)
            .into_par_iter()
            .map(|b| {
                let (mut s1, mut s2) = (vec![0.0f64; dim], vec![0.0f64; dim]);
                let lo = (b * rows_per).min(n);
                let hi = ((b + 1) * rows_per).min(n);
                for row in x[lo * dim..hi * dim].chunks_exact(dim) {
                    for j in 0..dim {
                        let d = row[j] as f64 - shift[j];
                        s1[j] += d;
                        s2[j] += d * d;
                    }
                }
                (s1, s2)
            })
            .collect();
        let (mut s1, mut s2) = (vec![0.0f64; dim], vec![0.0f64; dim]);
        for (a, b) in &partial {
            for j in 0..dim {
                s1[j] += a[j];
                s2[j] += b[j];
            }
        }
        (s1, s2)
    }

    /// Mean and unbiased variance of the `n` rows of `x` (row-major, `dim` columns).
    pub fn batch_moments(x: &[f32], dim: usize, shift: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let n = x.len() / dim;
        assert!(n >= 2, "a batch needs at least 2 rows for an unbiased variance");
        let (s1, s2) = Self::batch_sums(x, dim, shift);
        Self::moments_from_sums(n as f64, &s1, &s2, shift)
    }

    /// Mean and unbiased variance from `n` rows' sums of `x − shift` and `(x − shift)²`.
    pub fn moments_from_sums(
        n: f64,
        s1: &[f64],
        s2: &[f64],
        shift: &[f64],
    ) -> (Vec<f64>, Vec<f64>) {
        let mean = (0..s1.len()).map(|j| shift[j] + s1[j] / n).collect();
        let var =
            (0..s1.len()).map(|j| ((s2[j] - s1[j] * s1[j] / n) / (n - 1.0)).max(0.0)).collect();
        (mean, var)
    }

    /// Merge a batch (rows of `x`) into the statistics.
    pub fn update(&mut self, x: &[f32]) {
        let dim = self.dim();
        let nb = (x.len() / dim) as f64;
        let (s1, s2) = Self::batch_sums(x, dim, &self.mean);
        self.merge_sums(nb, &s1, &s2);
    }

    /// Merge a batch given by its row count `nb` (≥ 2) and its sums of `x − mean` and
    /// `(x − mean)²` taken with the current mean as the shift ([`Self::batch_sums`]).
    pub fn merge_sums(&mut self, nb: f64, s1: &[f64], s2: &[f64]) {
        let (bm, bv) = Self::moments_from_sums(nb, s1, s2, &self.mean);
        let tot = self.count + nb;
        for j in 0..self.dim() {
            let delta = bm[j] - self.mean[j];
            let m2 = self.var[j] * self.count + bv[j] * nb + delta * delta * self.count * nb / tot;
            self.mean[j] += delta * nb / tot;
            self.var[j] = m2 / tot;
        }
        self.count = tot;
    }

    /// Normalise rows of `x` into `out` (same shape) with the current statistics.
    pub fn normalize_into(&self, x: &[f32], out: &mut [f32]) {
        let dim = self.dim();
        let inv: Vec<f64> = self.var.iter().map(|v| 1.0 / (v + self.eps).sqrt()).collect();
        let (mean, clip) = (&self.mean, self.clip);
        out.par_chunks_mut(dim * 64).zip(x.par_chunks(dim * 64)).for_each(|(o, xi)| {
            for (orow, xrow) in o.chunks_exact_mut(dim).zip(xi.chunks_exact(dim)) {
                for j in 0..dim {
                    orow[j] = ((xrow[j] as f64 - mean[j]) * inv[j]).clamp(-clip, clip) as f32;
                }
            }
        });
    }

    /// Normalise a scalar feature value (dimension 1).
    pub fn normalize_scalar(&self, x: f64) -> f64 {
        ((x - self.mean[0]) / (self.var[0] + self.eps).sqrt()).clamp(-self.clip, self.clip)
    }

    /// Inverse of the normalisation for dimension 1: clamp to ±clip, then scale and shift.
    pub fn denormalize_scalar(&self, y: f64) -> f64 {
        y.clamp(-self.clip, self.clip) * (self.var[0] + self.eps).sqrt() + self.mean[0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merge_matches_a_hand_computed_example() {
        // one feature; batch [1, 2, 3, 4]: mean 2.5, unbiased var 5/3
        let mut r = RunningMeanStd::new(1, 1e-5, 5.0);
        r.update(&[1.0, 2.0, 3.0, 4.0]);
        // from (m 0, v 1, n 1): delta 2.5, n' 5, m' = 2.5*4/5 = 2, v' = (1 + 5/3*4 + 6.25*4/5)/5
        assert!((r.mean[0] - 2.0).abs() < 1e-12);
        assert!((r.var[0] - (1.0 + 20.0 / 3.0 + 5.0) / 5.0).abs() < 1e-12);
        assert_eq!(r.count, 5.0);
        let y = r.normalize_scalar(4.0);
        assert!((y - 2.0 / (r.var[0] + 1e-5).sqrt()).abs() < 1e-12);
        assert!((r.denormalize_scalar(y) - 4.0).abs() < 1e-9);
        assert_eq!(r.normalize_scalar(1e9), 5.0);
    }

    #[test]
    fn check_refuses_statistics_that_would_give_nan() {
        let good = RunningMeanStd::new(3, 1e-5, 5.0);
        good.check("obs_norm").unwrap();
        let with = |f: &dyn Fn(&mut RunningMeanStd)| {
            let mut r = good.clone();
            f(&mut r);
            r.check("obs_norm").unwrap_err()
        };
        assert_eq!(
            with(&|r| r.var[1] = -1.0),
            "tensor 'obs_norm.var' entry 1 is -1, expected a finite variance >= 0"
        );
        assert!(with(&|r| r.mean[2] = f64::NAN).contains("'obs_norm.mean' entry 2 is NaN"));
        assert!(with(&|r| r.eps = -1e-5).contains("'norm_eps' is -0.00001"));
        assert!(with(&|r| r.eps = 0.0).contains("'norm_eps' is 0"));
        assert!(with(&|r| r.clip = f64::NAN).contains("'norm_clip' is NaN"));
        assert!(with(&|r| r.clip = -1.0).contains("'norm_clip' is -1"));
        assert!(with(&|r| r.count = 0.0).contains("'obs_norm.count' is 0"));
    }

    #[test]
    fn moments_do_not_depend_on_threads() {
        let x: Vec<f32> = (0..4000).map(|i| ((i * 7919) % 1000) as f32 * 0.01 - 3.0).collect();
        let a = RunningMeanStd::batch_moments(&x, 4, &[0.0; 4]);
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let b = pool.install(|| RunningMeanStd::batch_moments(&x, 4, &[0.0; 4]));
        assert_eq!(a, b);
    }
}
