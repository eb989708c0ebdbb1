//! Reader for `torch.save` zip archives that hold one float32 2-D tensor (BallPlay-M clips).
//!
//! The pickle program in `*/data.pkl` is interpreted by candle's restricted pickle machine, which
//! only builds a tree of plain values (no code runs). We then accept exactly one shape of tree —
//! `torch._utils._rebuild_tensor_v2(persistent_load(('storage', FloatStorage, key, device, numel)),
//! offset, size, stride, …)` — and read the raw little-endian storage `*/data/<key>`.

use std::io::{BufReader, Read};
use std::path::Path;

use candle_core::pickle::{Object, Stack};

use crate::error::ClipError;
use crate::layout::PT_WIDTH;

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
    let file = std::fs::File::open(path).map_err(|source| ClipError::Io { path: path.to_path_buf(), source })?;
    let mut zip = zip::ZipArchive::new(BufReader::new(file))
        .map_err(|e| ClipError::NotZip { path: path.to_path_buf(), detail: e.to_string() })?;
    let pkl_name = zip
        .file_names()
        .filter_map(Result::ok)
        .find(|n| n.ends_with("/data.pkl") || n == "data.pkl")
        .map(|n| n.into_owned())
        .ok_or_else(|| format_err(path, "archive has no data.pkl entry; expected a torch.save file"))?;
    let dir = pkl_name.strip_suffix(".pkl").unwrap_or(&pkl_name).to_owned();

    let mut pkl = Vec::new();
    {
        let entry = zip.by_name(&pkl_name).map_err(|e| format_err(path, format!("{pkl_name}: {e}")))?;
        if entry.size() > 1 << 20 {
            return Err(format_err(path, format!("{pkl_name} is {} bytes; a single-tensor clip has a tiny pickle", entry.size())));
        }
        entry.take(1 << 20).read_to_end(&mut pkl).map_err(|source| ClipError::Io { path: path.to_path_buf(), source })?;
    }
    let root = parse_pickle(&pkl).map_err(|e| format_err(path, format!("{pkl_name}: {e}")))?;
    let info = tensor_info(root).map_err(|d| format_err(path, format!("{pkl_name}: {d}")))?;

    if info.dtype != "FloatStorage" {
        return Err(format_err(path, format!("tensor storage is {}, expected FloatStorage (float32)", info.dtype)));
    }
    if info.size.len() != 2 {
        return Err(ClipError::Shape { path: path.to_path_buf(), shape: info.size, expected_width: PT_WIDTH });
    }
    let (rows, cols) = (info.size[0], info.size[1]);
    if info.stride != [cols, 1] && rows > 1 {
        return Err(format_err(path, format!("tensor stride {:?} is not row-major for shape {:?}", info.stride, info.size)));
    }
    let numel = rows.checked_mul(cols).ok_or_else(|| format_err(path, "tensor size overflows"))?;
    if info.offset + numel > info.numel {
        return Err(format_err(path, format!("storage holds {} values, tensor needs {}", info.numel, info.offset + numel)));
    }

    let storage_name = format!("{dir}/{}", info.key);
    let mut bytes = Vec::with_capacity(4 * (info.offset + numel));
    {
        let entry = zip
            .by_name(&storage_name)
            .map_err(|e| format_err(path, format!("storage entry {storage_name} missing: {e}")))?;
        entry
            .take(4 * (info.offset + numel) as u64)
            .read_to_end(&mut bytes)
            .map_err(|source| ClipError::Io { path: path.to_path_buf(), source })?;
    }
    if bytes.len() < 4 * (info.offset + numel) {
        return Err(format_err(path, format!("storage {storage_name} is truncated ({} bytes, need {})", bytes.len(), 4 * (info.offset + numel))));
    }
    let data = bytes[4 * info.offset..]
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    Ok(PtMatrix { rows, cols, data })
}

/// Interpret a pickle program with candle's restricted machine (plain values only, no code runs).
/// The machine returns errors for malformed programs; the unwind guard turns any remaining
/// internal panic on hostile bytes into an error as well.
pub fn parse_pickle(pkl: &[u8]) -> Result<Object, String> {
    let parsed = std::panic::catch_unwind(|| {
        let mut stack = Stack::empty();
        stack.read_loop(&mut std::io::Cursor::new(pkl))?;
        stack.finalize()
    });
    match parsed {
        Ok(Ok(obj)) => Ok(obj),
        Ok(Err(e)) => Err(format!("not a readable pickle: {e}")),
        Err(_) => Err("malformed pickle".into()),
    }
}

struct TensorInfo {
    dtype: String,
    key: String,
    numel: usize,
    offset: usize,
    size: Vec<usize>,
    stride: Vec<usize>,
}

fn ints(o: &Object) -> Option<Vec<usize>> {
    match o {
        Object::Tuple(v) => v.iter().map(int).collect(),
        _ => None,
    }
}

fn int(o: &Object) -> Option<usize> {
    match o {
        Object::Int(i) if *i >= 0 => Some(*i as usize),
        Object::Long(i) if *i >= 0 => Some(*i as usize),
        _ => None,
    }
}

fn tensor_info(root: Object) -> Result<TensorInfo, String> {
    let expected = "expected the pickle of one tensor (torch._utils._rebuild_tensor_v2)";
    let (callable, args) = match root {
        Object::Reduce { callable, args } => (callable, args),
        Object::Dict(_) => return Err(format!("holds a dict (a checkpoint?), {expected}")),
        _ => return Err(expected.into()),
    };
    match *callable {
        Object::Class { ref module_name, ref class_name }
            if module_name == "torch._utils" && class_name == "_rebuild_tensor_v2" => {}
        _ => return Err(expected.into()),
    }
    let Object::Tuple(args) = *args else { return Err(expected.into()) };
    if args.len() < 4 {
        return Err(expected.into());
    }
    let Object::PersistentLoad(storage) = &args[0] else { return Err(expected.into()) };
    let Object::Tuple(storage) = &**storage else { return Err(expected.into()) };
    if storage.len() < 5 {
        return Err(expected.into());
    }
    let Object::Class { class_name, .. } = &storage[1] else { return Err(expected.into()) };
    let Object::Unicode(key) = &storage[2] else { return Err(expected.into()) };
    let numel = int(&storage[4]).ok_or(expected)?;
    let offset = int(&args[1]).ok_or(expected)?;
    let size = ints(&args[2]).ok_or(expected)?;
    let stride = ints(&args[3]).ok_or(expected)?;
    if key.contains('/') || key.contains("..") {
        return Err(format!("invalid storage key '{key}'"));
    }
    Ok(TensorInfo { dtype: class_name.clone(), key: key.clone(), numel, offset, size, stride })
}

/// Write a float32 matrix as a `torch.save` zip archive (the layout BallPlay-M clips use:
/// `archive/data.pkl`, `archive/data/0`, `archive/version`), readable by [`read_pt_matrix`] and by
/// `torch.load`. `storage_class` is normally `"FloatStorage"`; other names exist for tests of the
/// reader's errors. The file is written to a temporary name and renamed.
pub fn write_pt_matrix(path: &Path, rows: usize, cols: usize, data: &[f32], storage_class: &str) -> std::io::Result<()> {
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
        let opts = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
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
