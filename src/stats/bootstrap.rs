//! The percentile bootstrap: resamples of the items drawn with replacement
//! from a specified stream, and percentile intervals of a statistic over
//! them.
//!
//! A resample is given as the multiplicity of each item, so that one set of
//! resamples serves every metric (each metric keeps the resampled items that
//! have its value) and rank statistics need no new sort
//! ([`super::correlation::Paired::correlations_weighted`]).

use rayon::prelude::*;

use super::rng::{below, stream, BOOTSTRAP};
use super::{Estimate, Undefined};

/// How many resamples to draw, and from which seed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Bootstrap {
    /// The number of resamples.
    pub resamples: usize,
    /// The seed of the random streams.
    pub seed: u64,
}

impl Bootstrap {
    /// The multiplicities of `n` items in resample `b`: `n` draws with
    /// replacement, uniform over the items, from stream `BOOTSTRAP + b`.
    pub fn counts(&self, b: usize, n: usize) -> Vec<u32> {
        let mut rng = stream(self.seed, BOOTSTRAP + b as u64);
        let mut counts = vec![0u32; n];
        for _ in 0..n {
            counts[below(&mut rng, n as u64) as usize] += 1;
        }
        counts
    }

    /// `statistic` of every resample of `n` items, in resample order (drawn
    /// and computed in parallel; the result does not depend on the threads).
    pub fn map<T: Send>(&self, n: usize, statistic: impl Fn(&[u32]) -> T + Sync) -> Vec<T> {
        (0..self.resamples)
            .into_par_iter()
            .map(|b| statistic(&self.counts(b, n)))
            .collect()
    }
}

/// The percentile interval holding the central `level` (e.g. 0.95) of the
/// defined values, by linear interpolation between order statistics (as
/// `numpy.percentile`). Undefined values are left out; with none defined,
/// the interval is undefined.
pub fn percentile_interval(
    values: impl IntoIterator<Item = Estimate>,
    level: f64,
) -> Result<[f64; 2], Undefined> {
    let mut defined: Vec<f64> = values.into_iter().filter_map(Result::ok).collect();
    if defined.is_empty() {
        return Err(Undefined::NoResample);
    }
    defined.sort_unstable_by(f64::total_cmp);
    let tail = (1.0 - level) / 2.0;
    Ok([percentile(&defined, tail), percentile(&defined, 1.0 - tail)])
}

/// The `q` quantile (0..=1) of sorted, non-empty values, interpolated
/// linearly between the two nearest order statistics.
pub fn percentile(sorted: &[f64], q: f64) -> f64 {
    let h = (sorted.len() - 1) as f64 * q.clamp(0.0, 1.0);
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(sorted.len() - 1);
    let t = h - lo as f64;
    sorted[lo] + (sorted[hi] - sorted[lo]) * t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resamples_are_fixed_by_the_seed_and_keep_the_size() {
        let boot = Bootstrap {
            resamples: 3,
            seed: 11,
        };
        let all = boot.map(50, |c| c.to_vec());
        assert_eq!(all.len(), 3);
        assert!(all.iter().all(|c| c.iter().sum::<u32>() == 50));
        assert_eq!(all, boot.map(50, |c| c.to_vec()));
        assert_ne!(all[0], all[1]);
        let other = Bootstrap { seed: 12, ..boot };
        assert_ne!(all, other.map(50, |c| c.to_vec()));
    }

    #[test]
    fn percentiles_interpolate_like_numpy() {
        // numpy.percentile([1, 2, 3, 4, 10], [2.5, 97.5]) = [1.1, 9.4]
        let values = [4.0, 1.0, 10.0, 3.0, 2.0].map(Ok);
        let [lo, hi] = percentile_interval(values, 0.95).unwrap_or([f64::NAN; 2]);
        assert!(
            (lo - 1.1).abs() < 1e-12 && (hi - 9.4).abs() < 1e-12,
            "{lo} {hi}"
        );
        let one = percentile_interval([Ok(0.5), Err(Undefined::TooFewItems)], 0.95);
        assert_eq!(one, Ok([0.5, 0.5]));
        assert_eq!(
            percentile_interval([Err(Undefined::TooFewItems)], 0.95),
            Err(Undefined::NoResample)
        );
    }
}
