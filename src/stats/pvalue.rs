//! Two-sided p-values of the correlations, as `scipy.stats` computes them:
//! Kendall's tau-b exactly (no ties and at most 33 items, or at most one
//! discordant or concordant pair) or by the tie-corrected normal
//! approximation (`kendalltau`, method `auto`); Spearman's rho by Student's t
//! with n − 2 degrees of freedom (`spearmanr`); Pearson's r by its exact
//! beta distribution under independence (`pearsonr`).

use super::pairs::{PairCounts, TieSums};
use super::{Estimate, Undefined};

/// The two-sided p-values of the three correlations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PValues {
    /// Of Kendall's tau-b (`scipy.stats.kendalltau`).
    pub kendall_tau_b: Estimate,
    /// Of Spearman's rho (`scipy.stats.spearmanr`).
    pub spearman: Estimate,
    /// Of Pearson's r (`scipy.stats.pearsonr`).
    pub pearson: Estimate,
}

/// The p-value of tau-b over `n` items with these pair counts and tie
/// groups, as `scipy.stats.kendalltau(method="auto")`.
pub fn kendall(n: u64, counts: &PairCounts, x: TieSums, y: TieSums) -> Estimate {
    counts.tau_b(n)?;
    let (tot, dis) = (counts.total, counts.discordant);
    let (xtie, ytie) = (counts.x_ties, counts.y_ties);
    if xtie == 0 && ytie == 0 && (n <= 33 || dis.min(tot - dis) <= 1) {
        return Ok(kendall_exact(n, tot - dis));
    }
    let size = n as f64;
    let m = size * (size - 1.0);
    let var = (m * (2.0 * size + 5.0) - x.variance as f64 - y.variance as f64) / 18.0
        + (2.0 * xtie as f64 * ytie as f64) / m
        + (x.cubic as f64 * y.cubic as f64) / (9.0 * m * (size - 2.0));
    let con_minus_dis =
        tot as f64 - xtie as f64 - ytie as f64 + counts.joint_ties as f64 - 2.0 * dis as f64;
    let z = con_minus_dis / var.sqrt();
    Ok(2.0 * normal_sf(z.abs()))
}

/// The exact two-sided p-value of `c` concordant pairs among `n` items
/// without ties (Kendall 1970, as scipy's `_kendall_p_exact`).
fn kendall_exact(n: u64, c: u64) -> f64 {
    let total = n * (n - 1) / 2;
    let c = c.min(total - c);
    let prob = if n <= 2 {
        1.0
    } else if c == 0 {
        if n < 171 {
            2.0 / factorial(n)
        } else {
            0.0
        }
    } else if c == 1 {
        if n < 172 {
            2.0 / factorial(n - 1)
        } else {
            0.0
        }
    } else if 4 * c == n * (n - 1) {
        1.0
    } else {
        let c = c as usize;
        let mut new = vec![0.0f64; c + 1];
        new[0] = 1.0;
        new[1] = 1.0;
        let scaled = n >= 171;
        for j in 3..=n as usize {
            let mut sum = 0.0;
            for v in new.iter_mut() {
                sum += *v;
                *v = if scaled { sum / j as f64 } else { sum };
            }
            if j <= c {
                let before = new.clone();
                for (k, v) in new.iter_mut().enumerate().skip(j) {
                    *v -= before[k - j];
                }
            }
        }
        let sum: f64 = new.iter().sum();
        if scaled {
            sum
        } else {
            2.0 * sum / factorial(n)
        }
    };
    prob.clamp(0.0, 1.0)
}

/// n! as a float.
fn factorial(n: u64) -> f64 {
    (2..=n).fold(1.0, |acc, k| acc * k as f64)
}

/// The survival function of the standard normal, as scipy's `ndtr(-z)`.
pub fn normal_sf(z: f64) -> f64 {
    0.5 * libm::erfc(z / std::f64::consts::SQRT_2)
}

/// The p-value of Spearman's rho `rs` over `n` items: Student's t with
/// n − 2 degrees of freedom, as `scipy.stats.spearmanr`.
pub fn spearman(n: u64, rs: Estimate) -> Estimate {
    let rs = rs?;
    if n < 3 {
        return Err(Undefined::TooFewItems);
    }
    let dof = (n - 2) as f64;
    let denominator = (rs + 1.0) * (1.0 - rs);
    if denominator <= 0.0 {
        return Ok(0.0);
    }
    let t = rs * (dof / denominator).max(0.0).sqrt();
    Ok(student_t(t, dof))
}

/// The two-sided p-value of `t` under Student's t with `dof` degrees of
/// freedom, `2 · scipy.stats.t.sf(|t|, dof)`: every t-test of the product
/// (Spearman's rho, Williams' test) goes through here.
pub fn student_t(t: f64, dof: f64) -> f64 {
    // 2 · t.sf(|t|) = I_{dof / (dof + t²)}(dof / 2, 1 / 2).
    regularized_beta(dof / 2.0, 0.5, dof / (dof + t * t))
}

/// The p-value of Pearson's r over `n` items: r's beta distribution on
/// (−1, 1) with a = b = n/2 − 1 under independence, as `scipy.stats.pearsonr`
/// (exactly 1 for two items).
pub fn pearson(n: u64, r: Estimate) -> Estimate {
    let r = r?;
    if n == 2 {
        return Ok(1.0);
    }
    let a = n as f64 / 2.0 - 1.0;
    let upper = (r.abs() + 1.0) / 2.0;
    // 2 · sf(|r|) = 2 · I_{1 − (|r| + 1) / 2}(a, a).
    Ok((2.0 * regularized_beta(a, a, 1.0 - upper)).min(1.0))
}

/// The regularised incomplete beta function I_x(a, b), by the continued
/// fraction (modified Lentz) on the side where it converges fast.
pub fn regularized_beta(a: f64, b: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let ln_beta = libm::lgamma(a) + libm::lgamma(b) - libm::lgamma(a + b);
    let front = |a: f64, b: f64, x: f64| (a * x.ln() + b * (-x).ln_1p() - ln_beta).exp() / a;
    if x < (a + 1.0) / (a + b + 2.0) {
        front(a, b, x) * beta_fraction(a, b, x)
    } else {
        1.0 - front(b, a, 1.0 - x) * beta_fraction(b, a, 1.0 - x)
    }
}

/// The continued fraction of I_x(a, b) (Numerical Recipes' `betacf`).
fn beta_fraction(a: f64, b: f64, x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    const EPS: f64 = 1e-16;
    let away_from_zero = |v: f64| if v.abs() < TINY { TINY } else { v };
    let (qab, qap, qam) = (a + b, a + 1.0, a - 1.0);
    let mut c = 1.0;
    let mut d = 1.0 / away_from_zero(1.0 - qab * x / qap);
    let mut h = d;
    // One step of the modified Lentz method with coefficient `aa`: the
    // factor the fraction changes by.
    let step = |aa: f64, c: &mut f64, d: &mut f64| {
        *d = 1.0 / away_from_zero(1.0 + aa * *d);
        *c = away_from_zero(1.0 + aa / *c);
        *d * *c
    };
    for m in 1..100_000 {
        let m = f64::from(m);
        let m2 = 2.0 * m;
        h *= step(m * (b - m) * x / ((qam + m2) * (a + m2)), &mut c, &mut d);
        let delta = step(
            -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2)),
            &mut c,
            &mut d,
        );
        h *= delta;
        if (delta - 1.0).abs() < EPS {
            break;
        }
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_incomplete_beta_is_exact_where_it_is_known() {
        let close = |a: f64, b: f64| assert!((a - b).abs() < 1e-14, "{a:e} against {b:e}");
        close(regularized_beta(1.0, 1.0, 0.3), 0.3);
        close(regularized_beta(2.0, 3.0, 0.4), 0.5247999999999999);
        close(regularized_beta(0.5, 0.5, 0.5), 0.5);
        close(normal_sf(0.0), 0.5);
    }

    #[test]
    fn student_t_equals_scipy() {
        // scipy 1.17.1: 2 * stats.t.sf(t, dof).
        for (t, dof, want) in [
            (2.0, 5.0, 0.10193947882985835),
            (-0.5, 1.0, 0.7048327646991335),
            (3.5, 100.0, 0.0006964277173562688),
        ] {
            let got = student_t(t, dof);
            assert!(
                (got - want).abs() <= 1e-12 * want,
                "{got:e} against {want:e}"
            );
        }
        assert_eq!(student_t(0.0, 7.0), 1.0);
    }
}
