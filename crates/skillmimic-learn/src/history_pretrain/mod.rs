//! Pre-training of the SkillMimic-V2 history encoder by next-state prediction (seed 003 §4.6,
//! App. B.5; reference-facts §9.4), in candle.
//!
//! * Data: for every clip, the 316-d reference features of all frames (forward kinematics in the
//!   environment's scene, true heading: `skillmimic_env::v2::history`). One sample per frame
//!   i = 0 … T−2: history = features [i−k, i) (zero rows before frame 0), current = feature i,
//!   condition = one-hot(64) skill label, target = feature i+1.
//! * Model: the encoder (3 convolutions + linear, μ outputs) and a predictor MLP
//!   (μ + 316 + 64 → 512 → 256 → 316, ReLU; the reference code's sizes), trained jointly.
//! * Loss: λa · mean over elements of (ŝ − s)² + λb · mean over the batch of ‖h‖²
//!   (P2 eq. 23: λa = 1, λb = 1e-5; the reference code leaves the λb term out).
//! * Optimiser: Adam (lr 1e-3), ReduceLROnPlateau on the epoch's mean training loss (batch-size
//!   weighted; factor 0.1, patience 5, relative threshold 1e-4 — PyTorch's defaults), minibatches
//!   of 256 drawn without replacement (last one partial), seeded shuffling; PyTorch-default
//!   initialisation U(±1/√fan_in) for weights and biases. Training stops early once the learning
//!   rate has fallen below 1e-6 × its start (`stop_lr_ratio`), where further epochs no longer
//!   change the weights.
//!
//! Convolutions are written as zero-pad + unfold (concatenate the shifted sequences along the
//! channel axis) + one matrix product, so candle's gemm does the work and its autograd gives the
//! gradients; weights stay in PyTorch's `(c_out, c_in, k)` layout. In training the first
//! convolution, which holds 90 % of the work, is computed once per distinct frame of the batch:
//! its three kernel taps are applied to every frame (one product of the frames with the 316 × 384
//! stacked taps), and each window position then gathers its previous / current / next frame's
//! taps (zero at the window edges and before frame 0). Windows of a batch overlap heavily, so
//! this is the same function at a fraction of the cost (tested against the plain path).

use candle_core::{D, Device, Tensor, Var};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use skillmimic_motion::SKILL_WIDTH;
use skillmimic_nn::history::{
    CHANNELS, FEATURE_DIM, HistoryEncoder, KERNEL, TENSOR_NAMES, candle_forward,
    candle_forward_shared, reference_window,
};

use crate::adam::Adam;
use crate::error::LearnError;

/// Pre-training settings (defaults: the paper's / reference code's values).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PretrainConfig {
    /// History length k.
    pub history_length: usize,
    /// Embedding width μ.
    pub embed_dim: usize,
    /// Predictor hidden widths.
    pub predictor_hidden: Vec<usize>,
    pub epochs: usize,
    pub batch: usize,
    pub lr: f64,
    pub lambda_a: f64,
    pub lambda_b: f64,
    /// ReduceLROnPlateau patience (epochs) and factor.
    pub plateau_patience: usize,
    pub plateau_factor: f64,
    /// Stop once the learning rate has been reduced below `stop_lr_ratio` × `lr`: later epochs
    /// cannot move the weights measurably (the reference runs all epochs; results are the same).
    /// 0 = run every epoch.
    pub stop_lr_ratio: f64,
    pub seed: u64,
}

impl Default for PretrainConfig {
    fn default() -> Self {
        Self {
            history_length: 60,
            embed_dim: 3,
            predictor_hidden: vec![512, 256],
            epochs: 1000,
            batch: 256,
            lr: 1e-3,
            lambda_a: 1.0,
            lambda_b: 1e-5,
            plateau_patience: 5,
            plateau_factor: 0.1,
            stop_lr_ratio: 1e-6,
            seed: 0,
        }
    }
}

/// What pre-training measured.
#[derive(Clone, Debug, Default, Serialize)]
pub struct PretrainReport {
    pub clips: usize,
    pub samples: usize,
    /// Epochs run (fewer than configured when the learning rate fell below the stop ratio).
    pub epochs: usize,
    /// Next-state prediction MSE over the whole data set before and after training.
    pub initial_prediction_mse: f64,
    pub final_prediction_mse: f64,
    /// Mean training loss (λa·MSE + λb·‖h‖²) of the first and of the last epoch.
    pub first_epoch_loss: f64,
    pub last_epoch_loss: f64,
    /// Mean ‖h‖² over the data set after training.
    pub final_embedding_sq_norm: f64,
    pub final_lr: f64,
    pub seconds: f64,
    /// Mean training loss of every epoch.
    pub epoch_loss: Vec<f64>,
}

/// Pre-training data: per clip its feature rows and skill label.
#[derive(Clone, Debug)]
pub struct PretrainData {
    pub features: Vec<Vec<f32>>,
    pub labels: Vec<u32>,
    /// (clip, frame i) of every sample, i = 0 … T−2.
    pub samples: Vec<(usize, usize)>,
}

impl PretrainData {
    /// Samples of every clip (rows `[T × 316]` per clip).
    pub fn new(features: Vec<Vec<f32>>, labels: Vec<u32>) -> Self {
        let samples = features
            .iter()
            .enumerate()
            .flat_map(|(c, rows)| {
                (0..(rows.len() / FEATURE_DIM).saturating_sub(1)).map(move |i| (c, i))
            })
            .collect();
        Self { features, labels, samples }
    }

    /// Host arrays of a batch: windows (B·k·316), current (B·316), one-hot (B·64), target (B·316).
    fn batch(&self, idx: &[(usize, usize)], k: usize) -> [Vec<f32>; 4] {
        let mut out = self.batch_rows(idx);
        out[0] = vec![0.0f32; idx.len() * k * FEATURE_DIM];
        for (r, &(c, i)) in idx.iter().enumerate() {
            reference_window(
                &self.features[c],
                i,
                &mut out[0][r * k * FEATURE_DIM..(r + 1) * k * FEATURE_DIM],
            );
        }
        out
    }
}

/// A training batch with its frames deduplicated for the shared first convolution.
struct SharedBatch {
    /// Distinct frames (U × 316) followed by one zero row (index U).
    frames: Vec<f32>,
    rows: usize,
    /// Per window position (B·k): row of the previous, current and next frame.
    prev: Vec<u32>,
    cur: Vec<u32>,
    next: Vec<u32>,
    current: Vec<f32>,
    onehot: Vec<f32>,
    target: Vec<f32>,
}

impl PretrainData {
    fn shared_batch(&self, idx: &[(usize, usize)], k: usize) -> SharedBatch {
        let mut row_of: std::collections::HashMap<(usize, usize), u32> =
            std::collections::HashMap::new();
        let mut order: Vec<(usize, usize)> = Vec::new();
        let b = idx.len();
        // window position τ of sample (c, i) holds frame i − k + τ (negative: zero row)
        let frame_at = |i: usize, tau: isize| -> Option<usize> {
            let t = i as isize - k as isize + tau;
            (t >= 0 && tau >= 0 && tau < k as isize).then_some(t as usize)
        };
        let mut ids = vec![[None::<(usize, usize)>; 3]; b * k];
        for (r, &(c, i)) in idx.iter().enumerate() {
            for tau in 0..k as isize {
                for (j, d) in [-1isize, 0, 1].into_iter().enumerate() {
                    if let Some(t) = frame_at(i, tau + d) {
                        ids[r * k + tau as usize][j] = Some((c, t));
                        row_of.entry((c, t)).or_insert_with(|| {
                            order.push((c, t));
                            (order.len() - 1) as u32
                        });
                    }
                }
            }
        }
        let u = order.len();
        let mut frames = vec![0.0f32; (u + 1) * FEATURE_DIM];
        for (r, &(c, t)) in order.iter().enumerate() {
            frames[r * FEATURE_DIM..(r + 1) * FEATURE_DIM]
                .copy_from_slice(&self.features[c][t * FEATURE_DIM..(t + 1) * FEATURE_DIM]);
        }
        let pick = |j: usize| {
            ids.iter().map(|e| e[j].map_or(u as u32, |key| row_of[&key])).collect::<Vec<u32>>()
        };
        let [_, current, onehot, target] = self.batch_rows(idx);
        SharedBatch {
            frames,
            rows: u + 1,
            prev: pick(0),
            cur: pick(1),
            next: pick(2),
            current,
            onehot,
            target,
        }
    }

    /// Current features, one-hot labels and targets of a batch (the window part left empty).
    fn batch_rows(&self, idx: &[(usize, usize)]) -> [Vec<f32>; 4] {
        let b = idx.len();
        let mut cur = vec![0.0f32; b * FEATURE_DIM];
        let mut onehot = vec![0.0f32; b * SKILL_WIDTH];
        let mut tgt = vec![0.0f32; b * FEATURE_DIM];
        for (r, &(c, i)) in idx.iter().enumerate() {
            let rows = &self.features[c];
            cur[r * FEATURE_DIM..(r + 1) * FEATURE_DIM]
                .copy_from_slice(&rows[i * FEATURE_DIM..(i + 1) * FEATURE_DIM]);
            tgt[r * FEATURE_DIM..(r + 1) * FEATURE_DIM]
                .copy_from_slice(&rows[(i + 1) * FEATURE_DIM..(i + 2) * FEATURE_DIM]);
            onehot[r * SKILL_WIDTH + self.labels[c] as usize] = 1.0;
        }
        [Vec::new(), cur, onehot, tgt]
    }
}

/// Encoder forward of a [`SharedBatch`] (B samples, window k) → h (B, μ).
fn encode_shared(
    p: &[Tensor],
    sb: &SharedBatch,
    b: usize,
    k: usize,
    dev: &Device,
) -> candle_core::Result<Tensor> {
    let x = Tensor::from_slice(&sb.frames, (sb.rows, FEATURE_DIM), dev)?;
    candle_forward_shared(p, &x, &sb.prev, &sb.cur, &sb.next, b, k)
}

/// Parameters (PyTorch layouts): the 8 encoder tensors, then predictor weight/bias pairs.
struct Params {
    shapes: Vec<Vec<usize>>,
    values: Vec<Vec<f32>>,
}

fn init_params(cfg: &PretrainConfig, rng: &mut ChaCha8Rng) -> Params {
    let mut shapes = Vec::new();
    let dims = [FEATURE_DIM, CHANNELS[0], CHANNELS[1], CHANNELS[2]];
    for l in 0..3 {
        shapes.push(vec![dims[l + 1], dims[l], KERNEL]);
        shapes.push(vec![dims[l + 1]]);
    }
    shapes.push(vec![cfg.embed_dim, CHANNELS[2] * cfg.history_length]);
    shapes.push(vec![cfg.embed_dim]);
    let mut widths = vec![cfg.embed_dim + FEATURE_DIM + SKILL_WIDTH];
    widths.extend(&cfg.predictor_hidden);
    widths.push(FEATURE_DIM);
    for w in widths.windows(2) {
        shapes.push(vec![w[1], w[0]]);
        shapes.push(vec![w[1]]);
    }
    let mut values = Vec::new();
    for pair in shapes.chunks(2) {
        let fan_in: usize = pair[0][1..].iter().product();
        let bound = 1.0 / (fan_in as f32).sqrt();
        for s in pair {
            let n: usize = s.iter().product();
            values.push((0..n).map(|_| rng.random_range(-bound..bound)).collect());
        }
    }
    Params { shapes, values }
}

/// Encoder forward: windows (B, k, 316) → h (B, μ).
fn encode(p: &[Tensor], win: &Tensor) -> candle_core::Result<Tensor> {
    candle_forward(p, win)
}

/// Predictor forward on concat(h, current, one-hot).
fn predict(p: &[Tensor], h: &Tensor, cur: &Tensor, onehot: &Tensor) -> candle_core::Result<Tensor> {
    let mut x = Tensor::cat(&[h, cur, onehot], 1)?;
    let layers = (p.len() - 8) / 2;
    for l in 0..layers {
        x = x.matmul(&p[8 + 2 * l].t()?)?.broadcast_add(&p[9 + 2 * l])?;
        if l + 1 < layers {
            x = x.relu()?;
        }
    }
    Ok(x)
}

/// (prediction MSE sum over elements, ‖h‖² sum) of a batch, without gradients.
fn evaluate_batch(
    p: &[Tensor],
    host: &[Vec<f32>; 4],
    b: usize,
    k: usize,
    dev: &Device,
) -> candle_core::Result<(f64, f64)> {
    let win = Tensor::from_slice(&host[0], (b, k, FEATURE_DIM), dev)?;
    let cur = Tensor::from_slice(&host[1], (b, FEATURE_DIM), dev)?;
    let oh = Tensor::from_slice(&host[2], (b, SKILL_WIDTH), dev)?;
    let tgt = Tensor::from_slice(&host[3], (b, FEATURE_DIM), dev)?;
    let h = encode(p, &win)?;
    let pred = predict(p, &h, &cur, &oh)?;
    let se = (pred - tgt)?.sqr()?.sum_all()?.to_scalar::<f32>()? as f64;
    let hn = h.sqr()?.sum_all()?.to_scalar::<f32>()? as f64;
    Ok((se, hn))
}

fn dataset_mse(
    params: &Params,
    data: &PretrainData,
    cfg: &PretrainConfig,
    dev: &Device,
) -> candle_core::Result<(f64, f64)> {
    let p: Vec<Tensor> = params
        .values
        .iter()
        .zip(&params.shapes)
        .map(|(v, s)| Tensor::from_slice(v, s.as_slice(), dev))
        .collect::<Result<_, _>>()?;
    let (mut se, mut hn) = (0.0, 0.0);
    for chunk in data.samples.chunks(cfg.batch.max(1)) {
        let host = data.batch(chunk, cfg.history_length);
        let (a, b) = evaluate_batch(&p, &host, chunk.len(), cfg.history_length, dev)?;
        se += a;
        hn += b;
    }
    let n = data.samples.len().max(1) as f64;
    Ok((se / (n * FEATURE_DIM as f64), hn / n))
}

/// ReduceLROnPlateau (mode min, relative threshold, no cooldown).
struct Plateau {
    best: f64,
    bad: usize,
    patience: usize,
    factor: f64,
}

impl Plateau {
    fn step(&mut self, loss: f64, lr: &mut f64) {
        if loss < self.best * (1.0 - 1e-4) {
            self.best = loss;
            self.bad = 0;
        } else {
            self.bad += 1;
            if self.bad > self.patience {
                *lr *= self.factor;
                self.bad = 0;
            }
        }
    }
}

/// Train encoder and predictor; `on_epoch(epoch, mean loss, lr)` reports progress. Returns the
/// encoder (the predictor is only a training device) and the report.
pub fn pretrain(
    data: &PretrainData,
    cfg: &PretrainConfig,
    mut on_epoch: impl FnMut(usize, f64, f64),
) -> Result<(HistoryEncoder, PretrainReport), LearnError> {
    if data.samples.is_empty() {
        return Err(LearnError::Config(
            "history pre-training: the clips give no samples (each clip needs at least 2 frames)"
                .into(),
        ));
    }
    if cfg.history_length == 0 || cfg.embed_dim == 0 || cfg.batch == 0 {
        return Err(LearnError::Config(
            "history pre-training: history_length, embed_dim and batch must be >= 1".into(),
        ));
    }
    let dev = Device::Cpu;
    let start = std::time::Instant::now();
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let mut params = init_params(cfg, &mut rng);
    let sizes: Vec<usize> = params.values.iter().map(Vec::len).collect();
    let mut adam = Adam::new(&sizes, cfg.lr, 1e-8);
    let mut plateau = Plateau {
        best: f64::INFINITY,
        bad: 0,
        patience: cfg.plateau_patience,
        factor: cfg.plateau_factor,
    };
    let mut rep = PretrainReport {
        clips: data.features.len(),
        samples: data.samples.len(),
        ..Default::default()
    };
    rep.initial_prediction_mse = dataset_mse(&params, data, cfg, &dev)?.0;
    let k = cfg.history_length;
    let mut order = data.samples.clone();
    let mut lr = cfg.lr;
    for epoch in 0..cfg.epochs {
        order.shuffle(&mut rng);
        let mut loss_sum = 0.0;
        for chunk in order.chunks(cfg.batch) {
            let b = chunk.len();
            let sb = data.shared_batch(chunk, k);
            let step = || -> candle_core::Result<(f64, Vec<Vec<f32>>)> {
                let vars: Vec<Var> = params
                    .values
                    .iter()
                    .zip(&params.shapes)
                    .map(|(v, s)| Var::from_slice(v, s.as_slice(), &dev))
                    .collect::<Result<_, _>>()?;
                let p: Vec<Tensor> = vars.iter().map(|v| v.as_tensor().clone()).collect();
                let cur = Tensor::from_slice(&sb.current, (b, FEATURE_DIM), &dev)?;
                let oh = Tensor::from_slice(&sb.onehot, (b, SKILL_WIDTH), &dev)?;
                let tgt = Tensor::from_slice(&sb.target, (b, FEATURE_DIM), &dev)?;
                let h = encode_shared(&p, &sb, b, k, &dev)?;
                let pred = predict(&p, &h, &cur, &oh)?;
                let mse = (pred - tgt)?.sqr()?.mean_all()?;
                let reg = h.sqr()?.sum(D::Minus1)?.mean_all()?;
                let loss = ((mse * cfg.lambda_a)? + (reg * cfg.lambda_b)?)?;
                let grads = loss.backward()?;
                let g = vars
                    .iter()
                    .map(|v| match grads.get(v.as_tensor()) {
                        Some(g) => g.flatten_all()?.to_vec1::<f32>(),
                        None => Ok(vec![0.0; v.as_tensor().elem_count()]),
                    })
                    .collect::<candle_core::Result<Vec<_>>>()?;
                Ok((loss.to_scalar::<f32>()? as f64, g))
            };
            let (loss, grads) = step()?;
            if !loss.is_finite() {
                return Err(LearnError::Diverged(format!(
                    "history pre-training diverged at epoch {} (loss {loss}); lower the learning \
                        rate",
                    epoch + 1
                )));
            }
            adam.lr = lr;
            let mut refs: Vec<&mut Vec<f32>> = params.values.iter_mut().collect();
            adam.update(&mut refs, &grads);
            loss_sum += loss * b as f64;
        }
        // batch-size weighted: the data set's mean loss along the epoch
        let mean = loss_sum / order.len() as f64;
        rep.epoch_loss.push(mean);
        rep.epochs = epoch + 1;
        plateau.step(mean, &mut lr);
        on_epoch(epoch + 1, mean, lr);
        if lr < cfg.stop_lr_ratio * cfg.lr {
            break;
        }
    }
    let (mse, hn) = dataset_mse(&params, data, cfg, &dev)?;
    rep.final_prediction_mse = mse;
    rep.final_embedding_sq_norm = hn;
    rep.first_epoch_loss = rep.epoch_loss.first().copied().unwrap_or(f64::NAN);
    rep.last_epoch_loss = rep.epoch_loss.last().copied().unwrap_or(f64::NAN);
    rep.final_lr = lr;
    rep.seconds = start.elapsed().as_secs_f64();
    let enc_t: [Vec<f32>; 8] = std::array::from_fn(|i| params.values[i].clone());
    debug_assert_eq!(TENSOR_NAMES.len(), 8);
    Ok((HistoryEncoder::from_torch(cfg.history_length, cfg.embed_dim, &enc_t), rep))
}

#[cfg(test)]
mod tests;
