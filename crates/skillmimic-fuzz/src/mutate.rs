//! Mutations of byte inputs: raw (bit/byte flips, interesting integers at random offsets,
//! truncation, duplication, deletion, splicing), structure-aware for zip archives (mutate the
//! inner `data.pkl` or a storage entry and re-zip, so the entry CRCs stay valid; insert
//! deep-nesting and memo blow-up pickle runs), for safetensors headers (replace a number in the
//! JSON header and fix the length prefix) and for TOML text (replace a value).

use std::io::{Read, Write};

use rand::Rng;
use rand::seq::IndexedRandom;

/// Integers that break size arithmetic: 0, −1, 2^31, 2^32, 2^62, 2^63 − 1, u64::MAX, …
pub const INTERESTING: &[u64] = &[
    0,
    1,
    u64::MAX,
    0x7f,
    0x80,
    0xff,
    0xffff,
    1 << 31,
    (1 << 31) - 1,
    1 << 32,
    1 << 62,
    i64::MAX as u64,
    1 << 63,
];
/// Textual values for JSON/TOML numbers.
const INTERESTING_TEXT: &[&str] = &[
    "0",
    "-1",
    "1",
    "2147483648",
    "4294967296",
    "4611686018427387904",
    "9223372036854775807",
    "18446744073709551615",
    "1e308",
    "1e309",
    "-1e308",
    "nan",
    "inf",
    "-inf",
    "0.0",
    "-0.0",
    "1e-320",
    "100000",
    "\"x\"",
    "[]",
    "{}",
    "true",
];

fn random_bytes(r: &mut impl Rng, n: usize) -> Vec<u8> {
    (0..n).map(|_| r.random()).collect()
}

/// One raw mutation of `data` in place; `other` is a second corpus entry for splicing.
pub fn raw(r: &mut impl Rng, data: &mut Vec<u8>, other: &[u8]) {
    if data.is_empty() {
        let n = r.random_range(1..16);
        data.extend(random_bytes(r, n));
        return;
    }
    let len = data.len();
    let at = r.random_range(0..len);
    match r.random_range(0..10) {
        0 => data[at] ^= 1 << r.random_range(0..8),
        1 => data[at] = r.random(),
        2 => {
            // an interesting integer of 1, 2, 4 or 8 bytes, little or big endian
            let v = *INTERESTING.choose(r).expect("non-empty");
            let w = *[1usize, 2, 4, 8].choose(r).expect("non-empty");
            let bytes = if r.random() { v.to_le_bytes() } else { v.to_be_bytes() };
            let src = if r.random() { &bytes[..w] } else { &bytes[8 - w..] };
            for (k, b) in src.iter().enumerate() {
                if let Some(x) = data.get_mut(at + k) {
                    *x = *b;
                }
            }
        }
        3 => data.truncate(at),
        4 => {
            // duplicate a chunk
            let n = r.random_range(1..=(len - at).min(256));
            let chunk = data[at..at + n].to_vec();
            let to = r.random_range(0..=len);
            data.splice(to..to, chunk);
        }
        5 => {
            let n = r.random_range(1..=(len - at).min(64));
            data.drain(at..at + n);
        }
        6 => {
            let n = r.random_range(1..32);
            let b = random_bytes(r, n);
            data.splice(at..at, b);
        }
        7 if !other.is_empty() => {
            // splice: our head, the other input's tail
            let from = r.random_range(0..other.len());
            data.truncate(at);
            data.extend_from_slice(&other[from..]);
        }
        _ => {
            // a few bit flips
            for _ in 0..r.random_range(1..8) {
                let i = r.random_range(0..len);
                data[i] ^= 1 << r.random_range(0..8);
            }
        }
    }
}

/// Pickle runs a hostile archive may hold: deep nesting, memo blow-up, huge lengths.
fn pickle_run(r: &mut impl Rng) -> Vec<u8> {
    let n = r.random_range(1..20_000);
    match r.random_range(0..5) {
        0 => [&b")"[..], &vec![0x85; n]].concat(),
        1 => b"(".repeat(n),
        2 => [&b"]q\x00"[..], &b"h\x00h\x00\x86q\x00".repeat(n.min(200))].concat(),
        3 => [&b"X"[..], &(r.random::<u32>() | 0x8000_0000).to_le_bytes()].concat(),
        _ => [&b"}"[..], &b"(K\x01K\x02u".repeat(n.min(500))].concat(),
    }
}

/// The entries of a zip archive (name, bytes), if `data` is one.
pub fn unzip(data: &[u8]) -> Option<Vec<(String, Vec<u8>)>> {
    if !data.starts_with(b"PK") {
        return None;
    }
    let mut z = zip::ZipArchive::new(std::io::Cursor::new(data)).ok()?;
    let mut out = Vec::new();
    for i in 0..z.len() {
        let mut e = z.by_index(i).ok()?;
        if e.size() > 1 << 24 {
            return None;
        }
        let mut b = Vec::new();
        e.read_to_end(&mut b).ok()?;
        out.push((e.name().ok()?.into_owned(), b));
    }
    Some(out)
}

/// A stored (uncompressed) zip of `entries`, CRCs correct.
pub fn rezip(entries: &[(String, Vec<u8>)]) -> Vec<u8> {
    let mut z = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let o =
        zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
    for (name, bytes) in entries {
        if z.start_file(name.as_str(), o).is_ok() {
            let _ = z.write_all(bytes);
        }
    }
    z.finish().map(|c| c.into_inner()).unwrap_or_default()
}

/// Mutate an entry of the zip archive `data` (the pickle more often than a storage) and re-zip.
pub fn zip_inner(r: &mut impl Rng, data: &[u8], other: &[u8]) -> Option<Vec<u8>> {
    let mut entries = unzip(data)?;
    if entries.is_empty() {
        return None;
    }
    let pkl = entries.iter().position(|(n, _)| n.ends_with("data.pkl"));
    let k = match pkl {
        Some(p) if r.random_bool(0.7) => p,
        _ => r.random_range(0..entries.len()),
    };
    let target = &mut entries[k].1;
    if pkl == Some(k) && r.random_bool(0.15) {
        // insert a hostile pickle run somewhere before STOP
        let at = r.random_range(0..=target.len());
        let run = pickle_run(r);
        target.splice(at..at, run);
    } else {
        let other_inner =
            unzip(other).and_then(|e| e.into_iter().nth(k)).map(|e| e.1).unwrap_or_default();
        for _ in 0..r.random_range(1..4) {
            raw(r, target, &other_inner);
        }
    }
    if r.random_bool(0.05) {
        entries.remove(r.random_range(0..entries.len()));
    }
    Some(rezip(&entries))
}

/// Replace one number of a safetensors JSON header (fixing the length prefix), if `data` is a
/// safetensors file.
pub fn safetensors_header(r: &mut impl Rng, data: &[u8]) -> Option<Vec<u8>> {
    let n = usize::try_from(u64::from_le_bytes(data.get(..8)?.try_into().ok()?)).ok()?;
    let head = std::str::from_utf8(data.get(8..8usize.checked_add(n)?)?).ok()?;
    let new = replace_value(r, head)?;
    let mut out = (new.len() as u64).to_le_bytes().to_vec();
    out.extend_from_slice(new.as_bytes());
    out.extend_from_slice(&data[8 + n..]);
    Some(out)
}

/// `text` with one number or quoted value replaced by an interesting one.
pub fn replace_value(r: &mut impl Rng, text: &str) -> Option<String> {
    let b = text.as_bytes();
    let starts: Vec<usize> = (0..b.len())
        .filter(|&i| {
            (b[i].is_ascii_digit() || b[i] == b'"') && (i == 0 || !b[i - 1].is_ascii_alphanumeric())
        })
        .collect();
    let &s = starts.choose(r)?;
    let e = if b[s] == b'"' {
        s + 1 + b[s + 1..].iter().position(|&c| c == b'"')? + 1
    } else {
        s + b[s..]
            .iter()
            .position(|c| !(c.is_ascii_digit() || b".eE+-_".contains(c)))
            .unwrap_or(b.len() - s)
    };
    let value = *INTERESTING_TEXT.choose(r)?;
    // inside a JSON string (metadata values), keep the quotes
    let value = if b[s] == b'"' && r.random_bool(0.5) {
        format!("\"{}\"", value.trim_matches('"'))
    } else {
        value.to_string()
    };
    Some(format!("{}{}{}", &text[..s], value, &text[e..]))
}
