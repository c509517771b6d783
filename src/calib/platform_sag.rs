//! The platform's sag in the fit (`Spm::sagged`): whether a session shows it, and what the report
//! says about it.
//!
//! A platform that bends under its weight turns further down the more it tilts, by `c (n × (−z))`
//! after the rigid mechanism's orientation. The geometry's parameters mimic most of that turn,
//! so a small sag is a faint effect; left out, it still costs the mechanism's accuracy far more
//! than it shows in the residuals (the verdict study: 0.5° per unit of arm, 1.7 times the error).
//! `platform_sag: auto` (the default) fits without it, and tries it when its score at that fit is
//! beyond [`AUTO_SCORE`] standard deviations and the model check at that fit names no other cause;
//! the trial keeps it when its Wald statistic is beyond [`AUTO_SCORE`] too and, fitted, it leaves
//! no other structure for the model check to find. A camera beyond its model or a joint's scale
//! leans on the sag's column too (a camera's error can even raise the sag's test above its own):
//! fitted, the sag would take up their misfit and hide it.

use nalgebra::DMatrix;

use super::fit::{FitOutcome, weighted_normal};
use super::uncertainty::residual_scale;

/// The score (in standard deviations) beyond which `auto` tries the sag, and the Wald statistic's
/// root beyond which it keeps it: 2, a 5 % test. A clean session then fits it one time in twenty,
/// at the cost of one parameter the geometry nearly mimics; a 3σ test would leave a sag of 0.5°
/// per unit of arm unfitted in half the sessions of the verdict study, at 1.7 times the error.
pub(crate) const AUTO_SCORE: f64 = 2.0;

/// What the calibration tried together after the fit without them: the joint scales `auto`
/// found determined (entry indices), or the sag (its entry).
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Trial {
    /// The joint scales, kept together at 3σ's worth (`joint_scales::shows_error`).
    Scales(Vec<usize>),
    /// The sag, kept beyond [`AUTO_SCORE`].
    Sag(usize),
}

impl Trial {
    /// The entries tried.
    pub(crate) fn indices(&self) -> Vec<usize> {
        match self {
            Trial::Scales(indices) => indices.clone(),
            Trial::Sag(i) => vec![*i],
        }
    }

    /// Whether the trial's Wald statistic `wald` of these entries keeps them.
    pub(crate) fn shows(&self, wald: f64) -> bool {
        match self {
            Trial::Scales(indices) => super::joint_scales::shows_error(wald, indices.len()),
            Trial::Sag(_) => wald >= AUTO_SCORE * AUTO_SCORE,
        }
    }
}

/// The score statistic's root (signed, in standard deviations) of the held entry `sag` at
/// `outcome`, a fit of the `free` parameters (with the prior `lambda` on them, when the fit had
/// one): `g / √(σ̂² S)`, `g` the cost's gradient along the sag after the free parameters' (zero at
/// the optimum) and `S` the Schur complement of the weighted normal equations. `None` when the
/// data cannot tell the sag from the free parameters at all.
pub(crate) fn score<N>(
    outcome: &FitOutcome<N>,
    free: &[bool],
    sag: usize,
    lambda: Option<&DMatrix<f64>>,
) -> Option<f64> {
    let fitted: Vec<usize> = (0..free.len()).filter(|&i| free[i]).collect();
    let sigma2 = residual_scale(outcome, fitted.len());
    let all: Vec<usize> = fitted.iter().copied().chain([sag]).collect();
    let (mut h, g) = weighted_normal(&outcome.evaluation, &outcome.weighting, &all);
    if let Some(l) = lambda {
        for (a, &i) in fitted.iter().enumerate() {
            for (b, &k) in fitted.iter().enumerate() {
                h[(a, b)] += l[(i, k)];
            }
        }
    }
    let n = fitted.len();
    let hff = h.view((0, 0), (n, n)).clone_owned();
    let hfs = h.view((0, n), (n, 1)).clone_owned();
    let inv = crate::math::linalg::symmetric_pseudo_inverse(&hff, 1e-14)?;
    let s = h[(n, n)] - (hfs.transpose() * &inv * &hfs)[(0, 0)];
    let gs = g[n] - (hfs.transpose() * &inv * g.rows(0, n))[(0, 0)];
    // Relative to its own curvature, a Schur complement this small is the sag mimicked exactly.
    (s > 1e-10 * h[(n, n)] && sigma2 > 0.0).then(|| -gs / (sigma2 * s).sqrt())
}

/// Why `auto` did not try the sag: its score `z` (`None`: the data cannot tell it from the
/// mechanism's other parameters).
pub(crate) fn held_reason(z: Option<f64>) -> String {
    match z {
        Some(z) => format!(
            "not shown by this session: its score at the fit without it is {z:+.2}σ, within the ±{AUTO_SCORE:.0}σ \
             `platform_sag: auto` tries it beyond"
        ),
        None => "not determined by this session: the poses cannot tell it from the geometry".to_string(),
    }
}

/// Why `auto` did not try the sag although its score `z` is beyond [`AUTO_SCORE`]: the model
/// check at the fit without it names another `cause`.
pub(crate) fn named_cause_reason(z: f64, cause: &str) -> String {
    format!(
        "not tried: its score at the fit without it is {z:+.2}σ, but the model check names the {cause} as the \
         residuals' likeliest cause, whose misfit leans on the sag's column too"
    )
}

/// Why `auto` held the sag although the trial's Wald statistic may show it (`change` and `sigma`
/// what the trial gave, radians per unit of arm): with it fitted, the model check's test of another
/// structure (`cause`) still rejects, so that the misfit is not (only) a sag.
pub(crate) fn other_cause_reason(change: f64, sigma: f64, cause: &str) -> String {
    format!(
        "not kept: freed, it moved {:+.3} ± {:.3}° per unit of arm, but the residuals still follow the {cause} (the \
         model check's test rejects), whose misfit leans on the sag's column too",
        change.to_degrees(),
        sigma.to_degrees()
    )
}

/// Why `auto` held the sag after trying it (`change` from its start and `sigma`, radians per unit
/// of arm, what the trial gave).
pub(crate) fn insignificant_reason(change: f64, sigma: f64) -> String {
    format!(
        "not distinguishable from its start: freed, it moved {:+.3} ± {:.3}° per unit of arm, within the \
         ±{AUTO_SCORE:.0}σ `platform_sag: auto` keeps it beyond",
        change.to_degrees(),
        sigma.to_degrees()
    )
}
