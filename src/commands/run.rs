//! `savme run --config campaign.toml`: the paper's protocol on FMUs the user names.

use super::{config_failure, run_campaign, usage, Failure, ProtocolArgs, RunnerArgs, Target};
use savme::campaign::config;
use savme::viewer::Frames;
use savme_fmu::FmuBackend;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Campaign file (TOML); see examples/fmu/campaign.toml.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Output directory (default: the file's `campaign.out`, else savme-fmu-results).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Continue the campaign in DIR (give the same --config).
    #[arg(long, value_name = "DIR")]
    resume: Option<PathBuf>,
    /// Print every FMU log message to standard error (also `[fmu] log = true`); errors carry
    /// the last messages of their run either way.
    #[arg(long)]
    fmu_log: bool,
    #[command(flatten)]
    protocol: ProtocolArgs,
    #[command(flatten)]
    runner: RunnerArgs,
}

pub fn run(a: Args) -> Result<(), Failure> {
    let Some(config) = a.config else {
        return Err(usage(
            "give --config FILE (and --resume DIR to continue a campaign)",
        ));
    };
    let overrides = a.protocol.overrides();
    if a.resume.is_some() && overrides.any() {
        return Err(usage("protocol: `--resume`: a resumed campaign keeps its protocol (protocol.json); give only --config, --resume, --jobs and --quiet"));
    }
    let mut c = config::fmu_file(&config, &overrides).map_err(config_failure)?;
    c.file.init.spec.fmu_log |= a.fmu_log;
    let target = match a.resume {
        Some(dir) => Target {
            out: dir,
            resume: true,
        },
        None => Target {
            out: a
                .out
                .or(c.file.campaign.out.clone())
                .unwrap_or_else(|| PathBuf::from("savme-fmu-results")),
            resume: false,
        },
    };
    let worker = if c.file.isolate {
        let exe = std::env::current_exe()
            .map_err(|e| format!("cannot find the savme binary for the FMU workers: {e}"))?;
        Some(vec![exe.display().to_string(), "fmu-worker".into()])
    } else {
        None
    };
    let backend =
        FmuBackend::new(&c.file.init, worker, c.file.timeout).map_err(|e| e.to_string())?;
    run_campaign(
        c.protocol,
        c.problem,
        target,
        &a.runner,
        Frames::None,
        &backend,
    )
}
