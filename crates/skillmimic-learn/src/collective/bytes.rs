//! Byte strings over the collective's float operations (the exact-resume state of every rank):
//! bytes travel as little-endian 32-bit words, each held exactly by one `f64`; a gather sums
//! buffers in which every rank fills only its own span (zeros elsewhere), so the sum is exact.

use super::Collective;
use crate::error::LearnError;

fn to_words(bytes: &[u8], out: &mut [f64]) {
    for (w, c) in out.iter_mut().zip(bytes.chunks(4)) {
        let mut b = [0u8; 4];
        b[..c.len()].copy_from_slice(c);
        *w = f64::from(u32::from_le_bytes(b));
    }
}

fn from_words(words: &[f64], len: usize) -> Vec<u8> {
    let mut out: Vec<u8> = words.iter().flat_map(|&w| (w as u32).to_le_bytes()).collect();
    out.truncate(len);
    out
}

/// Word offsets of parts of `lens` bytes, and the total.
fn spans(lens: &[usize]) -> (Vec<usize>, usize) {
    let mut at = 0;
    let starts = lens
        .iter()
        .map(|&l| {
            let s = at;
            at += l.div_ceil(4);
            s
        })
        .collect();
    (starts, at)
}

/// Every rank's `mine`, in rank order, on every rank (collective: all ranks call it).
pub fn all_gather_bytes(
    comm: &mut dyn Collective,
    mine: &[u8],
) -> Result<Vec<Vec<u8>>, LearnError> {
    let (rank, world) = (comm.rank(), comm.world_size());
    let mut lens = vec![0.0f64; world];
    lens[rank] = mine.len() as f64;
    comm.all_reduce_f64(&mut lens)?;
    let lens: Vec<usize> = lens.iter().map(|&l| l as usize).collect();
    let (starts, total) = spans(&lens);
    let mut buf = vec![0.0f64; total];
    to_words(mine, &mut buf[starts[rank]..starts[rank] + lens[rank].div_ceil(4)]);
    comm.all_reduce_f64(&mut buf)?;
    Ok((0..world).map(|r| from_words(&buf[starts[r]..], lens[r])).collect())
}

/// Rank 0's `parts[r]` on rank `r` (collective: all ranks call it; `parts` is read on rank 0
/// only and must hold one part per rank there). Returns this rank's part.
pub fn scatter_bytes(comm: &mut dyn Collective, parts: &[Vec<u8>]) -> Result<Vec<u8>, LearnError> {
    let (rank, world) = (comm.rank(), comm.world_size());
    let mut lens = vec![0.0f64; world];
    if rank == 0 {
        assert_eq!(parts.len(), world, "one part per rank");
        for (l, p) in lens.iter_mut().zip(parts) {
            *l = p.len() as f64;
        }
    }
    comm.broadcast_f64(&mut lens)?;
    let lens: Vec<usize> = lens.iter().map(|&l| l as usize).collect();
    let (starts, total) = spans(&lens);
    let mut buf = vec![0.0f64; total];
    if rank == 0 {
        for (r, p) in parts.iter().enumerate() {
            to_words(p, &mut buf[starts[r]..starts[r] + lens[r].div_ceil(4)]);
        }
    }
    comm.broadcast_f64(&mut buf)?;
    Ok(from_words(&buf[starts[rank]..], lens[rank]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collective::threads::ThreadGroup;

    #[test]
    fn bytes_of_any_length_reach_every_rank_unchanged() {
        let parts: Vec<Vec<u8>> =
            vec![(0..13).map(|i| (i * 37 % 256) as u8).collect(), vec![], vec![255; 8]];
        let got: Vec<(Vec<Vec<u8>>, Vec<u8>)> = std::thread::scope(|s| {
            let hs: Vec<_> = ThreadGroup::new_group(3)
                .into_iter()
                .enumerate()
                .map(|(r, mut g)| {
                    let parts = &parts;
                    s.spawn(move || {
                        let all = all_gather_bytes(&mut g, &parts[r]).unwrap();
                        let given = if r == 0 { parts.clone() } else { Vec::new() };
                        (all, scatter_bytes(&mut g, &given).unwrap())
                    })
                })
                .collect();
            hs.into_iter().map(|h| h.join().unwrap()).collect()
        });
        for (r, (all, mine)) in got.iter().enumerate() {
            assert_eq!(all, &parts, "rank {r} gathered");
            assert_eq!(mine, &parts[r], "rank {r} received");
        }
    }
}
