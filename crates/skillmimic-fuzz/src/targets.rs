//! The fuzz targets: each has seed inputs generated in code from valid files and runs one
//! reader on an input written to a file (the readers take paths, as users' files are).

use std::path::Path;

use rand::SeedableRng;
use skillmimic_learn::checkpoint::{self, Progress};
use skillmimic_learn::config::{PpoConfig, TrainConfig};
use skillmimic_motion::pt::write_pt_matrix;
use skillmimic_motion::testing::synthetic_rows;
use skillmimic_motion::{Clip, PT_WIDTH};

/// A fuzz target.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// `Clip::from_pt` on a BallPlay-M `.pt` archive.
    Pt,
    /// `Clip::load` on a project clip (`.safetensors`).
    Clip,
    /// `checkpoint::load` + the stored config on a policy checkpoint.
    Checkpoint,
    /// `TrainConfig` from TOML over the defaults, then `validate()`.
    Config,
    /// The BVH reader, forward kinematics of every frame, and retargeting with a small joint map
    /// (`Hips` → Pelvis) into a validated clip.
    Bvh,
    /// The joint-positions CSV reader and retargeting from positions with light IK (a legs map)
    /// into a validated clip.
    Positions,
}

/// All targets, in the order `--target all` runs them.
pub const ALL: [Target; 6] =
    [Target::Pt, Target::Clip, Target::Checkpoint, Target::Config, Target::Bvh, Target::Positions];

impl Target {
    /// The target's command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Target::Pt => "pt",
            Target::Clip => "clip",
            Target::Checkpoint => "checkpoint",
            Target::Config => "config",
            Target::Bvh => "bvh",
            Target::Positions => "positions",
        }
    }

    /// The target named `name`.
    pub fn from_name(name: &str) -> Option<Target> {
        ALL.into_iter().find(|t| t.name() == name)
    }

    /// File name the input is written to (the `.pt` reader reads the skill label from it).
    pub fn file_name(self) -> &'static str {
        match self {
            Target::Pt => "001_fuzz.pt",
            Target::Clip => "fuzz.safetensors",
            Target::Checkpoint => "fuzz_ckpt.safetensors",
            Target::Config => "fuzz.toml",
            Target::Bvh => "fuzz.bvh",
            Target::Positions => "fuzz.csv",
        }
    }

    /// Seed inputs, generated from valid files in `dir`.
    pub fn seeds(self, dir: &Path) -> Vec<Vec<u8>> {
        let p = dir.join(format!("seed-{}", self.file_name()));
        let file = |p: &Path| std::fs::read(p).expect("seed file");
        match self {
            Target::Pt => {
                let mut out = Vec::new();
                for t in [1usize, 3] {
                    let rows = synthetic_rows(t);
                    write_pt_matrix(&p, t, PT_WIDTH, &rows, "FloatStorage").expect("seed .pt");
                    out.push(file(&p));
                }
                out
            }
            Target::Clip => {
                let mut clip = skillmimic_env::synth::demo_clips().expect("demo clips").remove(0);
                trim(&mut clip, 4);
                clip.save(&p).expect("seed clip");
                vec![file(&p)]
            }
            Target::Checkpoint => {
                let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
                let cfg = PpoConfig { hidden: vec![4], ..Default::default() };
                let mut out = Vec::new();
                for (obs, act) in [(6, 2), (3, 1)] {
                    let policy = skillmimic_learn::policy::Policy::new(obs, act, &cfg, &mut rng);
                    let sizes: Vec<usize> = policy
                        .actor
                        .params()
                        .iter()
                        .chain(policy.critic.params().iter())
                        .map(|x| x.len())
                        .collect();
                    let adam = skillmimic_learn::adam::Adam::new(&sizes, 1e-3, 1e-8);
                    let config = TrainConfig::preset("tiny").expect("preset").to_toml();
                    checkpoint::save(
                        &p,
                        &policy,
                        Some(&adam),
                        &Progress { iteration: 2, samples: 64 },
                        &config,
                    )
                    .expect("seed checkpoint");
                    out.push(file(&p));
                    checkpoint::save(&p, &policy, None, &Progress::default(), "")
                        .expect("seed checkpoint");
                    out.push(file(&p));
                }
                out
            }
            Target::Bvh => vec![BVH_SEED.as_bytes().to_vec()],
            Target::Positions => vec![positions_seed().into_bytes()],
            Target::Config => skillmimic_learn::config_presets::PRESETS
                .iter()
                .map(|name| TrainConfig::preset(name).expect("preset").to_toml().into_bytes())
                .collect(),
        }
    }

    /// Run the target on the file `path`; the error text when it refuses the input.
    pub fn run(self, path: &Path) -> Result<(), String> {
        match self {
            Target::Pt => Clip::from_pt(path).map(drop).map_err(|e| e.to_string()),
            Target::Clip => Clip::load(path).map(drop).map_err(|e| e.to_string()),
            Target::Checkpoint => {
                checkpoint::load_with_config(path).map(drop).map_err(|e| e.to_string())
            }
            Target::Config => {
                let text = std::fs::read_to_string(path).map_err(|e| e.to_string())?;
                let cfg = TrainConfig::from_toml_over(&TrainConfig::default(), &text, path)
                    .map_err(|e| e.to_string())?;
                cfg.validate().map_err(|e| e.to_string())
            }
            Target::Bvh => {
                use skillmimic_motion::{bvh, retarget_bvh, retarget_clip};
                let b = bvh::read(path).map_err(|e| e.to_string())?;
                for f in 0..b.frames {
                    let _ = b.pose(f);
                }
                let map = retarget_bvh::JointMap {
                    up: "y".into(),
                    yaw_deg: 0.0,
                    scale: Some(0.01),
                    bodies: [("Pelvis".to_string(), "Hips".to_string())].into(),
                };
                let m = retarget_bvh::retarget(&b, &map, &retarget_bvh::Options::default())
                    .map_err(|e| e.to_string())?;
                retarget_clip::to_clip(
                    &m,
                    "fuzz",
                    "fuzz",
                    10,
                    &retarget_clip::Ball::None,
                    b.frame_time,
                    path,
                )
                .map(drop)
                .map_err(|e| e.to_string())
            }
            Target::Positions => {
                use skillmimic_motion::{retarget_bvh, retarget_clip, retarget_positions};
                let src = retarget_positions::JointPositions::read_csv(path, 30.0)
                    .map_err(|e| e.to_string())?;
                let map = retarget_bvh::JointMap {
                    up: "y".into(),
                    yaw_deg: 0.0,
                    scale: Some(0.01),
                    bodies: LEGS.iter().map(|n| (n.to_string(), n.to_string())).collect(),
                };
                let m = retarget_positions::retarget_positions(
                    &src,
                    &map,
                    &retarget_bvh::Options { ik: true, ..Default::default() },
                )
                .map_err(|e| e.to_string())?;
                retarget_clip::to_clip(
                    &m,
                    "fuzz",
                    "fuzz",
                    10,
                    &retarget_clip::Ball::None,
                    1.0 / 30.0,
                    path,
                )
                .map(drop)
                .map_err(|e| e.to_string())
            }
        }
    }
}

/// The joints of the positions seed and map.
const LEGS: [&str; 7] = ["Pelvis", "L_Hip", "L_Knee", "L_Ankle", "R_Hip", "R_Knee", "R_Ankle"];

/// A small valid positions CSV: the humanoid's rest legs (centimetres), three frames walking +z.
fn positions_seed() -> String {
    use skillmimic_core::characters::skillmimic as skeleton;
    let rest = skeleton::forward_kinematics(
        [0.0, 95.0, 0.0],
        skillmimic_core::math::Quat::IDENTITY,
        &[0.0; skeleton::NUM_DOFS],
    );
    let mut text: String = LEGS
        .iter()
        .flat_map(|n| ["x", "y", "z"].map(|a| format!("{n}_{a}")))
        .collect::<Vec<_>>()
        .join(",");
    for f in 0..3 {
        let row: Vec<String> = LEGS
            .iter()
            .flat_map(|n| {
                let p = rest[skeleton::body_index(n).expect("leg body")];
                [100.0 * p[0], p[1] + 99.0 * (p[1] - 95.0), 100.0 * p[2] + 5.0 * f as f64]
                    .map(|x| format!("{x:.3}"))
            })
            .collect();
        text.push('\n');
        text.push_str(&row.join(","));
    }
    text + "\n"
}

/// A small valid BVH: a root with a position, two chained joints, an End Site, three frames.
const BVH_SEED: &str = "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition \
    Zposition Zrotation Xrotation Yrotation\n  JOINT Spine\n  {\n    OFFSET 0 10 0\n    CHANNELS \
    3 Zrotation Xrotation Yrotation\n    JOINT Head\n    {\n      OFFSET 0 20 0\n      CHANNELS 3 \
    Zrotation Xrotation Yrotation\n      End Site\n      {\n        OFFSET 0 5 0\n      }\n    \
    }\n  }\n}\nMOTION\nFrames: 3\nFrame Time: 0.0333333\n0 90 0 0 0 0 0 0 0 0 0 0\n1 90 0 10 0 0 \
    5 0 0 0 0 0\n2 90 0 20 0 0 10 0 0 0 0 5\n";

/// Keep the first `t` frames of `c`.
fn trim(c: &mut Clip, t: usize) {
    let n = c.num_frames.max(1);
    let cut = |v: &mut Vec<f32>| v.truncate(v.len() / n * t);
    for v in [
        &mut c.root_pos,
        &mut c.root_rot,
        &mut c.dof_rot,
        &mut c.body_pos,
        &mut c.ball_pos,
        &mut c.ball_rot,
        &mut c.contact,
    ] {
        cut(v);
    }
    c.num_frames = t;
}
