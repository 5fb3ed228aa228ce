//! The campaign's directory: `protocol.json` (what `--resume` continues), and the results
//! written at the end — `table.md`, `fidelity.md`, `summary.json` and the figures.

use super::log::TrialLine;
use super::{figures, CampaignError, Problem, Protocol, Report};
use std::path::{Path, PathBuf};

/// The layout version of the files a campaign writes (defined with the protocol, which
/// carries it in `protocol.json`).
pub use super::protocol::FORMAT_VERSION;

/// The files a campaign writes.
#[derive(Debug, Clone)]
pub struct Outputs {
    /// `protocol.json`.
    pub protocol: PathBuf,
    /// `trials.jsonl`.
    pub trials: PathBuf,
    /// `table.md`.
    pub table: PathBuf,
    /// `fidelity.md`.
    pub fidelity: PathBuf,
    /// `summary.json`.
    pub summary: PathBuf,
    /// `breakeven.png`.
    pub breakeven: PathBuf,
    /// `meta_testing.png`.
    pub meta_testing: PathBuf,
}

impl Outputs {
    /// The files in `dir`.
    pub fn in_dir(dir: &Path) -> Self {
        Outputs {
            protocol: dir.join("protocol.json"),
            trials: dir.join("trials.jsonl"),
            table: dir.join("table.md"),
            fidelity: dir.join("fidelity.md"),
            summary: dir.join("summary.json"),
            breakeven: dir.join("breakeven.png"),
            meta_testing: dir.join("meta_testing.png"),
        }
    }
}

/// Reads the protocol of the campaign in `dir` (for `--resume`): the first record of its
/// `trials.jsonl`, or, for a store written before the protocol was kept there,
/// `protocol.json`. Errors name the file, the line and the field.
pub fn load_protocol(dir: &Path) -> Result<Protocol, CampaignError> {
    if dir.is_file() {
        return Err(CampaignError::NotACampaign {
            path: dir.to_path_buf(),
        });
    }
    usable_dir(dir)?;
    let trials = Outputs::in_dir(dir).trials;
    let first = super::store::JsonlStore::read_first(&trials)?;
    if let Some(first) = first {
        let shown = trials.display().to_string();
        if let Some(p) = super::log::ProtocolLine::of(&first, &shown)? {
            return Ok(p);
        }
    }
    load_protocol_file(dir)
}

/// Reads `dir/protocol.json` (the protocol of a store written before the protocol was its
/// first record).
pub(crate) fn load_protocol_file(dir: &Path) -> Result<Protocol, CampaignError> {
    let path = Outputs::in_dir(dir).protocol;
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(CampaignError::NothingToResume {
                path: dir.to_path_buf(),
            })
        }
        Err(e) => return Err(CampaignError::io(&path, e)),
    };
    let p: Protocol = serde_json::from_str(&text).map_err(|e| CampaignError::Log {
        store: path.display().to_string(),
        line: e.line(),
        message: e.to_string(),
    })?;
    if p.format_version != FORMAT_VERSION {
        return Err(CampaignError::Log {
            store: path.display().to_string(),
            line: 2,
            message: format!(
                "format_version {}: this savme reads version {FORMAT_VERSION}",
                p.format_version
            ),
        });
    }
    // An edited file is checked as a new protocol is (a size savme refuses would panic or
    // allocate later), naming the field's line.
    match p.validate() {
        Ok(()) => Ok(p),
        Err(CampaignError::Protocol { field, message }) => {
            let key = format!("\"{field}\"");
            let line = text
                .lines()
                .position(|l| l.trim_start().starts_with(&key))
                .map_or(1, |i| i + 1);
            Err(CampaignError::Log {
                store: path.display().to_string(),
                line,
                message: format!("`{field}`: {message}"),
            })
        }
        Err(e) => Err(e),
    }
}

/// Refuses an output directory that is a file, or lies below one (instead of the I/O error
/// "File exists" or "Not a directory" creating or reading it would give).
pub(crate) fn usable_dir(dir: &Path) -> Result<(), CampaignError> {
    super::store::safe_file::dangling_link(dir).map_err(|e| CampaignError::io(dir, e))?;
    let in_the_way = dir
        .ancestors()
        .filter(|p| !p.as_os_str().is_empty())
        .find(|p| p.exists() && !p.is_dir());
    match in_the_way {
        Some(file) => Err(CampaignError::NotADirectory {
            path: dir.to_path_buf(),
            file: file.to_path_buf(),
        }),
        None => Ok(()),
    }
}

/// Writes `protocol.json` for a new campaign.
pub(crate) fn save_protocol(p: &Protocol, files: &Outputs) -> Result<(), CampaignError> {
    let json = serde_json::to_string_pretty(p).map_err(|e| CampaignError::Protocol {
        field: "protocol".into(),
        message: e.to_string(),
    })?;
    super::store::safe_file::write_file(&files.protocol, (json + "\n").as_bytes())
        .map_err(|e| CampaignError::io(&files.protocol, e))
}

/// Writes the results of a campaign (all of them computed from `lines`).
pub(crate) fn write(
    report: &Report,
    lines: &[TrialLine],
    failed: usize,
    files: &Outputs,
    problem: &Problem,
    elapsed: f64,
) -> Result<(), CampaignError> {
    let write = |path: &Path, text: String| {
        super::store::safe_file::write_file(path, text.as_bytes())
            .map_err(|e| CampaignError::io(path, e))
    };
    let version = format!("\n<!-- savme format_version {FORMAT_VERSION} -->\n");
    write(&files.table, report.table_md() + &version)?;
    write(
        &files.fidelity,
        report.fidelity_md(&problem.fidelity, &problem.theta_hf) + &version,
    )?;
    let summary = serde_json::json!({
        "format_version": FORMAT_VERSION,
        "report": report,
        "elapsed_seconds_of_last_process": elapsed,
        "trials": lines.len(),
        "failed_simulations": failed,
    });
    write(
        &files.summary,
        serde_json::to_string_pretty(&summary).unwrap_or_default() + "\n",
    )?;
    figures::breakeven(&files.breakeven, &report.protocol, lines)?;
    figures::meta_testing(&files.meta_testing, &report.protocol, lines)?;
    Ok(())
}

/// Writes the results of a repeated campaign into its parent directory `out`: `table.md`
/// (with intervals), `summary.json` (the aggregate with every seed's values) and the figures
/// with median curves and bands. `runs` are the seeds' trial lines, in seed order.
pub(crate) fn write_repeated(
    report: &super::report::repeated::RepeatedReport,
    runs: &[&[TrialLine]],
    out: &Path,
    elapsed: f64,
) -> Result<(), CampaignError> {
    let write = |path: &Path, text: String| {
        super::store::safe_file::write_file(path, text.as_bytes())
            .map_err(|e| CampaignError::io(path, e))
    };
    let version = format!("\n<!-- savme format_version {FORMAT_VERSION} -->\n");
    write(&out.join("table.md"), report.table_md() + &version)?;
    let summary = serde_json::json!({
        "format_version": FORMAT_VERSION,
        "repeated": report,
        "seed_dirs": report
            .seeds
            .iter()
            .map(|&s| format!("seed-{s}"))
            .collect::<Vec<_>>(),
        "trials_per_seed": runs.iter().map(|r| r.len()).collect::<Vec<_>>(),
        "elapsed_seconds_of_last_process": elapsed,
    });
    write(
        &out.join("summary.json"),
        serde_json::to_string_pretty(&summary).unwrap_or_default() + "\n",
    )?;
    figures::breakeven_bands(&out.join("breakeven.png"), &report.protocol, runs)?;
    figures::meta_testing_bands(&out.join("meta_testing.png"), &report.protocol, runs)?;
    Ok(())
}
