//! Visual-only task markers in videos (no collision, not in the simulated model — as in the
//! original): the target of `heading` (a red sphere at the target point), the circle of
//! `circling` (its centre and the ring on the floor) and the hoop of `scoring` (a ring of rim
//! radius at the basket point with a backboard). Built from the task's information entries
//! (`goal_x`, `goal_y`, `radius`: world metres) of the filmed environment.

use skillmimic_env::EnvConfig;
use skillmimic_env::tasks::hlc::config::HeadingConfig;
use skillmimic_env::tasks::hlc::config::ScoringConfig;

/// A visual geom: a sphere (`radius`) or a line segment (`from` → `to`, `radius` = thickness).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Marker {
    Sphere { pos: [f64; 3], radius: f64, rgba: [f32; 4] },
    Segment { from: [f64; 3], to: [f64; 3], radius: f64, rgba: [f32; 4] },
    Box { pos: [f64; 3], half: [f64; 3], rgba: [f32; 4] },
}

/// Most markers a frame draws (the renderer reserves this many user geoms).
pub const MAX_MARKERS: usize = 48;

/// Rim radius of a basketball hoop (m).
const RIM: f64 = 0.23;

fn ring(c: [f64; 3], r: f64, segments: usize, thick: f64, rgba: [f32; 4], out: &mut Vec<Marker>) {
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

/// The markers of `task` for one environment's information row (`names` = the task's
/// `info_names`).
pub fn task_markers(cfg: &EnvConfig, names: &[String], info: &[f32]) -> Vec<Marker> {
    let get = |k: &str| names.iter().position(|n| n == k).map(|i| info[i] as f64);
    let (Some(x), Some(y)) = (get("goal_x"), get("goal_y")) else { return Vec::new() };
    let mut out = Vec::new();
    match cfg.task.as_str() {
        "heading" => {
            out.push(Marker::Sphere {
                pos: [x, y, cfg.table::<HeadingConfig>().target_height],
                radius: 0.12,
                rgba: [0.9, 0.1, 0.1, 0.8],
            });
            out.push(Marker::Segment {
                from: [x, y, 0.0],
                to: [x, y, cfg.table::<HeadingConfig>().target_height],
                radius: 0.01,
                rgba: [0.9, 0.1, 0.1, 0.6],
            });
        }
        "circling" => {
            out.push(Marker::Sphere {
                pos: [x, y, 0.05],
                radius: 0.08,
                rgba: [0.1, 0.3, 0.9, 0.8],
            });
            if let Some(r) = get("radius") {
                ring([x, y, 0.01], r, 40, 0.015, [0.1, 0.3, 0.9, 0.7], &mut out);
            }
        }
        "scoring" => {
            let h = cfg.table::<ScoringConfig>().basket_height;
            let orange = [1.0, 0.45, 0.0, 1.0];
            ring([x, y, h], RIM, 24, 0.012, orange, &mut out);
            // backboard behind the rim (on the far side seen from the origin of the goal's
            // direction is unknown: put it on +x of the rim), and a pole
            out.push(Marker::Box {
                pos: [x + RIM + 0.15, y, h + 0.3],
                half: [0.015, 0.9, 0.55],
                rgba: [0.95, 0.95, 0.95, 0.6],
            });
            out.push(Marker::Segment {
                from: [x + RIM + 0.2, y, 0.0],
                to: [x + RIM + 0.2, y, h + 0.3],
                radius: 0.04,
                rgba: [0.3, 0.3, 0.3, 1.0],
            });
        }
        _ => {}
    }
    out.truncate(MAX_MARKERS);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markers_follow_the_goal_entries() {
        let names: Vec<String> =
            ["goal_x", "goal_y", "radius"].iter().map(|s| s.to_string()).collect();
        let mut cfg = EnvConfig { task: "circling".into(), ..Default::default() };
        let m = task_markers(&cfg, &names, &[1.0, 2.0, 3.0]);
        assert_eq!(m.len(), 41);
        let Marker::Segment { from, .. } = m[1] else { panic!("ring segment") };
        assert!(((from[0] - 1.0).hypot(from[1] - 2.0) - 3.0).abs() < 1e-9);
        cfg.task = "scoring".into();
        assert!(
            matches!(task_markers(&cfg, &names, &[1.0, 2.0, 0.0])[0], Marker::Segment { from, .. } if (from[2] - 2.5).abs() < 1e-12)
        );
        cfg.task = "throwing".into();
        assert!(task_markers(&cfg, &[], &[]).is_empty());
    }
}
