//! Krippendorff's alpha for nominal, ordinal and interval data, as the
//! `krippendorff` Python package computes it from coders × units with
//! missing values: coincidences within units, expected coincidences from
//! the pairable values, and `1 - D_o / D_e`.

use super::{Estimate, Undefined};

/// The level of measurement, which fixes the distance between two values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Level {
    /// Any two different values are equally far apart (categories, such as
    /// step labels coded as numbers).
    Nominal,
    /// Distances from the ranks of the values (how many pairable values lie
    /// between them).
    Ordinal,
    /// Squared differences of the values.
    Interval,
}

/// Krippendorff's alpha of `data`, one row per coder and one column per
/// unit (`None`: that coder did not judge that unit). Undefined when no
/// unit has two values, when all data hold one value, or when every
/// pairable value is the same.
pub fn alpha(data: &[Vec<Option<f64>>], level: Level) -> Estimate {
    let units = data.iter().map(Vec::len).max().unwrap_or(0);
    alpha_weighted(data, level, &vec![1; units])
}

/// Krippendorff's alpha of `data` with unit `u` counted `weights[u]` times
/// (a bootstrap resample of the units; weight 0 leaves a unit out, a unit
/// beyond `weights` counts 0): the alpha of the data with each unit's
/// column repeated, computed without repeating it.
pub fn alpha_weighted(data: &[Vec<Option<f64>>], level: Level, weights: &[u32]) -> Estimate {
    let units = data.iter().map(Vec::len).max().unwrap_or(0);
    let mut domain: Vec<f64> = data.iter().flatten().flatten().copied().collect();
    domain.sort_unstable_by(f64::total_cmp);
    domain.dedup_by(|a, b| a == b);
    if domain.len() <= 1 {
        return Err(Undefined::NoVariation);
    }
    let index = |v: f64| domain.partition_point(|&d| d < v);
    // Each pairable unit's values, as domain indices sorted with their counts.
    let mut pairable: Vec<(f64, Vec<(usize, f64)>)> = Vec::new();
    let mut n_v = vec![0.0f64; domain.len()];
    for u in 0..units {
        let weight = f64::from(weights.get(u).copied().unwrap_or(0));
        if weight == 0.0 {
            continue;
        }
        let mut values: Vec<usize> = data
            .iter()
            .filter_map(|row| row.get(u).copied().flatten())
            .map(index)
            .collect();
        if values.len() < 2 {
            continue;
        }
        values.sort_unstable();
        let mut counts: Vec<(usize, f64)> = Vec::new();
        for v in values {
            match counts.last_mut() {
                Some((last, c)) if *last == v => *c += 1.0,
                _ => counts.push((v, 1.0)),
            }
        }
        for &(v, c) in &counts {
            n_v[v] += weight * c;
        }
        pairable.push((weight, counts));
    }
    if pairable.is_empty() {
        return Err(Undefined::NoSharedUnits);
    }
    let mut below = vec![0.0f64; domain.len() + 1];
    for (v, &c) in n_v.iter().enumerate() {
        below[v + 1] = below[v] + c;
    }
    let distance = |i: usize, j: usize| -> f64 {
        let (i, j) = (i.min(j), i.max(j));
        match level {
            Level::Nominal => 1.0,
            Level::Interval => (domain[i] - domain[j]).powi(2),
            Level::Ordinal => (below[j + 1] - below[i] - (n_v[i] + n_v[j]) / 2.0).powi(2),
        }
    };
    let observed: f64 = pairable
        .iter()
        .map(|(weight, counts)| {
            let m: f64 = counts.iter().map(|&(_, c)| c).sum();
            let mut sum = 0.0;
            for &(v, cv) in counts {
                for &(k, ck) in counts {
                    if v != k {
                        sum += cv * ck * distance(v, k);
                    }
                }
            }
            weight * sum / (m - 1.0)
        })
        .sum();
    let total: f64 = n_v.iter().sum();
    let mut expected = 0.0;
    for (v, &cv) in n_v.iter().enumerate() {
        for (k, &ck) in n_v.iter().enumerate() {
            if v != k && cv > 0.0 && ck > 0.0 {
                expected += cv * ck * distance(v, k);
            }
        }
    }
    expected /= total - 1.0;
    if expected == 0.0 {
        return Err(Undefined::NoVariation);
    }
    Ok(1.0 - observed / expected)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The example of the package's documentation (Krippendorff's own).
    fn example() -> Vec<Vec<Option<f64>>> {
        let rows: [[f64; 15]; 3] = [
            [
                f64::NAN,
                f64::NAN,
                f64::NAN,
                f64::NAN,
                f64::NAN,
                3.,
                4.,
                1.,
                2.,
                1.,
                1.,
                3.,
                3.,
                f64::NAN,
                3.,
            ],
            [
                1.,
                f64::NAN,
                2.,
                1.,
                3.,
                3.,
                4.,
                3.,
                f64::NAN,
                f64::NAN,
                f64::NAN,
                f64::NAN,
                f64::NAN,
                f64::NAN,
                f64::NAN,
            ],
            [
                f64::NAN,
                f64::NAN,
                2.,
                1.,
                3.,
                4.,
                4.,
                f64::NAN,
                2.,
                1.,
                1.,
                3.,
                3.,
                f64::NAN,
                4.,
            ],
        ];
        rows.iter()
            .map(|r| r.iter().map(|&v| (!v.is_nan()).then_some(v)).collect())
            .collect()
    }

    #[test]
    fn the_documented_example() {
        // The package (0.8): interval 0.8108448928121059 (its doctest says
        // 0.810845), ordinal 0.8067214199413153.
        let interval = alpha(&example(), Level::Interval).unwrap_or(f64::NAN);
        assert!((interval - 0.8108448928121059).abs() < 1e-12, "{interval}");
        let ordinal = alpha(&example(), Level::Ordinal).unwrap_or(f64::NAN);
        assert!((ordinal - 0.8067214199413153).abs() < 1e-12, "{ordinal}");
    }

    #[test]
    fn a_weighted_unit_counts_as_that_many_copies() {
        // krippendorff 0.8 on this data, and on it with the columns repeated
        // [2, 0, 1, 3, 1, 1] times (np.repeat(data, weights, axis=1)).
        let rows: [[f64; 6]; 3] = [
            [1., 2., 3., 3., f64::NAN, 4.],
            [1., 3., 3., f64::NAN, 2., 4.],
            [f64::NAN, 2., 2., 3., 2., 5.],
        ];
        let data: Vec<Vec<Option<f64>>> = rows
            .iter()
            .map(|r| r.iter().map(|&v| (!v.is_nan()).then_some(v)).collect())
            .collect();
        let weights = [2, 0, 1, 3, 1, 1];
        for (level, plain, weighted) in [
            (Level::Ordinal, 0.8117117117117117, 0.9294380587484036),
            (Level::Interval, 0.8384615384615385, 0.9152119700748129),
            (Level::Nominal, 0.49397590361445787, 0.7043478260869566),
        ] {
            let a = alpha(&data, level).unwrap_or(f64::NAN);
            assert!((a - plain).abs() < 1e-12, "{level:?} {a}");
            let w = alpha_weighted(&data, level, &weights).unwrap_or(f64::NAN);
            assert!((w - weighted).abs() < 1e-12, "{level:?} {w}");
        }
    }

    #[test]
    fn nominal_alpha_of_three_units_by_hand() {
        // Units (0, 0), (1, 1), (1, 0): n_0 = n_1 = 3 of 6 pairable values;
        // D_o = 2 (the one disagreeing unit, both ways), D_e = 3·3·2 / 5.
        let data = vec![
            vec![Some(0.0), Some(1.0), Some(1.0)],
            vec![Some(0.0), Some(1.0), Some(0.0)],
        ];
        let a = alpha(&data, Level::Nominal).unwrap_or(f64::NAN);
        assert!((a - (1.0 - 2.0 / 3.6)).abs() < 1e-12, "{a}");
        assert_eq!(
            alpha_weighted(&data, Level::Nominal, &[0, 0, 0]),
            Err(Undefined::NoSharedUnits)
        );
    }

    #[test]
    fn undefined_cases() {
        let one_value = vec![vec![Some(3.0), Some(3.0)], vec![Some(3.0), None]];
        assert_eq!(
            alpha(&one_value, Level::Ordinal),
            Err(Undefined::NoVariation)
        );
        let unshared = vec![vec![Some(1.0), None], vec![None, Some(2.0)]];
        assert_eq!(
            alpha(&unshared, Level::Interval),
            Err(Undefined::NoSharedUnits)
        );
        let agree_within = vec![vec![Some(1.0), Some(2.0)], vec![Some(1.0), None]];
        assert_eq!(
            alpha(&agree_within, Level::Interval),
            Err(Undefined::NoVariation)
        );
    }
}
