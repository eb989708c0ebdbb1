//! Retargeting a BVH motion onto the SkillMimic humanoid (issue 23, first version: body motion).
//!
//! Frames: the humanoid's skeleton is Y-up with no rest rotations (T-pose, facing +z, left = +x;
//! [`skillmimic_core::characters::skillmimic`]); clips put the Y-up → Z-up turn `T` = Rx(+90°) into the root
//! rotation. Retargeting works in the skeleton's Y-up frame and applies `T` at the end.
//!
//! Method, per source frame:
//! 1. Source global rotations `R_s(j)` from the BVH ([`crate::bvh`]), turned into the Y-up frame:
//!    `R'_s = U · R_s · U⁻¹`, with `U` the map's up-axis conversion and yaw.
//! 2. Rest alignment of each mapped bone: `D(b)` is the smallest rotation taking the humanoid's
//!    rest direction of bone b (towards its next mapped body, or its first child for a leaf) onto
//!    the source's rest direction of the mapped joint (BVH rest = all channels zero). The pelvis
//!    keeps `D = I` (both skeletons face +z with the left side at +x; a map's `yaw_deg` fixes
//!    sources that face elsewhere).
//! 3. Global rotations `G(b) = R'_s(j) · D(b)`; an unmapped body (fingers, Spine2, toes …) keeps
//!    the rest pose relative to its parent, `G(b) = G(parent)`.
//! 4. Local rotations `G(parent)⁻¹ · G(b)` as rotation vectors; root rotation `T · G(pelvis)`.
//! 5. Root position: the source root joint's position × `scale` (source units → humanoid size:
//!    the leg-length ratio when both legs' hip, knee and ankle are mapped, else the map's `scale`),
//!    turned by `U` and `T`.
//! 6. Resampling to the output rate (linear positions, slerp rotations) and, optionally, ground
//!    alignment: the 10th percentile over frames of the lowest sole point goes to z = 0 (sole =
//!    ankle frame − 0.1164 m or toe frame − 0.02 m, the foot boxes' bottoms in the rest pose).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};
use skillmimic_core::characters::skillmimic::{self as skeleton, BODIES, NUM_BODIES, NUM_JOINTS};
use skillmimic_core::math::{Quat, Vec3, add, norm, scale};

use crate::bvh::Bvh;
use crate::error::ClipError;

/// A joint map: humanoid body name → source joint name, plus the source's conventions.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct JointMap {
    /// Up axis of the source: "y" (the BVH convention) or "z".
    #[serde(default = "default_up")]
    pub up: String,
    /// Turn of the source about its up axis (degrees) so that it faces +z with its left at +x.
    #[serde(default)]
    pub yaw_deg: f64,
    /// Source units → metres when the legs are not mapped (e.g. 0.01 for centimetres).
    #[serde(default)]
    pub scale: Option<f64>,
    /// Humanoid body → source joint.
    pub bodies: BTreeMap<String, String>,
}

fn default_up() -> String {
    "y".into()
}

/// The joint maps shipped with the project (`crates/skillmimic-motion/maps/`), by name.
pub const BUILTIN_MAPS: [(&str, &str); 4] = [
    ("humanoid", include_str!("../maps/humanoid.toml")),
    ("mocapbank", include_str!("../maps/mocapbank.toml")),
    ("cmu", include_str!("../maps/cmu.toml")),
    ("smplh", include_str!("../maps/smplh.toml")),
];

impl JointMap {
    /// A shipped map by name, or a TOML file (errors name the file and the field).
    pub fn load(name_or_path: &str) -> Result<Self, ClipError> {
        let path = std::path::Path::new(name_or_path);
        let (text, path) = match BUILTIN_MAPS.iter().find(|(n, _)| *n == name_or_path) {
            Some((_, t)) => (t.to_string(), path.to_path_buf()),
            None => {
                if !path.is_file() {
                    let names: Vec<&str> = BUILTIN_MAPS.iter().map(|m| m.0).collect();
                    return Err(ClipError::Format {
                        path: path.to_path_buf(),
                        detail: format!(
                            "joint map: neither a shipped map ({}) nor a TOML file",
                            names.join(", ")
                        ),
                    });
                }
                let t = std::fs::read_to_string(path)
                    .map_err(|error| ClipError::Io { path: path.to_path_buf(), error })?;
                (t, path.to_path_buf())
            }
        };
        toml::from_str(&text).map_err(|e| ClipError::Format {
            path,
            detail: format!(
                "joint map: {e} \
            (expected `up`, `yaw_deg`, `scale` and a [bodies] table of humanoid body = source \
            joint; shipped maps: humanoid, mocapbank, cmu, smplh)"
            ),
        })
    }
}

/// Most output frames of one retargeting run (4.6 hours at 60 fps).
pub const MAX_OUTPUT_FRAMES: usize = 1_000_000;

/// Options of one retargeting run.
#[derive(Clone, Debug)]
pub struct Options {
    /// Output frame rate (the clips' 60 fps).
    pub fps: f64,
    /// Move the feet onto the floor (step 6).
    pub ground: bool,
    /// Light IK ([`crate::limb_ik`]): put the hips' midpoint on the source's and bend the legs
    /// and arms so that the ankles and wrists reach the source's ankle and wrist positions × scale
    /// (kills the foot sliding and the hand–ball misses that different proportions cause). Off by
    /// default: rotations only.
    pub ik: bool,
}

impl Default for Options {
    fn default() -> Self {
        Self { fps: 60.0, ground: true, ik: false }
    }
}

/// The retargeted body motion at the output rate (world frame, Z-up, metres).
#[derive(Clone, Debug)]
pub struct Motion {
    pub fps: f64,
    pub frames: usize,
    /// `(T, 3)` root position.
    pub root_pos: Vec<Vec3>,
    /// `(T)` root rotation (w, x, y, z).
    pub root_rot: Vec<Quat>,
    /// `(T, 52)` joint rotation vectors in skeleton order.
    pub dof_rot: Vec<[Vec3; NUM_JOINTS]>,
    /// Source units → metres factor used.
    pub scale: f64,
    /// Height added to the root by the ground alignment (m).
    pub ground_shift: f64,
    /// Turn from the source's axes to the world (Z-up): `T · U`.
    pub source_turn: Quat,
    /// With [`Options::ik`]: the distances left between the ankles / wrists and their targets.
    pub ik: crate::limb_ik::IkResiduals,
}

impl Motion {
    /// A point in the source's axes and units (a marker, a ball) in the world frame, before the
    /// ground shift (the transform the root position takes).
    pub fn source_to_world(&self, p: Vec3) -> Vec3 {
        self.source_turn.rotate(scale(p, self.scale))
    }
}

fn err(bvh: &Bvh, what: String) -> ClipError {
    err_at(&bvh.path, what)
}

pub(crate) fn err_at(path: &std::path::Path, what: String) -> ClipError {
    ClipError::Format { path: path.to_path_buf(), detail: format!("retargeting: {what}") }
}

/// The up-axis and yaw conversion `U` of a map (source axes → the skeleton's Y-up frame).
pub(crate) fn up_turn(map: &JointMap, path: &std::path::Path) -> Result<Quat, ClipError> {
    let u = match map.up.as_str() {
        "y" => Quat::IDENTITY,
        "z" => Quat::from_axis_angle([1.0, 0.0, 0.0], -std::f64::consts::FRAC_PI_2),
        other => {
            return Err(err_at(
                path,
                format!("joint map 'up' must be \"y\" or \"z\", found \"{other}\""),
            ));
        }
    };
    Ok(Quat::from_axis_angle([0.0, 1.0, 0.0], map.yaw_deg.to_radians()).mul(u))
}

/// The Y-up → Z-up turn `T` = Rx(+90°) the clips' root rotations contain.
pub(crate) fn tilt() -> Quat {
    Quat::from_axis_angle([1.0, 0.0, 0.0], std::f64::consts::FRAC_PI_2)
}

/// Local rotations from global ones (Y-up skeleton frame): `G(parent)⁻¹ · G(b)`, and `T ·
/// G(pelvis)` for the root.
pub(crate) fn locals_of(g: &[Quat; NUM_BODIES]) -> [Quat; NUM_BODIES] {
    std::array::from_fn(|b| match BODIES[b].parent {
        Some(p) => g[p].conj().mul(g[b]).normalized(),
        None => tilt().mul(g[b]).normalized(),
    })
}

/// Rest vector of the source from joint `j` down to its descendant `d` (file frame).
fn source_chain(bvh: &Bvh, j: usize, d: usize) -> Option<Vec3> {
    let mut v = [0.0; 3];
    let mut k = d;
    while k != j {
        v = add(v, bvh.joints[k].offset);
        k = bvh.joints[k].parent?;
    }
    Some(v)
}

/// Rest vector of the humanoid from body `b` down to its descendant `d` (skeleton frame).
pub(crate) fn target_chain(b: usize, d: usize) -> Option<Vec3> {
    let mut v = [0.0; 3];
    let mut k = d;
    while k != b {
        v = add(v, BODIES[k].offset);
        k = BODIES[k].parent?;
    }
    Some(v)
}

/// Retarget `bvh` with `map` (see the module docs).
pub fn retarget(bvh: &Bvh, map: &JointMap, opts: &Options) -> Result<Motion, ClipError> {
    let u = up_turn(map, &bvh.path)?;
    // body → source joint
    let mut src: [Option<usize>; NUM_BODIES] = [None; NUM_BODIES];
    for (body, joint) in &map.bodies {
        let b = skeleton::body_index(body).ok_or_else(|| {
            err(
                bvh,
                format!(
                    "joint map names body \
            '{body}', which the humanoid does not have (e.g. Pelvis, L_Hip, L_Knee, L_Ankle, \
            Chest, Head, L_Shoulder, L_Elbow, L_Wrist)"
                ),
            )
        })?;
        let j = bvh.joint(joint).ok_or_else(|| {
            err(
                bvh,
                format!(
                    "joint map sends body '{body}' to \
            joint '{joint}', which the BVH file does not have"
                ),
            )
        })?;
        src[b] = Some(j);
    }
    let Some(root_joint) = src[0] else {
        return Err(err(bvh, "the joint map must map the Pelvis".into()));
    };
    if bvh.frames < 2 {
        return Err(err(bvh, format!("{} frame(s): at least 2 are needed", bvh.frames)));
    }
    // rest alignment D(b)
    let is_desc = |j: usize, d: usize| -> bool {
        let mut k = Some(d);
        while let Some(x) = k {
            if x == j {
                return true;
            }
            k = bvh.joints[x].parent;
        }
        false
    };
    let mut align = [Quat::IDENTITY; NUM_BODIES];
    for b in 1..NUM_BODIES {
        let Some(j) = src[b] else { continue };
        // the next mapped body down the humanoid's chain whose source joint lies below j
        let next = (b + 1..NUM_BODIES).find(|&c| {
            src[c].is_some_and(|sc| sc != j && is_desc(j, sc)) && target_chain(b, c).is_some()
        });
        let (dt, ds) = match next {
            Some(c) => {
                (target_chain(b, c).unwrap(), source_chain(bvh, j, src[c].unwrap()).unwrap())
            }
            None => {
                let child = (b + 1..NUM_BODIES).find(|&c| BODIES[c].parent == Some(b));
                match (child, bvh.joints[j].end_site) {
                    (Some(c), Some(e)) => (BODIES[c].offset, e),
                    _ => continue,
                }
            }
        };
        align[b] = Quat::between(dt, u.rotate(ds));
    }
    // scale: leg lengths (hip → knee → ankle) of both skeletons, else the map's factor
    let leg = |h: &str, k: &str, a: &str| -> Option<(f64, f64)> {
        let (hb, kb, ab) =
            (skeleton::body_index(h)?, skeleton::body_index(k)?, skeleton::body_index(a)?);
        let (hj, kj, aj) = (src[hb]?, src[kb]?, src[ab]?);
        let t = norm(BODIES[kb].offset) + norm(BODIES[ab].offset);
        let s = norm(source_chain(bvh, hj, kj)?) + norm(source_chain(bvh, kj, aj)?);
        (s > 1e-9).then_some((t, s))
    };
    let scale_f = match (leg("L_Hip", "L_Knee", "L_Ankle"), leg("R_Hip", "R_Knee", "R_Ankle")) {
        (Some((t1, s1)), Some((t2, s2))) => (t1 + t2) / (s1 + s2),
        _ => map.scale.ok_or_else(|| {
            err(
                bvh,
                "map both legs (L/R_Hip, _Knee, _Ankle) or give 'scale' (source units to metres)"
                    .into(),
            )
        })?,
    };
    // per source frame: root position (Y-up frame, metres), global rotations → locals
    let mut root_p = Vec::with_capacity(bvh.frames);
    let mut locals: Vec<[Quat; NUM_BODIES]> = Vec::with_capacity(bvh.frames);
    let mut ik = crate::limb_ik::Limbs::new(&src);
    for f in 0..bvh.frames {
        let pose = bvh.pose(f);
        let mut g = [Quat::IDENTITY; NUM_BODIES];
        for b in 0..NUM_BODIES {
            g[b] = match (src[b], BODIES[b].parent) {
                (Some(j), _) => u.mul(pose.rotations[j]).mul(u.conj()).mul(align[b]).normalized(),
                (None, Some(p)) => g[p],
                (None, None) => unreachable!("the pelvis is mapped"),
            };
        }
        let mut root = scale(u.rotate(pose.positions[root_joint]), scale_f);
        if opts.ik {
            root = ik.solve(&mut g, root, |j| scale(u.rotate(pose.positions[j]), scale_f));
        }
        root_p.push(root);
        locals.push(locals_of(&g));
    }
    finish(&bvh.path, bvh.frame_time, root_p, locals, scale_f, u, &ik, opts)
}

/// The shared tail of every retargeting path: resampling of the per-source-frame root positions
/// (Y-up skeleton frame, metres) and local rotations to `opts.fps`, the finiteness check and the
/// ground alignment (module docs, steps 5–6).
#[allow(clippy::too_many_arguments)]
pub(crate) fn finish(
    path: &std::path::Path,
    frame_time: f64,
    root_p: Vec<Vec3>,
    locals: Vec<[Quat; NUM_BODIES]>,
    scale_f: f64,
    u: Quat,
    ik: &crate::limb_ik::Limbs,
    opts: &Options,
) -> Result<Motion, ClipError> {
    let n = locals.len();
    let tilt = tilt();
    let duration = (n - 1) as f64 * frame_time;
    // (a 1e-6-frame allowance: 245 frames at 1/60 s make 244.99999… frames of 1/60 s in floats)
    let out_frames = (duration * opts.fps + 1e-6).floor() + 1.0;
    if !(out_frames.is_finite() && out_frames <= MAX_OUTPUT_FRAMES as f64) {
        return Err(err_at(
            path,
            format!(
                "{n} frames of {frame_time} s last {duration} s: more than {MAX_OUTPUT_FRAMES} \
                    output frames at {} fps",
                opts.fps
            ),
        ));
    }
    let frames = out_frames as usize;
    let mut m = Motion {
        fps: opts.fps,
        frames,
        root_pos: Vec::with_capacity(frames),
        root_rot: Vec::with_capacity(frames),
        dof_rot: Vec::with_capacity(frames),
        scale: scale_f,
        ground_shift: 0.0,
        source_turn: tilt.mul(u),
        ik: ik.residuals(),
    };
    let mut prev_root = Quat::IDENTITY;
    for k in 0..frames {
        let x = (k as f64 / opts.fps / frame_time).min((n - 1) as f64);
        let (i, t) = (x.floor() as usize, x - x.floor());
        let i1 = (i + 1).min(n - 1);
        let p = add(scale(root_p[i], 1.0 - t), scale(root_p[i1], t));
        m.root_pos.push(tilt.rotate(p));
        let mut r = locals[i][0].slerp(locals[i1][0], t);
        if k > 0 && r.dot(prev_root) < 0.0 {
            r = r.neg(); // sign-continuous, as clips are
        }
        prev_root = r;
        m.root_rot.push(r);
        m.dof_rot.push(std::array::from_fn(|jt| {
            locals[i][jt + 1].slerp(locals[i1][jt + 1], t).to_rotvec()
        }));
    }
    let finite = m
        .root_pos
        .iter()
        .flatten()
        .chain(m.dof_rot.iter().flatten().flatten())
        .all(|x| x.is_finite())
        && m.root_rot
            .iter()
            .all(|q| q.w.is_finite() && q.x.is_finite() && q.y.is_finite() && q.z.is_finite());
    if !finite {
        return Err(err_at(
            path,
            "the retargeted motion has non-finite values (offsets, positions \
            or channel values too large?)"
                .into(),
        ));
    }
    if opts.ground {
        let mut soles: Vec<f64> = (0..frames).map(|k| lowest_sole(&m, k)).collect();
        soles.sort_by(f64::total_cmp);
        let shift = -soles[(frames - 1) / 10];
        for p in m.root_pos.iter_mut() {
            p[2] += shift;
        }
        m.ground_shift = shift;
    }
    Ok(m)
}

/// The 156 joint rotation-vector components of frame `k` (skeleton order).
pub fn dof_row(m: &Motion, k: usize) -> Vec<f32> {
    m.dof_rot[k].iter().flat_map(|v| v.iter().map(|&x| x as f32)).collect()
}

/// World positions of the 53 bodies at frame `k`.
pub fn body_positions(m: &Motion, k: usize) -> [Vec3; NUM_BODIES] {
    skeleton::forward_kinematics(m.root_pos[k], m.root_rot[k], &dof_row(m, k))
}

/// Feet of the sole rule: (body, height of its sole below the body frame in the rest pose, m):
/// the ankle and toe boxes' bottoms.
const SOLES: [(&str, f64); 4] =
    [("L_Ankle", 0.1164), ("R_Ankle", 0.1164), ("L_Toe", 0.02), ("R_Toe", 0.02)];

/// The lowest sole point (m) of a frame's body positions, and the foot body it belongs to.
pub fn lowest_sole_of(p: &[Vec3; NUM_BODIES]) -> (f64, usize) {
    SOLES
        .iter()
        .map(|&(name, below)| {
            let b = skeleton::body_index(name).expect("foot bodies");
            (p[b][2] - below, b)
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .expect("four feet")
}

/// Lowest sole point (m) of frame `k` ([`lowest_sole_of`]).
pub fn lowest_sole(m: &Motion, k: usize) -> f64 {
    lowest_sole_of(&body_positions(m, k)).0
}

/// Joint speeds in one pass: the largest (rad/s) with its frame and joint, how many frames have
/// some joint faster than `spike` rad/s, and each frame's fastest joint speed (frame 0: 0).
pub fn joint_speeds(m: &Motion, spike: f64) -> ((f64, usize, usize), usize, Vec<f64>) {
    let mut worst = (0.0, 0, 0);
    let mut per_frame = vec![0.0; m.frames];
    for k in 1..m.frames {
        for j in 0..NUM_JOINTS {
            let (a, b) =
                (Quat::from_rotvec(m.dof_rot[k - 1][j]), Quat::from_rotvec(m.dof_rot[k][j]));
            let w = a.conj().mul(b).angle() * m.fps;
            per_frame[k] = f64::max(per_frame[k], w);
            if w > worst.0 {
                worst = (w, k, j);
            }
        }
    }
    let spikes = per_frame.iter().filter(|&&w| w > spike).count();
    (worst, spikes, per_frame)
}

/// Largest joint speed (rad/s) between consecutive output frames, and where ([`joint_speeds`]).
pub fn max_joint_speed(m: &Motion) -> (f64, usize, usize) {
    joint_speeds(m, f64::INFINITY).0
}
