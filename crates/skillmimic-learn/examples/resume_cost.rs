//! What the exact-resume state costs per checkpoint: its size beside the rest of the training
//! checkpoint (policy, normalisers, Adam, extensions) and beside the policy-only file, and the
//! time to encode it beside the time to write the whole checkpoint (best of 5), on preset
//! `small` (256 environments; the paper's networks) with the shipped demo clips, after one
//! iteration; `amp` as a third argument turns the motion prior on (its replay buffer is part of
//! the state). Run alone on the machine:
//!
//! `cargo run --release -p skillmimic-learn --example resume_cost [-- TASK [PRESET [amp]]]`

use std::time::Instant;

use skillmimic_learn::config::TrainConfig;
use skillmimic_learn::trainer::Trainer;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let task = args.get(1).map_or("imitation", String::as_str);
    let preset = args.get(2).map_or("small", String::as_str);
    let mut c = TrainConfig::preset(preset)?;
    c.env.task = task.into();
    c.ppo.amp.enabled = args.get(3).is_some_and(|a| a == "amp");
    c.env.motion = vec![std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../motions")];
    c.run.out_dir = std::env::temp_dir().join(format!("sm-resume-cost-{}", std::process::id()));
    let mut t = Trainer::new(c.clone(), None)?;
    t.iteration()?;
    let path = c.run.out_dir.join("ck.safetensors");
    std::fs::create_dir_all(&c.run.out_dir)?;
    let reps = 5;
    let (mut encode, mut save) = (f64::INFINITY, f64::INFINITY);
    let mut state_bytes = 0;
    for _ in 0..reps {
        let t0 = Instant::now();
        let s = skillmimic_learn::trainer::resume::single(&t)?.expect("one process");
        encode = encode.min(t0.elapsed().as_secs_f64());
        state_bytes = s.bytes.len();
        let t0 = Instant::now();
        t.save(&path)?;
        save = save.min(t0.elapsed().as_secs_f64());
    }
    let total = std::fs::metadata(&path)?.len() as usize;
    let rest = total - state_bytes;
    // the policy-only file (what `skillmimic export` writes)
    let policy_path = c.run.out_dir.join("policy.safetensors");
    skillmimic_learn::checkpoint::save(
        &policy_path,
        &t.policy,
        None,
        &t.progress,
        t.config_toml(),
    )?;
    let policy = std::fs::metadata(&policy_path)?.len() as usize;
    let line = serde_json::json!({
        "task": task,
        "preset": preset,
        "amp": c.ppo.amp.enabled,
        "num_envs": c.env.num_envs,
        "checkpoint_bytes": total,
        "state_bytes": state_bytes,
        "rest_bytes": rest,
        "state_over_rest": state_bytes as f64 / rest as f64,
        "policy_only_bytes": policy,
        "state_over_policy_only": state_bytes as f64 / policy as f64,
        "encode_s": encode,
        "save_s": save,
        "encode_over_save": encode / save,
        "best_of": reps,
    });
    println!("{line}");
    std::fs::remove_dir_all(&c.run.out_dir)?;
    Ok(())
}
