//! Visual-only task markers (no collision, not part of the simulated model): what a task draws
//! in videos and the interactive viewer — a goal sphere, a ring on the floor, a hoop. Each task
//! builds its own from an information row ([`crate::Task::markers`]); positions are world
//! metres, Z up.

/// A visual geom: a sphere (`radius`), a line segment (`from` → `to`, `radius` = thickness) or
/// a box (`half` = half extents), world frame (m), colour RGBA in [0, 1].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Marker {
    Sphere { pos: [f64; 3], radius: f64, rgba: [f32; 4] },
    Segment { from: [f64; 3], to: [f64; 3], radius: f64, rgba: [f32; 4] },
    Box { pos: [f64; 3], half: [f64; 3], rgba: [f32; 4] },
}

/// Most markers a frame draws (renderers reserve this many user geoms; extra ones are dropped).
pub const MAX_MARKERS: usize = 48;

/// A horizontal ring of `segments` segments, centre `c`, radius `r` (m), thickness `thick` (m).
pub fn ring(
    c: [f64; 3],
    r: f64,
    segments: usize,
    thick: f64,
    rgba: [f32; 4],
    out: &mut Vec<Marker>,
) {
    let p = |k: usize| {
        let a = std::f64::consts::TAU * k as f64 / segments as f64;
        [c[0] + r * a.cos(), c[1] + r * a.sin(), c[2]]
    };
    out.extend((0..segments).map(|k| Marker::Segment {
        from: p(k),
        to: p(k + 1),
        radius: thick,
        rgba,
    }));
}

/// The value of information entry `name` in `row` (`names` = the task's `info_names`).
pub fn entry(names: &[String], row: &[f32], name: &str) -> Option<f64> {
    names.iter().position(|n| n == name).and_then(|i| row.get(i)).map(|&v| v as f64)
}
