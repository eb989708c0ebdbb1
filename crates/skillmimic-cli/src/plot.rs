//! `skillmimic plot`: PNG learning curves from a training log (`log.jsonl`), or several runs
//! overlaid for a comparison (`--log A --log B --label a --label b`).
//!
//! One log: four panels against samples: mean reward per step, episode length, the task's reward
//! terms and the losses, each with a title, axis labels with tick numbers and a legend. Several
//! logs (at most six): mean reward per step, episode length, actor loss and critic loss, one
//! curve per run, optionally smoothed (`--smooth N`, trailing moving average). Everything is
//! drawn by `plotters` into an RGB buffer; text goes through its `ab_glyph` rasteriser with the
//! DejaVu Sans face embedded in the binary (`assets/fonts`, Bitstream Vera licence), so no system
//! font is needed (headless machines, fresh CI).

use std::path::{Path, PathBuf};

use anyhow::bail;

use crate::plot_draw::{COLORS, Panel, SIZE, Series, field, read_log, render, write_png};

#[derive(clap::Args)]
pub struct Args {
    /// Training log (one JSON object per iteration); repeat to overlay runs.
    #[arg(long, required_unless_present = "evals", conflicts_with = "evals")]
    pub log: Vec<PathBuf>,
    /// Checkpoint metrics (`checkpoint_evals.jsonl` of `scripts/results/eval_checkpoints.py`):
    /// completion from the clip's start (two test modes), success score, falls, Acc and
    /// E_b-mpjpe against samples; of `scripts/results/eval_tracking_checkpoints.py`: success over
    /// motions and the tracking errors; repeat to overlay runs.
    #[arg(long)]
    pub evals: Vec<PathBuf>,
    /// Samples per second of each `--evals` run (a quiet `skillmimic bench train`, one per file):
    /// the time-to-skill figure instead, completion from the start, E_b-mpjpe and reward per
    /// step against samples (left) and against wall-clock hours = samples ÷ rate (right).
    #[arg(long, requires = "evals")]
    pub rate: Vec<f64>,
    /// Legend label of each `--log` (default: the log's folder name).
    #[arg(long)]
    pub label: Vec<String>,
    /// Comparison plots: mean of each point and the `smooth − 1` before it (trailing moving
    /// average over iterations; 1 = raw).
    #[arg(long, default_value_t = 1)]
    pub smooth: usize,
    /// Output PNG.
    #[arg(long)]
    pub out: PathBuf,
}

fn term(rows: &[serde_json::Value], name: &str) -> Vec<(f64, f64)> {
    rows.iter()
        .filter_map(|r| {
            let v = r["reward_terms"].as_array()?.iter().find(|p| p[0] == name)?[1].as_f64()?;
            Some((r["samples"].as_f64()?, v))
        })
        .collect()
}

/// The reward terms to draw: the imitation task's informative ones (p, r, op, ig, cg; the others
/// are 1 with the paper's weights) when the log has them, else the task's terms except `total`
/// (at most as many as there are colours).
fn term_names(rows: &[serde_json::Value]) -> Vec<String> {
    let names: Vec<String> = rows
        .first()
        .and_then(|r| r["reward_terms"].as_array())
        .map(|a| a.iter().filter_map(|p| p[0].as_str().map(str::to_string)).collect())
        .unwrap_or_default();
    const IMITATION: [&str; 5] = ["p", "r", "op", "ig", "cg"];
    if IMITATION.iter().all(|n| names.iter().any(|m| m == n)) {
        return IMITATION.iter().map(|n| n.to_string()).collect();
    }
    names.into_iter().filter(|n| n != "total").take(COLORS.len()).collect()
}

/// Plot the learning curves of `log` into `out` (a [`SIZE`] PNG).
pub fn plot_log(log: &Path, out: &Path) -> anyhow::Result<()> {
    let rows = read_log(log)?;
    let s = |name: &str, k: usize, points| Series { name: name.into(), color: COLORS[k], points };
    let panels = [
        Panel {
            x_desc: "samples",
            title: "Mean reward per step",
            y_desc: "reward",
            series: vec![s("mean reward", 0, field(&rows, "mean_reward"))],
        },
        Panel {
            x_desc: "samples",
            title: "Episode length",
            y_desc: "steps",
            series: vec![s("episode length", 1, field(&rows, "episode_length"))],
        },
        Panel {
            x_desc: "samples",
            title: "Reward terms",
            y_desc: "mean term value",
            series: term_names(&rows)
                .iter()
                .enumerate()
                .map(|(k, n)| s(&format!("r_{n}"), k, term(&rows, n)))
                .collect(),
        },
        Panel {
            x_desc: "samples",
            title: "Losses",
            y_desc: "loss",
            series: vec![
                s("actor", 0, field(&rows, "actor_loss")),
                s("critic", 1, field(&rows, "critic_loss")),
                s("bounds", 2, field(&rows, "bounds_loss")),
            ],
        },
    ];
    let (w, h) = SIZE;
    let rgb = render(&panels, w, h)?;
    write_png(out, &rgb, w, h)
}

/// Trailing moving average of the y values over `k` points (the first points average what exists).
pub fn smooth(points: &[(f64, f64)], k: usize) -> Vec<(f64, f64)> {
    let k = k.max(1);
    let mut sum = 0.0;
    points
        .iter()
        .enumerate()
        .map(|(i, &(x, y))| {
            sum += y;
            if i >= k {
                sum -= points[i - k].1;
            }
            (x, sum / (i + 1).min(k) as f64)
        })
        .collect()
}

/// Overlay runs (label, JSON-lines file given by `flag`) into `out`: one panel per (title, y-axis
/// description, key), one curve per run, smoothed over `k` points ([`smooth`]).
fn plot_overlay(
    files: &[(String, PathBuf)],
    out: &Path,
    flag: &str,
    k: usize,
    panels: &[(&'static str, &'static str, &str)],
) -> anyhow::Result<()> {
    if files.len() > COLORS.len() {
        bail!(
            "{flag}: {} runs given, a comparison plot holds at most {}",
            files.len(),
            COLORS.len()
        );
    }
    let runs: Vec<(String, Vec<serde_json::Value>)> =
        files.iter().map(|(l, p)| Ok((l.clone(), read_log(p)?))).collect::<anyhow::Result<_>>()?;
    let panels: Vec<Panel> = panels
        .iter()
        .map(|&(title, y_desc, key)| Panel {
            title,
            x_desc: "samples",
            y_desc,
            series: runs
                .iter()
                .enumerate()
                .map(|(c, (label, rows))| Series {
                    name: label.clone(),
                    color: COLORS[c],
                    points: smooth(&field(rows, key), k),
                })
                .collect(),
        })
        .collect();
    // two panels per row, each row [`SIZE`]'s half height
    let (w, h) = (SIZE.0, SIZE.1 / 2 * panels.len().div_ceil(2) as u32);
    let rgb = render(&panels, w, h)?;
    write_png(out, &rgb, w, h)
}

/// Overlay the runs `logs` (label, log) into `out`: reward, episode length and the losses, one
/// curve per run in each panel, each smoothed over `k` iterations ([`smooth`]).
pub fn plot_compare(logs: &[(String, PathBuf)], out: &Path, k: usize) -> anyhow::Result<()> {
    plot_overlay(
        logs,
        out,
        "--log",
        k,
        &[
            ("Mean reward per step", "reward", "mean_reward"),
            ("Episode length", "steps", "episode_length"),
            ("Actor loss", "loss", "actor_loss"),
            ("Critic loss", "loss", "critic_loss"),
        ],
    )
}

/// The panels of imitation checkpoint metrics (`scripts/results/eval_checkpoints.py`):
/// completion from the clip's start (mean action with ε = 0.01 start noise; sampled actions), the
/// SkillMimic success score, falls, Acc and E_b-mpjpe.
const IMITATION_PANELS: [(&str, &str, &str); 6] = [
    (
        "Completed from the clip's start (mean action, start noise 0.01)",
        "% of 64 episodes",
        "start_eps001_completed_pct",
    ),
    (
        "Completed from the clip's start (sampled actions)",
        "% of 64 episodes",
        "start_sampled_completed_pct",
    ),
    (
        "Success score from the start (mean action, noise 0.01)",
        "SkillMimic score",
        "start_eps001_v1_score",
    ),
    ("Falls from random frames", "% of 64 episodes", "falls_pct"),
    ("Acc (random frames)", "%", "acc_pct"),
    ("E_b-mpjpe (random frames)", "mm", "e_b_mm"),
];

/// The panels of tracking checkpoint metrics (`scripts/results/eval_tracking_checkpoints.py`:
/// PHC's evaluation, every motion once): success over motions and the errors over every step.
const TRACKING_PANELS: [(&str, &str, &str); 4] = [
    ("Success (every motion once, 0.5 m)", "% of motions", "success_pct"),
    ("E_g-mpjpe", "mm", "g_mpjpe_mm"),
    ("E_mpjpe (root-relative)", "mm", "mpjpe_mm"),
    ("E_vel", "mm / frame", "vel_err_mm"),
];

/// Overlay checkpoint metrics of runs (label, JSON lines) into `out` against samples, one curve
/// per run (rows without a key are left out of its panel): the tracking panels when the first
/// file's rows carry `g_mpjpe_mm`, else the imitation ones.
pub fn plot_evals(files: &[(String, PathBuf)], out: &Path) -> anyhow::Result<()> {
    let tracking = match files.first() {
        Some((_, p)) => read_log(p)?.iter().any(|r| r.get("g_mpjpe_mm").is_some()),
        None => false,
    };
    let panels: &[(&str, &str, &str)] = if tracking { &TRACKING_PANELS } else { &IMITATION_PANELS };
    plot_overlay(files, out, "--evals", 1, panels)
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let n = a.log.len().max(a.evals.len());
    if !a.label.is_empty() && a.label.len() != n {
        bail!(
            "--label: {} labels for {n} --log/--evals files; give one per file or none",
            a.label.len()
        );
    }
    let name = |p: &Path| {
        p.parent()
            .and_then(|d| d.file_name())
            .map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned())
    };
    let labelled = |files: &[PathBuf]| -> Vec<(String, PathBuf)> {
        files
            .iter()
            .enumerate()
            .map(|(k, p)| (a.label.get(k).cloned().unwrap_or_else(|| name(p)), p.clone()))
            .collect()
    };
    if !a.rate.is_empty() {
        crate::plot_tts::plot_time_to_skill(&labelled(&a.evals), &a.rate, &a.out)?;
    } else if !a.evals.is_empty() {
        plot_evals(&labelled(&a.evals), &a.out)?;
    } else if a.log.len() == 1 {
        plot_log(&a.log[0], &a.out)?;
    } else {
        plot_compare(&labelled(&a.log), &a.out, a.smooth)?;
    }
    tracing::info!("wrote {}", a.out.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot_draw::fmt_num;
    use mujoco_rs::renderer::png;
    use plotters::style::RGBColor;

    fn temp_dir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("skillmimic-plot-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    /// A log shaped like the trainer's `log.jsonl` (the fields the plot reads).
    fn synthetic_log(dir: &Path, iterations: usize) -> PathBuf {
        let mut text = String::new();
        for i in 0..iterations {
            let t = i as f64 / iterations.max(1) as f64;
            let terms: Vec<(String, f64)> = skillmimic_env::reward::TERM_NAMES
                .iter()
                .enumerate()
                .map(|(k, n)| (n.to_string(), 0.2 + 0.5 * t / (1.0 + k as f64)))
                .collect();
            let row = serde_json::json!({
                "iteration": i + 1, "samples": (i + 1) * 512, "mean_reward": 0.015 + 0.03 * t,
                "reward_terms": terms, "episode_length": 20.0 + 40.0 * t,
                "actor_loss": -0.01 * t, "critic_loss": 1.0 - 0.5 * t, "bounds_loss": 0.001,
            });
            text.push_str(&row.to_string());
            text.push('\n');
        }
        let p = dir.join("log.jsonl");
        std::fs::write(&p, text).unwrap();
        p
    }

    /// Checkpoint metrics of two runs plot, one colour each, at the plot's size.
    #[test]
    fn checkpoint_metrics_overlay() {
        let dir = temp_dir("evals");
        let files: Vec<(String, PathBuf)> = (0..2)
            .map(|r| {
                let row = |k: usize| {
                    serde_json::json!({
                        "iteration": 25 * k,
                        "samples": 204800 * k,
                        "start_sampled_completed_pct": 10.0 * (k + r) as f64,
                        "falls_pct": 40.0 - 5.0 * k as f64,
                        "acc_pct": 5.0 + k as f64,
                        "e_b_mm": 500.0 - 20.0 * k as f64
                    })
                };
                let text: String = (1..=6).map(|k| format!("{}\n", row(k))).collect();
                let p = dir.join(format!("run{r}.jsonl"));
                std::fs::write(&p, text).unwrap();
                (format!("run {r}"), p)
            })
            .collect();
        let out = dir.join("metrics.png");
        plot_evals(&files, &out).unwrap();
        let (info, rgb) = decode(&out);
        assert_eq!((info.width, info.height), (SIZE.0, SIZE.1 / 2 * 3), "three rows of two panels");
        let has = |c: RGBColor| rgb.chunks(3).any(|p| p == [c.0, c.1, c.2]);
        assert!(has(COLORS[0]) && has(COLORS[1]) && !has(COLORS[2]), "one colour per run");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Tracking checkpoint metrics (training and held-back motions) plot in two rows of panels.
    #[test]
    fn tracking_checkpoint_metrics_overlay() {
        let dir = temp_dir("tracking-evals");
        let files: Vec<(String, PathBuf)> = ["training", "held-back"]
            .iter()
            .enumerate()
            .map(|(r, label)| {
                let text: String = (1..=5)
                    .map(|k| {
                        let v = serde_json::json!({
                            "iteration": 100 * k,
                            "samples": 204800 * k,
                            "success_pct": 20.0 * (k - r) as f64,
                            "g_mpjpe_mm": 300.0 - 30.0 * k as f64,
                            "mpjpe_mm": 200.0 - 20.0 * k as f64,
                            "vel_err_mm": 40.0 - k as f64
                        });
                        format!("{v}\n")
                    })
                    .collect();
                let p = dir.join(format!("{label}.jsonl"));
                std::fs::write(&p, text).unwrap();
                (label.to_string(), p)
            })
            .collect();
        let out = dir.join("tracking.png");
        plot_evals(&files, &out).unwrap();
        let (info, rgb) = decode(&out);
        assert_eq!((info.width, info.height), (SIZE.0, SIZE.1), "two rows of two panels");
        let has = |c: RGBColor| rgb.chunks(3).any(|p| p == [c.0, c.1, c.2]);
        assert!(has(COLORS[0]) && has(COLORS[1]), "one colour per motion set");
        std::fs::remove_dir_all(&dir).ok();
    }

    fn decode(path: &Path) -> (png::OutputInfo, Vec<u8>) {
        let dec = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
        let mut reader = dec.read_info().unwrap();
        let mut buf = vec![0u8; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        buf.truncate(info.buffer_size());
        (info, buf)
    }

    #[test]
    fn png_decodes_with_the_expected_size_and_has_text() {
        let dir = temp_dir("full");
        let log = synthetic_log(&dir, 40);
        let out = dir.join("sub").join("curve.png");
        plot_log(&log, &out).unwrap();
        let (info, rgb) = decode(&out);
        assert_eq!((info.width, info.height), SIZE);
        assert_eq!((info.color_type, info.bit_depth), (png::ColorType::Rgb, png::BitDepth::Eight));
        // the caption band of the first panel (above the plotting area) holds the title's glyphs:
        // dark pixels, and anti-aliased grey ones (outline fonts, not a bitmap font)
        let w = SIZE.0 as usize;
        let (mut dark, mut grey) = (0, 0);
        for y in 8..36 {
            for x in 0..w / 2 {
                let px = &rgb[3 * (y * w + x)..3 * (y * w + x) + 3];
                let m = *px.iter().max().unwrap();
                if m < 80 {
                    dark += 1;
                } else if px.iter().all(|&c| (100..220).contains(&c)) {
                    grey += 1;
                }
            }
        }
        assert!(dark > 200 && grey > 50, "title not rendered: {dark} dark, {grey} grey pixels");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn one_iteration_and_missing_fields_still_plot() {
        let dir = temp_dir("one");
        let log = dir.join("log.jsonl");
        std::fs::write(&log, "{\"samples\": 512, \"mean_reward\": 0.02}\n").unwrap();
        let out = dir.join("curve.png");
        plot_log(&log, &out).unwrap();
        assert_eq!((decode(&out).0.width, decode(&out).0.height), SIZE);
        std::fs::write(&log, "\n").unwrap();
        assert!(plot_log(&log, &out).is_err());
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn runs_overlay_with_one_colour_each() {
        let (a, b) = (temp_dir("cmp-a"), temp_dir("cmp-b"));
        let logs = [
            ("mlp".to_string(), synthetic_log(&a, 30)),
            ("modular".to_string(), synthetic_log(&b, 20)),
        ];
        let out = a.join("compare.png");
        plot_compare(&logs, &out, 5).unwrap();
        assert_eq!(
            smooth(&[(0.0, 1.0), (1.0, 3.0), (2.0, 5.0), (3.0, 7.0)], 2),
            vec![(0.0, 1.0), (1.0, 2.0), (2.0, 4.0), (3.0, 6.0)]
        );
        let (info, rgb) = decode(&out);
        assert_eq!((info.width, info.height), SIZE);
        let has = |c: RGBColor| rgb.chunks_exact(3).any(|p| p == [c.0, c.1, c.2]);
        assert!(has(COLORS[0]) && has(COLORS[1]), "both runs drawn in their colours");
        let seven: Vec<(String, PathBuf)> =
            (0..7).map(|k| (k.to_string(), logs[0].1.clone())).collect();
        assert!(plot_compare(&seven, &out, 1).unwrap_err().to_string().contains("at most 6"));
        std::fs::remove_dir_all(&a).ok();
        std::fs::remove_dir_all(&b).ok();
    }

    #[test]
    fn tick_labels_are_short() {
        for (v, s) in [
            (0.0, "0"),
            (0.0146, "0.0146"),
            (12.5, "12.5"),
            (150_000.0, "150k"),
            (2_500_000.0, "2.5M"),
            (3e-5, "3.0e-5"),
            (-0.25, "-0.25"),
            (-1e-15, "0"),
        ] {
            assert_eq!(fmt_num(v), s);
        }
    }
}
