//! Issue 42: the documented commands of the two comparison tables of docs/results.md — SkillMimic
//! against SkillMimic-V2 on layup (`scripts/experiments/layup_v1_v2.sh`) and SkillMimic Tab. 3
//! (`scripts/experiments/tab3.sh`) — re-run with the scripts' own flags and a short budget
//! (8 iterations) reproduce the committed first iterations bit for bit: every logged quantity
//! except wall-clock times.
//!
//! References: `configs/results/first8/<run>.jsonl` (8 rows each; the test compares the first
//! `ITERATIONS`, 4 since stop 57 to keep CI's time on a 2-core machine in bounds; the rows' values
//! do not depend on how many iterations a run is given), written by the same commands on the machine
//! class of `configs/results/first8/meta.json` (float results depend on the matrix kernels the CPU
//! selects and on the thread count; elsewhere the comparison is relaxed to 2 % per logged reward,
//! as in `results_repro.rs`). SkillMimic-V2's command has two steps: the history encoder's
//! pre-training, whose per-epoch losses are compared over its first 5 epochs (its learning-rate
//! schedule reacts to plateaus only, so the first epochs of the documented 1 000 are these), and
//! the training, run here with that 5-epoch encoder.

use std::path::{Path, PathBuf};
use std::process::Command;

mod repro;
use repro::{machine_class, rows};
use serde_json::Value;
use skillmimic_core::shared_data::{shared_dir_or_skip, workspace_root};

const ITERATIONS: usize = 4;
/// Rows of each committed reference (`UPDATE_FIRST8` writes this many).
const REFERENCE_ROWS: usize = 8;
const LAYUP: &str = "data/ballplay_m/layup/031_015pickle_layup_001_001.pt";

fn reference_dir() -> PathBuf {
    workspace_root().join("configs/results/first8")
}

/// The machine class the references were written on (`meta.json`'s `machine`).
fn reference_machine() -> Value {
    let text = std::fs::read_to_string(reference_dir().join("meta.json")).unwrap();
    serde_json::from_str::<Value>(&text).unwrap()["machine"].clone()
}

/// The configuration's clips under the shared folder actually found (the configs name
/// `../shared`), as a `--set env.motion=[...]` override, or nothing where they are the same.
fn motion_override(root: &Path, shared: &Path, config: &str) -> Vec<String> {
    if root.join("../shared").canonicalize().ok() == shared.canonicalize().ok() {
        return Vec::new();
    }
    // the quoted clip paths of `env.motion` (every string naming the shared data folder)
    let text = std::fs::read_to_string(root.join(config)).unwrap();
    let clips: Vec<String> = text
        .lines()
        .filter(|l| !l.trim_start().starts_with('#'))
        .flat_map(|l| l.split('"').skip(1).step_by(2))
        .filter_map(|p| p.find("shared/data/").map(|k| &p[k + "shared/".len()..]))
        .map(|rel| format!("{:?}", shared.join(rel).display().to_string()))
        .collect();
    assert!(!clips.is_empty(), "{config}: no clip under the shared data folder");
    vec!["--set".into(), format!("env.motion=[{}]", clips.join(", "))]
}

/// `skillmimic train` with the scripts' flags (seed 0, `--threads 0`, the checkpoint interval of
/// 204 800 samples) for `ITERATIONS` iterations; the logged rows.
fn train(preset: &str, config: &str, extra: &[String], out: &Path, shared: &Path) -> Vec<Value> {
    let root = workspace_root();
    let per = if preset == "small" { 8192 } else { 4096 };
    let _ = std::fs::remove_dir_all(out);
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_skillmimic"));
    cmd.current_dir(&root)
        .args(["train", "--preset", preset, "--config", config, "--seed", "0"])
        .args(["--iterations", &iterations().to_string(), "--resume", "latest", "--no-video"])
        .args(["--threads", "0", "--learner-threads", "0"])
        .args(["--set", &format!("run.save_every={}", 204_800 / per)])
        .args(["--set", "run.eval_episodes=0"])
        .args(motion_override(&root, shared, config))
        .args(extra)
        .arg("--out")
        .arg(out);
    let res = cmd.output().unwrap();
    assert!(res.status.success(), "{config}: {}", String::from_utf8_lossy(&res.stderr));
    let got = rows(&std::fs::read_to_string(out.join("log.jsonl")).unwrap());
    let _ = std::fs::remove_dir_all(out);
    got
}

/// Iterations a run is given: the references' length when they are rewritten.
fn iterations() -> usize {
    if std::env::var_os("UPDATE_FIRST8").is_some() { REFERENCE_ROWS } else { ITERATIONS }
}

fn compare(name: &str, got: &[Value]) {
    let path = reference_dir().join(format!("{name}.jsonl"));
    if std::env::var_os("UPDATE_FIRST8").is_some() {
        let text: String = got.iter().map(|v| format!("{v}\n")).collect();
        std::fs::write(&path, text).unwrap();
        eprintln!("wrote {}", path.display());
        return;
    }
    let mut reference = rows(&std::fs::read_to_string(&path).unwrap());
    assert_eq!((got.len(), reference.len()), (ITERATIONS, REFERENCE_ROWS), "{name}");
    reference.truncate(ITERATIONS);
    let meta = reference_machine();
    let here = machine_class();
    if here == meta {
        for (i, (g, r)) in got.iter().zip(&reference).enumerate() {
            assert_eq!(g, r, "{name}: iteration {}: the logged curve differs", i + 1);
        }
        println!("{name}: {ITERATIONS} iterations bit-identical to the reference");
    } else {
        println!(
            "{name}: this machine ({here}) is not of the reference's class ({meta}): comparing to 2 %"
        );
        for (i, (g, r)) in got.iter().zip(&reference).enumerate() {
            let (a, b) = (g["mean_reward"].as_f64().unwrap(), r["mean_reward"].as_f64().unwrap());
            assert!((a - b).abs() <= 0.02 * b.abs(), "{name}: iteration {}: {a} vs {b}", i + 1);
            assert_eq!(g["samples"], r["samples"], "{name}");
        }
    }
}

fn scratch(tag: &str) -> PathBuf {
    std::env::temp_dir().join(format!("sm-repro-tables-{}-{tag}", std::process::id()))
}

#[test]
fn layup_skillmimic_command_reproduces_its_first_iterations() {
    let Some(shared) = shared_dir_or_skip("results_repro_tables") else { return };
    let got = train("small", "configs/results/layup.toml", &[], &scratch("layup-sm"), &shared);
    compare("layup-sm-small", &got);
}

#[test]
fn layup_v2_commands_reproduce_pretraining_and_first_iterations() {
    let Some(shared) = shared_dir_or_skip("results_repro_tables") else { return };
    let dir = scratch("layup-v2");
    std::fs::create_dir_all(&dir).unwrap();
    let enc = dir.join("history-layup.safetensors");
    // step 1 as layup_v1_v2.sh runs it, 5 of its 1 000 epochs
    let res = Command::new(env!("CARGO_BIN_EXE_skillmimic"))
        .current_dir(workspace_root())
        .args(["history", "pretrain", "--motion"])
        .arg(shared.join(LAYUP))
        .arg("--out")
        .arg(&enc)
        .args(["--epochs", "5", "--seed", "0"])
        .output()
        .unwrap();
    assert!(res.status.success(), "{}", String::from_utf8_lossy(&res.stderr));
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(enc.with_extension("json")).unwrap())
            .unwrap();
    let losses = report["report"]["epoch_loss"].clone();
    let path = reference_dir().join("layup-v2-pretrain.json");
    if std::env::var_os("UPDATE_FIRST8").is_some() {
        std::fs::write(&path, format!("{}\n", serde_json::json!({ "epoch_loss": losses })))
            .unwrap();
    } else {
        let want: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        let (g, w) = (losses.as_array().unwrap(), want["epoch_loss"].as_array().unwrap());
        assert_eq!(g.len(), 5);
        let exact = machine_class() == reference_machine();
        for (k, (a, b)) in g.iter().zip(w).enumerate() {
            let (a, b) = (a.as_f64().unwrap(), b.as_f64().unwrap());
            assert!(
                if exact { a == b } else { (a - b).abs() <= 0.02 * b.abs() },
                "pre-training epoch {}: loss {a} vs {b}",
                k + 1
            );
        }
    }
    // step 2 with that encoder
    let set = vec!["--set".to_string(), format!("env.v2.history.encoder={:?}", enc.display())];
    let got = train("small", "configs/results/layup-v2.toml", &set, &dir.join("run"), &shared);
    let _ = std::fs::remove_dir_all(&dir);
    compare("layup-v2-small", &got);
}

#[test]
fn tab3_commands_reproduce_their_first_iterations() {
    let Some(shared) = shared_dir_or_skip("results_repro_tables") else { return };
    for run in ["df", "dl", "dr", "layup", "mixed"] {
        let config = match run {
            "layup" => "configs/results/layup.toml".to_string(),
            r => format!("configs/results/tab3-{r}.toml"),
        };
        let got = train("cpu", &config, &[], &scratch(&format!("tab3-{run}")), &shared);
        compare(&format!("tab3-{run}-cpu"), &got);
    }
}
