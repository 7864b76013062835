//! Williams' t-test for two dependent Pearson correlations that share a
//! variable (Williams 1959, as Steiger 1980 recommends it and WMT's metric
//! evaluations use it): is the human score correlated more with one metric
//! than with another, over the same items?
//!
//! With r12 and r13 the correlations of the shared variable (the human
//! score) with the two metrics and r23 the correlation of the metrics,
//!
//! t = (r12 − r13) · √((n − 1)(1 + r23)) / √(2K (n − 1)/(n − 3) + ((r12 + r13)² / 4)(1 − r23)³),
//!
//! K = 1 − r12² − r13² − r23² + 2 r12 r13 r23, with n − 3 degrees of
//! freedom; the two-sided p-value comes from Student's t
//! ([`super::pvalue::student_t`]).

use super::correlation::Paired;
use super::pvalue::student_t;
use super::Undefined;

/// The fewest items Williams' test is defined on (n − 3 degrees of freedom).
pub const MIN_ITEMS: u64 = 4;

/// One Williams test, with the correlations it was computed from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Williams {
    /// Pearson's r of the shared column with the first column (r12).
    pub r_first: f64,
    /// Pearson's r of the shared column with the second column (r13).
    pub r_second: f64,
    /// Pearson's r of the first column with the second (r23).
    pub r_between: f64,
    /// The t statistic: positive when the first correlation is the larger.
    pub t: f64,
    /// Its degrees of freedom, n − 3.
    pub dof: u64,
    /// The two-sided p-value, `2 · scipy.stats.t.sf(|t|, n − 3)`.
    pub p_value: f64,
}

/// Williams' test of r12 against r13 over `n` items, r23 the correlation of
/// the two non-shared columns. Undefined below [`MIN_ITEMS`] items, when a
/// correlation is exactly ±1, or when the three columns are linearly
/// dependent (no variance left to test with).
pub fn williams(n: u64, r12: f64, r13: f64, r23: f64) -> Result<Williams, Undefined> {
    if n < MIN_ITEMS {
        return Err(Undefined::FewerThanFourItems);
    }
    if [r12, r13, r23].iter().any(|r| r.abs() >= 1.0) {
        return Err(Undefined::PerfectCorrelation);
    }
    let size = n as f64;
    let k = 1.0 - r12 * r12 - r13 * r13 - r23 * r23 + 2.0 * r12 * r13 * r23;
    let variance =
        2.0 * k * (size - 1.0) / (size - 3.0) + ((r12 + r13).powi(2) / 4.0) * (1.0 - r23).powi(3);
    if !(k > 0.0 && variance > 0.0) {
        return Err(Undefined::Collinear);
    }
    let t = (r12 - r13) * ((size - 1.0) * (1.0 + r23)).sqrt() / variance.sqrt();
    let dof = n - 3;
    Ok(Williams {
        r_first: r12,
        r_second: r13,
        r_between: r23,
        t,
        dof,
        p_value: student_t(t, dof as f64),
    })
}

/// Williams' test on three columns of equal length: `shared` (the human
/// score) against `first` and against `second` (two metrics), with
/// Pearson's r as `scipy.stats.pearsonr` computes it. A constant column or
/// too few items are reported as such.
pub fn williams_columns(
    shared: &[f64],
    first: &[f64],
    second: &[f64],
) -> Result<Williams, Undefined> {
    let n = shared.len().min(first.len()).min(second.len());
    if (n as u64) < MIN_ITEMS {
        return Err(Undefined::FewerThanFourItems);
    }
    // The metric is the first column of each pair, so that a constant one
    // is named as the metric.
    let r = |x: &[f64], y: &[f64]| Paired::new(&x[..n], &y[..n]).correlations().pearson;
    let r12 = r(first, shared)?;
    let r13 = r(second, shared)?;
    let r23 = r(first, second)?;
    williams(n as u64, r12, r13, r23)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(actual: f64, expected: f64, tolerance: f64) {
        assert!(
            (actual - expected).abs() <= tolerance * expected.abs(),
            "{actual:e} against {expected:e}"
        );
    }

    #[test]
    fn steigers_case_a_and_the_psych_example() {
        // Steiger (1980), case A, the example of R psych's `r.test(103, .4,
        // .5, .1)`: t = −0.89 on 100 df, p = 0.37 as printed there; the full
        // digits by the formula in scipy 1.17.1 (2 · t.sf(|t|, 100)).
        let w = williams(103, 0.4, 0.5, 0.1).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(w.dof, 100);
        assert_eq!(format!("{:.2} {:.2}", w.t, w.p_value), "-0.89 0.37");
        close(w.t, -0.8912799047605415, 1e-12);
        close(w.p_value, 0.3749185174912554, 1e-9);
        // psych's documentation prints p < 0.1000759 for this case at
        // eight digits.
        let w = williams(
            5105,
            0.693458895410494,
            0.695966022434845,
            0.988475791500198,
        )
        .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(format!("{:.7}", w.p_value), "0.1000759");
        close(w.t, -1.644784146316017, 1e-10);
        close(w.p_value, 0.10007593739697644, 1e-9);
        // A case of the definitional Python (scipy 1.17.1).
        let w = williams(103, 0.5, 0.3, 0.2).unwrap_or_else(|e| panic!("{e}"));
        close(w.t, 1.8255430082864283, 1e-12);
        close(w.p_value, 0.07090371555003869, 1e-9);
    }

    #[test]
    fn undefined_cases_say_why() {
        assert_eq!(
            williams(3, 0.4, 0.5, 0.1),
            Err(Undefined::FewerThanFourItems)
        );
        assert_eq!(
            williams(10, 1.0, 0.5, 0.5),
            Err(Undefined::PerfectCorrelation)
        );
        assert_eq!(
            williams(10, 0.4, 0.5, -1.0),
            Err(Undefined::PerfectCorrelation)
        );
        // r23 = 0.6 and r12 = 0.8, r13 = 0: K = 1 − 0.64 − 0.36 = 0.
        assert_eq!(williams(10, 0.8, 0.0, 0.6), Err(Undefined::Collinear));
        let h = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(
            williams_columns(&h, &[0.1, 0.1, 0.1, 0.1], &[0.4, 0.3, 0.2, 0.1]),
            Err(Undefined::Constant(super::super::Column::First))
        );
        assert_eq!(
            williams_columns(&h[..3], &h[..3], &h[..3]),
            Err(Undefined::FewerThanFourItems)
        );
    }

    #[test]
    fn columns_give_the_correlations_of_the_formula() {
        let human = [1.0, 3.0, 2.0, 5.0, 4.0, 3.0];
        let a = [0.1, 0.5, 0.4, 0.9, 0.6, 0.2];
        let b = [0.3, 0.2, 0.5, 0.7, 0.9, 0.4];
        let w = williams_columns(&human, &a, &b).unwrap_or_else(|e| panic!("{e}"));
        let r = |x: &[f64], y: &[f64]| Paired::new(x, y).correlations().pearson.unwrap_or(f64::NAN);
        assert_eq!(
            (w.r_first, w.r_second, w.r_between),
            (r(&a, &human), r(&b, &human), r(&a, &b))
        );
        let by_formula = williams(6, w.r_first, w.r_second, w.r_between);
        assert_eq!(by_formula, Ok(w));
        // Swapping the metrics flips t and keeps p.
        let swapped = williams_columns(&human, &b, &a).unwrap_or_else(|e| panic!("{e}"));
        close(swapped.t, -w.t, 1e-12);
        close(swapped.p_value, w.p_value, 1e-12);
    }
}
