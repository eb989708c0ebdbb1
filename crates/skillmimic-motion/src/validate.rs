//! The one validation of motion clips, run by every loader ([`Clip::from_pt`], [`Clip::load`],
//! [`crate::MotionLibrary::from_clips`], hence `skillmimic convert`, training and the Python
//! package): a clip that passes can be trained on without producing a non-finite reset state.
//!
//! Bounds (checked per frame; velocities are backward differences times the clip's fps, the way
//! [`crate::ClipReference`] derives the reset velocities):
//!
//! * length — bound: ≥ [`MIN_FRAMES`] = 4 frames; largest value in the 56 BallPlay-M clips: 51
//!   frames (shortest clip)
//! * fps — bound: [`MIN_FPS`] = 1 … [`MAX_FPS`] = 1000 frames per second; largest value in the 56
//!   BallPlay-M clips: 60
//! * every value — bound: finite; largest value in the 56 BallPlay-M clips: —
//! * root / body / ball position component — bound: ≤ [`MAX_POSITION`] = 100 m in magnitude;
//!   largest value in the 56 BallPlay-M clips: 3.64 m
//! * exp-map rotation (joints; `.pt` root and ball columns) — bound: length ≤ [`MAX_ROTVEC`] = 2π
//!   rad; largest value in the 56 BallPlay-M clips: 3.1416 rad (root), 2.72 rad (joints), 0 (ball)
//! * quaternion (root, ball) — bound: norm within [`QUAT_NORM_TOL`] = 1e-3 of 1; largest value in
//!   the 56 BallPlay-M clips: unit by construction
//! * root / body / ball linear speed — bound: ≤ [`MAX_LINEAR_SPEED`] = 100 m/s; largest value in
//!   the 56 BallPlay-M clips: 3.5 (root), 14.2 (body), 11.3 (ball) m/s
//! * joint exp-map component rate — bound: ≤ [`MAX_DOF_SPEED`] = 2000 rad/s; largest value in the
//!   56 BallPlay-M clips: 221 rad/s (an exp-map wrap near π)
//! * contact label — bound: exactly 0 or 1; largest value in the 56 BallPlay-M clips: only 0 and 1
//!   occur (10 450 frames)
//!
//! Margins: positions and speeds ×7 to ×27 over the real maxima (a thrown ball stays below
//! 50 m/s); rotation vectors up to one full turn (every rotation has one of length ≤ π); joint
//! rates ×9 (an exp-map wrap at 120 fps gives at most 4π·120 ≈ 1508 rad/s). Root and ball angular
//! velocities come from unit quaternions, so they are at most π·fps ≤ 3142 rad/s and need no bound.
//! A flipped exponent bit (a finite value such as 1e30) fails the position or rotation bound.
//!
//! Messages name the file, the frame, the field — the project tensor (`body_pos[14] (Head)`) or,
//! for `.pt` files, the BallPlay-M column (`column 207 (body positions)`) — and the bound.

use std::f64::consts::PI;
use std::path::Path;

use skillmimic_core::characters::skillmimic::{BODIES, NUM_BODIES, NUM_DOFS};

use crate::clip::Clip;
use crate::error::ClipError;
use crate::layout::{PT_WIDTH, pt_column_field};

/// Smallest clip length any command accepts: reference-state initialisation draws start frames
/// 2 … T−2 (T − 2 ≥ 2), and velocities need the previous frame.
pub const MIN_FRAMES: usize = 4;
/// Lowest accepted frame rate (frames per second).
pub const MIN_FPS: f64 = 1.0;
/// Highest accepted frame rate (frames per second).
pub const MAX_FPS: f64 = 1000.0;
/// Largest accepted magnitude of a position component (root, bodies, ball), metres.
pub const MAX_POSITION: f64 = 100.0;
/// Largest accepted length of an exp-map rotation vector, rad.
pub const MAX_ROTVEC: f64 = 2.0 * PI;
/// Largest accepted deviation of a quaternion's norm from 1.
pub const QUAT_NORM_TOL: f64 = 1e-3;
/// Largest accepted linear speed of the root, a body or the ball (backward difference × fps), m/s.
pub const MAX_LINEAR_SPEED: f64 = 100.0;
/// Largest accepted rate of one joint exp-map component (backward difference × fps), rad/s.
pub const MAX_DOF_SPEED: f64 = 2000.0;

/// How messages name a field: by project-format tensor, or by BallPlay-M `.pt` column.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Naming {
    /// Tensor names of the project format (`body_pos[14] (Head)`).
    Project,
    /// Columns of the 337-column BallPlay-M layout (`column 207 (body positions)`).
    PtColumns,
}

/// The per-frame arrays of a [`Clip`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Field {
    RootPos,
    RootRot,
    DofRot,
    BodyPos,
    BallPos,
    BallRot,
    Contact,
}

impl Field {
    fn tensor(self) -> &'static str {
        match self {
            Field::RootPos => "root_pos",
            Field::RootRot => "root_rot",
            Field::DofRot => "dof_rot",
            Field::BodyPos => "body_pos",
            Field::BallPos => "ball_pos",
            Field::BallRot => "ball_rot",
            Field::Contact => "contact",
        }
    }
    /// Values per frame.
    fn width(self) -> usize {
        match self {
            Field::RootPos | Field::BallPos => 3,
            Field::RootRot | Field::BallRot => 4,
            Field::DofRot => NUM_DOFS,
            Field::BodyPos => 3 * NUM_BODIES,
            Field::Contact => 1,
        }
    }
    /// First BallPlay-M column of the field (quaternions: of the exp map they are decoded from).
    fn pt_column(self) -> usize {
        match self {
            Field::RootPos => 0,
            Field::RootRot => 3,
            Field::DofRot => 9,
            Field::BodyPos => 165,
            Field::BallPos => 324,
            Field::BallRot => 327,
            Field::Contact => 336,
        }
    }
    fn values(self, c: &Clip) -> &[f32] {
        match self {
            Field::RootPos => &c.root_pos,
            Field::RootRot => &c.root_rot,
            Field::DofRot => &c.dof_rot,
            Field::BodyPos => &c.body_pos,
            Field::BallPos => &c.ball_pos,
            Field::BallRot => &c.ball_rot,
            Field::Contact => &c.contact,
        }
    }
}

const ALL: [Field; 7] = [
    Field::RootPos,
    Field::RootRot,
    Field::DofRot,
    Field::BodyPos,
    Field::BallPos,
    Field::BallRot,
    Field::Contact,
];

/// Name of `len` values of `field` starting at index `k` within a frame (`len` is 1 for one
/// component, 3 for a vector, the field width for the whole field).
fn field_name(naming: Naming, field: Field, k: usize, len: usize) -> String {
    match naming {
        Naming::PtColumns => {
            let (c, n) = match field {
                Field::RootRot | Field::BallRot => (field.pt_column(), 3),
                _ => (field.pt_column() + k, len),
            };
            if n == 1 {
                format!("column {c} ({})", pt_column_field(c))
            } else {
                format!("columns {c}..{} ({})", c + n, pt_column_field(c))
            }
        }
        Naming::Project => {
            let t = field.tensor();
            match (field, len) {
                (Field::DofRot, 1) => {
                    format!("{t}[{}, {}] ({})", k / 3, k % 3, BODIES[k / 3 + 1].name)
                }
                (Field::DofRot, _) => format!("{t}[{}] ({})", k / 3, BODIES[k / 3 + 1].name),
                (Field::BodyPos, 1) => {
                    format!("{t}[{}, {}] ({})", k / 3, k % 3, BODIES[k / 3].name)
                }
                (Field::BodyPos, _) => format!("{t}[{}] ({})", k / 3, BODIES[k / 3].name),
                (_, 1) if field.width() > 1 => format!("{t}[{k}]"),
                _ => t.to_string(),
            }
        }
    }
}

/// Check every validity rule of the module doc on `clip`, loaded from `path` (the file named in
/// errors); `naming` selects tensor or `.pt` column names.
pub fn validate_clip(clip: &Clip, path: &Path, naming: Naming) -> Result<(), ClipError> {
    let format_err = |detail: String| ClipError::Format { path: path.to_path_buf(), detail };
    let fps = clip.fps;
    if !(MIN_FPS..=MAX_FPS).contains(&fps) {
        return Err(format_err(format!(
            "fps is {fps}, expected a frame rate of {MIN_FPS} to {MAX_FPS} frames per second"
        )));
    }
    let t_len = clip.num_frames;
    if t_len < MIN_FRAMES {
        return Err(format_err(format!(
            "clip has {t_len} frames, expected at least {MIN_FRAMES} (start frames 2..T-2 of \
                reference-state initialisation; velocities need the previous frame)"
        )));
    }
    for f in ALL {
        let n = f.values(clip).len();
        if Some(n) != t_len.checked_mul(f.width()) {
            return Err(format_err(format!(
                "{} holds {n} values, expected {t_len} frames x {}",
                f.tensor(),
                f.width()
            )));
        }
    }
    let bad = |f: Field, frame: usize, k: usize, len: usize, problem: String| ClipError::Invalid {
        path: path.to_path_buf(),
        field: field_name(naming, f, k, len),
        frame,
        problem,
    };
    for t in 0..t_len {
        for f in ALL {
            let w = f.width();
            let row = &f.values(clip)[t * w..(t + 1) * w];
            if let Some(k) = row.iter().position(|x| !x.is_finite()) {
                return Err(bad(
                    f,
                    t,
                    k,
                    1,
                    format!("is {}, expected a finite number", show(row[k])),
                ));
            }
            match f {
                Field::RootPos | Field::BodyPos | Field::BallPos => {
                    if let Some(k) = row.iter().position(|x| (*x as f64).abs() > MAX_POSITION) {
                        return Err(bad(
                            f,
                            t,
                            k,
                            1,
                            format!(
                                "is {} m, expected a position within ±{MAX_POSITION} m",
                                show(row[k])
                            ),
                        ));
                    }
                }
                Field::DofRot => check_rotvecs(row, |k, p| bad(f, t, k, 3, p))?,
                Field::RootRot | Field::BallRot => {
                    let n = row.iter().map(|&x| (x as f64) * (x as f64)).sum::<f64>().sqrt();
                    if (n - 1.0).abs() > QUAT_NORM_TOL {
                        return Err(bad(
                            f,
                            t,
                            0,
                            4,
                            format!(
                                "has norm {n}, expected a unit quaternion (w, x, y, z), norm \
                                    within {QUAT_NORM_TOL} of 1"
                            ),
                        ));
                    }
                }
                Field::Contact => {
                    if row[0] != 0.0 && row[0] != 1.0 {
                        return Err(bad(
                            f,
                            t,
                            0,
                            1,
                            format!("is {}, expected 0 or 1", show(row[0])),
                        ));
                    }
                }
            }
        }
        if t == 0 {
            continue;
        }
        for (f, group, limit, unit) in [
            (Field::RootPos, 3, MAX_LINEAR_SPEED, "m/s"),
            (Field::BodyPos, 3, MAX_LINEAR_SPEED, "m/s"),
            (Field::BallPos, 3, MAX_LINEAR_SPEED, "m/s"),
            (Field::DofRot, 1, MAX_DOF_SPEED, "rad/s"),
        ] {
            let (w, v) = (f.width(), f.values(clip));
            let (prev, cur) = (&v[(t - 1) * w..t * w], &v[t * w..(t + 1) * w]);
            for k in (0..w).step_by(group) {
                let speed = (k..k + group)
                    .map(|i| ((cur[i] as f64 - prev[i] as f64) * fps).powi(2))
                    .sum::<f64>()
                    .sqrt();
                if speed > limit {
                    return Err(bad(
                        f,
                        t,
                        k,
                        group,
                        format!(
                            "moves at {speed:.4e} {unit} from frame {} (backward difference x \
                                {fps} fps), expected at most {limit} {unit}",
                            t - 1
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}

/// A value for a message: plain for ordinary magnitudes, scientific for huge or tiny ones.
fn show(x: f32) -> String {
    let a = x.abs();
    if a != 0.0 && !(1e-4..1e6).contains(&a) { format!("{x:e}") } else { format!("{x}") }
}

/// Check the exp-map rotation vectors (consecutive triples) of `values` against [`MAX_ROTVEC`];
/// `err(k, problem)` builds the error of the vector starting at index `k`.
fn check_rotvecs(
    values: &[f32],
    err: impl Fn(usize, String) -> ClipError,
) -> Result<(), ClipError> {
    for (j, v) in values.chunks_exact(3).enumerate() {
        let n = v.iter().map(|&x| (x as f64) * (x as f64)).sum::<f64>().sqrt();
        if n > MAX_ROTVEC {
            return Err(err(
                3 * j,
                format!(
                    "is a rotation vector of length {n:.4e} rad, expected at most 2π = \
                        {MAX_ROTVEC:.4} rad"
                ),
            ));
        }
    }
    Ok(())
}

/// Checks of raw BallPlay-M rows (`t` rows of [`PT_WIDTH`] values) that the decoded clip can no
/// longer see: every column finite (unused ones included), and the root and ball exp maps
/// (columns 3..6, 327..330) within [`MAX_ROTVEC`] before they become unit quaternions. The
/// decoded clip is then checked by [`validate_clip`].
pub fn check_pt_rows(rows: &[f32], path: &Path) -> Result<(), ClipError> {
    if let Some(k) = rows.iter().position(|x| !x.is_finite()) {
        let (frame, column) = (k / PT_WIDTH, k % PT_WIDTH);
        return Err(ClipError::NonFinite {
            path: path.to_path_buf(),
            frame,
            column,
            field: pt_column_field(column),
            value: rows[k],
        });
    }
    for (frame, r) in rows.chunks_exact(PT_WIDTH).enumerate() {
        for c in [3, 327] {
            check_rotvecs(&r[c..c + 3], |_, problem| ClipError::Invalid {
                path: path.to_path_buf(),
                field: format!("columns {c}..{} ({})", c + 3, pt_column_field(c)),
                frame,
                problem,
            })?;
        }
    }
    Ok(())
}
