//! Are standard errors honest? The standardised errors `z = (estimate − truth) / σ` of honest σ's
//! are N(0, 1): 68.27% within 1σ, 95.45% within 2σ, 99.73% within 3σ, mean square 1. A test pools
//! the z's of several simulated sessions and checks all four, each against the range honest σ's
//! leave it with probability 99.9% (0.05% on either side): σ's 1.5× too small (z's RMS 1.5, 49.5%
//! within 1σ) or 1.5× too large (RMS 0.67, 86.6% within 1σ) fail once there are a few dozen
//! effectively independent z's.
//!
//! The z's of one session are correlated (through the fit's covariance); sessions are independent.
//! For an even function `f` of two standard normal variables of correlation ρ (the indicator of
//! `|z| ≤ k`, or `z²`), Mehler's expansion gives `corr(f(z_i), f(z_j)) ≤ ρ²`, so a fraction or a
//! mean over `n` z's varies at most as one over `n_eff = n² / Σ ρ_ij²` independent draws (the sum
//! over each session's pairs, `i = j` included). The bands are those of `n_eff` independent draws:
//! binomial for the fractions within kσ, χ² (Wilson–Hilferty) for the mean square.
//!
//! `SPMCAL_SIGMA_SCALE=1.5` (or `0.667`) multiplies every reported σ before the check: each test
//! using this module must then fail — the evidence that its check can catch dishonest σ's.

use nalgebra::{DMatrix, Vector3};
use spmcal::calib::{Calibration, Kind, TruthInGauge};
use spmcal::dataset::Session;

/// Two-sided probability outside the bands for honest σ's.
const ALPHA: f64 = 1e-3;
/// The standard normal quantile of `1 − ALPHA / 2`.
const Z_ALPHA: f64 = 3.2905;

/// Pooled standardised errors and the sum of their squared correlations.
#[derive(Debug, Default, Clone)]
pub struct ZScores {
    z: Vec<f64>,
    pairs: f64,
}

/// Coverage of N(0, 1) within 1σ, 2σ, 3σ.
const COVERAGE: [(f64, f64); 3] = [(1.0, 0.682_689), (2.0, 0.954_500), (3.0, 0.997_300)];

/// The test-only scale on every reported σ (`SPMCAL_SIGMA_SCALE`, 1 unless set).
fn sigma_scale() -> f64 {
    std::env::var("SPMCAL_SIGMA_SCALE").ok().and_then(|s| s.parse().ok()).unwrap_or(1.0)
}

impl ZScores {
    /// One session's errors `estimate − truth` of the parameters `indices`, with the fit's
    /// `covariance` (all parameters): their z's and correlations.
    pub fn add_session(&mut self, errors: &[f64], covariance: &DMatrix<f64>, indices: &[usize]) {
        assert_eq!(errors.len(), indices.len());
        let scale = sigma_scale();
        for (e, &i) in errors.iter().zip(indices) {
            let si = covariance[(i, i)].sqrt();
            assert!(si.is_finite() && si > 0.0, "parameter {i} has no standard error");
            self.z.push(e / (scale * si));
            for &j in indices {
                let r = covariance[(i, j)] / (si * covariance[(j, j)].sqrt());
                self.pairs += r * r;
            }
        }
    }

    /// A marker-level calibration of the simulated `session`: every parameter with a standard
    /// error against the truth in the fit's gauge (the latency against the true one). Returns
    /// the session's `(kind, z)`.
    pub fn add_marker_fit(&mut self, calibration: &Calibration, session: &Session) -> Vec<(Kind, f64)> {
        let truth = &session.truth.as_ref().expect("a simulated session").parameters;
        let markers: Vec<Vector3<f64>> = truth.markers.iter().map(|m| m.position).collect();
        let p = &calibration.parameterisation;
        let camera = truth.camera.expect("a simulated camera");
        let gauge = TruthInGauge::for_markers(p, &truth.legs, &camera, &truth.camera_model, &markers);
        let x = &calibration.calibrated.x;
        let (mut errors, mut indices) = (Vec::new(), Vec::new());
        for (i, e) in p.entries.iter().enumerate() {
            let sigma = calibration.covariance[(i, i)].sqrt();
            if !(sigma.is_finite() && sigma > 0.0) {
                continue; // frozen, held or at a bound: no standard error to check
            }
            errors.push(match e.kind {
                Kind::Latency => p.latency(x) - truth.latency_s.unwrap_or(0.0),
                Kind::ClockRate => {
                    (p.clock_rate_ppm(x) - truth.clock_rate_ppm.unwrap_or(0.0)) * 1e-6 * p.clock_rate_span_s
                }
                _ => x[i] - gauge.x[i],
            });
            indices.push(i);
        }
        let start = self.z.len();
        self.add_session(&errors, &calibration.covariance, &indices);
        indices.iter().zip(&self.z[start..]).map(|(&i, &z)| (p.entries[i].kind, z)).collect()
    }

    /// One z independent of every other (a parameter of its own session): `error / sigma`.
    pub fn add_independent(&mut self, error: f64, sigma: f64) {
        self.z.push(error / (sigma_scale() * sigma));
        self.pairs += 1.0;
    }

    /// How many z's.
    pub fn len(&self) -> usize {
        self.z.len()
    }

    /// The z's.
    pub fn values(&self) -> &[f64] {
        &self.z
    }

    /// The number of independent draws whose fractions vary at least as much: `n² / Σ ρ²`.
    pub fn effective(&self) -> f64 {
        (self.z.len() as f64).powi(2) / self.pairs
    }

    /// The fraction of the z's within `k` (|z| ≤ k).
    pub fn within(&self, k: f64) -> f64 {
        self.z.iter().filter(|z| z.abs() <= k).count() as f64 / self.z.len() as f64
    }

    /// The z's root mean square.
    pub fn rms(&self) -> f64 {
        (self.z.iter().map(|z| z * z).sum::<f64>() / self.z.len() as f64).sqrt()
    }

    /// The bands (fractions within 1σ, 2σ, 3σ; RMS) honest σ's keep with probability 1 − ALPHA
    /// each, given the effective number of draws.
    pub fn bands(&self) -> [(f64, f64); 4] {
        let n = self.effective();
        let trials = (n.floor() as usize).max(1);
        let fraction = |p: f64| {
            let (lo, hi) = binomial_quantiles(trials, p);
            (lo as f64 / trials as f64, hi as f64 / trials as f64)
        };
        let (lo, hi) = mean_square_band(n);
        [fraction(COVERAGE[0].1), fraction(COVERAGE[1].1), fraction(COVERAGE[2].1), (lo.sqrt(), hi.sqrt())]
    }

    /// One line: each statistic with its band.
    pub fn summary(&self) -> String {
        let b = self.bands();
        let mut s = format!("{} z's ({:.0} effectively independent):", self.len(), self.effective());
        for ((k, _), (lo, hi)) in COVERAGE.iter().zip(&b) {
            s += &format!(" within {k}σ {:.3} [{lo:.3}, {hi:.3}],", self.within(*k));
        }
        s + &format!(" RMS {:.3} [{:.3}, {:.3}]", self.rms(), b[3].0, b[3].1)
    }

    /// Panics unless every statistic lies in its band.
    pub fn assert_honest(&self, what: &str) {
        let b = self.bands();
        let stats = [self.within(1.0), self.within(2.0), self.within(3.0), self.rms()];
        let ok = stats.iter().zip(&b).all(|(s, (lo, hi))| (lo..=hi).contains(&s));
        assert!(ok, "{what}: standard errors not honest (σ scale {}): {}", sigma_scale(), self.summary());
    }
}

/// The range of `χ²_dof / dof` (a mean square of `dof` independent squared N(0, 1)'s) that holds
/// it with probability 1 − ALPHA, by Wilson–Hilferty (`χ²_k` quantile ≈ `k (1 − a + z √a)³`,
/// `a = 2 / (9k)`; at k = 8 its 0.05% and 99.95% points are 0.076 and 3.52 against the exact
/// 0.089 and 3.48: a little wider).
pub fn mean_square_band(dof: f64) -> (f64, f64) {
    let a = 2.0 / (9.0 * dof);
    let quantile = |z: f64| (1.0 - a + z * a.sqrt()).max(0.0).powi(3);
    (quantile(-Z_ALPHA), quantile(Z_ALPHA))
}

/// The range of the count of successes in `n` independent trials of probability `p` that holds it
/// with probability 1 − ALPHA.
pub fn binomial_band(n: usize, p: f64) -> (usize, usize) {
    binomial_quantiles(n, p)
}

/// The `ALPHA / 2` and `1 − ALPHA / 2` quantiles of Binomial(`n`, `p`): the smallest counts whose
/// cumulative probabilities reach them.
fn binomial_quantiles(n: usize, p: f64) -> (usize, usize) {
    // log pmf by the ratio of successive terms, normalised from its largest term (no underflow).
    let mut log_pmf = Vec::with_capacity(n + 1);
    let mut l = n as f64 * (1.0 - p).ln();
    for k in 0..=n {
        log_pmf.push(l);
        l += ((n - k) as f64 / (k + 1) as f64).ln() + (p / (1.0 - p)).ln();
    }
    let top = log_pmf.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let pmf: Vec<f64> = log_pmf.iter().map(|l| (l - top).exp()).collect();
    let total: f64 = pmf.iter().sum();
    let quantile = |q: f64| {
        let mut cdf = 0.0;
        for (k, m) in pmf.iter().enumerate() {
            cdf += m / total;
            if cdf >= q {
                return k;
            }
        }
        n
    };
    (quantile(ALPHA / 2.0), quantile(1.0 - ALPHA / 2.0))
}
