//! `spmcal export`: a calibrated URDF and its companion, written together (atomically).

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use spmcal::model::{Parameters, RobotModel, export};

use super::envelope::Envelope;
use super::files::Files;
use super::output::{Outputs, out};

#[derive(Args)]
pub(crate) struct ExportArgs {
    /// The (calibrated) parameters file.
    #[arg(long)]
    pub(crate) params: PathBuf,
    /// The URDF to write; its companion `.yaml` is written beside it.
    #[arg(long)]
    pub(crate) urdf: PathBuf,
    /// The model whose URDF is copied: a shipped model's name or a URDF's path (default: the
    /// parameters file's `model`, found by its `model_sha256` when moved, else agile_wrist).
    #[arg(long)]
    pub(crate) model: Option<PathBuf>,
    /// Print a machine-readable summary (JSON).
    #[arg(long)]
    pub(crate) json: bool,
}

pub(crate) fn run(args: ExportArgs) -> Result<()> {
    let mut files = Files::new();
    files.model_output("--urdf", &args.urdf);
    files.input("--params", &args.params);
    match &args.model {
        Some(model) => files.model(model),
        None => {
            let params = args.params.clone();
            files.model_named_by(move || Some(Parameters::read(&params).ok()?.model_reference(None)));
        }
    }
    files.check()?;
    let mut outputs = Outputs::new();
    let companion = RobotModel::companion_path(&args.urdf);
    let (urdf_slot, companion_slot) = (outputs.reserve(&args.urdf)?, outputs.reserve(&companion)?);
    let params = Parameters::read(&args.params)?;
    files.check_model(&params.model_reference(args.model.as_deref()))?;
    // The model the parameters name (found by identity when moved) or `--model`; the parameters
    // must belong to it (legs in the same order, the same markers): refused naming both files, or
    // a warning when only the file's `model:` header differs.
    let (model, warnings) = params.load_model(&args.params, args.model.as_deref())?;
    let model_path = model.urdf_path.clone();
    let mut provenance = vec![
        format!("Calibrated model exported by spmcal {} from {}", env!("CARGO_PKG_VERSION"), args.params.display()),
        format!("(parameters: {}; copied from the model {})", source_word(params.source), model_path.display()),
    ];
    if let Some(serde_yaml::Value::Mapping(fit)) = &params.fit {
        for (key, value) in fit {
            let value = serde_json::to_string(value).unwrap_or_default();
            provenance.push(format!("fit {}: {value}", key.as_str().unwrap_or("?")));
        }
    }
    let exported = export(&model, &params, &provenance)?;
    outputs.write(urdf_slot, exported.urdf.as_bytes())?;
    outputs.write(companion_slot, exported.companion.as_bytes())?;
    outputs.commit()?;
    let (urdf, companion) = (args.urdf.display().to_string(), companion.display().to_string());
    if args.json {
        let summary =
            serde_json::json!({ "urdf": urdf, "companion": companion, "model": model_path.display().to_string() });
        let mut envelope = Envelope::new("export", summary).input("params", args.params.display());
        envelope.warnings = warnings;
        return out(&(envelope.to_json() + "\n"));
    }
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    out(&format!("wrote {urdf} and {companion} (load it with --model {urdf})\n"))
}

/// Where the parameters came from, as their file spells it (`source: calibrated`).
fn source_word(source: spmcal::model::ParameterSource) -> String {
    serde_json::to_value(source).ok().and_then(|v| v.as_str().map(str::to_string)).unwrap_or_default()
}
