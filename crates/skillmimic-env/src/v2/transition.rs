//! State Transition Field (SkillMimic-V2, seed 003 §4.3, App. B.4): start an episode from a
//! state in the ε-neighbourhood of a reference state and connect it to the most similar frame of
//! the same clip.
//!
//! Choices where paper and reference code differ (reference-facts §9.5):
//! * noise is uniform in [−ε, ε] for every component (paper Tab. 7), heights upward only (code),
//!   root x/y perturbed too (paper: "every state component");
//! * the connection compares the **perturbed** state after forward kinematics (the reference code
//!   compares the previous episode's last state, a bug) with every frame 2 … T−2 of the clip,
//!   using [`similarity`](super::similarity::similarity).

use rand::Rng;
use skillmimic_core::math::Quat;
use skillmimic_motion::MotionClip;
use skillmimic_sim::ResetState;

use crate::config::{NoiseEps, RewardConfig};
use crate::hoi::HoiState;
use crate::v2::similarity::similarity;

#[inline]
fn sym<R: Rng>(rng: &mut R, eps: f64) -> f64 {
    if eps > 0.0 { rng.random_range(-eps..=eps) } else { 0.0 }
}

#[inline]
fn up<R: Rng>(rng: &mut R, eps: f64) -> f64 {
    if eps > 0.0 { rng.random_range(0.0..=eps) } else { 0.0 }
}

fn add_sym<R: Rng, const N: usize>(v: &mut [f64; N], rng: &mut R, eps: f64) {
    for x in v.iter_mut() {
        *x += sym(rng, eps);
    }
}

/// Rotate `q` by a world-frame rotation vector with components uniform in [−ε, ε].
fn perturb_rotation<R: Rng>(q: Quat, rng: &mut R, eps: f64) -> Quat {
    let d = [sym(rng, eps), sym(rng, eps), sym(rng, eps)];
    Quat::from_rotvec(d).mul(q).normalized()
}

/// Widths of one rigid body's perturbation.
struct BodyEps {
    xy: f64,
    height: f64,
    rot: f64,
    linvel: f64,
    angvel: f64,
}

fn perturb_body<R: Rng>(pos: &mut [f64; 3], quat: &mut Quat, linvel: &mut [f64; 3], angvel: &mut [f64; 3], e: BodyEps, rng: &mut R) {
    pos[0] += sym(rng, e.xy);
    pos[1] += sym(rng, e.xy);
    pos[2] += up(rng, e.height);
    *quat = perturb_rotation(*quat, rng, e.rot);
    add_sym(linvel, rng, e.linvel);
    add_sym(angvel, rng, e.angvel);
}

/// Perturb a reset state inside the ε-neighbourhood ([`NoiseEps`] documents each component).
/// The ball is perturbed only when `with_ball` (clips without a ball already get a random one).
pub fn perturb<R: Rng>(s: &mut ResetState, eps: &NoiseEps, with_ball: bool, rng: &mut R) {
    let root = BodyEps { xy: eps.root_pos, height: eps.root_height, rot: eps.root_rot, linvel: eps.root_linvel, angvel: eps.root_angvel };
    perturb_body(&mut s.root_pos, &mut s.root_quat, &mut s.root_linvel, &mut s.root_angvel_local, root, rng);
    add_sym(&mut s.dof_pos, rng, eps.dof_pos);
    add_sym(&mut s.dof_vel, rng, eps.dof_vel);
    if with_ball {
        let ball = BodyEps { xy: eps.ball_pos, height: eps.ball_height, rot: eps.ball_rot, linvel: eps.ball_linvel, angvel: eps.ball_angvel };
        perturb_body(&mut s.ball_pos, &mut s.ball_quat, &mut s.ball_linvel, &mut s.ball_angvel_local, ball, rng);
    }
}

/// Start frames an episode may connect to: 2 … T−2 (frames 0 and 1 have no velocity, T−1 has no
/// next frame).
pub fn connectable_frames(m: &MotionClip) -> std::ops::RangeInclusive<usize> {
    2..=m.clip.num_frames - 2
}

/// The frame of clip `m` most similar to the (simulated) state `s`, and its similarity β.
/// Ties keep the earliest frame.
pub fn connect(s: &HoiState, m: &MotionClip, cfg: &RewardConfig, ball_free: bool) -> (usize, f64) {
    let mut best = (*connectable_frames(m).start(), f64::NEG_INFINITY);
    for j in connectable_frames(m) {
        let sim = similarity(s, &HoiState::from_reference(m, j), cfg, ball_free);
        if sim > best.1 {
            best = (j, sim);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn within(a: &[f64], b: &[f64], lo: f64, hi: f64) -> bool {
        a.iter().zip(b).all(|(x, y)| {
            let d = x - y;
            d >= lo - 1e-12 && d <= hi + 1e-12
        })
    }

    fn rel_rotvec(a: Quat, b: Quat) -> [f64; 3] {
        // a = exp(d) b  ->  d = log(a b⁻¹)
        a.mul(b.conj()).normalized().to_rotvec()
    }

    #[test]
    fn neighbourhood_samples_stay_inside_the_stated_bounds() {
        let eps = NoiseEps {
            root_pos: 0.1,
            root_height: 0.05,
            root_rot: 0.2,
            root_linvel: 0.3,
            root_angvel: 0.4,
            dof_pos: 0.1,
            dof_vel: 0.5,
            ball_pos: 0.15,
            ball_height: 0.07,
            ball_rot: 0.1,
            ball_linvel: 0.2,
            ball_angvel: 0.3,
        };
        let base = ResetState { root_quat: Quat::from_rotvec([0.3, -1.0, 2.0]), ball_quat: Quat::from_rotvec([1.0, 0.5, 0.0]), ..Default::default() };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let (mut max_dof, mut min_h) = (0.0f64, f64::INFINITY);
        for _ in 0..2000 {
            let mut s = base.clone();
            perturb(&mut s, &eps, true, &mut rng);
            assert!(within(&s.root_pos[..2], &base.root_pos[..2], -eps.root_pos, eps.root_pos));
            assert!(within(&s.root_pos[2..], &base.root_pos[2..], 0.0, eps.root_height));
            assert!(within(&rel_rotvec(s.root_quat, base.root_quat), &[0.0; 3], -eps.root_rot, eps.root_rot));
            assert!(within(&s.root_linvel, &base.root_linvel, -eps.root_linvel, eps.root_linvel));
            assert!(within(&s.root_angvel_local, &base.root_angvel_local, -eps.root_angvel, eps.root_angvel));
            assert!(within(&s.dof_pos, &base.dof_pos, -eps.dof_pos, eps.dof_pos));
            assert!(within(&s.dof_vel, &base.dof_vel, -eps.dof_vel, eps.dof_vel));
            assert!(within(&s.ball_pos[..2], &base.ball_pos[..2], -eps.ball_pos, eps.ball_pos));
            assert!(within(&s.ball_pos[2..], &base.ball_pos[2..], 0.0, eps.ball_height));
            assert!(within(&rel_rotvec(s.ball_quat, base.ball_quat), &[0.0; 3], -eps.ball_rot, eps.ball_rot));
            assert!(within(&s.ball_linvel, &base.ball_linvel, -eps.ball_linvel, eps.ball_linvel));
            assert!(within(&s.ball_angvel_local, &base.ball_angvel_local, -eps.ball_angvel, eps.ball_angvel));
            max_dof = max_dof.max(s.dof_pos.iter().zip(&base.dof_pos).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max));
            min_h = min_h.min(s.root_pos[2] - base.root_pos[2]);
        }
        // the samples fill the neighbourhood (not a degenerate sampler)
        assert!(max_dof > 0.99 * eps.dof_pos, "{max_dof}");
        assert!(min_h < 0.01 * eps.root_height);
        // the ball is left alone when asked
        let mut s = base.clone();
        perturb(&mut s, &eps, false, &mut rng);
        assert_eq!((s.ball_pos, s.ball_quat, s.ball_linvel), (base.ball_pos, base.ball_quat, base.ball_linvel));
        // zero widths leave the state unchanged
        let zero = NoiseEps::zero();
        let mut s = base.clone();
        perturb(&mut s, &zero, true, &mut rng);
        assert_eq!(s.dof_pos, base.dof_pos);
        assert!(within(&s.root_quat.to_wxyz(), &base.root_quat.to_wxyz(), -1e-15, 1e-15));
    }
}
