//! The campaign driver: runs the paper's protocol (baseline, meta-training, evaluation,
//! meta-testing) on any [`Simulator`], in parallel, resumable, and writes its results.
//!
//! - [`protocol`]: what runs (stages, iterations, budgets, seeds);
//! - [`executor`]: how it runs (worker threads, trials told in ask order);
//! - [`log`]: `trials.jsonl`, the journal a killed campaign resumes from;
//! - [`report`]: tables and findings computed from the trials alone;
//! - [`plot`]: the figures.
//!
//! ```no_run
//! use savme::campaign::{self, Options, Protocol};
//! use savme_sim::sim::DrivingSimulator;
//!
//! let (train, test) = campaign::driving_scenarios();
//! let protocol = Protocol::quick("savme-sim/sensors", train, test);
//! let outcome = campaign::run(
//!     &protocol,
//!     &campaign::Problem::driving(protocol.fidelity_bins),
//!     &DrivingSimulator::default(),
//!     &Options::new("results".into()),
//! )?;
//! println!("{}", outcome.report.table_md());
//! # Ok::<(), savme::campaign::CampaignError>(())
//! ```

pub mod executor;
pub mod log;
pub mod plot;
pub mod protocol;
pub mod report;

pub use protocol::{Cost, OnError, Protocol, Stage, StageKind};
pub use report::Report;

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use savme_kernel::{ConfigError, Kernel, SimError, Simulator, Space};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

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
    /// A line of `trials.jsonl` is not a trial.
    #[error("{}, line {line}: {message}", path.display())]
    Log {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
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
    /// `--resume` on a directory without a campaign.
    #[error("{}: no protocol.json — is this a savme output directory?", path.display())]
    NothingToResume {
        /// The directory.
        path: PathBuf,
    },
    /// The kernel rejected its configuration.
    #[error("kernel configuration: {0}")]
    Kernel(#[from] ConfigError),
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
    /// Recording to the viewer failed.
    #[error("recording: {0}")]
    Recording(String),
    /// The worker threads stopped unexpectedly.
    #[error("the worker threads stopped unexpectedly")]
    WorkersGone,
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

impl CampaignError {
    pub(crate) fn io(path: &Path, source: std::io::Error) -> Self {
        CampaignError::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// How to run a campaign (nothing here changes its results).
#[derive(Debug, Clone)]
pub struct Options {
    /// Output directory.
    pub out: PathBuf,
    /// Continue the campaign in `out` instead of starting one.
    pub resume: bool,
    /// Worker threads.
    pub jobs: usize,
    /// No progress bars.
    pub quiet: bool,
}

impl Options {
    /// A new campaign in `out`, one worker per core, with progress bars.
    pub fn new(out: PathBuf) -> Self {
        Options {
            out,
            resume: false,
            jobs: std::thread::available_parallelism().map_or(1, |n| n.get()),
            quiet: false,
        }
    }
}

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

/// What a finished campaign returns.
#[derive(Debug, Clone)]
pub struct CampaignOutcome {
    /// The results.
    pub report: Report,
    /// Where they were written.
    pub outputs: Outputs,
    /// Trials replayed from `trials.jsonl` (resume) and run by this process.
    pub replayed: u64,
    /// Trials run by this process.
    pub ran: u64,
    /// Wall-clock seconds this process spent.
    pub elapsed_seconds: f64,
}

/// The bundled driving simulator's scenario names: meta-training (1–8) and meta-testing (9–10).
pub fn driving_scenarios() -> (Vec<String>, Vec<String>) {
    savme_sim::scenario::train_test_names()
}

/// What is searched: the fidelity space with θ_HF, and each scenario's parameter space.
#[derive(Debug, Clone, PartialEq)]
pub struct Problem {
    /// The fidelity settings θ.
    pub fidelity: Space,
    /// θ_HF.
    pub theta_hf: savme_kernel::Assignment,
    /// Scenario parameter spaces φ by scenario name.
    pub scenarios: BTreeMap<String, Space>,
}

impl Problem {
    /// The bundled driving simulator: the paper's Table I (`bins` per continuous setting) and
    /// the ten scenarios.
    pub fn driving(bins: u32) -> Problem {
        Problem {
            fidelity: savme_sim::fidelity::space(bins),
            theta_hf: savme_sim::fidelity::theta_hf(),
            scenarios: driving_spaces(),
        }
    }
}

/// The bundled driving simulator's scenario parameter spaces, by name.
pub fn driving_spaces() -> BTreeMap<String, Space> {
    savme_sim::scenario::spaces()
}

/// Reads the protocol of the campaign in `dir` (for `--resume`).
pub fn load_protocol(dir: &Path) -> Result<Protocol, CampaignError> {
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
    serde_json::from_str(&text).map_err(|e| CampaignError::Log {
        path,
        line: e.line(),
        message: e.to_string(),
    })
}

/// Scenario names with their parameter spaces.
type NamedSpaces = Vec<(String, Space)>;

/// Checks that every scenario of the protocol is known; returns the meta-training and
/// meta-testing scenario spaces.
fn scenario_spaces(
    p: &Protocol,
    spaces: &BTreeMap<String, Space>,
) -> Result<(NamedSpaces, NamedSpaces), CampaignError> {
    let pick = |names: &[String]| {
        names
            .iter()
            .map(|n| {
                spaces
                    .get(n)
                    .map(|s| (n.clone(), s.clone()))
                    .ok_or_else(|| CampaignError::UnknownScenario {
                        name: n.clone(),
                        known: spaces.keys().cloned().collect::<Vec<_>>().join(", "),
                    })
            })
            .collect::<Result<Vec<_>, _>>()
    };
    Ok((pick(&p.train_scenarios)?, pick(&p.test_scenarios)?))
}

/// Splits the logged lines into the protocol's stages (a prefix of each, in order); only the
/// last stage with lines may be incomplete.
fn split_log<'a>(
    p: &Protocol,
    lines: &'a [log::LogLine],
    path: &Path,
) -> Result<Vec<&'a [log::LogLine]>, CampaignError> {
    let mut out = Vec::new();
    let mut at = 0usize;
    for stage in p.stages() {
        let label = stage.label();
        let n = lines[at..]
            .iter()
            .take_while(|l| l.stage() == label)
            .count();
        let told = lines[at..at + n]
            .iter()
            .filter(|l| l.trial().is_some())
            .count();
        if told > stage.iterations as usize {
            return Err(CampaignError::Log {
                path: path.to_path_buf(),
                line: at + n,
                message: format!(
                    "stage `{label}` has {told} trials; the protocol runs {}",
                    stage.iterations
                ),
            });
        }
        if n > 0 && told < stage.iterations as usize && at + n < lines.len() {
            return Err(CampaignError::Log {
                path: path.to_path_buf(),
                line: at + n + 1,
                message: format!(
                    "stage `{}` begins before stage `{label}` is complete",
                    lines[at + n].stage()
                ),
            });
        }
        out.push(&lines[at..at + n]);
        at += n;
    }
    if at < lines.len() {
        return Err(CampaignError::Log {
            path: path.to_path_buf(),
            line: at + 1,
            message: format!(
                "stage `{}` is not where the protocol expects it (or not in the protocol)",
                lines[at].stage()
            ),
        });
    }
    Ok(out)
}

/// Prepares the output directory: a new campaign writes `protocol.json` (and fails if the
/// directory already holds one); a resumed one reads `trials.jsonl`.
fn prepare(p: &Protocol, opts: &Options, files: &Outputs) -> Result<log::Log, CampaignError> {
    if opts.resume {
        let saved = load_protocol(&opts.out)?;
        if saved != *p {
            return Err(CampaignError::Protocol {
                field: "protocol.json".into(),
                message: "differs from the protocol given to resume".into(),
            });
        }
        return match files.trials.exists() {
            true => log::read(&files.trials),
            false => Ok(log::Log::default()),
        };
    }
    std::fs::create_dir_all(&opts.out).map_err(|e| CampaignError::io(&opts.out, e))?;
    if files.protocol.exists() || files.trials.exists() {
        return Err(CampaignError::OutputExists {
            path: opts.out.clone(),
        });
    }
    let json = serde_json::to_string_pretty(p).map_err(|e| CampaignError::Protocol {
        field: "protocol".into(),
        message: e.to_string(),
    })?;
    std::fs::write(&files.protocol, json + "\n")
        .map_err(|e| CampaignError::io(&files.protocol, e))?;
    Ok(log::Log::default())
}

fn bar_style(template: &str) -> ProgressStyle {
    ProgressStyle::with_template(template)
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> ")
}

/// Watches a campaign as it runs (e.g. to record it for a viewer). Called on the coordinating
/// thread, in tell order — replayed trials included.
pub trait Observer {
    /// A stage starts.
    fn stage(&mut self, stage: &Stage) {
        let _ = stage;
    }

    /// A trial was told to `kernel` (which has learnt from it).
    fn trial(&mut self, stage: &Stage, line: &log::TrialLine, kernel: &Kernel) {
        let _ = (stage, line, kernel);
    }
}

/// An observer that does nothing.
#[derive(Debug, Default)]
pub struct NoObserver;

impl Observer for NoObserver {}

/// Runs (or resumes) the campaign `p` on `sim` and writes every output into `opts.out`.
/// Every error — bad protocol, unknown scenario, unwritable directory, corrupt trials file —
/// is reported before any simulation runs, except failures of the simulations themselves.
pub fn run<S>(
    p: &Protocol,
    problem: &Problem,
    sim: &S,
    opts: &Options,
) -> Result<CampaignOutcome, CampaignError>
where
    S: Simulator + Clone + Send,
{
    run_observed(p, problem, sim, opts, &mut NoObserver)
}

/// [`run`], telling `observer` about every stage and trial.
pub fn run_observed<S>(
    p: &Protocol,
    problem: &Problem,
    sim: &S,
    opts: &Options,
    observer: &mut dyn Observer,
) -> Result<CampaignOutcome, CampaignError>
where
    S: Simulator + Clone + Send,
{
    let clock = Instant::now();
    p.validate()?;
    let (train_spaces, test_spaces) = scenario_spaces(p, &problem.scenarios)?;
    let files = Outputs::in_dir(&opts.out);
    let logged = prepare(p, opts, &files)?;
    let logged_by_stage = split_log(p, &logged.lines, &files.trials)?;
    let mut writer = log::Writer::append(&files.trials, logged.valid_len)?;

    let fidelity = problem.fidelity.clone();
    let theta_hf = problem.theta_hf.clone();
    let kernel = |scenarios: &[(String, Space)], budget: f64, label: &str| {
        let mut b = Kernel::builder(fidelity.clone(), theta_hf.clone())
            .budget(budget)
            .seed(p.kernel_seed(label));
        for (name, space) in scenarios {
            b = b.scenario(name, space.clone(), p.weight(name));
        }
        b
    };
    // Every kernel is configured up front, so configuration errors come before any run.
    let mut kernels: Vec<Kernel> = Vec::new();
    kernels.push(kernel(&train_spaces, 1.0, "baseline-train").build()?);
    for &b in &p.budgets {
        kernels.push(kernel(&train_spaces, b, &format!("train@{b}")).build()?);
    }
    kernels.push(kernel(&test_spaces, 1.0, "baseline-test").build()?);

    let multi = MultiProgress::with_draw_target(if opts.quiet {
        ProgressDrawTarget::hidden()
    } else {
        ProgressDrawTarget::stderr()
    });
    let total = multi.add(ProgressBar::new(p.total_trials()));
    total.set_style(bar_style(
        "{prefix:>15} [{bar:30}] {pos}/{len} trials  {elapsed_precise} elapsed, ETA {eta}",
    ));
    total.set_prefix("campaign");
    let mut all_lines: Vec<log::LogLine> = Vec::new();
    let (mut replayed, mut ran) = (0u64, 0u64);
    let stages = p.stages();
    executor::with_pool(sim, opts.jobs, |pool| -> Result<(), CampaignError> {
        let budget_index = |b: f64| p.budgets.iter().position(|&x| x == b).unwrap_or(0);
        for (stage, logged) in stages.iter().zip(&logged_by_stage) {
            let label = stage.label();
            let bar = multi.add(ProgressBar::new(stage.iterations));
            bar.set_style(bar_style(
                "{prefix:>15} [{bar:30}] {pos}/{len}  {per_sec}, ETA {eta}  {msg}",
            ));
            bar.set_prefix(label.clone());
            observer.stage(stage);
            // The meta-testing kernels start from the finished meta-training posterior.
            let mut fresh;
            let kernel: &mut Kernel = match (stage.kind, stage.budget) {
                (StageKind::BaselineTrain, _) => &mut kernels[0],
                (StageKind::Train | StageKind::Evaluate, Some(b)) => {
                    &mut kernels[1 + budget_index(b)]
                }
                (StageKind::BaselineTest, _) => &mut kernels[1 + p.budgets.len()],
                (kind, b) => {
                    let b = b.unwrap_or(1.0);
                    // Both priors share a seed: common random numbers make the comparison
                    // fairer.
                    let mut builder = kernel(&test_spaces, b, &format!("test@{b}"));
                    if kind == StageKind::TestLearned {
                        let posterior = kernels[1 + budget_index(b)].fidelity_posterior().clone();
                        builder = builder.fidelity_prior(posterior, p.prior_strength);
                    }
                    fresh = builder.build()?;
                    &mut fresh
                }
            };
            let mut failures = 0u64;
            let lines = executor::run_stage(
                pool,
                kernel,
                executor::StageContext {
                    stage,
                    logged,
                    window: p.window,
                    cost: p.cost.measure(),
                    writer: &mut writer,
                    on_error: p.on_error,
                },
                |line, kernel| {
                    observer.trial(stage, line, kernel);
                    failures += u64::from(line.hf.failure);
                    bar.inc(1);
                    bar.set_message(format!("{failures} failures"));
                    total.inc(1);
                },
            )?;
            let trials =
                |l: &[log::LogLine]| l.iter().filter(|x| x.trial().is_some()).count() as u64;
            replayed += trials(logged);
            ran += trials(&lines) - trials(logged);
            bar.finish();
            all_lines.extend(lines);
        }
        Ok(())
    })?;
    total.finish();

    let trials: Vec<log::TrialLine> = all_lines
        .iter()
        .filter_map(|l| l.trial().cloned())
        .collect();
    let failed = all_lines.len() - trials.len();
    let report = Report::from_trials(p, &trials);
    write_outputs(
        &report,
        &trials,
        failed,
        &files,
        &fidelity,
        &theta_hf,
        clock.elapsed().as_secs_f64(),
    )?;
    Ok(CampaignOutcome {
        report,
        outputs: files,
        replayed,
        ran,
        elapsed_seconds: clock.elapsed().as_secs_f64(),
    })
}

fn write_outputs(
    report: &Report,
    lines: &[log::TrialLine],
    failed: usize,
    files: &Outputs,
    fidelity: &Space,
    theta_hf: &savme_kernel::Assignment,
    elapsed: f64,
) -> Result<(), CampaignError> {
    let write = |path: &Path, text: String| {
        std::fs::write(path, text).map_err(|e| CampaignError::io(path, e))
    };
    write(&files.table, report.table_md())?;
    write(&files.fidelity, report.fidelity_md(fidelity, theta_hf))?;
    let summary = serde_json::json!({
        "report": report,
        "elapsed_seconds_of_last_process": elapsed,
        "trials": lines.len(),
        "failed_simulations": failed,
    });
    write(
        &files.summary,
        serde_json::to_string_pretty(&summary).unwrap_or_default() + "\n",
    )?;
    plot::breakeven(&files.breakeven, &report.protocol, lines)?;
    plot::meta_testing(&files.meta_testing, &report.protocol, lines)?;
    Ok(())
}
