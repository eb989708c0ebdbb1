//! Issue 41: preset `cpu` trains (a short budget on the built-in demo clips) and the configuration
//! it saves next to its checkpoint is the one docs/throughput.md states in its "Preset `cpu`"
//! table (every row `| \`key\` | \`value\` | ... |` of that section, compared as typed values).

use std::process::Command;

use skillmimic_core::shared_data::workspace_root;
use skillmimic_learn::config::TrainConfig;

/// The (key, TOML value) rows of the section of `doc` whose heading names preset `cpu`.
fn documented_rows(doc: &str) -> Vec<(String, String)> {
    let mut rows = Vec::new();
    let mut inside = false;
    for line in doc.lines() {
        if line.starts_with('#') {
            inside = line.contains("Preset `cpu`");
            continue;
        }
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        if inside && cells.len() > 3 && cells[1].starts_with('`') && cells[2].starts_with('`') {
            let unquote = |c: &str| c.trim_matches('`').to_string();
            rows.push((unquote(cells[1]), unquote(cells[2])));
        }
    }
    rows
}

#[test]
fn preset_cpu_trains_and_is_what_the_docs_say() {
    let root = workspace_root();
    let doc = std::fs::read_to_string(root.join("docs/throughput.md")).unwrap();
    let rows = documented_rows(&doc);
    assert!(rows.len() >= 5, "docs/throughput.md: no 'Preset `cpu`' table with its keys: {rows:?}");

    let out = std::env::temp_dir().join(format!("sm-preset-cpu-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let status = Command::new(env!("CARGO_BIN_EXE_skillmimic"))
        .args(["train", "--preset", "cpu", "--iterations", "2", "--no-video", "--out"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let log = std::fs::read_to_string(out.join("log.jsonl")).unwrap();
    let lines: Vec<serde_json::Value> =
        log.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(lines.len(), 2, "two iterations logged");
    for l in &lines {
        assert_eq!(l["samples"].as_u64().unwrap() % 4096, 0, "4096 samples per iteration: {l}");
        let r = l["mean_reward"].as_f64().unwrap();
        assert!(r.is_finite() && r > 0.0, "{l}");
    }
    assert!(out.join("latest.safetensors").exists());

    // the saved configuration has every documented value, and it is preset `cpu` itself
    let saved_text = std::fs::read_to_string(out.join("config.toml")).unwrap();
    let saved =
        TrainConfig::from_toml_over(&TrainConfig::default(), &saved_text, &out.join("config.toml"))
            .unwrap();
    for (key, value) in &rows {
        let mut documented = saved.clone();
        documented.set(&format!("{key}={value}")).unwrap_or_else(|e| panic!("{key}: {e}"));
        assert_eq!(
            documented, saved,
            "docs/throughput.md says {key} = {value}; the run saved another"
        );
    }
    let mut preset = TrainConfig::preset("cpu").unwrap();
    // what a run fills in: its run table and the episode-start seed it derives from run.seed
    preset.run = saved.run.clone();
    preset.env.seed = saved.env.seed;
    assert_eq!(preset, saved, "the run's configuration is preset `cpu`");
    let small = TrainConfig::preset("small").unwrap();
    assert_ne!(small.ppo, saved.ppo);
    std::fs::remove_dir_all(&out).ok();
}
