//! `skillmimic convert` (the release binary): refuses an output equal to an input and clips that
//! training would refuse, with exit code 1, a one-line message naming the file, and nothing
//! written.

use std::path::{Path, PathBuf};
use std::process::Command;

use skillmimic_motion::pt::write_pt_matrix;
use skillmimic_motion::{Clip, PT_WIDTH};

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("skillmimic-convert-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A plausible `.pt` clip of `t` frames; `contact` is written into frame 1's label (if any).
fn write_pt(path: &Path, t: usize, contact: f32) {
    let mut rows = vec![0.0f32; t * PT_WIDTH];
    for f in 0..t {
        let r = &mut rows[f * PT_WIDTH..(f + 1) * PT_WIDTH];
        r[0..3].copy_from_slice(&[0.02 * f as f32, 1.0, 0.95]);
        r[3..6].copy_from_slice(&[1.5, 0.0, 0.0]);
        r[336] = (f % 2) as f32;
    }
    if t > 1 {
        rows[PT_WIDTH + 336] = contact;
    }
    write_pt_matrix(path, t, PT_WIDTH, &rows, "FloatStorage").unwrap();
}

/// Run `skillmimic convert <args>` in `dir`: (exit code, stderr).
fn convert(dir: &Path, args: &[&str]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_skillmimic"))
        .arg("convert")
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap();
    (
        out.status.code().expect("killed by a signal"),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn refused(dir: &Path, args: &[&str], parts: &[&str]) {
    let (rc, err) = convert(dir, args);
    assert_eq!(rc, 1, "{args:?}: {err}");
    let line = err
        .lines()
        .find(|l| l.starts_with("error: "))
        .unwrap_or_else(|| panic!("{args:?}: no error line in {err}"));
    for p in parts {
        assert!(line.contains(p), "{args:?}: expected '{p}' in: {line}");
    }
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn output_equal_to_input_is_refused_and_the_source_is_unchanged() {
    let d = tmpdir("same");
    let src = d.join("013_x.pt");
    write_pt(&src, 6, 1.0);
    let before = std::fs::read(&src).unwrap();
    let msg = "output is the input file";
    refused(&d, &["013_x.pt", "013_x.pt"], &["013_x.pt: ", msg]);
    refused(&d, &["./013_x.pt", "013_x.pt"], &[msg]);
    // `new` does not exist: writing would create it and land on the source
    refused(&d, &[src.to_str().unwrap(), "new/../013_x.pt"], &[msg]);
    assert!(!d.join("new").exists());
    std::os::unix::fs::symlink(&src, d.join("link.safetensors")).unwrap();
    refused(&d, &["013_x.pt", "link.safetensors"], &[msg]);
    std::fs::hard_link(&src, d.join("hard.safetensors")).unwrap();
    refused(&d, &["013_x.pt", "hard.safetensors"], &[msg]);
    // a folder whose output tree links back to an input
    std::fs::create_dir_all(d.join("out")).unwrap();
    std::os::unix::fs::symlink(&src, d.join("out/013_x.safetensors")).unwrap();
    refused(&d, &[".", "out"], &[msg]);
    assert_eq!(std::fs::read(&src).unwrap(), before, "the source clip changed");
    // a different output converts
    let (rc, err) = convert(&d, &["013_x.pt", "x.safetensors"]);
    assert_eq!(rc, 0, "{err}");
    assert_eq!(Clip::load(&d.join("x.safetensors")).unwrap().num_frames, 6);
}

#[test]
fn clips_that_training_refuses_are_not_converted() {
    let d = tmpdir("bad");
    write_pt(&d.join("013_half.pt"), 6, 0.5);
    refused(
        &d,
        &["013_half.pt", "half.safetensors"],
        &["013_half.pt: column 336 (contact label) at frame 1 is 0.5, expected 0 or 1"],
    );
    write_pt(&d.join("013_seven.pt"), 6, 7.0);
    refused(&d, &["013_seven.pt", "seven.safetensors"], &["is 7, expected 0 or 1"]);
    for t in [1, 3] {
        let name = format!("013_len{t}.pt");
        write_pt(&d.join(&name), t, 1.0);
        refused(
            &d,
            &[&name, "short.safetensors"],
            &[&format!("{name}: clip has {t} frames, expected at least 4")],
        );
    }
    for f in ["half.safetensors", "seven.safetensors", "short.safetensors"] {
        assert!(!d.join(f).exists(), "{f} was written");
    }
    // a folder with one bad clip writes nothing at all
    let tree = tmpdir("tree");
    std::fs::create_dir_all(tree.join("a")).unwrap();
    write_pt(&tree.join("a/013_good.pt"), 6, 1.0);
    write_pt(&tree.join("a/013_zbad.pt"), 6, 0.5);
    let out = tmpdir("tree-out");
    refused(&tree, &[".", out.to_str().unwrap()], &["013_zbad.pt: column 336"]);
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 0, "a partial conversion was written");
}

/// `skillmimic synth-motions --character tokenhsi --out-dir DIR` writes the built-in walks and
/// sits as character clips equal to `builtin:walks` and `builtin:sit`; without `--out-dir`
/// (which would put them among the SkillMimic clips of `motions/`) or with an unknown character
/// it exits 1 naming the flag.
#[test]
fn synth_motions_writes_the_tokenhsi_walks_only_where_asked() {
    use skillmimic_motion::character_clip::CharacterClip;
    let d = tmpdir("synth-walks");
    let run = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_skillmimic"))
            .arg("synth-motions")
            .args(args)
            .current_dir(&d)
            .output()
            .unwrap();
        (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stderr).into_owned())
    };
    let (code, err) = run(&["--character", "tokenhsi"]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("--out-dir"), "{err}");
    assert!(!d.join("motions").exists());
    let (code, err) = run(&["--character", "robot", "--out-dir", "x"]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("--character") && err.contains("tokenhsi"), "{err}");
    let (code, err) = run(&["--character", "tokenhsi", "--out-dir", "walks"]);
    assert_eq!(code, 0, "{err}");
    let sits = skillmimic_motion::synth_sit::tokenhsi_sits().into_iter().map(|s| s.clip);
    let carries = skillmimic_motion::synth_carry::tokenhsi_carries().into_iter().map(|c| c.clip);
    let climbs = skillmimic_motion::synth_climb::tokenhsi_climbs().into_iter().map(|c| c.clip);
    let walks: Vec<_> = skillmimic_motion::synth_walk::tokenhsi_walks()
        .into_iter()
        .chain(sits)
        .chain(climbs)
        .chain(carries)
        .collect();
    assert_eq!(walks.len(), 5 + 9 + 17 + 6);
    for w in &walks {
        let c =
            CharacterClip::load(&d.join("walks").join(format!("{}.safetensors", w.name))).unwrap();
        assert_eq!(&c, w);
    }
    std::fs::remove_dir_all(&d).ok();
}
