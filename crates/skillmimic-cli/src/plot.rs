//! `skillmimic plot`: PNG learning curves from a training log (`log.jsonl`).
//!
//! Four panels against samples: mean reward per step, episode length, the imitation sub-rewards
//! and the losses. Lines are drawn with `plotters` into an RGB buffer; labels use the public-domain
//! 8×8 bitmap glyphs of `font8x8`, so no system font is needed (headless machines).

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use font8x8::UnicodeFonts;
use plotters::prelude::*;

#[derive(clap::Args)]
pub struct Args {
    /// Training log (one JSON object per iteration).
    #[arg(long)]
    pub log: PathBuf,
    /// Output PNG.
    #[arg(long)]
    pub out: PathBuf,
}

/// One curve of a panel.
struct Series {
    name: String,
    color: RGBColor,
    points: Vec<(f64, f64)>,
}

const COLORS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(23, 190, 207),
];

fn read_log(path: &Path) -> anyhow::Result<Vec<serde_json::Value>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut rows = Vec::new();
    for (k, line) in text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty()) {
        rows.push(serde_json::from_str(line).with_context(|| format!("{}: line {} is not JSON", path.display(), k + 1))?);
    }
    if rows.is_empty() {
        bail!("{}: the log has no iterations yet", path.display());
    }
    Ok(rows)
}

fn field(rows: &[serde_json::Value], key: &str) -> Vec<(f64, f64)> {
    rows.iter().filter_map(|r| Some((r["samples"].as_f64()?, r[key].as_f64()?))).collect()
}

fn term(rows: &[serde_json::Value], name: &str) -> Vec<(f64, f64)> {
    rows.iter()
        .filter_map(|r| {
            let v = r["reward_terms"].as_array()?.iter().find(|p| p[0] == name)?[1].as_f64()?;
            Some((r["samples"].as_f64()?, v))
        })
        .collect()
}

/// Draw `text` with 8×8 glyphs scaled by `scale` at pixel (x, y) (top-left).
fn draw_text(buf: &mut [u8], w: usize, h: usize, x: i32, y: i32, text: &str, scale: i32, color: (u8, u8, u8)) {
    let mut cx = x;
    for ch in text.chars() {
        if let Some(glyph) = font8x8::BASIC_FONTS.get(ch) {
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..8 {
                    if bits & (1 << col) == 0 {
                        continue;
                    }
                    for dy in 0..scale {
                        for dx in 0..scale {
                            let px = cx + col * scale + dx;
                            let py = y + row as i32 * scale + dy;
                            if px >= 0 && py >= 0 && (px as usize) < w && (py as usize) < h {
                                let i = 3 * (py as usize * w + px as usize);
                                buf[i..i + 3].copy_from_slice(&[color.0, color.1, color.2]);
                            }
                        }
                    }
                }
            }
        }
        cx += 8 * scale;
    }
}

fn fmt_num(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) { format!("{v:.1e}") } else if a >= 100.0 { format!("{v:.0}") } else { format!("{v:.3}") }
}

/// Panel geometry: pixel box and data ranges.
struct Panel {
    x0: i32,
    y0: i32,
    w: i32,
    h: i32,
    title: String,
    series: Vec<Series>,
}

fn render(panels: &[Panel], width: usize, height: usize) -> anyhow::Result<Vec<u8>> {
    let mut buf = vec![255u8; width * height * 3];
    let mut labels: Vec<(i32, i32, String, (u8, u8, u8), i32)> = Vec::new();
    {
        let root = BitMapBackend::with_buffer(&mut buf, (width as u32, height as u32)).into_drawing_area();
        for p in panels {
            let (l, t, r, b) = (p.x0 + 70, p.y0 + 30, p.x0 + p.w - 10, p.y0 + p.h - 40);
            let all: Vec<(f64, f64)> = p.series.iter().flat_map(|s| s.points.iter().copied()).filter(|(x, y)| x.is_finite() && y.is_finite()).collect();
            labels.push((p.x0 + 8, p.y0 + 6, p.title.clone(), (0, 0, 0), 2));
            root.draw(&Rectangle::new([(l, t), (r, b)], BLACK.stroke_width(1))).map_err(|e| anyhow::anyhow!("plot: {e}"))?;
            if all.is_empty() {
                continue;
            }
            let (mut xmin, mut xmax) = all.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p.0), b.max(p.0)));
            let (mut ymin, mut ymax) = all.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p.1), b.max(p.1)));
            if xmax <= xmin {
                xmax = xmin + 1.0;
                xmin -= 1.0;
            }
            if ymax <= ymin {
                ymax = ymin + 1e-6 + ymin.abs() * 0.1;
                ymin -= 1e-6 + ymin.abs() * 0.1;
            }
            let pad = 0.05 * (ymax - ymin);
            let (ymin, ymax) = (ymin - pad, ymax + pad);
            let px = |x: f64| l + ((x - xmin) / (xmax - xmin) * (r - l) as f64) as i32;
            let py = |y: f64| b - ((y - ymin) / (ymax - ymin) * (b - t) as f64) as i32;
            for k in 0..=4 {
                let yv = ymin + (ymax - ymin) * k as f64 / 4.0;
                let yp = py(yv);
                root.draw(&PathElement::new(vec![(l, yp), (r, yp)], RGBColor(225, 225, 225).stroke_width(1))).map_err(|e| anyhow::anyhow!("plot: {e}"))?;
                labels.push((p.x0 + 2, yp - 4, fmt_num(yv), (60, 60, 60), 1));
                let xv = xmin + (xmax - xmin) * k as f64 / 4.0;
                labels.push((px(xv) - 16, b + 6, fmt_num(xv), (60, 60, 60), 1));
            }
            for (k, s) in p.series.iter().enumerate() {
                let pts: Vec<(i32, i32)> = s.points.iter().filter(|(x, y)| x.is_finite() && y.is_finite()).map(|&(x, y)| (px(x), py(y))).collect();
                if pts.len() == 1 {
                    root.draw(&Circle::new(pts[0], 3, s.color.filled())).map_err(|e| anyhow::anyhow!("plot: {e}"))?;
                }
                root.draw(&PathElement::new(pts, s.color.stroke_width(2))).map_err(|e| anyhow::anyhow!("plot: {e}"))?;
                labels.push((l + 8 + 90 * k as i32, t + 6, s.name.clone(), (s.color.0, s.color.1, s.color.2), 1));
            }
            labels.push((r - 60, b + 22, "samples".into(), (60, 60, 60), 1));
        }
        root.present().map_err(|e| anyhow::anyhow!("plot: {e}"))?;
    }
    for (x, y, text, color, scale) in labels {
        draw_text(&mut buf, width, height, x, y, &text, scale, color);
    }
    Ok(buf)
}

fn write_png(path: &Path, rgb: &[u8], w: usize, h: usize) -> anyhow::Result<()> {
    use mujoco_rs::renderer::png;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    let tmp = path.with_extension("png.tmp");
    {
        let file = std::fs::File::create(&tmp).with_context(|| format!("cannot create {}", tmp.display()))?;
        let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w as u32, h as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.write_header()?.write_image_data(rgb)?;
    }
    std::fs::rename(&tmp, path).with_context(|| format!("cannot write {}", path.display()))
}

/// Plot the learning curves of `log` into `out`.
pub fn plot_log(log: &Path, out: &Path) -> anyhow::Result<()> {
    let rows = read_log(log)?;
    let (w, h) = (1200usize, 800usize);
    let (pw, ph) = ((w / 2) as i32, (h / 2) as i32);
    let s = |name: &str, k: usize, points| Series { name: name.into(), color: COLORS[k], points };
    let panels = vec![
        Panel { x0: 0, y0: 0, w: pw, h: ph, title: "mean reward per step".into(), series: vec![s("reward", 0, field(&rows, "mean_reward"))] },
        Panel { x0: pw, y0: 0, w: pw, h: ph, title: "episode length (steps)".into(), series: vec![s("length", 1, field(&rows, "episode_length"))] },
        Panel {
            x0: 0,
            y0: ph,
            w: pw,
            h: ph,
            title: "sub-rewards".into(),
            series: ["p", "r", "op", "ig", "cg"].iter().enumerate().map(|(k, n)| s(&format!("r_{n}"), k, term(&rows, n))).collect(),
        },
        Panel {
            x0: pw,
            y0: ph,
            w: pw,
            h: ph,
            title: "losses".into(),
            series: vec![s("actor", 0, field(&rows, "actor_loss")), s("critic", 1, field(&rows, "critic_loss")), s("bounds", 2, field(&rows, "bounds_loss"))],
        },
    ];
    let rgb = render(&panels, w, h)?;
    write_png(out, &rgb, w, h)
}

pub fn run(a: Args) -> anyhow::Result<()> {
    plot_log(&a.log, &a.out)?;
    tracing::info!("wrote {}", a.out.display());
    Ok(())
}
