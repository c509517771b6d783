//! The verdict and its model check (README table, issue 36). Over simulated sessions from a camera
//! of realistic noise (1 mm across and 3 mm along the line of sight at the reference distance; a
//! new true geometry per seed), calibrated with the defaults (`camera_model: auto`, 5-fold
//! cross-validation):
//! - clean sessions of every kind (a pixel session's points triangulated through the true rig
//!   among them: the reference of a rig file's points): how often the model check fails (a false alarm; it holds to
//!   2 %) and how often the verdict is not PASS;
//! - sessions with an effect the model does not have (a camera beyond the fitted camera model, a
//!   stereo rig's ordinary miscalibration, a joint whose encoder reads 1 % or 2 % long, markers
//!   swapped at some captures): what the effect costs (the calibrated
//!   mechanism's error against the truth over the same seeds' clean sessions), how often the check
//!   fails (its power), how often it names the right cause, and the predicted error over the
//!   achieved one without and with the widening. The joint scales are held (`joint_scales:
//!   hold`), the camera clock's rate frozen and the platform's sag held (`platform_sag: hold`) on
//!   the rows of those effects; a platform that sags under its weight (`truth.sag_deg`) is scored
//!   against where it really is, sag included;
//! - the same joint scale, clock rate and sag calibrated with the defaults, which model them.
//!
//! Run: `cargo run --release --example verdict [sessions] [recordings] [hours]` (default 40 static
//! sessions per row and clean recordings of two and ten minutes, 10 recordings per ten-minute row
//! of an effect, 2 hour-long recordings).

#[macro_use]
#[path = "../common/results.rs"]
mod results;
use std::path::Path;
use std::sync::Arc;

use spmcal::calib::{CalibConfig, CameraModelSetting, FitChoice, Group};
use spmcal::dataset::Session;
use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;

#[path = "../marker_efficiency/study.rs"]
#[allow(dead_code)]
mod study;

/// One calibration as the study scores it.
struct Outcome {
    /// The model check failed.
    flagged: bool,
    /// The cause it named (a test's structure).
    cause: Option<String>,
    /// `PASS`, `WARN` or `FAIL`.
    verdict: &'static str,
    /// The calibrated mechanism's error against the truth (deg, up to the common rotations).
    achieved: f64,
    /// The report's predicted error (deg), widened when the check failed.
    predicted: f64,
    /// The same before the widening.
    unwidened: f64,
    /// The statistic (an F of one column) of the test of the row's cause, when that test is of
    /// one column (a joint's, the sag's): its mean over the sessions estimates the noncentrality.
    effect_f: Option<f64>,
    /// That test's share of the family's false-alarm rate.
    effect_alpha: Option<f64>,
}

/// A kind of session: its config, how it is altered, how it is calibrated.
#[derive(Clone)]
struct Kind {
    label: &'static str,
    config: SimConfig,
    sessions: u64,
    seed0: u64,
    alter: Alter,
    settings: CalibConfig,
    /// The cause the check should name.
    cause: &'static str,
}

/// Which rig triangulates a pixel session's points.
#[derive(Clone, Copy, PartialEq)]
enum Through {
    /// The rig file the session came with.
    File,
    /// The rig as it really is.
    Truth,
}

/// What the study does to a simulated session before calibrating it.
#[derive(Clone, Copy, PartialEq)]
enum Alter {
    /// Nothing.
    None,
    /// A pixel session seen through the true rig (a perfect rig file).
    PerfectRig,
    /// A pixel session's points as a rig triangulates them, its pixels dropped: the session's
    /// (miscalibrated) rig file, or the true rig (`Through::Truth`).
    Triangulated(Through),
    /// Written as a ROS 2 bag and read back (the truth, which a bag does not carry, kept).
    Bag,
    /// Markers 1 and 2 swapped at every n-th capture.
    Swapped(u64),
}

fn main() {
    let mut results = results::Results::new("verdict");
    let arg = |k: usize, default: u64| std::env::args().nth(k).and_then(|a| a.parse().ok()).unwrap_or(default);
    let (sessions, recordings, hours) = (arg(1, 40), arg(2, 10), arg(3, 2));
    let model = RobotModel::load(Path::new("models/agile_wrist.urdf")).expect("shipped model");
    let realistic = |path: &str| {
        let mut c = SimConfig::read(Path::new(path)).expect("shipped config");
        (c.camera.lateral_sigma_m, c.camera.depth_sigma_m) = (0.001, 0.003);
        c
    };
    let fixed = realistic("configs/simulate_agile_wrist.yaml");
    let static_n = |n: usize| {
        let mut c = fixed.clone();
        c.poses = n;
        c
    };
    let free_motion = |seconds: f64| {
        let mut c = realistic("configs/simulate_agile_wrist_free_motion.yaml");
        c.recording.as_mut().expect("a recording config").duration_s = seconds;
        c
    };
    let stereo = SimConfig::read(Path::new("configs/simulate_agile_wrist_stereo.yaml")).expect("shipped config");
    // The predicted error over the workspace the achieved one is measured on.
    let workspace = Some(study::TEST_WORKSPACE);
    let with = |camera_model| CalibConfig { camera_model, workspace, ..CalibConfig::default() };
    let kind = |label, config, sessions, seed0, alter, camera_model, cause| Kind {
        label,
        config,
        sessions,
        seed0,
        alter,
        settings: with(camera_model),
        cause,
    };
    let held = |k: Kind, group: Group| {
        let mut settings = k.settings.clone();
        match group {
            Group::JointScales => settings.joint_scales = FitChoice::Hold,
            Group::PlatformSag => settings.platform_sag = FitChoice::Hold,
            other => settings.freeze.push(other),
        }
        Kind { settings, ..k }
    };
    let auto = CameraModelSetting::Auto;
    let clean = [
        kind("static, 20 poses", static_n(20), sessions, 36_000, Alter::None, auto, ""),
        kind("static, 200 poses", static_n(200), sessions, 36_100, Alter::None, auto, ""),
        kind(
            "sequential, 200 stations",
            realistic("configs/simulate_agile_wrist_sequential.yaml"),
            sessions,
            36_200,
            Alter::None,
            auto,
            "",
        ),
        // As many clean recordings of two and ten minutes as static sessions: with ten, one false
        // alarm would read 10 %.
        kind("free motion, 2 min", free_motion(120.0), sessions, 36_300, Alter::None, auto, ""),
        kind("free motion, 2 min, as a ROS 2 bag", free_motion(120.0), sessions, 36_700, Alter::Bag, auto, ""),
        kind("free motion, 10 min", free_motion(600.0), sessions, 36_400, Alter::None, auto, ""),
        kind("free motion, 60 min", free_motion(3600.0), hours, 36_500, Alter::None, auto, ""),
        kind("pixels, 200 poses, perfect rig", stereo.clone(), sessions, 36_600, Alter::PerfectRig, auto, ""),
        // The reference of the rig file's points: the same pixels triangulated through the true rig.
        kind(
            "stereo points, 200 poses, perfect rig",
            stereo.clone(),
            sessions,
            36_600,
            Alter::Triangulated(Through::Truth),
            auto,
            "",
        ),
    ];
    out!(
        results,
        "| clean session (1 mm / 3 mm camera) | sessions | model check fails (false alarms) | verdict not PASS | \
         predicted / achieved |"
    );
    out!(results, "|---|---|---|---|---|");
    let mut clean_rows = Vec::new();
    for k in &clean {
        let rows = run_kind(k, &model);
        let n = rows.len();
        let flagged = rows.iter().filter(|o| o.flagged).count();
        let not_pass = rows.iter().filter(|o| o.verdict != "PASS").count();
        out!(
            results,
            "| {} | {n} | {flagged} ({:.1} %) | {not_pass} | {:.2} |",
            k.label,
            percent(flagged, n),
            rms(rows.iter().map(|o| o.predicted)) / rms(rows.iter().map(|o| o.achieved))
        );
        clean_rows.push(rows);
    }
    let (all, alarms) =
        clean_rows.iter().fold((0, 0), |(a, f), r| (a + r.len(), f + r.iter().filter(|o| o.flagged).count()));
    out!(results, "| all clean sessions | {all} | {alarms} ({:.1} %) | | |", percent(alarms, all));
    out!(results);

    // The effects, each against the clean row of the same sessions (same seeds).
    let mut depth = static_n(200);
    depth.camera.depth_scale = 1.02;
    let mut depth_moving = free_motion(600.0);
    depth_moving.camera.depth_scale = 1.02;
    let mut clock = free_motion(600.0);
    clock.recording.as_mut().expect("a recording config").clock_rate_ppm = 50.0;
    // Joint 1 reads `long` (a fraction) more than it turns: its true scale `1 / (1 + long)`, which
    // the truth carries, so that the unseen poses' readings are what the device would read.
    let long_joint = |long: f64| {
        let mut c = static_n(200);
        c.encoders.scales[0] = 1.0 / (1.0 + long);
        c
    };
    // The scales held: what the model check is to find.
    let held_joint = |label, long| {
        let k = kind(label, long_joint(long), sessions, 36_100, Alter::None, auto, "joint angles");
        held(k, Group::JointScales)
    };
    let sagging = |sag_deg: f64| {
        let mut c = static_n(200);
        c.truth.sag_deg = sag_deg;
        c
    };
    let mut affine = static_n(200);
    (affine.camera.depth_scale, affine.camera.scale_y, affine.camera.shear_xz, affine.camera.shear_xy) =
        (1.01, 0.99, 0.01, 0.005);
    let effects = [
        (
            kind(
                "depths 2 % long, fitted `rigid`",
                depth,
                sessions,
                36_100,
                Alter::None,
                CameraModelSetting::Rigid,
                "camera volume",
            ),
            1,
        ),
        (
            kind(
                "depths 2 % long, fitted `rigid`, 10 min",
                depth_moving,
                recordings,
                36_400,
                Alter::None,
                CameraModelSetting::Rigid,
                "camera volume",
            ),
            5,
        ),
        (
            kind(
                "affine camera, fitted `depth_scale`",
                affine,
                sessions,
                36_100,
                Alter::None,
                CameraModelSetting::DepthScale,
                "camera volume",
            ),
            1,
        ),
        (
            kind(
                "stereo rig's file off, its points, `auto`",
                stereo.clone(),
                sessions,
                36_600,
                Alter::Triangulated(Through::File),
                auto,
                "camera volume",
            ),
            8,
        ),
        (
            kind(
                "stereo rig's file off, pixels, rig refined",
                stereo,
                sessions,
                36_600,
                Alter::None,
                auto,
                "camera volume",
            ),
            7,
        ),
        (held_joint("joint 1 reads 1 % long, scales held", 0.01), 1),
        (held_joint("joint 1 reads 1.5 % long, scales held", 0.015), 1),
        (held_joint("joint 1 reads 2 % long, scales held", 0.02), 1),
        (
            held(
                kind(
                    "clock 50 ppm fast, rate frozen, 10 min",
                    clock.clone(),
                    recordings,
                    36_400,
                    Alter::None,
                    auto,
                    "time",
                ),
                Group::ClockRate,
            ),
            5,
        ),
        (
            held(
                kind(
                    "platform sags 0.5° per unit of arm (0.25° at 30° of tilt), sag held",
                    sagging(0.5),
                    sessions,
                    36_100,
                    Alter::None,
                    auto,
                    "platform sag",
                ),
                Group::PlatformSag,
            ),
            1,
        ),
        (
            held(
                kind(
                    "platform sags 0.75° per unit of arm (0.375° at 30° of tilt), sag held",
                    sagging(0.75),
                    sessions,
                    36_100,
                    Alter::None,
                    auto,
                    "platform sag",
                ),
                Group::PlatformSag,
            ),
            1,
        ),
        (
            held(
                kind(
                    "platform sags 1° per unit of arm (0.5° at 30° of tilt), sag held",
                    sagging(1.0),
                    sessions,
                    36_100,
                    Alter::None,
                    auto,
                    "platform sag",
                ),
                Group::PlatformSag,
            ),
            1,
        ),
        (
            kind(
                "markers m1, m2 swapped at 10 % of poses",
                static_n(200),
                sessions,
                36_100,
                Alter::Swapped(10),
                auto,
                "a marker",
            ),
            1,
        ),
        (
            kind(
                "markers m1, m2 swapped at 25 % of poses",
                static_n(200),
                sessions,
                36_100,
                Alter::Swapped(4),
                auto,
                "a marker",
            ),
            1,
        ),
    ];
    out!(
        results,
        "| effect (1 mm / 3 mm camera) | sessions | error vs clean | model check fails (power) | cause named right | \
         verdict not PASS | predicted / achieved, plain | widened | noncentrality | power bound, its share / the \
         whole 2 % |"
    );
    out!(results, "|---|---|---|---|---|---|---|---|---|---|");
    let (mut detected_all, mut named_all) = (0, 0);
    for (k, reference) in &effects {
        let rows = run_kind(k, &model);
        let n = rows.len();
        let flagged: Vec<&Outcome> = rows.iter().filter(|o| o.flagged).collect();
        let named = flagged.iter().filter(|o| o.cause.as_deref() == Some(k.cause)).count();
        let not_pass = rows.iter().filter(|o| o.verdict != "PASS").count();
        let cost = rms(rows.iter().map(|o| o.achieved)) / rms(clean_rows[*reference].iter().map(|o| o.achieved));
        let achieved = rms(rows.iter().map(|o| o.achieved));
        detected_all += flagged.len();
        named_all += named;
        out!(
            results,
            "| {} | {n} | {cost:.2}× | {} ({:.0} %) | {named} of {} | {not_pass} | {:.2} | {:.2} | {} |",
            k.label,
            flagged.len(),
            percent(flagged.len(), n),
            flagged.len(),
            rms(rows.iter().map(|o| o.unwidened)) / achieved,
            rms(rows.iter().map(|o| o.predicted)) / achieved,
            power_bound(&rows),
        );
    }
    out!(
        results,
        "| all detected | {detected_all} | | | {named_all} of {detected_all} ({:.0} %) | | | | | |",
        percent(named_all, detected_all)
    );
    out!(results);

    // The same effects calibrated with the defaults (`joint_scales: auto`, the clock rate fitted,
    // `platform_sag: auto`).
    let modelled = [
        (kind("joint 1 reads 1 % long", long_joint(0.01), sessions, 36_100, Alter::None, auto, ""), 1),
        (kind("clock 50 ppm fast, 10 min", clock, recordings, 36_400, Alter::None, auto, ""), 5),
        (kind("platform sags 0.25° per unit of arm", sagging(0.25), sessions, 36_100, Alter::None, auto, ""), 1),
        (kind("platform sags 0.5° per unit of arm", sagging(0.5), sessions, 36_100, Alter::None, auto, ""), 1),
        (kind("platform sags 0.75° per unit of arm", sagging(0.75), sessions, 36_100, Alter::None, auto, ""), 1),
        (kind("platform sags 1° per unit of arm", sagging(1.0), sessions, 36_100, Alter::None, auto, ""), 1),
    ];
    out!(
        results,
        "| the same, defaults (1 mm / 3 mm camera) | sessions | error vs clean | model check fails | verdict not PASS \
         | predicted / achieved |"
    );
    out!(results, "|---|---|---|---|---|---|");
    for (k, reference) in &modelled {
        let rows = run_kind(k, &model);
        let n = rows.len();
        let flagged = rows.iter().filter(|o| o.flagged).count();
        let not_pass = rows.iter().filter(|o| o.verdict != "PASS").count();
        let achieved = rms(rows.iter().map(|o| o.achieved));
        let cost = achieved / rms(clean_rows[*reference].iter().map(|o| o.achieved));
        out!(
            results,
            "| {} | {n} | {cost:.2}× | {flagged} ({:.0} %) | {not_pass} | {:.2} |",
            k.label,
            percent(flagged, n),
            rms(rows.iter().map(|o| o.predicted)) / achieved
        );
    }
    results.save();
}

/// For a row whose effect shows in one column (a joint's scale, the sag): the noncentrality `λ` of
/// its test (the mean of its F over the sessions, less 1), and the power that the best test of
/// that column, two-sided at its share of the family's rate and at the whole 2 %, has against a
/// normal shift of `√λ` standard errors: what no residual test at that rate can exceed.
fn power_bound(rows: &[Outcome]) -> String {
    let of: Vec<(f64, f64)> = rows.iter().filter_map(|o| Some((o.effect_f?, o.effect_alpha?))).collect();
    if of.is_empty() {
        return "— | —".into();
    }
    let n = of.len() as f64;
    let lambda = (of.iter().map(|(f, _)| f).sum::<f64>() / n - 1.0).max(0.0);
    let alpha = of.iter().map(|(_, a)| a).sum::<f64>() / n;
    let power = |a: f64| {
        let z = normal_quantile(1.0 - a / 2.0);
        normal_cdf(lambda.sqrt() - z) + normal_cdf(-lambda.sqrt() - z)
    };
    format!("{lambda:.1} | {:.0} % / {:.0} %", 100.0 * power(alpha), 100.0 * power(0.02))
}

/// The standard normal distribution function (Abramowitz and Stegun 7.1.26: error below 1.5e-7).
fn normal_cdf(x: f64) -> f64 {
    let z = x.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * z);
    let poly =
        t * (0.254_829_592 + t * (-0.284_496_736 + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let tail = 0.5 * poly * (-z * z).exp();
    if x >= 0.0 { 1.0 - tail } else { tail }
}

/// Its inverse, by bisection.
fn normal_quantile(p: f64) -> f64 {
    let (mut lo, mut hi) = (-10.0, 10.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if normal_cdf(mid) < p { lo = mid } else { hi = mid }
    }
    0.5 * (lo + hi)
}

fn percent(k: usize, n: usize) -> f64 {
    100.0 * k as f64 / n.max(1) as f64
}

fn rms(values: impl Iterator<Item = f64>) -> f64 {
    let v: Vec<f64> = values.filter(|v| v.is_finite()).collect();
    (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

/// Every session of `k`, simulated, altered and calibrated.
fn run_kind(k: &Kind, model: &RobotModel) -> Vec<Outcome> {
    let mut out = Vec::new();
    // A trial of some rows only: `VERDICT_ROWS=20` runs the rows whose label contains "20"
    // (`a|b`: either).
    if std::env::var("VERDICT_ROWS").is_ok_and(|only| !only.split('|').any(|o| k.label.contains(o))) {
        return out;
    }
    for s in 0..k.sessions {
        let mut c = k.config.clone();
        c.seed = k.seed0 + s;
        let (session, _) = c.simulate(model, &mut |_| {}).expect("the simulation succeeds");
        let session = alter(session, k.alter);
        match run(&session, model, c.seed, &k.settings, k.cause) {
            Ok((o, check)) => {
                if o.flagged && k.cause.is_empty() {
                    eprintln!("  false alarm: {} seed {}: {check}", k.label, c.seed);
                }
                out.push(o)
            }
            Err(e) => eprintln!("  {} seed {}: {e}", k.label, c.seed),
        }
    }
    out
}

/// `session` as `alter` makes it.
fn alter(mut session: Session, alter: Alter) -> Session {
    match alter {
        Alter::None => {}
        Alter::PerfectRig => {
            let truth = session.truth.as_ref().expect("simulated");
            session.rig = truth.rig.clone().map(Arc::new);
        }
        Alter::Triangulated(through) => {
            if through == Through::Truth {
                let rig = session.truth.as_ref().and_then(|t| t.rig.clone()).expect("a simulated pixel session");
                session = session.seen_through(&rig);
            }
            session.rig = None;
            session.poses.iter_mut().for_each(|p| p.pixels.clear());
            session.poses.retain(|p| p.seen() > 0);
        }
        Alter::Bag => {
            let path = std::env::temp_dir().join(format!("spmcal-verdict-{}.mcap", std::process::id()));
            session.write_bag(&path).expect("the bag is written");
            let (mut read, _) =
                Session::load(&path, Some(Path::new("models/agile_wrist.urdf"))).expect("the bag reads back");
            let _ = std::fs::remove_file(&path);
            read.truth = session.truth.take();
            session = read;
        }
        Alter::Swapped(every) => {
            for p in session.poses.iter_mut().filter(|p| p.id % every == 3 % every) {
                p.markers.swap(0, 1);
            }
        }
    }
    session
}

/// Calibrate `session` with `settings` and score it against the truth (where the platform really
/// is, its sag included); `cause`: the structure the row's effect
/// shows in (its one-column test's statistic is kept: joint 1's for a joint).
fn run(
    session: &Session,
    model: &RobotModel,
    seed: u64,
    settings: &CalibConfig,
    cause: &str,
) -> Result<(Outcome, String), String> {
    let truth = session.truth.as_ref().expect("simulated");
    let tests = study::test_orientations(&truth.parameters.spm().expect("valid"), 60, seed ^ 0x5eed);
    let fitted = spmcal::calib::calibrate(session, model, settings, &mut |_| {}).map_err(|e| e.to_string())?;
    let report = &fitted.report;
    let predicted = report.predicted_error_deg.as_ref().map_or(f64::NAN, |p| p.rms);
    let check = report.model_check.as_ref();
    let summary = check.map_or_else(String::new, |c| c.summary());
    let effect = check.and_then(|c| {
        let joint = cause == "joint angles";
        c.tests.iter().find(|t| t.structure == cause && t.dof[0] == 1.0 && (!joint || t.leg == Some(1)))
    });
    let outcome = Outcome {
        flagged: check.is_some_and(|c| !c.passed),
        cause: check.and_then(|c| c.cause.map(str::to_string)),
        verdict: report.verdict.label(),
        achieved: study::calibration_error_up_to_common_rotations(session, &fitted, &tests),
        predicted,
        unwidened: report.predicted_error_unwidened_deg.unwrap_or(predicted),
        effect_f: effect.map(|t| t.statistic),
        effect_alpha: effect.map(|t| t.alpha),
    };
    Ok((outcome, summary))
}
