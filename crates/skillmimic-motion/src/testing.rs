//! Synthetic inputs for tests and the fuzzer's seed corpus (not real motion).

use crate::layout::PT_WIDTH;

/// `t` plausible rows of the BallPlay-M 337-column layout: the root walks along x at
/// 0.02 m/frame at 0.95 m height, root and ball exp maps are (1.5, 0.05, 0.1) rad, joint exp
/// maps are small (≤ 0.12 rad), body positions drift by 0.01 m/frame, the contact label
/// alternates 0, 1, 0, … . Every row passes [`crate::validate`] at 60 fps.
pub fn synthetic_rows(t: usize) -> Vec<f32> {
    let mut rows = vec![0.0f32; t * PT_WIDTH];
    for (f, r) in rows.chunks_exact_mut(PT_WIDTH).enumerate() {
        r[0..3].copy_from_slice(&[0.02 * f as f32, 1.0, 0.95]);
        r[3..6].copy_from_slice(&[1.5, 0.05, 0.1]);
        r[6..9].copy_from_slice(&[1.5, 0.05, 0.1]);
        for (k, x) in r.iter_mut().enumerate().take(165).skip(9) {
            *x = ((k * 7 + f) % 13) as f32 * 0.01;
        }
        for (k, x) in r.iter_mut().enumerate().take(327).skip(165) {
            *x = (k % 5) as f32 * 0.1 + 0.01 * f as f32;
        }
        r[336] = (f % 2) as f32;
    }
    rows
}
