//! Multi-layer perceptrons (Linear + ReLU, no activation after the last layer) with the parameter
//! layout of PyTorch's `nn.Sequential(Linear, ReLU, Linear, …)`: layer k is module `2k`, weight
//! `(out, in)` row-major, bias `(out,)`.
//!
//! Two forward paths over the same parameters:
//! * [`Mlp::forward_into`]: batched inference straight into preallocated buffers with the `gemm`
//!   crate (used for rollouts; no per-step buffer allocation);
//! * [`Mlp::candle_forward`]: a candle graph whose weights are `Var`s (used for the PPO gradients).

use candle_core::{Device, Tensor, Var};
use rand::Rng;

/// MLP parameters.
#[derive(Clone, Debug)]
pub struct Mlp {
    /// Layer widths: input, hidden…, output.
    pub dims: Vec<usize>,
    /// Per layer: weight `(out, in)` row-major.
    pub weights: Vec<Vec<f32>>,
    /// Per layer: bias `(out,)`.
    pub biases: Vec<Vec<f32>>,
    /// Identity of this parameter version: unique per construction and renewed by every mutable
    /// access ([`Mlp::params_mut`]); caches derived from the weights are keyed by it.
    id: u64,
}

impl PartialEq for Mlp {
    fn eq(&self, o: &Self) -> bool {
        self.dims == o.dims && self.weights == o.weights && self.biases == o.biases
    }
}

fn next_id() -> u64 {
    use std::sync::atomic::{AtomicU64, Ordering};
    static NEXT: AtomicU64 = AtomicU64::new(1);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

/// Reusable buffers of one MLP forward pass: activations, and the transposed weights used by the
/// small-batch kernel (rebuilt when the parameters change).
#[derive(Clone, Debug, Default)]
pub struct Workspace {
    acts: Vec<Vec<f32>>,
    wt: Vec<Vec<f32>>,
    wt_id: u64,
}

/// Batches up to this many rows use `matrixmultiply` (faster than `gemm` for a small m on this
/// kind of CPU: 114–123 against 53–99 GFLOP/s per core at 64 rows), larger ones `gemm` (its
/// AVX-512 kernels reach ≈180 GFLOP/s per core at 2048+ rows).
pub const SMALL_BATCH: usize = 256;

/// Raw single-threaded matrix product: dst[m × n] (+)= lhs[m × k] · rhs[k × n] with explicit
/// strides (`*_rs` = row stride, `*_cs` = column stride, in elements).
///
/// # Safety
/// The pointers must address every element reached through the given sizes and strides.
#[allow(clippy::too_many_arguments)]
pub unsafe fn gemm_raw(
    m: usize,
    n: usize,
    k: usize,
    dst: *mut f32,
    dst_rs: isize,
    dst_cs: isize,
    accumulate: bool,
    lhs: *const f32,
    lhs_rs: isize,
    lhs_cs: isize,
    rhs: *const f32,
    rhs_rs: isize,
    rhs_cs: isize,
) {
    // SAFETY: forwarded from the caller.
    unsafe {
        if m <= SMALL_BATCH || n <= SMALL_BATCH && m > 4 * n {
            let beta = if accumulate { 1.0 } else { 0.0 };
            matrixmultiply::sgemm(
                m, k, n, 1.0, lhs, lhs_rs, lhs_cs, rhs, rhs_rs, rhs_cs, beta, dst, dst_rs, dst_cs,
            );
        } else {
            gemm::gemm(
                m,
                n,
                k,
                dst,
                dst_cs,
                dst_rs,
                accumulate,
                lhs,
                lhs_cs,
                lhs_rs,
                rhs,
                rhs_cs,
                rhs_rs,
                1.0,
                1.0,
                false,
                false,
                false,
                gemm::Parallelism::None,
            );
        }
    }
}

/// A raw pointer that may be sent to the pool threads (each thread writes a disjoint block).
#[derive(Clone, Copy)]
pub struct SendPtr(pub *mut f32);
// SAFETY: only used to hand disjoint output blocks to rayon tasks, see the callers.
unsafe impl Send for SendPtr {}
unsafe impl Sync for SendPtr {}

impl SendPtr {
    /// The pointer (a method, so closures capture the whole `Send` wrapper).
    #[inline]
    pub fn get(self) -> *mut f32 {
        self.0
    }
}

/// Split `0..len` into `parts` contiguous ranges (sizes differ by at most one multiple of 16).
pub fn split_ranges(len: usize, parts: usize) -> Vec<std::ops::Range<usize>> {
    let parts = parts.clamp(1, len.div_ceil(16).max(1));
    let chunk = len.div_ceil(parts).div_ceil(16) * 16;
    (0..parts)
        .map(|p| (p * chunk).min(len)..((p + 1) * chunk).min(len))
        .filter(|r| !r.is_empty())
        .collect()
}

/// y[n × out] = x[n × in] · Wᵀ + b (row-major everything). With `threads` > 1 the output
/// features are split into contiguous blocks, one single-threaded `gemm` per block on the current
/// rayon pool: each thread packs only its own rows of W, which scales at small batches where
/// gemm's internal parallelism does not.
pub fn linear_into(
    x: &[f32],
    n: usize,
    w: &[f32],
    b: &[f32],
    fan_in: usize,
    out: &mut [f32],
    threads: usize,
) {
    use rayon::prelude::*;
    let fan_out = b.len();
    assert_eq!(x.len(), n * fan_in);
    assert_eq!(w.len(), fan_out * fan_in);
    assert_eq!(out.len(), n * fan_out);
    for row in out.chunks_exact_mut(fan_out) {
        row.copy_from_slice(b);
    }
    let dst = SendPtr(out.as_mut_ptr());
    let block = |r: std::ops::Range<usize>| {
        // SAFETY: dst block = columns r of the n × fan_out output (row stride fan_out), disjoint
        // between blocks; lhs = x (n × fan_in); rhs = Wᵀ restricted to columns r, read from rows r
        // of W (fan_out × fan_in).
        unsafe {
            gemm_raw(
                n,
                r.len(),
                fan_in,
                dst.get().add(r.start),
                fan_out as isize,
                1,
                true,
                x.as_ptr(),
                fan_in as isize,
                1,
                w.as_ptr().add(r.start * fan_in),
                1,
                fan_in as isize,
            );
        }
    };
    if threads <= 1 {
        block(0..fan_out);
    } else {
        split_ranges(fan_out, threads).into_par_iter().for_each(block);
    }
}

impl Mlp {
    /// An MLP from its parameters (`weights[k]` is `(dims[k+1], dims[k])` row-major).
    pub fn from_parts(dims: Vec<usize>, weights: Vec<Vec<f32>>, biases: Vec<Vec<f32>>) -> Self {
        assert_eq!(weights.len(), dims.len() - 1);
        for (k, w) in dims.windows(2).enumerate() {
            assert_eq!(weights[k].len(), w[0] * w[1], "layer {k} weight size");
            assert_eq!(biases[k].len(), w[1], "layer {k} bias size");
        }
        Self { dims, weights, biases, id: next_id() }
    }

    /// PyTorch's default `nn.Linear` initialisation for the weights (uniform in ±1/√fan_in, i.e.
    /// Kaiming-uniform with a = √5) and zero biases (rl_games zeroes them).
    pub fn new<R: Rng>(dims: &[usize], rng: &mut R) -> Self {
        assert!(dims.len() >= 2);
        let mut weights = Vec::new();
        let mut biases = Vec::new();
        for w in dims.windows(2) {
            let (fan_in, fan_out) = (w[0], w[1]);
            let bound = 1.0 / (fan_in as f64).sqrt();
            weights.push(
                (0..fan_in * fan_out).map(|_| rng.random_range(-bound..bound) as f32).collect(),
            );
            biases.push(vec![0.0; fan_out]);
        }
        Self::from_parts(dims.to_vec(), weights, biases)
    }

    /// Number of linear layers.
    pub fn num_layers(&self) -> usize {
        self.weights.len()
    }
    /// Input width.
    pub fn input_dim(&self) -> usize {
        self.dims[0]
    }
    /// Output width.
    pub fn output_dim(&self) -> usize {
        *self.dims.last().unwrap()
    }

    /// `(name, shape)` of every parameter with the PyTorch `nn.Sequential` names under `prefix`.
    pub fn param_names(&self, prefix: &str) -> Vec<(String, Vec<usize>)> {
        let mut out = Vec::new();
        for (k, w) in self.dims.windows(2).enumerate() {
            out.push((format!("{prefix}.{}.weight", 2 * k), vec![w[1], w[0]]));
            out.push((format!("{prefix}.{}.bias", 2 * k), vec![w[1]]));
        }
        out
    }

    /// Parameters in `param_names` order.
    pub fn params(&self) -> Vec<&[f32]> {
        self.weights
            .iter()
            .zip(&self.biases)
            .flat_map(|(w, b)| [w.as_slice(), b.as_slice()])
            .collect()
    }
    /// Mutable parameters in `param_names` order (renews the parameter identity).
    pub fn params_mut(&mut self) -> Vec<&mut Vec<f32>> {
        self.id = next_id();
        self.weights.iter_mut().zip(self.biases.iter_mut()).flat_map(|(w, b)| [w, b]).collect()
    }

    /// Batched forward of `n` rows of `x` into the workspace; returns the `n × out` output.
    /// Batches up to [`SMALL_BATCH`] rows use the packing-free kernel of [`crate::kernel`] on the
    /// transposed weights, larger ones `gemm`; with `threads` > 1 the output features of every
    /// layer are split over the current rayon pool.
    pub fn forward_into<'w>(
        &self,
        x: &[f32],
        n: usize,
        ws: &'w mut Workspace,
        threads: usize,
    ) -> &'w [f32] {
        use rayon::prelude::*;
        let layers = self.num_layers();
        if ws.acts.len() < layers {
            ws.acts.resize_with(layers, Vec::new);
        }
        for k in 0..layers {
            let need = n * self.dims[k + 1];
            if ws.acts[k].len() < need {
                ws.acts[k].resize(need, 0.0);
            }
        }
        let small = n <= SMALL_BATCH;
        if small && ws.wt_id != self.id {
            ws.wt.resize_with(layers, Vec::new);
            for k in 0..layers {
                crate::kernel::transpose_into(
                    &self.weights[k],
                    self.dims[k + 1],
                    self.dims[k],
                    &mut ws.wt[k],
                );
            }
            ws.wt_id = self.id;
        }
        for k in 0..layers {
            let (done, rest) = ws.acts.split_at_mut(k);
            let input: &[f32] = if k == 0 { x } else { &done[k - 1][..n * self.dims[k]] };
            let (fan_in, fan_out) = (self.dims[k], self.dims[k + 1]);
            let out = &mut rest[0][..n * fan_out];
            if small {
                let (wt, b) = (&ws.wt[k], &self.biases[k]);
                if threads <= 1 {
                    crate::kernel::linear_cols(input, n, fan_in, wt, b, out, 0..fan_out);
                } else {
                    // each thread writes its own output columns: give every task a private
                    // result block, then scatter (cheap at small batches)
                    let dst = SendPtr(out.as_mut_ptr());
                    split_ranges(fan_out, threads).into_par_iter().for_each(|r| {
                        // SAFETY: the tasks write disjoint column ranges of `out` (n × fan_out).
                        let out = unsafe { std::slice::from_raw_parts_mut(dst.get(), n * fan_out) };
                        crate::kernel::linear_cols(input, n, fan_in, wt, b, out, r);
                    });
                }
            } else {
                linear_into(input, n, &self.weights[k], &self.biases[k], fan_in, out, threads);
            }
            if k + 1 < layers {
                out.iter_mut().for_each(|v| *v = v.max(0.0));
            }
        }
        &ws.acts[layers - 1][..n * self.output_dim()]
    }

    /// Candle variables of the parameters (`param_names` order).
    pub fn candle_vars(&self, dev: &Device) -> candle_core::Result<Vec<Var>> {
        let mut vars = Vec::new();
        for (k, w) in self.dims.windows(2).enumerate() {
            vars.push(Var::from_tensor(&Tensor::from_slice(&self.weights[k], (w[1], w[0]), dev)?)?);
            vars.push(Var::from_tensor(&Tensor::from_slice(&self.biases[k], w[1], dev)?)?);
        }
        Ok(vars)
    }

    /// Candle forward through `vars` (from [`Mlp::candle_vars`]).
    pub fn candle_forward(vars: &[Var], x: &Tensor) -> candle_core::Result<Tensor> {
        let layers = vars.len() / 2;
        let mut h = x.clone();
        for k in 0..layers {
            h = h
                .matmul(&vars[2 * k].as_tensor().t()?)?
                .broadcast_add(vars[2 * k + 1].as_tensor())?;
            if k + 1 < layers {
                h = h.relu()?;
            }
        }
        Ok(h)
    }
}

impl crate::network::Network for Mlp {
    /// `nn.Sequential` names: layer k is module `2k` (`0.weight`, `0.bias`, `2.weight`, …).
    fn state_dict(&self) -> Vec<crate::network::NamedTensor> {
        let mut v = Vec::with_capacity(2 * self.num_layers());
        for (k, w) in self.dims.windows(2).enumerate() {
            v.push(crate::network::NamedTensor {
                name: format!("{}.weight", 2 * k),
                shape: vec![w[1], w[0]],
                data: self.weights[k].clone(),
            });
            v.push(crate::network::NamedTensor {
                name: format!("{}.bias", 2 * k),
                shape: vec![w[1]],
                data: self.biases[k].clone(),
            });
        }
        v
    }
    fn forward(&self, x: &Tensor) -> candle_core::Result<Tensor> {
        Mlp::candle_forward(&self.candle_vars(x.device())?, x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn gemm_forward_equals_candle_forward_and_a_hand_computed_layer() {
        // one layer by hand: W = [[1, 2], [3, 4], [5, 6]], b = [0.5, -1, 0], x = [[1, -1], [2,
        // 0.5]]
        let m = Mlp::from_parts(
            vec![2, 3],
            vec![vec![1., 2., 3., 4., 5., 6.]],
            vec![vec![0.5, -1., 0.]],
        );
        let mut ws = Workspace::default();
        let y = m.forward_into(&[1., -1., 2., 0.5], 2, &mut ws, 1).to_vec();
        assert_eq!(y, vec![-0.5, -2.0, -1.0, 3.5, 7.0, 13.0]);

        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let m = Mlp::new(&[37, 64, 32, 5], &mut rng);
        let x: Vec<f32> = (0..11 * 37).map(|i| ((i * 31 % 17) as f32 - 8.0) * 0.1).collect();
        let fast = m.forward_into(&x, 11, &mut ws, 2).to_vec();
        let dev = Device::Cpu;
        let vars = m.candle_vars(&dev).unwrap();
        let xt = Tensor::from_slice(&x, (11, 37), &dev).unwrap();
        let slow: Vec<f32> =
            Mlp::candle_forward(&vars, &xt).unwrap().flatten_all().unwrap().to_vec1().unwrap();
        let err = fast.iter().zip(&slow).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
        assert!(err < 1e-5, "max diff {err}");
        assert_eq!(m.param_names("actor")[4], ("actor.4.weight".to_string(), vec![5, 32]));
        // init bound 1/sqrt(fan_in), zero biases
        assert!(m.weights[0].iter().all(|w| w.abs() <= 1.0 / 37f32.sqrt()));
        assert!(m.biases.iter().all(|b| b.iter().all(|&v| v == 0.0)));
    }
}
