//! State Transition Field (SkillMimic-V2, seed 003 §4.3, App. B.4): start an episode from a
//! state in the ε-neighbourhood of a reference state and connect it to the most similar frame of
//! the same clip.
//!
//! Choices where paper and reference code differ (reference-facts §9.5):
//! * noise ([`perturb`]): with `env.compat = "paper"` uniform in [−ε, ε] for every component
//!   (paper Tab. 7), heights upward only (code), root x/y perturbed too (paper: "every state
//!   component"); with `"code"` the released code's biased-Gaussian noise ([`perturb_code`]);
//! * the connection compares the **perturbed** state after forward kinematics (the reference code
//!   compares the previous episode's last state, a bug) with every frame 2 … T−2 of the clip,
//!   using [`similarity`](super::similarity::similarity).

use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use skillmimic_core::math::Quat;
use skillmimic_motion::MotionClip;
use skillmimic_sim::ResetState;

use crate::compat::Compat;
use crate::config::{NoiseEps, RewardConfig};
use crate::hoi::HoiState;
use crate::v2::similarity::connection_similarity;

#[inline]
fn sym<R: Rng>(rng: &mut R, eps: f64) -> f64 {
    if eps > 0.0 { rng.random_range(-eps..=eps) } else { 0.0 }
}

#[inline]
fn up<R: Rng>(rng: &mut R, eps: f64) -> f64 {
    if eps > 0.0 { rng.random_range(0.0..=eps) } else { 0.0 }
}

fn add_sym<R: Rng>(v: &mut [f64], rng: &mut R, eps: f64) {
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

fn perturb_body<R: Rng>(
    pos: &mut [f64; 3],
    quat: &mut Quat,
    linvel: &mut [f64; 3],
    angvel: &mut [f64; 3],
    e: BodyEps,
    rng: &mut R,
) {
    pos[0] += sym(rng, e.xy);
    pos[1] += sym(rng, e.xy);
    pos[2] += up(rng, e.height);
    *quat = perturb_rotation(*quat, rng, e.rot);
    add_sym(linvel, rng, e.linvel);
    add_sym(angvel, rng, e.angvel);
}

/// Perturb a reset state: the paper's uniform ε-neighbourhood ([`perturb_uniform`]) or, with
/// `compat = Code`, the released code's noise ([`perturb_code`]; `after_getup` = the environment's
/// previous episode imitated the get-up skill, label 0).
pub fn perturb<R: Rng>(
    s: &mut ResetState,
    eps: &NoiseEps,
    with_ball: bool,
    compat: Compat,
    after_getup: bool,
    rng: &mut R,
) {
    if compat.is_code() {
        perturb_code(s, eps, with_ball, after_getup, rng)
    } else {
        perturb_uniform(s, eps, with_ball, rng)
    }
}

/// Roll, pitch, yaw (rad) of `q` with q = R_z(yaw)·R_y(pitch)·R_x(roll) (Isaac Gym's
/// `get_euler_xyz` / `quat_from_euler_xyz` pair the released code uses).
pub fn to_roll_pitch_yaw(q: Quat) -> [f64; 3] {
    let Quat { w, x, y, z } = q.normalized();
    let roll = (2.0 * (w * x + y * z)).atan2(1.0 - 2.0 * (x * x + y * y));
    let pitch = (2.0 * (w * y - z * x)).clamp(-1.0, 1.0).asin();
    let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
    [roll, pitch, yaw]
}

/// The rotation R_z(yaw)·R_y(pitch)·R_x(roll).
pub fn from_roll_pitch_yaw(e: [f64; 3]) -> Quat {
    Quat::from_axis_angle([0.0, 0.0, 1.0], e[2])
        .mul(Quat::from_axis_angle([0.0, 1.0, 0.0], e[1]))
        .mul(Quat::from_axis_angle([1.0, 0.0, 0.0], e[0]))
}

/// w_g·(2·N(0,1) − 1): the released code's velocity / joint noise (mean −w_g, std 2·w_g).
#[inline]
fn biased_gauss<R: Rng>(rng: &mut R, w: f64) -> f64 {
    if w > 0.0 {
        let n: f64 = StandardNormal.sample(rng);
        w * (2.0 * n - 1.0)
    } else {
        0.0
    }
}

fn add_gauss<R: Rng>(v: &mut [f64], rng: &mut R, w: f64) {
    for x in v.iter_mut() {
        *x += biased_gauss(rng, w);
    }
}

/// Euler-angle orientation noise: roll, pitch and yaw each + U(−w, w).
fn euler_noise<R: Rng>(q: Quat, rng: &mut R, w: f64) -> Quat {
    let mut e = to_roll_pitch_yaw(q);
    for a in e.iter_mut() {
        *a += sym(rng, w);
    }
    from_roll_pitch_yaw(e)
}

/// The released code's initial-state noise (reference-facts §9.5 step 1), with the widths of
/// [`NoiseEps`] as its scales (all 0.1 by default = the code's constants):
/// * root height + U(0, w), w = `root_height` (1.0 after a get-up episode); root orientation:
///   roll/pitch/yaw each + U(−w_r, w_r), w_r = `root_rot` (1.0 after get-up); no x/y noise;
/// * root linear / angular velocity, joint velocities: + w·(2·N(0,1) − 1) with w =
///   `root_linvel` / `root_angvel` / `dof_vel`; joint exp maps likewise with `dof_pos` (0.5 after
///   get-up);
/// * ball (when `with_ball`): height + U(0, `ball_height`); orientation roll/pitch/yaw ±
///   `ball_rot`; linear / angular velocity + w·(2·N − 1) with `ball_linvel` / `ball_angvel`; no
///   x/y noise.
pub fn perturb_code<R: Rng>(
    s: &mut ResetState,
    eps: &NoiseEps,
    with_ball: bool,
    after_getup: bool,
    rng: &mut R,
) {
    let (wh, wr, wd) =
        if after_getup { (1.0, 1.0, 0.5) } else { (eps.root_height, eps.root_rot, eps.dof_pos) };
    s.root_pos[2] += up(rng, wh);
    s.root_quat = euler_noise(s.root_quat, rng, wr);
    add_gauss(&mut s.root_linvel, rng, eps.root_linvel);
    add_gauss(&mut s.root_angvel_local, rng, eps.root_angvel);
    add_gauss(&mut s.dof_pos, rng, wd);
    add_gauss(&mut s.dof_vel, rng, eps.dof_vel);
    if with_ball {
        let b = s.ball_mut();
        b.pos[2] += up(rng, eps.ball_height);
        b.quat = euler_noise(b.quat, rng, eps.ball_rot);
        add_gauss(&mut b.linvel, rng, eps.ball_linvel);
        add_gauss(&mut b.angvel_local, rng, eps.ball_angvel);
    }
}

/// Perturb a reset state inside the ε-neighbourhood ([`NoiseEps`] documents each component).
/// The ball is perturbed only when `with_ball` (clips without a ball already get a random one).
pub fn perturb_uniform<R: Rng>(s: &mut ResetState, eps: &NoiseEps, with_ball: bool, rng: &mut R) {
    let root = BodyEps {
        xy: eps.root_pos,
        height: eps.root_height,
        rot: eps.root_rot,
        linvel: eps.root_linvel,
        angvel: eps.root_angvel,
    };
    perturb_body(
        &mut s.root_pos,
        &mut s.root_quat,
        &mut s.root_linvel,
        &mut s.root_angvel_local,
        root,
        rng,
    );
    add_sym(&mut s.dof_pos, rng, eps.dof_pos);
    add_sym(&mut s.dof_vel, rng, eps.dof_vel);
    if with_ball {
        let ball = BodyEps {
            xy: eps.ball_pos,
            height: eps.ball_height,
            rot: eps.ball_rot,
            linvel: eps.ball_linvel,
            angvel: eps.ball_angvel,
        };
        let b = s.ball_mut();
        perturb_body(&mut b.pos, &mut b.quat, &mut b.linvel, &mut b.angvel_local, ball, rng);
    }
}

/// Start frames an episode may connect to: 2 … T−2 (frames 0 and 1 have no velocity, T−1 has no
/// next frame).
pub fn connectable_frames(m: &MotionClip) -> std::ops::RangeInclusive<usize> {
    2..=m.clip.num_frames - 2
}

/// The frame of clip `m` most similar to the (simulated) state `s`, and its similarity β.
/// Ties keep the earliest frame.
/// `compat` picks the similarity ([`connection_similarity`]).
pub fn connect(
    s: &HoiState,
    m: &MotionClip,
    cfg: &RewardConfig,
    ball_free: bool,
    compat: Compat,
) -> (usize, f64) {
    let mut best = (*connectable_frames(m).start(), f64::NEG_INFINITY);
    for j in connectable_frames(m) {
        let sim = connection_similarity(s, &HoiState::from_reference(m, j), cfg, ball_free, compat);
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
        let mut base =
            ResetState { root_quat: Quat::from_rotvec([0.3, -1.0, 2.0]), ..Default::default() };
        base.ball_mut().quat = Quat::from_rotvec([1.0, 0.5, 0.0]);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let (mut max_dof, mut min_h) = (0.0f64, f64::INFINITY);
        for _ in 0..2000 {
            let mut s = base.clone();
            perturb_uniform(&mut s, &eps, true, &mut rng);
            assert!(within(&s.root_pos[..2], &base.root_pos[..2], -eps.root_pos, eps.root_pos));
            assert!(within(&s.root_pos[2..], &base.root_pos[2..], 0.0, eps.root_height));
            assert!(within(
                &rel_rotvec(s.root_quat, base.root_quat),
                &[0.0; 3],
                -eps.root_rot,
                eps.root_rot
            ));
            assert!(within(&s.root_linvel, &base.root_linvel, -eps.root_linvel, eps.root_linvel));
            assert!(within(
                &s.root_angvel_local,
                &base.root_angvel_local,
                -eps.root_angvel,
                eps.root_angvel
            ));
            assert!(within(&s.dof_pos, &base.dof_pos, -eps.dof_pos, eps.dof_pos));
            assert!(within(&s.dof_vel, &base.dof_vel, -eps.dof_vel, eps.dof_vel));
            assert!(within(&s.ball().pos[..2], &base.ball().pos[..2], -eps.ball_pos, eps.ball_pos));
            assert!(within(&s.ball().pos[2..], &base.ball().pos[2..], 0.0, eps.ball_height));
            assert!(within(
                &rel_rotvec(s.ball().quat, base.ball().quat),
                &[0.0; 3],
                -eps.ball_rot,
                eps.ball_rot
            ));
            assert!(within(
                &s.ball().linvel,
                &base.ball().linvel,
                -eps.ball_linvel,
                eps.ball_linvel
            ));
            assert!(within(
                &s.ball().angvel_local,
                &base.ball().angvel_local,
                -eps.ball_angvel,
                eps.ball_angvel
            ));
            max_dof = max_dof.max(
                s.dof_pos.iter().zip(&base.dof_pos).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max),
            );
            min_h = min_h.min(s.root_pos[2] - base.root_pos[2]);
        }
        // the samples fill the neighbourhood (not a degenerate sampler)
        assert!(max_dof > 0.99 * eps.dof_pos, "{max_dof}");
        assert!(min_h < 0.01 * eps.root_height);
        // the ball is left alone when asked
        let mut s = base.clone();
        perturb_uniform(&mut s, &eps, false, &mut rng);
        assert_eq!(s.ball(), base.ball());
        // zero widths leave the state unchanged
        let zero = NoiseEps::zero();
        let mut s = base.clone();
        perturb_uniform(&mut s, &zero, true, &mut rng);
        assert_eq!(s.dof_pos, base.dof_pos);
        assert!(within(&s.root_quat.to_wxyz(), &base.root_quat.to_wxyz(), -1e-15, 1e-15));
    }
}
