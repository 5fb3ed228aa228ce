//! `savme worker --storage URL --campaign NAME [--jobs N]`: runs the HF and LF runs of a
//! campaign whose coordinator was started with `--remote`, on this host, until the campaign
//! is finished.

//!
//! Without the `postgres` feature the command is there (its help, its completions) and
//! refuses with the one message of [`super::database::MISSING`].

use super::{usage, Failure};
#[cfg(feature = "postgres")]
use savme::adapter::{simulator_of_label, AnySimulator};
#[cfg(feature = "postgres")]
use savme::campaign::shell_quote;
#[cfg(feature = "postgres")]
use savme::compose;
#[cfg(feature = "postgres")]
use savme::postgres::worker::{work, Unavailable, WorkerOptions};
#[cfg(feature = "postgres")]
use savme::postgres::{stored_simulator, Session};
#[cfg(feature = "postgres")]
use std::path::Path;
use std::path::PathBuf;
#[cfg(feature = "postgres")]
use std::time::Duration;

#[derive(clap::Args)]
#[cfg_attr(not(feature = "postgres"), allow(dead_code))]
pub struct Args {
    #[command(flatten)]
    storage: super::StorageArgs,
    /// Runs at once on this host (threads, each with its own simulator).
    #[arg(long, short = 'j', default_value_t = 1, value_parser = super::parse_jobs)]
    jobs: usize,
    /// For an FMU campaign: its campaign file on this host (the FMUs it names are resolved
    /// here). Not needed for the bundled and toy simulators.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Seconds a claimed run stays this worker's without a heartbeat (heartbeats come every
    /// third of it, every second at most); a killed worker's runs are taken over after this
    /// long. At most 3600.
    #[arg(long, value_name = "SECONDS", default_value_t = 30.0)]
    lease: f64,
    /// Seconds to wait for the campaign's coordinator to create the campaign.
    #[arg(long, value_name = "SECONDS", default_value_t = 600.0)]
    wait: f64,
    /// Seconds without a live coordinator (one running the campaign with --remote, its
    /// heartbeat fresh) before this worker stops (exit status 1, naming the command that
    /// resumes the campaign). The worker says so on stderr within seconds.
    #[arg(long, value_name = "SECONDS", default_value_t = 120.0)]
    grace: f64,
    /// No progress messages (waiting for the campaign, the closing count); warnings and
    /// errors still go to standard error.
    #[arg(long, short)]
    quiet: bool,
}

/// Without the `postgres` feature: the one refusal ([`super::database::MISSING`], a usage
/// error).
#[cfg(not(feature = "postgres"))]
pub fn run(_: Args) -> Result<(), Failure> {
    super::database::available().map_err(usage)
}

/// Runs the campaign's runs until it is finished (or a signal stops this worker).
#[cfg(feature = "postgres")]
pub fn run(a: Args) -> Result<(), Failure> {
    let Some((db, name)) = a.storage.database()? else {
        return Err(usage(
            "savme worker needs --storage URL (or --storage-file FILE) and --campaign NAME",
        ));
    };
    let restart = restart_command(a.storage.restart_words(&db), a.jobs, a.config.as_deref());
    let again = format!("start it again with: {restart}");
    let mut options = options(&a, &again)?;
    options.restart = Some(restart);
    let Some(label) = simulator_label(&db, &name, &options, a.quiet)? else {
        return Err(Failure::Interrupted(format!(
            "worker stopped ({}) while waiting for campaign {name:?} to be started; {again}",
            super::signals::received_name()
        )));
    };
    let report = match (simulator_of_label(&label), &a.config) {
        (Some(sim), _) => work(&db, &name, &sim, &options),
        (None, Some(file)) => match file_simulator(file, &name, &label)? {
            Ok(backend) => work(&db, &name, &backend, &options),
            Err(reason) => {
                eprintln!(
                    "savme worker: WARNING: this host cannot run campaign {name:?}'s simulator: {reason}\n\
                     savme worker: every run this worker takes will fail with that error, and the campaign's on_error applies (abort stops it; skip withdraws the trial): fix this host or stop this worker"
                );
                let sim = Unavailable::new(reason, Duration::from_secs(1));
                work(&db, &name, &sim, &options)
            }
        },
        (None, None) => {
            return Err(usage(format!(
                "campaign {name:?} runs simulator {label:?}, which savme cannot build from its name: give its campaign file with --config FILE (the FMUs are resolved on this host)"
            )))
        }
    }
    .map_err(|e| e.to_string())?;
    if report.stopped {
        return Err(Failure::Interrupted(format!(
            "worker stopped ({}) between runs: this worker ran {} runs ({} dropped: their lease had expired), every result is written and its unstarted claims are queued again; campaign {name:?} goes on; {again}",
            super::signals::received_name(),
            report.runs,
            report.dropped
        )));
    }
    if a.quiet {
        return Ok(());
    }
    eprintln!(
        "savme worker: campaign {name:?} finished; this worker ran {} runs ({} finished after their lease expired and were dropped)",
        report.runs, report.dropped
    );
    Ok(())
}

#[cfg(feature = "postgres")]
/// `savme worker` with `storage` (the flags naming the database and campaign), `--jobs` and
/// `--config` as this worker was given them, shell-quoted: the command that starts it again.
fn restart_command(storage: Vec<String>, jobs: usize, config: Option<&Path>) -> String {
    let mut words: Vec<String> = vec!["savme".into(), "worker".into()];
    words.extend(storage);
    words.extend(["--jobs".into(), jobs.to_string()]);
    if let Some(file) = config {
        words.extend(["--config".into(), file.display().to_string()]);
    }
    let quoted: Vec<String> = words.iter().map(|w| shell_quote(w)).collect();
    quoted.join(" ")
}

#[cfg(feature = "postgres")]
/// The worker's options from the flags (each duration a positive number of seconds); Ctrl-C
/// and SIGTERM stop it between runs (`again`: how to start it again).
fn options(a: &Args, again: &str) -> Result<WorkerOptions, Failure> {
    if a.jobs == 0 {
        return Err(usage("--jobs: must be at least 1"));
    }
    let seconds = |flag: &str, v: f64| {
        if v.is_finite() && v > 0.0 {
            Ok(Duration::from_secs_f64(v))
        } else {
            Err(usage(format!(
                "--{flag}: {v} is not a positive number of seconds"
            )))
        }
    };
    let (lease, wait_for_campaign) = (seconds("lease", a.lease)?, seconds("wait", a.wait)?);
    let longest = savme::postgres::queue::MAX_LEASE.as_secs();
    if lease.as_secs_f64() > longest as f64 {
        return Err(usage(format!(
            "--lease: {} s is longer than a worker may hold a run ({longest} s: the server refuses a longer lease)",
            a.lease
        )));
    }
    let grace = seconds("grace", a.grace)?;
    let stop = super::signals::stop_on_signals_saying(
        "stopping after the runs in flight (their results are written; the campaign goes on with the other workers); a second signal quits at once (its runs are taken over when their lease expires)",
        again,
    );
    Ok(WorkerOptions {
        jobs: a.jobs,
        lease,
        wait_for_campaign,
        stop,
        grace,
        restart: None,
    })
}

#[cfg(feature = "postgres")]
/// The simulator of campaign `name` (simulator `label`) from its campaign file on this host
/// (for FMUs: the file's FMUs resolved here); `Ok(Err(reason))` if this host cannot build it (the file's FMUs are missing or do not
/// load here), an error if the file is not there or describes another simulator.
fn file_simulator(
    file: &Path,
    name: &str,
    label: &str,
) -> Result<Result<AnySimulator, String>, Failure> {
    if let Err(e) = std::fs::metadata(file) {
        return Err(usage(format!("--config {}: {e}", file.display())));
    }
    super::signals::while_loading();
    let loaded = compose::campaign_file(file, &Default::default());
    super::signals::loaded(file)?;
    let c = match loaded {
        Ok(c) => c,
        Err(e) => return Ok(Err(e.to_string())),
    };
    if !savme::adapter::same_simulator(label, &c.protocol.simulator) {
        return Err(Failure::Runtime(format!(
            "{}: this campaign file describes simulator {:?}, but campaign {name:?} runs {label:?}",
            file.display(),
            c.protocol.simulator
        )));
    }
    Ok(c.file.simulator(&super::worker_command))
}

#[cfg(feature = "postgres")]
/// The simulator label of campaign `name`'s protocol, waiting until its coordinator stored it
/// (none if a signal stopped the wait).
fn simulator_label(
    db: &savme::postgres::Database,
    name: &str,
    options: &WorkerOptions,
    quiet: bool,
) -> Result<Option<String>, String> {
    let patience = options.wait_for_campaign;
    let mut s = super::storage::connecting(db, || Session::connect(db, "worker"))
        .map_err(|e| e.to_string())?;
    let start = std::time::Instant::now();
    let mut said = quiet;
    loop {
        let label: Option<String> = s
            .run(|c| stored_simulator(c, name))
            .map_err(|e| e.to_string())?;
        if label.is_some() || options.stop.is_requested() {
            return Ok(label);
        }
        if start.elapsed() >= patience {
            return Err(format!(
                "{}: no campaign {name:?} was started within {} s (start its coordinator with --storage … --campaign {name:?} --remote)",
                db.location(),
                patience.as_secs()
            ));
        }
        if !said {
            eprintln!(
                "savme worker: {}: waiting for campaign {name:?} to be started (or, if it runs, for this role to be allowed to work on it: its coordinator's --worker-role)",
                db.location()
            );
            said = true;
        }
        // Often: workers usually start before their coordinator, and every moment waited
        // here is a moment of the campaign (a cheap indexed read).
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[cfg(all(test, feature = "postgres"))]
mod tests {
    use super::restart_command;
    use std::path::Path;

    #[test]
    fn the_restart_command_keeps_jobs_and_config_and_is_quoted_for_a_shell() {
        let storage = [
            "--storage",
            "postgresql://w@db.lab:5432/safety?sslmode=require",
        ];
        let words = |name: &str| -> Vec<String> {
            let mut w: Vec<String> = storage.iter().map(|s| s.to_string()).collect();
            w.extend(["--campaign".into(), name.into()]);
            w
        };
        assert_eq!(
            restart_command(words("night 1"), 4, Some(Path::new("fmus/campaign.toml"))),
            "savme worker --storage 'postgresql://w@db.lab:5432/safety?sslmode=require' --campaign 'night 1' --jobs 4 --config fmus/campaign.toml"
        );
        let file = vec![
            "--storage-file".to_string(),
            "db.url".into(),
            "--campaign".into(),
            "night-1".into(),
        ];
        assert_eq!(
            restart_command(file, 1, None),
            "savme worker --storage-file db.url --campaign night-1 --jobs 1"
        );
    }
}
