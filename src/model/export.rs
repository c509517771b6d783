//! A calibrated URDF (`spmcal export`): the calibrated joint axes written into a copy of the
//! model's URDF, with a companion beside it (closures, markers as fitted, encoder offsets, the
//! fitted camera model) —
//! loading it gives the same forward kinematics as the parameters file.
//!
//! As in the nominal model, all joint values 0 is the home pose `R = I` and each joint axis in
//! the file is its axis in B there: the actuated axis `u`, the intermediate axis `w` at home and
//! the platform axis `v0` of each leg. The calibrated mechanism reaches home at encoder readings
//! `θ_home` (not 0 in general), so the URDF's joint value of `theta_i` is `s_i (θ_i − θ_home,i)`:
//! the companion's `encoder_scales[i] = s_i` (written when a scale is not 1) times the reading plus
//! its `encoder_offsets_deg[i] = −s_i θ_home,i`. A fitted platform sag, which no URDF term can
//! hold, is the companion's `platform_sag_deg`.

use std::collections::HashMap;

use nalgebra::Vector3;

use super::params::{CameraRecord, Parameters};
use super::urdf::{Companion, Loader, ModelError, ModelTexts, RobotModel, companion_path, parse_companion};

/// The two files of a calibrated model.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportedModel {
    /// The URDF text.
    pub urdf: String,
    /// The companion's text (`NAME.yaml` beside `NAME.urdf`).
    pub companion: String,
    /// What the caller should tell the user (the parameters' `model:` header names another URDF,
    /// whose legs and markers agree); each is also a comment in both files.
    pub warnings: Vec<String>,
}

impl ExportedModel {
    /// Write the URDF at `urdf` and its companion beside it (`NAME.yaml`), each atomically
    /// (temporary file, then rename).
    ///
    /// # Errors
    /// A [`FileError`](crate::io::FileError) naming the file that cannot be written.
    pub fn write(&self, urdf: &std::path::Path) -> Result<(), crate::io::FileError> {
        crate::io::files::write_atomic(urdf, self.urdf.as_bytes())?;
        crate::io::files::write_atomic(&companion_path(urdf), self.companion.as_bytes())
    }
}

/// The calibrated model of `params` (geometry, markers) as a URDF and companion, from `model`'s
/// URDF (its links, shapes and joint names kept); `provenance` lines go into both files as
/// comments. The parameters must belong to the model (their legs in the model's order, their fitted
/// markers the model's: see [`Parameters::check_model`], which also names the parameters file);
/// the result is checked by loading it back.
///
/// # Errors
/// A [`ModelError`] when the parameters do not belong to the model, the model's files cannot be
/// read, the parameters make no manipulator or do not reach home, or the exported model does not
/// load.
pub fn export(model: &RobotModel, params: &Parameters, provenance: &[String]) -> Result<ExportedModel, ModelError> {
    let warnings = super::consistency::check(model, params, None)?;
    // One line each, and nothing that would end an XML comment.
    let provenance: Vec<String> = provenance
        .iter()
        .chain(&warnings.iter().map(|w| format!("note: {w}")).collect::<Vec<_>>())
        .map(|l| l.replace(['\n', '\r'], " ").replace("--", "- -"))
        .collect();
    let provenance = provenance.as_slice();
    let path = &model.urdf_path;
    let unreadable = |reason: String| ModelError::Unreadable { path: path.clone(), reason };
    let texts = ModelTexts::of(path)?;
    let mut robot = urdf_rs::read_from_string(&texts.urdf).map_err(|e| unreadable(e.to_string()))?;
    let (mut companion, _) = parse_companion(&texts.companion_path, &texts.companion)?;
    let export = |reason: String| ModelError::Export { path: path.clone(), reason };
    let spm = params.spm().map_err(|e| export(format!("the parameters make no valid manipulator: {e}")))?;
    // A valid manipulator reaches home (`Spm::new` solves it): its readings and axes there.
    let home = spm.home_joints();
    let at_home = spm.intermediate_axes(&home);
    let mut axes: HashMap<&str, Vector3<f64>> = HashMap::new();
    for ((leg, names), w) in params.legs.iter().zip(&companion.legs).zip(at_home) {
        axes.insert(&names.actuated, leg.u);
        axes.insert(&names.intermediate, w);
        axes.insert(&names.platform, leg.v0);
    }
    // Each leg joint's axis in its own frame: the frame at the zero configuration is its parent
    // link's, then its origin.
    let local: Vec<Option<Vector3<f64>>> = {
        let frames = Loader { path, robot: &robot }.link_frames()?;
        robot
            .joints
            .iter()
            .map(|joint| {
                let axis = axes.get(joint.name.as_str())?;
                let frame = frames[joint.parent.link.as_str()] * super::urdf::origin_isometry(&joint.origin);
                Some(frame.rotation.inverse() * axis.normalize())
            })
            .collect()
    };
    for (joint, axis) in robot.joints.iter_mut().zip(local) {
        if let Some(a) = axis {
            joint.axis.xyz = urdf_rs::Vec3([a.x, a.y, a.z]);
        }
    }
    let fitted = params.marker_positions(companion.markers_m.keys().map(String::as_str));
    for (position, fitted) in companion.markers_m.values_mut().zip(fitted) {
        if let Some(fitted) = fitted {
            *position = fitted.into();
        }
    }
    // The joint value is `s (θ − θ_home)`: the scale carries over, the offset is `−s θ_home`.
    let scales = params.legs.map(|g| g.scale);
    companion.encoder_offsets_deg = Some([0, 1, 2].map(|i| -(scales[i] * home[i]).to_degrees()));
    companion.encoder_scales = scales.iter().any(|&s| s != 1.0).then_some(scales);
    // A URDF has no term for the sag: the companion carries it, and the model loads it back.
    companion.platform_sag_deg = (params.platform_sag_deg != 0.0).then_some(params.platform_sag_deg);
    companion.camera = (!params.camera_model.is_perfect()).then(|| CameraRecord::of(None, &params.camera_model));
    let comments: String = provenance.iter().map(|l| format!("  {l}\n")).collect();
    let body = urdf_rs::write_to_string(&robot).map_err(|e| export(format!("the URDF cannot be written: {e}")))?;
    let urdf = match body.strip_prefix("<?xml version=\"1.0\"?>") {
        Some(rest) => format!("<?xml version=\"1.0\"?>\n<!--\n{comments}-->{rest}"),
        None => format!("<!--\n{comments}-->\n{body}"),
    };
    let exported = ExportedModel { urdf, companion: companion_text(&companion, provenance), warnings };
    // Loaded back, it must be a valid model (axes through O, loops closed at home).
    let back = urdf_rs::read_from_string(&exported.urdf).map_err(|e| export(format!("the exported URDF: {e}")))?;
    let reread: Companion =
        serde_yaml::from_str(&exported.companion).map_err(|e| export(format!("the exported companion: {e}")))?;
    Loader { path, robot: &back }.build(reread)?;
    Ok(exported)
}

/// The companion as YAML, numbers with every digit.
fn companion_text(c: &Companion, provenance: &[String]) -> String {
    let mut text: String = provenance.iter().map(|l| format!("# {l}\n")).collect();
    text += "# The closures and markers of the URDF beside this file (see docs/formats.md); the URDF's\n";
    text += "# joint value of theta_i is encoder_scales[i] (1 when absent) times the encoder reading plus\n";
    text += "# encoder_offsets_deg[i].\n";
    text += &format!("platform_link: {}\nlegs:\n", c.platform_link);
    for leg in &c.legs {
        text += &format!(
            "  - {{ actuated: {}, intermediate: {}, platform: {}",
            leg.actuated, leg.intermediate, leg.platform
        );
        text += &leg.closes_on.as_ref().map_or(" }\n".to_string(), |l| format!(", closes_on: {l} }}\n"));
    }
    text += "markers_m:\n";
    for (name, p) in &c.markers_m {
        text += &format!("  {name}: [{:?}, {:?}, {:?}]\n", p[0], p[1], p[2]);
    }
    if let Some(o) = c.encoder_offsets_deg {
        text += &format!("encoder_offsets_deg: [{:?}, {:?}, {:?}]\n", o[0], o[1], o[2]);
    }
    if let Some(s) = c.encoder_scales {
        text += &format!("encoder_scales: [{:?}, {:?}, {:?}]\n", s[0], s[1], s[2]);
    }
    if let Some(sag) = c.platform_sag_deg {
        text += "# The platform's sag under its weight (no URDF term holds it): degrees per unit of the arm\n";
        text += "# n x (-z) (n the platform's axis, z the base's up), after the rigid mechanism's orientation.\n";
        text += &format!("platform_sag_deg: {sag:?}\n");
    }
    if let Some(camera) = &c.camera {
        text += "# The camera model the calibration fitted: the camera reports K x for x in its frame.\n";
        let body = serde_yaml::to_string(camera).unwrap_or_default();
        text += "camera:\n";
        text += &body.lines().map(|l| format!("  {l}\n")).collect::<String>();
    }
    text
}
