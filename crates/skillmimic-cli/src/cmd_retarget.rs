//! `skillmimic retarget`, by input:
//! * `--bvh FILE` / `--amass FILE.npz` / `--positions FILE.csv --fps F`, with `--map MAP --skill N`
//!   and optionally `--ik`: a motion → a clip of the SkillMimic humanoid in the project format
//!   (`skillmimic_motion::retarget_bvh`, `retarget_positions`, `retarget_clip`) with a JSON report
//!   (foot penetration and sliding, joint-speed spikes, scale, IK residuals);
//! * `--amass FILE.npz --to smpl`: the sequence's SMPL joint rotations as a clip of the SMPL
//!   humanoid as they are, no retargeting (`skillmimic_motion::amass_smpl`);
//! * `--to tokenhsi|smpl --motion …`: SkillMimic-skeleton clips (BallPlay-M `.pt` or the project
//!   format) → clips of the TokenHSI character or the SMPL humanoid (`character-clip` format,
//!   `skillmimic_motion::character_clip`), by shared joints (`skillmimic_motion::retarget_hsi`,
//!   `retarget_smpl`), with a JSON report per clip (TokenHSI: foot height error over the source's
//!   stance frames and joint-limit violations; SMPL: scale, ground shift, foot height error).
//!
//! Users who bring AMASS / SAMP / OMOMO motions for the sit, climb and carry styles (not
//! redistributable here) write the `character-clip` arrays directly from their SMPL retargets: the
//! character's lower body has SMPL's neutral offsets, so SMPL joint rotations of the shared joints
//! transfer as they are (see docs/tokenhsi.md).

use std::path::PathBuf;

use anyhow::{Context, bail};
use skillmimic_motion::Clip;
use skillmimic_motion::library::find_clip_files;
use skillmimic_motion::retarget_hsi::retarget_to_hsi;
use skillmimic_motion::retarget_smpl::retarget_to_smpl;

#[derive(clap::Args)]
pub struct Args {
    /// Target character: of `--motion`, `tokenhsi` (default) or `smpl`; of `--amass`, `smpl`
    /// writes the sequence's SMPL joint rotations as a clip of the SMPL humanoid as they are (no
    /// retargeting, `skillmimic_motion::amass_smpl`) instead of retargeting it onto the SkillMimic
    /// humanoid.
    #[arg(long)]
    pub to: Option<String>,
    /// Source clip files or folders (repeatable).
    #[arg(long, required_unless_present_any = ["bvh", "amass", "positions"])]
    pub motion: Vec<PathBuf>,
    /// Output folder (one `<name>.safetensors` per clip and `retarget_report.json`; for `--bvh`:
    /// `<name>.safetensors` and `<name>.retarget.json`).
    #[arg(long)]
    pub out: PathBuf,
    /// A BVH motion to retarget onto the SkillMimic humanoid (instead of `--motion`).
    #[arg(long, conflicts_with_all = ["motion", "amass"])]
    pub bvh: Option<PathBuf>,
    /// An SMPL / SMPL-H / SMPL-X sequence in the AMASS `.npz` layout (`poses`, `trans`,
    /// `mocap_framerate`) to retarget onto the SkillMimic humanoid (map `smplh` by default).
    #[arg(long, conflicts_with = "motion")]
    pub amass: Option<PathBuf>,
    /// Joint positions only: a CSV with a header of `<joint>_x,<joint>_y,<joint>_z` columns and
    /// one row per frame (the map's axes and units; needs `--fps`; map `humanoid` by default).
    /// Rotations are solved from bone directions; twists about a bone are not in positions.
    #[arg(long, conflicts_with_all = ["motion", "bvh", "amass"], requires = "fps")]
    pub positions: Option<PathBuf>,
    /// Frame rate of the `--positions` file (frames per second).
    #[arg(long, requires = "positions")]
    pub fps: Option<f64>,
    /// Light IK: bend legs and arms so the ankles and wrists reach the source's positions × scale
    /// (planted feet stay planted, hands stay on the ball, whatever the limb proportions).
    #[arg(long)]
    pub ik: bool,
    /// With `--amass`: an SMPL / SMPL-H body model `.npz` (`v_template`, `J_regressor`,
    /// `shapedirs`; never shipped) giving the rest joints for the sequence's `betas` (instead of
    /// `--rest`).
    #[arg(long, requires = "amass", conflicts_with = "rest")]
    pub body_model: Option<PathBuf>,
    /// With `--amass`: the rest skeleton without a body model: `smpl` (SMPL's neutral mean shape,
    /// pelvis at trans + J_pelvis) or `humanoid` (the humanoid's own: rotations transfer unchanged,
    /// pelvis at trans).
    #[arg(long, requires = "amass", value_parser = ["smpl", "humanoid"])]
    pub rest: Option<String>,
    /// Joint map: a shipped map (`humanoid`, `mocapbank`, `cmu`, `smplh`) or a TOML file
    /// (default `cmu` for `--bvh`, `smplh` for `--amass`).
    #[arg(long)]
    pub map: Option<String>,
    /// Skill label of the output clip (0 … 63; 0 and 10 are ball-free skills).
    #[arg(long)]
    pub skill: Option<u32>,
    /// Clip name (default: the BVH file's stem).
    #[arg(long)]
    pub name: Option<String>,
    /// Ball track: a CSV of x,y,z per BVH frame in the BVH's axes and units.
    #[arg(long, conflicts_with = "ball_joint")]
    pub ball_csv: Option<PathBuf>,
    /// Ball track: a joint (marker) of the BVH whose position is the ball's centre.
    #[arg(long)]
    pub ball_joint: Option<String>,
    /// Keep the source's heights (no ground alignment).
    #[arg(long)]
    pub no_ground: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    if let Some(bvh) = a.bvh.clone() {
        return run_bvh(&a, &bvh, false);
    }
    if let Some(npz) = a.amass.clone() {
        return match a.to.as_deref() {
            None | Some("skillmimic") => run_bvh(&a, &npz, true),
            Some("smpl") => run_amass_smpl(&a, &npz),
            Some(t) => bail!(
                "--to '{t}' with --amass: AMASS sequences go onto 'smpl' (as they are) or \
                 'skillmimic' (retargeted, the default)"
            ),
        };
    }
    if let Some(csv) = a.positions.clone() {
        return run_positions(&a, &csv);
    }
    let to = a.to.as_deref().unwrap_or("tokenhsi");
    if to != "tokenhsi" && to != "smpl" {
        bail!("--to '{to}': the target characters of --motion are 'tokenhsi' and 'smpl'");
    }
    let mut files = Vec::new();
    for m in &a.motion {
        files.extend(find_clip_files(m)?);
    }
    if files.is_empty() {
        bail!("no .pt or .safetensors clips under {:?}", a.motion);
    }
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create {}", a.out.display()))?;
    let mut reports = Vec::new();
    for f in &files {
        let clip = Clip::load_any(f)?;
        if to == "smpl" {
            let (out, rep) = retarget_to_smpl(&clip);
            let path = a.out.join(format!("{}.safetensors", clip.name));
            out.save(&path).with_context(|| format!("cannot write {}", path.display()))?;
            println!(
                "{}: {} frames, scale {:.3}, ground shift {:.1} mm, foot height error {:.1} mm \
                    mean / {:.1} mm max over the stance frames",
                clip.name,
                rep.frames,
                rep.scale,
                1000.0 * rep.ground_shift,
                1000.0 * rep.foot_height_error_mean,
                1000.0 * rep.foot_height_error_max
            );
            reports.push(serde_json::to_value(&rep)?);
            continue;
        }
        let (out, rep) = retarget_to_hsi(&clip);
        let path = a.out.join(format!("{}.safetensors", clip.name));
        out.save(&path).with_context(|| format!("cannot write {}", path.display()))?;
        println!(
            "{}: {} frames, foot height error {:.1} mm mean / {:.1} mm max over {} stance frames, \
                {} 3-DoF axes beyond their limits and {} elbow angles clamped ({:.1} % of frames, \
                max excess {:.1} deg)",
            clip.name,
            rep.frames,
            1000.0 * rep.foot_height_error_mean,
            1000.0 * rep.foot_height_error_max,
            rep.stance_frames,
            rep.limit_violations,
            rep.elbow_clamped,
            100.0 * rep.frames_with_violation,
            rep.max_violation.to_degrees()
        );
        reports.push(serde_json::to_value(&rep)?);
    }
    let path = a.out.join("retarget_report.json");
    skillmimic_core::tensorfile::write_bytes_atomic(
        &path,
        serde_json::to_string_pretty(&reports)?.as_bytes(),
    )
    .with_context(|| format!("cannot write {}", path.display()))?;
    println!("wrote {} clips and {}", reports.len(), path.display());
    Ok(())
}

/// `--amass FILE --to smpl`: the sequence's SMPL joint rotations as a clip of the SMPL humanoid
/// (no retargeting), with its report.
fn run_amass_smpl(a: &Args, path: &std::path::Path) -> anyhow::Result<()> {
    if a.body_model.is_some() || a.rest.is_some() || a.map.is_some() || a.ik {
        bail!(
            "--to smpl reads the sequence on SMPL's neutral body as it is: --body-model, --rest, \
             --map and --ik do not apply"
        );
    }
    let (mut clip, rep) = skillmimic_motion::amass_smpl::load(path, !a.no_ground)?;
    if let Some(n) = &a.name {
        clip.name = n.clone();
    }
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create {}", a.out.display()))?;
    let out = a.out.join(format!("{}.safetensors", clip.name));
    clip.save(&out).with_context(|| format!("cannot write {}", out.display()))?;
    let rpath = a.out.join(format!("{}.retarget.json", clip.name));
    skillmimic_core::tensorfile::write_bytes_atomic(
        &rpath,
        serde_json::to_string_pretty(&rep)?.as_bytes(),
    )
    .with_context(|| format!("cannot write {}", rpath.display()))?;
    println!(
        "{}: {} frames at {:.1} fps ({} pose columns) onto the SMPL humanoid as they are, ground \
         shift {:.1} mm{}; wrote {} and {}",
        clip.name,
        rep.frames,
        rep.fps,
        rep.source_width,
        1000.0 * rep.ground_shift,
        if rep.betas_ignored { " (betas ignored: the neutral body)" } else { "" },
        out.display(),
        rpath.display()
    );
    Ok(())
}

/// Ball positions per line `x,y,z` (a header line is skipped); errors name the file and the line.
fn read_ball_csv(path: &std::path::Path) -> anyhow::Result<Vec<[f64; 3]>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let cells: Vec<&str> = line.split(',').map(str::trim).filter(|c| !c.is_empty()).collect();
        if cells.is_empty() || (i == 0 && cells.iter().any(|c| c.parse::<f64>().is_err())) {
            continue;
        }
        let v: Vec<f64> =
            cells.iter().map(|c| c.parse::<f64>()).collect::<Result<_, _>>().map_err(|_| {
                anyhow::anyhow!(
                    "{} line {}: expected three numbers x,y,z, found '{line}'",
                    path.display(),
                    i + 1
                )
            })?;
        if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
            bail!(
                "{} line {}: expected three finite numbers x,y,z, found '{line}'",
                path.display(),
                i + 1
            );
        }
        out.push([v[0], v[1], v[2]]);
    }
    Ok(out)
}

/// `--bvh` (or `--amass`, read as a source skeleton motion by `skillmimic_motion::amass`).
fn run_bvh(a: &Args, path: &std::path::Path, amass: bool) -> anyhow::Result<()> {
    use skillmimic_motion::retarget_bvh::{JointMap, retarget};
    let flag = if amass { "--amass" } else { "--bvh" };
    let skill = skill_of(a, flag)?;
    let b = if amass {
        use skillmimic_motion::amass::{Rest, read_with_rest};
        let rest = match (a.body_model.as_deref(), a.rest.as_deref()) {
            (Some(m), _) => Rest::BodyModel(m),
            (None, Some("humanoid")) => Rest::Humanoid,
            (None, _) => Rest::SmplNeutral,
        };
        read_with_rest(path, rest)?
    } else {
        skillmimic_motion::bvh::read(path)?
    };
    let map = JointMap::load(a.map.as_deref().unwrap_or(if amass { "smplh" } else { "cmu" }))?;
    let m = retarget(&b, &map, &options(a))?;
    let marker =
        |name: &str| b.joint(name).map(|j| (0..b.frames).map(|f| b.pose(f).positions[j]).collect());
    write_clip(a, path, &m, skill, b.frames, b.frame_time, marker)
}

/// `--positions`: joint positions per frame (`skillmimic_motion::retarget_positions`).
fn run_positions(a: &Args, path: &std::path::Path) -> anyhow::Result<()> {
    use skillmimic_motion::retarget_bvh::JointMap;
    use skillmimic_motion::retarget_positions::{JointPositions, retarget_positions};
    let skill = skill_of(a, "--positions")?;
    let src = JointPositions::read_csv(path, a.fps.context("--positions needs --fps")?)?;
    let map = JointMap::load(a.map.as_deref().unwrap_or("humanoid"))?;
    let m = retarget_positions(&src, &map, &options(a))?;
    let marker =
        |name: &str| src.joint(name).map(|j| (0..src.frames).map(|f| src.at(f, j)).collect());
    write_clip(a, path, &m, skill, src.frames, 1.0 / src.fps, marker)
}

fn skill_of(a: &Args, flag: &str) -> anyhow::Result<u32> {
    a.skill.with_context(|| format!("{flag} needs --skill N (the clip's skill label, 0 … 63)"))
}

fn options(a: &Args) -> skillmimic_motion::retarget_bvh::Options {
    skillmimic_motion::retarget_bvh::Options { fps: 60.0, ground: !a.no_ground, ik: a.ik }
}

/// The ball track, the clip, its report and the summary line, for every retargeting path
/// (`frames`, `frame_time`: the source's; `marker(name)`: a source joint's positions per frame).
fn write_clip(
    a: &Args,
    path: &std::path::Path,
    m: &skillmimic_motion::retarget_bvh::Motion,
    skill: u32,
    frames: usize,
    frame_time: f64,
    marker: impl Fn(&str) -> Option<Vec<[f64; 3]>>,
) -> anyhow::Result<()> {
    use skillmimic_motion::retarget_clip::{Ball, to_clip};
    let ball = match (&a.ball_csv, &a.ball_joint) {
        (Some(csv), _) => {
            let p = read_ball_csv(csv)?;
            if p.len() != frames {
                bail!(
                    "{}: {} ball positions, expected one per source frame ({frames})",
                    csv.display(),
                    p.len()
                );
            }
            Ball::Points(p)
        }
        (None, Some(j)) => Ball::Points(marker(j).with_context(|| {
            format!("--ball-joint '{j}': {} has no such joint", path.display())
        })?),
        (None, None) => Ball::None,
    };
    let name = a.name.clone().unwrap_or_else(|| {
        path.file_stem().map_or("clip".into(), |s| s.to_string_lossy().into_owned())
    });
    let (clip, rep) =
        to_clip(m, &name, &path.display().to_string(), skill, &ball, frame_time, path)?;
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create {}", a.out.display()))?;
    let out = a.out.join(format!("{name}.safetensors"));
    clip.save(&out).with_context(|| format!("cannot write {}", out.display()))?;
    let rpath = a.out.join(format!("{name}.retarget.json"));
    skillmimic_core::tensorfile::write_bytes_atomic(
        &rpath,
        serde_json::to_string_pretty(&rep)?.as_bytes(),
    )
    .with_context(|| format!("cannot write {}", rpath.display()))?;
    let ik = if a.ik {
        let r = rep.ik;
        format!(
            ", IK: ankles within {:.1} mm mean / {:.1} mm max of their targets, wrists {:.1} / \
                {:.1} mm (targets beyond the straight limb)",
            1000.0 * r.feet_mean_m,
            1000.0 * r.feet_max_m,
            1000.0 * r.hands_mean_m,
            1000.0 * r.hands_max_m
        )
    } else {
        String::new()
    };
    println!(
        "{name}: {} frames at 60 fps (from {frames} at {:.1} fps), scale {:.4}, ground shift \
            {:.3} m; feet: deepest {:.1} mm below the floor, {} frames > 1 cm, sliding {:.3} m/s; \
            fastest joint {:.1} rad/s ({} at frame {}), {} frames with spikes > 20 rad/s; {} \
            contact frames{ik}",
        rep.frames,
        1.0 / frame_time,
        rep.scale,
        rep.ground_shift_m,
        1000.0 * rep.foot_penetration_max_m,
        rep.frames_penetrating,
        rep.foot_sliding_mean_m_s,
        rep.max_joint_speed_rad_s,
        rep.max_joint_speed_body,
        rep.max_joint_speed_frame,
        rep.frames_with_speed_spike,
        rep.contact_frames
    );
    println!(
        "wrote {} and {} (check it kinematically: skillmimic play --reference {})",
        out.display(),
        rpath.display(),
        out.display()
    );
    Ok(())
}
