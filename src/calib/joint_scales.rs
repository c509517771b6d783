//! The joints' scales in the fit (`φ = sθ + δ`): which ones a session identifies, and what the
//! report says about them.
//!
//! A scale moves a joint's angle by `θ` times what its offset does: where a joint's reading barely
//! changes over the session the two cannot be told apart, and where it spans a little they can
//! only poorly. `joint_scales: auto` (the default) fits without them, frees the ones the fit would
//! determine to [`AUTO_MOST_STD_ERROR`] and those determined worse whose own score test shows an
//! error at 3σ ([`score`]; the others are held at their start with a note giving the joints'
//! spans) and keeps them when together they differ from their start by 3σ's worth ([`wald`],
//! [`shows_error`]); else the fit without them stands, the report's lines saying why;
//! `fit` fits all three (an unidentifiable one is then regularised like any other direction);
//! `hold` fits none.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use super::config::{CalibConfig, FitChoice};
use super::fit::{FitOutcome, weighted_normal};
use super::parameterisation::{Kind, Parameterisation};
use super::uncertainty::{residual_scale, std_error};
use crate::dataset::Session;

/// `auto` tries a scale whose standard error is at most this (0.1 %): a transmission's error of
/// 0.3 % is then seen at 3σ. One that the data determine no better would add to the calibrated
/// model's error about as much as it could remove, unless its error is large: it is tried only
/// when its score test at the fit without it shows the error at 3σ (a joint 1 % long where the
/// session determines its scale to ±0.25 % costs 1.9 times the error when held).
pub(crate) const AUTO_MOST_STD_ERROR: f64 = 1e-3;

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

/// `free` as the check of enough observations counts it: under `auto` the scales (and the sag) are
/// fitted only where the data show them, so a session too small for them is still calibrated
/// without them.
pub(crate) fn counted(p: &Parameterisation, free: &[bool], config: &CalibConfig) -> Vec<bool> {
    let auto = auto(config);
    let sag = config.sag_auto();
    free.iter()
        .zip(&p.entries)
        .map(|(f, e)| *f && !(auto && matches!(e.kind, Kind::Scale { .. })) && !(sag && e.kind == Kind::PlatformSag))
        .collect()
}

/// Whether `auto` decides which scales to fit (the setting is `auto` and they are not frozen).
pub(crate) fn auto(config: &CalibConfig) -> bool {
    config.joint_scales == FitChoice::Auto && !config.freeze.contains(&super::config::Group::JointScales)
}

/// The 99.73 % quantile (3σ's worth) of χ² with 1, 2 and 3 degrees of freedom: `auto` frees the
/// scales when their changes, taken together with their covariance, would exceed it.
const CHI2_3_SIGMA: [f64; 3] = [9.0, 11.829, 14.156];

/// The score (Lagrange multiplier) test of the scales at a fit that held them: what the data say
/// about them without fitting them. At the fit's optimum the gradient of the free parameters is
/// zero; the scales' gradient `g_s`, with the Schur complement `S = H_ss − H_sf H_ff⁻¹ H_fs` of the
/// weighted normal equations, gives each scale's standard error were it freed (`σ̂² S⁻¹`), the
/// one-step change it would make (`−S⁻¹ g_s`) and the score statistic `g_sᵀ S⁻¹ g_s / σ̂²`. `auto`
/// uses the standard errors, and for a scale determined worse than [`AUTO_MOST_STD_ERROR`] its
/// own score statistic (3σ), to choose which scales to try; it decides on the Wald statistic of
/// the fit with them free, since the score's is blunted where the fit without them bent the
/// camera model and the robust weights to a scale error (a ten-minute recording, measured).
pub(crate) struct Score {
    /// Scales to try: determined to [`AUTO_MOST_STD_ERROR`], or worse with an error their score
    /// shows at 3σ: `(entry, one-step change, σ)`.
    pub(crate) determined: Vec<(usize, f64, f64)>,
    /// The others: `(entry, σ)` (`None`: not identifiable at all).
    pub(crate) undetermined: Vec<(usize, Option<f64>)>,
    /// The statistic of the determined ones.
    pub(crate) chi2: f64,
}

/// Whether `k` scales whose changes give the Wald statistic `wald` differ from their start by 3σ's
/// worth together.
pub(crate) fn shows_error(wald: f64, k: usize) -> bool {
    k > 0 && wald >= CHI2_3_SIGMA[k.min(3) - 1]
}

/// The Wald statistic `Δsᵀ C⁻¹ Δs` of the scales `indices` at `x` (their changes from the start)
/// with the fit's covariance `cov`.
pub(crate) fn wald(x: &DVector<f64>, cov: &DMatrix<f64>, indices: &[usize]) -> f64 {
    let k = indices.len();
    let c = DMatrix::from_fn(k, k, |a, b| cov[(indices[a], indices[b])]);
    let d = DVector::from_fn(k, |a, _| x[indices[a]]);
    crate::math::linalg::symmetric_pseudo_inverse(&c, 1e-14)
        // Not a number when the covariance is not (a fit gone non-finite): no evidence either way.
        .map_or(f64::NAN, |inv| (d.transpose() * inv * &d)[(0, 0)])
}

/// The score test of the scales `tested` at `outcome`, a fit of the `free` parameters (with the
/// prior `lambda` on them, when the fit had one).
pub(crate) fn score<N>(
    outcome: &FitOutcome<N>,
    free: &[bool],
    tested: &[usize],
    lambda: Option<&DMatrix<f64>>,
) -> Score {
    let fitted: Vec<usize> = (0..free.len()).filter(|&i| free[i]).collect();
    let sigma2 = residual_scale(outcome, fitted.len());
    let schur = |scales: &[usize]| -> Option<(DMatrix<f64>, DVector<f64>)> {
        let all: Vec<usize> = fitted.iter().chain(scales).copied().collect();
        let (mut h, g) = weighted_normal(&outcome.evaluation, &outcome.weighting, &all);
        if let Some(l) = lambda {
            for (a, &i) in fitted.iter().enumerate() {
                for (b, &k) in fitted.iter().enumerate() {
                    h[(a, b)] += l[(i, k)];
                }
            }
        }
        let (nf, ns) = (fitted.len(), scales.len());
        let hff = h.view((0, 0), (nf, nf)).clone_owned();
        let hfs = h.view((0, nf), (nf, ns)).clone_owned();
        let hss = h.view((nf, nf), (ns, ns)).clone_owned();
        let inv = crate::math::linalg::symmetric_pseudo_inverse(&hff, 1e-14)?;
        let mut s = &hss - hfs.transpose() * &inv * &hfs;
        // A scale its free parameters mimic to rounding (its Schur complement a 1e-12 of its own
        // curvature) is undetermined: zeroed, as the inverse's unit diagonal would not see it.
        for a in 0..ns {
            if s[(a, a)] <= 1e-12 * hss[(a, a)] {
                s.row_mut(a).fill(0.0);
                s.column_mut(a).fill(0.0);
            }
        }
        let gs = g.rows(nf, ns) - hfs.transpose() * &inv * g.rows(0, nf);
        Some((s, gs))
    };
    let mut out = Score { determined: Vec::new(), undetermined: Vec::new(), chi2: 0.0 };
    let Some((s, gs)) = schur(tested) else {
        out.undetermined = tested.iter().map(|&i| (i, None)).collect();
        return out;
    };
    // Each scale's standard error, were all the tested ones freed.
    let cov = crate::math::linalg::symmetric_pseudo_inverse(&s, 1e-12);
    let mut determined = Vec::new();
    for (a, &i) in tested.iter().enumerate() {
        let sigma = cov.as_ref().map(|c| (sigma2 * c[(a, a)]).sqrt()).filter(|s| s.is_finite() && *s > 0.0);
        // Its own score statistic, it alone freed (the Schur complement's diagonal is its own).
        let shows = s[(a, a)] > 0.0 && gs[a] * gs[a] / (sigma2 * s[(a, a)]) >= CHI2_3_SIGMA[0];
        match sigma {
            Some(sd) if sd <= AUTO_MOST_STD_ERROR || shows => determined.push(i),
            _ => out.undetermined.push((i, sigma)),
        }
    }
    if determined.is_empty() {
        return out;
    }
    let Some((s, gs)) = schur(&determined) else { return out };
    let Some(inv) = crate::math::linalg::symmetric_pseudo_inverse(&s, 1e-12) else { return out };
    let step = -(&inv * &gs);
    out.chi2 = (gs.transpose() * &inv * &gs)[(0, 0)] / sigma2;
    out.determined = determined.iter().enumerate().map(|(a, &i)| (i, step[a], (sigma2 * inv[(a, a)]).sqrt())).collect();
    out
}

/// Why a scale `auto` held at its start: the data do not show the scales to differ (`change` and
/// `sigma` what freeing it would give, `wald` the statistic of the `k` scales together).
pub(crate) fn insignificant_reason(change: f64, sigma: f64, wald: f64, k: usize) -> String {
    format!(
        "not distinguishable from its start: freed, it moved {:+.0} ± {:.0} ppm; the {k} scales' changes together \
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
         (`joint_scales: auto` fits a scale determined to ±{:.1} %, or worse where its error shows at 3σ)",
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
         ({span} {spans}; `joint_scales: auto` fits a scale determined to ±{:.1} %, or worse where its error shows \
         at 3σ): move the joints further to \
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
