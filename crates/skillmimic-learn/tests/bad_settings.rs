//! Hostile and broken settings (issue 19): out-of-range configuration values, crafted checkpoint
//! metadata and normaliser statistics, and absurd thread counts are refused at once with an error
//! naming the file (for checkpoints), the key and the valid range — never a panic or silent NaN.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use rand::SeedableRng;
use skillmimic_core::tensorfile::{OwnedTensor, TensorFile, write_atomic};
use skillmimic_learn::checkpoint::{self, Progress};
use skillmimic_learn::config::{PpoConfig, TrainConfig};
use skillmimic_learn::config_presets::PRESETS;
use skillmimic_learn::policy::Policy;

/// The error of `key=value` over the `tiny` preset (the assignment itself must be accepted:
/// the value has the key's type).
fn refused(assignment: &str) -> String {
    let mut c = TrainConfig::preset("tiny").unwrap();
    c.set(assignment).unwrap_or_else(|e| panic!("{assignment}: the override itself failed: {e}"));
    let e = c.validate().expect_err(assignment).to_string();
    let ranges = c.validate_ranges().expect_err(assignment).to_string();
    assert_eq!(e, ranges, "the range check comes first");
    e
}

#[test]
fn out_of_range_settings_name_the_key_the_value_and_the_range() {
    let cases = [
        ("ppo.gamma=2", "config field 'ppo.gamma': 2 is outside the valid range (0, 1]"),
        ("ppo.lr=1e30", "config field 'ppo.lr': 1e30 is outside the valid range (0, 1000]"),
        ("ppo.norm_clip=-1", "config field 'ppo.norm_clip': -1 is outside the valid range (0, ∞)"),
        (
            "ppo.norm_clip=nan",
            "config field 'ppo.norm_clip': is not a finite number (NaN or infinite); valid range \
                (0, ∞)",
        ),
        (
            "env.termination_height=nan",
            "config field 'env.termination_height': is not a finite number (NaN or infinite); \
                valid range finite",
        ),
        ("ppo.log_std=50", "config field 'ppo.log_std': 50 is outside the valid range [-20, 2]"),
        ("ppo.lam=0", "config field 'ppo.lam': 0 is outside the valid range (0, 1]"),
        (
            "env.threads=100000",
            "config field 'env.threads': 100000 is outside the valid range [0, 1024]",
        ),
        (
            "run.learner_threads=5000",
            "config field 'run.learner_threads': 5000 is outside the valid range [0, 1024]",
        ),
        (
            "env.reward.w_p=-1",
            "config field 'env.reward.w_p': -1 is outside the valid range [0, ∞)",
        ),
        (
            "env.v2.bridge.tau=1",
            "config field 'env.v2.bridge.tau': 1 is outside the valid range (0, 1)",
        ),
        ("ppo.hidden=[64, 0]", "config field 'ppo.hidden[1]': 0 is outside the valid range [1, ∞)"),
        (
            "env.tracking.weights=[0.5, inf, 0.1, 0.1]",
            "config field 'env.tracking.weights[1]': is not a finite number",
        ),
        ("ppo.amp.lr=-1", "config field 'ppo.amp.lr': -1 is outside the valid range [0, 1000]"),
    ];
    for (assignment, want) in cases {
        let e = refused(assignment);
        assert!(e.starts_with(want), "{assignment}: got\n  {e}\nwant\n  {want}");
    }
    // a learning rate of 1e3 is inside the range: divergence detection, not the range, stops it
    let mut c = TrainConfig::preset("tiny").unwrap();
    c.set("ppo.lr=1e3").unwrap();
    c.validate().unwrap();
}

#[test]
fn every_preset_and_the_defaults_are_in_range() {
    // (the bare defaults pair the paper's minibatch with 64 environments: only their ranges)
    TrainConfig::default().validate_ranges().unwrap();
    for p in PRESETS {
        TrainConfig::preset(p).unwrap().validate().unwrap_or_else(|e| panic!("preset {p}: {e}"));
    }
    let mut hl = TrainConfig::preset("small").unwrap();
    hl.env.task = "heading".into();
    hl.use_high_level_defaults();
    hl.validate_ranges().unwrap();
}

#[test]
fn an_absurd_thread_count_is_refused_at_once() {
    let mut c = TrainConfig::preset("tiny").unwrap();
    c.set("env.threads=100000").unwrap();
    let t = Instant::now();
    let e = skillmimic_env::registry::make(&c.env).err().expect("refused").to_string();
    assert!(e.contains("'env.threads'") && e.contains("[0, 1024]"), "{e}");
    assert!(t.elapsed() < Duration::from_secs(5), "refused at once, took {:?}", t.elapsed());
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    assert_eq!(
        skillmimic_env::config_range::capped_threads(1000, "env.threads"),
        (4 * cores).min(1000)
    );
    assert_eq!(
        skillmimic_env::config_range::capped_threads(0, "env.threads"),
        0,
        "0 = one per core"
    );
    assert_eq!(skillmimic_env::config_range::capped_threads(cores, "env.threads"), cores);
}

fn scratch(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("sm-bad-settings-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A valid small policy checkpoint at `dir/name`.
fn valid_checkpoint(dir: &Path, name: &str) -> PathBuf {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
    let cfg = PpoConfig { hidden: vec![8], ..Default::default() };
    let p = Policy::new(6, 3, &cfg, &mut rng);
    let path = dir.join(name);
    checkpoint::save(
        &path,
        &p,
        None,
        &Progress::default(),
        &TrainConfig::preset("tiny").unwrap().to_toml(),
    )
    .unwrap();
    checkpoint::load(&path, None).expect("the unmodified file loads");
    path
}

/// Rewrite the checkpoint at `path` with `edit` applied to its metadata and float64 tensors.
fn craft(
    path: &Path,
    edit: impl FnOnce(&mut BTreeMap<String, String>, &mut BTreeMap<String, Vec<f64>>),
) {
    let f = TensorFile::open(path).unwrap();
    let mut meta = f.metadata().clone();
    let (mut f32s, mut f64s) = (Vec::new(), BTreeMap::new());
    for name in f.names() {
        let rank = f.shape(&name).unwrap().len();
        let any = vec![None; rank];
        if name.contains("_norm.") {
            let (shape, data) = f.f64(&name, &any).unwrap();
            f64s.insert(name, (shape, data));
        } else {
            let (shape, data) = f.f32(&name, &any).unwrap();
            f32s.push(OwnedTensor::f32(&name, &shape, &data));
        }
    }
    let mut values: BTreeMap<String, Vec<f64>> =
        f64s.iter().map(|(k, (_, v))| (k.clone(), v.clone())).collect();
    edit(&mut meta, &mut values);
    for (name, (shape, _)) in &f64s {
        f32s.push(OwnedTensor::f64(name, shape, &values[name]));
    }
    drop(f);
    write_atomic(path, &f32s, &meta).unwrap();
}

/// `checkpoint::load` and `load_with_config` refuse the crafted file; the message names the file
/// and every string of `want`.
fn assert_refused(path: &Path, want: &[&str]) {
    for e in [
        checkpoint::load(path, None).err().map(|e| e.to_string()),
        checkpoint::load_with_config(path).err().map(|e| e.to_string()),
    ] {
        let e = e.unwrap_or_else(|| panic!("{} was accepted", path.display()));
        assert!(e.contains(&path.display().to_string()), "names the file: {e}");
        for w in want {
            assert!(e.contains(w), "names '{w}': {e}");
        }
    }
}

#[test]
fn crafted_checkpoints_are_refused_with_the_file_and_the_field() {
    let d = scratch("ckpt");
    let p = valid_checkpoint(&d, "version.safetensors");
    craft(&p, |m, _| {
        m.insert("format_version".into(), "99".into());
    });
    assert_refused(&p, &["format_version", "99", "newer"]);

    let p = valid_checkpoint(&d, "nan_mean.safetensors");
    craft(&p, |_, t| t.get_mut("obs_norm.mean").unwrap()[2] = f64::NAN);
    assert_refused(&p, &["obs_norm.mean"]);

    let p = valid_checkpoint(&d, "nan_var.safetensors");
    craft(&p, |_, t| t.get_mut("value_norm.var").unwrap()[0] = f64::NAN);
    assert_refused(&p, &["value_norm.var"]);

    let p = valid_checkpoint(&d, "negative_var.safetensors");
    craft(&p, |_, t| t.get_mut("obs_norm.var").unwrap()[1] = -1.0);
    assert_refused(&p, &["tensor 'obs_norm.var' entry 1 is -1", "variance >= 0"]);

    let p = valid_checkpoint(&d, "negative_eps.safetensors");
    craft(&p, |m, _| {
        m.insert("norm_eps".into(), "-0.00001".into());
    });
    assert_refused(&p, &["norm_eps", "-0.00001"]);

    for (tag, clip) in [("nan", "NaN"), ("negative", "-1")] {
        let p = valid_checkpoint(&d, &format!("{tag}_clip.safetensors"));
        craft(&p, |m, _| {
            m.insert("norm_clip".into(), clip.into());
        });
        assert_refused(&p, &["norm_clip", clip]);
    }

    let p = valid_checkpoint(&d, "stored_config.safetensors");
    craft(&p, |m, _| {
        let mut cfg = TrainConfig::preset("tiny").unwrap();
        cfg.ppo.gamma = 2.0;
        m.insert("config".into(), cfg.to_toml());
    });
    assert_refused(&p, &["metadata 'config'", "ppo.gamma", "2 is outside the valid range (0, 1]"]);

    let p = valid_checkpoint(&d, "stored_nan.safetensors");
    craft(&p, |m, _| {
        m.insert("config".into(), "[ppo]\nnorm_clip = nan\n".into());
    });
    assert_refused(&p, &["metadata 'config'", "ppo.norm_clip", "not a finite number"]);
    std::fs::remove_dir_all(&d).ok();
}
