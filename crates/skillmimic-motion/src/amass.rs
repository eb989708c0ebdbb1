//! SMPL-family parameter sequences in the AMASS `.npz` layout (issue 23), turned into a source
//! skeleton motion that [`crate::retarget_bvh`] retargets like a BVH file.
//!
//! Read arrays (`numpy.savez` archive: a zip of `.npy` files, float32 or float64, C order):
//! * `poses` (T, 3·J): per-joint axis-angle (radians) in SMPL-H joint order, J = 52 (SMPL-H) or
//!   55 (SMPL-X: jaw and eyes are dropped, the hands follow at 25…54) or 24 (SMPL: no fingers;
//!   joints 22 and 23 are the hands, dropped);
//! * `trans` (T, 3): root translation (metres, Z-up world, as AMASS stores it);
//! * `mocap_framerate` or `mocap_frame_rate` (scalar): frames per second.
//!
//! Skeleton: the SMPL-H kinematic tree with joint names `pelvis`, `left_hip`, …, `right_thumb3`.
//! Its rest joint positions ([`Rest`]) are, by default, SMPL's neutral mean shape (β = 0) given as
//! numbers here ([`SMPL_NEUTRAL_OFFSETS`]; the fingers, which SMPL lacks, from the humanoid's
//! rest hand attached at each wrist), with the pelvis at `trans + J_pelvis` as SMPL places it. A
//! user's body model file gives the exact rest joints and pelvis for the sequence's `betas`
//! ([`model_joints`]). `Rest::Humanoid` reads the sequence on the SkillMimic humanoid's own rest
//! skeleton instead (its 52 joints correspond one to one with SMPL-H's; SMPL-H `spine3` sits where
//! the humanoid's Chest is): every joint rotation then transfers unchanged (identity rest
//! alignment) and the pelvis is placed at `trans`.
//!
//! Frames: AMASS's `root_orient` (joint 0) and `trans` live in a Z-up world while the body's rest
//! frame is Y-up, exactly like BallPlay-M's root. The sequence is therefore expressed in the
//! Y-up frame (root rotation and translation turned by Rx(−90°)) and retargeted with `up = "y"`;
//! the humanoid's root comes out as AMASS's.

use std::io::Read;
use std::path::Path;

use skillmimic_core::characters::skillmimic as skeleton;
use skillmimic_core::math::{Quat, Vec3};

use crate::bvh::{Bvh, BvhJoint, Channel};
use crate::error::ClipError;

/// One `.npy` array: its shape and values.
type Array = (Vec<usize>, Vec<f64>);

/// Most frames a sequence may hold.
pub const MAX_FRAMES: usize = 1_000_000;

/// SMPL-H joints: (name, parent index, humanoid body whose rest skeleton supplies the position).
pub const SMPLH_JOINTS: [(&str, Option<usize>, &str); 52] = [
    ("pelvis", None, "Pelvis"),
    ("left_hip", Some(0), "L_Hip"),
    ("right_hip", Some(0), "R_Hip"),
    ("spine1", Some(0), "Torso"),
    ("left_knee", Some(1), "L_Knee"),
    ("right_knee", Some(2), "R_Knee"),
    ("spine2", Some(3), "Spine"),
    ("left_ankle", Some(4), "L_Ankle"),
    ("right_ankle", Some(5), "R_Ankle"),
    ("spine3", Some(6), "Chest"),
    ("left_foot", Some(7), "L_Toe"),
    ("right_foot", Some(8), "R_Toe"),
    ("neck", Some(9), "Neck"),
    ("left_collar", Some(9), "L_Thorax"),
    ("right_collar", Some(9), "R_Thorax"),
    ("head", Some(12), "Head"),
    ("left_shoulder", Some(13), "L_Shoulder"),
    ("right_shoulder", Some(14), "R_Shoulder"),
    ("left_elbow", Some(16), "L_Elbow"),
    ("right_elbow", Some(17), "R_Elbow"),
    ("left_wrist", Some(18), "L_Wrist"),
    ("right_wrist", Some(19), "R_Wrist"),
    ("left_index1", Some(20), "L_Index1"),
    ("left_index2", Some(22), "L_Index2"),
    ("left_index3", Some(23), "L_Index3"),
    ("left_middle1", Some(20), "L_Middle1"),
    ("left_middle2", Some(25), "L_Middle2"),
    ("left_middle3", Some(26), "L_Middle3"),
    ("left_pinky1", Some(20), "L_Pinky1"),
    ("left_pinky2", Some(28), "L_Pinky2"),
    ("left_pinky3", Some(29), "L_Pinky3"),
    ("left_ring1", Some(20), "L_Ring1"),
    ("left_ring2", Some(31), "L_Ring2"),
    ("left_ring3", Some(32), "L_Ring3"),
    ("left_thumb1", Some(20), "L_Thumb1"),
    ("left_thumb2", Some(34), "L_Thumb2"),
    ("left_thumb3", Some(35), "L_Thumb3"),
    ("right_index1", Some(21), "R_Index1"),
    ("right_index2", Some(37), "R_Index2"),
    ("right_index3", Some(38), "R_Index3"),
    ("right_middle1", Some(21), "R_Middle1"),
    ("right_middle2", Some(40), "R_Middle2"),
    ("right_middle3", Some(41), "R_Middle3"),
    ("right_pinky1", Some(21), "R_Pinky1"),
    ("right_pinky2", Some(43), "R_Pinky2"),
    ("right_pinky3", Some(44), "R_Pinky3"),
    ("right_ring1", Some(21), "R_Ring1"),
    ("right_ring2", Some(46), "R_Ring2"),
    ("right_ring3", Some(47), "R_Ring3"),
    ("right_thumb1", Some(21), "R_Thumb1"),
    ("right_thumb2", Some(49), "R_Thumb2"),
    ("right_thumb3", Some(50), "R_Thumb3"),
];

fn fmt_err(path: &Path, detail: String) -> ClipError {
    ClipError::Format { path: path.to_path_buf(), detail: format!("AMASS npz: {detail}") }
}

/// One `.npy` array: shape and values as f64.
fn parse_npy(path: &Path, name: &str, bytes: &[u8]) -> Result<Array, ClipError> {
    let e = |d: String| fmt_err(path, format!("array '{name}': {d}"));
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err(e("not a .npy array (no \\x93NUMPY magic)".into()));
    }
    let (hlen, start) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        2 | 3 if bytes.len() >= 12 => {
            (u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize, 12)
        }
        v => return Err(e(format!("unsupported .npy version {v}"))),
    };
    let header =
        bytes.get(start..start + hlen).ok_or_else(|| e("header longer than the file".into()))?;
    let header = std::str::from_utf8(header).map_err(|_| e("header is not text".into()))?;
    let field = |key: &str| -> Option<&str> {
        let i = header.find(&format!("'{key}'"))? + key.len() + 2;
        Some(header[i..].trim_start().trim_start_matches(':').trim_start())
    };
    let descr = field("descr")
        .and_then(|s| s.strip_prefix('\''))
        .and_then(|s| s.split('\'').next())
        .ok_or_else(|| e("no 'descr' in the header".into()))?;
    let width = match descr {
        "<f4" => 4,
        "<f8" => 8,
        other => {
            return Err(e(format!(
                "dtype '{other}', expected little-endian float32 '<f4' or float64 '<f8'"
            )));
        }
    };
    if field("fortran_order").is_some_and(|s| s.starts_with("True")) {
        return Err(e("Fortran order is not supported (save C-ordered arrays)".into()));
    }
    let shape_txt = field("shape")
        .and_then(|s| s.strip_prefix('('))
        .and_then(|s| s.split(')').next())
        .ok_or_else(|| e("no 'shape' in the header".into()))?;
    let shape: Vec<usize> = shape_txt
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<usize>())
        .collect::<Result<_, _>>()
        .map_err(|_| e(format!("shape ({shape_txt}) is not a tuple of whole numbers")))?;
    let n = shape
        .iter()
        .try_fold(1usize, |a, &d| a.checked_mul(d))
        .filter(|&n| n <= 3 * 165 * MAX_FRAMES)
        .ok_or_else(|| e(format!("shape {shape:?} is too large")))?;
    let data = &bytes[start + hlen..];
    if data.len() != n * width {
        return Err(e(format!(
            "{} data bytes, expected {} for shape {shape:?} of {descr}",
            data.len(),
            n * width
        )));
    }
    let values: Vec<f64> = if width == 4 {
        data.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f64).collect()
    } else {
        data.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes"))).collect()
    };
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(e(format!("non-finite value {} at flat index {i}", values[i])));
    }
    Ok((shape, values))
}

/// Largest single array read from an archive (bytes): a 1 M-frame SMPL-X `poses` in float64.
const MAX_ARRAY_BYTES: u64 = 8 * 165 * MAX_FRAMES as u64;

/// The named arrays of a `numpy.savez` archive that exist in it (others are never read).
fn read_arrays(path: &Path, names: &[&str]) -> Result<Vec<Option<Array>>, ClipError> {
    let file = std::fs::File::open(path)
        .map_err(|error| ClipError::Io { path: path.to_path_buf(), error })?;
    let mut zip = zip::ZipArchive::new(file).map_err(|e| {
        fmt_err(path, format!("not a zip archive ({e}); expected numpy.savez output"))
    })?;
    names
        .iter()
        .map(|name| {
            let Ok(mut f) = zip.by_name(&format!("{name}.npy")) else { return Ok(None) };
            if f.size() > MAX_ARRAY_BYTES {
                return Err(fmt_err(
                    path,
                    format!("array '{name}' of {} bytes is too large", f.size()),
                ));
            }
            let mut bytes = Vec::with_capacity(f.size() as usize);
            f.read_to_end(&mut bytes).map_err(|e| fmt_err(path, format!("array '{name}': {e}")))?;
            parse_npy(path, name, &bytes).map(Some)
        })
        .collect()
}

/// Rest joint positions (model frame, Y-up, metres) of the SMPL-H joints from a body model file
/// (`v_template` (V, 3), `J_regressor` (J, V) with J = 52 (SMPL-H) or 24 (SMPL: the hands then
/// come from the humanoid's rest skeleton, attached at the wrists), optional `shapedirs`
/// (V, 3, B)) for the shape `betas`: J = J_regressor · (v_template + shapedirs · β). The project
/// never ships such a file (SMPL's licence); users point `--body-model` at theirs.
pub fn model_joints(model: &Path, betas: &[f64]) -> Result<Vec<Vec3>, ClipError> {
    let e = |d: String| fmt_err(model, format!("body model: {d}"));
    let mut a = read_arrays(model, &["v_template", "J_regressor", "shapedirs"])?.into_iter();
    let (vs, v) = a.next().flatten().ok_or_else(|| e("no 'v_template' array (V, 3)".into()))?;
    let (rs, r) =
        a.next().flatten().ok_or_else(|| e("no dense 'J_regressor' array (J, V)".into()))?;
    let shape = a.next().flatten();
    let nv = match vs[..] {
        [n, 3] => n,
        _ => return Err(e(format!("'v_template' has shape {vs:?}, expected (V, 3)"))),
    };
    let nj = match rs[..] {
        [j, n] if n == nv && (j == 52 || j == 24) => j,
        _ => {
            return Err(e(format!(
                "'J_regressor' has shape {rs:?}, expected (52, {nv}) for SMPL-H or (24, {nv}) for \
                    SMPL"
            )));
        }
    };
    let mut verts = v;
    if let Some((ss, sd)) = shape {
        let nb = match ss[..] {
            [n, 3, b] if n == nv => b,
            _ => return Err(e(format!("'shapedirs' has shape {ss:?}, expected ({nv}, 3, B)"))),
        };
        for (k, &beta) in betas.iter().take(nb).enumerate() {
            for (i, x) in verts.iter_mut().enumerate() {
                *x += sd[i * nb + k] * beta;
            }
        }
    }
    let mut joints: Vec<Vec3> = (0..nj)
        .map(|j| std::array::from_fn(|c| (0..nv).map(|i| r[j * nv + i] * verts[3 * i + c]).sum()))
        .collect();
    if nj == 24 {
        // SMPL: fingers from the humanoid's rest skeleton, relative to each wrist
        joints.truncate(22);
        attach_humanoid_hands(&mut joints);
    }
    Ok(joints)
}

/// SMPL's neutral mean-shape (β = 0) skeleton for the 22 body joints of [`SMPLH_JOINTS`]: each
/// joint's offset from its parent (metres, SMPL's model frame: Y-up, facing +z, left = +x, the
/// humanoid skeleton's frame too); for the pelvis, its rest position `J_pelvis`. Numbers of the
/// SMPL neutral model's joint regressor applied to its template, to 0.1 mm, as SMPL-based humanoids
/// (PHC / ProtoMotions `smpl_humanoid.xml`, TokenHSI's lower body) carry them (their Z-up x-forward
/// frame turned into SMPL's: (x, y, z) → (y, z, x)).
pub const SMPL_NEUTRAL_OFFSETS: [Vec3; 22] = [
    [-0.0018, -0.2233, 0.0282],  // pelvis (J_pelvis, absolute)
    [0.0695, -0.0914, -0.0068],  // left_hip
    [-0.0677, -0.0905, -0.0043], // right_hip
    [-0.0025, 0.1090, -0.0267],  // spine1
    [0.0343, -0.3752, -0.0045],  // left_knee
    [-0.0383, -0.3826, -0.0089], // right_knee
    [0.0055, 0.1352, 0.0011],    // spine2
    [-0.0136, -0.3980, -0.0437], // left_ankle
    [0.0158, -0.3984, -0.0423],  // right_ankle
    [0.0015, 0.0529, 0.0254],    // spine3
    [0.0264, -0.0558, 0.1193],   // left_foot
    [-0.0254, -0.0481, 0.1233],  // right_foot
    [-0.0028, 0.2139, -0.0429],  // neck
    [0.0788, 0.1217, -0.0341],   // left_collar
    [-0.0818, 0.1188, -0.0386],  // right_collar
    [0.0052, 0.0650, 0.0513],    // head
    [0.0910, 0.0305, -0.0089],   // left_shoulder
    [-0.0960, 0.0326, -0.0091],  // right_shoulder
    [0.2596, -0.0128, -0.0275],  // left_elbow
    [-0.2537, -0.0133, -0.0214], // right_elbow
    [0.2492, 0.0090, -0.0012],   // left_wrist
    [-0.2553, 0.0078, -0.0056],  // right_wrist
];

/// The rest skeleton an AMASS sequence is read on (module docs).
#[derive(Clone, Copy, Debug)]
pub enum Rest<'a> {
    /// SMPL's neutral mean shape ([`SMPL_NEUTRAL_OFFSETS`]), pelvis at `trans + J_pelvis`.
    SmplNeutral,
    /// The humanoid's own rest skeleton, pelvis at `trans` (rotations transfer unchanged).
    Humanoid,
    /// A user's SMPL-H / SMPL body model file for the sequence's `betas` ([`model_joints`]).
    BodyModel(&'a Path),
}

/// Rest positions (Y-up, metres) of the 52 SMPL-H joints for SMPL's neutral mean shape; the
/// fingers from the humanoid's rest hands.
pub fn smpl_neutral_joints() -> Vec<Vec3> {
    let mut joints: Vec<Vec3> = Vec::with_capacity(52);
    for (j, (_, parent, _)) in SMPLH_JOINTS.iter().enumerate().take(22) {
        let o = SMPL_NEUTRAL_OFFSETS[j];
        joints.push(parent.map_or(o, |p| skillmimic_core::math::add(joints[p], o)));
    }
    attach_humanoid_hands(&mut joints);
    joints
}

/// Append the 30 finger joints (SMPL-H 22…51) of the humanoid's rest hands to 22 body joints, each
/// hand placed by its offsets from the wrist.
fn attach_humanoid_hands(joints: &mut Vec<Vec3>) {
    let humanoid = humanoid_rest();
    for (j, (name, _, _)) in SMPLH_JOINTS.iter().enumerate().skip(22) {
        let wrist = if name.starts_with("left") { 20 } else { 21 };
        let off = skillmimic_core::math::sub(humanoid[j], humanoid[wrist]);
        joints.push(skillmimic_core::math::add(joints[wrist], off));
    }
}

/// Rest positions of the SMPL-H joints on the humanoid's own rest skeleton (Y-up, metres): the
/// skeleton's forward kinematics with the root at the origin and every joint at zero.
fn humanoid_rest() -> Vec<Vec3> {
    let rest = skeleton::forward_kinematics([0.0; 3], Quat::IDENTITY, &[0.0; skeleton::NUM_DOFS]);
    SMPLH_JOINTS.iter().map(|j| rest[skeleton::body_index(j.2).expect("humanoid body")]).collect()
}

/// Read an AMASS-layout `.npz` sequence as a source skeleton motion ([`Bvh`] with ZXY channels;
/// see the module docs for frames) on SMPL's neutral mean-shape skeleton.
pub fn read(path: &Path) -> Result<Bvh, ClipError> {
    read_with_rest(path, Rest::SmplNeutral)
}

/// An AMASS-layout sequence as stored (validated: shapes, frame count, frame rate, finite values).
#[derive(Clone, Debug)]
pub struct Sequence {
    /// Frames T.
    pub frames: usize,
    /// Frames per second (`mocap_framerate` / `mocap_frame_rate`), in (0, 1000].
    pub fps: f64,
    /// Columns of a `poses` row: 72 (SMPL), 156 (SMPL-H) or 165 (SMPL-X).
    pub width: usize,
    /// `(T, width)` per-joint axis-angles (rad).
    pub poses: Vec<f64>,
    /// `(T, 3)` root translations (m, AMASS's Z-up world).
    pub trans: Vec<f64>,
    /// Shape coefficients (empty when the file has none).
    pub betas: Vec<f64>,
}

impl Sequence {
    /// Read and validate `poses`, `trans`, the frame rate and `betas` of an AMASS `.npz`; errors
    /// name the file, the array and the expected shape or range.
    pub fn read(path: &Path) -> Result<Self, ClipError> {
        let [poses, trans, fps_a, fps_b, betas]: [Option<Array>; 5] =
            read_arrays(path, &["poses", "trans", "mocap_framerate", "mocap_frame_rate", "betas"])?
                .try_into()
                .expect("five names");
        let (pshape, poses) = poses.ok_or_else(|| {
            fmt_err(path, "no 'poses' array (T, 156) of per-joint axis-angles".into())
        })?;
        let (tshape, trans) = trans
            .ok_or_else(|| fmt_err(path, "no 'trans' array (T, 3) of root translations".into()))?;
        let betas = betas.map(|b| b.1).unwrap_or_default();
        let fps = fps_a.or(fps_b).ok_or_else(|| {
            fmt_err(path, "no 'mocap_framerate' (or 'mocap_frame_rate') scalar".into())
        })?;
        let fps = *fps.1.first().ok_or_else(|| fmt_err(path, "empty frame rate".into()))?;
        if !(fps > 0.0 && fps <= 1000.0) {
            return Err(fmt_err(path, format!("frame rate {fps}, expected 0 < fps <= 1000")));
        }
        let (t, width) = match pshape[..] {
            [t, w] => (t, w),
            _ => {
                return Err(fmt_err(
                    path,
                    format!("'poses' has shape {pshape:?}, expected (T, 72), (T, 156) or (T, 165)"),
                ));
            }
        };
        if ![72, 156, 165].contains(&width) {
            return Err(fmt_err(
                path,
                format!(
                    "'poses' has {width} columns ({} joints), expected 72 (SMPL, 24 joints), 156 \
                     (SMPL-H, 52) or 165 (SMPL-X, 55)",
                    width as f64 / 3.0
                ),
            ));
        }
        if tshape[..] != [t, 3] {
            return Err(fmt_err(
                path,
                format!("'trans' has shape {tshape:?}, expected ({t}, 3) like 'poses'"),
            ));
        }
        if !(2..=MAX_FRAMES).contains(&t) {
            return Err(fmt_err(path, format!("{t} frames, expected 2 to {MAX_FRAMES}")));
        }
        Ok(Sequence { frames: t, fps, width, poses, trans, betas })
    }

    /// First column of SMPL-H joint `j` (0 … 51) in a `poses` row; `None` for the fingers of an
    /// SMPL file (72 columns: joints 22 and 23 there are SMPL's hands, not SMPL-H joints).
    pub fn smplh_column(&self, j: usize) -> Option<usize> {
        let hands_at = match self.width {
            156 => Some(22),
            165 => Some(25),
            _ => None,
        };
        match (j, hands_at) {
            (0..=21, _) => Some(3 * j),
            (22.., Some(h)) => Some(3 * (h + j - 22)),
            (22.., None) => None,
        }
    }

    /// Axis-angle (rad) of the `c`-th column triple of frame `f`.
    pub fn axis_angle(&self, f: usize, c: usize) -> [f64; 3] {
        let row = &self.poses[f * self.width..(f + 1) * self.width];
        [row[c], row[c + 1], row[c + 2]]
    }

    /// Root translation of frame `f` (m, Z-up world).
    pub fn trans_at(&self, f: usize) -> [f64; 3] {
        [self.trans[3 * f], self.trans[3 * f + 1], self.trans[3 * f + 2]]
    }
}

/// [`read`] on the given rest skeleton ([`Rest`]); with SMPL's skeletons the pelvis is placed at
/// `trans + J_pelvis`, as SMPL does.
pub fn read_with_rest(path: &Path, rest: Rest) -> Result<Bvh, ClipError> {
    let seq = Sequence::read(path)?;
    let (t, betas) = (seq.frames, &seq.betas);
    // rest skeleton: SMPL's neutral one, a body model's joints for these betas, or the humanoid's;
    // the pelvis goes to trans + its rest position (J_pelvis for SMPL's; the origin for the
    // humanoid's, whose forward kinematics start there)
    let rest_j = match rest {
        Rest::SmplNeutral => smpl_neutral_joints(),
        Rest::BodyModel(m) => model_joints(m, betas)?,
        Rest::Humanoid => humanoid_rest(),
    };
    let pelvis = rest_j[0];
    let rest = |j: usize| rest_j[j];
    let mut joints = Vec::with_capacity(52);
    for (j, (name, parent, _)) in SMPLH_JOINTS.iter().enumerate() {
        let offset = match parent {
            Some(p) => skillmimic_core::math::sub(rest(j), rest(*p)),
            None => [0.0; 3],
        };
        let mut channels = vec![Channel::Zrotation, Channel::Xrotation, Channel::Yrotation];
        if parent.is_none() {
            channels.splice(0..0, [Channel::Xposition, Channel::Yposition, Channel::Zposition]);
        }
        let first_value = if j == 0 { 0 } else { 6 + 3 * (j - 1) };
        joints.push(BvhJoint {
            name: name.to_string(),
            parent: *parent,
            offset,
            channels,
            first_value,
            end_site: None,
        });
    }
    let width_out = 6 + 3 * 51;
    let untilt = Quat::from_axis_angle([1.0, 0.0, 0.0], -std::f64::consts::FRAC_PI_2);
    let mut values = Vec::with_capacity(t * width_out);
    for f in 0..t {
        let aa = |j: usize| -> Quat {
            seq.smplh_column(j).map_or(Quat::IDENTITY, |c| Quat::from_rotvec(seq.axis_angle(f, c)))
        };
        let tr = seq.trans_at(f);
        let p = untilt.rotate([tr[0] + pelvis[0], tr[1] + pelvis[1], tr[2] + pelvis[2]]);
        values.extend_from_slice(&p);
        values.extend_from_slice(&zxy_degrees(untilt.mul(aa(0))));
        for j in 1..52 {
            values.extend_from_slice(&zxy_degrees(aa(j)));
        }
    }
    Ok(Bvh {
        path: path.to_path_buf(),
        joints,
        frame_time: 1.0 / seq.fps,
        frames: t,
        width: width_out,
        values,
    })
}

/// Euler angles (degrees) of R = Rz(a) · Rx(b) · Ry(c), the channel order of [`read`]'s joints.
pub fn zxy_degrees(q: Quat) -> [f64; 3] {
    let (w, x, y, z) = (q.w, q.x, q.y, q.z);
    let m01 = 2.0 * (x * y - w * z);
    let m11 = 1.0 - 2.0 * (x * x + z * z);
    let m20 = 2.0 * (x * z - w * y);
    let m21 = 2.0 * (y * z + w * x);
    let m22 = 1.0 - 2.0 * (x * x + y * y);
    [
        (-m01).atan2(m11).to_degrees(),
        m21.clamp(-1.0, 1.0).asin().to_degrees(),
        (-m20).atan2(m22).to_degrees(),
    ]
}
