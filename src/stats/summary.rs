//! The mean and the sample standard deviation of a list of values, and a
//! [`Spread`] (mean, sd, min–max): what the spread of a run's samples, the
//! spread of Table 3 over samples and the change between two runs are
//! stated in.

use super::{Estimate, Undefined};

/// The arithmetic mean; undefined for no values.
pub fn mean(values: &[f64]) -> Estimate {
    if values.is_empty() {
        return Err(Undefined::TooFewItems);
    }
    Ok(values.iter().sum::<f64>() / values.len() as f64)
}

/// The sample standard deviation (divided by n − 1, as `numpy.std(ddof=1)`);
/// undefined for fewer than two values.
pub fn sd(values: &[f64]) -> Estimate {
    if values.len() < 2 {
        return Err(Undefined::TooFewItems);
    }
    let m = mean(values)?;
    let squares: f64 = values.iter().map(|v| (v - m) * (v - m)).sum();
    Ok((squares / (values.len() - 1) as f64).sqrt())
}

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
        let mean = mean(&values).ok()?;
        let sd = sd(&values).ok();
        let min = values.iter().copied().fold(f64::INFINITY, f64::min);
        let max = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Some(Spread {
            count: values.len(),
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
    fn mean_and_sd_match_numpy_and_refuse_too_few_values() {
        // numpy.mean([1, 2, 4]) = 2.3333…, numpy.std([1, 2, 4], ddof=1) = 1.5275252316519465
        assert!((mean(&[1.0, 2.0, 4.0]).unwrap_or(f64::NAN) - 7.0 / 3.0).abs() < 1e-15);
        assert!((sd(&[1.0, 2.0, 4.0]).unwrap_or(f64::NAN) - 1.527_525_231_651_946_5).abs() < 1e-15);
        assert_eq!(mean(&[]), Err(Undefined::TooFewItems));
        assert_eq!(sd(&[0.5]), Err(Undefined::TooFewItems));
        assert_eq!(sd(&[0.5, 0.5]), Ok(0.0));
    }

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
