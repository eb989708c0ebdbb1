//! The one validation of clips (`skillmimic_motion::validate`): every loader — `.pt`, project
//! format, in-memory library — refuses finite-but-huge values, absurd frame rates, contact labels
//! other than 0/1 and clips shorter than the environment needs, with a message naming the file
//! loaded, the frame, the field and the bound; every real BallPlay-M clip passes.

use std::path::{Path, PathBuf};

use skillmimic_core::shared_data::{ballplay_clips, shared_dir_or_skip};
use skillmimic_motion::pt::write_pt_matrix;
use skillmimic_motion::testing::synthetic_rows as rows;
use skillmimic_motion::validate::{MIN_FRAMES, Naming, validate_clip};
use skillmimic_motion::{Clip, ClipError, ClipReference, MotionLibrary, PT_WIDTH};

fn tmpdir(name: &str) -> PathBuf {
    let d =
        std::env::temp_dir().join(format!("skillmimic-validation-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write_pt(dir: &Path, name: &str, t: usize, edit: impl FnOnce(&mut Vec<f32>)) -> PathBuf {
    let mut r = rows(t);
    edit(&mut r);
    let p = dir.join(name);
    write_pt_matrix(&p, t, PT_WIDTH, &r, "FloatStorage").unwrap();
    p
}

/// A project-format file of `t` frames, edited before saving (`Clip::save` does not validate).
fn write_project(dir: &Path, name: &str, t: usize, edit: impl FnOnce(&mut Clip)) -> PathBuf {
    let mut c = Clip::from_rows("x".into(), "/original/013_x.pt".into(), 13, 60.0, t, &rows(t));
    edit(&mut c);
    let p = dir.join(name);
    c.save(&p).unwrap();
    p
}

/// The error of loading `path` (either format), checked to name the file and not the clip's
/// `source` metadata.
fn load_err(path: &Path) -> (ClipError, String) {
    let e = Clip::load_any(path).unwrap_err();
    let s = e.to_string();
    assert!(
        s.starts_with(&format!("{}: ", path.display())),
        "error does not name the file first: {s}"
    );
    assert!(
        !s.contains("/original/"),
        "error names the source metadata instead of the loaded file: {s}"
    );
    (e, s)
}

fn has(s: &str, parts: &[&str]) {
    for p in parts {
        assert!(s.contains(p), "expected '{p}' in: {s}");
    }
}

/// 0.9 with bit 30 (the top exponent bit) flipped: 3.06e38, finite.
fn flipped_exponent() -> f32 {
    let v = f32::from_bits(0.9f32.to_bits() ^ (1 << 30));
    assert!(v.is_finite() && v > 1e38);
    v
}

#[test]
fn valid_clips_pass_in_both_formats() {
    let d = tmpdir("valid");
    let pt = write_pt(&d, "013_ok.pt", MIN_FRAMES, |_| {});
    let clip = Clip::from_pt(&pt).unwrap();
    assert_eq!(clip.contact, vec![0.0, 1.0, 0.0, 1.0]);
    let st = write_project(&d, "ok.safetensors", MIN_FRAMES, |_| {});
    assert_eq!(Clip::load(&st).unwrap().num_frames, MIN_FRAMES);
    MotionLibrary::from_clips(vec![clip]).unwrap();
}

#[test]
fn finite_but_huge_values_are_refused_with_file_frame_column_and_bound() {
    let d = tmpdir("huge");
    let big = flipped_exponent();
    // a body position: the position bound
    let p = write_pt(&d, "013_body.pt", 6, |r| r[3 * PT_WIDTH + 170] = big);
    let (e, s) = load_err(&p);
    assert!(matches!(e, ClipError::Invalid { frame: 3, .. }), "{e:?}");
    has(&s, &["column 170 (body positions) at frame 3", "3.06", "within ±100 m"]);
    // a joint exp map: the rotation bound (column 20 is joint 3, columns 18..21)
    let p = write_pt(&d, "013_joint.pt", 6, |r| r[2 * PT_WIDTH + 20] = big);
    has(
        &load_err(&p).1,
        &["columns 18..21 (joint rotations) at frame 2", "rotation vector of length", "at most 2π"],
    );
    // the root exp map, before it becomes a unit quaternion
    let p = write_pt(&d, "013_root.pt", 6, |r| r[PT_WIDTH + 4] = big);
    has(&load_err(&p).1, &["columns 3..6 (root rotation) at frame 1", "at most 2π"]);
    // project format: the same value in body_pos and dof_rot
    let p = write_project(&d, "body.safetensors", 6, |c| c.body_pos[4 * 159 + 3 * 14 + 2] = big);
    has(&load_err(&p).1, &["body_pos[14, 2] (Head) at frame 4", "within ±100 m"]);
    let p = write_project(&d, "dof.safetensors", 6, |c| c.dof_rot[5 * 156 + 7] = 1e30);
    has(&load_err(&p).1, &["dof_rot[2] (", "at frame 5", "rotation vector of length 1.0000e30"]);
}

#[test]
fn a_jump_inside_the_position_bound_fails_the_velocity_bound() {
    let d = tmpdir("jump");
    // the ball jumps 50 m between frames 3 and 4: 3000 m/s at 60 fps
    let p = write_pt(&d, "013_ball.pt", 6, |r| r[4 * PT_WIDTH + 326] += 50.0);
    let (e, s) = load_err(&p);
    assert!(matches!(e, ClipError::Invalid { frame: 4, .. }), "{e:?}");
    has(
        &s,
        &[
            "columns 324..327 (ball position) at frame 4",
            "moves at 3.0006e3 m/s from frame 3",
            "x 60 fps",
            "at most 100 m/s",
        ],
    );
    let p = write_project(&d, "root.safetensors", 6, |c| c.root_pos[3 * 2 + 2] += 10.0);
    has(&load_err(&p).1, &["root_pos at frame 2", "moves at 6.0000e2 m/s", "at most 100 m/s"]);
    // joint exp-map component rate: 0.1 rad per frame at 1000 fps = 100 rad/s passes; 3 rad at
    // 1000 fps = 3000 rad/s does not
    let p = write_project(&d, "dof.safetensors", 6, |c| {
        c.fps = 1000.0;
        c.dof_rot[3 * 156 + 4] += 3.0;
    });
    has(&load_err(&p).1, &["dof_rot[1, 1] (", "at frame 3", "rad/s", "at most 2000 rad/s"]);
}

#[test]
fn without_validation_such_a_clip_derives_infinite_reset_velocities() {
    // why the bounds exist: the reference velocities of a clip with one flipped exponent bit
    let mut c = Clip::from_rows("x".into(), "test".into(), 13, 60.0, 6, &rows(6));
    c.root_pos[3 * 3] = flipped_exponent();
    assert!(ClipReference::new(&c).root_linvel.iter().any(|v| !v.is_finite()));
    let e = validate_clip(&c, Path::new("mem"), Naming::Project).unwrap_err().to_string();
    has(&e, &["mem: root_pos[0] at frame 3"]);
    assert!(MotionLibrary::from_clips(vec![c]).is_err());
}

#[test]
fn absurd_fps_is_refused() {
    let d = tmpdir("fps");
    for fps in [1e-30, 1e30, 0.5, 1001.0, -1.0, 0.0, f64::NAN, f64::INFINITY] {
        let p = write_project(&d, "fps.safetensors", 6, |c| c.fps = fps);
        let (_, s) = load_err(&p);
        has(&s, &["fps is", "expected a frame rate of 1 to 1000 frames per second"]);
        // in memory (the library) too
        let c = Clip { fps, ..Clip::from_rows("m".into(), "test".into(), 13, 60.0, 6, &rows(6)) };
        let e = MotionLibrary::from_clips(vec![c]).unwrap_err().to_string();
        has(&e, &["clip 'm' (from test)", "fps is"]);
    }
    for fps in [1.0, 1000.0, 30.0] {
        let p = write_project(&d, "fps_ok.safetensors", 6, |c| c.fps = fps);
        assert_eq!(Clip::load(&p).unwrap().fps, fps);
    }
}

#[test]
fn contact_labels_must_be_exactly_0_or_1_in_both_formats() {
    let d = tmpdir("contact");
    for bad in [0.5f32, 7.0, -1.0, 0.999] {
        let p = write_pt(&d, "013_contact.pt", 6, |r| r[2 * PT_WIDTH + 336] = bad);
        let (e, s) = load_err(&p);
        assert!(matches!(e, ClipError::Invalid { frame: 2, .. }), "{e:?}");
        has(&s, &[&format!("column 336 (contact label) at frame 2 is {bad}, expected 0 or 1")]);
        let p = write_project(&d, "contact.safetensors", 6, |c| c.contact[2] = bad);
        has(&load_err(&p).1, &[&format!("contact at frame 2 is {bad}, expected 0 or 1")]);
    }
}

#[test]
fn clips_shorter_than_the_environment_needs_are_refused_everywhere() {
    let d = tmpdir("short");
    for t in [1, 2, 3] {
        let want = format!("clip has {t} frames, expected at least {MIN_FRAMES}");
        let p = write_pt(&d, "013_short.pt", t, |_| {});
        has(&load_err(&p).1, &[&want]);
        let p = write_project(&d, "short.safetensors", t, |_| {});
        has(&load_err(&p).1, &[&want]);
        let c = Clip::from_rows("m".into(), "test".into(), 13, 60.0, t, &rows(t));
        has(&MotionLibrary::from_clips(vec![c]).unwrap_err().to_string(), &[&want]);
    }
    let p = write_project(&d, "zero.safetensors", 0, |_| {});
    has(&load_err(&p).1, &["clip has 0 frames"]);
}

#[test]
fn in_memory_clips_with_inconsistent_arrays_are_an_error_not_a_panic() {
    let mut c = Clip::from_rows("m".into(), "test".into(), 13, 60.0, 6, &rows(6));
    c.body_pos.truncate(100);
    let e = MotionLibrary::from_clips(vec![c]).unwrap_err().to_string();
    has(&e, &["body_pos holds 100 values, expected 6 frames x 159"]);
}

#[test]
fn errors_of_a_converted_clip_name_the_loaded_file_not_its_source() {
    let d = tmpdir("source");
    // source metadata says /original/013_x.pt (checked absent by load_err)
    let p = write_project(&d, "renamed.safetensors", 6, |c| c.contact[1] = 0.5);
    has(&load_err(&p).1, &["renamed.safetensors: contact at frame 1"]);
    let p = write_project(&d, "short.safetensors", 2, |_| {});
    let e = MotionLibrary::load(std::slice::from_ref(&p)).unwrap_err().to_string();
    assert!(e.starts_with(&p.display().to_string()) && !e.contains("/original/"), "{e}");
}

#[test]
fn every_real_ballplay_clip_passes_validation() {
    let Some(shared) = shared_dir_or_skip("every_real_ballplay_clip_passes_validation") else {
        return;
    };
    let files = ballplay_clips(&shared);
    assert!(!files.is_empty(), "no BallPlay-M clips under {}", shared.display());
    let d = tmpdir("real");
    let mut clips = Vec::new();
    for f in &files {
        let clip = Clip::from_pt(f).unwrap_or_else(|e| panic!("{e}"));
        let out = d.join("real.safetensors");
        clip.save(&out).unwrap();
        Clip::load(&out).unwrap_or_else(|e| panic!("{} converted: {e}", f.display()));
        clips.push(clip);
    }
    let n = clips.len();
    MotionLibrary::from_clips(clips).unwrap();
    println!("{n} BallPlay-M clips pass the validation (.pt, project format, library)");
}
