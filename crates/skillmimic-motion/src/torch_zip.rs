//! Bounded reading of `torch.save` zip archives: the pickle `*/data.pkl` (interpreted by
//! [`crate::pickle`], no code runs) and tensor storages `*/data/<key>`.
//!
//! Every size is computed with checked arithmetic (storage offset, shape products, strides,
//! element size) and compared with the archive entry's uncompressed size before anything is
//! allocated, so a few bytes of pickle cannot claim terabytes or make offsets wrap around.

use std::io::{Read, Seek};
use std::path::Path;

use crate::pickle::{Id, Node, Pickle};

/// Largest storage read from one archive entry (4 GiB).
pub const MAX_STORAGE_BYTES: u64 = 1 << 32;

/// Why an archive could not be read (no path: callers add it).
#[derive(Debug)]
pub enum TorchError {
    /// Reading the file failed.
    Io(std::io::Error),
    /// The file is not a zip archive.
    NotZip(String),
    /// The archive's content is not what torch.save writes.
    Format(String),
}

fn fmt_err<T>(m: impl Into<String>) -> Result<T, TorchError> {
    Err(TorchError::Format(m.into()))
}

/// Element type of a storage class (`torch.FloatStorage`, …).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dtype {
    F32,
    F64,
    I64,
    I32,
}

impl Dtype {
    /// The dtype of storage class `name`; `None` for classes this reader does not convert.
    pub fn from_storage(name: &str) -> Option<Dtype> {
        Some(match name {
            "FloatStorage" => Dtype::F32,
            "DoubleStorage" => Dtype::F64,
            "LongStorage" => Dtype::I64,
            "IntStorage" => Dtype::I32,
            _ => return None,
        })
    }

    /// Bytes per element.
    pub fn size(self) -> u64 {
        match self {
            Dtype::F32 | Dtype::I32 => 4,
            Dtype::F64 | Dtype::I64 => 8,
        }
    }
}

/// A tensor as the pickle describes it: `_rebuild_tensor_v2(storage, offset, size, stride, …)`.
/// Offsets and strides count elements, not bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct TensorRef {
    /// Storage class name (`FloatStorage`, …).
    pub storage_class: String,
    /// Archive entry `<dir>/data/<key>`.
    pub key: String,
    /// Elements the storage holds (its declared length).
    pub storage_numel: u64,
    pub offset: u64,
    pub size: Vec<u64>,
    pub stride: Vec<u64>,
}

impl TensorRef {
    /// Elements of the tensor (product of `size`), `None` on overflow.
    pub fn numel(&self) -> Option<u64> {
        self.size.iter().try_fold(1u64, |a, &s| a.checked_mul(s))
    }

    /// `size` as `usize` values (the caller has read the tensor, so they fit).
    pub fn shape(&self) -> Vec<usize> {
        self.size.iter().map(|&s| s as usize).collect()
    }

    /// One past the largest storage element the tensor touches, with checked arithmetic
    /// (0 for an empty tensor).
    pub fn extent(&self) -> Result<u64, String> {
        if self.size.contains(&0) {
            return Ok(0);
        }
        let mut last = self.offset;
        for (&n, &s) in self.size.iter().zip(&self.stride) {
            last = (n - 1)
                .checked_mul(s)
                .and_then(|x| last.checked_add(x))
                .ok_or_else(|| self.overflow())?;
        }
        last.checked_add(1).ok_or_else(|| self.overflow())
    }

    fn overflow(&self) -> String {
        format!(
            "storage offset {} with size {:?} and stride {:?} overflows 64 bits",
            self.offset, self.size, self.stride
        )
    }
}

/// A non-negative integer of the pickle.
fn index(p: &Pickle, id: Id, what: &str) -> Result<u64, String> {
    match p.get(id) {
        Node::Int(i) => {
            u64::try_from(*i).map_err(|_| format!("{what} is {i}, expected a non-negative integer"))
        }
        Node::BigInt => Err(format!("{what} does not fit in 64 bits")),
        other => Err(format!("{what} is {}, expected an integer", kind(other))),
    }
}

fn indices(p: &Pickle, id: Id, what: &str) -> Result<Vec<u64>, String> {
    let items = p
        .tuple(id)
        .ok_or_else(|| format!("{what} is {}, expected a tuple of integers", kind(p.get(id))))?;
    items.iter().enumerate().map(|(k, &i)| index(p, i, &format!("{what}[{k}]"))).collect()
}

/// A short description of a value's kind for messages.
pub fn kind(n: &Node) -> &'static str {
    match n {
        Node::None => "None",
        Node::Bool(_) => "a bool",
        Node::Int(_) | Node::BigInt => "an integer",
        Node::Float(_) => "a float",
        Node::Str(_) => "a string",
        Node::Bytes(_) => "bytes",
        Node::Tuple(_) => "a tuple",
        Node::List(_) => "a list",
        Node::Dict(_) => "a dict",
        Node::Global { .. } => "a class reference",
        Node::Reduce { .. } => "an object",
        Node::Build { .. } => "a built object",
        Node::PersistentId(_) => "a storage reference",
    }
}

/// Whether value `id` is built by `_rebuild_tensor_v2` or `_rebuild_parameter` (a tensor).
pub fn is_tensor(p: &Pickle, id: Id) -> bool {
    match p.get(id) {
        Node::Reduce { callable, .. } => matches!(
            p.global(*callable),
            Some(("torch._utils", "_rebuild_tensor_v2" | "_rebuild_parameter"))
        ),
        _ => false,
    }
}

/// The tensor that value `id` rebuilds (`torch._utils._rebuild_tensor_v2`, also inside
/// `_rebuild_parameter`); the error says what the value is instead.
pub fn tensor_ref(p: &Pickle, id: Id) -> Result<TensorRef, String> {
    let expected = "expected a tensor (torch._utils._rebuild_tensor_v2)";
    let Node::Reduce { callable, args } = p.get(id) else {
        return Err(format!("is {}, {expected}", kind(p.get(id))));
    };
    let args = p.tuple(*args).unwrap_or(&[]);
    match p.global(*callable) {
        Some(("torch._utils", "_rebuild_tensor_v2")) => {}
        Some(("torch._utils", "_rebuild_parameter")) if !args.is_empty() => {
            return tensor_ref(p, args[0]);
        }
        Some((m, c)) => return Err(format!("is built by {m}.{c}, {expected}")),
        None => return Err(format!("is {}, {expected}", kind(p.get(id)))),
    }
    if args.len() < 4 {
        return Err(format!(
            "_rebuild_tensor_v2 has {} arguments, expected at least 4",
            args.len()
        ));
    }
    let Node::PersistentId(pid) = p.get(args[0]) else {
        return Err(format!(
            "storage argument is {}, expected a storage reference",
            kind(p.get(args[0]))
        ));
    };
    let storage = p
        .tuple(*pid)
        .filter(|s| s.len() >= 5 && p.str(s[0]) == Some("storage"))
        .ok_or("storage reference is not ('storage', class, key, device, numel)")?;
    let storage_class =
        p.global(storage[1]).ok_or("storage class is not a class reference")?.1.to_string();
    let key = p.str(storage[2]).ok_or("storage key is not a string")?.to_string();
    if key.is_empty() || !key.bytes().all(|c| c.is_ascii_alphanumeric() || c == b'_') {
        return Err(format!("storage key '{key}' is not a plain name"));
    }
    let t = TensorRef {
        storage_class,
        key,
        storage_numel: index(p, storage[4], "storage numel")?,
        offset: index(p, args[1], "storage offset")?,
        size: indices(p, args[2], "size")?,
        stride: indices(p, args[3], "stride")?,
    };
    if t.size.len() != t.stride.len() {
        return Err(format!("size {:?} and stride {:?} have different lengths", t.size, t.stride));
    }
    Ok(t)
}

/// An open `torch.save` archive with its parsed pickle.
pub struct TorchZip<R: Read + Seek> {
    zip: zip::ZipArchive<R>,
    /// Entry name of the pickle (`<dir>/data.pkl`).
    pub pkl_name: String,
    dir: String,
    /// Length of the whole archive in bytes.
    file_len: u64,
    pub pickle: Pickle,
}

impl<R: Read + Seek> TorchZip<R> {
    /// Read the archive and interpret its pickle, refusing pickles larger than `max_pickle` bytes.
    pub fn new(mut reader: R, max_pickle: u64) -> Result<Self, TorchError> {
        let file_len = reader.seek(std::io::SeekFrom::End(0)).map_err(TorchError::Io)?;
        reader.rewind().map_err(TorchError::Io)?;
        let mut zip =
            zip::ZipArchive::new(reader).map_err(|e| TorchError::NotZip(e.to_string()))?;
        let pkl_name = zip
            .file_names()
            .filter_map(Result::ok)
            .find(|n| n.ends_with("/data.pkl") || n == "data.pkl")
            .map(|n| n.into_owned())
            .ok_or_else(|| {
                TorchError::Format(
                    "archive has no data.pkl entry; expected a torch.save file".into(),
                )
            })?;
        let dir = pkl_name.strip_suffix("data.pkl").unwrap_or("").to_owned();
        let pkl = {
            let mut entry = zip
                .by_name(&pkl_name)
                .map_err(|e| TorchError::Format(format!("{pkl_name}: {e}")))?;
            let size = entry.size();
            if size > max_pickle {
                return fmt_err(format!(
                    "{pkl_name} is {size} bytes, more than the {max_pickle} this reader accepts"
                ));
            }
            read_entry(&mut entry, size, false)
                .map_err(|e| TorchError::Format(format!("{pkl_name}: {e}")))?
        };
        let pickle =
            Pickle::parse(&pkl).map_err(|e| TorchError::Format(format!("{pkl_name}: {e}")))?;
        Ok(Self { zip, pkl_name, dir, file_len, pickle })
    }

    /// The raw little-endian bytes of elements `[offset, extent)` of `t`'s storage, after checking
    /// every size against the entry's uncompressed size; the returned bytes start at element 0.
    fn storage_bytes(&mut self, t: &TensorRef, dtype: Dtype) -> Result<Vec<u8>, String> {
        let extent = t.extent()?;
        if extent > t.storage_numel {
            return Err(format!(
                "needs storage elements up to {extent} (offset {}, size {:?}, stride {:?}), the \
                    storage declares {}",
                t.offset, t.size, t.stride, t.storage_numel
            ));
        }
        let need = extent.checked_mul(dtype.size()).ok_or_else(|| t.overflow())?;
        let name = format!("{}data/{}", self.dir, t.key);
        let mut entry =
            self.zip.by_name(&name).map_err(|e| format!("storage entry {name}: {e}"))?;
        let size = entry.size();
        if need > size {
            return Err(format!(
                "storage entry {name} is truncated: the tensor needs {need} bytes, the entry \
                    holds {size}"
            ));
        }
        if size > MAX_STORAGE_BYTES {
            return Err(format!(
                "storage entry {name} is {size} bytes, more than this reader's limit of \
                    {MAX_STORAGE_BYTES}"
            ));
        }
        // a stored (uncompressed) entry cannot hold more than the file: only then reserve it all
        let stored = entry.compression() == zip::CompressionMethod::Stored;
        if stored && size > self.file_len {
            return Err(format!(
                "storage entry {name} claims {size} bytes, the whole file has {}",
                self.file_len
            ));
        }
        let bytes = read_entry(&mut entry, size, stored)
            .map_err(|e| format!("storage entry {name}: {e}"))?;
        if (bytes.len() as u64) < need {
            return Err(format!(
                "storage entry {name} is truncated ({} bytes, need {need})",
                bytes.len()
            ));
        }
        Ok(bytes)
    }

    /// The elements of `t` in row-major order, converted by `conv` from each element's bytes.
    fn gather<T>(
        &mut self,
        t: &TensorRef,
        conv: impl Fn(Dtype, &[u8]) -> T,
    ) -> Result<Vec<T>, String> {
        let dtype = Dtype::from_storage(&t.storage_class).ok_or_else(|| {
            format!(
                "storage is {}; supported: FloatStorage, DoubleStorage, LongStorage, IntStorage",
                t.storage_class
            )
        })?;
        let bytes = self.storage_bytes(t, dtype)?;
        let numel = t.numel().ok_or_else(|| t.overflow())?;
        if numel > t.extent()? {
            // only overlapping strides (stride 0, expanded views) give more elements than storage
            return Err(format!(
                "size {:?} with stride {:?} has more elements than the storage it reads; \
                    overlapping strides are not supported",
                t.size, t.stride
            ));
        }
        let numel = numel as usize;
        let es = dtype.size() as usize;
        let mut out = Vec::with_capacity(numel);
        let mut idx = vec![0u64; t.size.len()];
        for _ in 0..numel {
            // element offset: offset + Σ idx·stride <= extent − 1 (checked above)
            let e = t.offset + idx.iter().zip(&t.stride).map(|(i, s)| i * s).sum::<u64>();
            let at = e as usize * es;
            out.push(conv(dtype, &bytes[at..at + es]));
            for d in (0..idx.len()).rev() {
                idx[d] += 1;
                if idx[d] < t.size[d] {
                    break;
                }
                idx[d] = 0;
            }
        }
        Ok(out)
    }

    /// The float32 tensor `t`, values in row-major order (other dtypes are refused).
    pub fn read_f32(&mut self, t: &TensorRef) -> Result<Vec<f32>, String> {
        if t.storage_class != "FloatStorage" {
            return Err(format!(
                "tensor storage is {}, expected FloatStorage (float32)",
                t.storage_class
            ));
        }
        self.gather(t, |_, b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// Tensor `t` of any supported dtype (float32, float64, int64, int32) as float64 values in
    /// row-major order.
    pub fn read_f64(&mut self, t: &TensorRef) -> Result<Vec<f64>, String> {
        self.gather(t, |d, b| match d {
            Dtype::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Dtype::I32 => f64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Dtype::F64 => f64::from_le_bytes(b.try_into().expect("8 bytes")),
            Dtype::I64 => i64::from_le_bytes(b.try_into().expect("8 bytes")) as f64,
        })
    }
}

/// All of a zip entry whose declared size the caller has bounded: reading to the end lets the zip
/// layer verify the CRC-32, and one byte past the declared size is the most ever read. Memory is
/// reserved up front only for `reserve` (a stored entry, which the file's length bounds).
fn read_entry(entry: &mut impl Read, size: u64, reserve: bool) -> std::io::Result<Vec<u8>> {
    let mut bytes = Vec::with_capacity(if reserve { size } else { size.min(1 << 26) } as usize);
    entry.take(size.saturating_add(1)).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > size {
        return Err(std::io::Error::other(format!(
            "the entry holds more than its declared {size} bytes"
        )));
    }
    Ok(bytes)
}

/// Open the archive at `path` (see [`TorchZip::new`]).
pub fn open(
    path: &Path,
    max_pickle: u64,
) -> Result<TorchZip<std::io::BufReader<std::fs::File>>, TorchError> {
    let file = std::fs::File::open(path).map_err(TorchError::Io)?;
    TorchZip::new(std::io::BufReader::new(file), max_pickle)
}
