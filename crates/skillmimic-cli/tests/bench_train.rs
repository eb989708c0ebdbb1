//! `skillmimic bench train` prints the raw mj_step anchor measured in the same run, the end-to-end
//! / raw ratio and the memory per environment (issue 21), with plausible values.

use std::process::Command;

#[test]
fn bench_train_reports_the_raw_anchor_and_memory() {
    let out = Command::new(env!("CARGO_BIN_EXE_skillmimic"))
        .args([
            "bench",
            "train",
            "--preset",
            "tiny",
            "--rounds",
            "1",
            "--warmup",
            "0",
            "--num-envs",
            "8",
            "--threads",
            "1",
        ])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}\n{}", String::from_utf8_lossy(&out.stderr));
    let line = text
        .lines()
        .find(|l| l.starts_with("raw mj_step anchor"))
        .unwrap_or_else(|| panic!("no anchor line in\n{text}"));
    // "... {rate} policy steps/s; end-to-end / raw {ratio}"
    let rate: f64 =
        line.split(": ").nth(1).and_then(|s| s.split_whitespace().next()).unwrap().parse().unwrap();
    let ratio: f64 = line.rsplit(' ').next().unwrap().parse().unwrap();
    assert!(rate > 10.0, "{line}");
    assert!(ratio > 0.0 && ratio < 1.5, "end-to-end cannot beat the raw physics by much: {line}");
    let mem = text
        .lines()
        .find(|l| l.starts_with("memory per environment"))
        .unwrap_or_else(|| panic!("no memory line in\n{text}"));
    let kb: f64 = mem
        .split("MjData ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .unwrap()
        .parse()
        .unwrap();
    assert!(kb > 100.0, "{mem}");
}

/// `--against`: both presets measured in the same rounds, each with its median and end-to-end /
/// raw line, and the speed-up between them equal to the ratio of the two medians.
#[test]
fn bench_train_against_another_preset_reports_both_and_the_speed_up() {
    let out = Command::new(env!("CARGO_BIN_EXE_skillmimic"))
        .args(["bench", "train", "--preset", "tiny", "--against", "cpu", "--rounds", "1"])
        .args(["--warmup", "0", "--num-envs", "8", "--threads", "1", "--set", "ppo.minibatch=128"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}\n{}", String::from_utf8_lossy(&out.stderr));
    let rate = |p: &str| -> f64 {
        let line = text
            .lines()
            .find(|l| l.starts_with(&format!("{p}: median: end-to-end ")))
            .unwrap_or_else(|| panic!("no median line of {p} in\n{text}"));
        line.split("end-to-end ")
            .nth(1)
            .unwrap()
            .split_whitespace()
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    let (tiny, cpu) = (rate("tiny"), rate("cpu"));
    assert!(text.lines().any(|l| l.starts_with("cpu: raw mj_step anchor")), "{text}");
    let speed = text
        .lines()
        .find(|l| l.starts_with("speed-up: preset 'tiny'"))
        .unwrap_or_else(|| panic!("no speed-up line in\n{text}"));
    let x: f64 =
        speed.split(" trains ").nth(1).unwrap().split('x').next().unwrap().parse().unwrap();
    assert!((x - tiny / cpu).abs() <= 0.01 + 0.01 * x, "{speed}: {tiny} / {cpu}");
}
