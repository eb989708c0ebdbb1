//! The motion prior's resume state beside its checkpoint tensors: the window-draw stream, every
//! environment's current window and whether it restarts, and each discriminator's buffer of
//! simulated windows with its fill level and write position. With the tensors (networks,
//! normalisers, Adam) this is everything the next iteration reads.
//!
//! Size: the buffers dominate (`ppo.amp.buffer` × window width floats per discriminator); they
//! are saved with every checkpoint.

use serde::{Deserialize, Serialize};

use super::AmpReward;

#[derive(Serialize)]
struct Out<'a> {
    rng: &'a rand_chacha::ChaCha8Rng,
    rings: &'a [f32],
    fresh: &'a [bool],
    /// (buffer, filled, next) per discriminator.
    priors: Vec<(&'a [f32], usize, usize)>,
}

#[derive(Deserialize)]
struct In {
    rng: rand_chacha::ChaCha8Rng,
    rings: Vec<f32>,
    fresh: Vec<bool>,
    priors: Vec<(Vec<f32>, usize, usize)>,
}

pub(super) fn save(a: &AmpReward) -> Vec<u8> {
    let out = Out {
        rng: &a.rng,
        rings: &a.rings,
        fresh: &a.fresh,
        priors: a.priors.iter().map(|p| (p.buffer.as_slice(), p.filled, p.next)).collect(),
    };
    postcard::to_stdvec(&out).expect("plain numbers encode")
}

pub(super) fn restore(a: &mut AmpReward, bytes: &[u8]) -> Result<(), String> {
    let s: In =
        postcard::from_bytes(bytes).map_err(|e| format!("motion prior state unreadable ({e})"))?;
    let here: Vec<usize> = a.priors.iter().map(|p| p.buffer.len()).collect();
    let saved: Vec<usize> = s.priors.iter().map(|p| p.0.len()).collect();
    if s.rings.len() != a.rings.len()
        || s.fresh.len() != a.fresh.len()
        || s.priors.len() != a.priors.len()
        || s.priors
            .iter()
            .zip(&a.priors)
            .any(|(x, p)| x.0.len() != p.buffer.len() || x.1 > p.buffer.len())
    {
        return Err(format!(
            "motion prior state: saved windows of {} environments and buffers of {saved:?} \
                values, here {} and {here:?} (or a fill level past the buffer)",
            s.fresh.len(),
            a.fresh.len()
        ));
    }
    a.rng = s.rng;
    a.rings = s.rings;
    a.fresh = s.fresh;
    for (p, (buffer, filled, next)) in a.priors.iter_mut().zip(s.priors) {
        p.buffer = buffer;
        p.filled = filled;
        p.next = next;
    }
    Ok(())
}
