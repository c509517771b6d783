//! A parameters file and a model must describe one mechanism (issue 19): the export refuses
//! parameters whose legs are in another order or whose fitted markers are not the model's, names
//! both files and the item, and warns when only the `model:` header differs. And every number of
//! the parameters file and the companion is checked at load and reported at its own line.

use std::path::{Path, PathBuf};

use nalgebra::{Rotation3, Vector3};
use spmcal::model::{MarkerPosition, Parameters, RobotModel, export};

const URDF: &str = "models/agile_wrist.urdf";
const FITTED: &str = "tests/data/golden/calibrate_markers_free_motion_120s.params.yaml";

fn model() -> RobotModel {
    RobotModel::load(Path::new(URDF)).unwrap()
}

/// The line of the `nth` (0-based) line of the fitted parameters file that starts with `prefix`.
fn fitted_line(prefix: &str, nth: usize) -> usize {
    let text = std::fs::read_to_string(FITTED).unwrap();
    1 + text.lines().enumerate().filter(|(_, l)| l.starts_with(prefix)).nth(nth).unwrap().0
}

fn fitted() -> Parameters {
    Parameters::read(Path::new(FITTED)).unwrap()
}

/// The shipped model copied to `dir` as `m.urdf` with its companion edited.
fn model_copy(dir: &Path, from: &str, to: &str) -> PathBuf {
    let companion = std::fs::read_to_string("models/agile_wrist.yaml").unwrap();
    assert!(companion.contains(from), "{from}");
    let urdf = dir.join("m.urdf");
    std::fs::copy(URDF, &urdf).unwrap();
    std::fs::write(dir.join("m.yaml"), companion.replacen(from, to, 1)).unwrap();
    urdf
}

fn written(dir: &Path, params: &Parameters) -> PathBuf {
    let path = dir.join("p.yaml");
    std::fs::write(&path, params.to_yaml()).unwrap();
    path
}

#[test]
fn parameters_of_the_model_agree_and_export() {
    let (model, params) = (model(), fitted());
    assert_eq!(params.check_model(Path::new(FITTED), &model).unwrap(), Vec::<String>::new());
    let exported = export(&model, &params, &[]).unwrap();
    assert!(exported.warnings.is_empty(), "{:?}", exported.warnings);
    // Nominal parameters carry no markers: any model's markers are fine.
    let nominal = Parameters::nominal(&model.spm, None);
    assert!(export(&model, &nominal, &[]).is_ok());
}

#[test]
fn legs_in_another_order_are_refused_naming_both_files_and_the_legs() {
    let dir = tempfile::tempdir().unwrap();
    let model = model();
    // The parameters' legs 2 and 3 swapped.
    let mut params = fitted();
    params.legs.swap(1, 2);
    let file = written(dir.path(), &params);
    let text = params.check_model(&file, &model).unwrap_err().to_string();
    // The line of the second leg record (`legs[1]`).
    let second_leg = {
        let text = std::fs::read_to_string(&file).unwrap();
        1 + text.lines().enumerate().filter(|(_, l)| l.starts_with("- u:")).nth(1).unwrap().0
    };
    assert!(
        text.starts_with("models/agile_wrist.yaml:13: column `legs[1]`: leg 2 of models/agile_wrist.urdf"),
        "{text}"
    );
    assert!(text.contains(&format!("{} (line {}, `legs[1]`)", file.display(), second_leg)), "{text}");
    assert!(text.contains("model's leg 3") && text.contains("another order"), "{text}");
    let text = export(&model, &params, &[]).unwrap_err().to_string();
    assert!(text.contains("leg 2 of the parameters") && text.contains("another order"), "{text}");

    // The model's legs 2 and 3 in the other order (a valid model): leg 3's axis must not go onto
    // leg 2's links.
    let swapped = model_copy(
        dir.path(),
        "  - { actuated: theta2, intermediate: elbow2, platform: wrist2, closes_on: platform_closure2 }\n  \
         - { actuated: theta3, intermediate: elbow3, platform: wrist3, closes_on: platform_closure3 }",
        "  - { actuated: theta3, intermediate: elbow3, platform: wrist3, closes_on: platform_closure3 }\n  \
         - { actuated: theta2, intermediate: elbow2, platform: wrist2, closes_on: platform_closure2 }",
    );
    let other = RobotModel::load(&swapped).unwrap();
    let text = fitted().check_model(Path::new(FITTED), &other).unwrap_err().to_string();
    assert!(text.contains("m.yaml:13: column `legs[1]`") && text.contains("(joints `theta3`"), "{text}");
    assert!(text.contains(&format!("{FITTED} (line {}, `legs[1]`)", fitted_line("- u:", 1))), "{text}");
    // The header names the shipped model, and the geometry disagrees: both said.
    assert!(text.contains("also, the header of") && text.contains("`model: agile_wrist`"), "{text}");
    assert!(export(&other, &fitted(), &[]).is_err());
}

#[test]
fn markers_must_be_the_models_by_name() {
    let dir = tempfile::tempdir().unwrap();
    // A fitted marker the model lacks.
    let renamed = RobotModel::load(&model_copy(dir.path(), "  m4:", "  column:")).unwrap();
    let text = fitted().check_model(Path::new(FITTED), &renamed).unwrap_err().to_string();
    assert!(text.contains("m.yaml:15: column `markers_m`") && text.contains("no marker `m4`"), "{text}");
    assert!(text.contains(&format!("{FITTED} (line {}, `markers[3].name`)", fitted_line("- name:", 3))), "{text}");
    let text = export(&renamed, &fitted(), &[]).unwrap_err().to_string();
    assert!(text.contains("no marker `m4`") && text.contains("would be lost"), "{text}");

    // A model marker the parameters do not know.
    let dir = tempfile::tempdir().unwrap();
    let extra = RobotModel::load(&model_copy(
        dir.path(),
        "  m4: [0.0, 0.0, 0.22]",
        "  m4: [0.0, 0.0, 0.22]\n  m5: [0.02, 0.0, 0.1]",
    ))
    .unwrap();
    let text = fitted().check_model(Path::new(FITTED), &extra).unwrap_err().to_string();
    assert!(text.contains("m.yaml:20: column `markers_m.m5`: marker `m5`"), "{text}");
    assert!(
        text.contains(&format!("the 4 markers {FITTED} (line {}, `markers`) fitted", fitted_line("markers:", 0))),
        "{text}"
    );

    // A parameter set with the model's markers only in part.
    let mut partial = fitted();
    partial.markers.retain(|m| m.name != "m2");
    assert!(export(&model(), &partial, &[]).unwrap_err().to_string().contains("marker `m2`"));
}

#[test]
fn another_models_header_with_the_same_geometry_is_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    // Another model's content (one comment more: another identity), the same geometry.
    let copy = RobotModel::load(&model_copy(dir.path(), "legs:", "legs: # our copy")).unwrap();
    let warnings = fitted().check_model(Path::new(FITTED), &copy).unwrap();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(warnings[0].contains(&format!("{FITTED} (line {}, `model`)", fitted_line("model:", 0))), "{warnings:?}");
    assert!(warnings[0].contains("agree") && warnings[0].contains("m.urdf"), "{warnings:?}");
    let exported = export(&copy, &fitted(), &[]).unwrap();
    assert_eq!(exported.warnings.len(), 1);
    assert!(exported.urdf.contains("note: the header of the parameters says"), "{}", exported.urdf);
    assert!(exported.companion.contains("# note: the header of the parameters says"));
    // A header relative to the parameters file's folder names the same model.
    let mut params = fitted();
    params.model = Some("m.urdf".into());
    let file = written(dir.path(), &params);
    assert!(params.check_model(&file, &copy).unwrap().is_empty());
}

/// Leg `leg`'s axes turned by `angle_deg` about the axis `about` (its geometry stays a leg).
fn turned(params: &Parameters, leg: usize, about: Vector3<f64>, angle_deg: f64) -> Parameters {
    let r = Rotation3::new(about.normalize() * angle_deg.to_radians());
    let mut p = params.clone();
    let g = &mut p.legs[leg];
    (g.u, g.z, g.v0) = (r * g.u, r * g.z, r * g.v0);
    p
}

#[test]
fn a_leg_matches_within_the_tolerance_and_nearer_than_any_other() {
    let (model, params) = (model(), Parameters::nominal(&model().spm, Some(URDF.into())));
    let file = Path::new("p.yaml"); // not written: the messages have no lines
    let up = Vector3::new(0.3, -0.2, 1.0);
    // 15° (beyond any calibration bound's default, within the 20° tolerance): accepted.
    assert!(turned(&params, 2, up, 15.0).check_model(file, &model).is_ok());
    // 25°: beyond the tolerance, though still nearest its own leg.
    let text = turned(&params, 2, up, 25.0).check_model(file, &model).unwrap_err().to_string();
    assert!(text.contains("leg 3") && text.contains("beyond the 20°"), "{text}");
    // A link angle 30° off.
    let mut far = params.clone();
    far.legs[1].alpha2 += 30f64.to_radians();
    let text = far.check_model(file, &model).unwrap_err().to_string();
    assert!(text.contains("alpha2") && text.contains("30.0° apart"), "{text}");
}

#[test]
fn every_number_of_the_parameters_file_is_reported_at_its_own_line() {
    let dir = tempfile::tempdir().unwrap();
    let mut params = fitted();
    // A projective camera: every camera term and its standard error is a number of the file.
    let terms = [1.002, 0.999, 0.001, -0.002, 0.003, 0.01, -0.02, 0.03];
    params.camera_model = spmcal::model::CameraModelKind::Projective
        .terms()
        .iter()
        .zip(terms)
        .fold(spmcal::model::CameraModel::perfect(spmcal::model::CameraModelKind::Projective), |m, (t, v)| {
            m.with(*t, v, Some(0.0004))
        });
    params.markers.push(MarkerPosition {
        name: "m5".into(),
        position: Vector3::new(0.01, 0.02, 0.03),
        std_error: None,
        rotation: None,
        rotation_std_error: None,
    });
    let good = params.to_yaml();
    let path = dir.path().join("p.yaml");
    let lines: Vec<&str> = good.lines().collect();
    let fit = lines.iter().position(|l| l.starts_with("fit:")).unwrap();
    let mut checked = 0;
    let mut key_line = 0;
    for (k, line) in lines[..fit].iter().enumerate() {
        let (head, value) = match line.rsplit_once(' ') {
            Some((head, value)) if value.parse::<f64>().is_ok() => (head, value),
            _ => {
                if line.trim_end().ends_with(':') {
                    key_line = k + 1;
                }
                continue;
            }
        };
        let component = head.trim_start().starts_with('-');
        // NaN: at the value's own line, a vector's component included.
        let nan: Vec<String> = lines
            .iter()
            .enumerate()
            .map(|(j, l)| if j == k { format!("{head} .nan") } else { l.to_string() })
            .collect();
        std::fs::write(&path, nan.join("\n")).unwrap();
        let err = Parameters::read(&path).expect_err(line);
        assert_eq!(err.line, Some(k + 1), "{line} → .nan: {err}");
        // Far out of range: scalars at their line, a vector (a norm) at its key's line. A standard
        // error has no upper bound (a poorly determined term's may exceed any bound on the value):
        // a negative one is out of its range.
        let std_error = head.contains("std_error") || lines[key_line - 1].contains("std_error");
        let huge = match (std_error, value.starts_with('-')) {
            (true, _) => "-1.0",
            (false, true) => "-1.0e6",
            (false, false) => "1.0e6",
        };
        let far: Vec<String> = lines
            .iter()
            .enumerate()
            .map(|(j, l)| if j == k { format!("{head} {huge}") } else { l.to_string() })
            .collect();
        std::fs::write(&path, far.join("\n")).unwrap();
        let err = Parameters::read(&path).expect_err(line);
        // A standard error is checked per axis, at its own line.
        let per_axis = lines[key_line - 1].contains("std_error_m");
        let expected = if component && !per_axis { key_line } else { k + 1 };
        assert_eq!(err.line, Some(expected), "{line} → {huge}: {err}");
        checked += 1;
    }
    // 3 legs × 12, the camera's 7 and its projective model's 8 terms with their standard errors,
    // 5 markers' positions and 4 standard errors, the latency and the clock rate.
    assert_eq!(checked, 36 + 7 + 16 + 15 + 12 + 1 + 1);
}

#[test]
fn every_number_of_the_companion_is_reported_at_its_own_line() {
    let dir = tempfile::tempdir().unwrap();
    let companion = "platform_link: platform\nlegs:\n  - { actuated: theta1, intermediate: elbow1, platform: wrist1 }\n  \
        - { actuated: theta2, intermediate: elbow2, platform: wrist2, closes_on: platform_closure2 }\n  \
        - { actuated: theta3, intermediate: elbow3, platform: wrist3, closes_on: platform_closure3 }\n\
        markers_m:\n  m1:\n    - 0.0\n    - 0.075\n    - 0.06\n  m2: [-0.0649519053, -0.0375, 0.06]\n  \
        m3: [0.0649519053, -0.0375, 0.06]\n  m4: [0.0, 0.0, 0.22]\nencoder_offsets_deg:\n  - 1.5\n  - -2.0\n  - 0.25\n";
    let urdf = dir.path().join("m.urdf");
    std::fs::copy(URDF, &urdf).unwrap();
    let lines: Vec<&str> = companion.lines().collect();
    std::fs::write(dir.path().join("m.yaml"), companion).unwrap();
    RobotModel::load(&urdf).unwrap();
    let mut checked = 0;
    for (k, line) in lines.iter().enumerate() {
        let Some((head, value)) = line.rsplit_once(' ') else { continue };
        if value.parse::<f64>().is_err() {
            continue;
        }
        for bad in [".nan", "1.0e4"] {
            let edited: Vec<String> = lines
                .iter()
                .enumerate()
                .map(|(j, l)| if j == k { format!("{head} {bad}") } else { l.to_string() })
                .collect();
            std::fs::write(dir.path().join("m.yaml"), edited.join("\n")).unwrap();
            let text = RobotModel::load(&urdf).expect_err(line).to_string();
            // A marker's norm is checked at its key (line 7 for m1); everything else at its own line.
            let at = if bad != ".nan" && (8..=10).contains(&(k + 1)) { 7 } else { k + 1 };
            assert!(text.contains(&format!("m.yaml:{at}: ")), "{line} → {bad}: {text}");
        }
        checked += 1;
    }
    assert_eq!(checked, 6);
    // Flow sequences: the whole sequence is on its line.
    let text = {
        let edited = companion.replace("m2: [-0.0649519053, -0.0375, 0.06]", "m2: [-0.0649519053, .inf, 0.06]");
        std::fs::write(dir.path().join("m.yaml"), edited).unwrap();
        RobotModel::load(&urdf).unwrap_err().to_string()
    };
    assert!(text.contains("m.yaml:11: column `markers_m.m2[1]`"), "{text}");
}

/// A URDF with `n` more links in one chain from the base, listed tip first, written to its own
/// folder (with the shipped companion) as `m.urdf`.
fn long_chain(n: usize) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let urdf = std::fs::read_to_string(URDF).unwrap();
    let mut chain = String::new();
    for i in 0..n {
        chain.push_str(&format!("  <link name=\"extra{i}\"/>\n"));
    }
    for i in (0..n).rev() {
        let parent = if i == 0 { "base_link".to_string() } else { format!("extra{}", i - 1) };
        chain.push_str(&format!(
            "  <joint name=\"extra_joint{i}\" type=\"fixed\"><parent link=\"{parent}\"/><child link=\"extra{i}\"/></joint>\n"
        ));
    }
    let at = urdf.rfind("</robot>").unwrap();
    let path = dir.path().join("m.urdf");
    std::fs::write(&path, format!("{}{chain}{}", &urdf[..at], &urdf[at..])).unwrap();
    std::fs::copy("models/agile_wrist.yaml", dir.path().join("m.yaml")).unwrap();
    (dir, path)
}

/// The shortest of `runs` loads of `path` (the least disturbed by other work on the machine).
fn load_time(path: &Path, runs: usize) -> std::time::Duration {
    (0..runs)
        .map(|_| {
            let started = std::time::Instant::now();
            let model = RobotModel::load(path).unwrap();
            let elapsed = started.elapsed();
            assert_eq!(model.markers.len(), 4);
            elapsed
        })
        .min()
        .unwrap()
}

/// Four times the chain, at most this many times the time: a linear walk takes 4× (less with
/// the fixed cost of the rest of the file), a quadratic one 16×, and 8× lies a factor of two from
/// each. Measured (release, 2 cores shared with other builds, best of 3–5 loads): 6,250 to
/// 100,000 links in 0.13, 0.31, 0.43, 1.04 and 2.55 s (each doubling 1.4–2.4×); 10,000 →
/// 40,000 in five runs: 3.4, 3.8, 3.9, 4.3, 5.2×; four loads timed as one (16× work) read 13×.
const MOST_GROWTH: f64 = 8.0;

/// A ceiling on the longer chain's load: 40,000 links load in 0.8–1.5 s here; a quadratic walk
/// took minutes at 50,000.
const CEILING_S: u64 = 10;

/// A URDF with 10,000 and then 40,000 more links in one chain from the base, listed tip first:
/// loading it walks the tree once (it took time quadratic in the chain's length). The time must
/// grow at most `MOST_GROWTH`-fold from one to the other, and the longer chain load within
/// `CEILING_S`.
#[test]
fn a_long_chain_of_links_loads_in_linear_time() {
    let n = 10_000;
    let ((_short_dir, short), (_long_dir, long)) = (long_chain(n), long_chain(4 * n));
    // Warm the file cache and the allocator once, then the best of three of each.
    load_time(&short, 1);
    let (at_n, at_4n) = (load_time(&short, 3), load_time(&long, 3));
    let growth = at_4n.as_secs_f64() / at_n.as_secs_f64();
    eprintln!("{n} extra links loaded in {at_n:?}, {} in {at_4n:?}: {growth:.2}×", 4 * n);
    assert!(growth < MOST_GROWTH, "{} links took {growth:.2}× the time of {n}: not linear", 4 * n);
    assert!(at_4n < std::time::Duration::from_secs(CEILING_S), "{} links took {at_4n:?}", 4 * n);
}
