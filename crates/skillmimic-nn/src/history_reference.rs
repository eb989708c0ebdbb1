//! An independent forward pass of the history encoder for tests: plain f64 loops over the
//! encoder's PyTorch-layout tensors ([`HistoryEncoder::torch_tensors`]), sharing no code with the
//! network's own forward (`history::HistoryEncoder`). The environment's and the learner's tests
//! compare the embeddings the environment and pre-training produce with it.

use crate::history::{FEATURE_DIM, HistoryEncoder};

/// The history encoder written out from its PyTorch-layout tensors (`torch_tensors`), in f64:
/// x `[316][k]` (channels × time) → three Conv1d (kernel 3, zero padding 1, ReLU) → flatten
/// channel-major (c·k + τ) → Linear to μ. `window` is k × 316, oldest frame first.
pub fn torch_reference_embedding(enc: &HistoryEncoder, window: &[f32]) -> Vec<f32> {
    let t = enc.torch_tensors();
    let k = enc.length();
    let mut x: Vec<Vec<f64>> = (0..FEATURE_DIM)
        .map(|c| (0..k).map(|tau| window[tau * FEATURE_DIM + c] as f64).collect())
        .collect();
    for l in 0..3 {
        let (w, b) = (&t[2 * l].2, &t[2 * l + 1].2);
        let (cout, cin, kw) = (t[2 * l].1[0], t[2 * l].1[1], t[2 * l].1[2]);
        assert_eq!((cin, kw), (x.len(), 3));
        let mut y = vec![vec![0.0f64; k]; cout];
        for (o, yo) in y.iter_mut().enumerate() {
            for (tau, out) in yo.iter_mut().enumerate() {
                let mut s = b[o] as f64;
                for (c, xc) in x.iter().enumerate() {
                    for j in 0..kw {
                        // output τ sees inputs τ − 1, τ, τ + 1 (zero outside the window)
                        if let Some(p) = (tau + j).checked_sub(1).filter(|&p| p < k) {
                            s += w[(o * cin + c) * kw + j] as f64 * xc[p];
                        }
                    }
                }
                *out = s.max(0.0);
            }
        }
        x = y;
    }
    let (fw, fb, c3) = (&t[6].2, &t[7].2, x.len());
    (0..enc.embed_dim())
        .map(|o| {
            let mut s = fb[o] as f64;
            for (c, xc) in x.iter().enumerate() {
                for (tau, &v) in xc.iter().enumerate() {
                    s += fw[o * c3 * k + c * k + tau] as f64 * v;
                }
            }
            s as f32
        })
        .collect()
}
