//! `savme run --config campaign.toml`: the paper's protocol on FMUs the user names.

use super::database::{self, Database};
use super::{
    config_failure, resume_dir, run_campaign, run_repeated, usage, CampaignStorageArgs, Failure,
    ProtocolArgs, RunnerArgs, Target,
};
use savme::adapter::AnySimulator;
use savme::campaign::shell_quote;
use savme::campaign::store::TrialStore;
use savme::compose;
use savme_fmu::campaign_file::FmuCampaignFile;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// Campaign file (TOML); see examples/fmu/campaign.toml.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Output directory (default: the file's `campaign.out`, else savme-fmu-results).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Continue the campaign in DIR (give the same --config and protocol flags: a stopped run
    /// prints the whole command); with --storage, continue the database's campaign (no DIR).
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
    // Protocol flags are taken on resume: with the file they must give the stored protocol
    // (checked when the campaign opens, naming each difference), and the resume command a
    // stopped run prints repeats them.
    // A signal while the file is read (its OpenSCENARIO files can be large) stops the reading.
    super::signals::while_loading();
    let loaded = compose::campaign_file(&config, &overrides);
    super::signals::loaded(&config)?;
    let mut c = loaded.map_err(config_failure)?;
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
    let out = match &resume {
        Some(dir) if store.is_none() => dir.clone(),
        _ => out,
    };
    let database = a.storage.store.database()?;
    // The campaign and its [estimate] stage continue with the same command.
    let hint = resume_hint(&out, database.as_ref().map(|(db, _)| db));
    let target = Target {
        out,
        resume: resume.is_some(),
        store: store.map(|s| Box::new(s) as Box<dyn TrialStore>),
        remote,
        hint: Some(hint.clone()),
    };
    let backend = c.file.simulator(&super::worker_command)?;
    let repeat = c.repeat;
    let estimate = c.estimate_settings().map_err(Failure::Runtime)?;
    // Where the [estimate] stage reads the campaign: its database, or its directory.
    let place = match database {
        Some((db, name)) => database::place(db, name),
        None => compose::Place::Dir(target.out.clone()),
    };
    if let Some(n) = repeat {
        return run_repeated(c.protocol, c.problem, n, target, &a.runner, &backend);
    }
    let out = target.out.clone();
    // The φ-spaces a campaign in a directory starts with are kept beside it (phi.json); a
    // resumed one must still have them (an .xosc edited since is named with both ranges).
    if target.store.is_none() {
        let scenarios = &c.file.common().scenarios;
        if target.resume {
            super::phi::check(&out, &config, &scenarios.spaces, &scenarios.openscenario)?;
        } else {
            super::phi::record(&out, &scenarios.spaces)?;
        }
    }
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
        run_estimate_stage(stage, &hint, a.runner.quiet(), &backend)?;
    }
    Ok(())
}

/// `continue with` the whole command that continues this run (its campaign, then its
/// `[estimate]` stage): this process's command line ([`resume_words`]), shell-quoted.
fn resume_hint(dir: &Path, database: Option<&Database>) -> String {
    let args: Vec<String> = std::env::args().skip(2).collect();
    let dir = super::shown_path(dir);
    let words = resume_words(&args, database.map(database::worker_url).as_deref(), &dir);
    let quoted: Vec<String> = words.iter().map(|w| shell_quote(w)).collect();
    format!("continue with {}", quoted.join(" "))
}

/// `savme run` with `args` (the arguments after `run`: the campaign file, the protocol flags a
/// resumed campaign must repeat to give the same protocol, `--jobs`, …) as they were given,
/// but its campaign resumed: `--out DIR` and any `--resume [DIR]` replaced by `--resume DIR`
/// (`dir`: the campaign's directory); for a campaign in a database (`storage`: its URL
/// without the password) `--resume` alone, `--out` kept (the `[estimate]` stage writes there)
/// and `--storage` given `storage`.
pub(super) fn resume_words(args: &[String], storage: Option<&str>, dir: &str) -> Vec<String> {
    let mut words: Vec<String> = vec!["savme".into(), "run".into()];
    let mut args = args.iter().peekable();
    while let Some(arg) = args.next() {
        let (flag, inline) = match arg.split_once('=') {
            Some((f, v)) if f.starts_with("--") => (f, Some(v)),
            _ => (arg.as_str(), None),
        };
        match flag {
            // Its value, if any, is the next word unless that is a flag (num_args 0..=1).
            "--resume" => {
                if inline.is_none() && args.peek().is_some_and(|v| !v.starts_with('-')) {
                    args.next();
                }
            }
            "--out" if storage.is_none() => {
                if inline.is_none() {
                    args.next();
                }
            }
            "--storage" => {
                let given = inline.map(str::to_string).or_else(|| args.next().cloned());
                words.push(flag.into());
                words.push(storage.map_or_else(|| given.unwrap_or_default(), str::to_string));
            }
            _ => words.push(arg.clone()),
        }
    }
    words.push("--resume".into());
    if storage.is_none() {
        words.push(dir.into());
    }
    words
}

/// The campaign file's `[estimate]` stage, after its campaign; a signal stops it between runs
/// with the command that resumes it (`hint`).
fn run_estimate_stage(
    mut stage: compose::EstimateStage,
    hint: &str,
    quiet: bool,
    backend: &AnySimulator,
) -> Result<(), Failure> {
    stage.stop = super::signals::stop_on_signals(hint);
    let outcome = stage
        .run(compose::estimate_progress_lines(quiet), backend)
        .map_err(|e| {
            super::estimate::interrupted(e, hint)
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

#[cfg(test)]
mod tests {
    use super::resume_words;

    fn words(s: &str) -> Vec<String> {
        s.split_whitespace().map(str::to_string).collect()
    }

    #[test]
    fn the_resume_command_repeats_the_run_with_its_directory_as_resume() {
        let given = words("--config c.toml --out o --method paper --seed 3 --jobs 2 --quiet");
        assert_eq!(
            resume_words(&given, None, "/abs/o"),
            words("savme run --config c.toml --method paper --seed 3 --jobs 2 --quiet --resume /abs/o")
        );
        // Resumed, then stopped again: the same command (`--resume DIR`, `--resume=DIR`, a
        // bare `--resume` before a flag).
        for given in [
            "--config=c.toml --resume o --method=paper",
            "--config=c.toml --resume=o --method=paper",
            "--config=c.toml --out=o --resume --method=paper",
        ] {
            assert_eq!(
                resume_words(&words(given), None, "o"),
                words("savme run --config=c.toml --method=paper --resume o"),
                "{given}"
            );
        }
    }

    #[test]
    fn in_a_database_the_resume_command_keeps_out_and_drops_the_password() {
        let given = words(
            "--config c.toml --storage postgresql://u:pw@h/db --campaign n --remote --out o --seed 3",
        );
        assert_eq!(
            resume_words(&given, Some("postgresql://u@h:5432/db"), "unused"),
            words("savme run --config c.toml --storage postgresql://u@h:5432/db --campaign n --remote --out o --seed 3 --resume")
        );
        let given = words("--config c.toml --storage=postgresql://u:pw@h/db --campaign n --resume");
        assert_eq!(
            resume_words(&given, Some("postgresql://u@h:5432/db"), ""),
            words("savme run --config c.toml --storage postgresql://u@h:5432/db --campaign n --resume")
        );
    }
}
