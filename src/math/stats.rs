//! Summary statistics of a list of errors (angles, distances): the one summary every report uses.

use serde::Serialize;

/// Count, RMS, mean, median and largest value of a list of numbers.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Stats {
    /// How many values.
    pub count: usize,
    /// Root mean square.
    pub rms: f64,
    /// Mean.
    pub mean: f64,
    /// Median (the mean of the middle two for an even count).
    pub median: f64,
    /// Largest value.
    pub max: f64,
}

impl Stats {
    /// `None` for an empty list.
    pub fn of(values: &[f64]) -> Option<Stats> {
        if values.is_empty() {
            return None;
        }
        let mut sorted = values.to_vec();
        sorted.sort_by(f64::total_cmp);
        let mid = sorted.len() / 2;
        let median = if sorted.len().is_multiple_of(2) { (sorted[mid - 1] + sorted[mid]) / 2.0 } else { sorted[mid] };
        Some(Stats {
            count: values.len(),
            rms: rms(values.iter().copied()),
            mean: values.iter().sum::<f64>() / values.len() as f64,
            median,
            max: sorted[sorted.len() - 1],
        })
    }

    /// [`Stats::of`], all zeros for an empty list.
    pub fn of_or_zero(values: &[f64]) -> Stats {
        Stats::of(values).unwrap_or_default()
    }
}

/// The root mean square of `values` (0 for none).
pub(crate) fn rms(values: impl IntoIterator<Item = f64>) -> f64 {
    let (sum, n) = values.into_iter().fold((0.0, 0usize), |(s, n), v| (s + v * v, n + 1));
    (sum / n.max(1) as f64).sqrt()
}

#[cfg(feature = "full")]
/// `ln Γ(x)` for `x > 0` (Lanczos, g = 7, nine terms: relative error below 1e-13).
pub(crate) fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection: Γ(x) Γ(1 − x) = π / sin(πx).
        return (std::f64::consts::PI / (std::f64::consts::PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let t = x + 7.5;
    let sum = G.iter().enumerate().skip(1).fold(G[0], |s, (i, g)| s + g / (x + i as f64));
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + sum.ln()
}

#[cfg(feature = "full")]
/// The regularised incomplete beta function `I_x(a, b)` (Lentz's continued fraction).
pub(crate) fn incomplete_beta(x: f64, a: f64, b: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let front = (ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln()).exp();
    // The fraction converges fast for x < (a + 1) / (a + b + 2); use the symmetry otherwise.
    if x > (a + 1.0) / (a + b + 2.0) {
        return 1.0 - incomplete_beta(1.0 - x, b, a);
    }
    const TINY: f64 = 1e-300;
    let (mut c, mut d) = (1.0, 1.0 - (a + b) * x / (a + 1.0));
    d = 1.0 / if d.abs() < TINY { TINY } else { d };
    let mut h = d;
    for m in 1..500 {
        let m = m as f64;
        for numerator in [
            m * (b - m) * x / ((a + 2.0 * m - 1.0) * (a + 2.0 * m)),
            -(a + m) * (a + b + m) * x / ((a + 2.0 * m) * (a + 2.0 * m + 1.0)),
        ] {
            d = 1.0 + numerator * d;
            d = 1.0 / if d.abs() < TINY { TINY } else { d };
            c = 1.0 + numerator / c;
            c = if c.abs() < TINY { TINY } else { c };
            h *= d * c;
        }
        if (d * c - 1.0).abs() < 1e-15 {
            break;
        }
    }
    front * h / a
}

#[cfg(feature = "full")]
/// `P(F > f)` for an F distribution of `d1`, `d2` degrees of freedom.
pub(crate) fn f_survival(f: f64, d1: f64, d2: f64) -> f64 {
    if f.is_nan() {
        return f64::NAN;
    }
    if f <= 0.0 {
        return 1.0;
    }
    incomplete_beta(d2 / (d2 + d1 * f), d2 / 2.0, d1 / 2.0)
}

#[cfg(feature = "full")]
/// The standard normal deviate with the same upper tail as an F of `d1`, `d2` degrees of freedom
/// at `f` (Paulson's approximation): a scale on which tests of different degrees of freedom
/// compare without their p-values underflowing.
pub(crate) fn f_as_normal(f: f64, d1: f64, d2: f64) -> f64 {
    let (a, b) = (2.0 / (9.0 * d1), 2.0 / (9.0 * d2));
    let cube = f.max(0.0).cbrt();
    ((1.0 - b) * cube - (1.0 - a)) / (b * cube * cube + a).sqrt()
}

#[cfg(all(test, feature = "full"))]
mod distribution_tests {
    use super::*;

    #[test]
    fn the_distributions_match_published_values() {
        // Γ(5) = 24, Γ(1/2) = √π.
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12);
        assert!((ln_gamma(0.5) - std::f64::consts::PI.sqrt().ln()).abs() < 1e-12);
        // Tables: F(5, 10) upper 5 % point 3.3258, F(1, 100) 3.9361, F(10, 1000) upper 1 % 2.3386 (the last by integrating the density numerically).
        assert!((f_survival(3.3258, 5.0, 10.0) - 0.05).abs() < 1e-4);
        assert!((f_survival(3.9361, 1.0, 100.0) - 0.05).abs() < 1e-4);
        assert!((f_survival(2.3386, 10.0, 1000.0) - 0.01).abs() < 1e-4);
        // I_x(1, 1) = x; I_x(a, b) = 1 − I_{1−x}(b, a).
        assert!((incomplete_beta(0.3, 1.0, 1.0) - 0.3).abs() < 1e-12);
        assert!((incomplete_beta(0.2, 2.5, 4.0) + incomplete_beta(0.8, 4.0, 2.5) - 1.0).abs() < 1e-12);
        // t² = F(1, ν): the two-sided 5 % point of t with 10 degrees of freedom is 2.2281.
        assert!((f_survival(2.2281f64.powi(2), 1.0, 10.0) - 0.05).abs() < 1e-4);
        // Paulson: the upper 1 % point of F(10, 1000) maps to about z = 2.326.
        assert!((f_as_normal(2.3386, 10.0, 1000.0) - 2.326).abs() < 0.03);
    }
}
