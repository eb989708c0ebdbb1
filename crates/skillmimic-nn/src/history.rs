//! The SkillMimic-V2 history encoder network (seed 003 §4.6, App. B.5; reference-facts §9.3):
//! one definition used by the environment's online inference and by pre-training.
//!
//! **Input**: a window of k per-frame features (k × [`FEATURE_DIM`] = 316, oldest frame first;
//! the feature itself is defined by `skillmimic_env::v2::history`).
//! **Network**: Conv1d 316→128, 128→64, 64→32 (kernel 3, stride 1, zero padding 1, ReLU each);
//! flatten channel-major (c·k + τ, PyTorch's order); Linear 32·k → μ. Tensor names and layouts
//! are those of the PyTorch module `skillmimic_rs.history.HistoryEncoder` (`conv1.weight`
//! (128, 316, 3), …, `fc.weight` (μ, 32k)).
//!
//! Three forward paths over the same parameters, tested against each other:
//! * [`candle_forward`] / [`candle_forward_shared`]: candle graphs (autograd for pre-training);
//! * [`HistoryEncoder::embed`]: the plain CPU pass over one window;
//! * [`HistoryBuffer`]: the online per-environment buffer. The embedding is read before the
//!   current frame is pushed (h_t summarises frames t−k … t−1). It keeps every convolution
//!   layer's output per frame: a position whose receptive field lies inside the window never
//!   changes as the window slides, so a push recomputes only the 2l+1 boundary positions of layer
//!   l (≈ 17× less work than a full pass) with results bit-identical to `embed`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use candle_core::Tensor;
use skillmimic_core::tensorfile::{OwnedTensor, TensorFile, TensorFileError, write_atomic};

/// Width of the per-frame history feature.
pub const FEATURE_DIM: usize = 316;
/// Channels of the three convolutions.
pub const CHANNELS: [usize; 3] = [128, 64, 32];
/// Kernel width of the convolutions.
pub const KERNEL: usize = 3;
/// The paper's history length k and embedding width μ.
pub const DEFAULT_LENGTH: usize = 60;
pub const DEFAULT_EMBED: usize = 3;
/// `format` metadata value of encoder files.
pub const FORMAT: &str = "skillmimic-history-encoder";

/// Error loading an encoder file.
#[derive(Debug, thiserror::Error)]
pub enum HistoryError {
    #[error(transparent)]
    File(#[from] TensorFileError),
    #[error("{path}: {detail}")]
    Invalid { path: PathBuf, detail: String },
}

/// Fill `window` (k × 316, oldest first) with reference rows [s − k, s) of a clip's feature table
/// (zero rows before frame 0).
pub fn reference_window(rows: &[f32], s: usize, window: &mut [f32]) {
    let k = window.len() / FEATURE_DIM;
    for (i, w) in window.chunks_exact_mut(FEATURE_DIM).enumerate() {
        // window row i holds frame s − k + i
        match (s + i).checked_sub(k) {
            Some(t) if (t + 1) * FEATURE_DIM <= rows.len() => {
                w.copy_from_slice(&rows[t * FEATURE_DIM..(t + 1) * FEATURE_DIM])
            }
            _ => w.fill(0.0),
        }
    }
}

/// One convolution layer, weights stored as `[k][c_in][c_out]` for contiguous updates.
#[derive(Clone, Debug, PartialEq)]
struct Conv {
    cin: usize,
    cout: usize,
    w: Vec<f32>,
    b: Vec<f32>,
}

impl Conv {
    /// From PyTorch's `(c_out, c_in, k)` layout.
    fn from_torch(cin: usize, cout: usize, w: &[f32], b: &[f32]) -> Self {
        let mut t = vec![0.0; KERNEL * cin * cout];
        for o in 0..cout {
            for c in 0..cin {
                for k in 0..KERNEL {
                    t[(k * cin + c) * cout + o] = w[(o * cin + c) * KERNEL + k];
                }
            }
        }
        Self { cin, cout, w: t, b: b.to_vec() }
    }

    fn to_torch(&self) -> Vec<f32> {
        let mut w = vec![0.0; self.w.len()];
        for o in 0..self.cout {
            for c in 0..self.cin {
                for k in 0..KERNEL {
                    w[(o * self.cin + c) * KERNEL + k] = self.w[(k * self.cin + c) * self.cout + o];
                }
            }
        }
        w
    }

    /// out = ReLU(b + Σ_k W_k · input_k), inputs at τ−1, τ, τ+1 (`None` = zero padding).
    fn apply(&self, inputs: [Option<&[f32]>; KERNEL], out: &mut [f32]) {
        out.copy_from_slice(&self.b);
        for (k, x) in inputs.iter().enumerate() {
            let Some(x) = x else { continue };
            let wk = &self.w[k * self.cin * self.cout..(k + 1) * self.cin * self.cout];
            for (c, &xc) in x.iter().enumerate() {
                if xc == 0.0 {
                    continue;
                }
                let row = &wk[c * self.cout..(c + 1) * self.cout];
                for (o, &w) in out.iter_mut().zip(row) {
                    *o += xc * w;
                }
            }
        }
        for o in out.iter_mut() {
            *o = o.max(0.0);
        }
    }
}

/// The frozen encoder.
#[derive(Clone, Debug, PartialEq)]
pub struct HistoryEncoder {
    length: usize,
    embed_dim: usize,
    convs: [Conv; 3],
    /// PyTorch layout `(μ, 32·k)`, column c·k + τ.
    fc_w: Vec<f32>,
    fc_b: Vec<f32>,
}

/// Tensor names of the encoder in PyTorch layout.
pub const TENSOR_NAMES: [&str; 8] = [
    "conv1.weight",
    "conv1.bias",
    "conv2.weight",
    "conv2.bias",
    "conv3.weight",
    "conv3.bias",
    "fc.weight",
    "fc.bias",
];

impl HistoryEncoder {
    /// Build from PyTorch-layout tensors in [`TENSOR_NAMES`] order.
    pub fn from_torch(length: usize, embed_dim: usize, t: &[Vec<f32>; 8]) -> Self {
        let dims = [FEATURE_DIM, CHANNELS[0], CHANNELS[1], CHANNELS[2]];
        let convs = std::array::from_fn(|l| {
            Conv::from_torch(dims[l], dims[l + 1], &t[2 * l], &t[2 * l + 1])
        });
        Self { length, embed_dim, convs, fc_w: t[6].clone(), fc_b: t[7].clone() }
    }

    /// The tensors in PyTorch layout, [`TENSOR_NAMES`] order, with their shapes.
    pub fn torch_tensors(&self) -> Vec<(&'static str, Vec<usize>, Vec<f32>)> {
        let mut v = Vec::new();
        for (l, c) in self.convs.iter().enumerate() {
            v.push((TENSOR_NAMES[2 * l], vec![c.cout, c.cin, KERNEL], c.to_torch()));
            v.push((TENSOR_NAMES[2 * l + 1], vec![c.cout], c.b.clone()));
        }
        v.push((
            TENSOR_NAMES[6],
            vec![self.embed_dim, CHANNELS[2] * self.length],
            self.fc_w.clone(),
        ));
        v.push((TENSOR_NAMES[7], vec![self.embed_dim], self.fc_b.clone()));
        v
    }

    /// History length k.
    pub fn length(&self) -> usize {
        self.length
    }
    /// Embedding width μ.
    pub fn embed_dim(&self) -> usize {
        self.embed_dim
    }

    /// Save as safetensors (atomic) with `extra` metadata added.
    pub fn save(&self, path: &Path, extra: &BTreeMap<String, String>) -> std::io::Result<()> {
        let tensors: Vec<OwnedTensor> =
            self.torch_tensors().iter().map(|(n, s, d)| OwnedTensor::f32(n, s, d)).collect();
        let mut meta = extra.clone();
        meta.insert("format".into(), FORMAT.into());
        meta.insert("format_version".into(), "1".into());
        meta.insert("history_length".into(), self.length.to_string());
        meta.insert("feature_dim".into(), FEATURE_DIM.to_string());
        meta.insert("embed_dim".into(), self.embed_dim.to_string());
        meta.insert("heading".into(), "true root quaternion heading".into());
        write_atomic(path, &tensors, &meta)
    }

    /// Load an encoder file, checking its format, sizes and values.
    pub fn load(path: &Path) -> Result<Self, HistoryError> {
        let f = TensorFile::open(path)?;
        let invalid = |detail: String| HistoryError::Invalid { path: path.to_path_buf(), detail };
        match f.meta("format") {
            Ok(FORMAT) => {}
            Ok(other) => {
                return Err(invalid(format!(
                    "metadata 'format' is '{other}', expected '{FORMAT}' (write encoders with \
                        `skillmimic history pretrain`)"
                )));
            }
            Err(e) => return Err(e.into()),
        }
        let length: usize = f.meta_parse("history_length", "a positive integer")?;
        let embed: usize = f.meta_parse("embed_dim", "a positive integer")?;
        let feat: usize = f.meta_parse("feature_dim", "316")?;
        if feat != FEATURE_DIM || length == 0 || embed == 0 {
            return Err(invalid(format!(
                "feature_dim {feat}, history_length {length}, embed_dim {embed}: expected 316 and \
                    positive sizes"
            )));
        }
        let dims = [FEATURE_DIM, CHANNELS[0], CHANNELS[1], CHANNELS[2]];
        let mut t: [Vec<f32>; 8] = Default::default();
        for l in 0..3 {
            t[2 * l] =
                f.f32(TENSOR_NAMES[2 * l], &[Some(dims[l + 1]), Some(dims[l]), Some(KERNEL)])?.1;
            t[2 * l + 1] = f.f32(TENSOR_NAMES[2 * l + 1], &[Some(dims[l + 1])])?.1;
        }
        t[6] = f.f32("fc.weight", &[Some(embed), Some(CHANNELS[2] * length)])?.1;
        t[7] = f.f32("fc.bias", &[Some(embed)])?.1;
        Ok(Self::from_torch(length, embed, &t))
    }

    /// Embedding of one full window (k × 316, oldest first) — the plain forward pass.
    pub fn embed(&self, window: &[f32], out: &mut [f32]) {
        let k = self.length;
        assert_eq!(window.len(), k * FEATURE_DIM, "history window size");
        let mut prev: Vec<f32> = window.to_vec();
        let mut cin = FEATURE_DIM;
        for conv in &self.convs {
            let mut next = vec![0.0f32; k * conv.cout];
            for tau in 0..k {
                let at =
                    |p: Option<usize>| p.filter(|&p| p < k).map(|p| &prev[p * cin..(p + 1) * cin]);
                conv.apply(
                    [at(tau.checked_sub(1)), at(Some(tau)), at(Some(tau + 1))],
                    &mut next[tau * conv.cout..(tau + 1) * conv.cout],
                );
            }
            prev = next;
            cin = conv.cout;
        }
        self.fc(|tau| &prev[tau * cin..(tau + 1) * cin], out);
    }

    /// h = b + W·flatten(y3) with the channel-major flatten order.
    fn fc<'a>(&self, y3: impl Fn(usize) -> &'a [f32], out: &mut [f32]) {
        let (k, c3) = (self.length, CHANNELS[2]);
        out[..self.embed_dim].copy_from_slice(&self.fc_b);
        for tau in 0..k {
            let y = y3(tau);
            for (o, h) in out[..self.embed_dim].iter_mut().enumerate() {
                let w = &self.fc_w[o * c3 * k..(o + 1) * c3 * k];
                let mut s = 0.0f32;
                for c in 0..c3 {
                    s += w[c * k + tau] * y[c];
                }
                *h += s;
            }
        }
    }
}

/// Per-environment history: the last k features and every layer's output per frame, in rings.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct HistoryBuffer {
    k: usize,
    /// Ring slot of the oldest frame.
    head: usize,
    /// Layer 0 (features) … layer 3, each k × channels.
    layers: [Vec<f32>; 4],
}

const WIDTHS: [usize; 4] = [FEATURE_DIM, CHANNELS[0], CHANNELS[1], CHANNELS[2]];

impl HistoryBuffer {
    /// An all-zero history for `enc`.
    pub fn new(enc: &HistoryEncoder) -> Self {
        let k = enc.length;
        let mut b = Self { k, head: 0, layers: std::array::from_fn(|l| vec![0.0; k * WIDTHS[l]]) };
        b.recompute(enc, |_| true);
        b
    }

    #[inline]
    fn slot(&self, tau: usize) -> usize {
        (self.head + tau) % self.k
    }

    /// Recompute layers 1…3 at the window positions selected by `which(layer, τ)`.
    fn recompute(&mut self, enc: &HistoryEncoder, which: impl Fn((usize, usize)) -> bool) {
        let k = self.k;
        for l in 1..4 {
            let (cin, cout) = (WIDTHS[l - 1], WIDTHS[l]);
            let (lower, upper) = self.layers.split_at_mut(l);
            let (prev, cur) = (&lower[l - 1], &mut upper[0]);
            for tau in 0..k {
                if !which((l, tau)) {
                    continue;
                }
                let slot = |p: usize| (self.head + p) % k;
                let at = |p: Option<usize>| {
                    p.filter(|&p| p < k).map(|p| &prev[slot(p) * cin..(slot(p) + 1) * cin])
                };
                let s = slot(tau);
                enc.convs[l - 1].apply(
                    [at(tau.checked_sub(1)), at(Some(tau)), at(Some(tau + 1))],
                    &mut cur[s * cout..(s + 1) * cout],
                );
            }
        }
    }

    /// Replace the whole window (k × 316, oldest first) and recompute every layer.
    pub fn fill(&mut self, enc: &HistoryEncoder, window: &[f32]) {
        assert_eq!(window.len(), self.k * FEATURE_DIM, "history window size");
        self.head = 0;
        self.layers[0].copy_from_slice(window);
        self.recompute(enc, |_| true);
    }

    /// Fill the window with reference rows [s − k, s) of a clip's feature table (zero rows before
    /// frame 0), without allocating.
    pub fn fill_from_reference(&mut self, enc: &HistoryEncoder, rows: &[f32], s: usize) {
        self.head = 0;
        reference_window(rows, s, &mut self.layers[0]);
        self.recompute(enc, |_| true);
    }

    /// Embedding of the current window.
    pub fn embedding(&self, enc: &HistoryEncoder, out: &mut [f32]) {
        let c3 = CHANNELS[2];
        enc.fc(|tau| &self.layers[3][self.slot(tau) * c3..(self.slot(tau) + 1) * c3], out);
    }

    /// Append a frame (dropping the oldest) and update the layers incrementally: layer l is
    /// recomputed at window positions τ < l and τ ≥ k − 1 − l, the positions whose receptive
    /// field touches the window boundary or just left it.
    pub fn push(&mut self, enc: &HistoryEncoder, frame: &[f32]) {
        let newest = self.head;
        self.head = (self.head + 1) % self.k;
        self.layers[0][newest * FEATURE_DIM..(newest + 1) * FEATURE_DIM].copy_from_slice(frame);
        let k = self.k;
        self.recompute(enc, |(l, tau)| tau < l || tau + 1 + l >= k);
    }

    /// The current window (k × 316, oldest first).
    pub fn window(&self) -> Vec<f32> {
        let mut w = Vec::with_capacity(self.k * FEATURE_DIM);
        for tau in 0..self.k {
            let s = self.slot(tau);
            w.extend_from_slice(&self.layers[0][s * FEATURE_DIM..(s + 1) * FEATURE_DIM]);
        }
        w
    }
}

/// A deterministic pseudo-random encoder (tests and benchmarks without a pre-trained file).
pub fn random_encoder(length: usize, embed_dim: usize, seed: u64) -> HistoryEncoder {
    let mut state = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    let mut next = move |scale: f32| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        ((state >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0) * scale
    };
    let dims = [FEATURE_DIM, CHANNELS[0], CHANNELS[1], CHANNELS[2]];
    let mut t: [Vec<f32>; 8] = Default::default();
    for l in 0..3 {
        let s = 1.0 / ((dims[l] * KERNEL) as f32).sqrt();
        t[2 * l] = (0..dims[l + 1] * dims[l] * KERNEL).map(|_| next(s)).collect();
        t[2 * l + 1] = (0..dims[l + 1]).map(|_| next(s)).collect();
    }
    let s = 1.0 / ((CHANNELS[2] * length) as f32).sqrt();
    t[6] = (0..embed_dim * CHANNELS[2] * length).map(|_| next(s)).collect();
    t[7] = (0..embed_dim).map(|_| next(s)).collect();
    HistoryEncoder::from_torch(length, embed_dim, &t)
}

/// Zero-pad + unfold + matmul convolution (kernel 3, padding 1), ReLU. `x`: (B, k, C_in), `w`:
/// PyTorch layout (C_out, C_in, 3).
fn conv_relu(x: &Tensor, w: &Tensor, b: &Tensor) -> candle_core::Result<Tensor> {
    let (bs, k, cin) = x.dims3()?;
    let cout = w.dim(0)?;
    let p = x.pad_with_zeros(1, 1, 1)?;
    // (B, k, 3·C_in), index kk·C_in + c
    let u = Tensor::cat(&[p.narrow(1, 0, k)?, p.narrow(1, 1, k)?, p.narrow(1, 2, k)?], 2)?;
    let wm = w.permute((2, 1, 0))?.contiguous()?.reshape((KERNEL * cin, cout))?;
    u.reshape((bs * k, KERNEL * cin))?.matmul(&wm)?.broadcast_add(b)?.relu()?.reshape((bs, k, cout))
}

/// Layers 2, 3 and the linear head on the first layer's output `y1` (B, k, 128).
fn head(p: &[Tensor], y1: Tensor) -> candle_core::Result<Tensor> {
    let mut y = y1;
    for l in 1..3 {
        y = conv_relu(&y, &p[2 * l], &p[2 * l + 1])?;
    }
    let (bs, k, c) = y.dims3()?;
    let flat = y.transpose(1, 2)?.contiguous()?.reshape((bs, c * k))?; // channel-major: c·k + τ
    flat.matmul(&p[6].t()?)?.broadcast_add(&p[7])
}

/// Candle forward: windows (B, k, 316) → h (B, μ). `p`: the 8 tensors in [`TENSOR_NAMES`] order
/// and PyTorch layouts (variables for autograd, or constants).
pub fn candle_forward(p: &[Tensor], win: &Tensor) -> candle_core::Result<Tensor> {
    let y1 = conv_relu(win, &p[0], &p[1])?;
    head(p, y1)
}

/// The same function as [`candle_forward`] for a batch of windows that share frames: `frames`
/// (R, 316) holds each distinct frame once plus a final zero row (index R−1 = padding); window
/// position τ of sample b reads frame `prev[b·k+τ]`, `cur[b·k+τ]`, `next[b·k+τ]` for its three
/// kernel taps. The first convolution, 90 % of the work, then runs once per distinct frame.
pub fn candle_forward_shared(
    p: &[Tensor],
    frames: &Tensor,
    prev: &[u32],
    cur: &[u32],
    next: &[u32],
    b: usize,
    k: usize,
) -> candle_core::Result<Tensor> {
    let dev = frames.device();
    let c1 = CHANNELS[0];
    // taps[(c, kk·128 + o)] = W1[o, c, kk]
    let taps = p[0].permute((1, 2, 0))?.contiguous()?.reshape((FEATURE_DIM, KERNEL * c1))?;
    let pr = frames.matmul(&taps)?; // (R, 3·128)
    let gather = |j: usize, idx: &[u32]| -> candle_core::Result<Tensor> {
        let ids = Tensor::from_slice(idx, idx.len(), dev)?;
        pr.narrow(1, j * c1, c1)?.contiguous()?.index_select(&ids, 0)
    };
    let pre = ((gather(0, prev)? + gather(1, cur)?)? + gather(2, next)?)?.broadcast_add(&p[1])?;
    head(p, pre.relu()?.reshape((b, k, c1))?)
}

impl crate::network::Network for HistoryEncoder {
    fn state_dict(&self) -> Vec<crate::network::NamedTensor> {
        self.torch_tensors()
            .into_iter()
            .map(|(n, s, d)| crate::network::NamedTensor { name: n.to_string(), shape: s, data: d })
            .collect()
    }
    fn forward(&self, x: &Tensor) -> candle_core::Result<Tensor> {
        let dev = x.device();
        let p: Vec<Tensor> = self
            .torch_tensors()
            .iter()
            .map(|(_, s, d)| Tensor::from_slice(d, s.as_slice(), dev))
            .collect::<Result<_, _>>()?;
        candle_forward(&p, x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(i: usize) -> Vec<f32> {
        (0..FEATURE_DIM).map(|j| (((i * 31 + j * 7) % 23) as f32 - 11.0) * 0.05).collect()
    }

    #[test]
    fn incremental_buffer_is_bit_identical_to_the_full_pass() {
        for (k, pushes) in [(60, 150), (7, 30), (3, 10), (1, 4)] {
            let enc = random_encoder(k, 3, 7);
            let mut buf = HistoryBuffer::new(&enc);
            let mut window: Vec<f32> = (0..k)
                .flat_map(|i| if i % 3 == 0 { vec![0.0; FEATURE_DIM] } else { frame(i) })
                .collect();
            buf.fill(&enc, &window);
            let (mut a, mut b) = ([0.0f32; 3], [0.0f32; 3]);
            for p in 0..pushes {
                buf.embedding(&enc, &mut a);
                enc.embed(&window, &mut b);
                assert_eq!(a, b, "k {k} after {p} pushes");
                assert_eq!(buf.window(), window);
                let f = frame(1000 + p);
                buf.push(&enc, &f);
                window.drain(..FEATURE_DIM);
                window.extend_from_slice(&f);
            }
            assert!(a.iter().any(|&x| x != 0.0));
        }
    }

    #[test]
    fn torch_layout_round_trips_and_reference_windows_pad_with_zeros() {
        let enc = random_encoder(5, 3, 1);
        let t = enc.torch_tensors();
        let arr: [Vec<f32>; 8] = std::array::from_fn(|i| t[i].2.clone());
        assert_eq!(HistoryEncoder::from_torch(5, 3, &arr), enc);
        assert_eq!(t[0].1, vec![128, 316, 3]);
        assert_eq!(t[6].1, vec![3, 160]);
        let rows: Vec<f32> = (0..4).flat_map(frame).collect();
        let mut w = vec![1.0f32; 5 * FEATURE_DIM];
        reference_window(&rows, 3, &mut w); // frames -2, -1, 0, 1, 2
        assert!(w[..2 * FEATURE_DIM].iter().all(|&x| x == 0.0));
        assert_eq!(&w[2 * FEATURE_DIM..3 * FEATURE_DIM], frame(0).as_slice());
        assert_eq!(&w[4 * FEATURE_DIM..], frame(2).as_slice());
    }

    #[test]
    fn candle_forward_equals_the_plain_pass() {
        let (k, b) = (6, 3);
        let enc = random_encoder(k, 3, 11);
        let win: Vec<f32> = (0..b * k).flat_map(frame).collect();
        let dev = candle_core::Device::Cpu;
        let x = Tensor::from_slice(&win, (b, k, FEATURE_DIM), &dev).unwrap();
        let h: Vec<f32> = crate::network::Network::forward(&enc, &x)
            .unwrap()
            .flatten_all()
            .unwrap()
            .to_vec1()
            .unwrap();
        for s in 0..b {
            let mut e = [0.0f32; 3];
            enc.embed(&win[s * k * FEATURE_DIM..(s + 1) * k * FEATURE_DIM], &mut e);
            for j in 0..3 {
                assert!(
                    (e[j] - h[s * 3 + j]).abs() < 1e-4,
                    "sample {s}: {e:?} vs {:?}",
                    &h[s * 3..s * 3 + 3]
                );
            }
        }
    }
}
