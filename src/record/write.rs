//! A [`Scene`] written as one `.rrd` recording: the default layout (blueprint), then every entity
//! (`draw`).

use std::path::Path;

use rerun::blueprint::{
    Blueprint, BlueprintActivation, BlueprintPanel, Horizontal, SelectionPanel, Spatial2DView, Spatial3DView, Tabs,
    TextDocumentView, TimePanel, TimeSeriesView, Vertical,
};

use super::draw;
use super::scene::{APPLICATION, FIT_TABLE, RecordError, RecordingSummary, Scene};

impl Scene<'_> {
    /// Write `scene` to `path` (atomically: a temporary file beside it, renamed when complete).
    ///
    /// # Errors
    /// The destination cannot be written, or Rerun refuses to log an entity.
    pub fn write(&self, path: &Path) -> Result<RecordingSummary, RecordError> {
        let scene = self;
        let create = |e: crate::io::FileError| RecordError::Create { path: path.to_path_buf(), reason: e.reason };
        let file = crate::io::StagedFile::create(path).map_err(create)?;
        let summary = scene.write_staged(file.temp_path(), path)?;
        file.commit().map_err(create)?;
        Ok(summary)
    }

    /// Write `scene` into the file `tmp`, which the caller puts in place as `destination` (e.g. a
    /// [`crate::io::StagedFile`] written together with other outputs); errors and the summary name
    /// `destination`.
    ///
    /// # Errors
    /// `tmp` cannot be written, or Rerun refuses to log an entity.
    pub fn write_staged(&self, tmp: &Path, destination: &Path) -> Result<RecordingSummary, RecordError> {
        let scene = self;
        let path = destination;
        let create = |reason: String| RecordError::Create { path: path.to_path_buf(), reason };
        let rec = rerun::RecordingStreamBuilder::new(APPLICATION).save(tmp).map_err(|e| create(e.to_string()))?;
        let mut logger = draw::Logger { rec: &rec, path };
        send_blueprint(&rec, scene).map_err(|e| create(e.to_string()))?;
        logger.scene(scene)?;
        rec.flush_blocking().map_err(|e| create(e.to_string()))?;
        drop(rec);
        let bytes = std::fs::metadata(tmp).map_or(0, |m| m.len());
        Ok(RecordingSummary { path: path.to_path_buf(), poses: scene.session.poses.len(), bytes })
    }
}

/// The default layout: the 3-D scene beside the plots — FDA-vs-vision angles (degrees), marker
/// errors (mm), `e_j` (dimensionless, so on its own axes), a plan's predicted errors — and tabs of
/// documents: the fit's iterations and the parameter sets (a text view shows one document). Only
/// panels with data are laid out, so the viewer opens with none empty; the fit's plots live on
/// the `iteration` timeline (the time panel shows `pose`, or `time` for a free-motion recording),
/// so the layout shows the fit as a table, which needs no timeline. The 3-D
/// view leaves out the camera (0.8 m away, it would shrink the wrist to a few pixels).
fn send_blueprint(rec: &rerun::RecordingStream, scene: &Scene) -> rerun::RecordingStreamResult<()> {
    let has = |prefix: &str| scene.series.iter().any(|s| s.name == prefix || s.name.starts_with(&format!("{prefix}/")));
    let mut panels: Vec<rerun::blueprint::ContainerLike> = Vec::new();
    if has("fda_vs_vision") {
        panels.push(TimeSeriesView::new("FDA vs vision (deg)").with_origin("errors/fda_vs_vision").into());
    }
    if has("markers_mm") {
        panels.push(
            TimeSeriesView::new("FDA vs camera, per pose (mm RMS over its markers)")
                .with_origin("errors/markers_mm")
                .into(),
        );
    }
    if has("marker_residuals_mm") {
        panels.push(
            TimeSeriesView::new("calibrated residual per marker (mm)").with_origin("errors/marker_residuals_mm").into(),
        );
    }
    if has("pixels_px") {
        panels.push(
            TimeSeriesView::new("FDA vs cameras, per pose (px RMS over its pixels)")
                .with_origin("errors/pixels_px")
                .into(),
        );
    }
    if has("pixel_residuals_px") {
        panels.push(
            TimeSeriesView::new("calibrated residual per marker (px)").with_origin("errors/pixel_residuals_px").into(),
        );
    }
    if has("e_j") {
        panels.push(TimeSeriesView::new("e_j").with_origin("errors/e_j").into());
    }
    if has("predicted_error_deg") {
        panels.push(
            TimeSeriesView::new("predicted orientation error after calibration (deg)")
                .with_origin("errors/predicted_error_deg")
                .into(),
        );
    }
    if has("predicted_error_mm") {
        panels.push(
            TimeSeriesView::new("predicted marker error after calibration (mm)")
                .with_origin("errors/predicted_error_mm")
                .into(),
        );
    }
    if has("predicted_error_px") {
        panels.push(
            TimeSeriesView::new("predicted pixel error after calibration (px)")
                .with_origin("errors/predicted_error_px")
                .into(),
        );
    }
    let mut documents: Vec<rerun::blueprint::ContainerLike> = Vec::new();
    if !scene.iterations.is_empty() {
        documents.push(TextDocumentView::new("fit").with_origin(FIT_TABLE).into());
    }
    documents.extend(
        scene
            .documents
            .iter()
            .map(|(name, _)| TextDocumentView::new(name.as_str()).with_origin(format!("parameters/{name}")).into()),
    );
    if !documents.is_empty() {
        panels.push(Tabs::new(documents).into());
    }
    let mechanism = Spatial3DView::new("mechanism")
        .with_origin("world")
        .with_contents(["$origin/**", "- $origin/camera/**"])
        .into();
    // A pixel session: each camera's image plane (its measured and predicted pixels) below the
    // 3-D view.
    let images: Vec<rerun::blueprint::ContainerLike> = scene
        .image_planes
        .iter()
        .flat_map(|planes| &planes.rig.cameras)
        .map(|c| Spatial2DView::new(format!("{} (px)", c.name)).with_origin(draw::image_plane(&c.name)).into())
        .collect();
    let mechanism =
        if images.is_empty() { mechanism } else { Vertical::new([mechanism, Horizontal::new(images).into()]).into() };
    let layout: rerun::blueprint::ContainerLike =
        if panels.is_empty() { mechanism } else { Horizontal::new([mechanism, Vertical::new(panels).into()]).into() };
    // The side panels start collapsed: the first look is at the data (a click opens them).
    let blueprint = Blueprint::new(layout)
        .with_blueprint_panel(BlueprintPanel::from_state(rerun::blueprint::components::PanelState::Collapsed))
        .with_selection_panel(SelectionPanel::from_state(rerun::blueprint::components::PanelState::Collapsed))
        // A free-motion recording plays in time (its frames are 1/15 s apart, not evenly numbered).
        .with_time_panel(TimePanel::new().with_timeline(if scene.session.streams.is_some() { "time" } else { "pose" }));
    blueprint.send(rec, BlueprintActivation::default())
}
