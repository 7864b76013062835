//! The mean and spread of repeated measurements: the scores of a plan's
//! samples, for the Scores pane, Table 3 and the run history.

/// The mean, sample standard deviation and range of some values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spread {
    /// How many values.
    pub count: usize,
    /// Their mean.
    pub mean: f64,
    /// Their sample standard deviation (n − 1 in the denominator); `None`
    /// for a single value, whose spread is unknown rather than zero.
    pub sd: Option<f64>,
    /// The smallest value.
    pub min: f64,
    /// The largest value.
    pub max: f64,
}

impl Spread {
    /// The spread of `values`; `None` when there is none. Values that are
    /// not finite are left out.
    pub fn of(values: impl IntoIterator<Item = f64>) -> Option<Spread> {
        let values: Vec<f64> = values.into_iter().filter(|v| v.is_finite()).collect();
        let count = values.len();
        if count == 0 {
            return None;
        }
        let mean = values.iter().sum::<f64>() / count as f64;
        let sd = (count > 1).then(|| {
            let squares: f64 = values.iter().map(|v| (v - mean).powi(2)).sum();
            (squares / (count - 1) as f64).sqrt()
        });
        let min = values.iter().copied().fold(f64::INFINITY, f64::min);
        let max = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Some(Spread {
            count,
            mean,
            sd,
            min,
            max,
        })
    }

    /// `0.433 ±0.020` with `digits` decimals (the mean alone when the
    /// standard deviation is unknown).
    pub fn plus_minus(&self, digits: usize) -> String {
        match self.sd {
            Some(sd) => format!("{:.digits$} ±{sd:.digits$}", self.mean),
            None => format!("{:.digits$}", self.mean),
        }
    }

    /// `0.410–0.455` with `digits` decimals.
    pub fn range(&self, digits: usize) -> String {
        format!("{:.digits$}–{:.digits$}", self.min, self.max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_spread_of_three_scores_is_their_mean_sample_sd_and_range() {
        let spread = Spread::of([0.41, 0.455, 0.434]).unwrap();
        assert_eq!(spread.count, 3);
        assert!((spread.mean - 0.433).abs() < 1e-12);
        // sqrt(((0.41-0.433)^2 + (0.455-0.433)^2 + (0.434-0.433)^2) / 2)
        let sd = ((0.023f64.powi(2) + 0.022f64.powi(2) + 0.001f64.powi(2)) / 2.0).sqrt();
        assert!((spread.sd.unwrap() - sd).abs() < 1e-12);
        assert_eq!((spread.min, spread.max), (0.41, 0.455));
        assert_eq!(spread.plus_minus(3), "0.433 ±0.023");
        assert_eq!(spread.range(3), "0.410–0.455");
    }

    #[test]
    fn one_value_has_no_sd_and_none_has_no_spread() {
        let one = Spread::of([0.5, f64::NAN]).unwrap();
        assert_eq!((one.count, one.sd), (1, None));
        assert_eq!(one.plus_minus(2), "0.50");
        assert_eq!(Spread::of([]), None);
    }
}
