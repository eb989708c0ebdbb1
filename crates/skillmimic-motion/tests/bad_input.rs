//! The clip loader turns every kind of bad input into an error naming the file and what was
//! expected, and reads a well-formed archive exactly.

use std::path::{Path, PathBuf};

use skillmimic_motion::pt::{read_pt_matrix, write_pt_matrix};
use skillmimic_motion::{Clip, ClipError, PT_WIDTH};

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("skillmimic-motion-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn synthetic_rows(t: usize) -> Vec<f32> {
    let mut rows = vec![0.0f32; t * PT_WIDTH];
    for f in 0..t {
        let r = &mut rows[f * PT_WIDTH..(f + 1) * PT_WIDTH];
        r[0..3].copy_from_slice(&[0.1 * f as f32, 1.0, 0.95]);
        r[3..6].copy_from_slice(&[1.5, 0.05, 0.1]);
        r[6..9].copy_from_slice(&[1.5, 0.05, 0.1]);
        for k in 9..165 {
            r[k] = ((k * 7 + f) % 13) as f32 * 0.01;
        }
        for k in 165..327 {
            r[k] = (k % 5) as f32 * 0.1;
        }
        r[336] = (f % 2) as f32;
    }
    rows
}

fn err_text(path: &Path) -> String {
    let e = Clip::from_pt(path).unwrap_err();
    let s = e.to_string();
    assert!(s.contains(&path.display().to_string()), "error does not name the file: {s}");
    s
}

#[test]
fn a_well_formed_archive_reads_back_exactly() {
    let d = tmpdir("ok");
    let p = d.join("013_synthetic_run.pt");
    let rows = synthetic_rows(6);
    write_pt_matrix(&p, 6, PT_WIDTH, &rows, "FloatStorage").unwrap();
    let m = read_pt_matrix(&p).unwrap();
    assert_eq!((m.rows, m.cols), (6, PT_WIDTH));
    assert_eq!(m.data, rows);
    let clip = Clip::from_pt(&p).unwrap();
    assert_eq!(clip.skill, 13);
    assert_eq!(clip.num_frames, 6);
    assert_eq!(&clip.root_pos[3..6], &rows[PT_WIDTH..PT_WIDTH + 3]);
    assert_eq!(&clip.dof_rot[156..312], &rows[PT_WIDTH + 9..PT_WIDTH + 165]);
    assert_eq!(&clip.body_pos[..159], &rows[165..324]);
    assert_eq!(clip.contact, vec![0.0, 1.0, 0.0, 1.0, 0.0, 1.0]);
    // exp map (1.5, 0.05, 0.1) -> quaternion (w, x, y, z)
    let q = &clip.root_rot[..4];
    let a = (1.5f64 * 1.5 + 0.05 * 0.05 + 0.1 * 0.1).sqrt();
    assert!((q[0] as f64 - (a / 2.0).cos()).abs() < 1e-6);
    assert!((q[1] as f64 - 1.5 * (a / 2.0).sin() / a).abs() < 1e-6);
    assert_eq!(&clip.ball_rot[..4], &[1.0, 0.0, 0.0, 0.0]);
}

#[test]
fn not_a_zip_is_rejected() {
    let d = tmpdir("notzip");
    let p = d.join("001_text.pt");
    std::fs::write(&p, "this is not a torch file").unwrap();
    let s = err_text(&p);
    assert!(s.contains("not a PyTorch zip archive") && s.contains("(T, 337)"), "{s}");
}

#[test]
fn missing_file_is_an_io_error() {
    let p = Path::new("/nonexistent/dir/001_missing.pt");
    let s = err_text(p);
    assert!(s.contains("cannot read file"), "{s}");
}

#[test]
fn zip_without_pickle_is_rejected() {
    use std::io::Write;
    let d = tmpdir("nopkl");
    let p = d.join("001_nopkl.pt");
    let mut z = zip::ZipWriter::new(std::fs::File::create(&p).unwrap());
    z.start_file("archive/other.txt", zip::write::SimpleFileOptions::default()).unwrap();
    z.write_all(b"x").unwrap();
    z.finish().unwrap();
    let s = err_text(&p);
    assert!(s.contains("no data.pkl"), "{s}");
}

#[test]
fn wrong_width_is_rejected() {
    let d = tmpdir("width");
    let p = d.join("001_narrow.pt");
    write_pt_matrix(&p, 4, 300, &vec![0.0; 1200], "FloatStorage").unwrap();
    let s = err_text(&p);
    assert!(s.contains("[4, 300]") && s.contains("expected (T, 337)"), "{s}");
}

#[test]
fn empty_clip_is_rejected() {
    let d = tmpdir("empty");
    let p = d.join("001_empty.pt");
    write_pt_matrix(&p, 0, PT_WIDTH, &[], "FloatStorage").unwrap();
    let s = err_text(&p);
    assert!(s.contains("[0, 337]") && s.contains("T >= 1"), "{s}");
}

#[test]
fn non_float32_storage_is_rejected() {
    let d = tmpdir("dtype");
    let p = d.join("001_double.pt");
    write_pt_matrix(&p, 2, PT_WIDTH, &vec![0.0; 2 * PT_WIDTH], "DoubleStorage").unwrap();
    let s = err_text(&p);
    assert!(s.contains("DoubleStorage") && s.contains("float32"), "{s}");
}

#[test]
fn nan_and_inf_are_located() {
    let d = tmpdir("nan");
    let p = d.join("001_nan.pt");
    let mut rows = synthetic_rows(5);
    rows[3 * PT_WIDTH + 200] = f32::NAN;
    write_pt_matrix(&p, 5, PT_WIDTH, &rows, "FloatStorage").unwrap();
    let s = err_text(&p);
    assert!(s.contains("frame 3") && s.contains("column 200") && s.contains("body positions"), "{s}");
    let mut rows = synthetic_rows(5);
    rows[PT_WIDTH + 325] = f32::INFINITY;
    write_pt_matrix(&p, 5, PT_WIDTH, &rows, "FloatStorage").unwrap();
    let s = err_text(&p);
    assert!(s.contains("frame 1") && s.contains("ball position") && s.contains("inf"), "{s}");
}

#[test]
fn unreadable_skill_prefix_is_rejected() {
    let d = tmpdir("label");
    let rows = synthetic_rows(3);
    let p = d.join("run_clip.pt");
    write_pt_matrix(&p, 3, PT_WIDTH, &rows, "FloatStorage").unwrap();
    let s = err_text(&p);
    assert!(s.contains("three digits") && s.contains("run_clip.pt"), "{s}");
    let p = d.join("099_too_big.pt");
    write_pt_matrix(&p, 3, PT_WIDTH, &rows, "FloatStorage").unwrap();
    assert!(matches!(Clip::from_pt(&p), Err(ClipError::LabelRange { label: 99, .. })));
}

#[test]
fn truncated_storage_and_garbage_pickle_are_rejected() {
    use std::io::Write;
    let d = tmpdir("trunc");
    // valid pickle claiming 2 x 337, storage with only 10 floats
    let good = d.join("001_good.pt");
    write_pt_matrix(&good, 2, PT_WIDTH, &vec![0.0; 2 * PT_WIDTH], "FloatStorage").unwrap();
    let mut src = zip::ZipArchive::new(std::fs::File::open(&good).unwrap()).unwrap();
    let mut pkl = Vec::new();
    std::io::copy(&mut src.by_name("archive/data.pkl").unwrap(), &mut pkl).unwrap();
    for (name, pickle, storage) in [
        ("001_trunc.pt", pkl.clone(), vec![0u8; 40]),
        ("001_garbage.pt", vec![0x80, 2, b'X', 0xff, 0xff, 0xff, 0x7f, b'.'], vec![0u8; 8]),
        ("001_dict.pt", vec![0x80, 2, b'}', b'.'], vec![]),
    ] {
        let p = d.join(name);
        let mut z = zip::ZipWriter::new(std::fs::File::create(&p).unwrap());
        let o = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
        z.start_file("archive/data.pkl", o).unwrap();
        z.write_all(&pickle).unwrap();
        z.start_file("archive/data/0", o).unwrap();
        z.write_all(&storage).unwrap();
        z.finish().unwrap();
        let s = err_text(&p);
        println!("{name}: {s}");
    }
    assert!(err_text(&d.join("001_trunc.pt")).contains("truncated"));
    assert!(err_text(&d.join("001_dict.pt")).contains("dict"));
}
