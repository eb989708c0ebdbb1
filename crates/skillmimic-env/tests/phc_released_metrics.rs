//! The tracking metrics against the released evaluation's own function: PHC's
//! `compute_metrics_lite` (SMPLSim, called by ModSkill's player) on body-position sequences of
//! this project (`tests/fixtures/phc_metrics_golden.json`, see its note). Per frame, the
//! tracking formulas give E_g-mpjpe and E_mpjpe (root-relative), and per frame pair / triple the
//! velocity and acceleration errors, to 1e-5 mm; aggregated as the released player does (the
//! mean over every frame of every motion) they give its printed means.
//!
//! The per-episode report of `skillmimic eval` also counts the first step's velocity error and
//! the first two steps' acceleration errors against the reset state; the per-motion evaluation
//! (`eval --each-motion`, `skillmimic_learn::tracking_eval`) leaves them out, as the released
//! arrays start at the first step after the reset (docs/guide/modskill.md).

mod common;

use common::{TOL, check, fixture, floats};
use skillmimic_core::math::Quat;
use skillmimic_env::tasks::tracking::formulas::{self, Bodies};

/// Body positions of one frame (orientations and velocities unused by the metrics).
struct Positions(Vec<f64>);

impl Bodies for Positions {
    fn pos(&self, b: usize) -> [f64; 3] {
        [self.0[3 * b], self.0[3 * b + 1], self.0[3 * b + 2]]
    }
    fn quat(&self, _: usize) -> Quat {
        Quat::IDENTITY
    }
    fn linvel(&self, _: usize) -> [f64; 3] {
        [0.0; 3]
    }
    fn angvel(&self, _: usize) -> [f64; 3] {
        [0.0; 3]
    }
}

fn frames(v: &serde_json::Value) -> Vec<Positions> {
    v.as_array().expect("frames").iter().map(|f| Positions(floats(f))).collect()
}

#[test]
fn tracking_metrics_match_phcs_compute_metrics_lite() {
    let fx = fixture("phc_metrics_golden.json");
    let n = fx["body_names"].as_array().expect("names").len();
    assert_eq!(n, 24, "the SMPL humanoid's bodies");
    let bodies: Vec<usize> = (0..n).collect();
    let released = &fx["released"];
    let (mut worst, mut count) = (0.0f64, 0usize);
    // sums and counts as the released player concatenates them
    let mut sums = [0.0f64; 4];
    let mut counts = [0usize; 4];
    for (s, seq) in fx["sequences"].as_array().expect("sequences").iter().enumerate() {
        let (x, y) = (frames(&seq["pred"]), frames(&seq["gt"]));
        let want = &released["per_sequence"][s];
        let len = x.len();
        let mut ours = [vec![], vec![], vec![], vec![]];
        for k in 0..len {
            let e = formulas::errors(&x[k], &y[k], &bodies);
            ours[0].push(1e3 * e.dist);
            ours[1].push(1e3 * e.dist_rel);
            if k >= 1 {
                // the oldest frame only enters the acceleration (unused at k = 1)
                let k0 = if k >= 2 { k - 2 } else { k - 1 };
                let (xr, yr) = (&x, &y);
                let p = |i: usize| move |b: usize| xr[i].pos(b);
                let g = |i: usize| move |b: usize| yr[i].pos(b);
                let (px, gx) = ([p(k0), p(k - 1), p(k)], [g(k0), g(k - 1), g(k)]);
                let (v, a) = formulas::vel_acc_errors(
                    [&px[0], &px[1], &px[2]],
                    [&gx[0], &gx[1], &gx[2]],
                    &bodies,
                );
                ours[2].push(1e3 * v);
                if k >= 2 {
                    ours[3].push(1e3 * a);
                }
            }
        }
        assert_eq!((ours[2].len(), ours[3].len()), (len - 1, len - 2));
        for (m, key) in
            ["mpjpe_g_mm", "mpjpe_l_mm", "vel_dist_mm", "accel_dist_mm"].into_iter().enumerate()
        {
            check(key, s, &ours[m], &floats(&want[key]), &mut worst);
            sums[m] += ours[m].iter().sum::<f64>();
            counts[m] += ours[m].len();
            count += ours[m].len();
        }
    }
    for (m, key) in ["mpjpe_g", "mpjpe_l", "vel_dist", "accel_dist"].into_iter().enumerate() {
        let want = released["means"][key].as_f64().expect("a mean");
        let ours = sums[m] / counts[m] as f64;
        assert!((ours - want).abs() <= TOL.max(1e-8 * want), "{key}: ours {ours} vs {want}");
    }
    println!(
        "{count} per-frame metric values of {} sequences within {worst:.1e} mm of the released \
         compute_metrics_lite; the means agree",
        fx["sequences"].as_array().map_or(0, Vec::len)
    );
}
