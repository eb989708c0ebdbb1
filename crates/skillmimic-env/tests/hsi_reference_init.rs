//! Reference-state initialisation of the TokenHSI tasks (`env.hsi.state_init`): an episode starts
//! from a frame of the task's clips, moved to the origin and turned to the rule's heading, with
//! the clip's joint positions; without clips `auto` keeps the rest pose, `reference` refuses.

use skillmimic_core::characters::tokenhsi;
use skillmimic_core::math::{Quat, heading, wrap_angle};
use skillmimic_env::tasks::hsi::config::{HsiConfig, StateInit};
use skillmimic_env::{EnvConfig, registry};
use skillmimic_motion::character_clip::CharacterClip;

/// A two-clip folder: a crouch turned 1 rad about z, placed away from the origin.
fn clips(dir: &std::path::Path) -> Vec<f64> {
    let spec = tokenhsi::spec();
    let mut dof = vec![0.0f64; spec.num_dofs];
    for (k, v) in [(15, -0.9), (18, 1.4), (21, -0.4), (24, -0.9), (27, 1.4), (30, -0.4)] {
        dof[k] = v; // hips, knees, ankles about y
    }
    let frames: Vec<_> = (0..4)
        .map(|t| ([3.0 + 0.05 * t as f64, -2.0, 0.80], Quat::about_z(1.0), dof.clone()))
        .collect();
    std::fs::create_dir_all(dir).unwrap();
    for name in ["a", "b"] {
        let c = CharacterClip::from_frames(&spec, name, "test", 30.0, &frames);
        c.save(&dir.join(format!("{name}.safetensors"))).unwrap();
    }
    dof
}

fn config(state_init: StateInit, clip_dir: Option<&std::path::Path>) -> EnvConfig {
    let mut cfg =
        EnvConfig { task: "hsi_follow".into(), num_envs: 6, threads: 1, ..Default::default() };
    let h = cfg.table_mut::<HsiConfig>();
    h.state_init = state_init;
    h.style_motion = clip_dir.map(|d| vec![d.to_path_buf()]).unwrap_or_default();
    cfg
}

#[test]
fn episodes_start_from_reference_frames_where_the_rule_places_the_character() {
    let dir = std::env::temp_dir().join(format!("hsi_rsi_{}", std::process::id()));
    let dof = clips(&dir);
    let mut env = registry::make(&config(StateInit::Auto, Some(&dir))).expect("env with clips");
    env.reset_all(Some(3));
    let mut headings = Vec::new();
    for i in 0..6 {
        let st = env.mujoco().env_state(i);
        let root = st.pos(0);
        assert!(root[0].abs() < 1e-9 && root[1].abs() < 1e-9, "root at the origin: {root:?}");
        assert!((root[2] - 0.80).abs() < 1e-6, "the clip's height (float32): {root:?}");
        for k in [15usize, 18, 21, 24, 27, 30] {
            assert!(
                (st.dof_pos[k] - dof[k]).abs() < 1e-5,
                "dof {k}: {} vs {}",
                st.dof_pos[k],
                dof[k]
            );
        }
        // the whole pose turned to the rule's heading: upright, as the clip's root
        let up = st.quat(0).rotate([0.0, 0.0, 1.0]);
        assert!((up[2] - 1.0).abs() < 1e-9, "{up:?}");
        headings.push(heading(st.quat(0)));
        // the trajectory starts at the character: the first observed waypoint is at the root
        let o = &env.buffers().obs[i * env.obs_dim()..(i + 1) * env.obs_dim()];
        assert!(o[222].abs() < 1e-5 && o[223].abs() < 1e-5, "{:?}", &o[222..224]);
    }
    assert!(
        headings.iter().any(|h| wrap_angle(h - 1.0).abs() > 0.3),
        "headings are the rule's (random), not the clip's: {headings:?}"
    );
    // `default` keeps the rest pose; `reference` without clips is refused by name
    let mut rest = registry::make(&config(StateInit::Default, Some(&dir))).unwrap();
    rest.reset_all(Some(3));
    let st = rest.mujoco().env_state(0);
    assert!((st.pos(0)[2] - tokenhsi::STANDING_ROOT_HEIGHT).abs() < 1e-9);
    assert!(st.dof_pos.iter().all(|x| x.abs() < 1e-12));
    let e = registry::make(&config(StateInit::Reference, None)).err().expect("refused").to_string();
    assert!(e.contains("env.hsi.state_init") && e.contains("style_motion"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}
