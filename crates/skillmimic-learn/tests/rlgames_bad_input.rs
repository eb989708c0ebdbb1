//! rl_games `.pth` import through the bounded pickle reader: a checkpoint written here in the
//! rl_games layout imports with its values exact; crafted hostile variants (oversized tensor
//! header, storage offset near 2^62, shape product overflow, deep nesting, memo blow-up,
//! unsupported dtype, a class that would run code) are refused with an error naming the file and
//! the tensor or pickle field, quickly and without a huge allocation.

use std::io::Write;
use std::path::{Path, PathBuf};

use skillmimic_learn::rlgames::{Kind, import};

/// A tensor of the checkpoint: name, storage class, shape, values (as f64; written in the class's
/// element type), and overrides of the pickled header fields.
struct T {
    name: &'static str,
    class: &'static str,
    shape: Vec<u64>,
    values: Vec<f64>,
    offset: u64,
    numel: Option<u64>,
}

fn t(name: &'static str, class: &'static str, shape: &[u64], f: impl Fn(usize) -> f64) -> T {
    let n = shape.iter().product::<u64>() as usize;
    T {
        name,
        class,
        shape: shape.to_vec(),
        values: (0..n).map(f).collect(),
        offset: 0,
        numel: None,
    }
}

fn long(p: &mut Vec<u8>, v: u64) {
    p.extend_from_slice(&[0x8a, 8]);
    p.extend_from_slice(&v.to_le_bytes());
}

fn unicode(p: &mut Vec<u8>, s: &str) {
    p.push(b'X');
    p.extend_from_slice(&(s.len() as u32).to_le_bytes());
    p.extend_from_slice(s.as_bytes());
}

/// Pickle of `_rebuild_tensor_v2` for `t` stored under storage key `key`.
fn tensor(p: &mut Vec<u8>, t: &T, key: usize) {
    p.extend_from_slice(b"ctorch._utils\n_rebuild_tensor_v2\n((");
    unicode(p, "storage");
    p.extend_from_slice(format!("ctorch\n{}\n", t.class).as_bytes());
    unicode(p, &key.to_string());
    unicode(p, "cpu");
    long(p, t.numel.unwrap_or(t.values.len() as u64));
    p.extend_from_slice(b"tQ");
    long(p, t.offset);
    p.push(b'(');
    for &s in &t.shape {
        long(p, s);
    }
    p.extend_from_slice(b"t(");
    let mut stride: Vec<u64> = vec![1; t.shape.len()];
    for d in (0..t.shape.len().saturating_sub(1)).rev() {
        stride[d] = stride[d + 1].saturating_mul(t.shape[d + 1]);
    }
    for s in stride {
        long(p, s);
    }
    p.extend_from_slice(b"t\x89ccollections\nOrderedDict\n)RtR");
}

fn bytes_of(t: &T) -> Vec<u8> {
    t.values
        .iter()
        .flat_map(|&v| match t.class {
            "FloatStorage" => (v as f32).to_le_bytes().to_vec(),
            "DoubleStorage" => v.to_le_bytes().to_vec(),
            "LongStorage" => (v as i64).to_le_bytes().to_vec(),
            _ => vec![0u8; 2],
        })
        .collect()
}

/// Write a `.pth` with entries `model` (OrderedDict of `model`), `running_mean_std` (dict of
/// `norm`), `epoch`, and `extra` pickle bytes as the value of `env_state`.
fn write_pth(path: &Path, model: &[T], norm: &[T], extra: &[u8]) {
    let mut p = vec![0x80, 2, b'}', b'('];
    let mut storages = Vec::new();
    for (entry, ts, ordered) in [("model", model, true), ("running_mean_std", norm, false)] {
        unicode(&mut p, entry);
        p.extend_from_slice(if ordered { b"ccollections\nOrderedDict\n)R(" } else { b"}(" });
        for t in ts {
            unicode(&mut p, t.name);
            tensor(&mut p, t, storages.len());
            storages.push(bytes_of(t));
        }
        p.push(b'u');
    }
    unicode(&mut p, "epoch");
    p.extend_from_slice(b"K\x07");
    unicode(&mut p, "env_state");
    if extra.is_empty() {
        p.push(b'N');
    } else {
        p.extend_from_slice(extra);
    }
    p.extend_from_slice(b"u.");
    let mut z = zip::ZipWriter::new(std::fs::File::create(path).unwrap());
    let o =
        zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
    z.start_file("ck/data.pkl", o).unwrap();
    z.write_all(&p).unwrap();
    for (k, s) in storages.iter().enumerate() {
        z.start_file(format!("ck/data/{k}"), o).unwrap();
        z.write_all(s).unwrap();
    }
    z.finish().unwrap();
}

fn valid_model() -> (Vec<T>, Vec<T>) {
    let model = vec![
        t("a2c_network.actor_mlp.0.weight", "FloatStorage", &[4, 902], |i| (i % 7) as f64 * 0.01),
        t("a2c_network.actor_mlp.0.bias", "FloatStorage", &[4], |i| i as f64),
        t("a2c_network.mu.weight", "FloatStorage", &[156, 4], |i| (i % 5) as f64 * 0.1),
        t("a2c_network.mu.bias", "FloatStorage", &[156], |_| 0.5),
        t("a2c_network.critic_mlp.0.weight", "FloatStorage", &[4, 902], |i| (i % 3) as f64 * 0.01),
        t("a2c_network.critic_mlp.0.bias", "FloatStorage", &[4], |_| 0.0),
        t("a2c_network.value.weight", "FloatStorage", &[1, 4], |_| 1.0),
        t("a2c_network.value.bias", "FloatStorage", &[1], |_| 0.25),
        t("a2c_network.sigma", "FloatStorage", &[156], |_| -2.9),
    ];
    let norm = vec![
        t("running_mean", "DoubleStorage", &[902], |i| i as f64 * 1e-3),
        t("running_var", "DoubleStorage", &[902], |_| 2.0),
        t("count", "LongStorage", &[], |_| 1234.0),
    ];
    (model, norm)
}

fn dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("sm-rlgames-bad-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Import `path`, expecting an error that names the file and contains every part of `want`.
fn refused(path: &Path, want: &[&str]) -> String {
    let t = std::time::Instant::now();
    let e = import(path, Kind::Skill).err().expect("import must fail").to_string();
    assert!(t.elapsed().as_secs_f64() < 2.0, "took {:?}", t.elapsed());
    assert!(e.contains(&path.display().to_string()), "error does not name the file: {e}");
    for w in want {
        assert!(e.contains(w), "error lacks '{w}': {e}");
    }
    e
}

#[test]
fn a_valid_checkpoint_imports_exactly() {
    let p = dir().join("ok.pth");
    let (model, norm) = valid_model();
    write_pth(&p, &model, &norm, &[]);
    let imp = import(&p, Kind::Skill).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(imp.epoch, 7);
    assert_eq!(imp.policy.log_std, vec![-2.9f32; 156]);
    assert_eq!(imp.policy.obs_norm.mean[901], 0.901);
    assert_eq!(imp.policy.obs_norm.count, 1234.0);
    assert_eq!(imp.ppo.hidden, vec![4]);
}

#[test]
fn crafted_tensor_headers_are_refused_naming_the_tensor() {
    let d = dir();
    let w = "model.a2c_network.actor_mlp.0.weight";
    type Edit = Box<dyn Fn(&mut T)>;
    let cases: Vec<(&str, Edit, Vec<&str>)> = vec![
        // claims 10^9 rows (4 TB as float32) in a file of a few KB
        (
            "rows.pth",
            Box::new(|t: &mut T| {
                t.shape = vec![1_000_000_000, 902];
                t.numel = Some(902_000_000_000);
            }),
            vec![w, "truncated", "needs 3608000000000 bytes"],
        ),
        (
            "offset.pth",
            Box::new(|t: &mut T| {
                t.offset = 1 << 62;
                t.numel = Some((1 << 62) + 3608);
            }),
            vec![w, "storage offset 4611686018427387904", "overflows 64 bits"],
        ),
        (
            "shape.pth",
            Box::new(|t: &mut T| t.shape = vec![1 << 40, 1 << 40]),
            vec![w, "size [1099511627776, 1099511627776]", "overflows 64 bits"],
        ),
        (
            "half.pth",
            Box::new(|t: &mut T| t.class = "HalfStorage"),
            vec![w, "HalfStorage", "supported: FloatStorage, DoubleStorage, LongStorage"],
        ),
    ];
    for (name, change, want) in cases {
        let (mut model, norm) = valid_model();
        change(&mut model[0]);
        let p = d.join(name);
        write_pth(&p, &model, &norm, &[]);
        println!("{name}: {}", refused(&p, &want));
    }
}

#[test]
fn crafted_pickles_are_refused_naming_the_pickle() {
    let d = dir();
    let (model, norm) = valid_model();
    let deep = [&b")"[..], &vec![0x85u8; 100_000]].concat();
    let mut memo = b")q\x00".to_vec();
    for _ in 0..100 {
        memo.extend_from_slice(b"h\x00h\x00\x86q\x00");
    }
    for (name, extra, want) in [
        ("deep.pth", deep, vec!["ck/data.pkl", "TUPLE1", "nest deeper than"]),
        ("memo.pth", memo, vec!["ck/data.pkl", "memo references"]),
        (
            "evil.pth",
            b"cposix\nsystem\n(X\x02\x00\x00\x00lstR".to_vec(),
            vec!["posix.system", "nothing was executed"],
        ),
    ] {
        let p = d.join(name);
        write_pth(&p, &model, &norm, &extra);
        println!("{name}: {}", refused(&p, &want));
    }
}
