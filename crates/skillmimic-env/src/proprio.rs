//! The character part of every observation, for any character: ASE's proprioception as the
//! character's [`Proprioception`] selects it, and ASE's fall rule.
//!
//! Layout (float32), all in the root's heading frame (world rotated about +z by −heading(root)),
//! relative to the root where noted:
//! * `[root height]` (m, world z) — SkillMimic humanoid, SMPL; not TokenHSI;
//! * positions of bodies 1…n−1 minus the root position (m);
//! * rotations of bodies 0…n−1 as tan-norm 6D (rotated x axis, rotated z axis) — the root's in the
//!   **world** frame for TokenHSI, heading-local otherwise;
//! * linear velocities of the bodies' centres of mass (m/s);
//! * angular velocities of the bodies (rad/s);
//! * net contact force on the character's listed bodies (**world** frame, N; the SkillMimic
//!   humanoid's ten fingertips).
//!
//! Widths: SkillMimic humanoid 823 (`obs::layout::HUMANOID_DIM`), TokenHSI character 222, SMPL
//! humanoid 358 (PHC's self observation).

use skillmimic_core::characters::{CharacterSpec, Proprioception};
use skillmimic_core::math::{heading_inverse, sub, tan_norm};
use skillmimic_sim::EnvState;

#[inline]
fn put3(out: &mut [f32], at: usize, v: [f64; 3]) {
    out[at] = v[0] as f32;
    out[at + 1] = v[1] as f32;
    out[at + 2] = v[2] as f32;
}

/// Write the proprioception of the first `n` state bodies of `st` into `out[..p.width(n)]`.
pub fn write(p: &Proprioception, n: usize, st: &EnvState<'_>, out: &mut [f32]) {
    let root = st.pos(0);
    let rq = st.quat(0);
    let inv = heading_inverse(rq);
    let h = usize::from(p.root_height);
    if p.root_height {
        out[0] = root[2] as f32;
    }
    for b in 1..n {
        put3(out, h + 3 * (b - 1), inv.rotate(sub(st.pos(b), root)));
    }
    let r0 = h + 3 * (n - 1);
    let (v0, w0) = (r0 + 6 * n, r0 + 9 * n);
    for b in 0..n {
        let t = if b == 0 && p.root_rotation_world {
            tan_norm(rq)
        } else {
            tan_norm(inv.mul(st.quat(b)))
        };
        for k in 0..6 {
            out[r0 + 6 * b + k] = t[k] as f32;
        }
        put3(out, v0 + 3 * b, inv.rotate(st.linvel(b)));
        put3(out, w0 + 3 * b, inv.rotate(st.angvel(b)));
    }
    let f0 = r0 + 12 * n;
    for (k, &b) in p.contact_force_bodies.iter().enumerate() {
        put3(out, f0 + 3 * k, st.contact_force(b));
    }
}

/// [`fn@write`] for `spec`'s bodies.
pub fn write_for(spec: &CharacterSpec, st: &EnvState<'_>, out: &mut [f32]) {
    write(&spec.proprio, spec.bodies.len(), st, out)
}

/// The columns of `out` that [`write()`] fills with body `b`'s own state, in layout order: its
/// position (bodies after the root), rotation, linear and angular velocity and, for a
/// contact-force body, its force. The root height (column 0 when present) belongs to no body.
pub fn body_columns(p: &Proprioception, n: usize, b: usize) -> Vec<usize> {
    let h = usize::from(p.root_height);
    let (r0, v0) = (h + 3 * (n - 1), h + 3 * (n - 1) + 6 * n);
    let (w0, f0) = (v0 + 3 * n, v0 + 6 * n);
    let mut c = Vec::with_capacity(18);
    if b >= 1 {
        c.extend(h + 3 * (b - 1)..h + 3 * b);
    }
    c.extend(r0 + 6 * b..r0 + 6 * (b + 1));
    c.extend(v0 + 3 * b..v0 + 3 * (b + 1));
    c.extend(w0 + 3 * b..w0 + 3 * (b + 1));
    if let Some(k) = p.contact_force_bodies.iter().position(|&t| t == b) {
        c.extend(f0 + 3 * k..f0 + 3 * (k + 1));
    }
    c
}

/// ASE's fall rule: a character body other than the ground bodies (the feet) touches something
/// that is not the character below `height` (m).
pub fn fallen(spec: &CharacterSpec, st: &EnvState<'_>, height: f64) -> bool {
    (0..spec.bodies.len())
        .any(|b| !spec.ground_bodies.contains(&b) && st.touches(b) && st.pos(b)[2] < height)
}
