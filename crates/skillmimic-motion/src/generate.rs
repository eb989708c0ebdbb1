//! Generators of new clips from a clip the policy fails on — the "generative" half of ModSkill's
//! active skill learning (seed 001 §3.4; modskill-tokenhsi-facts §1.6) — and the validity filter
//! every generated clip passes before it may join a motion library.
//!
//! * [`Generator`]: the pluggable interface (a failed clip and the library in, new clips out).
//! * [`ModelFree`], the default: **not a learned generative model** (ModSkill uses the
//!   text-to-motion model MDM; BallPlay-M has no text labels). It makes variations of the failed
//!   clip itself: per-part recombination (one body part's joints taken from another clip of the
//!   same skill while the other parts stay — the paper's per-part generation), mirroring
//!   (left ↔ right) and time warping.
//! * [`ExternalCommand`]: any program (e.g. a wrapper around MDM): it receives the failed clip as
//!   a project-format file and an empty output folder, and writes new clips there.
//! * [`Callback`]: a function with the same folder protocol; with [`register`] a named generator
//!   of this process (`run.active.generator = "<name>"`) — how a Python callable plugs in.
//! * [`check_validity`]: no body frame below the floor, joint angular speeds within a bound, all
//!   values finite.
//!
//! Generated clips get their body positions from [`forward_kinematics`] and a name
//! `<failed>~<how>`; mirroring swaps the labels of left and right dribbling (11 ↔ 12).

use std::path::{Path, PathBuf};

use rand::{Rng, RngCore};
use skillmimic_core::characters::skillmimic::{
    NUM_BODIES, NUM_DOFS, NUM_JOINTS, body_parts, dof_range, forward_kinematics, mirror_body,
};
use skillmimic_core::math::Quat;

use crate::clip::Clip;

/// Why a generator failed.
#[derive(Debug, thiserror::Error)]
pub enum GenError {
    #[error("generator '{name}': {detail}")]
    Failed { name: String, detail: String },
}

/// Makes new clips from a failed one.
pub trait Generator: Send {
    /// Name in logs.
    fn name(&self) -> String;
    /// New clips derived from `failed`; `library` = the clips trained on.
    fn generate(
        &mut self,
        failed: &Clip,
        library: &[Clip],
        rng: &mut dyn RngCore,
    ) -> Result<Vec<Clip>, GenError>;
}

fn q_at(v: &[f32], t: usize) -> Quat {
    Quat::from_wxyz(std::array::from_fn(|k| v[4 * t + k] as f64))
}

fn put_q(v: &mut [f32], t: usize, q: Quat) {
    for (k, x) in q.to_wxyz().iter().enumerate() {
        v[4 * t + k] = *x as f32;
    }
}

/// Recompute the body positions of every frame from the root and the joints.
pub fn refresh_body_pos(c: &mut Clip) {
    for t in 0..c.num_frames {
        let p = forward_kinematics(c.root_pos_at(t), c.root_quat_at(t), c.dof_at(t));
        for (b, pb) in p.iter().enumerate() {
            let at = (t * NUM_BODIES + b) * 3;
            for (o, &v) in c.body_pos[at..at + 3].iter_mut().zip(pb) {
                *o = v as f32;
            }
        }
    }
}

/// The mirror image of a clip: the world reflected across its x–z plane (y → −y), left and right
/// bodies exchanged. Quaternion rules (reflections written as −(half turns)): root
/// q' = q_y(π) q q_x(π) (the skeleton's sagittal plane is its y–z plane); a joint's local
/// rotation q' = q_x(π) q q_x(π), moved to the partner body; the ball q' = q_y(π) q q_y(π).
/// Up to the wrists the skeleton is symmetric, so body positions are exactly the partners'
/// reflected; the mocap skeleton's finger offsets differ between the hands by up to 1.3 cm, and
/// so do the mirrored fingers' positions from the reflected ones.
pub fn mirror(c: &Clip) -> Clip {
    let (qx, qy) = (Quat::from_wxyz([0.0, 1.0, 0.0, 0.0]), Quat::from_wxyz([0.0, 0.0, 1.0, 0.0]));
    let mut m = c.clone();
    for t in 0..c.num_frames {
        m.root_pos[3 * t + 1] = -c.root_pos[3 * t + 1];
        m.ball_pos[3 * t + 1] = -c.ball_pos[3 * t + 1];
        put_q(&mut m.root_rot, t, qy.mul(q_at(&c.root_rot, t)).mul(qx));
        put_q(&mut m.ball_rot, t, qy.mul(q_at(&c.ball_rot, t)).mul(qy));
        for b in 1..NUM_BODIES {
            let (src, dst) = (dof_range(b), dof_range(mirror_body(b)));
            let v = &c.dof_rot[t * NUM_DOFS + src.start..t * NUM_DOFS + src.end];
            // conjugation by the half turn about x: (vx, vy, vz) → (vx, −vy, −vz)
            let w = [v[0], -v[1], -v[2]];
            m.dof_rot[t * NUM_DOFS + dst.start..t * NUM_DOFS + dst.end].copy_from_slice(&w);
        }
    }
    // keep the root quaternions sign-continuous
    for t in 1..m.num_frames {
        if q_at(&m.root_rot, t).dot(q_at(&m.root_rot, t - 1)) < 0.0 {
            let q = q_at(&m.root_rot, t).neg();
            put_q(&mut m.root_rot, t, q);
        }
    }
    m.skill = match c.skill {
        11 => 12,
        12 => 11,
        s => s,
    };
    m.name = format!("{}~mirror", c.name);
    m.source = format!("mirror of {}", c.source);
    refresh_body_pos(&mut m);
    m
}

/// The clip played `factor` times as fast (frame rate kept): frame k of the result is the source
/// at time k·factor frames, root and ball positions interpolated linearly, rotations by slerp,
/// the contact label of the nearest frame.
pub fn time_warp(c: &Clip, factor: f64) -> Clip {
    assert!(factor > 0.0 && c.num_frames >= 1);
    let t_new = (((c.num_frames - 1) as f64 / factor).floor() as usize) + 1;
    let mut w = Clip {
        num_frames: t_new,
        root_pos: vec![0.0; 3 * t_new],
        root_rot: vec![0.0; 4 * t_new],
        dof_rot: vec![0.0; NUM_DOFS * t_new],
        body_pos: vec![0.0; 3 * NUM_BODIES * t_new],
        ball_pos: vec![0.0; 3 * t_new],
        ball_rot: vec![0.0; 4 * t_new],
        contact: vec![0.0; t_new],
        ..c.clone()
    };
    for k in 0..t_new {
        let x = (k as f64 * factor).min((c.num_frames - 1) as f64);
        let (i, s) = (x.floor() as usize, x - x.floor());
        let j = (i + 1).min(c.num_frames - 1);
        let lerp = |v: &[f32], n: usize, o: &mut [f32]| {
            for d in 0..n {
                o[n * k + d] = ((1.0 - s) * v[n * i + d] as f64 + s * v[n * j + d] as f64) as f32;
            }
        };
        lerp(&c.root_pos, 3, &mut w.root_pos);
        lerp(&c.ball_pos, 3, &mut w.ball_pos);
        put_q(&mut w.root_rot, k, q_at(&c.root_rot, i).slerp(q_at(&c.root_rot, j), s));
        put_q(&mut w.ball_rot, k, q_at(&c.ball_rot, i).slerp(q_at(&c.ball_rot, j), s));
        for jt in 0..NUM_JOINTS {
            let rv = |t: usize| {
                Quat::from_rotvec(std::array::from_fn(|d| {
                    c.dof_rot[t * NUM_DOFS + 3 * jt + d] as f64
                }))
            };
            let v = rv(i).slerp(rv(j), s).to_rotvec();
            let at = k * NUM_DOFS + 3 * jt;
            for (o, &x) in w.dof_rot[at..at + 3].iter_mut().zip(&v) {
                *o = x as f32;
            }
        }
        w.contact[k] = c.contact[if s < 0.5 { i } else { j }];
    }
    w.name = format!("{}~warp{factor:.2}", c.name);
    w.source = format!("time warp x{factor} of {}", c.source);
    refresh_body_pos(&mut w);
    w
}

/// `base` with the joints of `bodies` taken from `donor` frame by frame (both cut to the shorter
/// length); root, ball and the other joints stay `base`'s.
pub fn recombine(base: &Clip, donor: &Clip, part: &str, bodies: &[usize]) -> Clip {
    let t = base.num_frames.min(donor.num_frames);
    let mut c = time_warp(base, 1.0);
    c.num_frames = t;
    c.root_pos.truncate(3 * t);
    c.root_rot.truncate(4 * t);
    c.dof_rot.truncate(NUM_DOFS * t);
    c.body_pos.truncate(3 * NUM_BODIES * t);
    c.ball_pos.truncate(3 * t);
    c.ball_rot.truncate(4 * t);
    c.contact.truncate(t);
    for f in 0..t {
        for &b in bodies.iter().filter(|&&b| b >= 1) {
            let r = dof_range(b);
            c.dof_rot[f * NUM_DOFS + r.start..f * NUM_DOFS + r.end]
                .copy_from_slice(&donor.dof_rot[f * NUM_DOFS + r.start..f * NUM_DOFS + r.end]);
        }
    }
    c.name = format!("{}~{part}-from-{}", base.name, donor.name);
    c.source = format!("{} with the {part} of {}", base.source, donor.source);
    refresh_body_pos(&mut c);
    c
}

/// The default, model-free generator (see the module doc): per call, up to `per_part` part
/// recombinations with random same-skill donors (other parts fixed), the mirror image, and one
/// time warp with a factor drawn from `warp`.
pub struct ModelFree {
    pub per_part: usize,
    pub warp: (f64, f64),
}

impl Default for ModelFree {
    fn default() -> Self {
        Self { per_part: 1, warp: (0.8, 1.25) }
    }
}

impl Generator for ModelFree {
    fn name(&self) -> String {
        "model-free (part recombination, mirror, time warp)".into()
    }
    fn generate(
        &mut self,
        failed: &Clip,
        library: &[Clip],
        rng: &mut dyn RngCore,
    ) -> Result<Vec<Clip>, GenError> {
        let mut out = Vec::new();
        let donors: Vec<&Clip> = library
            .iter()
            .filter(|c| c.skill == failed.skill && c.name != failed.name && c.num_frames >= 2)
            .collect();
        if !donors.is_empty() {
            let parts = body_parts("five").expect("a known split");
            for _ in 0..self.per_part {
                let (name, bodies) = &parts[rng.random_range(0..parts.len())];
                let donor = donors[rng.random_range(0..donors.len())];
                out.push(recombine(failed, donor, name, bodies));
            }
        }
        out.push(mirror(failed));
        out.push(time_warp(failed, rng.random_range(self.warp.0..=self.warp.1)));
        Ok(out)
    }
}

/// A program that writes clips: run as `program args… <failed.safetensors> <output folder>`;
/// every `*.safetensors` clip it leaves in the folder is read back (project format).
pub struct ExternalCommand {
    pub program: PathBuf,
    pub args: Vec<String>,
    /// Scratch folder (one sub-folder per call).
    pub work_dir: PathBuf,
    calls: usize,
}

impl ExternalCommand {
    pub fn new(program: PathBuf, args: Vec<String>, work_dir: PathBuf) -> Self {
        Self { program, args, work_dir, calls: 0 }
    }
}

impl Generator for ExternalCommand {
    fn name(&self) -> String {
        format!("external command {}", self.program.display())
    }
    fn generate(
        &mut self,
        failed: &Clip,
        _library: &[Clip],
        _rng: &mut dyn RngCore,
    ) -> Result<Vec<Clip>, GenError> {
        self.calls += 1;
        let (program, args) = (&self.program, &self.args);
        through_folder(&self.name(), &self.work_dir, self.calls, failed, |input, out| {
            let status = std::process::Command::new(program)
                .args(args)
                .arg(input)
                .arg(out)
                .status()
                .map_err(|e| format!("cannot start: {e}"))?;
            if status.success() { Ok(()) } else { Err(format!("exited with {status}")) }
        })
    }
}

/// The folder protocol shared by [`ExternalCommand`] and [`Callback`]: `failed` is written to
/// `<work_dir>/call_<call>/failed.safetensors`, `run(input, out)` writes clips into the empty
/// folder `<work_dir>/call_<call>/out`, and every `*.safetensors` clip there is read back
/// (project format, validated by [`Clip::load`]).
fn through_folder(
    name: &str,
    work_dir: &Path,
    call: usize,
    failed: &Clip,
    run: impl FnOnce(&Path, &Path) -> Result<(), String>,
) -> Result<Vec<Clip>, GenError> {
    let fail = |detail: String| GenError::Failed { name: name.to_string(), detail };
    let dir = work_dir.join(format!("call_{call:05}"));
    let out = dir.join("out");
    std::fs::create_dir_all(&out)
        .map_err(|e| fail(format!("cannot create {}: {e}", out.display())))?;
    let input = dir.join("failed.safetensors");
    failed.save(&input).map_err(|e| fail(format!("cannot write {}: {e}", input.display())))?;
    run(&input, &out).map_err(&fail)?;
    read_clips(&out).map_err(fail)
}

/// The folder function of a [`Callback`]: (failed clip file, output folder) → Ok, or an error text.
pub type FolderFn = Box<dyn FnMut(&Path, &Path) -> Result<(), String> + Send>;

/// A generator that is a function following the folder protocol of [`ExternalCommand`] — how a
/// Python callable plugs in (`skillmimic_rs.register_generator`).
pub struct Callback {
    pub label: String,
    pub work_dir: PathBuf,
    calls: usize,
    f: FolderFn,
}

impl Callback {
    pub fn new(label: String, work_dir: PathBuf, f: FolderFn) -> Self {
        Self { label, work_dir, calls: 0, f }
    }
}

impl Generator for Callback {
    fn name(&self) -> String {
        self.label.clone()
    }
    fn generate(
        &mut self,
        failed: &Clip,
        _library: &[Clip],
        _rng: &mut dyn RngCore,
    ) -> Result<Vec<Clip>, GenError> {
        self.calls += 1;
        let f = &mut self.f;
        through_folder(&self.label, &self.work_dir, self.calls, failed, |input, out| f(input, out))
    }
}

/// Makes a registered generator for a run (argument: the run's scratch folder for generators).
pub type Factory = std::sync::Arc<dyn Fn(&Path) -> Box<dyn Generator> + Send + Sync>;

static REGISTRY: std::sync::Mutex<std::collections::BTreeMap<String, Factory>> =
    std::sync::Mutex::new(std::collections::BTreeMap::new());

/// Names `run.active.generator` takes without registration.
pub const BUILT_IN: [&str; 2] = ["model_free", "command"];

/// Register a generator under `name` for this process (`run.active.generator = "<name>"`); a
/// second registration of a name replaces the first. The built-in names cannot be taken.
pub fn register(name: &str, factory: Factory) -> Result<(), String> {
    if BUILT_IN.contains(&name) || name.is_empty() {
        return Err(format!("generator name '{name}' is built in or empty; choose another"));
    }
    REGISTRY.lock().unwrap_or_else(|e| e.into_inner()).insert(name.to_string(), factory);
    Ok(())
}

/// The factory registered under `name`.
pub fn registered(name: &str) -> Option<Factory> {
    REGISTRY.lock().unwrap_or_else(|e| e.into_inner()).get(name).cloned()
}

/// Registered names, sorted.
pub fn registered_names() -> Vec<String> {
    REGISTRY.lock().unwrap_or_else(|e| e.into_inner()).keys().cloned().collect()
}

/// Every project-format clip in `dir` (sorted by name).
fn read_clips(dir: &Path) -> Result<Vec<Clip>, String> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| format!("{}: {e}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "safetensors"))
        .collect();
    files.sort();
    files.iter().map(|p| Clip::load(p).map_err(|e| e.to_string())).collect()
}

/// Why a clip is not valid training data.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Invalid {
    #[error("clip '{clip}': a value of {field} is not finite (frame {frame})")]
    NonFinite { clip: String, field: &'static str, frame: usize },
    #[error("clip '{clip}': body {body} is {depth:.3} m below the floor at frame {frame}")]
    BelowFloor { clip: String, body: &'static str, depth: f64, frame: usize },
    #[error(
        "clip '{clip}': joint {joint} turns at {speed:.1} rad/s at frame {frame} (limit {limit} \
            rad/s)"
    )]
    TooFast { clip: String, joint: &'static str, speed: f64, frame: usize, limit: f64 },
    #[error("clip '{clip}': fewer than {min} frames", min = crate::validate::MIN_FRAMES)]
    TooShort { clip: String },
    #[error("{why}")]
    Implausible { clip: String, why: String },
}

/// The validity filter: at least [`MIN_FRAMES`](crate::validate::MIN_FRAMES) frames, finite values,
/// no body frame lower than `floor_tol` below the floor (z < −floor_tol, m), no joint turning
/// faster than `max_speed` (rad/s, the angle between consecutive frames' local rotations × fps),
/// and every rule of the loaders' validation ([`crate::validate::validate_clip`]), so that an
/// accepted clip can be loaded again.
pub fn check_validity(c: &Clip, floor_tol: f64, max_speed: f64) -> Result<(), Invalid> {
    let clip = c.name.clone();
    if c.num_frames < crate::validate::MIN_FRAMES {
        return Err(Invalid::TooShort { clip });
    }
    for (field, v, w) in [
        ("root_pos", &c.root_pos, 3),
        ("root_rot", &c.root_rot, 4),
        ("dof_rot", &c.dof_rot, NUM_DOFS),
        ("body_pos", &c.body_pos, 3 * NUM_BODIES),
        ("ball_pos", &c.ball_pos, 3),
    ] {
        if let Some(k) = v.iter().position(|x| !x.is_finite()) {
            return Err(Invalid::NonFinite { clip, field, frame: k / w });
        }
    }
    for t in 0..c.num_frames {
        for b in 0..NUM_BODIES {
            let z = c.body_pos[(t * NUM_BODIES + b) * 3 + 2] as f64;
            if z < -floor_tol {
                return Err(Invalid::BelowFloor {
                    clip,
                    body: skillmimic_core::characters::skillmimic::BODIES[b].name,
                    depth: -z,
                    frame: t,
                });
            }
        }
    }
    for t in 1..c.num_frames {
        for b in 1..NUM_BODIES {
            let r = dof_range(b);
            let q = |f: usize| {
                Quat::from_rotvec(std::array::from_fn(|d| {
                    c.dof_rot[f * NUM_DOFS + r.start + d] as f64
                }))
            };
            let speed = q(t - 1).conj().mul(q(t)).angle() * c.fps;
            if speed > max_speed {
                return Err(Invalid::TooFast {
                    clip,
                    joint: skillmimic_core::characters::skillmimic::BODIES[b].name,
                    speed,
                    frame: t,
                    limit: max_speed,
                });
            }
        }
    }
    let origin = format!("clip '{}'", c.name);
    crate::validate::validate_clip(c, Path::new(&origin), crate::validate::Naming::Project)
        .map_err(|e| Invalid::Implausible { clip, why: e.to_string() })?;
    Ok(())
}
