//! The subcommands, one module each; this module holds what several share: the protocol flags
//! (one override chain for every campaign command), the runner flags (jobs, quiet, recording),
//! running a campaign with its observers, and printing.

pub mod completions;
mod database;
pub mod estimate;
pub mod failures;
pub mod fidelity;
pub mod fmu;
mod phi;
pub mod reproduce;
pub mod run;
pub mod scenarios;
pub mod serve;
mod signals;
pub mod simulate;
mod storage;
pub mod toy;
pub mod worker;

use database::{Database, PostgresStore, Remote, RemoteOptions};
use savme::campaign::config::Overrides;
use savme::campaign::store::{ProtocolKeeper, TrialStore};
use savme::campaign::{
    Campaign, CampaignOutcome, Observer, Problem, ProgressBars, ProgressLines, Protocol, Repeated,
    RepeatedOutcome,
};
use savme::campaign::{CampaignError, Stop};
use savme::kernel::Simulator;
use savme::viewer::{self, Frames, RecordRequest};
use std::fmt::Write as _;
use std::io::{self, IsTerminal, Write};
use std::path::PathBuf;
use std::time::Duration;
pub use storage::{stored_protocol, CampaignStorageArgs, StorageArgs};

/// Why a command failed, which decides the exit status.
#[derive(Debug)]
pub enum Failure {
    /// The command line is wrong: a flag's value savme refuses before running anything
    /// (exit status 2, as for clap's own parse errors).
    Usage(String),
    /// Running failed: a file, a simulator, the trial store, the output (exit status 1).
    Runtime(String),
    /// Ctrl-C stopped a campaign between trials; the message says how to resume (exit status
    /// 130, as a shell reports a process ended by SIGINT).
    Interrupted(String),
}

impl Failure {
    /// The process exit status.
    pub fn code(&self) -> u8 {
        match self {
            Failure::Usage(_) => 2,
            Failure::Runtime(_) => 1,
            Failure::Interrupted(_) => signals::interrupted_code(),
        }
    }

    /// The message.
    pub fn message(&self) -> &str {
        match self {
            Failure::Usage(m) | Failure::Runtime(m) | Failure::Interrupted(m) => m,
        }
    }
}

impl From<String> for Failure {
    fn from(m: String) -> Self {
        Failure::Runtime(m)
    }
}

impl From<&str> for Failure {
    fn from(m: &str) -> Self {
        Failure::Runtime(m.into())
    }
}

/// A flag's value is wrong.
pub fn usage(message: impl std::fmt::Display) -> Failure {
    Failure::Usage(message.to_string())
}

/// An error building a campaign's protocol: one in a protocol field that a flag gave is a usage
/// error; one in a file (named with its line and key) or elsewhere a runtime error.
pub fn config_failure(e: CampaignError) -> Failure {
    match e {
        CampaignError::Protocol { .. } | CampaignError::UnknownScenario { .. } => usage(e),
        other => Failure::Runtime(other.to_string()),
    }
}

/// Ctrl-C or SIGTERM during a campaign: the first asks it to stop between trials (the runs in
/// flight finish, every told trial is stored, the recording is closed); a second quits at once,
/// printing `resume_hint` ([`signals`]).
fn stop_on_ctrl_c(resume_hint: &str) -> Stop {
    signals::stop_on_signals(resume_hint)
}

/// A campaign stopped by Ctrl-C as a [`Failure`] that says how to continue; `otherwise` for
/// every other error.
fn campaign_failure(
    e: CampaignError,
    resume_hint: &str,
    otherwise: fn(CampaignError) -> Failure,
) -> Failure {
    let stopped = match &e {
        CampaignError::Stopped { .. } => true,
        CampaignError::Seed { source, .. } => matches!(**source, CampaignError::Stopped { .. }),
        _ => false,
    };
    if stopped {
        return Failure::Interrupted(format!("interrupted: {e}; {resume_hint}"));
    }
    otherwise(e)
}

/// Protocol values on the command line (they override the preset or the campaign file): the
/// flags are derived from the one declaration of every protocol value
/// ([`savme::campaign::values`]).
#[derive(clap::Args, Debug, Clone, Default)]
pub struct ProtocolArgs {
    #[command(flatten)]
    values: Overrides,
}

impl ProtocolArgs {
    /// The values given, as protocol overrides.
    pub fn overrides(&self) -> Overrides {
        self.values.clone()
    }
}

/// The most worker threads `--jobs` starts: each thread holds a simulator, and a count far
/// beyond the cores only fails to start (100,000 aborted savme in `failed to spawn thread`).
pub const MAX_JOBS: usize = 1024;

/// Parses `--jobs`, refusing more than [`MAX_JOBS`] (0 is refused where it is used, naming
/// the flag).
pub fn parse_jobs(s: &str) -> Result<usize, String> {
    let n: usize = s.parse().map_err(|e| format!("{e}"))?;
    if n > MAX_JOBS {
        return Err(format!("at most {MAX_JOBS} worker threads"));
    }
    // One rule for every command (estimate read 0 as 1, reproduce refused it).
    if n == 0 {
        return Err("must be at least 1 (worker threads)".into());
    }
    Ok(n)
}

/// How a campaign runs (nothing here changes its trials).
#[derive(clap::Args, Debug, Clone)]
pub struct RunnerArgs {
    /// Worker threads (default: one per core). Does not change the results.
    #[arg(long, short = 'j', value_parser = parse_jobs)]
    jobs: Option<usize>,
    /// No progress output.
    #[arg(long, short)]
    quiet: bool,
    #[command(flatten)]
    record: CampaignRecordArgs,
}

impl RunnerArgs {
    /// `--jobs`, else one per core.
    pub fn jobs(&self) -> usize {
        self.jobs
            .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
    }

    /// `--quiet`.
    pub fn quiet(&self) -> bool {
        self.quiet
    }
}

/// Where to record (a build with `--features rerun`; without it the flags are hidden from
/// `--help` and refused before anything runs).
#[derive(clap::Args, Debug, Clone)]
pub struct RecordArgs {
    /// Record to a rerun file (open it with `rerun FILE.rrd`).
    #[arg(long, value_name = "FILE.rrd", hide = !cfg!(feature = "rerun"))]
    record: Option<PathBuf>,
    /// Record to a newly started rerun viewer.
    #[arg(long, hide = !cfg!(feature = "rerun"))]
    spawn: bool,
    /// Record to a running rerun viewer (default rerun+http://127.0.0.1:9876/proxy).
    #[arg(
        long,
        value_name = "URL",
        num_args = 0..=1,
        default_missing_value = "",
        hide = !cfg!(feature = "rerun")
    )]
    connect: Option<String>,
}

/// Recording a campaign: where, and which trials get sensor frames.
#[derive(clap::Args, Debug, Clone)]
pub struct CampaignRecordArgs {
    #[command(flatten)]
    sink: RecordArgs,
    /// A trial recording (frames of its HF and LF runs) for every N-th trial (0: none).
    #[arg(long, value_name = "N", default_value_t = 200, hide = !cfg!(feature = "rerun"))]
    record_every: u64,
    /// ... plus up to N informative trials, chosen when the campaign ends: FN and FP of
    /// meta-training, evaluation and meta-testing first (alternately, in campaign order), then
    /// TP, then HF failures of the baselines (which have no LF run).
    #[arg(long, value_name = "N", default_value_t = 10, hide = !cfg!(feature = "rerun"))]
    record_failures: u64,
}

impl RecordArgs {
    /// The recording asked for (one run: no frame selection).
    pub fn request(&self) -> RecordRequest {
        RecordRequest {
            file: self.record.clone(),
            spawn: self.spawn,
            connect: self.connect.clone(),
            every: 1,
            failures: 0,
        }
    }
}

impl CampaignRecordArgs {
    /// The recording asked for.
    pub fn request(&self) -> RecordRequest {
        RecordRequest {
            every: self.record_every,
            failures: self.record_failures,
            ..self.sink.request()
        }
    }
}

/// The worker process of a campaign file's simulator that isolates its runs: `savme
/// fmu-worker` of this binary.
pub fn worker_command() -> Result<Vec<String>, String> {
    let exe = std::env::current_exe()
        .map_err(|e| format!("cannot find the savme binary for the FMU workers: {e}"))?;
    Ok(vec![exe.display().to_string(), "fmu-worker".into()])
}

/// Where a campaign command writes, and whether it continues a campaign.
pub struct Target {
    /// The output directory.
    pub out: PathBuf,
    /// Continue the campaign in `out` (or in `store`).
    pub resume: bool,
    /// The store, when not the output directory's `trials.jsonl`.
    pub store: Option<Box<dyn TrialStore>>,
    /// The work queue, when `savme worker` processes run the trials.
    pub remote: Option<Remote>,
    /// How to continue the campaign once a signal stopped it (`continue with …`: a whole
    /// command, as `savme run` needs its `--config`); `None`: `continue with --resume DIR`
    /// (in a database: the same --storage and --campaign and --resume), for a command that
    /// continues with those alone.
    pub hint: Option<String>,
}

/// Runs a campaign with the observers the flags ask for (progress bars on a terminal, plain
/// lines otherwise, none with --quiet; the recording) and prints its summary.
pub fn run_campaign<S>(
    protocol: Protocol,
    problem: Problem,
    target: Target,
    runner: &RunnerArgs,
    frames: Frames,
    sim: &S,
) -> Result<(), Failure>
where
    S: Simulator + Clone + Send,
{
    let hint = match (&target.hint, &target.store) {
        (Some(hint), _) => hint.clone(),
        (None, Some(_)) => {
            "continue with the same --storage and --campaign and --resume".to_string()
        }
        (None, None) => format!("continue with --resume {}", shown_path(&target.out)),
    };
    let target_in_database = target.store.is_some();
    let mut campaign = Campaign::new(protocol.clone(), problem.clone())
        .out(target.out)
        .resume(target.resume);
    if let Some(store) = target.store {
        campaign = campaign.store(store);
    }
    if let Some(remote) = target.remote {
        campaign = campaign.remote(remote);
    }
    if let Some(j) = runner.jobs {
        if j == 0 {
            return Err(usage("protocol: `--jobs`: must be at least 1"));
        }
        campaign = campaign.jobs(j);
        if j > 2 * protocol.window && !runner.quiet() {
            eprintln!(
                "savme: WARNING: --jobs {j} but a window of {} trials keeps at most {} runs in flight: {} threads will be idle; --window {j} would keep them busy (it changes the trials slightly)",
                protocol.window,
                2 * protocol.window,
                j - 2 * protocol.window
            );
        }
    }
    // Before the observers: the recording's own Ctrl-C handler then stays out of the way, and
    // the stopped campaign closes the recording.
    campaign = campaign.stop_on(stop_on_ctrl_c(&hint));
    for o in observers(runner, frames, &protocol, &problem).map_err(usage)? {
        campaign = campaign.boxed_observer(o);
    }
    let in_database = target_in_database;
    let outcome = campaign.run(sim).map_err(|e| {
        let database_failed = in_database && matches!(e, CampaignError::Store(_));
        match campaign_failure(e, &hint, |e| Failure::Runtime(e.to_string())) {
            // The told trials are in the database: say how to go on once it is back.
            Failure::Runtime(m) if database_failed => Failure::Runtime(format!(
                "{m}\nThe campaign stopped; every trial it told is in the database. Once the database is reachable again, {hint}"
            )),
            other => other,
        }
    })?;
    Ok(print(&summary_text(&outcome, &problem))?)
}

/// Runs `protocol` with `repeat` seeds ([`Repeated`]): one plain progress line per finished
/// stage and seed (none with --quiet), then prints the results over the seeds.
pub fn run_repeated<S>(
    protocol: Protocol,
    problem: Problem,
    repeat: u32,
    target: Target,
    runner: &RunnerArgs,
    sim: &S,
) -> Result<(), Failure>
where
    S: Simulator + Clone + Send,
{
    let r = runner.record.request();
    if r.file.is_some() || r.spawn || r.connect.is_some() {
        return Err(usage(
            "`--repeat` cannot record to the viewer; record one seed's campaign instead",
        ));
    }
    if target.store.is_some() || target.remote.is_some() {
        return Err(usage(
            "`--repeat` runs each seed in its own directory with the default trial store; it cannot use --storage or --remote",
        ));
    }
    let quiet = runner.quiet;
    let factory = move |seed: u64| -> Vec<Box<dyn Observer + Send>> {
        if quiet {
            return Vec::new();
        }
        vec![Box::new(ProgressLines::with_prefix(
            io::stderr(),
            &format!("seed {seed}: "),
        ))]
    };
    let hint = target
        .hint
        .clone()
        .unwrap_or_else(|| format!("continue with --resume {}", shown_path(&target.out)));
    let mut repeated = Repeated::new(protocol, problem, repeat)
        .out(target.out)
        .resume(target.resume)
        .observers(&factory)
        .stop_on(stop_on_ctrl_c(&hint));
    if let Some(j) = runner.jobs {
        if j == 0 {
            return Err(usage("protocol: `--jobs`: must be at least 1"));
        }
        repeated = repeated.jobs(j);
    }
    let outcome = repeated
        .run(sim)
        .map_err(|e| campaign_failure(e, &hint, config_failure))?;
    Ok(print(&repeated_text(&outcome))?)
}

/// What a repeated campaign prints at the end.
fn repeated_text(o: &RepeatedOutcome) -> String {
    let mut s = o.report.table_md();
    let (replayed, ran): (u64, u64) = o
        .runs
        .iter()
        .fold((0, 0), |(a, b), r| (a + r.replayed, b + r.ran));
    let _ = writeln!(
        s,
        "\n{} seeds, {} trials ({replayed} replayed, {ran} run) in {:.1} s; outputs in {} (each seed in seed-<s>/)",
        o.runs.len(),
        replayed + ran,
        o.elapsed_seconds,
        shown_path(&o.out)
    );
    s
}

fn observers(
    runner: &RunnerArgs,
    frames: Frames,
    protocol: &Protocol,
    problem: &Problem,
) -> Result<Vec<Box<dyn Observer>>, String> {
    let mut out: Vec<Box<dyn Observer>> = Vec::new();
    if !runner.quiet {
        if io::stderr().is_terminal() {
            out.push(Box::new(ProgressBars::new()));
        } else {
            out.push(Box::new(ProgressLines::new(io::stderr())));
        }
    }
    let recording = viewer::start(&runner.record.request(), frames, protocol, problem)
        .map_err(|e| e.to_string())?;
    out.extend(recording);
    Ok(out)
}

/// What `savme reproduce` and `savme run` print at the end.
pub fn summary_text(o: &CampaignOutcome, problem: &Problem) -> String {
    let mut s = String::new();
    let r = &o.report;
    let _ = writeln!(s, "{}", r.table_md());
    let _ = writeln!(s, "{}", r.fidelity_md(&problem.fidelity, &problem.theta_hf));
    let _ = writeln!(s, "{}", r.findings_text());
    if o.withdrawn > 0 {
        let _ = writeln!(
            s,
            "{} trials withdrawn because a simulation failed (on_error = \"skip\"; each is in \
             the trial store with its error, and `failed_simulations` in summary.json) and \
             replaced by new ones: the results rest on the told trials only.",
            o.withdrawn
        );
    }
    let _ = writeln!(
        s,
        "{} trials ({} replayed from the trial store, {} run) in {}; outputs in {}",
        o.replayed + o.ran,
        o.replayed,
        o.ran,
        savme::campaign::report::format_seconds(o.elapsed_seconds),
        o.outputs
            .table
            .parent()
            .map_or_else(|| ".".into(), shown_path)
    );
    s
}

/// `path` as a person would write it: resolved (no `..`, no `.`, links followed — for a path
/// not created yet, its longest existing ancestor) and relative to the working directory when
/// inside it (`examples/fmu/../../out` is `out`).
pub fn shown_path(path: &std::path::Path) -> String {
    let mut missing = Vec::new();
    let mut existing = path;
    let real = loop {
        if let Ok(real) = existing.canonicalize() {
            break Some(real);
        }
        match (existing.file_name(), existing.parent()) {
            (Some(name), Some(parent)) => {
                missing.push(name.to_os_string());
                existing = if parent.as_os_str().is_empty() {
                    std::path::Path::new(".")
                } else {
                    parent
                };
            }
            _ => break None,
        }
    };
    let Some(mut real) = real else {
        return path.display().to_string();
    };
    real.extend(missing.iter().rev());
    let cwd = std::env::current_dir().and_then(|d| d.canonicalize());
    match cwd.as_ref().map(|cwd| real.strip_prefix(cwd)) {
        Ok(Ok(rel)) if rel.as_os_str().is_empty() => ".".into(),
        Ok(Ok(rel)) => rel.display().to_string(),
        _ => real.display().to_string(),
    }
}

/// Writes to stdout; a closed pipe (`savme scenarios | head`) is not an error.
pub fn print(text: &str) -> Result<(), String> {
    match io::stdout().lock().write_all(text.as_bytes()) {
        Err(e) if e.kind() != io::ErrorKind::BrokenPipe => Err(format!("stdout: {e}")),
        _ => Ok(()),
    }
}

/// The directory `--resume` continues (a directory store), `Some("")` for a database's
/// campaign, or None for a new campaign; refuses the combinations that make no sense.
pub fn resume_dir(
    resume: Option<Option<PathBuf>>,
    out: Option<&std::path::Path>,
    database: bool,
) -> Result<Option<PathBuf>, Failure> {
    match (resume, database) {
        (None, _) => Ok(None),
        (Some(Some(dir)), false) if out.is_none() => Ok(Some(dir)),
        (Some(Some(_)), false) => Err(usage("--resume DIR continues the campaign in DIR: give either --resume DIR or --out DIR")),
        (Some(None), false) => Err(usage("--resume needs the campaign's directory (--resume DIR), or --storage URL --campaign NAME")),
        (Some(Some(_)), true) => Err(usage("with --storage, give --resume without a directory: the campaign is in the database")),
        (Some(None), true) => Ok(Some(PathBuf::new())),
    }
}

#[cfg(test)]
mod tests {
    use super::storage::say_if_slow;

    #[test]
    fn shown_paths_are_resolved_and_relative_to_the_working_directory() {
        use super::shown_path;
        // cargo runs unit tests in the package's directory.
        assert_eq!(shown_path("src/../Cargo.toml".as_ref()), "Cargo.toml");
        assert_eq!(shown_path("src/..".as_ref()), ".");
        let base = std::env::temp_dir().join(format!("savme-shown-{}", std::process::id()));
        std::fs::create_dir_all(base.join("sub")).unwrap();
        let real = base.canonicalize().unwrap();
        // Not created yet: its existing ancestor resolved, the rest appended.
        let shown = shown_path(&base.join("sub/../out/leaf"));
        let _ = std::fs::remove_dir_all(&base);
        assert_eq!(shown, real.join("out/leaf").display().to_string());
    }
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::time::{Duration, Instant};

    #[test]
    fn a_slow_step_is_announced_and_a_quick_one_neither_announced_nor_delayed() {
        // A step that outlasts the 20 ms (it waits, up to 30 s, for the announcement).
        let said = AtomicBool::new(false);
        let v = say_if_slow(
            Duration::from_millis(20),
            || said.store(true, Ordering::SeqCst),
            || {
                let start = Instant::now();
                while !said.load(Ordering::SeqCst) && start.elapsed() < Duration::from_secs(30) {
                    std::thread::sleep(Duration::from_millis(5));
                }
                7
            },
        );
        assert_eq!(v, 7);
        assert!(said.load(Ordering::SeqCst), "a slow step was not announced");

        let said = AtomicBool::new(false);
        let start = Instant::now();
        let v = say_if_slow(
            Duration::from_secs(30),
            || said.store(true, Ordering::SeqCst),
            || 8,
        );
        assert_eq!(v, 8);
        assert!(!said.load(Ordering::SeqCst));
        assert!(
            start.elapsed() < Duration::from_secs(10),
            "waited for the timer"
        );
    }
}
