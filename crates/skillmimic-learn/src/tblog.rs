//! TensorBoard scalar logs, written without a TensorBoard dependency.
//!
//! An event file is a TFRecord stream: per record `u64 length`, `u32 masked_crc32c(length)`,
//! the bytes, `u32 masked_crc32c(bytes)`, with `masked(c) = ((c >> 15) | (c << 17)) + 0xa282ead8`.
//! Each record is a protobuf `Event { double wall_time = 1; int64 step = 2; string file_version
//! = 3; Summary summary = 5; }` with `Summary { repeated Value value = 1; }` and
//! `Value { string tag = 1; float simple_value = 2; }`, encoded by hand below. The first record
//! carries `file_version = "brain.Event:2"`.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

fn masked_crc(data: &[u8]) -> u32 {
    let c = crc32c::crc32c(data);
    ((c >> 15) | (c << 17)).wrapping_add(0xa282_ead8)
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
pub fn encode_event(wall_time: f64, step: i64, file_version: Option<&str>, scalars: &[(&str, f32)]) -> Vec<u8> {
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

/// Appends scalar summaries to `events.out.tfevents.<time>.skillmimic` in a folder.
pub struct EventWriter {
    path: PathBuf,
    file: BufWriter<File>,
}

fn now() -> f64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_secs_f64()).unwrap_or(0.0)
}

impl EventWriter {
    /// Create a new event file in `dir`.
    pub fn create(dir: &Path) -> std::io::Result<Self> {
        std::fs::create_dir_all(dir)?;
        let t = now();
        let path = dir.join(format!("events.out.tfevents.{}.skillmimic", t as u64));
        let mut w = Self { file: BufWriter::new(File::create(&path)?), path };
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
    }
}
