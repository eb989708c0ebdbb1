//! Project clip format: exact round trip from BallPlay-M files, validation of malformed files,
//! and the motion library's sampling rules.

use std::collections::BTreeMap;
use std::path::PathBuf;

use rand::SeedableRng;
use skillmimic_core::shared_data::{ballplay_clips, shared_dir_or_skip};
use skillmimic_core::tensorfile::{OwnedTensor, write_atomic};
use skillmimic_motion::pt::read_pt_matrix;
use skillmimic_motion::{Clip, MotionLibrary, PT_WIDTH};

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("skillmimic-format-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

fn column(raw: &[f32], t: usize, cols: std::ops::Range<usize>) -> Vec<f32> {
    (0..t).flat_map(|f| raw[f * PT_WIDTH + cols.start..f * PT_WIDTH + cols.end].to_vec()).collect()
}

#[test]
fn pt_to_project_format_round_trip_is_exact_on_all_clips() {
    let Some(shared) = shared_dir_or_skip("pt_to_project_format_round_trip_is_exact_on_all_clips")
    else {
        return;
    };
    let files = ballplay_clips(&shared);
    for f in &files {
        let raw = read_pt_matrix(f).unwrap();
        let t = raw.rows;
        let clip = Clip::from_pt(f).unwrap();
        let out = tmp("roundtrip.safetensors");
        clip.save(&out).unwrap();
        let back = Clip::load(&out).unwrap();
        assert_eq!(back, clip, "{}", f.display());
        // the stored tensors are the source columns bit for bit
        assert_eq!(back.root_pos, column(&raw.data, t, 0..3));
        assert_eq!(back.dof_rot, column(&raw.data, t, 9..165));
        assert_eq!(back.body_pos, column(&raw.data, t, 165..324));
        assert_eq!(back.ball_pos, column(&raw.data, t, 324..327));
        assert_eq!(back.contact, column(&raw.data, t, 336..337));
        // the root quaternion is the exp map of columns 3:6 (up to sign continuity)
        for k in 0..t {
            let e = [
                raw.data[k * PT_WIDTH + 3] as f64,
                raw.data[k * PT_WIDTH + 4] as f64,
                raw.data[k * PT_WIDTH + 5] as f64,
            ];
            let q = skillmimic_core::math::Quat::from_rotvec(e);
            let b = back.root_quat_at(k);
            assert!((q.dot(b).abs() - 1.0).abs() < 1e-6, "{} frame {k}", f.display());
        }
        assert_eq!(
            back.skill,
            f.file_name().unwrap().to_str().unwrap()[..3].parse::<u32>().unwrap()
        );
    }
    println!(
        "{} clips: .pt -> .safetensors -> loaded tensors equal the source columns",
        files.len()
    );
}

fn write_fields(
    path: &std::path::Path,
    edit: impl Fn(&mut Vec<OwnedTensor>, &mut BTreeMap<String, String>),
) {
    let t = 5;
    let mut quat = vec![0.0f32; 4 * t];
    quat.chunks_exact_mut(4).for_each(|q| q[0] = 1.0);
    let mut tensors = vec![
        OwnedTensor::f32("root_pos", &[t, 3], &vec![0.5; 3 * t]),
        OwnedTensor::f32("root_rot", &[t, 4], &quat),
        OwnedTensor::f32("dof_rot", &[t, 52, 3], &vec![0.1; 156 * t]),
        OwnedTensor::f32("body_pos", &[t, 53, 3], &vec![0.2; 159 * t]),
        OwnedTensor::f32("ball_pos", &[t, 3], &vec![1.0; 3 * t]),
        OwnedTensor::f32("ball_rot", &[t, 4], &quat),
        OwnedTensor::f32("contact", &[t], &[0.0, 1.0, 1.0, 0.0, 0.0]),
    ];
    let mut meta: BTreeMap<String, String> = [
        ("format", "skillmimic-clip"),
        ("format_version", "1"),
        ("fps", "60"),
        ("skill", "13"),
        ("name", "x"),
        ("source", "test"),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v.to_string()))
    .collect();
    edit(&mut tensors, &mut meta);
    write_atomic(path, &tensors, &meta).unwrap();
}

#[test]
fn malformed_project_files_give_clear_errors() {
    let p = tmp("bad.safetensors");
    write_fields(&p, |_, _| {});
    assert_eq!(Clip::load(&p).unwrap().num_frames, 5);
    type Edit = Box<dyn Fn(&mut Vec<OwnedTensor>, &mut BTreeMap<String, String>)>;
    let cases: Vec<(&str, Edit)> = vec![
        (
            "tensor 'dof_rot' has shape [5, 50, 3], expected (5, 52, 3)",
            Box::new(|t, _| t[2] = OwnedTensor::f32("dof_rot", &[5, 50, 3], &vec![0.0; 750])),
        ),
        (
            "tensor 'body_pos' holds a non-finite value",
            Box::new(|t, _| {
                let mut v = vec![0.2f32; 159 * 5];
                v[17] = f32::NAN;
                t[3] = OwnedTensor::f32("body_pos", &[5, 53, 3], &v)
            }),
        ),
        (
            "root_rot at frame 0 has norm",
            Box::new(|t, _| t[1] = OwnedTensor::f32("root_rot", &[5, 4], &[0.7; 20])),
        ),
        (
            "contact at frame 2 is 0.5",
            Box::new(|t, _| t[6] = OwnedTensor::f32("contact", &[5], &[0.0, 1.0, 0.5, 0.0, 0.0])),
        ),
        (
            "tensor 'ball_pos' is missing",
            Box::new(|t, _| {
                t.remove(4);
            }),
        ),
        (
            "expected 'skillmimic-clip'",
            Box::new(|_, m| {
                m.insert("format".into(), "other".into());
            }),
        ),
        (
            "skill label 70 is outside the one-hot width 64",
            Box::new(|_, m| {
                m.insert("skill".into(), "70".into());
            }),
        ),
        (
            "fps is -1",
            Box::new(|_, m| {
                m.insert("fps".into(), "-1".into());
            }),
        ),
        (
            "metadata field 'fps' is missing",
            Box::new(|_, m| {
                m.remove("fps");
            }),
        ),
        (
            "tensor 'root_rot' has dtype F64, expected F32",
            Box::new(|t, _| t[1] = OwnedTensor::f64("root_rot", &[5, 4], &[1.0; 20])),
        ),
    ];
    for (want, edit) in cases {
        write_fields(&p, edit);
        let e = Clip::load(&p).unwrap_err().to_string();
        assert!(
            e.contains(&p.display().to_string()) && e.contains(want),
            "expected '{want}', got: {e}"
        );
    }
    std::fs::write(&p, b"not safetensors").unwrap();
    assert!(Clip::load(&p).unwrap_err().to_string().contains("not a safetensors file"));
    let e = Clip::load_any(&tmp("clip.npz")).unwrap_err().to_string();
    assert!(e.contains("unknown clip extension"), "{e}");
}

fn synthetic(skill: u32, t: usize) -> Clip {
    let mut rows = vec![0.0f32; t * PT_WIDTH];
    rows.chunks_exact_mut(PT_WIDTH).for_each(|r| r[2] = 0.9);
    Clip::from_rows(format!("s{skill}"), "synthetic".into(), skill, 60.0, t, &rows)
}

#[test]
fn library_weights_are_class_balanced_with_pickup_doubled() {
    // labels: 13 x3, 1 x2, 31 x1 -> raw weights 1/3 each, 2/2 each, 1 -> total 1 + 2 + 1 = 4
    let clips = vec![
        synthetic(13, 10),
        synthetic(13, 10),
        synthetic(13, 10),
        synthetic(1, 8),
        synthetic(1, 8),
        synthetic(31, 6),
    ];
    let lib = MotionLibrary::from_clips(clips).unwrap();
    let w = lib.weights();
    let expect = [1.0 / 12.0, 1.0 / 12.0, 1.0 / 12.0, 0.25, 0.25, 0.25];
    for (a, b) in w.iter().zip(expect) {
        assert!((a - b).abs() < 1e-12, "{w:?}");
    }
    // empirical frequencies and start-frame range
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
    let mut counts = [0usize; 6];
    for _ in 0..60_000 {
        let i = lib.sample_clip(&mut rng);
        counts[i] += 1;
        let s = lib.sample_start(i, &mut rng);
        assert!((2..=lib.get(i).clip.num_frames - 2).contains(&s));
    }
    for (c, e) in counts.iter().zip(expect) {
        assert!((*c as f64 / 60_000.0 - e).abs() < 0.01, "{counts:?}");
    }
    assert_eq!(lib.skills(), vec![1, 13, 31]);
    let e = MotionLibrary::from_clips(vec![synthetic(13, 3)]).unwrap_err().to_string();
    assert!(e.contains("has 3 frames") && e.contains("at least 4"), "{e}");
}
