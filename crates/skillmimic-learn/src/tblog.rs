//! TensorBoard scalar logs, written without a TensorBoard dependency.
//!
//! An event file is a TFRecord stream: per record `u64 length`, `u32 masked_crc32c(length)`,
//! the bytes, `u32 masked_crc32c(bytes)`, with `masked(c) = ((c >> 15) | (c << 17)) + 0xa282ead8`.
//! Each record is a protobuf `Event { double wall_time = 1; int64 step = 2; string file_version
//! = 3; Summary summary = 5; }` with `Summary { repeated Value value = 1; }` and
//! `Value { string tag = 1; float simple_value = 2; }`, encoded by hand below. The first record
//! carries `file_version = "brain.Event:2"`.
//!
//! The files can be read back ([`read_events`]) and cut to the steps a resumed run starts from
//! ([`truncate_dir`]), so a resumed run never logs a step twice.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

fn masked_crc(data: &[u8]) -> u32 {
    let c = crc32c::crc32c(data);
    c.rotate_right(15).wrapping_add(0xa282_ead8)
}

fn varint(mut v: u64, out: &mut Vec<u8>) {
    loop {
        let b = (v & 0x7f) as u8;
        v >>= 7;
        if v == 0 {
            out.push(b);
            break;
        }
        out.push(b | 0x80);
    }
}

fn field_bytes(field: u32, bytes: &[u8], out: &mut Vec<u8>) {
    varint(((field << 3) | 2) as u64, out);
    varint(bytes.len() as u64, out);
    out.extend_from_slice(bytes);
}

/// Encode an `Event` with a wall time, a step and either a file version or scalar values.
pub fn encode_event(
    wall_time: f64,
    step: i64,
    file_version: Option<&str>,
    scalars: &[(&str, f32)],
) -> Vec<u8> {
    let mut ev = Vec::new();
    ev.push((1 << 3) | 1); // wall_time, fixed64
    ev.extend_from_slice(&wall_time.to_le_bytes());
    varint((2 << 3) as u64, &mut ev); // step, varint
    varint(step as u64, &mut ev);
    if let Some(v) = file_version {
        field_bytes(3, v.as_bytes(), &mut ev);
    }
    if !scalars.is_empty() {
        let mut summary = Vec::new();
        for (tag, value) in scalars {
            let mut val = Vec::new();
            field_bytes(1, tag.as_bytes(), &mut val);
            val.push((2 << 3) | 5); // simple_value, fixed32
            val.extend_from_slice(&value.to_le_bytes());
            field_bytes(1, &val, &mut summary);
        }
        field_bytes(5, &summary, &mut ev);
    }
    ev
}

/// Frame one record (TFRecord).
pub fn frame_record(data: &[u8], out: &mut Vec<u8>) {
    let len = (data.len() as u64).to_le_bytes();
    out.extend_from_slice(&len);
    out.extend_from_slice(&masked_crc(&len).to_le_bytes());
    out.extend_from_slice(data);
    out.extend_from_slice(&masked_crc(data).to_le_bytes());
}

/// The records of a TFRecord stream, up to the first incomplete or corrupt one (the tail of a
/// file cut short by a killed process is dropped).
pub fn read_records(bytes: &[u8]) -> Vec<&[u8]> {
    let mut out = Vec::new();
    let mut at = 0usize;
    while bytes.len() - at >= 12 {
        let len_bytes = &bytes[at..at + 8];
        let crc = u32::from_le_bytes(bytes[at + 8..at + 12].try_into().unwrap());
        let len = u64::from_le_bytes(len_bytes.try_into().unwrap());
        if crc != masked_crc(len_bytes) {
            break;
        }
        let start = at + 12;
        let Some(end) = usize::try_from(len)
            .ok()
            .and_then(|l| start.checked_add(l))
            .filter(|&e| e.checked_add(4).is_some_and(|x| x <= bytes.len()))
        else {
            break;
        };
        let data = &bytes[start..end];
        if u32::from_le_bytes(bytes[end..end + 4].try_into().unwrap()) != masked_crc(data) {
            break;
        }
        out.push(data);
        at = end + 4;
    }
    out
}

fn read_varint(b: &[u8], at: &mut usize) -> Option<u64> {
    let mut v = 0u64;
    for shift in (0..64).step_by(7) {
        let byte = *b.get(*at)?;
        *at += 1;
        v |= ((byte & 0x7f) as u64) << shift;
        if byte & 0x80 == 0 {
            return Some(v);
        }
    }
    None
}

/// An event read back: its step and whether it carries scalar values (the file-version header
/// does not).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EventInfo {
    pub step: i64,
    pub has_summary: bool,
}

/// The step and kind of an encoded `Event` (`None` if it is not a well-formed protobuf message).
pub fn decode_event(ev: &[u8]) -> Option<EventInfo> {
    let (mut at, mut info) = (0usize, EventInfo { step: 0, has_summary: false });
    while at < ev.len() {
        let key = read_varint(ev, &mut at)?;
        let skip = match key & 7 {
            0 => {
                let v = read_varint(ev, &mut at)?;
                if key >> 3 == 2 {
                    info.step = v as i64;
                }
                0
            }
            1 => 8,
            2 => {
                info.has_summary |= key >> 3 == 5;
                usize::try_from(read_varint(ev, &mut at)?).ok()?
            }
            5 => 4,
            _ => return None,
        };
        at = at.checked_add(skip).filter(|&e| e <= ev.len())?;
    }
    Some(info)
}

/// The events of an event file in order, up to the first unreadable record.
pub fn read_events(path: &Path) -> std::io::Result<Vec<EventInfo>> {
    let bytes = std::fs::read(path)?;
    Ok(read_records(&bytes).into_iter().map_while(decode_event).collect())
}

/// The event files (`*tfevents*`) of `dir`, sorted by name; none when `dir` does not exist.
pub fn event_files(dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut v = Vec::new();
    match std::fs::read_dir(dir) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(v),
        Err(e) => return Err(e),
        Ok(rd) => {
            for e in rd {
                let p = e?.path();
                let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
                if name.contains("tfevents") && !is_temp_name(name) && p.is_file() {
                    v.push(p);
                }
            }
        }
    }
    v.sort();
    Ok(v)
}

/// Whether `name` is an atomic write's temporary file, `<name>.tmp<pid>`; returns the pid.
pub fn temp_pid(name: &str) -> Option<u32> {
    let (_, pid) = name.rsplit_once(".tmp")?;
    if pid.is_empty() || !pid.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    pid.parse().ok()
}

fn is_temp_name(name: &str) -> bool {
    temp_pid(name).is_some()
}

/// Cut every event file of `dir` to the events with step ≤ `max_step` (the file-version header
/// stays; an unreadable tail is dropped). A file left with no scalar event is removed; a changed
/// file is rewritten atomically. Returns the number of scalar events removed.
pub fn truncate_dir(dir: &Path, max_step: i64) -> std::io::Result<usize> {
    let mut removed = 0;
    for path in event_files(dir)? {
        let bytes = std::fs::read(&path)?;
        let records = read_records(&bytes);
        let mut kept = Vec::with_capacity(bytes.len());
        let (mut scalars, mut total) = (0usize, 0usize);
        for r in &records {
            let Some(ev) = decode_event(r) else { break };
            total += 1;
            if !ev.has_summary || ev.step <= max_step {
                scalars += usize::from(ev.has_summary);
                frame_record(r, &mut kept);
            } else {
                removed += 1;
            }
        }
        if scalars == 0 {
            std::fs::remove_file(&path)?;
        } else if kept.len() != bytes.len() || total != records.len() {
            skillmimic_core::tensorfile::write_bytes_atomic(&path, &kept)?;
        }
    }
    Ok(removed)
}

/// Appends scalar summaries to `events.out.tfevents.<time>.skillmimic` in a folder.
pub struct EventWriter {
    path: PathBuf,
    file: BufWriter<File>,
}

fn now() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}

impl EventWriter {
    /// Create a new event file in `dir` (never an existing one: a second file started in the
    /// same second gets the suffix `.1`, `.2`, …).
    pub fn create(dir: &Path) -> std::io::Result<Self> {
        std::fs::create_dir_all(dir)?;
        let t = now();
        let base = format!("events.out.tfevents.{}.skillmimic", t as u64);
        let mut k = 0u32;
        let (path, file) = loop {
            let path = dir.join(if k == 0 { base.clone() } else { format!("{base}.{k}") });
            match std::fs::OpenOptions::new().write(true).create_new(true).open(&path) {
                Ok(f) => break (path, f),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && k < 1000 => k += 1,
                Err(e) => return Err(e),
            }
        };
        let mut w = Self { file: BufWriter::new(file), path };
        w.write_event(&encode_event(t, 0, Some("brain.Event:2"), &[]))?;
        Ok(w)
    }

    /// Path of the event file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    fn write_event(&mut self, ev: &[u8]) -> std::io::Result<()> {
        let mut rec = Vec::with_capacity(ev.len() + 16);
        frame_record(ev, &mut rec);
        self.file.write_all(&rec)
    }

    /// Log scalars at `step` and flush.
    pub fn scalars(&mut self, step: i64, values: &[(&str, f32)]) -> std::io::Result<()> {
        self.write_event(&encode_event(now(), step, None, values))?;
        self.file.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_and_encoding_by_hand() {
        // CRC-32C of "123456789" is 0xe3069283 (the standard check value)
        assert_eq!(crc32c::crc32c(b"123456789"), 0xe306_9283);
        let mut v = Vec::new();
        varint(300, &mut v);
        assert_eq!(v, vec![0xac, 0x02]);
        let ev = encode_event(1.5, 7, None, &[("a", 2.0)]);
        // wall_time tag 0x09 + 8 bytes, step tag 0x10 + 7, summary tag 0x2a ...
        assert_eq!(ev[0], 0x09);
        assert_eq!(&ev[1..9], &1.5f64.to_le_bytes());
        assert_eq!(&ev[9..11], &[0x10, 7]);
        assert_eq!(ev[11], 0x2a);
        // summary { value { tag "a", simple_value 2.0 } }
        assert_eq!(&ev[12..], &[10, 0x0a, 8, 0x0a, 1, b'a', 0x15, 0, 0, 0, 0x40]);
        assert_eq!(decode_event(&ev), Some(EventInfo { step: 7, has_summary: true }));
        assert_eq!(
            decode_event(&encode_event(0.0, 0, Some("brain.Event:2"), &[])),
            Some(EventInfo { step: 0, has_summary: false })
        );
        assert_eq!(decode_event(&ev[..ev.len() - 2]), None, "a cut message is not an event");
        assert_eq!(temp_pid("latest.safetensors.tmp4242"), Some(4242));
        assert_eq!(temp_pid("a.tmp"), None);
        assert_eq!(temp_pid("a.tmpx1"), None);
    }

    #[test]
    fn read_back_and_truncate() {
        let dir = std::env::temp_dir().join(format!("sm-tblog-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let mut w = EventWriter::create(&dir).unwrap();
        let mut w2 = EventWriter::create(&dir).unwrap();
        assert_ne!(w.path(), w2.path(), "two writers in one second get two files");
        for step in [10, 20, 30] {
            w.scalars(step, &[("x", step as f32)]).unwrap();
        }
        w2.scalars(40, &[("x", 1.0)]).unwrap();
        let (p1, p2) = (w.path().to_path_buf(), w2.path().to_path_buf());
        drop((w, w2));
        // a record cut short by a kill: dropped on reading
        let mut bytes = std::fs::read(&p1).unwrap();
        let whole = bytes.len();
        let mut extra = Vec::new();
        frame_record(&encode_event(1.0, 50, None, &[("x", 5.0)]), &mut extra);
        bytes.extend_from_slice(&extra[..extra.len() - 3]);
        std::fs::write(&p1, &bytes).unwrap();
        let steps = |p: &Path| {
            read_events(p)
                .unwrap()
                .iter()
                .filter(|e| e.has_summary)
                .map(|e| e.step)
                .collect::<Vec<_>>()
        };
        assert_eq!(steps(&p1), vec![10, 20, 30]);
        assert_eq!(truncate_dir(&dir, 20).unwrap(), 2);
        assert_eq!(steps(&p1), vec![10, 20]);
        assert!(std::fs::read(&p1).unwrap().len() < whole);
        assert!(!p2.exists(), "a file with no step left is removed");
        assert_eq!(event_files(&dir).unwrap(), vec![p1.clone()]);
        assert_eq!(truncate_dir(&dir, 20).unwrap(), 0);
        std::fs::remove_dir_all(&dir).ok();
    }
}
