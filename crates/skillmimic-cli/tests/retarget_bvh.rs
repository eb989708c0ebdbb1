//! `skillmimic retarget --bvh` / `--amass` / `--positions`: a synthetic SMPL-H walk in the AMASS
//! layout and the real MocapBank capture shipped in the crates.io package bvh_anim 0.4.0 becomes a
//! clip with its feet on the floor (≤ 2 cm), no joint-speed spikes, a written report, and trains
//! for a few iterations without a non-finite value; bad maps and missing labels are refused by
//! name.

use std::process::Command;

use serde_json::Value;
use skillmimic_core::shared_data::registry_file_or_skip;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_skillmimic"))
}

/// Train 3 tiny iterations on `clip`; every logged loss and reward is finite.
fn trains_finite(clip: &std::path::Path, out: &std::path::Path) {
    let t = bin()
        .args([
            "train",
            "--preset",
            "tiny",
            "--iterations",
            "3",
            "--no-video",
            "--set",
            "run.eval_episodes=0",
            "--set",
            "env.num_envs=8",
            "--motion",
        ])
        .arg(clip)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap();
    assert!(t.status.success(), "{}", String::from_utf8_lossy(&t.stderr));
    let log = std::fs::read_to_string(out.join("log.jsonl")).unwrap();
    let rows: Vec<Value> = log.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(rows.len(), 3);
    for r in &rows {
        for k in ["mean_reward", "actor_loss", "critic_loss", "value_mean"] {
            assert!(r[k].as_f64().is_some_and(f64::is_finite), "{k} in {r}");
        }
    }
}

#[test]
fn synthetic_amass_sequence_retargets_and_trains() {
    let out = std::env::temp_dir().join(format!("sm-retarget-amass-{}", std::process::id()));
    std::fs::create_dir_all(&out).unwrap();
    let npz = out.join("walk.npz");
    skillmimic_motion::testing::write_synthetic_amass(&npz, 240, 120.0, &[]).unwrap();
    let r = bin()
        .args(["retarget", "--skill", "10", "--name", "010_walk", "--amass"])
        .arg(&npz)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let rep: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("010_walk.retarget.json")).unwrap())
            .unwrap();
    println!("{rep}");
    assert_eq!(rep["frames"], 120, "2 s at 120 fps resampled to 60 fps");
    assert!(rep["foot_penetration_max_m"].as_f64().unwrap() <= 0.02);
    assert_eq!(rep["frames_with_speed_spike"], 0);
    trains_finite(&out.join("010_walk.safetensors"), &out.join("train"));
    // with --ik on SMPL's neutral skeleton: the hips' midpoint moves onto SMPL's and the ankles
    // meet SMPL's ankles × scale: 0.7 mm mean; up to 8 mm where a nearly straight SMPL leg, from
    // hips 7 cm narrower than the humanoid's, reaches beyond the humanoid's straight leg
    let r = bin()
        .args(["retarget", "--skill", "10", "--name", "010_walk_ik", "--ik", "--amass"])
        .arg(&npz)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let rep: Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("010_walk_ik.retarget.json")).unwrap(),
    )
    .unwrap();
    println!("{}", rep["ik"]);
    assert!(
        rep["ik"]["feet_mean_m"].as_f64().unwrap() < 0.002
            && rep["ik"]["feet_max_m"].as_f64().unwrap() < 0.01,
        "{}",
        rep["ik"]
    );
    assert!(rep["foot_penetration_max_m"].as_f64().unwrap() <= 0.02);
    let _ = std::fs::remove_dir_all(&out);
}

/// `--positions` with `--ik` and `--ball-joint`: the shipped synthetic dribble clip's body
/// positions plus a `Ball` column, written as a CSV at 30 fps, come back as a 60 fps clip whose
/// ball follows the column and whose wrists and ankles meet the positions; it trains finite.
#[test]
fn joint_positions_csv_retargets_with_ik_and_trains() {
    use std::fmt::Write;
    let out = std::env::temp_dir().join(format!("sm-retarget-positions-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    std::fs::create_dir_all(&out).unwrap();
    let clip = skillmimic_motion::Clip::load(
        &skillmimic_core::shared_data::workspace_root()
            .join("motions/050_synth_stand_dribble_right.safetensors"),
    )
    .unwrap();
    let names: Vec<&str> = skillmimic_core::characters::skillmimic::BODIES
        .iter()
        .map(|b| b.name)
        .chain(["Ball"])
        .collect();
    let mut csv = names
        .iter()
        .flat_map(|n| ["x", "y", "z"].map(|a| format!("{n}_{a}")))
        .collect::<Vec<_>>()
        .join(",")
        + "\n";
    let frames: Vec<usize> = (0..clip.num_frames).step_by(2).collect(); // 60 → 30 fps
    for &t in &frames {
        let row: Vec<f32> = clip.body_pos[t * 159..(t + 1) * 159]
            .iter()
            .chain(&clip.ball_pos[t * 3..t * 3 + 3])
            .copied()
            .collect();
        writeln!(csv, "{}", row.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(","))
            .unwrap();
    }
    std::fs::write(out.join("dribble.csv"), csv).unwrap();
    std::fs::write(
        out.join("zup.toml"),
        format!(
            "up = \"z\"\n[bodies]\n{}",
            names[..53].iter().map(|n| format!("{n} = \"{n}\"\n")).collect::<String>()
        ),
    )
    .unwrap();
    let r = bin()
        .args([
            "retarget",
            "--skill",
            "50",
            "--name",
            "050_back",
            "--fps",
            "30",
            "--ik",
            "--no-ground",
            "--ball-joint",
            "Ball",
            "--map",
        ])
        .arg(out.join("zup.toml"))
        .arg("--positions")
        .arg(out.join("dribble.csv"))
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let rep: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("050_back.retarget.json")).unwrap())
            .unwrap();
    println!("{rep}");
    assert_eq!(rep["frames"].as_u64().unwrap() as usize, 2 * (frames.len() - 1) + 1, "30 → 60 fps");
    for k in ["feet_max_m", "hands_max_m"] {
        assert!(
            rep["ik"][k].as_f64().unwrap() < 1e-4,
            "the same skeleton: every target within reach ({k})"
        );
    }
    assert!(rep["contact_frames"].as_u64().unwrap() > 0, "a dribble touches the ball");
    let back = skillmimic_motion::Clip::load(&out.join("050_back.safetensors")).unwrap();
    // even output frames are source frames: body and ball positions come back (f32 CSV, 1e-4 m)
    for (k, &t) in frames.iter().enumerate() {
        let d = (0..159)
            .map(|i| (back.body_pos[2 * k * 159 + i] - clip.body_pos[t * 159 + i]).abs())
            .fold(0.0f32, f32::max);
        let db = (0..3)
            .map(|i| (back.ball_pos[2 * k * 3 + i] - clip.ball_pos[t * 3 + i]).abs())
            .fold(0.0f32, f32::max);
        assert!(d < 1e-4 && db < 1e-5, "frame {t}: bodies {d} m, ball {db} m");
    }
    trains_finite(&out.join("050_back.safetensors"), &out.join("train"));
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn mocap_bvh_retargets_and_trains() {
    let Some(bvh) =
        registry_file_or_skip("retarget --bvh", "bvh_anim-0.4.0", "data/test_mocapbank.bvh")
    else {
        return;
    };
    let out = std::env::temp_dir().join(format!("sm-retarget-bvh-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let r = bin()
        .args([
            "retarget",
            "--map",
            "mocapbank",
            "--skill",
            "10",
            "--name",
            "010_mocapbank",
            "--bvh",
        ])
        .arg(&bvh)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let rep: Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("010_mocapbank.retarget.json")).unwrap(),
    )
    .unwrap();
    println!(
        "{}",
        rep.as_object()
            .unwrap()
            .iter()
            .filter(|(k, _)| *k != "per_frame")
            .map(|(k, v)| format!("{k}: {v}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    assert_eq!(rep["frames"], 908);
    assert!(rep["foot_penetration_max_m"].as_f64().unwrap() <= 0.02);
    assert_eq!(rep["frames_with_speed_spike"], 0);
    assert!(rep["max_joint_speed_rad_s"].as_f64().unwrap() < 20.0);
    // the per-frame checks agree with the summaries
    let col = |k: &str| -> Vec<f64> {
        rep["per_frame"][k].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
    };
    let (sole, slide, speed) =
        (col("lowest_sole_m"), col("foot_sliding_m_s"), col("max_joint_speed_rad_s"));
    assert!(sole.len() == 908 && slide.len() == 908 && speed.len() == 908);
    let deepest = sole.iter().cloned().fold(f64::INFINITY, f64::min);
    assert!((deepest + rep["foot_penetration_max_m"].as_f64().unwrap()).abs() < 1e-12, "{deepest}");
    assert!(
        (speed.iter().cloned().fold(0.0, f64::max)
            - rep["max_joint_speed_rad_s"].as_f64().unwrap())
        .abs()
            < 1e-12
    );
    let on_floor: Vec<f64> = (1..908).filter(|&k| sole[k] < 0.02).map(|k| slide[k]).collect();
    assert!(
        (on_floor.iter().sum::<f64>() / on_floor.len() as f64
            - rep["foot_sliding_mean_m_s"].as_f64().unwrap())
        .abs()
            < 1e-9
    );
    trains_finite(&out.join("010_mocapbank.safetensors"), &out.join("train"));
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn bad_maps_and_missing_labels_are_refused() {
    let dir = std::env::temp_dir().join(format!("sm-retarget-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bvh = dir.join("a.bvh");
    std::fs::write(
        &bvh,
        "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition \
        Zposition Zrotation Xrotation Yrotation\n End Site\n {\n  OFFSET 0 1 0\n \
        }\n}\nMOTION\nFrames: 2\nFrame Time: 0.0333\n0 90 0 0 0 0\n0 90 0 0 0 0\n",
    )
    .unwrap();
    let run = |extra: &[&str]| {
        let r = bin()
            .args(["retarget", "--bvh"])
            .arg(&bvh)
            .arg("--out")
            .arg(&dir)
            .args(extra)
            .output()
            .unwrap();
        assert!(!r.status.success());
        String::from_utf8_lossy(&r.stderr).into_owned()
    };
    assert!(run(&["--map", "cmu"]).contains("--skill"));
    assert!(run(&["--map", "nosuch", "--skill", "1"]).contains("neither a shipped map"));
    let e = run(&["--map", "cmu", "--skill", "1"]);
    assert!(
        e.contains("a.bvh") && e.contains("which the BVH file does not have"),
        "a map naming joints the file lacks: {e}"
    );
    let map = dir.join("m.toml");
    std::fs::write(&map, "[bodies]\nPelvis = \"Hips\"\nNose = \"Hips\"\n").unwrap();
    let e = run(&["--map", map.to_str().unwrap(), "--skill", "1"]);
    assert!(e.contains("Nose"), "{e}");
    std::fs::write(&map, "[bodies]\nPelvis = \"Hips\"\n").unwrap();
    let e = run(&["--map", map.to_str().unwrap(), "--skill", "1"]);
    assert!(e.contains("scale"), "no legs and no scale: {e}");
    let _ = std::fs::remove_dir_all(&dir);
}
