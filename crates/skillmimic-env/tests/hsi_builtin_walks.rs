//! `env.hsi.style_motion = ["builtin:walks"]`: the procedural walks of the TokenHSI character
//! serve reference-state initialisation (an episode starts from one of their frames) and the
//! style prior without any file; an unknown `builtin:` name is refused by field.

use skillmimic_env::tasks::hsi::config::{HsiConfig, StateInit};
use skillmimic_env::tasks::hsi::style::{BUILTIN_WALKS, load_style_clips};
use skillmimic_env::{EnvConfig, registry};
use skillmimic_motion::synth_walk::tokenhsi_walks;

/// `task` on `num_envs` environments (one thread) with reference-state initialisation, the
/// HSI table then set by `set`.
fn reference_starts(task: &str, num_envs: usize, set: impl FnOnce(&mut HsiConfig)) -> EnvConfig {
    let mut cfg = EnvConfig { task: task.into(), num_envs, threads: 1, ..Default::default() };
    let h = cfg.table_mut::<HsiConfig>();
    h.state_init = StateInit::Reference;
    set(h);
    cfg
}

fn config(motion: &str) -> EnvConfig {
    reference_starts("hsi_follow", 8, |h| h.style_motion = vec![motion.into()])
}

#[test]
fn builtin_walks_start_episodes_from_walking_frames() {
    let walks = tokenhsi_walks();
    let loaded = load_style_clips(&[BUILTIN_WALKS.into()]).unwrap();
    assert_eq!(loaded, walks, "the built-in set is synth_walk's clips");
    let mut env = registry::make(&config(BUILTIN_WALKS)).expect("hsi_follow with builtin:walks");
    env.reset_all(Some(5));
    for i in 0..8 {
        let st = env.mujoco().env_state(i);
        // the joint coordinates are those of some frame of some walk (float32 storage)
        let found = walks.iter().any(|c| {
            (0..c.num_frames).any(|t| {
                c.dof_at(t).iter().zip(st.dof_pos).all(|(&a, &b)| (a as f64 - b).abs() < 1e-5)
            })
        });
        assert!(found, "env {i}: its pose is no frame of the walks");
        // a walking frame stands at walking height
        let z = st.pos(0)[2];
        assert!((0.85..0.96).contains(&z), "env {i}: pelvis at {z}");
    }
}

#[test]
fn an_unknown_builtin_motion_set_is_refused_by_field() {
    let e = registry::make(&config("builtin:dance")).err().expect("refused").to_string();
    assert!(e.contains("env.hsi.style_motion") && e.contains("builtin:walks"), "{e}");
}

/// `hsi_sit` with `env.hsi.sit.style_motion = ["builtin:sit"]`: a reference start is a frame of
/// the sit clip whose seat height is nearest the episode's seat, placed where the clip has the
/// character relative to its seat and turned to the seat's yaw.
#[test]
fn builtin_sits_start_where_the_clip_has_the_character_relative_to_the_seat() {
    use skillmimic_core::math::{heading, wrap_angle};
    use skillmimic_env::tasks::hsi::style::BUILTIN_SITS;
    use skillmimic_motion::synth_sit::tokenhsi_sits;
    let cfg = reference_starts("hsi_sit", 16, |h| h.sit.style_motion = vec![BUILTIN_SITS.into()]);
    let above = cfg.table::<HsiConfig>().sit.target_above_seat;
    let mut env = registry::make(&cfg).expect("hsi_sit with builtin:sit");
    env.reset_all(Some(2));
    let sits = tokenhsi_sits();
    let ni = env.spec().info_names.len();
    let mut seated = 0;
    for i in 0..16 {
        let st = env.mujoco().env_state(i);
        let info = &env.buffers().info[i * ni..(i + 1) * ni];
        let top = [info[0] as f64, info[1] as f64, info[2] as f64 - above];
        let yaw = info[6] as f64;
        let (s, t) = sits
            .iter()
            .flat_map(|s| (0..s.clip.num_frames).map(move |t| (s, t)))
            .find(|(s, t)| {
                s.clip.dof_at(*t).iter().zip(st.dof_pos).all(|(&a, &b)| (a as f64 - b).abs() < 1e-5)
            })
            .expect("the start is a frame of a sit clip");
        assert!(
            (s.seat_top[2] - top[2]).abs() <= 0.0125 + 1e-6,
            "env {i}: clip seat {} vs {}",
            s.seat_top[2],
            top[2]
        );
        let c = s.clip.root_pos_at(t);
        let (dx, dy) = (c[0] - s.seat_top[0], c[1] - s.seat_top[1]);
        let (sn, cs) = yaw.sin_cos();
        let want = [top[0] + cs * dx - sn * dy, top[1] + sn * dx + cs * dy, c[2]];
        let root = st.pos(0);
        for k in 0..3 {
            assert!((root[k] - want[k]).abs() < 1e-4, "env {i}: root {root:?}, want {want:?}");
        }
        assert!(
            wrap_angle(heading(st.quat(0)) - yaw).abs() < 1e-4,
            "env {i}: faces the seat's front"
        );
        seated += usize::from(t + 1 == s.clip.num_frames || c[2] < 0.7);
    }
    assert!(seated > 0 && seated < 16, "starts both standing and seated: {seated} of 16 low");
}

/// `hsi_carry` with `env.hsi.carry.style_motion = ["builtin:carry"]`: a reference start is a frame
/// of the carrying clip whose cube is nearest the episode's box, placed as the rule places the
/// character, and the box starts in the hands where the clip has it — if its size is a clip's
/// (within `HELD_SIDE_TOLERANCE`); any other box stays where the rule put it.
#[test]
fn builtin_carries_start_with_the_box_in_the_hands_when_its_size_is_a_clips() {
    use skillmimic_core::characters::tokenhsi::{HANDS, NUM_BODIES};
    use skillmimic_env::tasks::hsi::reference_init::HELD_SIDE_TOLERANCE;
    use skillmimic_env::tasks::hsi::style::BUILTIN_CARRIES;
    use skillmimic_motion::synth_carry::tokenhsi_carries;
    let cfg =
        reference_starts("hsi_carry", 32, |h| h.carry.style_motion = vec![BUILTIN_CARRIES.into()]);
    let mut env = registry::make(&cfg).expect("hsi_carry with builtin:carry");
    env.reset_all(Some(3));
    let carries = tokenhsi_carries();
    let ni = env.spec().info_names.len();
    let (mut held, mut left) = (0, 0);
    for i in 0..32 {
        let st = env.mujoco().env_state(i);
        let info = &env.buffers().info[i * ni..(i + 1) * ni];
        let side = 2.0 * info[6] as f64; // the box's half extents follow target and start
        let (c, _) = carries
            .iter()
            .flat_map(|c| (0..c.clip.num_frames).map(move |t| (c, t)))
            .find(|(c, t)| {
                c.clip.dof_at(*t).iter().zip(st.dof_pos).all(|(&a, &b)| (a as f64 - b).abs() < 1e-5)
            })
            .expect("the start is a frame of a carrying clip");
        let nearest = carries.iter().map(|c| (c.side - side).abs()).fold(f64::INFINITY, f64::min);
        assert!(
            (c.side - side).abs() <= nearest + 1e-6,
            "env {i}: clip {} for a {side} m box",
            c.side
        );
        let (h0, h1) = (st.pos(HANDS[0]), st.pos(HANDS[1]));
        let hands = [0.5 * (h0[0] + h1[0]), 0.5 * (h0[1] + h1[1]), 0.5 * (h0[2] + h1[2])];
        let b = st.pos(NUM_BODIES);
        let gap =
            ((hands[0] - b[0]).powi(2) + (hands[1] - b[1]).powi(2) + (hands[2] - b[2]).powi(2))
                .sqrt();
        if nearest <= HELD_SIDE_TOLERANCE + 1e-6 {
            let r = st.quat(0).rotate(c.box_in_root);
            let root = st.pos(0);
            for k in 0..3 {
                assert!((b[k] - root[k] - r[k]).abs() < 1e-4, "env {i}: box {b:?}");
            }
            assert!(gap < 1e-3, "env {i}: hands' mean {gap} m from the box");
            // moving with the root: the box's velocity is the root's at standstill of ω
            let (vb, vr) = (st.linvel(NUM_BODIES), st.linvel(0));
            assert!((vb[0] - vr[0]).abs() < 0.5 && (vb[1] - vr[1]).abs() < 0.5, "env {i}");
            held += 1;
        } else {
            assert!(gap > 0.3, "env {i}: a {side} m box is not put into the hands");
            left += 1;
        }
    }
    assert!(held > 0 && left > 0, "both cases: {held} held, {left} left");
}

/// `hsi_climb` with `env.hsi.climb.style_motion = ["builtin:climb"]`: a reference start is a frame
/// of the step-up of the nearest platform height, placed against a face of the episode's
/// platform: facing across that face, with every foot the clip has on the top standing on the
/// platform's footprint at the top's height, and every foot it has on the floor off it.
#[test]
fn builtin_climbs_start_against_a_face_of_the_platform() {
    use skillmimic_core::characters::tokenhsi::FEET;
    use skillmimic_core::math::{Quat, heading, wrap_angle};
    use skillmimic_env::tasks::hsi::style::BUILTIN_CLIMBS;
    use skillmimic_motion::synth_climb::tokenhsi_climbs;
    let cfg =
        reference_starts("hsi_climb", 32, |h| h.climb.style_motion = vec![BUILTIN_CLIMBS.into()]);
    let mut env = registry::make(&cfg).expect("hsi_climb with builtin:climb");
    env.reset_all(Some(4));
    let climbs = tokenhsi_climbs();
    let ni = env.spec().info_names.len();
    let (mut on_top, mut on_floor) = (0, 0);
    for i in 0..32 {
        let st = env.mujoco().env_state(i);
        let info: Vec<f64> =
            env.buffers().info[i * ni..(i + 1) * ni].iter().map(|&x| x as f64).collect();
        let (pos, yaw, lo, hi) =
            ([info[3], info[4], info[5]], info[6], &info[7..10], &info[10..13]);
        let top = pos[2] + hi[2];
        let (c, t) = climbs
            .iter()
            .flat_map(|c| (0..c.clip.num_frames).map(move |t| (c, t)))
            .filter(|(c, t)| {
                // the same pose at the same height (the first and last frames share their pose)
                let z = c.clip.root_pos_at(*t)[2] + (top - c.edge[2]).max(0.0);
                (z - st.pos(0)[2]).abs() < 1e-4
                    && c.clip
                        .dof_at(*t)
                        .iter()
                        .zip(st.dof_pos)
                        .all(|(&a, &b)| (a as f64 - b).abs() < 1e-5)
            })
            // the standing frames at the start are the same in every clip: the nearest height's
            .min_by(|a, b| (a.0.edge[2] - top).abs().total_cmp(&(b.0.edge[2] - top).abs()))
            .expect("the start is a frame of a step-up");
        assert!(
            (c.edge[2] - top).abs() <= 0.025 + 1e-6,
            "env {i}: clip {} for a {top} m platform",
            c.edge[2]
        );
        // facing across a face: the heading is the platform's yaw plus a multiple of 90°
        let rel = wrap_angle(heading(st.quat(0)) - yaw);
        let quarter = (rel / std::f64::consts::FRAC_PI_2).round() * std::f64::consts::FRAC_PI_2;
        assert!((rel - quarter).abs() < 1e-4, "env {i}: heading {rel} rad from the platform's yaw");
        let inv = Quat::about_z(yaw).conj();
        for f in FEET {
            let [clip_x, _, clip_z] = c.clip.body_pos_at(t, f);
            let w = st.pos(f);
            let l = inv.rotate([w[0] - pos[0], w[1] - pos[1], 0.0]);
            let inside = (lo[0]..=hi[0]).contains(&l[0]) && (lo[1]..=hi[1]).contains(&l[1]);
            if clip_z > c.edge[2] + 0.03 && clip_z < c.edge[2] + 0.12 && clip_x > c.edge[0] {
                // over the clip's top, standing or nearly
                assert!(inside, "env {i} frame {t}: a foot on the top lands off the platform");
                let lift = (top - c.edge[2]).max(0.0);
                assert!((w[2] - clip_z - lift).abs() < 1e-4, "env {i}: foot height");
                on_top += 1;
            } else if clip_z < 0.12 && clip_x < c.edge[0] - 0.1 {
                assert!(
                    !inside,
                    "env {i} frame {t}: a foot on the floor stands inside the platform: {l:?} in \
                    {lo:?}..{hi:?}, platform at {pos:?} yaw {yaw}, root {:?} heading {}",
                    st.pos(0),
                    heading(st.quat(0))
                );
                on_floor += 1;
            }
        }
    }
    assert!(
        on_top > 0 && on_floor > 0,
        "both kinds of start: {on_top} feet on top, {on_floor} on the floor"
    );
}
