//! The hand-written gradient kernels of the fast PPO path for ReLU MLPs (used by [`super::fast`]
//! and [`super::fast_modular`]): forward keeping activations, weight/bias/input gradients and the
//! backward through a whole MLP. Matrix products go through [`skillmimic_nn::mlp::gemm_raw`]
//! (float32, split over the current rayon pool by output blocks) or, with [`Mm::bf16`],
//! [`skillmimic_nn::bf16::gemm`] (bf16 inputs, float32 sums); reductions use fixed row blocks
//! combined in order, so results do not depend on scheduling.

use std::cell::RefCell;

use rayon::prelude::*;
use skillmimic_nn::bf16::{self, View};
use skillmimic_nn::mlp::{Mlp, SendPtr, gemm_raw, linear_into, split_ranges};

const BLOCKS: usize = 32;

/// How the update's matrix products run.
#[derive(Clone, Copy, Debug)]
pub struct Mm {
    /// Width of the current rayon pool.
    pub threads: usize,
    /// bf16 inputs with float32 accumulation (only set where [`bf16::available`] holds).
    pub bf16: bool,
}

impl Mm {
    /// float32 products on `threads` threads.
    pub fn f32(threads: usize) -> Self {
        Self { threads, bf16: false }
    }
    /// The products `precision` asks for, float32 where the CPU lacks AVX512-BF16.
    pub fn new(threads: usize, precision: crate::config::Precision) -> Self {
        Self { threads, bf16: precision == crate::config::Precision::Bf16 && bf16::available() }
    }
}

thread_local! {
    /// Packing buffers of the bf16 products issued from this thread (the update's thread).
    static PACK: RefCell<bf16::Workspace> = RefCell::new(bf16::Workspace::default());
}

/// `dst[m × n] (+)= lhs · rhs` in bf16 (row-major `dst` with row stride `dst_rs`).
///
/// # Safety
/// As [`bf16::gemm`]; `mm.bf16` implies availability.
#[allow(clippy::too_many_arguments)]
unsafe fn gemm_bf16(
    m: usize,
    n: usize,
    k: usize,
    dst: *mut f32,
    dst_rs: usize,
    accumulate: bool,
    lhs: View,
    rhs: View,
    mm: Mm,
) {
    debug_assert!(mm.bf16);
    // SAFETY: forwarded from the caller.
    PACK.with(|ws| unsafe {
        bf16::gemm(m, n, k, dst, dst_rs, accumulate, lhs, rhs, mm.threads, &mut ws.borrow_mut())
    });
}

/// y[n × out] = x[n × in] · Wᵀ + b, in the precision of `mm`.
pub fn linear(x: &[f32], n: usize, w: &[f32], b: &[f32], fan_in: usize, out: &mut [f32], mm: Mm) {
    if !mm.bf16 {
        return linear_into(x, n, w, b, fan_in, out, mm.threads);
    }
    let fan_out = b.len();
    assert!(x.len() == n * fan_in && w.len() == fan_out * fan_in && out.len() == n * fan_out);
    for row in out.chunks_exact_mut(fan_out) {
        row.copy_from_slice(b);
    }
    let lhs = View { ptr: x.as_ptr(), rs: fan_in as isize, cs: 1 };
    let rhs = View { ptr: w.as_ptr(), rs: 1, cs: fan_in as isize };
    // SAFETY: x is n × fan_in, Wᵀ (fan_in × fan_out) is read from W (fan_out × fan_in), out is
    // n × fan_out (sizes asserted above).
    unsafe { gemm_bf16(n, fan_out, fan_in, out.as_mut_ptr(), fan_out, true, lhs, rhs, mm) }
}

/// Forward through `m` keeping every activation (`h[k]` = output of layer k).
pub fn forward_keep(m: &Mlp, x: &[f32], n: usize, h: &mut Vec<Vec<f32>>, mm: Mm) {
    let layers = m.num_layers();
    h.resize_with(layers, Vec::new);
    for k in 0..layers {
        let need = n * m.dims[k + 1];
        h[k].resize(need, 0.0);
        let (done, rest) = h.split_at_mut(k);
        let input: &[f32] = if k == 0 { x } else { &done[k - 1] };
        linear(input, n, &m.weights[k], &m.biases[k], m.dims[k], &mut rest[0], mm);
        if k + 1 < layers {
            rest[0].par_chunks_mut(4096).for_each(|c| c.iter_mut().for_each(|v| *v = v.max(0.0)));
        }
    }
}

/// dW = gᵀ · h_in (out × in) over `n` rows, split by output rows over the pool.
pub fn weight_grad(
    g: &[f32],
    h_in: &[f32],
    n: usize,
    fan_in: usize,
    fan_out: usize,
    dw: &mut [f32],
    mm: Mm,
) {
    assert!(g.len() >= n * fan_out && h_in.len() >= n * fan_in && dw.len() == fan_out * fan_in);
    if mm.bf16 {
        let lhs = View { ptr: g.as_ptr(), rs: 1, cs: fan_out as isize };
        let rhs = View { ptr: h_in.as_ptr(), rs: fan_in as isize, cs: 1 };
        // SAFETY: gᵀ (fan_out × n) is read from g (n × fan_out), h_in is n × fan_in, dW is
        // fan_out × fan_in (asserted above).
        return unsafe {
            gemm_bf16(fan_out, fan_in, n, dw.as_mut_ptr(), fan_in, false, lhs, rhs, mm)
        };
    }
    let threads = mm.threads;
    let dst = SendPtr(dw.as_mut_ptr());
    let one = |r: std::ops::Range<usize>| {
        // SAFETY: rows r of dW (fan_out × fan_in) are written by this task only; lhs = gᵀ
        // restricted to rows r (columns r of g, n × fan_out); rhs = h_in (n × fan_in).
        unsafe {
            gemm_raw(
                r.len(),
                fan_in,
                n,
                dst.get().add(r.start * fan_in),
                fan_in as isize,
                1,
                false,
                g.as_ptr().add(r.start),
                1,
                fan_out as isize,
                h_in.as_ptr(),
                fan_in as isize,
                1,
            );
        }
    };
    if threads <= 1 {
        one(0..fan_out);
    } else {
        split_ranges(fan_out, threads).into_par_iter().for_each(one);
    }
}

/// db = column sums of g (n × out), fixed row blocks summed in order.
pub fn bias_grad(g: &[f32], n: usize, fan_out: usize, db: &mut [f32]) {
    let rows = n.div_ceil(BLOCKS);
    let partial: Vec<Vec<f64>> = (0..BLOCKS)
        .into_par_iter()
        .map(|b| {
            let mut s = vec![0.0f64; fan_out];
            let (lo, hi) = ((b * rows).min(n), ((b + 1) * rows).min(n));
            for row in g[lo * fan_out..hi * fan_out].chunks_exact(fan_out) {
                for (a, &v) in s.iter_mut().zip(row) {
                    *a += v as f64;
                }
            }
            s
        })
        .collect();
    db.fill(0.0);
    let mut acc = vec![0.0f64; fan_out];
    for p in &partial {
        for (a, v) in acc.iter_mut().zip(p) {
            *a += v;
        }
    }
    for (d, a) in db.iter_mut().zip(acc) {
        *d = a as f32;
    }
}

/// g_in = g · W (n × in), split by input columns over the pool.
pub fn input_grad_plain(
    g: &[f32],
    w: &[f32],
    n: usize,
    fan_in: usize,
    fan_out: usize,
    g_in: &mut [f32],
    mm: Mm,
) {
    assert!(g.len() >= n * fan_out && w.len() == fan_out * fan_in && g_in.len() >= n * fan_in);
    if mm.bf16 {
        let lhs = View { ptr: g.as_ptr(), rs: fan_out as isize, cs: 1 };
        let rhs = View { ptr: w.as_ptr(), rs: fan_in as isize, cs: 1 };
        // SAFETY: g is n × fan_out, W is fan_out × fan_in, g_in is n × fan_in (asserted above).
        return unsafe {
            gemm_bf16(n, fan_in, fan_out, g_in.as_mut_ptr(), fan_in, false, lhs, rhs, mm)
        };
    }
    let threads = mm.threads;
    let dst = SendPtr(g_in.as_mut_ptr());
    let one = |r: std::ops::Range<usize>| {
        // SAFETY: columns r of g_in (n × fan_in) are written by this task only; lhs = g
        // (n × fan_out); rhs = W (fan_out × fan_in) restricted to columns r.
        unsafe {
            gemm_raw(
                n,
                r.len(),
                fan_out,
                dst.get().add(r.start),
                fan_in as isize,
                1,
                false,
                g.as_ptr(),
                fan_out as isize,
                1,
                w.as_ptr().add(r.start),
                fan_in as isize,
                1,
            );
        }
    };
    if threads <= 1 {
        one(0..fan_in);
    } else {
        split_ranges(fan_in, threads).into_par_iter().for_each(one);
    }
}

/// g_in = (g · W) ⊙ \[h_in > 0\] (n × in).
#[allow(clippy::too_many_arguments)]
pub fn input_grad(
    g: &[f32],
    w: &[f32],
    h_in: &[f32],
    n: usize,
    fan_in: usize,
    fan_out: usize,
    g_in: &mut [f32],
    mm: Mm,
) {
    input_grad_plain(g, w, n, fan_in, fan_out, g_in, mm);
    // a select, not a branch: the ReLU pattern is random, a conditional store mispredicts
    g_in.par_chunks_mut(4096).zip(h_in.par_chunks(4096)).for_each(|(gi, hi)| {
        for (a, &h) in gi.iter_mut().zip(hi) {
            *a = if h > 0.0 { *a } else { 0.0 };
        }
    });
}

/// Backward through `m` given the output gradient `g_out` (consumed as scratch; on return it
/// holds the gradient at the first layer's output); parameter gradients go to `grads`
/// (weight, bias per layer).
#[allow(clippy::too_many_arguments)]
pub fn backward(
    m: &Mlp,
    x: &[f32],
    n: usize,
    h: &[Vec<f32>],
    g_out: &mut Vec<f32>,
    scratch: &mut Vec<f32>,
    grads: &mut [Vec<f32>],
    mm: Mm,
) {
    let layers = m.num_layers();
    for k in (0..layers).rev() {
        let (fan_in, fan_out) = (m.dims[k], m.dims[k + 1]);
        let h_in: &[f32] = if k == 0 { x } else { &h[k - 1] };
        let (gw, gb) = grads.split_at_mut(2 * k + 1);
        weight_grad(g_out, h_in, n, fan_in, fan_out, &mut gw[2 * k], mm);
        bias_grad(g_out, n, fan_out, &mut gb[0]);
        if k > 0 {
            scratch.resize(n * fan_in, 0.0);
            input_grad(g_out, &m.weights[k], h_in, n, fan_in, fan_out, scratch, mm);
            std::mem::swap(g_out, scratch);
        }
    }
}
