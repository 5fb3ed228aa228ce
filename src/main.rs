//! The `savme` command line.
use clap::{Parser, Subcommand};
use savme::kernel::journal::{self, Journaled};
use savme::kernel::{Kernel, KernelConfig};
use savme::serve::Session;
use std::fs::{File, OpenOptions};
use std::io::{self, BufReader};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "savme",
    version,
    about = "Find the failures of an autonomous system in simulation, fast (SAVME)."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Serve the ask/tell kernel as JSON lines on stdin/stdout, for a harness in any language.
    Serve {
        /// Kernel configuration (JSON, as printed by `savme example-config`). Optional when
        /// resuming from an existing journal.
        #[arg(long)]
        config: Option<PathBuf>,
        /// Journal file: created if missing, resumed if it exists. Every ask and tell is logged
        /// to it before it takes effect.
        #[arg(long)]
        journal: Option<PathBuf>,
    },
    /// Print a kernel configuration (the toy simulator's) to start editing from.
    ExampleConfig,
    /// List the bundled driving simulator's scenarios with their parameter spaces.
    Scenarios,
    /// List the 16 fidelity settings (the paper's Table I) with their high-fidelity values.
    Fidelity,
    /// Reproduce the paper's protocol on the bundled simulator: baseline, meta-training per
    /// budget, evaluation, meta-testing. Writes table.md, fidelity.md, summary.json,
    /// trials.jsonl, breakeven.png and meta_testing.png.
    Reproduce(ReproduceArgs),
    /// Run the paper's protocol on FMUs named in a campaign file (TOML).
    Run(RunArgs),
    /// FMU tools.
    #[command(subcommand)]
    Fmu(FmuCommand),
    /// Serve FMU evaluations on stdin/stdout (started by `savme run` with `isolate = true`).
    #[command(hide = true)]
    FmuWorker,
    /// Run one simulation on the bundled driving simulator.
    Simulate {
        /// Scenario number (1–10) or name.
        #[arg(long)]
        scenario: String,
        /// Scenario parameters: name=value,name=value,… (see `savme scenarios`).
        #[arg(long)]
        phi: String,
        /// Fidelity: `hf`, or name=value,… overriding θ_HF (e.g. simulation_rate_hz=2).
        #[arg(long, default_value = "hf")]
        fidelity: String,
        /// Print the result as JSON.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        record: RecordArgs,
    },
}

#[derive(clap::Args)]
struct ReproduceArgs {
    /// Output directory (created if missing; must not hold a campaign already).
    #[arg(long, default_value = "savme-results")]
    out: PathBuf,
    /// Continue the campaign in DIR after an interruption (even `kill -9`).
    #[arg(long, value_name = "DIR", conflicts_with = "out")]
    resume: Option<PathBuf>,
    /// A short preset (one budget, fewer iterations) that finishes in about a minute.
    #[arg(long)]
    quick: bool,
    /// Worker threads (default: one per core). Does not change the results.
    #[arg(long)]
    jobs: Option<usize>,
    /// Master seed.
    #[arg(long)]
    seed: Option<u64>,
    /// Cost of a run: measured wall-clock time, or deterministic work units (reproducible).
    #[arg(long, value_enum)]
    cost: Option<CostArg>,
    /// Compute budgets C_budget, comma-separated, each in (0, 1].
    #[arg(long, value_delimiter = ',')]
    budgets: Option<Vec<f64>>,
    /// Meta-training iterations per budget.
    #[arg(long)]
    iterations: Option<u64>,
    /// Evaluation trials per budget.
    #[arg(long)]
    eval_iterations: Option<u64>,
    /// Meta-testing iterations per budget and prior.
    #[arg(long)]
    test_iterations: Option<u64>,
    /// Baseline trials on the meta-training scenarios.
    #[arg(long)]
    baseline_iterations: Option<u64>,
    /// Baseline trials on the meta-testing scenarios.
    #[arg(long)]
    baseline_test_iterations: Option<u64>,
    /// Meta-training scenarios (numbers or names, comma-separated). Default 1–8.
    #[arg(long, value_delimiter = ',')]
    train_scenarios: Option<Vec<String>>,
    /// Meta-testing scenarios. Default 9,10.
    #[arg(long, value_delimiter = ',')]
    test_scenarios: Option<Vec<String>>,
    /// Perception of the system under test: camera + lidar (the paper's), or idealised
    /// (fast, blind to the sensor settings).
    #[arg(long, value_enum, default_value = "sensors")]
    perception: PerceptionArg,
    /// Trials in flight at once (changes the results slightly; the number of jobs does not).
    #[arg(long)]
    window: Option<usize>,
    /// No progress bars.
    #[arg(long, short)]
    quiet: bool,
    #[command(flatten)]
    record: RecordArgs,
}

/// Recording to the rerun viewer (a build with `--features rerun`).
#[derive(clap::Args, Debug, Clone)]
struct RecordArgs {
    /// Record to a rerun file (open it with `rerun FILE.rrd`).
    #[arg(long, value_name = "FILE.rrd")]
    record: Option<PathBuf>,
    /// Record to a newly started rerun viewer.
    #[arg(long)]
    spawn: bool,
    /// Record to a running rerun viewer (default rerun+http://127.0.0.1:9876/proxy).
    #[arg(long, value_name = "URL", num_args = 0..=1, default_missing_value = "")]
    connect: Option<String>,
    /// Sensor frames for every N-th trial.
    #[arg(long, value_name = "N", default_value_t = 200)]
    record_every: u64,
    /// ... plus trials whose HF run failed, up to N.
    #[arg(long, value_name = "N", default_value_t = 10)]
    record_failures: u64,
}

impl RecordArgs {
    fn request(&self) -> savme::recording::RecordRequest {
        savme::recording::RecordRequest {
            file: self.record.clone(),
            spawn: self.spawn,
            connect: self.connect.clone(),
            every: self.record_every,
            failures: self.record_failures,
        }
    }
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum CostArg {
    Wall,
    Work,
}

#[derive(Clone, Copy, PartialEq, clap::ValueEnum)]
enum PerceptionArg {
    Sensors,
    Ideal,
}

fn reproduce(a: ReproduceArgs) -> Result<(), String> {
    let overrides = savme::reproduce::Overrides {
        quick: a.quick,
        seed: a.seed,
        cost: a.cost.map(|c| match c {
            CostArg::Wall => savme::campaign::Cost::Wall,
            CostArg::Work => savme::campaign::Cost::Work,
        }),
        budgets: a.budgets,
        train_iterations: a.iterations,
        eval_iterations: a.eval_iterations,
        test_iterations: a.test_iterations,
        baseline_train_iterations: a.baseline_iterations,
        baseline_test_iterations: a.baseline_test_iterations,
        train_scenarios: a.train_scenarios,
        test_scenarios: a.test_scenarios,
        ideal: a.perception == PerceptionArg::Ideal,
        window: a.window,
    };
    let (out, resume) = match a.resume {
        Some(dir) => (dir, true),
        None => (a.out, false),
    };
    let outcome = savme::reproduce::run(
        &overrides,
        out,
        resume,
        a.jobs,
        a.quiet,
        &a.record.request(),
    )
    .map_err(|e| e.to_string())?;
    let (space, hf) = (
        savme_sim::fidelity::space(outcome.report.protocol.fidelity_bins),
        savme_sim::fidelity::theta_hf(),
    );
    print(&savme::reproduce::summary_text(&outcome, &space, &hf))
}

fn run_config(a: RunArgs) -> Result<(), String> {
    let (config, out, resume) = match (a.config, a.resume) {
        (Some(c), None) => (c, a.out, false),
        (Some(c), Some(dir)) => (c, Some(dir), true),
        (None, _) => {
            return Err("give --config FILE (and --resume DIR to continue a campaign)".into())
        }
    };
    let (outcome, problem) =
        savme::fmu_campaign::run(&config, out, resume, a.jobs, a.quiet, &a.record.request())?;
    print(&savme::reproduce::summary_text(
        &outcome,
        &problem.fidelity,
        &problem.theta_hf,
    ))
}

#[derive(clap::Args)]
struct RunArgs {
    /// Campaign file (TOML); see examples/fmu/campaign.toml.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Output directory (default: the file's `campaign.out`, else savme-fmu-results).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Continue the campaign in DIR (give the same --config).
    #[arg(long, value_name = "DIR")]
    resume: Option<PathBuf>,
    /// Worker threads (default: one per core).
    #[arg(long)]
    jobs: Option<usize>,
    /// No progress bars.
    #[arg(long, short)]
    quiet: bool,
    #[command(flatten)]
    record: RecordArgs,
}

#[derive(Subcommand)]
enum FmuCommand {
    /// Write the bundled driving simulator as an FMI 2.0 co-simulation FMU.
    Pack {
        /// The .fmu to write.
        #[arg(long, default_value = "savme-sim.fmu")]
        out: PathBuf,
        /// The simulator's shared library (default: found next to this binary).
        #[arg(long)]
        library: Option<PathBuf>,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Serve { config, journal } => serve(config.as_deref(), journal.as_deref()),
        Command::ExampleConfig => example_config(),
        Command::Reproduce(args) => reproduce(args),
        Command::Run(args) => run_config(args),
        Command::Fmu(FmuCommand::Pack { out, library }) => {
            savme::fmu_campaign::pack(&out, library.as_deref()).and_then(|t| print(&t))
        }
        Command::FmuWorker => savme::fmu_campaign::serve_worker().map_err(|e| e.to_string()),
        Command::Scenarios => print(&savme::cli::scenarios_text()),
        Command::Fidelity => print(&savme::cli::fidelity_text()),
        Command::Simulate {
            scenario,
            phi,
            fidelity,
            json,
            record,
        } => savme::cli::simulate_recorded(&scenario, &phi, &fidelity, json, &record.request())
            .and_then(|t| print(&t)),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("savme: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Writes to stdout; a closed pipe (`savme scenarios | head`) is not an error.
fn print(text: &str) -> Result<(), String> {
    use std::io::Write;
    match io::stdout().lock().write_all(text.as_bytes()) {
        Err(e) if e.kind() != io::ErrorKind::BrokenPipe => Err(format!("stdout: {e}")),
        _ => Ok(()),
    }
}

fn example_config() -> Result<(), String> {
    let kernel = savme::toy::kernel_builder()
        .seed(1)
        .build()
        .map_err(|e| e.to_string())?;
    let json = serde_json::to_string_pretty(kernel.config()).map_err(|e| e.to_string())?;
    print(&format!("{json}\n"))
}

fn read_config(path: &Path) -> Result<KernelConfig, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let config: KernelConfig =
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    // Validate now, so that the error names the file.
    Kernel::new(config.clone()).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(config)
}

fn serve(config: Option<&Path>, journal: Option<&Path>) -> Result<(), String> {
    let config = config.map(read_config).transpose()?;
    let stdin = io::stdin().lock();
    let stdout = io::stdout().lock();
    let io_err = |e: io::Error| format!("stdin/stdout: {e}");
    match journal {
        None => {
            let config = config.ok_or("give --config (or --journal to resume)")?;
            let kernel = Kernel::new(config).map_err(|e| e.to_string())?;
            Session::<File>::Plain(kernel)
                .serve(stdin, stdout)
                .map_err(io_err)
        }
        Some(path) => {
            let shown = path.display();
            let exists = path.metadata().map(|m| m.len() > 0).unwrap_or(false);
            let log = if exists {
                let file = File::open(path).map_err(|e| format!("{shown}: {e}"))?;
                let replay =
                    journal::replay(BufReader::new(file)).map_err(|e| format!("{shown}: {e}"))?;
                if let Some(c) = &config {
                    if c != replay.kernel.config() {
                        return Err(format!(
                            "{shown} was started with a different configuration than the one given"
                        ));
                    }
                }
                let file = OpenOptions::new()
                    .write(true)
                    .open(path)
                    .map_err(|e| format!("{shown}: {e}"))?;
                if let Some(tail) = &replay.truncated {
                    eprintln!(
                        "savme: {shown}: line {} was cut off mid-write ({} bytes); dropping it and \
                         resuming after line {}",
                        tail.line, tail.bytes, replay.lines
                    );
                }
                file.set_len(replay.valid_len)
                    .map_err(|e| format!("{shown}: {e}"))?;
                let mut file = file;
                io::Seek::seek(&mut file, io::SeekFrom::End(0))
                    .map_err(|e| format!("{shown}: {e}"))?;
                eprintln!(
                    "savme: resumed {shown}: {} told, {} pending",
                    replay.kernel.stats().told,
                    replay.kernel.pending().count()
                );
                Journaled::resume(&replay, file)
            } else {
                let config = config.ok_or_else(|| format!("{shown} is new: give --config"))?;
                let file = File::create(path).map_err(|e| format!("{shown}: {e}"))?;
                Journaled::start(config, file).map_err(|e| format!("{shown}: {e}"))?
            };
            Session::Journaled(log).serve(stdin, stdout).map_err(io_err)
        }
    }
}
