//! Does a parameters file belong to a model? Two files describe one mechanism when the
//! parameters' legs are the model's legs, in the same order, and their fitted markers are the
//! model's markers, by name.
//!
//! **Legs.** A calibration moves each axis from its nominal direction by at most the calibrate
//! config's `bounds.axis_tilt_deg` (10° by default; the gauge holds leg 1's axes at nominal), and
//! a link angle by at most `bounds.link_angle_deg` (5°). So leg `i` of the parameters matches leg
//! `i` of the model when its axes lie within [`LEG_TOLERANCE_DEG`] (20°: twice the default bound)
//! of that leg's and nearer to it than to any other leg's, and its link angles within the same
//! tolerance. The distance between two legs is the larger of the angles between their actuated
//! axes `u` and between their platform axes `v0`: the actuated axes alone cannot tell the legs of
//! a coaxial design (Orbita3d) apart, the platform axes can. The legs of every SPM are tens of
//! degrees apart (90° for the Agile Wrist, 120° between Orbita3d's platform axes), so legs in
//! another order are far beyond the tolerance and nearer to another leg.
//!
//! Each leg's home branch (the sign of `(u×w)·v` at home, which fixes the working mode) must be
//! the model's: the same axes on the other branch are another mechanism's working mode.
//!
//! **Markers.** When the parameters have fitted markers, their names and the model's are the same
//! set: a fitted marker the model lacks would be dropped, a model marker without a fitted position
//! would keep a nominal one beside fitted ones.
//!
//! **The `model:` header.** When it names another URDF than the model given, the files are used
//! together if the legs and markers agree (with a warning); if they do not, the error says so too.
//!
//! A disagreement is reported at the model's companion line of the item (`legs[1]`,
//! `markers_m.m4`, `markers_m`) and names the parameters file and its line.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use super::params::Parameters;
use super::urdf::{ModelError, RobotModel, read_companion};
use crate::io::files::{FileError, read_text, tidy_path};
use crate::io::yaml::{KeyLines, scan};

/// Largest angle (deg) between a parameters leg's axis (or link angle) and the model's leg of the
/// same number: twice the calibrate config's default bound on an axis tilt (10°), far below the
/// tens of degrees between the legs of any SPM.
pub(crate) const LEG_TOLERANCE_DEG: f64 = 20.0;

/// One of the two files, with the lines of its keys when it could be read again.
struct Located {
    path: Option<PathBuf>,
    keys: KeyLines,
}

impl Located {
    fn read(path: Option<&Path>) -> Self {
        let keys = path.and_then(|p| read_text(p).ok().and_then(|t| scan(p, &t).ok())).unwrap_or_default();
        Located { path: path.map(Path::to_path_buf), keys }
    }

    /// The file as the user named it (or "the parameters", when not known) and the line of `key`:
    /// `p.yaml (line 23, `legs[1]`)`.
    fn at(&self, key: &str) -> String {
        let name = self.path.as_ref().map_or("the parameters".to_string(), |p| p.display().to_string());
        match self.keys.nearest_line(key) {
            Some(line) => format!("{name} (line {line}, `{key}`)"),
            None => name,
        }
    }
}

fn angle_deg(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.angle(b).to_degrees()
}

/// Check that `params` (read from `file`, when known) belong to `model`; the warnings (a `model:`
/// header naming another URDF, while the geometry agrees).
pub(crate) fn check(model: &RobotModel, params: &Parameters, file: Option<&Path>) -> Result<Vec<String>, ModelError> {
    let params_file = Located::read(file);
    let companion = read_companion(&model.urdf_path).ok();
    let companion_keys = companion.as_ref().map(|(_, k, _)| k.clone()).unwrap_or_default();
    let companion_file =
        companion.as_ref().map_or_else(|| super::urdf::companion_path(&model.urdf_path), |(_, _, p)| p.clone());
    let urdf = model.urdf_path.display();
    // The same content is the same model, whatever its path or name.
    let same_content = params.model_sha256.as_deref().is_some_and(|h| h == model.sha256);
    let header = params
        .model
        .as_deref()
        .filter(|h| !same_content && !names_model(h, file, &model.urdf_path))
        .map(|h| format!("the header of {} says `model: {h}`, not {urdf}", params_file.at("model")));
    let refuse = |key: &str, reason: String| {
        let reason = match &header {
            Some(h) => format!("{reason} (also, {h})"),
            None => reason,
        };
        ModelError::File(companion_keys.error(&companion_file, key, reason))
    };

    // Markers, by name, in one pass each way (a rigid body's frame, fitted from a tracker's
    // poses, is no marker of the model: an export leaves it out).
    if params.markers.iter().any(|m| m.rotation.is_none()) {
        let in_model: HashSet<&str> = model.markers.iter().map(|m| m.name.as_str()).collect();
        let unknown = |m: &super::MarkerPosition| m.rotation.is_none() && !in_model.contains(m.name.as_str());
        if let Some(k) = params.markers.iter().position(unknown) {
            let reason = format!(
                "{urdf} has no marker `{}`, which {} fitted: the parameters belong to another model, or a marker \
                 was renamed; exported, the fitted marker would be lost",
                params.markers[k].name,
                params_file.at(&format!("markers[{k}].name")),
            );
            return Err(refuse("markers_m", reason));
        }
        let fitted: HashSet<&str> = params.markers.iter().map(|m| m.name.as_str()).collect();
        if let Some(m) = model.markers.iter().find(|m| !fitted.contains(m.name.as_str())) {
            let reason = format!(
                "marker `{}` of {urdf} is not among the {} markers {} fitted: the parameters belong to another \
                 model, or a marker was renamed",
                m.name,
                params.markers.len(),
                params_file.at("markers"),
            );
            return Err(refuse(&format!("markers_m.{}", m.name), reason));
        }
    }

    // Legs, in order.
    let nominal = model.spm.geometry();
    let distance = |i: usize, j: usize| {
        let (p, m) = (&params.legs[i], &nominal[j]);
        angle_deg(&p.u, &m.u).max(angle_deg(&p.v0, &m.v0))
    };
    let joints = |i: usize| {
        companion.as_ref().map_or(String::new(), |(c, _, _)| {
            let l = &c.legs[i];
            format!(" (joints `{}`, `{}`, `{}`)", l.actuated, l.intermediate, l.platform)
        })
    };
    for (i, (theirs_leg, ours)) in params.legs.iter().zip(nominal).enumerate() {
        let own = distance(i, i);
        let nearest = (0..3).filter(|&j| j != i).map(|j| (j, distance(i, j))).min_by(|a, b| a.1.total_cmp(&b.1));
        let leg = format!("leg {} of {urdf}{}", i + 1, joints(i));
        let theirs = params_file.at(&format!("legs[{i}]"));
        if let Some((j, other)) = nearest
            && other <= own
        {
            let reason = format!(
                "{leg} does not match leg {} of {theirs}: that leg's axes are {own:.1}° from this one's but \
                 {other:.1}° from the model's leg {}{}: are the legs in another order?",
                i + 1,
                j + 1,
                joints(j)
            );
            return Err(refuse(&format!("legs[{i}]"), reason));
        }
        if own.is_nan() || own > LEG_TOLERANCE_DEG {
            let reason = format!(
                "{leg} does not match leg {} of {theirs}: their axes are {own:.1}° apart, beyond the \
                 {LEG_TOLERANCE_DEG}° a calibration may move an axis: the parameters belong to another model",
                i + 1
            );
            return Err(refuse(&format!("legs[{i}]"), reason));
        }
        for (what, p, m) in [("alpha1", theirs_leg.alpha1, ours.alpha1), ("alpha2", theirs_leg.alpha2, ours.alpha2)] {
            let apart = (p - m).abs().to_degrees();
            if apart.is_nan() || apart > LEG_TOLERANCE_DEG {
                let reason = format!(
                    "{leg} has {what} = {:.3}°, {} has {:.3}°: {apart:.1}° apart, beyond the {LEG_TOLERANCE_DEG}° \
                     a calibration may move a link angle: the parameters belong to another model",
                    m.to_degrees(),
                    params_file.at(&format!("legs[{i}].{what}_deg")),
                    p.to_degrees(),
                );
                return Err(refuse(&format!("legs[{i}]"), reason));
            }
        }
        if theirs_leg.home_branch != ours.home_branch {
            let reason = format!(
                "{leg} is on the {} branch at home, {} says {}: the two describe different working modes                  (a parameters file without `home_branch` reads as negative)",
                ours.home_branch,
                params_file.at(&format!("legs[{i}].home_branch")),
                theirs_leg.home_branch,
            );
            return Err(refuse(&format!("legs[{i}]"), reason));
        }
    }
    Ok(header.map(|h| format!("{h}; its legs and markers agree with {urdf}, which is used")).into_iter().collect())
}

/// Whether the `model:` header `header` names the URDF `urdf`: as a path from the working folder
/// or from the parameters file's folder, compared by their real paths (links resolved), else as
/// written.
fn names_model(header: &str, file: Option<&Path>, urdf: &Path) -> bool {
    let header = Path::new(header);
    let mut candidates = vec![header.to_path_buf()];
    if let Some(dir) = file.and_then(Path::parent).filter(|_| header.is_relative()) {
        candidates.push(dir.join(header));
    }
    match urdf.canonicalize() {
        Ok(real) => candidates.iter().any(|c| c.canonicalize().is_ok_and(|c| c == real)),
        Err(_) => candidates.iter().any(|c| tidy_path(c) == tidy_path(urdf)),
    }
}

impl Parameters {
    /// Check that these parameters, read from `file`, belong to `model`: their legs are the
    /// model's legs in the same order (each within 20° of the model's leg of its number, and
    /// nearer to it than to any other), and their fitted markers, when they have any, are the
    /// model's markers by name. `Ok` holds the warnings: the file's `model:` header naming another
    /// URDF than `model`'s while the geometry agrees.
    ///
    /// # Errors
    /// A [`ModelError::File`] located at the model companion's line of the leg or marker that
    /// disagrees, naming the parameters file and its line.
    pub fn check_model(&self, file: &Path, model: &RobotModel) -> Result<Vec<String>, ModelError> {
        check(model, self, Some(file))
    }
}

impl Parameters {
    /// Write the file atomically, its model named as [`Parameters::to_yaml_at`] names it.
    ///
    /// # Errors
    /// A [`FileError`] when the file cannot be written; an existing file is then left unchanged.
    pub fn write(&self, path: &Path) -> Result<(), FileError> {
        crate::io::files::write_atomic(path, self.to_yaml_at(path).as_bytes())
    }

    /// The file text as written at `path`: [`Parameters::to_yaml`] with the model named as a file
    /// there names it — a shipped model by its name (also when loaded from a copy of its files), a
    /// URDF by its path relative to `path`'s folder (absolute when they share no folder but the
    /// root, or when it was given absolute).
    pub fn to_yaml_at(&self, path: &Path) -> String {
        let folder = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let model = self.model.as_ref().map(|m| super::urdf::reference_from(folder, Path::new(m)));
        Parameters { model: model.map(|m| m.display().to_string()), ..self.clone() }.to_yaml()
    }

    /// The model these parameters (read from `file`) are used with, and the warnings: `given`
    /// (`--model`) when there is one, else the model the file names (`model:`, a shipped model's
    /// name or a path relative to the file), else the default model (`agile_wrist`); then
    /// [`Parameters::check_model`].
    ///
    /// The file's `model_sha256` is the identity of the model it was made with. When the model it
    /// names cannot be found (a file copied to another machine), the shipped model of that
    /// identity is used; else the error says that the path came from the file and that `--model`
    /// gives the model. A model found under the file's name whose content is not that identity is
    /// refused (the file was made with another version of it), unless given explicitly; a `given`
    /// model of another identity is used with a warning, since the user chose it.
    ///
    /// # Errors
    /// A [`ModelError`] when the model cannot be loaded, has changed, or does not fit the
    /// parameters.
    pub fn load_model(&self, file: &Path, given: Option<&Path>) -> Result<(RobotModel, Vec<String>), ModelError> {
        let located = Located::read(Some(file));
        let at = |key: &str| {
            let err = FileError::new(file, String::new());
            match located.keys.nearest_line(key) {
                Some(line) => err.at_line(line),
                None => err,
            }
        };
        let short = |h: &str| h.chars().take(12).collect::<String>();
        let mut warnings = Vec::new();
        let model = match (given, self.model.as_deref()) {
            (Some(path), _) => {
                let model = RobotModel::load(path)?;
                if let Some(h) = self.model_sha256.as_deref().filter(|h| *h != model.sha256) {
                    warnings.push(format!(
                        "{}: these parameters were made with a model of identity {}… (`model_sha256`), not the \
                                 --model {} given (identity {}…): used as asked",
                        file.display(),
                        short(h),
                        path.display(),
                        short(&model.sha256)
                    ));
                }
                model
            }
            (None, None) => RobotModel::load(Path::new(super::shipped::DEFAULT_MODEL))?,
            (None, Some(named)) => match RobotModel::load(Path::new(named)) {
                Ok(model) => {
                    if let Some(h) = self.model_sha256.as_deref().filter(|h| *h != model.sha256) {
                        return Err(ModelError::File(FileError {
                            reason: format!(
                                "the model `{named}` this file names has changed since these parameters were made: \
                                 its identity is {}… where `model_sha256` says {}…; give the model they were made \
                                 with, or pass --model {named} to use this one anyway",
                                short(&model.sha256),
                                short(h)
                            ),
                            ..at("model_sha256")
                        }));
                    }
                    model
                }
                Err(e) => match self.model_sha256.as_deref().and_then(super::shipped::with_sha256) {
                    Some(shipped) => RobotModel::load(Path::new(shipped.name))?,
                    None => {
                        return Err(ModelError::File(FileError {
                            reason: format!(
                                "the model `{named}` named by this parameters file (its `model:`) cannot be loaded \
                                 ({e}); give the model with --model (Python: urdf=), a URDF's path or a shipped model's name ({})",
                                super::shipped::listed()
                            ),
                            ..at("model")
                        }));
                    }
                },
            },
        };
        warnings.extend(self.check_model(file, &model)?);
        Ok((model, warnings))
    }

    /// The model [`Parameters::load_model`] tries first: `given`, else the file's `model:`, else
    /// the default model's name.
    pub fn model_reference(&self, given: Option<&Path>) -> PathBuf {
        given
            .map(Path::to_path_buf)
            .or_else(|| self.model.as_ref().map(PathBuf::from))
            .unwrap_or_else(|| PathBuf::from(super::shipped::DEFAULT_MODEL))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{LegGeometry, Spm};

    /// A coaxial design (Orbita3d-like: one actuated axis for all legs, α1 = 126°): the legs
    /// differ only by their platform axes, and legs in another order are still found.
    #[test]
    fn coaxial_legs_are_told_apart_by_their_platform_axes() {
        let alpha1 = 126f64.to_radians();
        let (a, c) = (alpha1.sin() * 0.5, -alpha1.cos());
        let legs = [0, 1, 2].map(|i| {
            let eta = 2.0 * std::f64::consts::PI * i as f64 / 3.0;
            let phi = eta + 2.0 * std::f64::consts::FRAC_PI_3;
            // v0 ⟂ w(0) = (sin α1 cos η, sin α1 sin η, −cos α1), out of the plane of u and w.
            let v0 = Vector3::new(c * phi.cos(), c * phi.sin(), a).normalize();
            LegGeometry {
                u: Vector3::new(0.0, 0.0, 1.0).scale(-1.0),
                z: Vector3::new(eta.cos(), eta.sin(), 0.0),
                alpha1,
                alpha2: std::f64::consts::FRAC_PI_2,
                v0,
                delta: 0.0,
                scale: 1.0,
                home_branch: crate::model::HomeBranch::Negative,
            }
        });
        let spm = Spm::new(legs).unwrap();
        let model = RobotModel {
            name: "coaxial".into(),
            urdf_path: PathBuf::from("no/such/coaxial.urdf"),
            spm: spm.clone(),
            markers: Vec::new(),
            shapes: Vec::new(),
            camera_model: crate::model::CameraModel::rigid(),
            sha256: String::new(),
        };
        let params = Parameters::nominal(&spm, None);
        assert!(check(&model, &params, None).unwrap().is_empty());
        let mut swapped = params.clone();
        swapped.legs.swap(0, 2);
        let text = check(&model, &swapped, None).unwrap_err().to_string();
        assert!(text.contains("leg 1 of") && text.contains("another order"), "{text}");
    }

    #[test]
    fn a_header_names_the_model_from_either_folder() {
        let urdf = Path::new("models/agile_wrist.urdf");
        assert!(names_model("models/agile_wrist.urdf", None, urdf));
        assert!(names_model("./models/../models/agile_wrist.urdf", None, urdf));
        assert!(names_model("../models/agile_wrist.urdf", Some(Path::new("configs/p.yaml")), urdf));
        assert!(!names_model("models/other.urdf", Some(Path::new("configs/p.yaml")), urdf));
        assert!(!names_model("agile_wrist.urdf", None, urdf));
    }
}
