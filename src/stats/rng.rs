//! The random streams of the resampling statistics: ChaCha20 (a generator
//! whose output is specified, so the same seed gives the same intervals on
//! every machine and in every version), one stream per resample so that
//! resamples can be drawn in parallel and still in a fixed order.

use rand_chacha::rand_core::{RngCore, SeedableRng};
use rand_chacha::ChaCha20Rng;

/// The stream numbers of the bootstrap start here (resample `b` uses
/// `BOOTSTRAP + b`).
pub const BOOTSTRAP: u64 = 0;
/// The stream numbers of the permutation test start here (permutation `p`
/// uses `PERMUTATION + p`).
pub const PERMUTATION: u64 = 1 << 63;

/// The generator of stream `stream` under `seed`: ChaCha20 keyed by
/// `seed_from_u64(seed)` with its stream (nonce) set to `stream`.
pub fn stream(seed: u64, stream: u64) -> ChaCha20Rng {
    let mut rng = ChaCha20Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    rng
}

/// A uniform integer in `0..n` (`n > 0`), without bias: Lemire's
/// multiply-and-reject on 64-bit words.
pub fn below(rng: &mut impl RngCore, n: u64) -> u64 {
    let mut m = u128::from(rng.next_u64()) * u128::from(n);
    if (m as u64) < n {
        let threshold = n.wrapping_neg() % n;
        while (m as u64) < threshold {
            m = u128::from(rng.next_u64()) * u128::from(n);
        }
    }
    (m >> 64) as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_stream_is_fixed_by_seed_and_number() {
        let draw = |seed, s| {
            let mut rng = stream(seed, s);
            (0..5).map(|_| below(&mut rng, 10)).collect::<Vec<_>>()
        };
        assert_eq!(draw(7, 3), draw(7, 3));
        assert_ne!(draw(7, 3), draw(7, 4));
        assert_ne!(draw(7, 3), draw(8, 3));
        // The stream is specified: these words must never change.
        let mut rng = stream(0, 0);
        assert_eq!(rng.next_u64(), 449_479_075_714_955_186);
    }

    #[test]
    fn below_stays_in_range_and_hits_every_value() {
        let mut rng = stream(1, 0);
        let mut seen = [0u32; 7];
        for _ in 0..7000 {
            seen[below(&mut rng, 7) as usize] += 1;
        }
        assert!(seen.iter().all(|&c| (800..1200).contains(&c)), "{seen:?}");
    }
}
