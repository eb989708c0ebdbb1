//! `env.hsi.style_motion = ["builtin:walks"]`: the procedural walks of the TokenHSI character
//! serve reference-state initialisation (an episode starts from one of their frames) and the
//! style prior without any file; an unknown `builtin:` name is refused by field.

use skillmimic_env::tasks::hsi::config::{HsiConfig, StateInit};
use skillmimic_env::tasks::hsi::style::{BUILTIN_WALKS, load_style_clips};
use skillmimic_env::{EnvConfig, registry};
use skillmimic_motion::synth_walk::tokenhsi_walks;

fn config(motion: &str) -> EnvConfig {
    let mut cfg =
        EnvConfig { task: "hsi_follow".into(), num_envs: 8, threads: 1, ..Default::default() };
    let h = cfg.table_mut::<HsiConfig>();
    h.state_init = StateInit::Reference;
    h.style_motion = vec![motion.into()];
    cfg
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
