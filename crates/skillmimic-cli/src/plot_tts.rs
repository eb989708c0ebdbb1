//! The time-to-skill figure of `skillmimic plot --evals A --evals B --rate RA --rate RB`
//! (issue 41, docs/throughput.md): the criterion's checkpoint metrics of several runs against
//! samples (left column) and against wall-clock hours (right column). The wall-clock axis is
//! samples ÷ the run's end-to-end rate measured by a quiet `skillmimic bench train` (samples/s),
//! not the run's own logged time, which depends on what else the machine ran beside it.

use std::path::{Path, PathBuf};

use anyhow::bail;

use crate::plot_draw::{COLORS, Panel, SIZE, Series, field, read_log, render, write_png};

/// The rows of the figure: (title, y-axis description, key of `checkpoint_evals.jsonl`).
const ROWS: [(&str, &str, &str); 3] = [
    (
        "Completed from the start (mean action, noise 0.01)",
        "% of 64 episodes",
        "start_eps001_completed_pct",
    ),
    ("E_b-mpjpe (random frames)", "mm", "e_b_mm"),
    ("Mean reward per step", "reward", "reward_per_step"),
];

/// Draw the figure of `files` (label, checkpoint metrics), whose runs train at `rates` samples/s,
/// into `out`: one row per metric of [`ROWS`], samples on the left, hours on the right.
pub fn plot_time_to_skill(
    files: &[(String, PathBuf)],
    rates: &[f64],
    out: &Path,
) -> anyhow::Result<()> {
    if rates.len() != files.len() {
        bail!("--rate: {} rates for {} --evals files; give one per file", rates.len(), files.len());
    }
    if let Some(r) = rates.iter().find(|r| !(r.is_finite() && **r > 0.0)) {
        bail!("--rate: {r} is not a positive number of samples per second");
    }
    if files.len() > COLORS.len() {
        bail!(
            "--evals: {} runs given, a comparison plot holds at most {}",
            files.len(),
            COLORS.len()
        );
    }
    let runs: Vec<(String, Vec<serde_json::Value>, f64)> = files
        .iter()
        .zip(rates)
        .map(|((l, p), &r)| Ok((l.clone(), read_log(p)?, r)))
        .collect::<anyhow::Result<_>>()?;
    let mut panels = Vec::new();
    for (title, y_desc, key) in ROWS {
        for hours in [false, true] {
            let series = runs
                .iter()
                .enumerate()
                .map(|(c, (label, rows, rate))| {
                    let pts = field(rows, key);
                    let points = if hours {
                        pts.into_iter().map(|(s, y)| (s / rate / 3600.0, y)).collect()
                    } else {
                        pts
                    };
                    let name = if hours {
                        format!("{label} ({rate:.0} samples/s)")
                    } else {
                        label.clone()
                    };
                    Series { name, color: COLORS[c], points }
                })
                .collect();
            let x_desc = if hours { "wall-clock hours (samples / rate)" } else { "samples" };
            panels.push(Panel { title, x_desc, y_desc, series });
        }
    }
    let (w, h) = (SIZE.0, SIZE.1 / 2 * ROWS.len() as u32);
    let rgb = render(&panels, w, h)?;
    write_png(out, &rgb, w, h)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two runs at different rates: the figure has three rows, both colours, and the rate checks
    /// name the flag.
    #[test]
    fn two_runs_against_samples_and_hours() {
        let dir = std::env::temp_dir().join(format!("skillmimic-plot-tts-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let files: Vec<(String, PathBuf)> = (0..2)
            .map(|r| {
                let text: String = (1..=8)
                    .map(|k| {
                        let v = serde_json::json!({
                            "iteration": 25 * k, "samples": 204800 * k,
                            "start_eps001_completed_pct": (12 * k * (r + 1)).min(100) as f64,
                            "e_b_mm": 400.0 - 20.0 * k as f64, "reward_per_step": 0.05 + 0.01 * k as f64
                        });
                        format!("{v}\n")
                    })
                    .collect();
                let p = dir.join(format!("run{r}.jsonl"));
                std::fs::write(&p, text).unwrap();
                (format!("run {r}"), p)
            })
            .collect();
        let out = dir.join("tts.png");
        plot_time_to_skill(&files, &[1000.0, 2500.0], &out).unwrap();
        let dec = mujoco_rs::renderer::png::Decoder::new(std::io::BufReader::new(
            std::fs::File::open(&out).unwrap(),
        ));
        let mut reader = dec.read_info().unwrap();
        let mut buf = vec![0u8; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (SIZE.0, SIZE.1 / 2 * 3));
        let has = |c: plotters::style::RGBColor| buf.chunks_exact(3).any(|p| p == [c.0, c.1, c.2]);
        assert!(has(COLORS[0]) && has(COLORS[1]));
        let err = plot_time_to_skill(&files, &[1000.0], &out).unwrap_err().to_string();
        assert!(err.contains("--rate") && err.contains("one per file"), "{err}");
        let err = plot_time_to_skill(&files, &[1000.0, -1.0], &out).unwrap_err().to_string();
        assert!(err.contains("not a positive"), "{err}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
