//! `savme run --config campaign.toml`: the paper's protocol on FMUs the user names.

use super::{
    config_failure, resume_dir, run_campaign, run_repeated, usage, CampaignStorageArgs, Failure,
    ProtocolArgs, RunnerArgs, Target,
};
use savme::adapter::AnySimulator;
use savme::campaign::store::TrialStore;
use savme::compose;
use savme_fmu::campaign_file::FmuCampaignFile;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Campaign file (TOML); see examples/fmu/campaign.toml.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Output directory (default: the file's `campaign.out`, else savme-fmu-results).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Continue the campaign in DIR (give the same --config); with --storage, continue the
    /// database's campaign (no DIR).
    #[arg(long, value_name = "DIR", num_args = 0..=1)]
    resume: Option<Option<PathBuf>>,
    /// Print every FMU log message to standard error (also `[fmu] log = true`); errors carry
    /// the last messages of their run either way.
    #[arg(long)]
    fmu_log: bool,
    #[command(flatten)]
    protocol: ProtocolArgs,
    #[command(flatten)]
    storage: CampaignStorageArgs,
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
    let store = a.storage.open()?;
    let remote = a.storage.remote(store.as_ref())?;
    let resume = resume_dir(a.resume, a.out.as_deref(), store.is_some())?;
    if resume.is_some() && overrides.any() {
        return Err(usage("protocol: `--resume`: a resumed campaign keeps its protocol; give only --config, --resume, --out, --storage, --campaign, --remote, --jobs and --quiet"));
    }
    let mut c = compose::campaign_file(&config, &overrides).map_err(config_failure)?;
    if a.fmu_log {
        let Some(fmu) = c.file.as_any_mut().downcast_mut::<FmuCampaignFile>() else {
            return Err(usage("--fmu-log: the campaign file names no FMU"));
        };
        fmu.init.spec.fmu_log = true;
    }
    let out = a
        .out
        .or(c.file.common().campaign.out.clone())
        .unwrap_or_else(|| PathBuf::from("savme-fmu-results"));
    let target = Target {
        out: match &resume {
            Some(dir) if store.is_none() => dir.clone(),
            _ => out,
        },
        resume: resume.is_some(),
        store: store.map(|s| Box::new(s) as Box<dyn TrialStore>),
        remote,
    };
    let backend = c.file.simulator(&super::worker_command)?;
    let repeat = c.repeat;
    let estimate = c.estimate_settings().map_err(Failure::Runtime)?;
    // Where the [estimate] stage reads the campaign: its database, or its directory.
    let place = match a.storage.store.database()? {
        Some((db, name)) => compose::Place::Database(Box::new(db), name),
        None => compose::Place::Dir(target.out.clone()),
    };
    if let Some(n) = repeat {
        return run_repeated(c.protocol, c.problem, n, target, &a.runner, &backend);
    }
    let out = target.out.clone();
    let frames = c.file.frames(&super::worker_command)?;
    run_campaign(
        c.protocol,
        c.problem.clone(),
        target,
        &a.runner,
        frames,
        &backend,
    )?;
    if let Some(settings) = estimate {
        let stage = compose::EstimateStage {
            campaign: place,
            out: out.clone(),
            problem: c.problem,
            settings,
            jobs: a.runner.jobs(),
            stop: savme::campaign::Stop::new(),
        };
        run_estimate_stage(stage, &config, a.runner.quiet(), &backend)?;
    }
    Ok(())
}

/// The campaign file's `[estimate]` stage, after its campaign; a signal stops it between runs
/// with the command that resumes it.
fn run_estimate_stage(
    mut stage: compose::EstimateStage,
    config: &std::path::Path,
    quiet: bool,
    backend: &AnySimulator,
) -> Result<(), Failure> {
    let hint = format!(
        "continue with savme run --config {} --resume {}",
        config.display(),
        super::shown_path(&stage.out)
    );
    stage.stop = super::signals::stop_on_signals(&hint);
    let outcome = stage
        .run(compose::estimate_progress_lines(quiet), backend)
        .map_err(|e| {
            super::estimate::interrupted(e, &hint)
                .unwrap_or_else(|e| Failure::Runtime(e.to_string()))
        })?;
    for change in &outcome.changed_on_resume {
        eprintln!("savme: [estimate] resumed with a changed stopping rule (the runs drawn are the same): {change}");
    }
    super::print(&format!(
        "{}\nestimate written to {}\n",
        outcome.table_md,
        super::shown_path(&outcome.out)
    ))
    .map_err(Failure::Runtime)
}
