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
