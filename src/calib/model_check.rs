//! The model check: are the calibrated model's residuals what its noise model says? A family of
//! tests with a known false-alarm rate (Bonferroni over the tests, [`FALSE_ALARM_RATE`] in all),
//! each a test of one way the model can be wrong, so that a failed check names its likely cause.
//!
//! - **Structure** (score tests of omitted regressors): the whitened, weighted residuals regressed
//!   on the columns a missing effect would add, after the model's own Jacobian has taken what it
//!   can of them (`X̃ = X − J H⁻¹ JᵀX`, `H` the fit's normal matrix). Under the model, the share
//!   they explain is an F variable: exact for independent observations (`F(r, rows − p − r)`), and
//!   with the observations of a pose as one cluster (a recording's frame shares its timing error)
//!   a cluster-robust Wald statistic, Hotelling-corrected to `F(r, G − r)`, when there are at least
//!   ten clusters per column. The columns: the camera's volume (each axis's residual against the
//!   point's position and a perspective term; a pixel's against its place in the image, with
//!   radial terms); the joints (each encoder's offset column times its angle: a joint scale); time
//!   (each axis against time, and the latency column times time: a clock rate).
//! - **A marker**: each marker's whitened mean square against 1.5 times the others' (an F test per
//!   marker, each side's degrees of freedom its rows less their leverage; Bonferroni over the
//!   markers): a marker mislabelled at some captures, loose or half hidden — not one whose noise
//!   is a little above the noise model's, which costs nothing.
//! - **Overall**: the cross-validated whitened residuals' mean square against what the noise and
//!   the parameters' uncertainty make expected (`rows σ̂² + k/(k−1) tr(S J C Jᵀ Sᵀ)` per
//!   observation), one-sided, its standard error from the poses' sums (Student's t on their number).
//!
//! The cause of a failed check is the most significant failed test (on a normal-deviate scale,
//! so that tests of different degrees of freedom compare), said with the option that models it.
//! What the misfit can do to the parameters is the change the regression's effect would make to
//! them (`δx = −H⁻¹ JᵀX γ̂`): the report's predicted error adds it.

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use serde::Serialize;

use super::fit::{FitOutcome, weighted_normal};
use super::parameterisation::Kind;
use super::residuals::{Observed, Residuals};
use crate::math::stats::{f_as_normal, f_survival};

/// The check's false-alarm rate on data the model explains: the family's, shared by its tests.
pub(crate) const FALSE_ALARM_RATE: f64 = 0.02;

/// The marker test asks whether a marker's variance exceeds this many times the others'.
const MARKER_MARGIN: f64 = 1.5;

/// The weight in the family of a test of one faint effect ([`weight`]): measured, it lifts the
/// power against a joint 1 % long from 80 % (equal weights) to the 85–88 % its noncentrality allows
/// at these shares, at no cost to the camera's tests (their p-values are below 1e-10 there).
const FAINT_EFFECT_WEIGHT: f64 = 3.0;

/// Clusters per regression column from which the cluster-robust test is used.
const CLUSTERS_PER_COLUMN: usize = 10;

/// Which way of being wrong a test looks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Structure {
    /// The cross-validated residuals are larger than the noise and uncertainty make expected.
    Overall,
    /// The residuals follow the position in the camera's volume (or the image).
    Camera,
    /// The residuals follow the joints' angles (a joint scale).
    Joints,
    /// The residuals follow time (a clock rate, a drift).
    Time,
    /// The residuals follow the gravity torque on the platform (it sags under its weight).
    Sag,
    /// One marker's residuals are larger than the others'.
    Marker,
}

impl Structure {
    /// Its name in the report.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Structure::Overall => "overall",
            Structure::Camera => "camera volume",
            Structure::Joints => "joint angles",
            Structure::Time => "time",
            Structure::Sag => "platform sag",
            Structure::Marker => "a marker",
        }
    }
}

/// One test of the model check.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StructureTest {
    /// What it tests: `overall`, `camera volume`, `joint angles`, `time` or `a marker`.
    pub structure: &'static str,
    /// Its statistic: an F (structure, marker) or a ratio of mean squares (overall).
    pub statistic: f64,
    /// Its degrees of freedom (an F's two; for the overall ratio, the square of its t statistic's:
    /// `[1, clusters − 1]`).
    pub dof: [f64; 2],
    /// Its p-value on its own (the worst marker's, times the markers, for `marker`).
    pub p_value: f64,
    /// Its share of the family's false-alarm rate: it fails when `p_value` is below it.
    pub alpha: f64,
    /// The normal deviate of the same upper tail (how strongly it rejects, comparable across tests).
    pub z: f64,
    /// The marker it names (`marker`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub marker: Option<String>,
    /// The leg whose joint it tests (1-based; `joint angles`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub leg: Option<usize>,
    /// Cluster-robust (observations of a pose as one cluster), else for independent observations.
    pub robust: bool,
}

/// The evidence of a cause: the residuals against the feature of the winning structure, binned.
struct ResidualFigure {
    x_label: String,
    y_label: String,
    bins: Vec<[f64; 3]>,
}

/// Whether the residuals are what the noise model says.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModelCheck {
    /// The most significant test's statistic.
    pub statistic: f64,
    /// The family's p-value: the smallest over the tests of the rate times its p-value over its
    /// share of the rate (at most 1); with equal shares, the smallest p-value times the number of
    /// tests.
    pub p_value: f64,
    /// The false-alarm rate the check holds to: it fails when `p_value` is below it.
    pub false_alarm_rate: f64,
    /// The residuals are what the noise model says.
    pub passed: bool,
    /// The cross-validated whitened mean square over its expectation (1 when the model explains
    /// the data).
    pub excess: f64,
    /// Every test.
    pub tests: Vec<StructureTest>,
    /// When it failed: the structure that explains most (a test's `structure`).
    pub cause: Option<&'static str>,
    /// What the residuals show, in words.
    pub finding: Option<String>,
    /// What to do: the option that models it.
    pub action: Option<String>,
    /// The evidence: the axes of the figure of the residuals against the cause's feature.
    pub figure_axes: Option<[String; 2]>,
    /// Its points: `[x, mean residual, its standard error]` per bin of x (per marker for a marker).
    pub figure_bins: Vec<[f64; 3]>,
    /// When it failed: the factor by which the misfit widens the predicted orientation error (set
    /// with the report).
    pub widening: Option<f64>,
}

/// What a regression test adds for the widening: the change its effect would make to the
/// parameters (full vector).
pub(crate) struct Misfit {
    pub(crate) bias: Option<DVector<f64>>,
    pub(crate) scale: f64,
}

/// A group of regression columns, per observation in the residuals' raw space.
struct Group {
    structure: Structure,
    /// The joint's leg, for a joint's test.
    leg: Option<usize>,
    columns: usize,
    xtx: DMatrix<f64>,
    /// The diagonal of `XᵀX` before the projection: the columns' own size.
    xtx_raw: Vec<f64>,
    jtx: DMatrix<f64>,
    xte: DVector<f64>,
    /// Per cluster `Xᵀe`.
    cluster_xte: Vec<DVector<f64>>,
}

/// Means and spreads of the features, to scale the columns.
struct Scales {
    point_mean: Vector3<f64>,
    point_sd: Vector3<f64>,
    point_norm: f64,
    pixel_mean: Vec<[f64; 2]>,
    pixel_sd: Vec<[f64; 2]>,
    joint_mean: Vector3<f64>,
    joint_sd: Vector3<f64>,
    time_mean: f64,
    time_sd: f64,
}

fn mean_sd(values: impl Iterator<Item = f64> + Clone) -> (f64, f64) {
    let n = values.clone().count().max(1) as f64;
    let mean = values.clone().sum::<f64>() / n;
    let var = values.map(|v| (v - mean).powi(2)).sum::<f64>() / n;
    (mean, var.sqrt().max(1e-12))
}

impl Scales {
    fn of(observed: &[Observed]) -> Self {
        let points: Vec<Vector3<f64>> = observed.iter().filter_map(|o| o.point).collect();
        let (mut point_mean, mut point_sd) = (Vector3::zeros(), Vector3::repeat(1.0));
        for k in 0..3 {
            (point_mean[k], point_sd[k]) = mean_sd(points.iter().map(|p| p[k]));
        }
        let cameras = observed.iter().filter_map(|o| o.pixel.map(|p| p.0 + 1)).max().unwrap_or(0);
        let (mut pixel_mean, mut pixel_sd) = (vec![[0.0; 2]; cameras], vec![[1.0; 2]; cameras]);
        for c in 0..cameras {
            let of_c: Vec<[f64; 2]> =
                observed.iter().filter_map(|o| o.pixel.filter(|p| p.0 == c).map(|p| p.1)).collect();
            for k in 0..2 {
                (pixel_mean[c][k], pixel_sd[c][k]) = mean_sd(of_c.iter().map(|p| p[k]));
            }
        }
        let (mut joint_mean, mut joint_sd) = (Vector3::zeros(), Vector3::repeat(1.0));
        for k in 0..3 {
            (joint_mean[k], joint_sd[k]) = mean_sd(observed.iter().map(|o| o.joints[k]));
        }
        let (time_mean, time_sd) = mean_sd(observed.iter().filter_map(|o| o.time_s));
        Scales {
            point_mean,
            point_sd,
            point_norm: point_mean.norm().max(1e-6),
            pixel_mean,
            pixel_sd,
            joint_mean,
            joint_sd,
            time_mean,
            time_sd,
        }
    }
}

/// The raw-space columns of `structure` for an observation (`jac`: its 3 × N Jacobian rows; `sag`:
/// the joint offsets' change that turns its pose's platform as its weight would, per unit of
/// compliance, [`sag_offsets`]).
#[allow(clippy::too_many_arguments)]
fn columns(
    structure: Structure,
    o: &Observed,
    s: &Scales,
    jac: &nalgebra::DMatrixView<'_, f64>,
    offsets: &[usize],
    latency: Option<usize>,
    cameras: usize,
    sag: &Vector3<f64>,
    leg: Option<usize>,
) -> Vec<Vector3<f64>> {
    match structure {
        Structure::Camera => {
            if let Some(p) = o.point {
                let h = (p - s.point_mean).component_div(&s.point_sd);
                let mut out = Vec::with_capacity(12);
                for c in 0..3 {
                    for k in 0..3 {
                        let mut v = Vector3::zeros();
                        v[c] = h[k];
                        out.push(v);
                    }
                }
                // A perspective term moves the point along itself by its coordinate.
                out.extend((0..3).map(|k| p / s.point_norm * h[k]));
                out.extend(std::iter::repeat_n(Vector3::zeros(), 6 * cameras));
                out
            } else if let Some((camera, [u, v])) = o.pixel {
                let mut out = vec![Vector3::zeros(); 12 + 6 * cameras];
                let (m, sd) = (s.pixel_mean[camera], s.pixel_sd[camera]);
                let (u, v) = ((u - m[0]) / sd[0], (v - m[1]) / sd[1]);
                let r2 = u * u + v * v;
                let at = 12 + 6 * camera;
                out[at] = Vector3::new(u, 0.0, 0.0);
                out[at + 1] = Vector3::new(v, 0.0, 0.0);
                out[at + 2] = Vector3::new(0.0, u, 0.0);
                out[at + 3] = Vector3::new(0.0, v, 0.0);
                out[at + 4] = Vector3::new(u * r2, v * r2, 0.0);
                out[at + 5] = Vector3::new(u * r2 * r2, v * r2 * r2, 0.0);
                out
            } else {
                Vec::new()
            }
        }
        Structure::Joints => offsets
            .iter()
            .enumerate()
            .filter(|(l, _)| leg.is_none_or(|only| only == *l))
            .map(|(leg, &i)| {
                let column = Vector3::new(jac[(0, i)], jac[(1, i)], jac[(2, i)]);
                column * (o.joints[leg] - s.joint_mean[leg]) / s.joint_sd[leg]
            })
            .collect(),
        // The platform turned by `sag`'s offsets: the offsets' columns move the platform (and
        // through it every marker, point or pixel) as the joints would.
        Structure::Sag => vec![
            offsets
                .iter()
                .zip(sag.iter())
                .map(|(&i, d)| Vector3::new(jac[(0, i)], jac[(1, i)], jac[(2, i)]) * *d)
                .sum(),
        ],
        Structure::Time => {
            let t = o.time_s.map_or(0.0, |t| (t - s.time_mean) / s.time_sd);
            let mut out: Vec<Vector3<f64>> = (0..3).map(|c| Vector3::ith(c, t)).collect();
            if let Some(i) = latency {
                out.push(Vector3::new(jac[(0, i)], jac[(1, i)], jac[(2, i)]) * t);
            }
            out
        }
        Structure::Overall | Structure::Marker => Vec::new(),
    }
}

/// The held-out residuals of the cross-validation, for the overall test.
pub(crate) struct HeldOut<'a> {
    /// `(observation, residual of the model fitted without its fold)`.
    pub(crate) residuals: &'a [(usize, Vector3<f64>)],
    /// Folds.
    pub(crate) folds: usize,
}

/// The rows an observation's whitening keeps (2 for a pixel, 3 for a point or an orientation).
fn rows_of(s: &Matrix3<f64>) -> usize {
    (0..3).filter(|&r| s.row(r).norm() > 0.0).count()
}

/// Per pose, the joint offsets' change that turns the platform as its weight would bend it, per
/// unit of compliance: the rotation `n × (−z)` (`n` the platform's axis in the base frame, `z` the
/// base's up: the gravity torque's arm, zero when the platform is level), taken back through the
/// pose's sensitivity of the platform to the offsets, `ω = F δ`. Zero where `F` is singular or not
/// at hand (no mechanism in the fit).
fn sag_offsets(
    orientations: &[nalgebra::Rotation3<f64>],
    sensitivities: Option<&[DMatrix<f64>]>,
    offsets: &[usize],
) -> Vec<Vector3<f64>> {
    orientations
        .iter()
        .enumerate()
        .map(|(g, r)| {
            let f = sensitivities
                .and_then(|s| s.get(g))
                .filter(|_| offsets.len() == 3)
                .map(|s| Matrix3::from_fn(|a, b| s[(a, offsets[b])]));
            let arm = (r * Vector3::z()).cross(&-Vector3::z());
            f.and_then(|f| f.try_inverse()).map_or(Vector3::zeros(), |inverse| inverse * arm)
        })
        .collect()
}

/// The model check of `outcome` (the calibrated fit of `model`, parameters `free`, covariance
/// `cov`), with the cross-validation's held-out residuals when there are some
/// (markers are named by index until [`ModelCheck::name_markers`]). `None` without a Jacobian or with nothing to test.
pub(crate) fn check<M: Residuals>(
    model: &M,
    outcome: &FitOutcome<M::Noise>,
    free: &[bool],
    cov: &DMatrix<f64>,
    held_out: Option<HeldOut<'_>>,
) -> Option<(ModelCheck, Misfit)> {
    let jac = outcome.evaluation.jacobian.as_ref()?;
    let m = model.len();
    if m == 0 || outcome.evaluation.residuals.len() != m {
        return None;
    }
    let p = model.parameterisation();
    let idx: Vec<usize> = (0..free.len()).filter(|&i| free[i]).collect();
    let nf = idx.len();
    // The projection off the Jacobian's columns is the data's alone: a weak prior's directions are
    // the data's null space, which no regression column enters.
    let (h, jte) = weighted_normal(&outcome.evaluation, &outcome.weighting, &idx);
    let h_inv = crate::math::linalg::symmetric_pseudo_inverse(&h, 1e-12)?;
    // The residuals with the Jacobian's share taken out too: at a fit with a prior, or stopped
    // short of the exact minimum, `Jᵀe` is not quite zero, and a column nearly in the Jacobian's
    // span would amplify what is left.
    let step = &h_inv * &jte;
    // Where the model puts each observation, not where it was measured: a feature read from the
    // measurement would carry its noise, which the residual carries too, and correlate with it.
    let residuals = &outcome.evaluation.residuals;
    let observed: Vec<Observed> = model
        .observed(&outcome.x)
        .into_iter()
        .zip(residuals)
        .map(|(mut o, r)| {
            o.point = o.point.map(|p| p - r);
            o.pixel = o.pixel.map(|(c, [u, v])| (c, [u - r.x, v - r.y]));
            o
        })
        .collect();
    let scales = Scales::of(&observed);
    let cameras = scales.pixel_mean.len();
    let offsets: Vec<usize> =
        (0..3).filter_map(|leg| p.entries.iter().position(|e| e.kind == Kind::Offset { leg })).collect();
    let latency = p.entries.iter().position(|e| e.kind == Kind::Latency);
    // The structure tests look at markers: a per-pose orientation estimate's own errors follow the
    // pose (which markers it saw, how they lie), so at the orientation level they would test the
    // estimator, not the mechanism; there the overall test alone checks the model.
    let markers_seen = observed.iter().any(|o| o.marker.is_some());
    // Each test: its structure, and for the joints the leg (a scale error is one encoder's: a
    // test of its one column is more powerful than one of all three).
    let mut structures: Vec<(Structure, Option<usize>)> = Vec::new();
    if markers_seen {
        structures.push((Structure::Camera, None));
    }
    if offsets.len() == 3 && markers_seen {
        structures.extend((0..3).map(|leg| (Structure::Joints, Some(leg))));
    }
    if markers_seen && observed.iter().all(|o| o.time_s.is_some()) && scales.time_sd > 1e-9 {
        structures.push((Structure::Time, None));
    }
    let sags =
        sag_offsets(&outcome.evaluation.orientations, outcome.evaluation.orientation_jacobians.as_deref(), &offsets);
    // A sag the fit modelled leaves nothing of its kind in the residuals to test.
    let sag_fitted = p.entries.iter().position(|e| e.kind == Kind::PlatformSag).is_some_and(|i| free[i]);
    if offsets.len() == 3 && markers_seen && !sag_fitted && sags.iter().any(|d| d.norm() > 0.0) {
        structures.push((Structure::Sag, None));
    }
    let no_sag = Vector3::zeros();
    let sag_of = |j: usize| sags.get(model.pose_of(j)).unwrap_or(&no_sag);
    // A recording's frame shares its timing error among its observations; a static pose's
    // observations share nothing the model leaves out (its encoders' noise is hundredths of the
    // camera's), so that there the exact F test holds, and is the more powerful.
    let shared = latency.is_some();
    // The clusters: a pose's observations.
    let clusters = model.poses();
    let w = &outcome.weighting;
    let (mut rss, mut rows) = (0.0, 0usize);
    let markers = observed.iter().filter_map(|o| o.marker.map(|k| k + 1)).max().unwrap_or(0);
    let (mut marker_ss, mut marker_rows) = (vec![0.0; markers], vec![0usize; markers]);
    let mut marker_dof = vec![0.0; markers];
    let mut jw = DMatrix::<f64>::zeros(3, nf);
    let whitened_jacobian = |j: usize, s: &Matrix3<f64>, jw: &mut DMatrix<f64>| {
        let rows_j = jac.rows(3 * j, 3);
        for (a, &i) in idx.iter().enumerate() {
            jw.set_column(a, &(s * Vector3::new(rows_j[(0, i)], rows_j[(1, i)], rows_j[(2, i)])));
        }
    };
    let group_columns = |j: usize, (structure, leg): (Structure, Option<usize>), s: &Matrix3<f64>| -> DMatrix<f64> {
        let o = &observed[j];
        let x = columns(structure, o, &scales, &jac.rows(3 * j, 3), &offsets, latency, cameras, sag_of(j), leg);
        DMatrix::from_iterator(3, x.len(), x.iter().flat_map(|c| (s * c).iter().copied().collect::<Vec<_>>()))
    };
    // First pass: `JᵀX` of each group, the residuals' sum of squares, each marker's.
    let widths: Vec<usize> = structures
        .iter()
        .map(|&(st, leg)| {
            columns(st, &observed[0], &scales, &jac.rows(0, 3), &offsets, latency, cameras, sag_of(0), leg).len()
        })
        .collect();
    let mut jtx: Vec<DMatrix<f64>> = widths.iter().map(|&q| DMatrix::zeros(nf, q)).collect();
    for j in 0..m {
        let s = w.whitening[j] * w.weights[j].sqrt();
        let e = s * residuals[j];
        let r = rows_of(&w.whitening[j]);
        rss += e.norm_squared();
        rows += r;
        whitened_jacobian(j, &s, &mut jw);
        if let Some(k) = observed[j].marker {
            // Its residuals' degrees of freedom: its rows less its leverage `tr(J̃_j H⁻¹ J̃_jᵀ)`
            // (a marker's own position takes three of its rows, not a share of everyone's).
            let leverage = (&jw * &h_inv).component_mul(&jw).sum();
            marker_ss[k] += e.norm_squared();
            marker_dof[k] += r as f64 - leverage;
            marker_rows[k] += r;
        }
        for (n, &structure) in structures.iter().enumerate() {
            let xw = group_columns(j, structure, &s);
            if xw.ncols() == widths[n] {
                jtx[n] += jw.tr_mul(&xw);
            }
        }
    }
    // Second pass: the columns with the model's share taken out, `X̃ = X − J H⁻¹ JᵀX`, explicitly
    // (forming `X̃ᵀX̃` as `XᵀX − XᵀJ H⁻¹ JᵀX` would cancel away its smallest directions).
    let shares: Vec<DMatrix<f64>> = jtx.iter().map(|t| &h_inv * t).collect();
    let mut groups: Vec<Group> = structures
        .iter()
        .zip(&widths)
        .zip(jtx)
        .map(|((&(structure, leg), &q), jtx)| Group {
            structure,
            leg,
            columns: q,
            xtx: DMatrix::zeros(q, q),
            xtx_raw: vec![0.0; q],
            jtx,
            xte: DVector::zeros(q),
            cluster_xte: vec![DVector::zeros(q); clusters],
        })
        .collect();
    for (j, residual) in residuals.iter().enumerate() {
        let s = w.whitening[j] * w.weights[j].sqrt();
        whitened_jacobian(j, &s, &mut jw);
        let e = DMatrix::from_column_slice(3, 1, (s * residual).as_slice()) - &jw * &step;
        let g = model.pose_of(j);
        for (n, group) in groups.iter_mut().enumerate() {
            let xw = group_columns(j, (group.structure, group.leg), &s);
            if xw.ncols() != group.columns {
                continue;
            }
            for (k, v) in group.xtx_raw.iter_mut().enumerate() {
                *v += xw.column(k).norm_squared();
            }
            let projected = xw - &jw * &shares[n];
            group.xtx += projected.tr_mul(&projected);
            let xe = projected.tr_mul(&e);
            group.xte += xe.column(0);
            group.cluster_xte[g] += xe.column(0);
        }
    }
    let dof_noise = rows.saturating_sub(nf).max(1) as f64;
    let mut tests = Vec::new();
    let mut structure_of: Vec<Structure> = Vec::new();
    let mut fits: Vec<Option<DVector<f64>>> = Vec::new();
    for group in &groups {
        let Some((test, gamma)) = regression_test(group, rss, rows, nf, shared) else {
            continue;
        };
        let bias = -(&h_inv * (&group.jtx * &gamma));
        let mut full = DVector::zeros(free.len());
        for (a, &i) in idx.iter().enumerate() {
            full[i] = bias[a];
        }
        tests.push(test);
        structure_of.push(group.structure);
        fits.push(Some(full));
    }
    // A marker's mean square against the others'.
    if markers >= 2 {
        let total_dof: f64 = marker_dof.iter().sum();
        let worst = (0..markers)
            .filter(|&k| marker_rows[k] > 0 && marker_dof[k] > 0.5 && marker_dof[k] < total_dof - 0.5)
            .map(|k| {
                let (d1, d2) = (marker_dof[k], total_dof - marker_dof[k]);
                // Against a variance MARKER_MARGIN times the others': a noise model a little off
                // for one marker (one that moves faster in a recording) costs nothing; a marker
                // mislabelled, loose or half hidden is far noisier.
                let f = (marker_ss[k] / d1) / ((rss - marker_ss[k]).max(f64::MIN_POSITIVE) / d2) / MARKER_MARGIN;
                (k, f, d1, d2)
            })
            .max_by(|a, b| f_as_normal(a.1, a.2, a.3).total_cmp(&f_as_normal(b.1, b.2, b.3)));
        if let Some((k, f, d1, d2)) = worst {
            let tested = marker_rows.iter().filter(|&&r| r > 0).count() as f64;
            let p_value = (f_survival(f, d1, d2) * tested).min(1.0);
            structure_of.push(Structure::Marker);
            tests.push(StructureTest {
                structure: Structure::Marker.name(),
                statistic: f,
                dof: [d1, d2],
                p_value,
                alpha: 0.0,
                // The worst of `tested` markers: its deviate after the Bonferroni factor.
                z: f_as_normal(f, d1, d2) - (2.0 * tested.ln()).max(0.0).sqrt(),
                marker: Some(k.to_string()),
                leg: None,
                robust: false,
            });
            fits.push(None);
        }
    }
    // The cross-validated whitened mean square against its expectation.
    let sigma2 = rss / dof_noise;
    let mut excess = 1.0;
    if let Some(held) = held_out.filter(|h| h.folds >= 2 && !h.residuals.is_empty()) {
        let without_fold = held.folds as f64 / (held.folds - 1) as f64;
        let c: DMatrix<f64> = DMatrix::from_fn(nf, nf, |a, b| cov[(idx[a], idx[b])]);
        let (mut a_g, mut b_g) = (vec![0.0; clusters], vec![0.0; clusters]);
        for &(j, r) in held.residuals {
            let s = w.whitening[j] * w.weights[j].sqrt();
            let rows_j = jac.rows(3 * j, 3);
            for (a, &i) in idx.iter().enumerate() {
                jw.set_column(a, &(s * Vector3::new(rows_j[(0, i)], rows_j[(1, i)], rows_j[(2, i)])));
            }
            let spread = (&jw * &c).component_mul(&jw).sum().max(0.0);
            let g = model.pose_of(j);
            a_g[g] += (s * r).norm_squared();
            b_g[g] += rows_of(&w.whitening[j]) as f64 * w.weights[j] * sigma2 + without_fold * spread;
        }
        let (a, b): (f64, f64) = (a_g.iter().sum(), b_g.iter().sum());
        if b > 0.0 && a.is_finite() {
            excess = a / b;
            let used = b_g.iter().filter(|v| **v > 0.0).count() as f64;
            let var: f64 =
                a_g.iter().zip(&b_g).map(|(a, b)| (a - excess * b).powi(2)).sum::<f64>() * used / (used - 1.0).max(1.0);
            let se = var.sqrt() / b;
            let z = if se > 0.0 { (excess - 1.0) / se } else { 0.0 };
            // Student's t on the clusters' degrees of freedom (twenty poses are not many).
            let p_value = match z > 0.0 {
                true => 0.5 * f_survival(z * z, 1.0, (used - 1.0).max(1.0)),
                false => 1.0 - 0.5 * f_survival(z * z, 1.0, (used - 1.0).max(1.0)),
            };
            structure_of.insert(0, Structure::Overall);
            tests.insert(
                0,
                StructureTest {
                    structure: Structure::Overall.name(),
                    statistic: excess,
                    dof: [1.0, (used - 1.0).max(1.0)],
                    p_value,
                    alpha: 0.0,
                    z,
                    marker: None,
                    leg: None,
                    robust: true,
                },
            );
            fits.insert(0, None);
        }
    }
    if tests.is_empty() {
        return None;
    }
    // Each test's share of the family's rate (weighted Bonferroni: the shares add up to it).
    let weights: Vec<f64> = structure_of.iter().map(|&s| weight(s)).collect();
    let total: f64 = weights.iter().sum();
    for (t, w) in tests.iter_mut().zip(&weights) {
        t.alpha = FALSE_ALARM_RATE * w / total;
    }
    let best = (0..tests.len()).max_by(|&a, &b| tests[a].z.total_cmp(&tests[b].z)).unwrap_or(0);
    // The family's p-value: the smallest rate at which some test would fail.
    let p_value = tests.iter().map(|t| t.p_value * FALSE_ALARM_RATE / t.alpha).fold(1.0, f64::min);
    let passed = tests.iter().all(|t| t.p_value >= t.alpha);
    let winner = &tests[best];
    let winner_structure = structure_of[best];
    let check = ModelCheck {
        statistic: winner.statistic,
        p_value,
        false_alarm_rate: FALSE_ALARM_RATE,
        passed,
        excess,
        cause: None,
        finding: None,
        action: None,
        figure_axes: None,
        figure_bins: Vec::new(),
        widening: None,
        tests: tests.clone(),
    };
    let misfit = Misfit { bias: if passed { None } else { fits[best].clone() }, scale: excess.max(1.0) };
    let mut check = check;
    let leg = winner.leg.map(|l| l - 1);
    let features = Features { offsets: &offsets, scales: &scales, sags: &sags, leg };
    if !passed && let Some(f) = figure(model, outcome, &observed, winner_structure, &fits[best], &features) {
        check.figure_axes = Some([f.x_label, f.y_label]);
        check.figure_bins = f.bins;
    }
    Some((check, misfit))
}

/// A test's weight in the family: its share of [`FALSE_ALARM_RATE`] is its weight over the sum of
/// the family's. A test of one column the model's own parameters take most of (a joint's scale,
/// which its offset nearly mimics; the sag, which the geometry bends to) weighs
/// [`FAINT_EFFECT_WEIGHT`]: such an effect costs accuracy long before its residuals stand out (a
/// joint 1 % long costs 1.9 times the error of a 200-pose session at 4.0 standard errors of its column), while
/// the broad tests' effects (the camera's, a marker's, time's) stand out far beyond any share.
fn weight(structure: Structure) -> f64 {
    match structure {
        Structure::Joints | Structure::Sag => FAINT_EFFECT_WEIGHT,
        Structure::Overall | Structure::Camera | Structure::Time | Structure::Marker => 1.0,
    }
}

/// The score test of one group of columns (`X̃ᵀX̃`, `X̃ᵀe` and its sums per cluster in `group`),
/// with its effect `γ̂ = (X̃ᵀX̃)⁺ X̃ᵀe`.
fn regression_test(
    group: &Group,
    rss: f64,
    rows: usize,
    nf: usize,
    shared: bool,
) -> Option<(StructureTest, DVector<f64>)> {
    if group.columns == 0 {
        return None;
    }
    let eigen = crate::math::linalg::bounded_symmetric_eigen(&group.xtx)?;
    // A direction the Jacobian nearly spans (what is left of it is a millionth of the columns'
    // size) is the model's, not a missing effect's.
    let largest = group.xtx_raw.iter().copied().fold(0.0, f64::max);
    if largest <= 0.0 {
        return None;
    }
    let keep: Vec<usize> = (0..eigen.eigenvalues.len()).filter(|&k| eigen.eigenvalues[k] > 1e-6 * largest).collect();
    let r = keep.len();
    if r == 0 {
        return None;
    }
    // `T = U_r Λ_r^{-1/2}`: orthonormal regressors `Z = X̃ T`.
    let t =
        DMatrix::from_fn(group.columns, r, |i, k| eigen.eigenvectors[(i, keep[k])] / eigen.eigenvalues[keep[k]].sqrt());
    let u = t.tr_mul(&group.xte);
    let explained = u.norm_squared();
    let gamma = &t * &u;
    let clusters = group.cluster_xte.len();
    let robust = shared && clusters >= CLUSTERS_PER_COLUMN * r;
    let (statistic, dof) = if robust {
        let mut v = DMatrix::<f64>::zeros(r, r);
        for xte in &group.cluster_xte {
            let u_g = t.tr_mul(xte);
            v += &u_g * u_g.transpose();
        }
        let wald = v.cholesky().map(|c| c.solve(&u).dot(&u))?;
        let g = clusters as f64;
        (wald * (g - r as f64) / (r as f64 * (g - 1.0)), [r as f64, g - r as f64])
    } else {
        let d2 = rows.saturating_sub(nf + r).max(1) as f64;
        ((explained / r as f64) / ((rss - explained).max(f64::MIN_POSITIVE) / d2), [r as f64, d2])
    };
    let p_value = f_survival(statistic, dof[0], dof[1]);
    let test = StructureTest {
        structure: group.structure.name(),
        statistic,
        dof,
        p_value,
        alpha: 0.0,
        z: f_as_normal(statistic, dof[0], dof[1]),
        marker: None,
        leg: group.leg.map(|l| l + 1),
        robust,
    };
    Some((test, gamma))
}

/// What the figure reads its features from: the offsets' entries, the features' scales, the sag's
/// offsets per pose.
struct Features<'a> {
    offsets: &'a [usize],
    scales: &'a Scales,
    sags: &'a [Vector3<f64>],
    /// The winning joint test's leg (0-based).
    leg: Option<usize>,
}

/// The residuals against the winning structure's feature, in the report's unit, binned.
fn figure<M: Residuals>(
    model: &M,
    outcome: &FitOutcome<M::Noise>,
    observed: &[Observed],
    winner: Structure,
    bias: &Option<DVector<f64>>,
    features: &Features<'_>,
) -> Option<ResidualFigure> {
    let Features { offsets, scales, sags, leg } = *features;
    let unit = model.unit();
    let scale = model.unit_scale();
    let residuals = &outcome.evaluation.residuals;
    let jac = outcome.evaluation.jacobian.as_ref()?;
    let pairs: Vec<(f64, f64)> = match winner {
        Structure::Camera => observed
            .iter()
            .zip(residuals)
            .filter_map(|(o, r)| match (o.point, o.pixel) {
                (Some(p), _) => Some((p.norm() * 1e3, p.normalize().dot(r) * scale)),
                (None, Some((c, [u, v]))) => {
                    let d = nalgebra::Vector2::new(u - scales.pixel_mean[c][0], v - scales.pixel_mean[c][1]);
                    let radial = d.norm().max(1e-9);
                    Some((radial, (d.x * r.x + d.y * r.y) / radial * scale))
                }
                _ => None,
            })
            .collect(),
        Structure::Joints => {
            // The winning test's joint (else the one whose scale moves the parameters most).
            let leg = leg.filter(|&l| l < offsets.len()).unwrap_or_else(|| {
                (0..offsets.len())
                    .max_by(|&a, &b| {
                        let size = |k: usize| bias.as_ref().map_or(0.0, |x| x[offsets[k]].abs());
                        size(a).total_cmp(&size(b))
                    })
                    .unwrap_or(0)
            });
            let i = offsets[leg];
            observed
                .iter()
                .zip(residuals)
                .enumerate()
                .map(|(j, (o, r))| {
                    let d = Vector3::new(jac[(3 * j, i)], jac[(3 * j + 1, i)], jac[(3 * j + 2, i)]);
                    let y = if d.norm() > 0.0 { d.normalize().dot(r) * scale } else { 0.0 };
                    (o.joints[leg].to_degrees(), y)
                })
                .collect()
        }
        Structure::Time => {
            // The axis along which the residuals drift most.
            let mut sums = [(0.0, 0.0, 0.0); 3];
            for (o, r) in observed.iter().zip(residuals) {
                let t = o.time_s.unwrap_or(0.0) - scales.time_mean;
                for (c, s) in sums.iter_mut().enumerate() {
                    *s = (s.0 + t * r[c], s.1 + t * t, 0.0);
                }
            }
            let axis = (0..3).max_by(|&a, &b| sums[a].0.abs().total_cmp(&sums[b].0.abs())).unwrap_or(2);
            observed.iter().zip(residuals).map(|(o, r)| (o.time_s.unwrap_or(0.0), r[axis] * scale)).collect()
        }
        Structure::Marker => {
            let markers = observed.iter().filter_map(|o| o.marker.map(|k| k + 1)).max().unwrap_or(0);
            let bins = (0..markers)
                .map(|k| {
                    let of_k: Vec<f64> = observed
                        .iter()
                        .zip(residuals)
                        .filter(|(o, _)| o.marker == Some(k))
                        .map(|(_, r)| (r.norm() * scale).powi(2))
                        .collect();
                    let n = of_k.len().max(1) as f64;
                    let ms = of_k.iter().sum::<f64>() / n;
                    [k as f64, ms.sqrt(), 0.0]
                })
                .collect();
            return Some(ResidualFigure { x_label: "marker".into(), y_label: format!("RMS residual ({unit})"), bins });
        }
        Structure::Sag => observed
            .iter()
            .zip(residuals)
            .enumerate()
            .map(|(j, (_, r))| {
                let g = model.pose_of(j);
                let d: Vector3<f64> = offsets
                    .iter()
                    .zip(sags.get(g).map_or([0.0; 3], |s| [s.x, s.y, s.z]))
                    .map(|(&i, k)| Vector3::new(jac[(3 * j, i)], jac[(3 * j + 1, i)], jac[(3 * j + 2, i)]) * k)
                    .sum();
                let y = if d.norm() > 0.0 { d.normalize().dot(r) * scale } else { 0.0 };
                let tilt = outcome
                    .evaluation
                    .orientations
                    .get(g)
                    .map_or(0.0, |o| (o * Vector3::z()).z.clamp(-1.0, 1.0).acos());
                (tilt.to_degrees(), y)
            })
            .collect(),
        Structure::Overall => return None,
    };
    let (x_label, y_label) = match winner {
        Structure::Camera if observed.iter().any(|o| o.point.is_some()) => {
            ("distance from the camera (mm)".to_string(), format!("residual along the line of sight ({unit})"))
        }
        Structure::Camera => ("distance from the image's centre (px)".to_string(), format!("radial residual ({unit})")),
        Structure::Joints => ("joint angle (°)".to_string(), format!("residual along the joint's offset ({unit})")),
        Structure::Sag => ("platform's tilt (°)".to_string(), format!("residual along the sag's direction ({unit})")),
        _ => ("time (s)".to_string(), format!("residual ({unit})")),
    };
    Some(ResidualFigure { x_label, y_label, bins: binned(pairs, 12) })
}

/// `[x, mean y, standard error]` of `pairs` in `bins` bins of equal count along x.
fn binned(mut pairs: Vec<(f64, f64)>, bins: usize) -> Vec<[f64; 3]> {
    pairs.retain(|(x, y)| x.is_finite() && y.is_finite());
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let per = pairs.len().div_ceil(bins).max(1);
    pairs
        .chunks(per)
        .map(|chunk| {
            let n = chunk.len() as f64;
            let x = chunk.iter().map(|p| p.0).sum::<f64>() / n;
            let y = chunk.iter().map(|p| p.1).sum::<f64>() / n;
            let var = chunk.iter().map(|p| (p.1 - y).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
            [x, y, (var / n).sqrt()]
        })
        .collect()
}

impl ModelCheck {
    /// Whether the test of `structure` failed (below its share of the false-alarm rate).
    pub(crate) fn rejects(&self, structure: Structure) -> bool {
        self.tests.iter().any(|t| t.structure == structure.name() && t.p_value < t.alpha)
    }

    /// The marker test's marker by its name among `names` (the session's markers, in order).
    pub(crate) fn name_markers(&mut self, names: &[String]) {
        for t in self.tests.iter_mut().filter(|t| t.structure == Structure::Marker.name()) {
            if let Some(name) = t.marker.as_ref().and_then(|k| k.parse::<usize>().ok()).and_then(|k| names.get(k)) {
                t.marker = Some(name.clone());
            }
        }
    }

    /// The cause of a failed check in words, with the option that models it, for the fitted camera
    /// model `camera` (a pixel session's: `None`).
    /// `camera_frozen`: the config holds the camera model (`freeze: [camera_model]`).
    pub(crate) fn diagnose(&mut self, camera: Option<&str>, pixels: bool, camera_frozen: bool) {
        if self.passed {
            return;
        }
        let Some(winner) = self.tests.iter().max_by(|a, b| a.z.total_cmp(&b.z)) else { return };
        let structure = [
            Structure::Overall,
            Structure::Camera,
            Structure::Joints,
            Structure::Time,
            Structure::Sag,
            Structure::Marker,
        ]
        .into_iter()
        .find(|s| s.name() == winner.structure)
        .unwrap_or(Structure::Overall);
        let (finding, action) = match structure {
            Structure::Camera if pixels => (
                "the residuals follow the markers' place in the images: the camera rig's calibration is off in a \
                 way the refined terms do not cover"
                    .to_string(),
                "refine more of the rig (`rig_terms`, e.g. the lenses' distortion), or recalibrate the cameras"
                    .to_string(),
            ),
            Structure::Camera => (
                format!(
                    "the residuals follow the markers' position in the camera's volume: the camera's errors go beyond \
                     the `{}` camera model",
                    camera.unwrap_or("fitted")
                ),
                match camera {
                    Some("projective") => {
                        "recalibrate the camera: its errors are beyond a projective model".to_string()
                    }
                    _ if camera_frozen => "take `camera_model` out of `freeze` and fit a fuller camera model \
                                           (`camera_model: auto`, or `affine` / `projective`)"
                        .to_string(),
                    _ => "fit a fuller camera model (`camera_model: auto`, or `affine` / `projective`)".to_string(),
                },
            ),
            Structure::Joints => {
                let joint = winner.leg.map_or("a joint".to_string(), |l| format!("joint {l}"));
                (
                    format!(
                        "the residuals grow with {joint}'s angle, as an encoder whose scale is off makes them (joint \
                         scales)"
                    ),
                    format!(
                        "fit the joint scales (`joint_scales: fit`; `auto` holds a scale the session determines to \
                         no better than 0.1 % unless its own error shows at 3σ), and check {joint}'s encoder: \
                         its counts per revolution and gear ratio"
                    ),
                )
            }
            Structure::Sag => (
                "the residuals grow with the platform's tilt, as its weight would bend it: the platform sags under \
                 gravity (the mechanism or its mounting gives a little), and the calibration held the sag, which \
                 the model has as a term (`platform_sag`), at its start"
                    .to_string(),
                "fit the platform's sag (`platform_sag: fit`, and take `platform_sag` out of `freeze`; `auto` fits it \
                 where its score shows it at 2σ), or limit the workspace's tilt to where the sag is small; else accept \
                 the widened predicted error, which covers what the sag does to the calibration"
                    .to_string(),
            ),
            Structure::Time => (
                "the residuals drift with time: the camera's clock runs at another rate than the encoders', or the \
                 camera or the base moved during the recording"
                    .to_string(),
                "fit the camera clock's rate (a recording of at least `clock_rate_min_duration_s`, `clock_rate` not \
                 frozen), and check that the camera and the base stay fixed"
                    .to_string(),
            ),
            Structure::Marker => {
                let name = winner.marker.clone().unwrap_or_default();
                (
                    format!("marker `{name}` disagrees with the others more than its noise allows"),
                    format!(
                        "check marker `{name}`: mislabelled at some captures, loose, or half hidden; leave it out of \
                         the session if it stays"
                    ),
                )
            }
            Structure::Overall => (
                "the model predicts unseen poses worse than its noise and its parameters' uncertainty allow"
                    .to_string(),
                "spread the poses over the workspace, and check the camera model and the markers".to_string(),
            ),
        };
        self.cause = Some(structure.name());
        self.finding = Some(finding);
        self.action = Some(action);
    }

    /// The check's outcome in one line.
    pub fn summary(&self) -> String {
        let tests: Vec<String> = self
            .tests
            .iter()
            .map(|t| {
                let name = match (&t.marker, t.leg) {
                    (Some(m), _) => format!("marker {m}"),
                    (None, Some(leg)) => format!("joint {leg}"),
                    (None, None) => t.structure.to_string(),
                };
                format!("{name} p = {:.2e}", t.p_value)
            })
            .collect();
        format!(
            "{} (p = {:.3} against a false-alarm rate of {}; cross-validated mean square {:.3} of expected; {})",
            if self.passed {
                "the residuals are what the noise model says"
            } else {
                "the residuals are NOT what the noise model says"
            },
            self.p_value,
            self.false_alarm_rate,
            self.excess,
            tests.join(", ")
        )
    }
}
