//! Reader for `torch.save` zip archives that hold one float32 2-D tensor (BallPlay-M clips).
//!
//! The pickle program in `*/data.pkl` is interpreted by this crate's restricted pickle machine
//! ([`crate::pickle`]), which only builds a graph of plain values (no code runs). We then accept
//! exactly one shape of value — `torch._utils._rebuild_tensor_v2(persistent_load(('storage',
//! FloatStorage, key, device, numel)), offset, size, stride, …)` — and read the raw
//! little-endian storage `*/data/<key>` with every size checked against the archive entry before
//! anything is allocated ([`crate::torch_zip`]).

use std::path::Path;

use crate::error::ClipError;
use crate::layout::PT_WIDTH;
use crate::torch_zip::{self, TorchError};

/// Largest pickle of a single-tensor clip (a real one is about 200 bytes).
const MAX_PICKLE: u64 = 1 << 20;

/// A dense row-major float32 matrix read from a `.pt` file.
#[derive(Clone, Debug, PartialEq)]
pub struct PtMatrix {
    pub rows: usize,
    pub cols: usize,
    pub data: Vec<f32>,
}

fn format_err(path: &Path, detail: impl Into<String>) -> ClipError {
    ClipError::Format { path: path.to_path_buf(), detail: detail.into() }
}

/// Read the single 2-D float32 tensor stored in the `torch.save` archive at `path`.
pub fn read_pt_matrix(path: &Path) -> Result<PtMatrix, ClipError> {
    let mut tz = torch_zip::open(path, MAX_PICKLE).map_err(|e| match e {
        TorchError::Io(error) => ClipError::Io { path: path.to_path_buf(), error },
        TorchError::NotZip(detail) => ClipError::NotZip { path: path.to_path_buf(), detail },
        TorchError::Format(detail) => format_err(path, detail),
    })?;
    let pkl_name = tz.pkl_name.clone();
    let root = tz.pickle.root;
    if tz.pickle.dict(root).is_some() {
        return Err(format_err(
            path,
            format!(
                "{pkl_name}: holds a dict (a checkpoint?), expected the pickle of one tensor \
                    (torch._utils._rebuild_tensor_v2)"
            ),
        ));
    }
    let t = torch_zip::tensor_ref(&tz.pickle, root)
        .map_err(|d| format_err(path, format!("{pkl_name}: the pickled value {d}")))?;
    if t.storage_class != "FloatStorage" {
        return Err(format_err(
            path,
            format!("tensor storage is {}, expected FloatStorage (float32)", t.storage_class),
        ));
    }
    if t.size.len() != 2 {
        return Err(ClipError::Shape {
            path: path.to_path_buf(),
            shape: t.size.iter().map(|&s| s as usize).collect(),
            expected_width: PT_WIDTH,
        });
    }
    let data = tz.read_f32(&t).map_err(|d| format_err(path, format!("tensor {}: {d}", t.key)))?;
    Ok(PtMatrix { rows: t.size[0] as usize, cols: t.size[1] as usize, data })
}

/// Write a float32 matrix as a `torch.save` zip archive (the layout BallPlay-M clips use:
/// `archive/data.pkl`, `archive/data/0`, `archive/version`), readable by [`read_pt_matrix`] and by
/// `torch.load`. `storage_class` is normally `"FloatStorage"`; other names exist for tests of the
/// reader's errors. The file is written to a temporary name and renamed.
pub fn write_pt_matrix(
    path: &Path,
    rows: usize,
    cols: usize,
    data: &[f32],
    storage_class: &str,
) -> std::io::Result<()> {
    use std::io::Write;
    assert_eq!(data.len(), rows * cols, "data length must be rows * cols");
    let mut p: Vec<u8> = vec![0x80, 2]; // PROTO 2
    let global = |p: &mut Vec<u8>, module: &str, name: &str| {
        p.push(b'c');
        p.extend_from_slice(format!("{module}\n{name}\n").as_bytes());
    };
    let unicode = |p: &mut Vec<u8>, s: &str| {
        p.push(b'X');
        p.extend_from_slice(&(s.len() as u32).to_le_bytes());
        p.extend_from_slice(s.as_bytes());
    };
    let int = |p: &mut Vec<u8>, v: usize| {
        p.push(b'J');
        p.extend_from_slice(&(v as i32).to_le_bytes());
    };
    global(&mut p, "torch._utils", "_rebuild_tensor_v2");
    p.push(b'('); // MARK: args of _rebuild_tensor_v2
    p.push(b'('); // MARK: persistent id
    unicode(&mut p, "storage");
    global(&mut p, "torch", storage_class);
    unicode(&mut p, "0");
    unicode(&mut p, "cpu");
    int(&mut p, rows * cols);
    p.push(b't'); // TUPLE
    p.push(b'Q'); // BINPERSID
    int(&mut p, 0); // storage offset
    int(&mut p, rows);
    int(&mut p, cols);
    p.push(0x86); // TUPLE2: size
    int(&mut p, cols);
    int(&mut p, 1);
    p.push(0x86); // TUPLE2: stride
    p.push(0x89); // NEWFALSE: requires_grad
    global(&mut p, "collections", "OrderedDict");
    p.push(b')'); // EMPTY_TUPLE
    p.push(b'R'); // REDUCE: OrderedDict()
    p.push(b't'); // TUPLE: args
    p.push(b'R'); // REDUCE
    p.push(b'.'); // STOP

    let tmp = path.with_extension("pt.tmp");
    {
        let mut zip = zip::ZipWriter::new(std::fs::File::create(&tmp)?);
        let opts = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Stored);
        let io = |e: zip::result::ZipError| std::io::Error::other(e);
        zip.start_file("archive/data.pkl", opts).map_err(io)?;
        zip.write_all(&p)?;
        zip.start_file("archive/byteorder", opts).map_err(io)?;
        zip.write_all(b"little")?;
        zip.start_file("archive/data/0", opts).map_err(io)?;
        let mut bytes = Vec::with_capacity(4 * data.len());
        for x in data {
            bytes.extend_from_slice(&x.to_le_bytes());
        }
        zip.write_all(&bytes)?;
        zip.start_file("archive/version", opts).map_err(io)?;
        zip.write_all(b"3\n")?;
        zip.finish().map_err(io)?;
    }
    std::fs::rename(&tmp, path)
}
