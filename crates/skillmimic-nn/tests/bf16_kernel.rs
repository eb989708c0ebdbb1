//! The bf16 matrix product ([`skillmimic_nn::bf16::gemm`]) against a plain float64 sum of the
//! bf16-rounded inputs, over shapes that are not multiples of the tile (1, 11–13, 31–33, 97), k
//! odd and k beyond one cache block, the four layouts of the two inputs, a strided view with no
//! contiguous dimension, accumulation, and one and two threads (bit-identical). The rounding of
//! [`skillmimic_nn::bf16::to_bf16`] is checked on exact cases and against the hardware conversion.
//!
//! A libtest-mimic harness: on a CPU without AVX512-BF16 the two kernel cases are reported as
//! ignored (not as passed).

use rand::{Rng, SeedableRng};
use skillmimic_nn::bf16::{self, View, from_bf16, to_bf16};

fn rounding_is_nearest_even() {
    assert_eq!(to_bf16(1.0), 0x3F80);
    assert_eq!(to_bf16(-2.0), 0xC000);
    // exactly half way: ties to the even neighbour
    assert_eq!(to_bf16(f32::from_bits(0x3F80_8000)), 0x3F80);
    assert_eq!(to_bf16(f32::from_bits(0x3F81_8000)), 0x3F82);
    // just above / below half way
    assert_eq!(to_bf16(f32::from_bits(0x3F80_8001)), 0x3F81);
    assert_eq!(to_bf16(f32::from_bits(0x3F80_7FFF)), 0x3F80);
    assert_eq!(to_bf16(f32::INFINITY), 0x7F80);
    assert_eq!(to_bf16(f32::MAX), 0x7F80, "rounds up to infinity, as the hardware does");
    assert!(from_bf16(to_bf16(f32::NAN)).is_nan());
    assert_eq!(to_bf16(1e-40), 0x0001, "a subnormal keeps its top bits (1e-40 = 0x000116C2)");
}

fn rand_mat(rng: &mut impl Rng, len: usize) -> Vec<f32> {
    (0..len)
        .map(|_| rng.random_range(-1.0f32..1.0) * if rng.random_bool(0.1) { 30.0 } else { 1.0 })
        .collect()
}

/// Element (r, c) of an r × c matrix stored with strides (rs, cs) in `buf`.
fn layout(rows: usize, cols: usize, kind: usize) -> (usize, usize, usize) {
    match kind {
        0 => (cols, 1, rows * cols),                   // row-major
        1 => (1, rows, rows * cols),                   // column-major
        _ => (2 * cols + 3, 2, rows * (2 * cols + 3)), // neither stride 1
    }
}

fn check(m: usize, n: usize, k: usize, lk: usize, rk: usize, accumulate: bool, rng: &mut impl Rng) {
    let (lrs, lcs, llen) = layout(m, k, lk);
    let (rrs, rcs, rlen) = layout(k, n, rk);
    let (lhs, rhs) = (rand_mat(rng, llen.max(1)), rand_mat(rng, rlen.max(1)));
    let init = rand_mat(rng, m * n);
    let want = bf16::reference(m, n, k, &lhs, lrs, lcs, &rhs, rrs, rcs);
    let mut outs = Vec::new();
    for threads in [1, 2] {
        let mut dst = init.clone();
        let mut ws = bf16::Workspace::default();
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| unsafe {
            bf16::gemm(
                m,
                n,
                k,
                dst.as_mut_ptr(),
                n,
                accumulate,
                View { ptr: lhs.as_ptr(), rs: lrs as isize, cs: lcs as isize },
                View { ptr: rhs.as_ptr(), rs: rrs as isize, cs: rcs as isize },
                threads,
                &mut ws,
            )
        });
        for i in 0..m {
            for j in 0..n {
                let base = if accumulate { init[i * n + j] as f64 } else { 0.0 };
                // float32 accumulation of k products: bound by k·2⁻²⁴ of the absolute sum
                let abs: f64 = (0..k)
                    .map(|t| {
                        (bf16::round_bf16(lhs[i * lrs + t * lcs]) as f64
                            * bf16::round_bf16(rhs[t * rrs + j * rcs]) as f64)
                            .abs()
                    })
                    .sum();
                let tol = (k as f64 + 2.0) * 6e-8 * (abs + base.abs()) + 1e-30;
                let got = dst[i * n + j] as f64;
                assert!(
                    (got - base - want[i * n + j]).abs() <= tol,
                    "m {m} n {n} k {k} layouts {lk}/{rk} acc {accumulate}: ({i}, {j}) {got} vs {}",
                    base + want[i * n + j]
                );
            }
        }
        outs.push(dst);
    }
    assert_eq!(outs[0], outs[1], "one and two threads differ (m {m} n {n} k {k})");
}

fn gemm_matches_reference() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
    for &(m, n, k) in &[
        (1, 1, 1),
        (12, 32, 2),
        (13, 33, 3),
        (11, 31, 97),
        (97, 13, 12),
        (5, 70, 1200),
        (200, 40, 33),
        (1, 512, 64),
        (64, 1, 64),
    ] {
        for (lk, rk) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
            check(m, n, k, lk, rk, false, &mut rng);
        }
        check(m, n, k, 2, 2, true, &mut rng);
        check(m, n, k, 0, 1, true, &mut rng);
    }
}

fn hardware_conversion_equals_to_bf16() {
    // 1 × 1 × 1 products with 1.0: the packed value comes back exactly
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let mut vals: Vec<f32> =
        (0..4000).map(|_| f32::from_bits(rng.random::<u32>() & 0xBFFF_FFFF)).collect();
    vals.extend([
        0.0,
        -0.0,
        1.0,
        f32::from_bits(0x3F80_8000),
        f32::from_bits(0x3F81_8000),
        1e-40,
        f32::MAX,
    ]);
    let mut ws = bf16::Workspace::default();
    for &x in &vals {
        // a row-major and a column-major operand take the two packing paths
        for (rs, cs) in [(1isize, 1isize), (1, 2)] {
            let lhs = [x, 0.0];
            let one = [1.0f32, 0.0];
            let mut out = [0.0f32];
            unsafe {
                bf16::gemm(
                    1,
                    1,
                    1,
                    out.as_mut_ptr(),
                    1,
                    false,
                    View { ptr: lhs.as_ptr(), rs, cs },
                    View { ptr: one.as_ptr(), rs: cs, cs: rs },
                    1,
                    &mut ws,
                )
            };
            let want = from_bf16(to_bf16(x));
            assert!(
                out[0] == want || (out[0] == 0.0 && want.abs() < f32::MIN_POSITIVE),
                "{x:e} ({:#010x}): kernel {:e}, to_bf16 {want:e}",
                x.to_bits(),
                out[0]
            );
        }
    }
}

fn main() {
    use libtest_mimic::{Arguments, Trial};
    let args = Arguments::from_args();
    // without the instructions the update falls back to float32: nothing of the kernel to check
    let absent = !bf16::available();
    let kernel = |name: &str, f: fn()| {
        Trial::test(name, move || {
            f();
            Ok(())
        })
        .with_ignored_flag(absent)
    };
    let trials = vec![
        Trial::test("rounding_is_nearest_even", || {
            rounding_is_nearest_even();
            Ok(())
        }),
        kernel("gemm_matches_reference", gemm_matches_reference),
        kernel("hardware_conversion_equals_to_bf16", hardware_conversion_equals_to_bf16),
    ];
    if absent {
        eprintln!("this CPU has no AVX512-BF16: the kernel cases are ignored");
    }
    libtest_mimic::run(&args, trials).exit();
}
