//! safetensors files: atomic writing and validated reading, shared by clips, traces and
//! checkpoints.
//!
//! Writing goes to `<path>.tmp` first and is renamed into place, so a crash never leaves a
//! partially written file under the final name. Reading checks every tensor's dtype and shape and
//! names the file, the tensor and the expected value in its errors.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use safetensors::tensor::Dtype;

/// Error reading a tensor file.
#[derive(Debug, thiserror::Error)]
pub enum TensorFileError {
    /// (The I/O error is part of the message, not a `source`, so error chains do not repeat it.)
    #[error("{path}: cannot read file: {error}")]
    Io { path: PathBuf, error: std::io::Error },
    #[error("{path}: not a safetensors file: {detail}")]
    Format { path: PathBuf, detail: String },
    #[error("{path}: tensor '{name}' is missing")]
    Missing { path: PathBuf, name: String },
    #[error("{path}: tensor '{name}' has dtype {got}, expected {expected}")]
    Dtype { path: PathBuf, name: String, got: String, expected: &'static str },
    #[error("{path}: tensor '{name}' has shape {got:?}, expected {expected}")]
    Shape { path: PathBuf, name: String, got: Vec<usize>, expected: String },
    #[error("{path}: tensor '{name}' holds a non-finite value at flat index {index}")]
    NonFinite { path: PathBuf, name: String, index: usize },
    #[error("{path}: metadata field '{key}' {detail}")]
    Metadata { path: PathBuf, key: String, detail: String },
}

/// An owned tensor to be written.
#[derive(Clone, Debug)]
pub struct OwnedTensor {
    pub name: String,
    pub dtype: Dtype,
    pub shape: Vec<usize>,
    pub bytes: Vec<u8>,
}

impl OwnedTensor {
    /// A float32 tensor (little endian).
    pub fn f32(name: &str, shape: &[usize], data: &[f32]) -> Self {
        assert_eq!(
            shape.iter().product::<usize>(),
            data.len(),
            "tensor '{name}': shape/data mismatch"
        );
        Self {
            name: name.into(),
            dtype: Dtype::F32,
            shape: shape.to_vec(),
            bytes: data.iter().flat_map(|x| x.to_le_bytes()).collect(),
        }
    }
    /// A float64 tensor (little endian).
    pub fn f64(name: &str, shape: &[usize], data: &[f64]) -> Self {
        assert_eq!(
            shape.iter().product::<usize>(),
            data.len(),
            "tensor '{name}': shape/data mismatch"
        );
        Self {
            name: name.into(),
            dtype: Dtype::F64,
            shape: shape.to_vec(),
            bytes: data.iter().flat_map(|x| x.to_le_bytes()).collect(),
        }
    }
    /// A byte tensor (opaque encoded data, e.g. a training run's resume state).
    pub fn u8(name: &str, data: &[u8]) -> Self {
        Self { name: name.into(), dtype: Dtype::U8, shape: vec![data.len()], bytes: data.to_vec() }
    }
    /// An int64 tensor (little endian).
    pub fn i64(name: &str, shape: &[usize], data: &[i64]) -> Self {
        assert_eq!(
            shape.iter().product::<usize>(),
            data.len(),
            "tensor '{name}': shape/data mismatch"
        );
        Self {
            name: name.into(),
            dtype: Dtype::I64,
            shape: shape.to_vec(),
            bytes: data.iter().flat_map(|x| x.to_le_bytes()).collect(),
        }
    }
}

/// Serialise tensors + metadata to safetensors bytes, deterministically: the header lists the
/// metadata keys and the tensors sorted by name (the `safetensors` crate's own serialiser keeps
/// metadata in a `HashMap`, whose order changes from run to run), padded with spaces to a
/// multiple of 8 bytes as the format asks; tensor data follows in the same order.
pub fn to_bytes(tensors: &[OwnedTensor], metadata: &BTreeMap<String, String>) -> Vec<u8> {
    let mut sorted: Vec<&OwnedTensor> = tensors.iter().collect();
    sorted.sort_by(|a, b| a.name.cmp(&b.name));
    let mut header = serde_json::Map::new();
    if !metadata.is_empty() {
        let meta: serde_json::Map<String, serde_json::Value> = metadata
            .iter()
            .map(|(k, v)| (k.clone(), serde_json::Value::String(v.clone())))
            .collect();
        header.insert("__metadata__".into(), serde_json::Value::Object(meta));
    }
    let mut offset = 0usize;
    for t in &sorted {
        let dtype = match t.dtype {
            Dtype::F32 => "F32",
            Dtype::F64 => "F64",
            Dtype::I64 => "I64",
            Dtype::U8 => "U8",
            other => panic!("unsupported dtype {other:?}"),
        };
        assert_eq!(
            t.bytes.len(),
            t.shape.iter().product::<usize>() * t.dtype.bitsize() / 8,
            "tensor '{}'",
            t.name
        );
        let offsets = [offset, offset + t.bytes.len()];
        let info = serde_json::json!({ "dtype": dtype, "shape": t.shape, "data_offsets": offsets });
        header.insert(t.name.clone(), info);
        offset += t.bytes.len();
    }
    // serde_json's Map is ordered by key (no preserve_order feature): deterministic
    let mut head = serde_json::to_vec(&serde_json::Value::Object(header)).expect("json header");
    while !head.len().is_multiple_of(8) {
        head.push(b' ');
    }
    let mut out = Vec::with_capacity(8 + head.len() + offset);
    out.extend_from_slice(&(head.len() as u64).to_le_bytes());
    out.extend_from_slice(&head);
    for t in &sorted {
        out.extend_from_slice(&t.bytes);
    }
    out
}

/// Write a safetensors file atomically (temp file in the same folder, then rename).
///
/// Test hook: with the environment variable `SKILLMIMIC_TEST_WRITE_PAUSE_MS` set to a number of
/// milliseconds, the write stops for that long halfway through the temporary file (what is
/// written so far flushed to it), so that a test can kill the process inside a checkpoint write
/// for certain. Unset (the normal case), nothing pauses.
pub fn write_atomic(
    path: &Path,
    tensors: &[OwnedTensor],
    metadata: &BTreeMap<String, String>,
) -> std::io::Result<()> {
    write_atomic_pausing(path, &to_bytes(tensors, metadata), write_pause())
}

/// The pause of [`write_atomic`]'s test hook (read once per process).
fn write_pause() -> Option<std::time::Duration> {
    static PAUSE: std::sync::OnceLock<Option<std::time::Duration>> = std::sync::OnceLock::new();
    *PAUSE.get_or_init(|| {
        let ms = std::env::var("SKILLMIMIC_TEST_WRITE_PAUSE_MS").ok()?.trim().parse().ok()?;
        Some(std::time::Duration::from_millis(ms))
    })
}

/// Write `bytes` to `path` atomically (temp file in the same folder, fsync, rename).
pub fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    write_atomic_pausing(path, bytes, None)
}

/// [`write_bytes_atomic`] that sleeps for `pause` halfway through the temporary file.
fn write_atomic_pausing(
    path: &Path,
    bytes: &[u8],
    pause: Option<std::time::Duration>,
) -> std::io::Result<()> {
    use std::io::Write;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(format!(".tmp{}", std::process::id()));
    let tmp = PathBuf::from(tmp);
    {
        let mut f = std::fs::File::create(&tmp)?;
        let (head, tail) = bytes.split_at(if pause.is_some() { bytes.len() / 2 } else { 0 });
        f.write_all(head)?;
        if let Some(p) = pause {
            f.flush()?;
            std::thread::sleep(p);
        }
        f.write_all(tail)?;
        f.sync_all()?;
    }
    std::fs::rename(&tmp, path).inspect_err(|_| {
        let _ = std::fs::remove_file(&tmp);
    })
}

/// Largest JSON header [`TensorFile::open`] accepts (the `safetensors` crate's own limit).
pub const MAX_HEADER: u64 = 100_000_000;

/// The first tensor entry of the header whose shape, dtype and data offsets disagree (or overflow),
/// named, for errors the `safetensors` crate reports without a tensor name.
fn explain(bytes: &[u8], header_len: u64) -> Option<String> {
    let head = bytes.get(8..8usize.checked_add(usize::try_from(header_len).ok()?)?)?;
    let data_len = (bytes.len() - 8 - head.len()) as u64;
    let serde_json::Value::Object(map) = serde_json::from_slice(head).ok()? else { return None };
    for (name, info) in map.iter().filter(|(k, _)| *k != "__metadata__") {
        let shape: Vec<u64> = info
            .get("shape")?
            .as_array()?
            .iter()
            .map(serde_json::Value::as_u64)
            .collect::<Option<_>>()?;
        let bits = match info.get("dtype")?.as_str()? {
            "F64" | "I64" | "U64" => 64,
            "F32" | "I32" | "U32" => 32,
            "F16" | "BF16" | "I16" | "U16" => 16,
            "I8" | "U8" | "BOOL" => 8,
            _ => return None,
        };
        let offsets: Vec<u64> = info
            .get("data_offsets")?
            .as_array()?
            .iter()
            .map(serde_json::Value::as_u64)
            .collect::<Option<_>>()?;
        let Some(bytes_needed) = shape.iter().try_fold(bits / 8, |a: u64, &s| a.checked_mul(s))
        else {
            return Some(format!(
                "tensor '{name}': shape {shape:?} has more elements than 64 bits can count"
            ));
        };
        let [start, end] = offsets[..] else {
            return Some(format!("tensor '{name}': data_offsets {offsets:?} are not [start, end]"));
        };
        if end > data_len || start > end {
            return Some(format!(
                "tensor '{name}': data_offsets [{start}, {end}] lie outside the {data_len} data \
                    bytes of the file"
            ));
        }
        if end - start != bytes_needed {
            return Some(format!(
                "tensor '{name}': data_offsets [{start}, {end}] hold {} bytes, its shape \
                    {shape:?} needs {bytes_needed}",
                end - start
            ));
        }
    }
    None
}

/// A safetensors file read into memory.
pub struct TensorFile {
    path: PathBuf,
    bytes: Vec<u8>,
    metadata: BTreeMap<String, String>,
}

impl std::fmt::Debug for TensorFile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "TensorFile({})", self.path.display())
    }
}

impl TensorFile {
    /// Read and parse the header of `path`. The 8-byte header length is checked against the
    /// file's size and [`MAX_HEADER`] before the file is read; the `safetensors` crate then checks
    /// every tensor's dtype, shape product (overflow-checked) and data offsets against the data.
    pub fn open(path: &Path) -> Result<Self, TensorFileError> {
        use std::io::Read;
        let io = |error| TensorFileError::Io { path: path.into(), error };
        let format = |detail: String| TensorFileError::Format { path: path.into(), detail };
        let mut file = std::fs::File::open(path).map_err(io)?;
        let meta = file.metadata().map_err(io)?;
        let len = meta.len();
        if !meta.is_file() || len < 8 {
            return Err(format(format!(
                "{len} bytes; a safetensors file is a regular file starting with an 8-byte header \
                    length"
            )));
        }
        let mut head = [0u8; 8];
        file.read_exact(&mut head).map_err(io)?;
        let n = u64::from_le_bytes(head);
        if n > MAX_HEADER || n > len - 8 {
            return Err(format(format!(
                "header length field is {n} bytes, the file has {} after it (limit {MAX_HEADER})",
                len - 8
            )));
        }
        let mut bytes = Vec::with_capacity(len as usize);
        bytes.extend_from_slice(&head);
        file.read_to_end(&mut bytes).map_err(io)?;
        // the file may have changed size since; the crate checks the header length again
        let (_, meta) = safetensors::SafeTensors::read_metadata(&bytes)
            .map_err(|e| format(explain(&bytes, n).unwrap_or_else(|| e.to_string())))?;
        let metadata = meta.metadata().clone().unwrap_or_default().into_iter().collect();
        safetensors::SafeTensors::deserialize(&bytes).map_err(|e| format(e.to_string()))?;
        Ok(Self { path: path.into(), bytes, metadata })
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// All metadata entries.
    pub fn metadata(&self) -> &BTreeMap<String, String> {
        &self.metadata
    }

    /// A required metadata entry.
    pub fn meta(&self, key: &str) -> Result<&str, TensorFileError> {
        self.metadata.get(key).map(String::as_str).ok_or_else(|| TensorFileError::Metadata {
            path: self.path.clone(),
            key: key.into(),
            detail: "is missing".into(),
        })
    }

    /// Metadata entry parsed as `T`.
    pub fn meta_parse<T: std::str::FromStr>(
        &self,
        key: &str,
        expected: &str,
    ) -> Result<T, TensorFileError> {
        let v = self.meta(key)?;
        v.parse().map_err(|_| TensorFileError::Metadata {
            path: self.path.clone(),
            key: key.into(),
            detail: format!("is '{v}', expected {expected}"),
        })
    }

    /// Names of all tensors.
    pub fn names(&self) -> Vec<String> {
        let st = safetensors::SafeTensors::deserialize(&self.bytes).expect("checked on open");
        let mut n: Vec<String> = st.names().into_iter().map(str::to_owned).collect();
        n.sort();
        n
    }

    /// Shape of tensor `name`, if present.
    pub fn shape(&self, name: &str) -> Option<Vec<usize>> {
        let st = safetensors::SafeTensors::deserialize(&self.bytes).expect("checked on open");
        st.tensor(name).ok().map(|t| t.shape().to_vec())
    }

    fn raw(
        &self,
        name: &str,
        dtype: Dtype,
        expected: &'static str,
        shape: &[Option<usize>],
    ) -> Result<(Vec<usize>, Vec<u8>), TensorFileError> {
        let st = safetensors::SafeTensors::deserialize(&self.bytes).expect("checked on open");
        let t = st
            .tensor(name)
            .map_err(|_| TensorFileError::Missing { path: self.path.clone(), name: name.into() })?;
        if t.dtype() != dtype {
            return Err(TensorFileError::Dtype {
                path: self.path.clone(),
                name: name.into(),
                got: format!("{:?}", t.dtype()),
                expected,
            });
        }
        let got = t.shape().to_vec();
        let ok = got.len() == shape.len()
            && got.iter().zip(shape).all(|(g, e)| e.is_none_or(|e| e == *g));
        if !ok {
            let exp: Vec<String> =
                shape.iter().map(|e| e.map_or("*".to_string(), |v| v.to_string())).collect();
            return Err(TensorFileError::Shape {
                path: self.path.clone(),
                name: name.into(),
                got,
                expected: format!("({})", exp.join(", ")),
            });
        }
        Ok((got, t.data().to_vec()))
    }

    /// A float32 tensor whose shape matches `shape` (`None` = any size); values must be finite.
    pub fn f32(
        &self,
        name: &str,
        shape: &[Option<usize>],
    ) -> Result<(Vec<usize>, Vec<f32>), TensorFileError> {
        let (s, b) = self.raw(name, Dtype::F32, "F32", shape)?;
        let v: Vec<f32> =
            b.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
        if let Some(index) = v.iter().position(|x| !x.is_finite()) {
            return Err(TensorFileError::NonFinite {
                path: self.path.clone(),
                name: name.into(),
                index,
            });
        }
        Ok((s, v))
    }

    /// A float64 tensor whose shape matches `shape`; values must be finite.
    pub fn f64(
        &self,
        name: &str,
        shape: &[Option<usize>],
    ) -> Result<(Vec<usize>, Vec<f64>), TensorFileError> {
        let (s, b) = self.raw(name, Dtype::F64, "F64", shape)?;
        let v: Vec<f64> =
            b.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap())).collect();
        if let Some(index) = v.iter().position(|x| !x.is_finite()) {
            return Err(TensorFileError::NonFinite {
                path: self.path.clone(),
                name: name.into(),
                index,
            });
        }
        Ok((s, v))
    }

    /// A one-dimensional byte tensor of any length.
    pub fn u8(&self, name: &str) -> Result<Vec<u8>, TensorFileError> {
        Ok(self.raw(name, Dtype::U8, "U8", &[None])?.1)
    }

    /// Whether the file holds a tensor `name`.
    pub fn has(&self, name: &str) -> bool {
        self.shape(name).is_some()
    }

    /// An int64 tensor whose shape matches `shape`.
    pub fn i64(
        &self,
        name: &str,
        shape: &[Option<usize>],
    ) -> Result<(Vec<usize>, Vec<i64>), TensorFileError> {
        let (s, b) = self.raw(name, Dtype::I64, "I64", shape)?;
        Ok((s, b.chunks_exact(8).map(|c| i64::from_le_bytes(c.try_into().unwrap())).collect()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_validation() {
        let dir = std::env::temp_dir().join(format!("sm-tensorfile-{}", std::process::id()));
        let p = dir.join("t.safetensors");
        let mut meta = BTreeMap::new();
        meta.insert("fps".to_string(), "60".to_string());
        write_atomic(
            &p,
            &[
                OwnedTensor::f32("a", &[2, 3], &[1., 2., 3., 4., 5., 6.]),
                OwnedTensor::f64("b", &[1], &[0.5]),
            ],
            &meta,
        )
        .unwrap();
        let f = TensorFile::open(&p).unwrap();
        assert_eq!(f.meta("fps").unwrap(), "60");
        assert_eq!(f.meta_parse::<f64>("fps", "a number").unwrap(), 60.0);
        assert_eq!(
            f.f32("a", &[None, Some(3)]).unwrap(),
            (vec![2, 3], vec![1., 2., 3., 4., 5., 6.])
        );
        assert_eq!(f.f64("b", &[Some(1)]).unwrap().1, vec![0.5]);
        let e = f.f32("a", &[Some(3), None]).unwrap_err().to_string();
        assert!(e.contains("'a'") && e.contains("[2, 3]") && e.contains("(3, *)"), "{e}");
        assert!(f.f32("b", &[Some(1)]).unwrap_err().to_string().contains("expected F32"));
        assert!(f.f32("zzz", &[None]).unwrap_err().to_string().contains("missing"));
        assert!(f.meta("nope").is_err());
        std::fs::write(&p, b"garbage").unwrap();
        assert!(TensorFile::open(&p).unwrap_err().to_string().contains("not a safetensors file"));
        // no temp files left behind
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        // deterministic bytes, readable by the safetensors crate
        let tensors = [OwnedTensor::f32("z", &[2], &[1.0, 2.0]), OwnedTensor::i64("a", &[1], &[7])];
        let mut meta = BTreeMap::new();
        for k in ["b", "c", "a", "d"] {
            meta.insert(k.to_string(), k.repeat(3));
        }
        let bytes = to_bytes(&tensors, &meta);
        for _ in 0..5 {
            assert_eq!(to_bytes(&tensors, &meta), bytes);
        }
        let st = safetensors::SafeTensors::deserialize(&bytes).unwrap();
        assert_eq!(st.tensor("a").unwrap().data(), &7i64.to_le_bytes());
        let (n, m) = safetensors::SafeTensors::read_metadata(&bytes).unwrap();
        assert_eq!(n % 8, 0);
        assert_eq!(m.metadata().as_ref().unwrap().get("c").unwrap(), "ccc");
    }
}
