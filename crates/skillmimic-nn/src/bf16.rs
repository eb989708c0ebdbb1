//! bf16 matrix products with float32 accumulation (AVX512-BF16), for the reduced-precision PPO
//! update.
//!
//! [`fn@gemm`] computes `dst[m × n] (+)= lhs[m × k] · rhs[k × n]` like [`crate::mlp::gemm_raw`],
//! with the inputs rounded to bfloat16 (round to nearest even, the rounding of `VCVTNE2PS2BF16`)
//! and every product summed in float32 (`VDPBF16PS`). The output and everything around it stay
//! float32: weights, optimizer state and the gradients that leave the product.
//!
//! Why written here: the `gemm` crate (0.19) has float32/float64 and a float16 path that converts
//! to float32, but no bf16 dot-product kernel, and candle's CPU bf16 matmul goes through the same
//! crate. The kernel is small: packing into bf16 pairs and one 12 × 32 register tile.
//!
//! Layout: the k dimension is taken in pairs. A is packed per panel of [`MR`] rows as
//! `[k pair][row]` 32-bit words (low half = even k, high half = odd k); B per panel of [`NR`]
//! columns as `[k pair][column]` words. One `VDPBF16PS` then multiplies one broadcast A word with
//! 16 B words: two products per lane, summed into the lane's float32 accumulator. An odd k is
//! padded with a zero; rows and columns beyond m, n are padded with zeros and never stored.
//!
//! Availability is decided at run time ([`available`]): the caller falls back to float32 on CPUs
//! without AVX512-BF16 (every x86 CPU before Zen 4 / Cooper Lake, and every non-x86 CPU).

use rayon::prelude::*;

/// Rows of the register tile.
pub const MR: usize = 12;
/// Columns of the register tile (two 16-lane vectors).
pub const NR: usize = 32;
/// k pairs per cache block (512 values of k: one B micro-panel is 32 KB).
const KC: usize = 256;
/// Rows per parallel task (one A block of MC × 2·KC bf16 = 96 KB stays in L2).
const MC: usize = 8 * MR;

/// Whether this CPU runs the bf16 kernel (AVX512F and AVX512-BF16, detected once).
pub fn available() -> bool {
    static AVAILABLE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *AVAILABLE.get_or_init(|| {
        #[cfg(target_arch = "x86_64")]
        {
            std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("avx512bf16")
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            false
        }
    })
}

/// The bf16 bits of `x` (round to nearest even; a NaN stays a NaN). Branch-free, so the packing
/// loops vectorise.
#[inline]
pub fn to_bf16(x: f32) -> u16 {
    let b = x.to_bits();
    let rounded = (b.wrapping_add(0x7FFF + ((b >> 16) & 1))) >> 16;
    let nan = (b & 0x7FFF_FFFF) > 0x7F80_0000;
    (if nan { (b >> 16) | 0x40 } else { rounded }) as u16
}

/// The float32 value of bf16 bits.
#[inline]
pub fn from_bf16(h: u16) -> f32 {
    f32::from_bits((h as u32) << 16)
}

/// `x` rounded to bf16 and back (what the kernel multiplies).
#[inline]
pub fn round_bf16(x: f32) -> f32 {
    from_bf16(to_bf16(x))
}

#[inline]
fn pair(lo: f32, hi: f32) -> u32 {
    to_bf16(lo) as u32 | ((to_bf16(hi) as u32) << 16)
}

/// A read-only strided matrix: element (r, c) at `ptr + r·rs + c·cs` (in elements).
#[derive(Clone, Copy)]
pub struct View {
    /// First element.
    pub ptr: *const f32,
    /// Row stride.
    pub rs: isize,
    /// Column stride.
    pub cs: isize,
}
// SAFETY: a View is only read, from the pool threads of one call, while the caller holds the data.
unsafe impl Send for View {}
unsafe impl Sync for View {}

impl View {
    #[inline]
    unsafe fn at(&self, r: usize, c: usize) -> f32 {
        // SAFETY: the caller keeps (r, c) inside the matrix the view was made for.
        unsafe { *self.ptr.offset(r as isize * self.rs + c as isize * self.cs) }
    }
    /// The transposed view.
    fn t(self) -> View {
        View { ptr: self.ptr, rs: self.cs, cs: self.rs }
    }
}

/// Pack `lines` lines of `w` words each: word (line l, pair p) = `pair(v(l, 2p), v(l, 2p + 1))` of
/// the view `v` (lines = rows of `v`, pairs along its columns, `len` columns, odd tail padded with
/// 0), written at `out[p · w + l]`; lines beyond `valid` are zero. The loop order follows the
/// memory: along the contiguous dimension of `v` when there is one.
unsafe fn pack_pairs(v: View, valid: usize, len: usize, w: usize, out: &mut [u32]) {
    debug_assert_eq!(out.len(), len.div_ceil(2) * w);
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: forwarded; the kernels run only where `available()` holds (the caller's promise).
        if v.cs == 1 {
            return unsafe { pack_lines_avx512(v, valid, len, w, out) };
        }
        if v.rs == 1 {
            return unsafe { pack_across_avx512(v, valid, len, w, out) };
        }
    }
    let kp = len.div_ceil(2);
    for p in 0..kp {
        let dst = &mut out[p * w..(p + 1) * w];
        for (l, d) in dst.iter_mut().enumerate() {
            *d = if l < valid {
                // SAFETY: l < valid lines and 2p(+1) < len columns.
                let lo = unsafe { v.at(l, 2 * p) };
                let hi = if 2 * p + 1 < len { unsafe { v.at(l, 2 * p + 1) } } else { 0.0 };
                pair(lo, hi)
            } else {
                0
            };
        }
    }
}

/// [`pack_pairs`] when each line is contiguous (`cs` = 1): 32 values → 16 words per conversion.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bf16")]
unsafe fn pack_lines_avx512(v: View, valid: usize, len: usize, w: usize, out: &mut [u32]) {
    use std::arch::x86_64::*;
    let kp = len.div_ceil(2);
    let mut words = [0u32; 16];
    for l in 0..w {
        if l >= valid {
            (0..kp).for_each(|p| out[p * w + l] = 0);
            continue;
        }
        // SAFETY: line l < valid holds `len` contiguous values; loads are masked to them.
        let line = unsafe { v.ptr.offset(l as isize * v.rs) };
        let mut c = 0;
        while c < len {
            let n = (len - c).min(32);
            let m_lo: __mmask16 = if n >= 16 { 0xFFFF } else { ((1u32 << n) - 1) as u16 };
            let m_hi: __mmask16 = if n >= 32 {
                0xFFFF
            } else if n > 16 {
                ((1u32 << (n - 16)) - 1) as u16
            } else {
                0
            };
            unsafe {
                let lo = _mm512_maskz_loadu_ps(m_lo, line.add(c));
                let hi = _mm512_maskz_loadu_ps(m_hi, line.add(c + 16));
                let packed: __m512i = std::mem::transmute(_mm512_cvtne2ps_pbh(hi, lo));
                _mm512_storeu_si512(words.as_mut_ptr() as *mut __m512i, packed);
            }
            let p0 = c / 2;
            for (q, &wd) in words.iter().enumerate().take(n.div_ceil(2)) {
                out[(p0 + q) * w + l] = wd;
            }
            c += 32;
        }
    }
}

/// [`pack_pairs`] when lines lie side by side (`rs` = 1): the even and odd value of a pair come
/// from two contiguous runs, interleaved 16 words at a time.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bf16")]
unsafe fn pack_across_avx512(v: View, valid: usize, len: usize, w: usize, out: &mut [u32]) {
    use std::arch::x86_64::*;
    let kp = len.div_ceil(2);
    for p in 0..kp {
        let dst = out[p * w..(p + 1) * w].as_mut_ptr();
        let has_hi = 2 * p + 1 < len;
        let mut l = 0;
        while l < w {
            let n = valid.saturating_sub(l).min(16);
            let mask: __mmask16 = if n >= 16 { 0xFFFF } else { ((1u32 << n) - 1) as u16 };
            let store: __mmask16 =
                if w - l >= 16 { 0xFFFF } else { ((1u32 << (w - l)) - 1) as u16 };
            // SAFETY: loads are masked to the valid lines of columns 2p, 2p + 1; the store to the
            // panel's w words.
            unsafe {
                let lo = _mm512_maskz_loadu_ps(mask, v.ptr.offset((2 * p) as isize * v.cs).add(l));
                let hi = if has_hi {
                    _mm512_maskz_loadu_ps(mask, v.ptr.offset((2 * p + 1) as isize * v.cs).add(l))
                } else {
                    _mm512_setzero_ps()
                };
                let lo16: __m256i = std::mem::transmute(_mm512_cvtneps_pbh(lo));
                let hi16: __m256i = std::mem::transmute(_mm512_cvtneps_pbh(hi));
                let words = _mm512_or_si512(
                    _mm512_cvtepu16_epi32(lo16),
                    _mm512_slli_epi32(_mm512_cvtepu16_epi32(hi16), 16),
                );
                _mm512_mask_storeu_epi32(dst.add(l) as *mut i32, store, words);
            }
            l += 16;
        }
    }
}

/// Pack `MR` rows (from `r0`, beyond `m` zero) of A (m × k) into `out` = `[k pair][MR]` words.
unsafe fn pack_a_panel(a: View, m: usize, k: usize, r0: usize, out: &mut [u32]) {
    let v = View { ptr: a.ptr.wrapping_offset(r0 as isize * a.rs), ..a };
    // SAFETY: forwarded; rows r0.. of A are lines of the view.
    unsafe { pack_pairs(v, m.saturating_sub(r0).min(MR), k, MR, out) }
}

/// Pack columns `c0..c0+NR` (beyond `n` zero) of B (k × n) into `out` = `[k pair][NR]` words.
unsafe fn pack_b_panel(b: View, k: usize, n: usize, c0: usize, out: &mut [u32]) {
    let v = View { ptr: b.ptr.wrapping_offset(c0 as isize * b.cs), ..b }.t();
    // SAFETY: forwarded; columns c0.. of B are lines of the transposed view.
    unsafe { pack_pairs(v, n.saturating_sub(c0).min(NR), k, NR, out) }
}

/// Packing buffers, reused across calls (no allocation once they have grown).
#[derive(Default)]
pub struct Workspace {
    a: Vec<u32>,
    b: Vec<u32>,
}

/// A raw output pointer handed to the pool threads (each writes its own rows).
#[derive(Clone, Copy)]
struct Out(*mut f32);
// SAFETY: tasks write disjoint row blocks of the output, see `gemm`.
unsafe impl Send for Out {}
unsafe impl Sync for Out {}
impl Out {
    #[inline]
    fn get(self) -> *mut f32 {
        self.0
    }
}

/// `dst[m × n] (+)= lhs[m × k] · rhs[k × n]` in bf16 × bf16 → float32 (see the module docs); the
/// output is row-major with row stride `dst_rs`. Work is split over the current rayon pool by
/// blocks of `MC` rows when `threads` > 1; each output element is one float32 sum in a fixed
/// order, so results do not depend on scheduling.
///
/// # Safety
/// [`available`] must be true; the views must address every element of an m × k (lhs) and
/// k × n (rhs) matrix, and `dst` every element of an m × n matrix with row stride `dst_rs`.
#[allow(clippy::too_many_arguments)]
pub unsafe fn gemm(
    m: usize,
    n: usize,
    k: usize,
    dst: *mut f32,
    dst_rs: usize,
    accumulate: bool,
    lhs: View,
    rhs: View,
    threads: usize,
    ws: &mut Workspace,
) {
    if m == 0 || n == 0 {
        return;
    }
    let kp = k.div_ceil(2);
    let (mp, np) = (m.div_ceil(MR), n.div_ceil(NR));
    ws.a.resize(mp * kp * MR, 0);
    ws.b.resize(np * kp * NR, 0);
    let par = threads > 1;
    // SAFETY (both packs): forwarded from the caller; each panel is written by one task.
    let pack_a = |(i, out): (usize, &mut [u32])| unsafe { pack_a_panel(lhs, m, k, i * MR, out) };
    let pack_b = |(j, out): (usize, &mut [u32])| unsafe { pack_b_panel(rhs, k, n, j * NR, out) };
    if kp == 0 {
        if !accumulate {
            for r in 0..m {
                // SAFETY: row r of the m × n output.
                unsafe { std::slice::from_raw_parts_mut(dst.add(r * dst_rs), n) }.fill(0.0);
            }
        }
        return;
    }
    if par {
        ws.a.par_chunks_mut(kp * MR).enumerate().for_each(pack_a);
        ws.b.par_chunks_mut(kp * NR).enumerate().for_each(pack_b);
    } else {
        ws.a.chunks_mut(kp * MR).enumerate().for_each(pack_a);
        ws.b.chunks_mut(kp * NR).enumerate().for_each(pack_b);
    }
    let (a, b) = (&ws.a[..], &ws.b[..]);
    let out = Out(dst);
    let block = |blk: usize| {
        let (p_lo, p_hi) = (blk * (MC / MR), ((blk + 1) * (MC / MR)).min(mp));
        for k0 in (0..kp).step_by(KC) {
            let kc = KC.min(kp - k0);
            let load = accumulate || k0 > 0;
            for j in 0..np {
                let bp = &b[j * kp * NR + k0 * NR..][..kc * NR];
                let cols = (n - j * NR).min(NR);
                for i in p_lo..p_hi {
                    let ap = &a[i * kp * MR + k0 * MR..][..kc * MR];
                    let rows = (m - i * MR).min(MR);
                    // SAFETY: the tile (rows × cols at row i·MR, column j·NR) is inside the output
                    // and belongs to this task's row block; availability is the caller's promise.
                    unsafe {
                        let c = out.get().add(i * MR * dst_rs + j * NR);
                        tile(ap, bp, kc, c, dst_rs, rows, cols, load);
                    }
                }
            }
        }
    };
    let blocks = m.div_ceil(MC);
    if par {
        (0..blocks).into_par_iter().for_each(block);
    } else {
        (0..blocks).for_each(block);
    }
}

/// One MR × NR output tile over `kc` k pairs.
#[allow(clippy::too_many_arguments)]
#[inline]
unsafe fn tile(
    a: &[u32],
    b: &[u32],
    kc: usize,
    c: *mut f32,
    rs: usize,
    rows: usize,
    cols: usize,
    load: bool,
) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: forwarded from `gemm`.
    unsafe {
        tile_avx512(a, b, kc, c, rs, rows, cols, load)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (a, b, kc, c, rs, rows, cols, load);
        unreachable!("bf16::available() is false off x86_64");
    }
}

#[cfg(target_arch = "x86_64")]
#[allow(clippy::too_many_arguments)]
#[target_feature(enable = "avx512f,avx512bf16")]
unsafe fn tile_avx512(
    a: &[u32],
    b: &[u32],
    kc: usize,
    c: *mut f32,
    rs: usize,
    rows: usize,
    cols: usize,
    load: bool,
) {
    use std::arch::x86_64::*;
    debug_assert!(a.len() >= kc * MR && b.len() >= kc * NR);
    let m0: __mmask16 = if cols >= 16 { 0xFFFF } else { ((1u32 << cols) - 1) as u16 };
    let m1: __mmask16 = if cols >= NR {
        0xFFFF
    } else if cols > 16 {
        ((1u32 << (cols - 16)) - 1) as u16
    } else {
        0
    };
    let mut acc = [[_mm512_setzero_ps(); 2]; MR];
    if load {
        for (r, row) in acc.iter_mut().enumerate().take(rows) {
            // SAFETY: masked loads of the tile's valid columns.
            unsafe {
                row[0] = _mm512_maskz_loadu_ps(m0, c.add(r * rs));
                row[1] = _mm512_maskz_loadu_ps(m1, c.add(r * rs + 16));
            }
        }
    }
    let (ap, bp) = (a.as_ptr(), b.as_ptr());
    for p in 0..kc {
        // SAFETY: p < kc, inside the packed panels (checked above).
        unsafe {
            let b0: __m512bh =
                std::mem::transmute(_mm512_loadu_si512(bp.add(p * NR) as *const __m512i));
            let b1: __m512bh =
                std::mem::transmute(_mm512_loadu_si512(bp.add(p * NR + 16) as *const __m512i));
            for (r, row) in acc.iter_mut().enumerate() {
                let av: __m512bh =
                    std::mem::transmute(_mm512_set1_epi32(*ap.add(p * MR + r) as i32));
                row[0] = _mm512_dpbf16_ps(row[0], av, b0);
                row[1] = _mm512_dpbf16_ps(row[1], av, b1);
            }
        }
    }
    for (r, row) in acc.iter().enumerate().take(rows) {
        // SAFETY: masked stores of the tile's valid columns.
        unsafe {
            _mm512_mask_storeu_ps(c.add(r * rs), m0, row[0]);
            _mm512_mask_storeu_ps(c.add(r * rs + 16), m1, row[1]);
        }
    }
}

/// Reference of [`fn@gemm`] in plain code (bf16-rounded inputs, float64 sums), for tests.
#[allow(clippy::too_many_arguments)]
pub fn reference(
    m: usize,
    n: usize,
    k: usize,
    lhs: &[f32],
    lhs_rs: usize,
    lhs_cs: usize,
    rhs: &[f32],
    rhs_rs: usize,
    rhs_cs: usize,
) -> Vec<f64> {
    let mut out = vec![0.0f64; m * n];
    for i in 0..m {
        for j in 0..n {
            out[i * n + j] = (0..k)
                .map(|t| {
                    round_bf16(lhs[i * lhs_rs + t * lhs_cs]) as f64
                        * round_bf16(rhs[t * rhs_rs + j * rhs_cs]) as f64
                })
                .sum();
        }
    }
    out
}
