//! The bf16 matrix product against the float32 one the update uses otherwise, in one run, on the
//! paper network's largest products at the `small` preset's minibatch (4096 rows, first layer
//! 902 → 1024): forward (x · Wᵀ), weight gradient (gᵀ · h) and input gradient (g · W). Both split
//! over the same rayon pool; prints each one's GFLOP/s, the speed-up and the relative difference.
//!
//!     cargo run --release -p skillmimic-nn --example bf16_bench [-- THREADS]

use rayon::prelude::*;
use skillmimic_nn::bf16::{self, View};
use skillmimic_nn::mlp::{SendPtr, gemm_raw, split_ranges};
use std::time::Instant;

fn main() {
    let threads: usize = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(2);
    if !bf16::available() {
        println!("this CPU has no AVX512-BF16: nothing to compare");
        return;
    }
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    // (name, m, n, k, lhs transposed)
    let shapes = [
        ("forward x·Wt", 4096, 1024, 902, false),
        ("weight grad gt·h", 1024, 902, 4096, true),
        ("input grad g·W", 4096, 1024, 512, false),
    ];
    let mut ws = bf16::Workspace::default();
    println!("{threads} threads");
    for (name, m, n, k, tr) in shapes {
        let lhs: Vec<f32> =
            (0..m * k).map(|i| ((i * 7919 % 1000) as f32 - 500.0) / 500.0).collect();
        let rhs: Vec<f32> =
            (0..k * n).map(|i| ((i * 104_729 % 1000) as f32 - 500.0) / 500.0).collect();
        let (lrs, lcs) = if tr { (1, m) } else { (k, 1) };
        let (mut d32, mut d16) = (vec![0f32; m * n], vec![0f32; m * n]);
        let f32_product = |d: &mut [f32]| {
            let dst = SendPtr(d.as_mut_ptr());
            split_ranges(n, threads).into_par_iter().for_each(|r| unsafe {
                gemm_raw(
                    m,
                    r.len(),
                    k,
                    dst.get().add(r.start),
                    n as isize,
                    1,
                    false,
                    lhs.as_ptr(),
                    lrs as isize,
                    lcs as isize,
                    rhs.as_ptr().add(r.start),
                    n as isize,
                    1,
                );
            });
        };
        let views = (
            View { ptr: lhs.as_ptr(), rs: lrs as isize, cs: lcs as isize },
            View { ptr: rhs.as_ptr(), rs: n as isize, cs: 1 },
        );
        let reps = 10;
        let (mut t32, mut t16) = (0.0, 0.0);
        pool.install(|| {
            for r in 0..=reps {
                let t = Instant::now();
                f32_product(&mut d32);
                let a = t.elapsed().as_secs_f64();
                let t = Instant::now();
                unsafe {
                    bf16::gemm(
                        m,
                        n,
                        k,
                        d16.as_mut_ptr(),
                        n,
                        false,
                        views.0,
                        views.1,
                        threads,
                        &mut ws,
                    )
                };
                let b = t.elapsed().as_secs_f64();
                if r > 0 {
                    t32 += a / reps as f64;
                    t16 += b / reps as f64;
                }
            }
        });
        let gf = 2.0 * (m * n * k) as f64 / 1e9;
        let num: f64 = d32.iter().zip(&d16).map(|(a, b)| ((a - b) as f64).powi(2)).sum();
        let den: f64 = d32.iter().map(|a| (*a as f64).powi(2)).sum();
        println!(
            "{name:>17} ({m}x{n}x{k}): f32 {:.2} ms ({:.0} GFLOP/s), bf16 {:.2} ms ({:.0} \
                GFLOP/s), bf16 / f32 speed {:.2}x, relative L2 difference {:.1e}",
            t32 * 1e3,
            gf / t32,
            t16 * 1e3,
            gf / t16,
            t32 / t16,
            (num / den).sqrt()
        );
    }
}
