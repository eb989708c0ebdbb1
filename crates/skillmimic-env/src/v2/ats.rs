//! Adaptive Trajectory Sampling (SkillMimic-V2, seed 003 §4.5, eq. 8): start states where the
//! policy earns little reward are sampled more often.
//!
//! * Every finished episode reports r̄ for its (clip, start frame): the episode's reward per
//!   planned step (masked steps excluded; steps lost to an early fall count as zero, which is the
//!   paper's "average reward from frame i to the end" restricted to the episode horizon — the
//!   reference code's mean over the steps actually taken rates an episode that falls at once as
//!   well as one that survives). The table keeps an exponential average with factor ½ starting
//!   at 0, so never-tried frames keep the largest weight.
//! * Every `update_interval` vectorised steps the distributions are recomputed:
//!   frames p(s | m) = (1 − α)/(T−3) + α·softmax_s(−λ_s r̄_{m,s}), s = 2 … T−2;
//!   clips: R_m = mean over the clip's frames, R_c = mean of R_m over the clips of class c,
//!   P_m ∝ softmax_c(−λ_c R_c) · softmax_{m ∈ c}(−λ_c R_m), then (1 − α)/M + α·P_m.

use rand::Rng;
use skillmimic_motion::MotionLibrary;

use crate::config::AtsConfig;

/// Sampling tables and distributions.
#[derive(Clone, Debug)]
pub struct AdaptiveSampler {
    cfg: AtsConfig,
    interval: usize,
    steps: usize,
    classes: Vec<u32>,
    /// `[clip][start − 2]` → r̄.
    table: Vec<Vec<f64>>,
    clip_cdf: Vec<f64>,
    frame_cdf: Vec<Vec<f64>>,
    clip_p: Vec<f64>,
    frame_p: Vec<Vec<f64>>,
}

fn softmax_neg(values: &[f64], lambda: f64) -> Vec<f64> {
    let m = values.iter().copied().fold(f64::INFINITY, f64::min);
    let e: Vec<f64> = values.iter().map(|&v| (-lambda * (v - m)).exp()).collect();
    let s: f64 = e.iter().sum();
    e.into_iter().map(|x| x / s).collect()
}

fn cdf(p: &[f64]) -> Vec<f64> {
    let mut acc = 0.0;
    p.iter()
        .map(|x| {
            acc += x;
            acc
        })
        .collect()
}

fn draw<R: Rng>(cdf: &[f64], rng: &mut R) -> usize {
    let u = rng.random::<f64>() * cdf.last().copied().unwrap_or(1.0);
    cdf.partition_point(|&c| c <= u).min(cdf.len() - 1)
}

impl AdaptiveSampler {
    /// A sampler for `lib` with all table entries 0: uniform frames, and until the first update
    /// uniform classes, or the clip probabilities `initial` when given (the released code starts
    /// from the library's class-balanced weights, pickup counted twice; `env.compat = "code"`).
    pub fn new(lib: &MotionLibrary, cfg: &AtsConfig, initial: Option<&[f64]>) -> Self {
        let total: usize = (0..lib.len()).map(|c| lib.get(c).clip.num_frames).sum();
        let interval = if cfg.update_interval > 0 { cfg.update_interval } else { 5 * total };
        let table = (0..lib.len()).map(|c| vec![0.0; lib.get(c).clip.num_frames - 3]).collect();
        let classes = (0..lib.len()).map(|c| lib.get(c).clip.skill).collect();
        let mut s = Self {
            cfg: cfg.clone(),
            interval,
            steps: 0,
            classes,
            table,
            clip_cdf: vec![],
            frame_cdf: vec![],
            clip_p: vec![],
            frame_p: vec![],
        };
        s.recompute();
        if let Some(w) = initial.filter(|w| w.len() == s.clip_p.len()) {
            let z: f64 = w.iter().sum();
            s.clip_p = w.iter().map(|x| x / z).collect();
            s.clip_cdf = cdf(&s.clip_p);
        }
        s
    }

    /// Record an episode that started at `start` of `clip` and earned `mean_reward` per step.
    pub fn record(&mut self, clip: usize, start: usize, mean_reward: f64) {
        if let Some(cell) = start.checked_sub(2).and_then(|k| self.table.get_mut(clip)?.get_mut(k))
        {
            *cell = 0.5 * (*cell + mean_reward);
        }
    }

    /// Count one vectorised step; recompute the distributions every `update_interval` steps.
    /// Returns true when it recomputed.
    pub fn tick(&mut self) -> bool {
        self.steps += 1;
        if self.steps >= self.interval {
            self.steps = 0;
            self.recompute();
            true
        } else {
            false
        }
    }

    /// Recompute the clip and frame distributions from the table.
    pub fn recompute(&mut self) {
        let (a, ls, lc) = (self.cfg.alpha, self.cfg.lambda_s, self.cfg.lambda_c);
        self.frame_p = self
            .table
            .iter()
            .map(|t| {
                let sm = softmax_neg(t, ls);
                let u = (1.0 - a) / t.len() as f64;
                sm.into_iter().map(|p| u + a * p).collect()
            })
            .collect();
        let m = self.table.len();
        let r_m: Vec<f64> =
            self.table.iter().map(|t| t.iter().sum::<f64>() / t.len() as f64).collect();
        let mut classes = self.classes.clone();
        classes.sort_unstable();
        classes.dedup();
        let r_c: Vec<f64> = classes
            .iter()
            .map(|&c| {
                let v: Vec<f64> =
                    (0..m).filter(|&i| self.classes[i] == c).map(|i| r_m[i]).collect();
                v.iter().sum::<f64>() / v.len() as f64
            })
            .collect();
        let p_class = softmax_neg(&r_c, lc);
        let mut p = vec![0.0; m];
        for (k, &c) in classes.iter().enumerate() {
            let members: Vec<usize> = (0..m).filter(|&i| self.classes[i] == c).collect();
            let within = softmax_neg(&members.iter().map(|&i| r_m[i]).collect::<Vec<_>>(), lc);
            for (&i, w) in members.iter().zip(within) {
                p[i] = p_class[k] * w;
            }
        }
        self.clip_p = p.into_iter().map(|x| (1.0 - a) / m as f64 + a * x).collect();
        self.clip_cdf = cdf(&self.clip_p);
        self.frame_cdf = self.frame_p.iter().map(|p| cdf(p)).collect();
    }

    /// Draw a clip and a start frame (2 … T−2).
    pub fn sample<R: Rng>(&self, rng: &mut R) -> (usize, usize) {
        let clip = draw(&self.clip_cdf, rng);
        (clip, 2 + draw(&self.frame_cdf[clip], rng))
    }

    /// Current clip probabilities.
    pub fn clip_probs(&self) -> &[f64] {
        &self.clip_p
    }
    /// Current start-frame probabilities of `clip` (index 0 = frame 2).
    pub fn frame_probs(&self, clip: usize) -> &[f64] {
        &self.frame_p[clip]
    }
    /// The r̄ table of `clip` (index 0 = frame 2).
    pub fn table(&self, clip: usize) -> &[f64] {
        &self.table[clip]
    }

    /// What changes while the sampler runs (exact resume): the update clock, the r̄ table and
    /// the distributions of the last recompute (they lag the table until the next one).
    pub fn saved(&self) -> SamplerState {
        SamplerState {
            steps: self.steps,
            table: self.table.clone(),
            clip_p: self.clip_p.clone(),
            frame_p: self.frame_p.clone(),
            clip_cdf: self.clip_cdf.clone(),
            frame_cdf: self.frame_cdf.clone(),
        }
    }

    /// Restore [`saved`](Self::saved) state of a sampler over the same clips and frames.
    pub fn restore(&mut self, s: SamplerState) -> Result<(), String> {
        let lens = |t: &[Vec<f64>]| t.iter().map(Vec::len).collect::<Vec<_>>();
        let want = lens(&self.table);
        for (what, got) in [
            ("r̄ table", lens(&s.table)),
            ("frame probabilities", lens(&s.frame_p)),
            ("frame cdf", lens(&s.frame_cdf)),
        ] {
            if got != want {
                return Err(format!(
                    "adaptive sampler: the saved {what} covers {} clips / {} frames, this \
                    library {} / {}",
                    got.len(),
                    got.iter().sum::<usize>(),
                    want.len(),
                    want.iter().sum::<usize>()
                ));
            }
        }
        if s.clip_p.len() != want.len() || s.clip_cdf.len() != want.len() {
            return Err(format!(
                "adaptive sampler: saved clip probabilities for {} clips, this library has {}",
                s.clip_p.len(),
                want.len()
            ));
        }
        self.steps = s.steps;
        self.table = s.table;
        self.clip_p = s.clip_p;
        self.frame_p = s.frame_p;
        self.clip_cdf = s.clip_cdf;
        self.frame_cdf = s.frame_cdf;
        Ok(())
    }
}

/// The running state of an [`AdaptiveSampler`] ([`AdaptiveSampler::saved`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SamplerState {
    pub steps: usize,
    pub table: Vec<Vec<f64>>,
    pub clip_p: Vec<f64>,
    pub frame_p: Vec<Vec<f64>>,
    pub clip_cdf: Vec<f64>,
    pub frame_cdf: Vec<Vec<f64>>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use skillmimic_motion::clip::Clip;

    fn clip(skill: u32, frames: usize) -> Clip {
        let rows = vec![0.0f32; frames * skillmimic_motion::clip::PT_WIDTH];
        // zero rows: identity rotations, everything at the origin
        Clip::from_rows(format!("{skill:03}_c"), "test".into(), skill, 60.0, frames, &rows)
    }

    #[test]
    fn probabilities_match_a_hand_computed_example() {
        // class 1: clips 0 (6 frames -> 3 starts) and 1 (5 frames -> 2 starts); class 2: clip 2
        let lib = MotionLibrary::from_clips(vec![clip(1, 6), clip(1, 5), clip(2, 5)]).unwrap();
        let cfg = AtsConfig {
            enabled: true,
            lambda_s: 10.0,
            lambda_c: 5.0,
            alpha: 1.0,
            update_interval: 3,
        };
        let mut s = AdaptiveSampler::new(&lib, &cfg, None);
        // all zero: uniform frames, classes equally likely, clips equal within the class
        assert_eq!(s.frame_probs(0), &[1.0 / 3.0; 3]);
        let cp = s.clip_probs();
        assert!(
            (cp[0] - 0.25).abs() < 1e-12
                && (cp[1] - 0.25).abs() < 1e-12
                && (cp[2] - 0.5).abs() < 1e-12
        );
        // clip 0: start 2 earns 0.4 twice -> 0.5*(0+0.4)=0.2, then 0.5*(0.2+0.4)=0.3; start 3 earns
        // 0.2 once -> 0.1
        s.record(0, 2, 0.4);
        s.record(0, 2, 0.4);
        s.record(0, 3, 0.2);
        // clip 2: starts 2 and 3 earn 0.6 -> 0.3 each
        s.record(2, 2, 0.6);
        s.record(2, 3, 0.6);
        s.record(9, 2, 1.0); // unknown clip: ignored
        s.record(0, 99, 1.0); // unknown frame: ignored
        for (got, want) in s.table(0).iter().zip([0.3, 0.1, 0.0]) {
            assert!((got - want).abs() < 1e-15, "{got} vs {want}");
        }
        assert!(!s.tick() && !s.tick() && s.tick()); // recomputed on the third step
        // frames of clip 0: exp(-10 r) over [0.3, 0.1, 0] normalised
        let e = [(-3.0f64).exp(), (-1.0f64).exp(), 1.0];
        let z: f64 = e.iter().sum();
        for (p, want) in s.frame_probs(0).iter().zip(e.iter().map(|x| x / z)) {
            assert!((p - want).abs() < 1e-12, "{p} vs {want}");
        }
        // clips: R_0 = 0.4/3, R_1 = 0, R_2 = 0.3; R_class1 = (0.4/3 + 0)/2 = 1/15, R_class2 = 0.3
        let (r0, r1, r2): (f64, f64, f64) = (0.4 / 3.0, 0.0, 0.3);
        let (rc1, rc2) = ((r0 + r1) / 2.0, r2);
        let (c1, c2) = ((-5.0 * rc1).exp(), (-5.0f64 * rc2).exp());
        let (pc1, pc2) = (c1 / (c1 + c2), c2 / (c1 + c2));
        let (w0, w1) = ((-5.0f64 * r0).exp(), (-5.0f64 * r1).exp());
        let want = [pc1 * w0 / (w0 + w1), pc1 * w1 / (w0 + w1), pc2];
        for (p, w) in s.clip_probs().iter().zip(want) {
            assert!((p - w).abs() < 1e-12, "{p} vs {w}");
        }
        // alpha mixes with uniform
        let mut half = AdaptiveSampler::new(&lib, &AtsConfig { alpha: 0.5, ..cfg.clone() }, None);
        half.record(0, 2, 0.4);
        half.recompute();
        let sm = softmax_neg(&[0.2, 0.0, 0.0], 10.0);
        assert!((half.frame_probs(0)[0] - (0.5 / 3.0 + 0.5 * sm[0])).abs() < 1e-12);
        // sampling follows the distribution
        let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(1);
        let mut counts = [0usize; 3];
        for _ in 0..20000 {
            let (c, f) = s.sample(&mut rng);
            assert!((2..=lib.get(c).clip.num_frames - 2).contains(&f));
            counts[c] += 1;
        }
        for (k, w) in want.iter().enumerate() {
            assert!(
                (counts[k] as f64 / 20000.0 - w).abs() < 0.015,
                "clip {k}: {} vs {w}",
                counts[k]
            );
        }
    }
}
