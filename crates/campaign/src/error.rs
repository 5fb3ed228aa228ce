//! [`CampaignError`]: everything that can stop a campaign, each naming its culprit.

use super::store::StoreError;
use savme_kernel::SimError;
use std::path::{Path, PathBuf};

/// Why a campaign could not run or finish.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CampaignError {
    /// A protocol value is invalid.
    #[error("protocol: `{field}`: {message}")]
    Protocol {
        /// The field.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A scenario the protocol names is not known to the simulator.
    #[error("unknown scenario `{name}` (known: {known})")]
    UnknownScenario {
        /// The name given.
        name: String,
        /// The known names.
        known: String,
    },
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// A campaign file is invalid (names the file, line and key).
    #[error(transparent)]
    File(#[from] savme_campaign_file::ConfigError),
    /// The trial store failed (locked by another process, unreadable, unwritable).
    #[error(transparent)]
    Store(#[from] StoreError),
    /// A line of the trial store (or of `protocol.json`) is not what it should be.
    #[error("{store}, line {line}: {message}")]
    Log {
        /// The store or file.
        store: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A simulator's result (just run, not replayed) that the kernel refuses, e.g. a runtime of
    /// 0 under wall-clock cost.
    #[error(
        "{stage} trial {index}: the simulator's result cannot be told to the kernel: {message}"
    )]
    Untellable {
        /// Stage label.
        stage: String,
        /// Trial position in the stage.
        index: u64,
        /// The kernel's reason.
        message: String,
    },
    /// The trials file does not match the protocol (a different run, or edited).
    #[error("trials.jsonl does not match the protocol at {stage} trial {index}: {message}")]
    Diverged {
        /// Stage label.
        stage: String,
        /// Trial position in the stage.
        index: u64,
        /// What differs.
        message: String,
    },
    /// The output directory already holds a campaign.
    #[error("{} already holds a campaign; resume it with --resume {}, or choose another output directory", path.display(), path.display())]
    OutputExists {
        /// The directory.
        path: PathBuf,
    },
    /// The output directory, or a directory above it, is a file.
    #[error("{}", not_a_directory(path, file))]
    NotADirectory {
        /// The output directory.
        path: PathBuf,
        /// The file in its way: the output directory itself or one above it.
        file: PathBuf,
    },
    /// A campaign to read (to resume, estimate, list its failures) given as a file.
    #[error("{} is a file, not a campaign directory: give the directory that savme reproduce, run or toy wrote (it holds protocol.json and trials.jsonl){}", path.display(), journal_hint(path))]
    NotACampaign {
        /// The file given.
        path: PathBuf,
    },
    /// `--resume` on a directory without a campaign.
    #[error("{}: no campaign here (no trials.jsonl beginning with its protocol, no protocol.json) — is this a savme output directory?", path.display())]
    NothingToResume {
        /// The directory.
        path: PathBuf,
    },
    /// A new campaign in a store (a database) that already holds one of that name.
    #[error("{store} already holds a campaign; resume it with --resume, or give another --campaign name")]
    CampaignExists {
        /// The store, with the campaign's name.
        store: String,
    },
    /// A campaign read back (not run) whose store holds no protocol (yet).
    #[error("{store}: no protocol stored yet")]
    NoProtocol {
        /// The store, with the campaign's name.
        store: String,
    },
    /// `--resume` on a campaign a store (a database) does not hold.
    #[error("{store}: no campaign to resume (none was started under this name) — start it without --resume")]
    NothingToResumeIn {
        /// The store, with the campaign's name.
        store: String,
    },
    /// The kernel rejected its configuration.
    #[error("kernel configuration: {0}")]
    Kernel(#[from] savme_kernel::ConfigError),
    /// A simulation failed.
    #[error(transparent)]
    Simulation(Box<SimulationError>),
    /// A figure could not be drawn.
    #[error("{}: {message}", path.display())]
    Plot {
        /// The file.
        path: PathBuf,
        /// What failed.
        message: String,
    },
    /// More simulations of a stage failed than the stage has iterations (`on_error = skip`).
    #[error("{stage}: {failures} simulations failed (more than the stage's iterations); the last: {last}")]
    TooManyFailures {
        /// Stage label.
        stage: String,
        /// Failures so far.
        failures: u64,
        /// The last error.
        last: String,
    },
    /// The campaign was asked to stop ([`Stop`](super::Stop)) before it finished; the trials
    /// told so far are stored, and resuming continues from them.
    #[error("stopped in {stage} after {told} of its {planned} (every told trial is stored)")]
    Stopped {
        /// Label of the stage that was running.
        stage: String,
        /// Trials of that stage told (and stored).
        told: u64,
        /// What the stage runs: `300 trials`, or `trials until 4e10 work units are spent`.
        planned: String,
    },
    /// Recording to the viewer failed.
    #[error("recording: {0}")]
    Recording(String),
    /// The worker threads stopped unexpectedly.
    #[error("the worker threads stopped unexpectedly")]
    WorkersGone,
    /// The executor that runs the simulations elsewhere (e.g. on a Ray cluster) failed.
    #[error("the executor ({executor}) failed: {message}")]
    Executor {
        /// Which executor.
        executor: String,
        /// What failed.
        message: String,
    },
    /// The campaign of one seed of a repeated campaign failed.
    #[error("seed {seed} ({}): {source}", dir.display())]
    Seed {
        /// The seed.
        seed: u64,
        /// Its campaign's directory.
        dir: PathBuf,
        /// What failed.
        source: Box<CampaignError>,
    },
}

/// A simulation of a trial failed.
#[derive(Debug, thiserror::Error)]
#[error("{stage}, trial {trial} ({scenario}: {phi}), {run} run: {source}")]
pub struct SimulationError {
    /// Stage label.
    pub stage: String,
    /// Trial id.
    pub trial: u64,
    /// Scenario.
    pub scenario: String,
    /// Its parameters.
    pub phi: String,
    /// HF or LF.
    pub run: &'static str,
    /// The simulator's error.
    pub source: SimError,
}

/// The message of [`CampaignError::NotADirectory`]: names the file, and the output directory
/// when the file is further up its path.
/// For a file given as a campaign: what it may be instead (a `savme serve` journal).
fn journal_hint(path: &Path) -> &'static str {
    let first = std::fs::read(path).ok().and_then(|b| {
        let line = b.split(|&c| c == b'\n').next()?.to_vec();
        String::from_utf8(line).ok()
    });
    match first {
        Some(l) if l.contains("\"event\":\"start\"") => {
            "; this file is a savme serve journal (reopen it with savme serve --journal FILE)"
        }
        _ => "",
    }
}

fn not_a_directory(path: &Path, file: &Path) -> String {
    if path == file {
        format!(
            "{} is a file, not a directory; choose another output directory",
            file.display()
        )
    } else {
        format!(
            "{}: {} is a file, not a directory",
            path.display(),
            file.display()
        )
    }
}

impl CampaignError {
    /// The I/O error of `path`.
    pub fn io(path: &Path, source: std::io::Error) -> Self {
        CampaignError::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}
