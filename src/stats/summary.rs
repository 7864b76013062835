//! The mean and the sample standard deviation of a list of values: what the
//! spread of a run's samples and the change between two runs are stated in.

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
}
