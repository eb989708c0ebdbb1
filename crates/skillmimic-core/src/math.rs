//! Rotation math in `f64`.
//!
//! Conventions used everywhere in skillmimic-rs:
//! * quaternions are **(w, x, y, z)**, as in MuJoCo (`qpos`, `xquat`); the original SkillMimic
//!   code stores (x, y, z, w) — convert only at the boundary with [`Quat::from_xyzw`];
//! * a rotation vector (exponential map) is `axis · angle` in radians;
//! * `q.rotate(v)` maps a vector from the rotated (child/body) frame to the reference
//!   (parent/world) frame;
//! * the world is Z-up with gravity along −z.

use std::f64::consts::PI;

/// A 3-vector (m, m/s, rad/s … depending on use).
pub type Vec3 = [f64; 3];

/// `a + b`.
#[inline]
pub fn add(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
/// `a − b`.
#[inline]
pub fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
/// `s · a`.
#[inline]
pub fn scale(a: Vec3, s: f64) -> Vec3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
/// Dot product.
#[inline]
pub fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
/// Cross product `a × b`.
#[inline]
pub fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
/// Euclidean norm.
#[inline]
pub fn norm(a: Vec3) -> f64 {
    dot(a, a).sqrt()
}

/// Unit quaternion (w, x, y, z).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Quat {
    pub w: f64,
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

impl Default for Quat {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Quat {
    /// The identity rotation.
    pub const IDENTITY: Quat = Quat { w: 1.0, x: 0.0, y: 0.0, z: 0.0 };

    /// From MuJoCo order `[w, x, y, z]`.
    #[inline]
    pub fn from_wxyz(q: [f64; 4]) -> Self {
        Quat { w: q[0], x: q[1], y: q[2], z: q[3] }
    }
    /// To MuJoCo order `[w, x, y, z]`.
    #[inline]
    pub fn to_wxyz(self) -> [f64; 4] {
        [self.w, self.x, self.y, self.z]
    }
    /// From Isaac Gym order `[x, y, z, w]`.
    #[inline]
    pub fn from_xyzw(q: [f64; 4]) -> Self {
        Quat { w: q[3], x: q[0], y: q[1], z: q[2] }
    }
    /// To Isaac Gym order `[x, y, z, w]`.
    #[inline]
    pub fn to_xyzw(self) -> [f64; 4] {
        [self.x, self.y, self.z, self.w]
    }

    /// Rotation of `angle` radians about the unit vector `axis`.
    pub fn from_axis_angle(axis: Vec3, angle: f64) -> Self {
        let (s, c) = (0.5 * angle).sin_cos();
        Quat { w: c, x: axis[0] * s, y: axis[1] * s, z: axis[2] * s }
    }

    /// Rotation of `angle` radians about world +z.
    pub fn about_z(angle: f64) -> Self {
        let (s, c) = (0.5 * angle).sin_cos();
        Quat { w: c, x: 0.0, y: 0.0, z: s }
    }

    /// Exponential map: the rotation whose rotation vector is `v` (axis · angle, rad).
    pub fn from_rotvec(v: Vec3) -> Self {
        let angle = norm(v);
        let half = 0.5 * angle;
        // sin(a/2)/a, with its Taylor series near zero
        let k = if angle < 1e-8 { 0.5 - angle * angle / 48.0 } else { half.sin() / angle };
        Quat { w: half.cos(), x: v[0] * k, y: v[1] * k, z: v[2] * k }
    }

    /// Logarithm map: rotation vector with angle in (−π, π], the same convention as MuJoCo's
    /// `mju_quat2Vel(·, q, 1)` (which is what a ball-joint actuator reports as its length).
    pub fn to_rotvec(self) -> Vec3 {
        let v = [self.x, self.y, self.z];
        let s = norm(v);
        if s < 1e-15 {
            return [0.0; 3];
        }
        let mut angle = 2.0 * s.atan2(self.w);
        if angle > PI {
            angle -= 2.0 * PI;
        }
        scale(v, angle / s)
    }

    /// Hamilton product `self ⊗ r` (apply `r` first, then `self`).
    #[inline]
    pub fn mul(self, r: Quat) -> Quat {
        Quat {
            w: self.w * r.w - self.x * r.x - self.y * r.y - self.z * r.z,
            x: self.w * r.x + self.x * r.w + self.y * r.z - self.z * r.y,
            y: self.w * r.y - self.x * r.z + self.y * r.w + self.z * r.x,
            z: self.w * r.z + self.x * r.y - self.y * r.x + self.z * r.w,
        }
    }

    /// Conjugate (= inverse for unit quaternions).
    #[inline]
    pub fn conj(self) -> Quat {
        Quat { w: self.w, x: -self.x, y: -self.y, z: -self.z }
    }

    /// Unit-norm copy (identity for a zero quaternion).
    pub fn normalized(self) -> Quat {
        let n = (self.w * self.w + self.x * self.x + self.y * self.y + self.z * self.z).sqrt();
        if n < 1e-15 {
            return Quat::IDENTITY;
        }
        Quat { w: self.w / n, x: self.x / n, y: self.y / n, z: self.z / n }
    }

    /// 4-D dot product (sign continuity tests).
    #[inline]
    pub fn dot(self, r: Quat) -> f64 {
        self.w * r.w + self.x * r.x + self.y * r.y + self.z * r.z
    }

    /// `-q` (same rotation).
    #[inline]
    pub fn neg(self) -> Quat {
        Quat { w: -self.w, x: -self.x, y: -self.y, z: -self.z }
    }

    /// Rotate vector `v` by this rotation.
    #[inline]
    pub fn rotate(self, v: Vec3) -> Vec3 {
        // v' = v + 2 w (u × v) + 2 u × (u × v), u = (x, y, z)
        let u = [self.x, self.y, self.z];
        let t = scale(cross(u, v), 2.0);
        add(add(v, scale(t, self.w)), cross(u, t))
    }

    /// The smallest rotation taking direction `a` onto direction `b` (any frame; lengths are
    /// ignored; the identity when either is zero; half a turn about an axis perpendicular to `a`
    /// when they are opposite).
    pub fn between(a: Vec3, b: Vec3) -> Quat {
        let (na, nb) = (norm(a), norm(b));
        if na < 1e-12 || nb < 1e-12 {
            return Quat::IDENTITY;
        }
        let (a, b) = (scale(a, 1.0 / na), scale(b, 1.0 / nb));
        let c = dot(a, b);
        if c < -1.0 + 1e-12 {
            // opposite: half a turn about any axis perpendicular to a
            let axis = if a[0].abs() < 0.9 {
                cross(a, [1.0, 0.0, 0.0])
            } else {
                cross(a, [0.0, 1.0, 0.0])
            };
            return Quat::from_axis_angle(scale(axis, 1.0 / norm(axis)), std::f64::consts::PI);
        }
        let v = cross(a, b);
        Quat { w: 1.0 + c, x: v[0], y: v[1], z: v[2] }.normalized()
    }

    /// Spherical interpolation from `self` (t = 0) to `b` (t = 1) along the shorter arc.
    pub fn slerp(self, b: Quat, t: f64) -> Quat {
        let b = if self.dot(b) < 0.0 { b.neg() } else { b };
        let d = self.conj().mul(b).to_rotvec();
        self.mul(Quat::from_rotvec([d[0] * t, d[1] * t, d[2] * t])).normalized()
    }

    /// Rotation angle in [0, π] of this rotation.
    pub fn angle(self) -> f64 {
        let s = norm([self.x, self.y, self.z]);
        2.0 * s.atan2(self.w.abs())
    }
}

/// Heading angle (rad) of a root orientation: world +x rotated by `q`, projected on the ground
/// plane, `atan2(y, x)`. For the SkillMimic skeleton this is the direction of the character's
/// left side (the definition of the original observation; used consistently it is harmless).
#[inline]
pub fn heading(q: Quat) -> f64 {
    let d = q.rotate([1.0, 0.0, 0.0]);
    d[1].atan2(d[0])
}

/// Rotation about +z by −heading(q): maps world vectors into the root's heading frame.
#[inline]
pub fn heading_inverse(q: Quat) -> Quat {
    Quat::about_z(-heading(q))
}

/// Tan-norm 6D encoding of a rotation: the rotated x axis followed by the rotated z axis.
#[inline]
pub fn tan_norm(q: Quat) -> [f64; 6] {
    let a = q.rotate([1.0, 0.0, 0.0]);
    let c = q.rotate([0.0, 0.0, 1.0]);
    [a[0], a[1], a[2], c[0], c[1], c[2]]
}

/// Wrap an angle to [−π, π).
#[inline]
pub fn wrap_angle(a: f64) -> f64 {
    (a + PI).rem_euclid(2.0 * PI) - PI
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &[f64], b: &[f64], tol: f64) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
    }

    #[test]
    fn exp_and_log_are_inverse_below_pi() {
        for v in [[0.3, -0.2, 0.1], [1e-10, 0.0, 2e-10], [2.0, 1.0, -1.5], [0.0, 0.0, 3.1]] {
            let q = Quat::from_rotvec(v);
            assert!((q.dot(q) - 1.0).abs() < 1e-14);
            assert!(close(&q.to_rotvec(), &v, 1e-12), "{v:?} -> {:?}", q.to_rotvec());
        }
        // log of the negated quaternion gives the same rotation vector
        let q = Quat::from_rotvec([0.4, 0.5, -0.6]);
        assert!(close(&q.neg().to_rotvec(), &[0.4, 0.5, -0.6], 1e-12));
    }

    #[test]
    fn rotation_about_x_by_90_degrees_maps_y_to_z() {
        // the Y-up -> Z-up tilt of the skeleton
        let q = Quat::from_rotvec([PI / 2.0, 0.0, 0.0]);
        assert!(close(&q.rotate([0.0, 1.0, 0.0]), &[0.0, 0.0, 1.0], 1e-15));
        assert!(close(&q.rotate([0.0, 0.0, 1.0]), &[0.0, -1.0, 0.0], 1e-15));
        let h = Quat::about_z(0.7);
        assert!((heading(h.mul(q)) - 0.7).abs() < 1e-12);
        // heading frame undoes the yaw
        let hi = heading_inverse(h.mul(q));
        assert!((heading(hi.mul(h).mul(q))).abs() < 1e-12);
    }

    #[test]
    fn product_composes_rotations() {
        let a = Quat::from_rotvec([0.1, 0.2, 0.3]);
        let b = Quat::from_rotvec([-0.4, 0.0, 0.9]);
        let v = [0.3, -1.0, 2.0];
        assert!(close(&a.mul(b).rotate(v), &a.rotate(b.rotate(v)), 1e-14));
        assert!(close(&a.conj().rotate(a.rotate(v)), &v, 1e-14));
        assert_eq!(Quat::from_xyzw(a.to_xyzw()), a);
    }

    #[test]
    fn tan_norm_of_identity_and_quarter_turn() {
        assert_eq!(tan_norm(Quat::IDENTITY), [1.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
        let t = tan_norm(Quat::about_z(PI / 2.0));
        assert!(close(&t, &[0.0, 1.0, 0.0, 0.0, 0.0, 1.0], 1e-15));
        assert!((wrap_angle(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-15);
    }
}
