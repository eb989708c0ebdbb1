//! The clip loader turns every kind of bad input into an error naming the file and what was
//! expected, and reads a well-formed archive exactly.

use std::path::{Path, PathBuf};

use skillmimic_motion::pt::{read_pt_matrix, write_pt_matrix};
use skillmimic_motion::testing::synthetic_rows;
use skillmimic_motion::{Clip, ClipError, PT_WIDTH};

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("skillmimic-motion-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
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
    assert!(
        s.contains("frame 3") && s.contains("column 200") && s.contains("body positions"),
        "{s}"
    );
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
        let o = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Stored);
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

// ---- crafted hostile inputs (issue 19): each is refused quickly with an error naming the file
// and the field, never an abort, a huge allocation, a stack overflow or a wrapped offset ----

/// A zip with `archive/data.pkl` = `pickle` and `archive/data/0` = `storage` (stored entries).
fn write_archive(p: &Path, pickle: &[u8], storage: &[u8]) {
    use std::io::Write;
    let mut z = zip::ZipWriter::new(std::fs::File::create(p).unwrap());
    let o =
        zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
    z.start_file("archive/data.pkl", o).unwrap();
    z.write_all(pickle).unwrap();
    z.start_file("archive/data/0", o).unwrap();
    z.write_all(storage).unwrap();
    z.finish().unwrap();
}

/// LONG1 with 8 bytes: any u64 bit pattern as a (signed) pickle integer.
fn long(p: &mut Vec<u8>, v: u64) {
    p.extend_from_slice(&[0x8a, 8]);
    p.extend_from_slice(&v.to_le_bytes());
}

/// The pickle of `_rebuild_tensor_v2(storage(numel), offset, size, stride)` with 64-bit integers.
fn tensor_pickle(numel: u64, offset: u64, size: [u64; 2], stride: [u64; 2]) -> Vec<u8> {
    let mut p = vec![0x80, 2];
    p.extend_from_slice(
        b"ctorch._utils\n_rebuild_tensor_v2\n((X\x07\x00\x00\x00storagectorch\n\
        FloatStorage\nX\x01\x00\x00\x000X\x03\x00\x00\x00cpu",
    );
    long(&mut p, numel);
    p.extend_from_slice(b"tQ");
    long(&mut p, offset);
    long(&mut p, size[0]);
    long(&mut p, size[1]);
    p.push(0x86);
    long(&mut p, stride[0]);
    long(&mut p, stride[1]);
    p.extend_from_slice(&[0x86, 0x89, b't', b'R', b'.']);
    p
}

/// Loads `pickle` + `storage` as a clip and returns the error text after checking that it names
/// the file and that loading took well under a second (no huge allocation or long loop).
fn crafted(name: &str, pickle: &[u8], storage: &[u8]) -> String {
    let d = tmpdir("crafted");
    let p = d.join(name);
    write_archive(&p, pickle, storage);
    let t = std::time::Instant::now();
    let s = err_text(&p);
    assert!(t.elapsed().as_secs_f64() < 1.0, "{name} took {:?}", t.elapsed());
    s
}

#[test]
fn crafted_tensor_header_claiming_more_rows_than_the_file_holds() {
    let storage = vec![0u8; 2 * PT_WIDTH * 4];
    // consistent claim (storage numel too) of 10^9 rows: terabytes if allocated from the header
    let rows = 1_000_000_000u64;
    let s = crafted(
        "001_rows.pt",
        &tensor_pickle(rows * PT_WIDTH as u64, 0, [rows, PT_WIDTH as u64], [PT_WIDTH as u64, 1]),
        &storage,
    );
    assert!(
        s.contains("storage entry archive/data/0 is truncated")
            && s.contains(&format!("needs {} bytes", rows * PT_WIDTH as u64 * 4)),
        "{s}"
    );
    // the storage declares fewer elements than the tensor reads
    let s = crafted(
        "001_numel.pt",
        &tensor_pickle(674, 0, [3, PT_WIDTH as u64], [PT_WIDTH as u64, 1]),
        &storage,
    );
    assert!(s.contains("the storage declares 674") && s.contains("size [3, 337]"), "{s}");
    // the well-formed version of the same archive reads
    let d = tmpdir("crafted");
    write_archive(
        &d.join("001_fine.pt"),
        &tensor_pickle(674, 0, [2, PT_WIDTH as u64], [PT_WIDTH as u64, 1]),
        &storage,
    );
    assert_eq!(read_pt_matrix(&d.join("001_fine.pt")).unwrap().data.len(), 674);
}

#[test]
fn crafted_deep_pickle_nesting() {
    let p: Vec<u8> = [&[0x80, 2, b')'][..], &vec![0x85u8; 1 << 19], b"."].concat();
    let s = crafted("001_deep.pt", &p, &[]);
    assert!(
        s.contains("archive/data.pkl")
            && s.contains("TUPLE1")
            && s.contains("nest deeper than 200 levels"),
        "{s}"
    );
    // nesting by marks is bounded too
    let p: Vec<u8> = [&[0x80, 2][..], &[b'(', b']'].repeat(1 << 18), b"."].concat();
    let s = crafted("001_marks.pt", &p, &[]);
    assert!(s.contains("archive/data.pkl"), "{s}");
}

#[test]
fn crafted_memo_blow_up() {
    // x = (); then 100 times x = (x, x) through the memo: 2^100 values if copied
    let mut p = vec![0x80, 2, b')', b'q', 0];
    for _ in 0..100 {
        p.extend_from_slice(&[b'h', 0, b'h', 0, 0x86, b'q', 0]);
    }
    p.push(b'.');
    let s = crafted("001_memo.pt", &p, &[]);
    assert!(
        s.contains("archive/data.pkl")
            && s.contains("expands to more than")
            && s.contains("memo references"),
        "{s}"
    );
}

#[test]
fn crafted_storage_offset_near_2_pow_62() {
    let storage = vec![0u8; 2 * PT_WIDTH * 4];
    let w = PT_WIDTH as u64;
    for (offset, numel) in
        [(1u64 << 62, (1u64 << 62) + 674), (1 << 62, 674), (u64::MAX >> 1, u64::MAX >> 1)]
    {
        let s = crafted("001_offset.pt", &tensor_pickle(numel, offset, [2, w], [w, 1]), &storage);
        assert!(
            s.contains(&format!("storage offset {offset}"))
                || s.contains(&format!("offset {offset}")),
            "{s}"
        );
        assert!(s.contains("overflows 64 bits") || s.contains("the storage declares"), "{s}");
    }
    // a negative offset is refused as such
    let s = crafted("001_neg.pt", &tensor_pickle(674, u64::MAX, [2, w], [w, 1]), &storage);
    assert!(s.contains("storage offset is -1, expected a non-negative integer"), "{s}");
}

#[test]
fn crafted_shape_product_overflow() {
    let storage = vec![0u8; 2 * PT_WIDTH * 4];
    let s =
        crafted("001_shape.pt", &tensor_pickle(674, 0, [1 << 40, 1 << 40], [1 << 40, 1]), &storage);
    assert!(
        s.contains("size [1099511627776, 1099511627776]") && s.contains("overflows 64 bits"),
        "{s}"
    );
    // stride 0 (an expanded view) cannot make a small storage yield many elements
    let s = crafted(
        "001_stride0.pt",
        &tensor_pickle(674, 0, [1 << 40, PT_WIDTH as u64], [0, 1]),
        &storage,
    );
    assert!(s.contains("stride [0, 1]") && s.contains("overlapping strides"), "{s}");
}

/// A project clip file (`.safetensors`) whose 8-byte header length or tensor entries lie.
#[test]
fn crafted_safetensors_headers() {
    let d = tmpdir("st");
    let p = d.join("huge_header.safetensors");
    let mut bytes = u64::MAX.to_le_bytes().to_vec();
    bytes.extend_from_slice(b"{}      ");
    std::fs::write(&p, &bytes).unwrap();
    let s = Clip::load(&p).unwrap_err().to_string();
    assert!(
        s.contains(&p.display().to_string())
            && s.contains(&format!("header length field is {}", u64::MAX)),
        "{s}"
    );
    for (name, info, msg) in [
        (
            "overflow",
            r#"{"root_pos":{"dtype":"F32","shape":[4294967296,4294967296,4],"data_offsets":[0,8]}}"#,
            "tensor 'root_pos': shape [4294967296, 4294967296, 4] has more elements",
        ),
        (
            "beyond",
            r#"{"root_pos":{"dtype":"F32","shape":[1000000,3],"data_offsets":[0,12000000]}}"#,
            "tensor 'root_pos': data_offsets [0, 12000000] lie outside the 8 data bytes",
        ),
        (
            "mismatch",
            r#"{"root_pos":{"dtype":"F32","shape":[5,3],"data_offsets":[0,8]}}"#,
            "tensor 'root_pos': data_offsets [0, 8] hold 8 bytes, its shape [5, 3] needs 60",
        ),
    ] {
        let p = d.join(format!("{name}.safetensors"));
        let mut head = info.as_bytes().to_vec();
        while head.len() % 8 != 0 {
            head.push(b' ');
        }
        let mut bytes = (head.len() as u64).to_le_bytes().to_vec();
        bytes.extend_from_slice(&head);
        bytes.extend_from_slice(&[0u8; 8]);
        std::fs::write(&p, &bytes).unwrap();
        let s = Clip::load(&p).unwrap_err().to_string();
        assert!(s.contains(&p.display().to_string()) && s.contains(msg), "{name}: {s}");
    }
}

/// `error: {e:#}` (the CLI) prints the error's source chain; no part may repeat itself (the issue
/// saw "Invalid checksum: Invalid checksum").
#[test]
fn error_chains_do_not_repeat_themselves() {
    fn chain(e: &dyn std::error::Error) -> Vec<String> {
        let mut v = vec![e.to_string()];
        let mut s = e.source();
        while let Some(x) = s {
            v.push(x.to_string());
            s = x.source();
        }
        v
    }
    let d = tmpdir("chain");
    // a stored entry whose CRC does not match its bytes
    let p = d.join("001_crc.pt");
    write_pt_matrix(&p, 2, PT_WIDTH, &synthetic_rows(2), "FloatStorage").unwrap();
    let mut bytes = std::fs::read(&p).unwrap();
    let at = bytes.windows(4).position(|w| w == 1.0f32.to_le_bytes()).unwrap();
    bytes[at] ^= 1;
    std::fs::write(&p, &bytes).unwrap();
    let errors: Vec<ClipError> = vec![
        Clip::from_pt(&p).unwrap_err(),
        Clip::from_pt(Path::new("/nonexistent/001_x.pt")).unwrap_err(),
        Clip::load(Path::new("/nonexistent/x.safetensors")).unwrap_err(),
    ];
    for e in &errors {
        let parts = chain(e);
        let text = parts.join(": ");
        for (i, a) in parts.iter().enumerate() {
            for b in &parts[i + 1..] {
                assert!(!a.contains(b.as_str()), "the chain repeats '{b}': {text}");
            }
        }
        println!("{text}");
    }
    assert!(errors[0].to_string().contains("checksum"), "{}", errors[0]);
}
