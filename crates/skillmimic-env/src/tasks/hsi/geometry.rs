//! Geometry shared by the TokenHSI task observations and rewards: the root's heading frame,
//! object bounding-box corners, horizontal directions, and the start of an episode.

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use skillmimic_core::characters::tokenhsi::STANDING_ROOT_HEIGHT;
use skillmimic_core::math::{Quat, Vec3, heading, heading_inverse, sub, tan_norm};
use skillmimic_sim::{EnvState, ResetState};

/// The character's heading frame: origin at the root, rotated about +z by −heading.
#[derive(Clone, Copy, Debug)]
pub struct Local {
    pub root: Vec3,
    pub inv: Quat,
}

impl Local {
    /// The heading frame of the root (body 0) of `st`.
    pub fn of(st: &EnvState<'_>) -> Self {
        Self { root: st.pos(0), inv: heading_inverse(st.quat(0)) }
    }
    /// A world point in the heading frame (m).
    pub fn point(&self, p: Vec3) -> Vec3 {
        self.inv.rotate(sub(p, self.root))
    }
    /// A world vector (velocity, direction) in the heading frame.
    pub fn vector(&self, v: Vec3) -> Vec3 {
        self.inv.rotate(v)
    }
    /// A world rotation as heading-local tan-norm 6D.
    pub fn rotation(&self, q: Quat) -> [f64; 6] {
        tan_norm(self.inv.mul(q))
    }
}

/// The 8 corners (world, m) of the box `[lo, hi]` (object frame) of an object at `pos`/`quat`, in
/// the released `_build_object_bps` order: the bottom face (+x +y), (−x +y), (−x −y), (+x −y), then
/// the top face in the same order (+x = `hi[0]`, −x = `lo[0]`, …).
pub fn corners(pos: Vec3, quat: Quat, lo: Vec3, hi: Vec3) -> [Vec3; 8] {
    const SIGNS: [[bool; 2]; 4] = [[true, true], [false, true], [false, false], [true, false]];
    let mut out = [[0.0; 3]; 8];
    for (k, c) in out.iter_mut().enumerate() {
        let [px, py] = SIGNS[k % 4];
        let p = [
            if px { hi[0] } else { lo[0] },
            if py { hi[1] } else { lo[1] },
            if k < 4 { lo[2] } else { hi[2] },
        ];
        let r = quat.rotate(p);
        *c = [pos[0] + r[0], pos[1] + r[1], pos[2] + r[2]];
    }
    out
}

/// Write `v` as float32 into `out[at..]`, returning the next index.
pub fn put(out: &mut [f32], at: usize, v: &[f64]) -> usize {
    for (o, x) in out[at..at + v.len()].iter_mut().zip(v) {
        *o = *x as f32;
    }
    at + v.len()
}

/// 2-D distance between the horizontal parts of `a` and `b` (m).
pub fn dist2d(a: Vec3, b: Vec3) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
}

/// Horizontal unit vector from `from` to `to` (zero when they coincide).
pub fn dir2d(from: Vec3, to: Vec3) -> [f64; 2] {
    let (dx, dy) = (to[0] - from[0], to[1] - from[1]);
    let n = (dx * dx + dy * dy).sqrt();
    if n > 1e-9 { [dx / n, dy / n] } else { [0.0, 0.0] }
}

/// `exp(−k (v* − d·v)²)`: the speed-towards-a-target reward of the far stage (Eqs. 3, 6, 9, 11),
/// with the horizontal velocity `v` = finite difference of positions over `dt`.
pub fn speed_reward(
    k: f64,
    target_speed: f64,
    d: [f64; 2],
    now: Vec3,
    before: Vec3,
    dt: f64,
) -> f64 {
    (-k * (target_speed - along(d, now, before, dt)).powi(2)).exp()
}

/// `d·v`: the horizontal velocity (finite difference of positions over `dt`, m/s) along the unit
/// direction `d`.
fn along(d: [f64; 2], now: Vec3, before: Vec3, dt: f64) -> f64 {
    let v = [(now[0] - before[0]) / dt, (now[1] - before[1]) / dt];
    d[0] * v[0] + d[1] * v[1]
}

/// Squared 3-D distance.
pub fn dist_sq(a: Vec3, b: Vec3) -> f64 {
    let d = sub(a, b);
    d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
}

/// The released direction-speed term: `exp(−k (v* − d·v)²)` as [`speed_reward`], but 0 when the
/// horizontal velocity points away from the target (`d·v ≤ 0`).
pub fn speed_reward_towards(
    k: f64,
    target_speed: f64,
    d: [f64; 2],
    now: Vec3,
    before: Vec3,
    dt: f64,
) -> f64 {
    let v = along(d, now, before, dt);
    if v <= 0.0 { 0.0 } else { (-k * (target_speed - v).powi(2)).exp() }
}

/// The released excess penalty `−coeff (1 − exp(−k (threshold − max(x, threshold))²))`: 0 up to
/// `threshold`, approaching −`coeff` beyond it (speeds in m/s, turning rates in rad/s).
pub fn excess_penalty(coeff: f64, k: f64, threshold: f64, x: f64) -> f64 {
    -coeff * (1.0 - (-k * (threshold - x.max(threshold)).powi(2)).exp())
}

/// 3-D speed (m/s) of a point that moved from `before` to `now` in `dt` s.
pub fn speed(now: Vec3, before: Vec3, dt: f64) -> f64 {
    dist_sq(now, before).sqrt() / dt
}

/// The yaw of `q` in [0, 2π) (rad), as the released `get_euler_xyz` returns it (not unwrapped).
pub fn yaw_0_2pi(q: Quat) -> f64 {
    heading(q).rem_euclid(std::f64::consts::TAU)
}

/// Squared 2-D distance between the horizontal parts of `a` and `b` (m²).
pub fn dist2d_sq(a: Vec3, b: Vec3) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}

/// The start of the character: the rest pose standing at the origin, facing a uniformly random
/// heading (or +x), at rest. (Reference-state initialisation from retargeted clips is not used:
/// the project ships none for these tasks.)
pub fn stand_at_origin(rng: &mut ChaCha8Rng, random_heading: bool, reset: &mut ResetState) -> f64 {
    let yaw = if random_heading {
        rng.random_range(-std::f64::consts::PI..std::f64::consts::PI)
    } else {
        0.0
    };
    reset.clear([0.0, 0.0, STANDING_ROOT_HEIGHT], Quat::about_z(yaw));
    yaw
}

/// A value drawn uniformly from the configured range `[low, high]` (`low` when they are equal).
pub fn draw(rng: &mut ChaCha8Rng, r: [f64; 2]) -> f64 {
    if r[1] > r[0] { rng.random_range(r[0]..r[1]) } else { r[0] }
}

/// A point on the ground at a random direction and a distance in `r` from the origin.
pub fn ring_point(rng: &mut ChaCha8Rng, r: [f64; 2]) -> [f64; 2] {
    let a = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
    let d = draw(rng, r);
    [d * a.cos(), d * a.sin()]
}
