//! Which bag is static: runs of joint states resting within `still_rad` for `min_rest_s`, each
//! holding observations (marker points or a body's poses); their joints and observations taken as
//! medians over the rest.

use nalgebra::Vector3;

use crate::dataset::EncoderSample;
use crate::dataset::streams::StreamLimits;

/// A run of joint states that rest within `still` of each other, without a gap.
struct Rest {
    from: usize,
    to: usize,
}

/// A static pose's time (its first observation's) and joints (their median over the rest).
pub(super) type RestingJoints = (f64, Vector3<f64>);

/// The poses of a static bag — each run of joints resting within `still` for at least `min_rest_s`
/// with observations in it: the first observation's time and the joints' median — and the pose of
/// each observation (at `times`, ascending); `None` when some observation falls where the joints
/// move (a free-motion recording: a slow hand also stays within `still` for a few samples, so a
/// rest must last).
pub(super) fn resting(
    encoders: &[EncoderSample],
    times: &[f64],
    still: f64,
    min_rest_s: f64,
) -> Option<(Vec<RestingJoints>, Vec<usize>)> {
    let limits = StreamLimits::default();
    let mut rests: Vec<Rest> = Vec::new();
    let mut from = 0;
    for k in 1..=encoders.len() {
        let ends = k == encoders.len()
            || encoders[k].time_s - encoders[k - 1].time_s > limits.max_encoder_gap_s
            || (encoders[k].joints - encoders[from].joints).amax() > still;
        if ends {
            rests.push(Rest { from, to: k - 1 });
            from = k;
        }
    }
    let (mut poses, mut of) = (Vec::new(), Vec::with_capacity(times.len()));
    let mut rest = 0;
    let mut last_rest = usize::MAX;
    for &t in times {
        while rest < rests.len() && encoders[rests[rest].to].time_s < t {
            rest += 1;
        }
        let r = rests.get(rest)?;
        if encoders[r.from].time_s > t || encoders[r.to].time_s - encoders[r.from].time_s < min_rest_s {
            return None;
        }
        if rest != last_rest {
            let samples = &encoders[r.from..=r.to];
            poses.push((t, Vector3::from_fn(|i, _| median(samples.iter().map(|s| s.joints[i]).collect()))));
            last_rest = rest;
        }
        of.push(poses.len() - 1);
    }
    Some((poses, of))
}

/// The median (the mean of the middle two for an even count) — exact for equal values.
pub(super) fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 || v[n / 2 - 1] == v[n / 2] { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}
