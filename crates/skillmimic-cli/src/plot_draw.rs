//! Drawing for `skillmimic plot`: panels of curves with titles, axis labels, tick numbers and
//! legends, rendered by `plotters` into an RGB buffer with the embedded DejaVu Sans face, and
//! PNG output.

use std::path::Path;
use std::sync::OnceLock;

use anyhow::{Context, bail};
use plotters::prelude::*;

/// DejaVu Sans 2.37 (`assets/fonts/LICENSE-DejaVu.txt`).
pub(crate) static FONT: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");
/// The family name the embedded face is registered under.
pub(crate) const FAMILY: &str = "sans-serif";

/// Register the embedded face with plotters (once per process).
pub(crate) fn register_font() -> anyhow::Result<()> {
    static DONE: OnceLock<Result<(), String>> = OnceLock::new();
    DONE.get_or_init(|| {
        plotters::style::register_font(FAMILY, FontStyle::Normal, FONT)
            .map_err(|_| "the embedded DejaVu Sans font does not parse".to_string())
    })
    .clone()
    .map_err(anyhow::Error::msg)
}

/// One curve of a panel.
pub(crate) struct Series {
    pub(crate) name: String,
    pub(crate) color: RGBColor,
    pub(crate) points: Vec<(f64, f64)>,
}

/// One panel: title, x- and y-axis descriptions, curves.
pub(crate) struct Panel {
    pub(crate) title: &'static str,
    pub(crate) x_desc: &'static str,
    pub(crate) y_desc: &'static str,
    pub(crate) series: Vec<Series>,
}

pub(crate) const COLORS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(23, 190, 207),
];

/// Tick label: `0`, `0.0146`, `12.5`, `150k`, `2.5M`, `3.0e-5`.
pub(crate) fn fmt_num(v: f64) -> String {
    fn trim(s: String) -> String {
        if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s }
    }
    let a = v.abs();
    let s = if a < 1e-12 {
        "0".to_string()
    } else if a >= 1e3 {
        let (div, unit) = if a >= 1e9 {
            (1e9, "G")
        } else if a >= 1e6 {
            (1e6, "M")
        } else {
            (1e3, "k")
        };
        format!("{}{unit}", trim(format!("{:.2}", v / div)))
    } else if a >= 1.0 {
        trim(format!("{v:.3}"))
    } else if a >= 1e-3 {
        trim(format!("{v:.5}"))
    } else {
        format!("{v:.1e}")
    };
    if s == "-0" { "0".to_string() } else { s }
}

pub(crate) fn plot_err(e: impl std::fmt::Display) -> anyhow::Error {
    anyhow::anyhow!("plot: {e}")
}

/// Data range of the finite points of `series` (x, y), padded; a unit range when empty.
pub(crate) fn ranges(series: &[Series]) -> (std::ops::Range<f64>, std::ops::Range<f64>) {
    let finite = || {
        series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .filter(|(x, y)| x.is_finite() && y.is_finite())
    };
    let (mut xmin, mut xmax) =
        finite().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let (mut ymin, mut ymax) =
        finite().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p.1), b.max(p.1)));
    if !(xmin.is_finite() && ymin.is_finite()) {
        return (0.0..1.0, 0.0..1.0);
    }
    if xmax <= xmin {
        xmax = xmin + 1.0;
        xmin -= 1.0;
    }
    if ymax <= ymin {
        ymax = ymin + 1e-6 + ymin.abs() * 0.1;
        ymin -= 1e-6 + ymin.abs() * 0.1;
    }
    let pad = 0.06 * (ymax - ymin);
    (xmin..xmax, ymin - pad..ymax + pad)
}

/// The corner of the plotting area where the legend (one line per series) covers the fewest points.
pub(crate) fn legend_corner(
    series: &[Series],
    xr: &std::ops::Range<f64>,
    yr: &std::ops::Range<f64>,
) -> SeriesLabelPosition {
    let (bw, bh) = (0.35, (0.06 + 0.065 * series.len() as f64).min(0.6));
    let corners = [
        (SeriesLabelPosition::UpperLeft, 0.0, 1.0 - bh),
        (SeriesLabelPosition::UpperRight, 1.0 - bw, 1.0 - bh),
        (SeriesLabelPosition::LowerLeft, 0.0, 0.0),
        (SeriesLabelPosition::LowerRight, 1.0 - bw, 0.0),
    ];
    let covered = |x0: f64, y0: f64| {
        let pts = series.iter().flat_map(|s| s.points.iter());
        pts.filter(|(x, y)| {
            let (u, v) =
                ((x - xr.start) / (xr.end - xr.start), (y - yr.start) / (yr.end - yr.start));
            (x0..=x0 + bw).contains(&u) && (y0..=y0 + bh).contains(&v)
        })
        .count()
    };
    corners.into_iter().min_by_key(|(_, x0, y0)| covered(*x0, *y0)).expect("four corners").0
}

pub(crate) fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    p: &Panel,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let (xr, yr) = ranges(&p.series);
    let corner = legend_corner(&p.series, &xr, &yr);
    let mut chart = ChartBuilder::on(area)
        .caption(p.title, (FAMILY, 22).into_font().color(&BLACK))
        .margin(12)
        .x_label_area_size(46)
        .y_label_area_size(70)
        .build_cartesian_2d(xr, yr)
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .bold_line_style(RGBColor(222, 222, 222))
        .x_labels(6)
        .y_labels(6)
        .x_label_formatter(&|v| fmt_num(*v))
        .y_label_formatter(&|v| fmt_num(*v))
        .label_style((FAMILY, 14).into_font().color(&RGBColor(50, 50, 50)))
        .x_desc(p.x_desc)
        .y_desc(p.y_desc)
        .axis_desc_style((FAMILY, 15).into_font().color(&BLACK))
        .draw()
        .map_err(plot_err)?;
    let mut any = false;
    for s in &p.series {
        let pts: Vec<(f64, f64)> =
            s.points.iter().copied().filter(|(x, y)| x.is_finite() && y.is_finite()).collect();
        if pts.is_empty() {
            continue;
        }
        any = true;
        let color = s.color;
        if pts.len() == 1 {
            chart
                .draw_series(std::iter::once(Circle::new(pts[0], 4, color.filled())))
                .map_err(plot_err)?;
        }
        chart
            .draw_series(LineSeries::new(pts, color.stroke_width(2)))
            .map_err(plot_err)?
            .label(s.name.as_str())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 22, y)], color.stroke_width(3))
            });
    }
    if any {
        chart
            .configure_series_labels()
            .position(corner)
            .margin(8)
            .legend_area_size(28)
            .label_font((FAMILY, 14).into_font().color(&BLACK))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(170, 170, 170))
            .draw()
            .map_err(plot_err)?;
    } else {
        let (w, h) = area.dim_in_pixel();
        let style = (FAMILY, 18).into_font().color(&RGBColor(120, 120, 120)).pos(
            plotters::style::text_anchor::Pos::new(
                plotters::style::text_anchor::HPos::Center,
                plotters::style::text_anchor::VPos::Center,
            ),
        );
        area.draw(&Text::new("no data in the log", (w as i32 / 2, h as i32 / 2), style))
            .map_err(plot_err)?;
    }
    Ok(())
}

/// Render the four panels into an RGB buffer of `width × height`.
pub(crate) fn render(panels: &[Panel], width: u32, height: u32) -> anyhow::Result<Vec<u8>> {
    register_font()?;
    let mut buf = vec![255u8; width as usize * height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        for (area, p) in root.split_evenly((panels.len().div_ceil(2), 2)).iter().zip(panels) {
            draw_panel(area, p)?;
        }
        root.present().map_err(plot_err)?;
    }
    Ok(buf)
}

pub(crate) fn write_png(path: &Path, rgb: &[u8], w: u32, h: u32) -> anyhow::Result<()> {
    use mujoco_rs::renderer::png;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    let tmp = path.with_extension("png.tmp");
    {
        let file = std::fs::File::create(&tmp)
            .with_context(|| format!("cannot create {}", tmp.display()))?;
        let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.write_header()?.write_image_data(rgb)?;
    }
    std::fs::rename(&tmp, path).with_context(|| format!("cannot write {}", path.display()))
}

/// Size of the PNG of `skillmimic plot` with one log (`plot::plot_log`).
pub const SIZE: (u32, u32) = (1200, 800);

pub(crate) fn read_log(path: &Path) -> anyhow::Result<Vec<serde_json::Value>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut rows = Vec::new();
    for (k, line) in text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty()) {
        rows.push(
            serde_json::from_str(line)
                .with_context(|| format!("{}: line {} is not JSON", path.display(), k + 1))?,
        );
    }
    if rows.is_empty() {
        bail!("{}: the log has no iterations yet", path.display());
    }
    Ok(rows)
}

pub(crate) fn field(rows: &[serde_json::Value], key: &str) -> Vec<(f64, f64)> {
    rows.iter().filter_map(|r| Some((r["samples"].as_f64()?, r[key].as_f64()?))).collect()
}
