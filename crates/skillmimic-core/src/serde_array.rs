//! serde for fixed-size arrays of any length (serde's own impls stop at 32 elements), for
//! `#[serde(with = "skillmimic_core::serde_array")]` on a field `[T; N]`: encoded as a sequence of
//! `N` elements; decoding a sequence of another length is an error naming both lengths.

use serde::de::Error;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// Encode `a` as a sequence.
pub fn serialize<S: Serializer, T: Serialize, const N: usize>(
    a: &[T; N],
    s: S,
) -> Result<S::Ok, S::Error> {
    a.as_slice().serialize(s)
}

/// Decode a sequence of exactly `N` elements.
pub fn deserialize<'de, D: Deserializer<'de>, T: Deserialize<'de>, const N: usize>(
    d: D,
) -> Result<[T; N], D::Error> {
    let v = Vec::<T>::deserialize(d)?;
    let len = v.len();
    v.try_into().map_err(|_| D::Error::custom(format!("expected {N} elements, got {len}")))
}
