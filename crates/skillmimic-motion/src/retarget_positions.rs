//! Retargeting from joint positions alone (issue 23: `skillmimic retarget --positions`): a motion
//! given as world positions of named joints per frame (a CSV, or the 53 body positions a clip
//! stores) onto the SkillMimic humanoid, through the same joint maps, resampling and ground
//! alignment as the rotation paths ([`crate::retarget_bvh`]).
//!
//! Frames: source positions are in the map's axes (`up`, `yaw_deg`) and units; the solve works in
//! the humanoid skeleton's Y-up frame (T-pose rest, facing +z, left = +x) and the clip gets the
//! Y-up → Z-up turn in its root rotation, as in the rotation paths.
//!
//! Method, per frame, bodies in skeleton order (parents first):
//! * the *branches* of body b: for each child of b, the nearest mapped body down that child's
//!   subtree (through unmapped bodies); rest vector `r` = the humanoid's rest chain from b to it,
//!   observed vector `o` = source position of its joint − source position of b's joint;
//! * two or more branches that span a plane (pelvis: hips and spine; chest: neck and collars; a
//!   wrist: fingers): `G(b)` is the rotation that best takes the unit rest directions onto the
//!   unit observed ones (Horn's quaternion method: the top eigenvector of a 4 × 4 symmetric matrix,
//!   by Jacobi sweeps, written here because the workspace has no linear-algebra crate for one 4 × 4
//!   eigenproblem);
//! * one branch: the smallest rotation that turns the bone, carried by the parent's rotation, onto
//!   the observed direction, `G(b) = between(G(p)·r, o) · G(p)`;
//! * no branch (a leaf: head, toes, fingertips) or an unmapped body: `G(b) = G(parent)`;
//! * then the twists, which positions do not show: a one-branch bone whose direct child is solved
//!   from spanning branches turns about itself so that the child's local rotation is smallest (a
//!   hand solved from its fingers sets the forearm's twist). Other bones keep their parent's twist;
//!   letting the twist climb further (upper arm, collar) measured worse on a clip whose true
//!   rotations are known (0.78 rad mean at the collar instead of 0.08).
//!
//! Root position: the source pelvis joint × scale, scale = ratio of the humanoid's leg length
//! (hip → knee → ankle) to the source's median leg length over frames, else the map's `scale`.
//! With [`Options::ik`] the legs and arms are then bent so the ankles and wrists reach the source
//! positions × scale ([`crate::limb_ik`]).

use std::path::{Path, PathBuf};

use skillmimic_core::characters::skillmimic::{self as skeleton, BODIES, NUM_BODIES};
use skillmimic_core::math::{Quat, Vec3, cross, norm, scale, sub};

use crate::error::ClipError;
use crate::retarget_bvh::{
    JointMap, MAX_OUTPUT_FRAMES, Motion, Options, err_at, finish, locals_of, target_chain, up_turn,
};

/// Joint positions per frame: `frames × names.len()` points, row-major (source axes and units).
#[derive(Clone, Debug)]
pub struct JointPositions {
    /// The source file (named in errors).
    pub path: PathBuf,
    pub names: Vec<String>,
    /// Frames per second.
    pub fps: f64,
    pub frames: usize,
    pub positions: Vec<Vec3>,
}

impl JointPositions {
    pub fn joint(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    pub fn at(&self, frame: usize, joint: usize) -> Vec3 {
        self.positions[frame * self.names.len() + joint]
    }

    /// Read a CSV: a header of `<joint>_x,<joint>_y,<joint>_z` triples (also `<joint>.x` …), then
    /// one row of numbers per frame; `fps`: the file's frame rate. Errors name the file, the line
    /// and the expected value.
    pub fn read_csv(path: &Path, fps: f64) -> Result<Self, ClipError> {
        let fail = |detail: String| ClipError::Format { path: path.to_path_buf(), detail };
        if !(fps.is_finite() && fps > 0.0 && fps <= 10_000.0) {
            return Err(fail(format!(
                "frame rate {fps}: expected a positive number of frames per second (≤ 10000)"
            )));
        }
        let meta = std::fs::metadata(path)
            .map_err(|error| ClipError::Io { path: path.to_path_buf(), error })?;
        if meta.len() > crate::bvh::MAX_BYTES {
            return Err(fail(format!(
                "{} bytes: larger than the {} bytes a motion file may have",
                meta.len(),
                crate::bvh::MAX_BYTES
            )));
        }
        let text = std::fs::read_to_string(path)
            .map_err(|error| ClipError::Io { path: path.to_path_buf(), error })?;
        let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
        let Some((_, header)) = lines.next() else {
            return Err(fail(
                "empty: expected a header line of <joint>_x,<joint>_y,<joint>_z columns".into(),
            ));
        };
        let cells: Vec<&str> = header.split(',').map(str::trim).collect();
        if cells.is_empty() || !cells.len().is_multiple_of(3) {
            return Err(fail(format!(
                "line 1: {} columns, expected x, y, z triples per joint",
                cells.len()
            )));
        }
        let mut names = Vec::with_capacity(cells.len() / 3);
        for (k, triple) in cells.chunks(3).enumerate() {
            let stem = |c: &str, axis: char| {
                c.strip_suffix(&format!("_{axis}"))
                    .or_else(|| c.strip_suffix(&format!(".{axis}")))
                    .map(str::to_string)
            };
            match (stem(triple[0], 'x'), stem(triple[1], 'y'), stem(triple[2], 'z')) {
                (Some(a), Some(b), Some(c)) if a == b && b == c && !a.is_empty() => names.push(a),
                _ => {
                    return Err(fail(format!(
                        "line 1, columns {}–{}: expected <joint>_x,<joint>_y,<joint>_z, found '{}'",
                        3 * k + 1,
                        3 * k + 3,
                        triple.join(",")
                    )));
                }
            }
        }
        let mut positions = Vec::new();
        let mut frames = 0;
        for (i, line) in lines {
            let row: Vec<f64> = line
                .split(',')
                .map(|c| c.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|_| {
                    fail(format!(
                        "line {}: expected {} numbers, found '{}'",
                        i + 1,
                        cells.len(),
                        line.chars().take(80).collect::<String>()
                    ))
                })?;
            if row.len() != cells.len() || row.iter().any(|x| !x.is_finite()) {
                return Err(fail(format!(
                    "line {}: expected {} finite numbers, found {}",
                    i + 1,
                    cells.len(),
                    row.len()
                )));
            }
            positions.extend(row.chunks(3).map(|c| [c[0], c[1], c[2]]));
            frames += 1;
            if frames > MAX_OUTPUT_FRAMES {
                return Err(fail(format!("more than {MAX_OUTPUT_FRAMES} frames")));
            }
        }
        Ok(Self { path: path.to_path_buf(), names, fps, frames, positions })
    }
}

/// The rotation that best takes the unit vectors `rest[i]` onto `obs[i]` (Horn's quaternion
/// method).
pub fn best_rotation(rest: &[Vec3], obs: &[Vec3]) -> Quat {
    let mut s = [[0.0f64; 3]; 3];
    for (r, o) in rest.iter().zip(obs) {
        let (r, o) = (scale(*r, 1.0 / norm(*r)), scale(*o, 1.0 / norm(*o)));
        for i in 0..3 {
            for j in 0..3 {
                s[i][j] += r[i] * o[j];
            }
        }
    }
    let [[sxx, sxy, sxz], [syx, syy, syz], [szx, szy, szz]] = s;
    let mut n = [
        [sxx + syy + szz, syz - szy, szx - sxz, sxy - syx],
        [syz - szy, sxx - syy - szz, sxy + syx, szx + sxz],
        [szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy],
        [sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz],
    ];
    let (values, vectors) = jacobi4(&mut n);
    let k = (0..4).max_by(|&a, &b| values[a].total_cmp(&values[b])).expect("four eigenvalues");
    Quat { w: vectors[0][k], x: vectors[1][k], y: vectors[2][k], z: vectors[3][k] }.normalized()
}

/// Eigen-decomposition of a symmetric 4 × 4 matrix by cyclic Jacobi rotations: (eigenvalues,
/// eigenvectors as columns). The matrix is destroyed.
fn jacobi4(a: &mut [[f64; 4]; 4]) -> ([f64; 4], [[f64; 4]; 4]) {
    let mut v = [[0.0; 4]; 4];
    for (i, row) in v.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    for _sweep in 0..50 {
        let off: f64 = (0..4)
            .flat_map(|i| (0..4).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| a[i][j] * a[i][j])
            .sum();
        if off < 1e-30 {
            break;
        }
        for p in 0..3 {
            for q in p + 1..4 {
                if a[p][q].abs() < 1e-300 {
                    continue;
                }
                let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt()); // (signum(0) = 1)
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for row in a.iter_mut() {
                    let (akp, akq) = (row[p], row[q]);
                    row[p] = c * akp - s * akq;
                    row[q] = s * akp + c * akq;
                }
                let (rp, rq) = (a[p], a[q]);
                a[p] = std::array::from_fn(|k| c * rp[k] - s * rq[k]);
                a[q] = std::array::from_fn(|k| s * rp[k] + c * rq[k]);
                for row in v.iter_mut() {
                    let (vp, vq) = (row[p], row[q]);
                    row[p] = c * vp - s * vq;
                    row[q] = s * vp + c * vq;
                }
            }
        }
    }
    ([a[0][0], a[1][1], a[2][2], a[3][3]], v)
}

/// How a body's global rotation is found (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// Two or more branches spanning a plane: Horn's fit.
    Spanning,
    /// One branch (or collinear ones): the bone's direction, then the twist pass.
    Bone,
    /// Unmapped or a leaf: the parent's rotation.
    Inherit,
}

/// `parent` turned about the unit world axis `u` by the angle ψ that makes the local rotation
/// `parent(ψ)⁻¹ · child` smallest: with q(ψ) = P⁻¹·R_u(−ψ)·C, its scalar part is
/// cos(ψ/2)·w₁ − sin(ψ/2)·w₂ (w₁ = w(P⁻¹C), w₂ = w(P⁻¹·(0, u)·C)), largest at
/// ψ = 2·atan2(−w₂, w₁).
fn least_turn(parent: Quat, child: Quat, u: Vec3) -> Quat {
    let pinv = parent.conj();
    let w1 = pinv.mul(child).w;
    let w2 = pinv.mul(Quat { w: 0.0, x: u[0], y: u[1], z: u[2] }).mul(child).w;
    let psi = 2.0 * (-w2).atan2(w1);
    Quat::from_axis_angle(u, psi).mul(parent).normalized()
}

/// For each body: its branches (the nearest mapped bodies down each child's subtree).
fn branches(mapped: &[bool; NUM_BODIES]) -> Vec<Vec<usize>> {
    let children = |b: usize| (b + 1..NUM_BODIES).filter(move |&c| BODIES[c].parent == Some(b));
    fn nearest(c: usize, mapped: &[bool; NUM_BODIES]) -> Option<usize> {
        if mapped[c] {
            return Some(c);
        }
        (c + 1..NUM_BODIES)
            .filter(|&d| BODIES[d].parent == Some(c))
            .find_map(|d| nearest(d, mapped))
    }
    (0..NUM_BODIES).map(|b| children(b).filter_map(|c| nearest(c, mapped)).collect()).collect()
}

/// Retarget joint positions with `map` (see the module docs).
pub fn retarget_positions(
    src: &JointPositions,
    map: &JointMap,
    opts: &Options,
) -> Result<Motion, ClipError> {
    let path = &src.path;
    if src.positions.len() != src.frames * src.names.len()
        || !(src.fps.is_finite() && src.fps > 0.0)
    {
        return Err(err_at(
            path,
            format!(
                "{} positions for {} frames × {} joints at {} fps: expected frames × joints \
                    points and a positive frame rate",
                src.positions.len(),
                src.frames,
                src.names.len(),
                src.fps
            ),
        ));
    }
    let u = up_turn(map, path)?;
    let mut joint: [Option<usize>; NUM_BODIES] = [None; NUM_BODIES];
    for (body, name) in &map.bodies {
        let b = skeleton::body_index(body).ok_or_else(|| {
            err_at(
                path,
                format!(
                    "joint map names \
            body '{body}', which the humanoid does not have (e.g. Pelvis, L_Hip, L_Knee, L_Ankle, \
            Chest, Head, L_Shoulder, L_Elbow, L_Wrist)"
                ),
            )
        })?;
        joint[b] = Some(src.joint(name).ok_or_else(|| {
            err_at(
                path,
                format!(
                    "joint map sends body \
            '{body}' to joint '{name}', which the positions file does not have (it has {})",
                    src.names.join(", ")
                ),
            )
        })?);
    }
    if joint[0].is_none() {
        return Err(err_at(path, "the joint map must map the Pelvis".into()));
    }
    if src.frames < 2 {
        return Err(err_at(path, format!("{} frame(s): at least 2 are needed", src.frames)));
    }
    let o = |f: usize, b: usize| u.rotate(src.at(f, joint[b].expect("mapped")));
    // scale: the humanoid's leg length over the source's median leg length
    let leg = |h: &str, k: &str, a: &str| -> Option<(f64, f64)> {
        let (hb, kb, ab) =
            (skeleton::body_index(h)?, skeleton::body_index(k)?, skeleton::body_index(a)?);
        joint[hb].and(joint[kb]).and(joint[ab])?;
        let mut lengths: Vec<f64> = (0..src.frames)
            .map(|f| norm(sub(o(f, kb), o(f, hb))) + norm(sub(o(f, ab), o(f, kb))))
            .collect();
        lengths.sort_by(f64::total_cmp);
        let s = lengths[lengths.len() / 2];
        (s > 1e-9).then_some((norm(BODIES[kb].offset) + norm(BODIES[ab].offset), s))
    };
    let scale_f = match (leg("L_Hip", "L_Knee", "L_Ankle"), leg("R_Hip", "R_Knee", "R_Ankle")) {
        (Some((t1, s1)), Some((t2, s2))) => (t1 + t2) / (s1 + s2),
        _ => map.scale.ok_or_else(|| {
            err_at(
                path,
                "map both legs (L/R_Hip, _Knee, _Ankle) or give 'scale' (source units to metres)"
                    .into(),
            )
        })?,
    };
    let mapped: [bool; NUM_BODIES] = std::array::from_fn(|b| joint[b].is_some());
    let branch = branches(&mapped);
    let mut ik = crate::limb_ik::Limbs::new(&joint);
    let mut root_p = Vec::with_capacity(src.frames);
    let mut locals = Vec::with_capacity(src.frames);
    // each body's rest vectors towards its branches (skeleton frame), and how its rotation is
    // found: from ≥ 2 spanning branches, from one bone, or inherited
    let rest: Vec<Vec<Vec3>> = (0..NUM_BODIES)
        .map(|b| branch[b].iter().map(|&c| target_chain(b, c).expect("a descendant")).collect())
        .collect();
    let kind: [Kind; NUM_BODIES] = std::array::from_fn(|b| {
        if !mapped[b] || branch[b].is_empty() {
            return Kind::Inherit;
        }
        let unit = |r: Vec3| scale(r, 1.0 / norm(r));
        let spans = rest[b][1..].iter().any(|&r| norm(cross(unit(rest[b][0]), unit(r))) > 0.05);
        if spans { Kind::Spanning } else { Kind::Bone }
    });
    let mut obs: Vec<Vec3> = Vec::new();
    for f in 0..src.frames {
        let mut g = [Quat::IDENTITY; NUM_BODIES];
        for b in 0..NUM_BODIES {
            let parent = BODIES[b].parent.map_or(Quat::IDENTITY, |p| g[p]);
            if kind[b] == Kind::Inherit {
                g[b] = parent;
                continue;
            }
            obs.clear();
            obs.extend(branch[b].iter().map(|&c| sub(o(f, c), o(f, b))));
            g[b] = if kind[b] == Kind::Spanning && obs.iter().all(|v| norm(*v) > 0.0) {
                best_rotation(&rest[b], &obs)
            } else {
                Quat::between(parent.rotate(rest[b][0]), obs[0]).mul(parent).normalized()
            };
        }
        // twists: a bone whose direct child is solved from spanning branches (a forearm above a
        // hand with fingers) turns about itself so that the child's local rotation is smallest;
        // inherited bodies follow
        for b in (0..NUM_BODIES).rev() {
            let c = branch[b].first().copied();
            if let (Kind::Bone, Some(c)) = (kind[b], c)
                && BODIES[c].parent == Some(b)
                && kind[c] == Kind::Spanning
            {
                let axis = sub(o(f, c), o(f, b));
                if norm(axis) > 0.0 {
                    g[b] = least_turn(g[b], g[c], scale(axis, 1.0 / norm(axis)));
                }
            }
        }
        for b in 1..NUM_BODIES {
            if kind[b] == Kind::Inherit {
                g[b] = g[BODIES[b].parent.expect("non-root")];
            }
        }
        let mut root = scale(o(f, 0), scale_f);
        if opts.ik {
            root = ik.solve(&mut g, root, |j| scale(u.rotate(src.at(f, j)), scale_f));
        }
        root_p.push(root);
        locals.push(locals_of(&g));
    }
    finish(path, 1.0 / src.fps, root_p, locals, scale_f, u, &ik, opts)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Horn's fit recovers a known rotation from three exact directions to 1e-12.
    #[test]
    fn best_rotation_recovers_a_rotation() {
        let q = Quat::from_axis_angle([0.3, -0.5, 0.81], 2.4).normalized();
        let rest = [[0.1, -0.3, 0.02], [-0.12, -0.08, 0.0], [0.0, 0.25, -0.03]];
        let obs: Vec<Vec3> = rest.iter().map(|&r| scale(q.rotate(r), 1.7)).collect();
        let fit = best_rotation(&rest, &obs);
        assert!(fit.dot(q).abs() > 1.0 - 1e-12, "{fit:?} vs {q:?}");
        // a half turn (eigenvalues tie-free but far from the identity)
        let q = Quat::from_axis_angle([0.0, 0.0, 1.0], std::f64::consts::PI);
        let obs: Vec<Vec3> = rest.iter().map(|&r| q.rotate(r)).collect();
        assert!(best_rotation(&rest, &obs).dot(q).abs() > 1.0 - 1e-12);
    }
}
