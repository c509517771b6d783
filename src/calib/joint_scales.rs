//! The joints' scales in the fit (`φ = sθ + δ`): which ones a session identifies, and what the
//! report says about them.
//!
//! A scale moves a joint's angle by `θ` times what its offset does: where a joint's reading barely
//! changes over the session the two cannot be told apart, and where it spans a little they can
//! only poorly. `joint_scales: auto` (the default) keeps a fitted scale only where the fit
//! determines it to [`AUTO_MOST_STD_ERROR`] (else it is held at its start with a warning giving the
//! joint's span) and the scales together differ from their start by 3σ's worth (else they are
//! held there, said in the report's lines; see [`auto_holds`]);
//! `fit` fits all three (an unidentifiable one is then regularised like any other direction);
//! `hold` fits none.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use super::config::{CalibConfig, JointScales};
use super::identify::Identifiability;
use super::parameterisation::{Kind, Parameterisation};
use super::uncertainty::std_error;
use crate::dataset::Session;

/// `auto` fits a scale whose standard error is at most this (0.1 %): a transmission's error of
/// 0.3 % is then seen at 3σ, and one that the data determine no better would add to the
/// calibrated model's error about as much as it could remove.
pub(crate) const AUTO_MOST_STD_ERROR: f64 = 1e-3;

/// A scale weighs this much (column-scaled) in an unidentifiable direction: it is part of what
/// the data cannot determine (as a camera term: `pipeline::CAMERA_IN_NULL_DIRECTION`).
const SCALE_IN_NULL_DIRECTION: f64 = 0.3;

/// One leg's joint scale as the calibration leaves it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct JointScaleReport {
    /// Leg number (1-based).
    pub leg: usize,
    /// The scale `s` (`φ = sθ + δ`).
    pub scale: f64,
    /// Its change from the start, parts per million.
    pub change_ppm: f64,
    /// Its standard error (ppm), when fitted and not at its bound.
    pub std_error_ppm: Option<f64>,
    /// Why it was not fitted (`None`: fitted).
    pub held: Option<String>,
}

/// The entry indices of the scales in `p`, with their legs.
pub(crate) fn entries(p: &Parameterisation) -> Vec<(usize, usize)> {
    p.entries
        .iter()
        .enumerate()
        .filter_map(|(i, e)| match e.kind {
            Kind::Scale { leg } => Some((i, leg)),
            _ => None,
        })
        .collect()
}

/// The span of each joint's reading over the session's poses (degrees).
pub(crate) fn spans_deg(session: &Session) -> [f64; 3] {
    std::array::from_fn(|leg| {
        let (low, high) = session
            .poses
            .iter()
            .map(|p| p.joints[leg])
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), t| (l.min(t), h.max(t)));
        if high >= low { (high - low).to_degrees() } else { 0.0 }
    })
}

/// The scales that take part in an unidentifiable direction (by their share of the column-scaled
/// direction, so that units do not decide).
pub(crate) fn unidentified(p: &Parameterisation, identifiability: &Identifiability) -> Vec<usize> {
    let scales: Vec<usize> = entries(p).into_iter().map(|(i, _)| i).collect();
    let mut held: Vec<usize> = identifiability
        .null_vectors
        .iter()
        .flat_map(|v| {
            let scaled = v.component_mul(&identifiability.column_norms);
            let norm = scaled.norm().max(f64::MIN_POSITIVE);
            scales.iter().copied().filter(move |&i| (scaled[i] / norm).abs() > SCALE_IN_NULL_DIRECTION)
        })
        .collect();
    held.sort_unstable();
    held.dedup();
    held
}

/// `free` as the check of enough observations counts it: under `auto` the scales are fitted only
/// where the data show them, so a session too small for them is still calibrated without them.
pub(crate) fn counted(p: &Parameterisation, free: &[bool], config: &CalibConfig) -> Vec<bool> {
    let auto = auto(config);
    free.iter().zip(&p.entries).map(|(f, e)| *f && !(auto && matches!(e.kind, Kind::Scale { .. }))).collect()
}

/// Whether `auto` decides which scales to fit (the setting is `auto` and they are not frozen).
pub(crate) fn auto(config: &CalibConfig) -> bool {
    config.joint_scales == JointScales::Auto && !config.freeze.contains(&super::config::Group::JointScales)
}

/// The 99.73 % quantile (3σ's worth) of χ² with 1, 2 and 3 degrees of freedom: `auto` keeps the
/// fitted scales when their changes, taken together with their covariance, exceed it.
const CHI2_3_SIGMA: [f64; 3] = [9.0, 11.829, 14.156];

/// What `auto` does with the fitted scales, as `(entry, σ, undetermined)` for each one to hold:
/// a scale whose standard error exceeds [`AUTO_MOST_STD_ERROR`] is held (`undetermined`: the
/// session cannot tell it); the others are kept together or held together, kept when their
/// changes differ from none by 3σ's worth jointly (the Wald statistic `Δsᵀ C⁻¹ Δs` against χ²'s
/// 99.73 % quantile). On a session without a scale error they are then fitted in 0.3 % of
/// sessions — fitting three scales determined to ±500 ppm would cost such a session 20–30 % of its
/// accuracy (`examples/joint_scales`) — and where one joint's error shows, all are fitted, so that
/// a smaller error beside it is not left behind.
pub(crate) fn auto_holds(
    p: &Parameterisation,
    x: &DVector<f64>,
    cov: &DMatrix<f64>,
    free: &[bool],
) -> (Vec<(usize, f64, bool)>, f64) {
    let fitted: Vec<(usize, f64)> =
        entries(p).into_iter().filter_map(|(i, _)| std_error(cov, free, i).map(|s| (i, s))).collect();
    let (undetermined, determined): (Vec<_>, Vec<_>) =
        fitted.into_iter().partition(|(_, s)| s.is_nan() || *s > AUTO_MOST_STD_ERROR);
    let mut holds: Vec<(usize, f64, bool)> = undetermined.iter().map(|&(i, s)| (i, s, true)).collect();
    let k = determined.len();
    let wald = match k {
        0 => 0.0,
        _ => {
            let c = DMatrix::from_fn(k, k, |a, b| cov[(determined[a].0, determined[b].0)]);
            let d = DVector::from_fn(k, |a, _| x[determined[a].0]);
            let eps = 1e-14 * c.amax();
            c.pseudo_inverse(eps).map_or(f64::INFINITY, |inv| (d.transpose() * inv * &d)[(0, 0)])
        }
    };
    if k > 0 && wald < CHI2_3_SIGMA[k - 1] {
        holds.extend(determined.iter().map(|&(i, s)| (i, s, false)));
    }
    (holds, wald)
}

/// Why a scale `auto` fitted was held at its start because the data do not show the scales to
/// differ (`wald`: their joint statistic, over `k` scales).
pub(crate) fn insignificant_reason(change: f64, sigma: f64, wald: f64, k: usize) -> String {
    format!(
        "not distinguishable from its start: fitted, it moved {:+.0} ± {:.0} ppm; the {k} scales' changes together \
         give χ² = {wald:.1}, under the {:.1} of 3σ",
        1e6 * change,
        1e6 * sigma,
        CHI2_3_SIGMA[k.clamp(1, 3) - 1]
    )
}

/// Why a scale was held, in the report's line for its leg: `span` the joint's reading span
/// (degrees), `sigma` the standard error it would have had (`None`: not identifiable at all).
pub(crate) fn held_reason(span_deg: f64, sigma: Option<f64>) -> String {
    let determined = match sigma {
        Some(s) => format!("tells it from the joint's offset to ±{:.2} % only", 100.0 * s),
        None => "cannot tell it from the joint's offset".to_string(),
    };
    format!(
        "not determined by this session: the joint's reading spans {span_deg:.1}°, which {determined} \
         (`joint_scales: auto` fits a scale determined to ±{:.1} %)",
        100.0 * AUTO_MOST_STD_ERROR
    )
}

/// The one warning for the scales held as undetermined: `(leg, span in degrees, σ)` each.
pub(crate) fn undetermined_warning(held: &[(usize, f64, Option<f64>)]) -> Option<String> {
    if held.is_empty() {
        return None;
    }
    let list = |items: Vec<String>| match items.len() {
        1 => items[0].clone(),
        n => format!("{} and {}", items[..n - 1].join(", "), items[n - 1]),
    };
    let legs = list(held.iter().map(|(leg, _, _)| (leg + 1).to_string()).collect());
    let spans = list(held.iter().map(|(_, span, _)| format!("{span:.0}°")).collect());
    let sigmas = list(
        held.iter().map(|(_, _, s)| s.map_or("not at all".to_string(), |s| format!("±{:.2} %", 100.0 * s))).collect(),
    );
    let (noun, held_at, them, span) = match held.len() {
        1 => ("scale of leg", "is held at its start", "it", "its reading spans"),
        _ => ("scales of legs", "are held at their start", "them", "their readings span"),
    };
    Some(format!(
        "the joint {noun} {legs} {held_at}: this session tells {them} from the joint offsets to {sigmas} \
         ({span} {spans}; `joint_scales: auto` fits a scale determined to ±{:.1} %): move the joints further to \
         calibrate {them}, or set `joint_scales: fit`",
        100.0 * AUTO_MOST_STD_ERROR
    ))
}

/// Each leg's scale at `x` with its standard error, and why held ones were held (`held`: entry
/// index and reason; a scale frozen by the config is said so).
pub(crate) fn report(
    p: &Parameterisation,
    x: &DVector<f64>,
    cov: &DMatrix<f64>,
    free: &[bool],
    held: &[(usize, String)],
) -> Vec<JointScaleReport> {
    let legs = p.legs(x);
    entries(p)
        .into_iter()
        .map(|(i, leg)| {
            let held = match held.iter().find(|(k, _)| *k == i) {
                Some((_, why)) => Some(why.clone()),
                None if p.at_bound(x, i) => {
                    Some("at its bound (`bounds.joint_scale`): the data want it further".into())
                }
                None if !free[i] => Some("frozen (`joint_scales: hold` or `freeze: [joint_scales]`)".into()),
                None => None,
            };
            JointScaleReport {
                leg: leg + 1,
                scale: legs[leg].scale,
                change_ppm: 1e6 * x[i],
                std_error_ppm: std_error(cov, free, i).map(|s| 1e6 * s),
                held,
            }
        })
        .collect()
}
