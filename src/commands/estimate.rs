//! `savme estimate CAMPAIGN`: P(failure) under the nominal distribution by importance sampling
//! from the campaign's trained posterior (see `savme::campaign::estimate`).

use super::{usage, Failure};
use savme::campaign::estimate::{
    parse_nominal, EstimateError, EstimateOutcome, EstimateProgress, EstimateRun, EstimateSettings,
};
use savme::campaign::Problem;
use savme::compose;
use savme_kernel::estimation::{Fidelity, ProposalKind, Tilt};
use std::io::IsTerminal;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The directory of a finished campaign (savme reproduce / run); or give --storage and
    /// --campaign for a campaign kept in a database.
    #[arg(value_name = "CAMPAIGN")]
    dir: Option<PathBuf>,
    #[command(flatten)]
    store: super::StorageArgs,
    /// Output directory (default CAMPAIGN/estimate-<budget>; needed for a campaign kept in a
    /// database).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Continue the estimate in the output directory with its stored settings.
    #[arg(long)]
    resume: bool,
    /// The budget whose meta-training posterior builds the proposal (default: the first).
    #[arg(long, allow_negative_numbers = true)]
    budget: Option<f64>,
    /// The nominal's share ε of the proposal, in (0, 1]; 1 is plain Monte Carlo [default: 0.1].
    #[arg(long, allow_negative_numbers = true)]
    epsilon: Option<f64>,
    /// Seed of the proposal's draws (default: from the campaign's seed).
    #[arg(long)]
    seed: Option<u64>,
    /// Stop when the 95 % interval is within ± this fraction of the estimate (0.1 = ±10 %)
    /// [default: 0.1].
    #[arg(long, allow_negative_numbers = true)]
    target_width: Option<f64>,
    /// Run exactly --max-runs (no target width).
    #[arg(long, conflicts_with = "target_width")]
    no_target: bool,
    /// The most HF runs to make [default: 10000].
    #[arg(long)]
    max_runs: Option<u64>,
    /// Failures needed before the target width may stop the estimate [default: 10].
    #[arg(long)]
    min_failures: Option<u64>,
    /// A scenario to estimate (repeat; default: every meta-training scenario).
    #[arg(long = "scenario", value_name = "NAME")]
    scenarios: Vec<String>,
    /// A variable's nominal distribution: SCENARIO.VARIABLE=normal:MEAN,SD (truncated to the
    /// variable's range), =lognormal:MU,SIGMA (of ln φ; truncated too), =weights:W1,W2,…
    /// (discrete) or =uniform (the default). Repeat.
    #[arg(long = "nominal", value_name = "DECL")]
    nominals: Vec<String>,
    /// How the proposal weighs each variable's bins: by the posterior means, or also by the
    /// nominal's probability of the bin (for a nominal far from the failures) [default:
    /// posterior].
    #[arg(long, value_enum)]
    tilt: Option<TiltArg>,
    /// Cross-entropy pilot rounds that refit the proposal toward where p(φ)·P(failure) is
    /// large before the estimate (0: none) [default: 0]. Pilot runs count in --max-runs, not
    /// in the estimate.
    #[arg(long)]
    refine_rounds: Option<u32>,
    /// HF runs per pilot round (with --refine-rounds) [default: 0].
    #[arg(long)]
    refine_runs: Option<u64>,
    /// How many of the last pilot rounds also count toward the estimate, each run weighted
    /// by its own round's proposal (unbiased; fewer runs for the same width when the last
    /// rounds' proposals are close to the final one) [default: 0].
    #[arg(long)]
    refine_reuse: Option<u32>,
    /// What the pilot rounds fit: each variable's bins (product), or a mixture over the whole
    /// of φ fitted to the pilot's weighted failures and near-misses (joint; needs
    /// --refine-rounds) [default: product].
    #[arg(long, value_enum)]
    proposal: Option<ProposalArg>,
    /// The most mixture components of a joint proposal (with --proposal joint) [default: 8].
    #[arg(long)]
    joint_components: Option<u32>,
    /// The fidelity of the pilot rounds: hf, or lf — the multi-fidelity estimator: the
    /// proposal is fitted on LF runs at the campaign's learned θ_LF* (charged at their cost),
    /// the estimate itself uses HF runs only (unbiased for the HF probability); needs
    /// --refine-rounds [default: hf].
    #[arg(long, value_enum)]
    pilot_fidelity: Option<FidelityArg>,
    /// LF runs at the campaign's learned θ_LF* as control variates for the HF estimate
    /// (multi-fidelity Monte Carlo): this many calibration pairs (φ run at HF and LF; not in
    /// the estimate) measure the LF/HF correlation and costs and choose α and the LF runs per
    /// pair, or HF only when the LF does not pay; every run counts in --max-runs
    /// [default: 0, off].
    #[arg(long)]
    control_calibration: Option<u64>,
    /// Extra LF-only runs per estimate pair with --control-calibration, 0..=64 (0: HF only
    /// after the calibration) [default: chosen by the calibration].
    #[arg(long)]
    control_extra: Option<u32>,
    /// The campaign file of an FMU campaign (savme run): its problem and HF simulator. Its
    /// `[estimate]` section, if any, gives the settings; flags given here override its keys.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Worker threads (default: one per core). Does not change the result.
    #[arg(long, short = 'j', value_parser = super::parse_jobs)]
    jobs: Option<usize>,
    /// Print summary.json (the estimate, its settings and costs; raw numbers) on standard
    /// output instead of the table.
    #[arg(long)]
    json: bool,
    /// No progress output (a bar on a terminal, else a line about every 10 s on standard
    /// error).
    #[arg(long, short)]
    quiet: bool,
}

/// An estimate's progress on standard error: a bar on a terminal, else a line when it starts
/// and about every 10 s; either way the last state as a final line (nothing with --quiet).
struct Progress {
    quiet: bool,
    bar: Option<indicatif::ProgressBar>,
    lines: Box<dyn FnMut(&EstimateProgress<'_>)>,
    last: Option<String>,
}

impl Progress {
    fn new(quiet: bool) -> Self {
        let bar = (!quiet && std::io::stderr().is_terminal()).then(|| {
            let bar = indicatif::ProgressBar::new(0);
            if let Ok(style) = indicatif::ProgressStyle::with_template("[{bar:25}] {msg}") {
                bar.set_style(style.progress_chars("=> "));
            }
            bar
        });
        Progress {
            quiet,
            bar,
            lines: Box::new(compose::estimate_progress_lines(quiet)),
            last: None,
        }
    }

    fn show(&mut self, p: &EstimateProgress<'_>) {
        if self.quiet {
            return;
        }
        let line = p.line();
        match &self.bar {
            Some(bar) => {
                bar.set_length(p.max_runs);
                bar.set_position(p.told);
                bar.set_message(line.clone());
            }
            None => (self.lines)(p),
        }
        self.last = Some(line);
    }

    /// The final line: where the estimate stopped.
    fn finish(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
        if let Some(line) = self.last.take() {
            eprintln!("{line}");
        }
    }
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum ProposalArg {
    Product,
    Joint,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum FidelityArg {
    Hf,
    Lf,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum TiltArg {
    Posterior,
    NominalWeighted,
}

impl Args {
    /// The settings: `base` (the defaults, or a campaign file's `[estimate]` section) with
    /// every flag given on the command line put over it.
    fn settings(&self, base: EstimateSettings) -> Result<EstimateSettings, EstimateError> {
        let mut s = base;
        s.budget = self.budget.or(s.budget);
        s.epsilon = self.epsilon.unwrap_or(s.epsilon);
        s.seed = self.seed.or(s.seed);
        if self.no_target {
            s.target_width = None;
        } else if self.target_width.is_some() {
            s.target_width = self.target_width;
        }
        s.max_runs = self.max_runs.unwrap_or(s.max_runs);
        s.min_failures = self.min_failures.unwrap_or(s.min_failures);
        if !self.scenarios.is_empty() {
            s.scenarios = self.scenarios.clone();
        }
        if let Some(t) = self.tilt {
            s.tilt = match t {
                TiltArg::Posterior => Tilt::Posterior,
                TiltArg::NominalWeighted => Tilt::NominalWeighted,
            };
        }
        s.refine_rounds = self.refine_rounds.unwrap_or(s.refine_rounds);
        s.refine_runs = self.refine_runs.unwrap_or(s.refine_runs);
        s.refine_reuse = self.refine_reuse.unwrap_or(s.refine_reuse);
        if let Some(p) = self.proposal {
            s.proposal = match p {
                ProposalArg::Product => ProposalKind::Product,
                ProposalArg::Joint => ProposalKind::Joint,
            };
        }
        s.joint_components = self.joint_components.or(s.joint_components);
        if let Some(f) = self.pilot_fidelity {
            s.pilot_fidelity = match f {
                FidelityArg::Hf => Fidelity::Hf,
                FidelityArg::Lf => Fidelity::Lf,
            };
        }
        s.control_calibration = self.control_calibration.unwrap_or(s.control_calibration);
        s.control_extra = self.control_extra.or(s.control_extra);
        // A flag overrides the file's declaration of its variable; a second flag for the
        // same variable is refused rather than silently winning.
        let mut given = std::collections::BTreeSet::new();
        for n in &self.nominals {
            let (scenario, variable, nominal) = parse_nominal(n)?;
            if !given.insert((scenario.clone(), variable.clone())) {
                return Err(EstimateError::NominalSyntax {
                    given: n.clone(),
                    message: format!("`{scenario}.{variable}` is declared by an earlier --nominal"),
                });
            }
            s.nominal
                .entry(scenario)
                .or_default()
                .insert(variable, nominal);
        }
        s.validate()?;
        Ok(s)
    }
}

impl Args {
    /// The names of the settings given: by a flag, or by a key of the campaign file's
    /// `[estimate]` section (a resume compares these with the stored ones, and keeps the
    /// stored value of every other).
    fn given(&self, section: Option<&savme_campaign_file::EstimateSection>) -> Vec<&'static str> {
        let mut names = Vec::new();
        let mut add = |name: &'static str, flag: bool, key: bool| {
            if flag || key {
                names.push(name);
            }
        };
        let s = section.cloned().unwrap_or_default();
        add("budget", self.budget.is_some(), s.budget.is_some());
        add("epsilon", self.epsilon.is_some(), s.epsilon.is_some());
        add("seed", self.seed.is_some(), s.seed.is_some());
        add(
            "target_width",
            self.target_width.is_some() || self.no_target,
            s.target_width.is_some(),
        );
        add("max_runs", self.max_runs.is_some(), s.max_runs.is_some());
        add(
            "min_failures",
            self.min_failures.is_some(),
            s.min_failures.is_some(),
        );
        add(
            "scenarios",
            !self.scenarios.is_empty(),
            s.scenarios.is_some(),
        );
        add("nominal", !self.nominals.is_empty(), !s.nominal.is_empty());
        add("tilt", self.tilt.is_some(), s.tilt.is_some());
        add(
            "refine_rounds",
            self.refine_rounds.is_some(),
            s.refine_rounds.is_some(),
        );
        add(
            "refine_runs",
            self.refine_runs.is_some(),
            s.refine_runs.is_some(),
        );
        add(
            "refine_reuse",
            self.refine_reuse.is_some(),
            s.refine_reuse.is_some(),
        );
        add("proposal", self.proposal.is_some(), s.proposal.is_some());
        add(
            "joint_components",
            self.joint_components.is_some(),
            s.joint_components.is_some(),
        );
        add(
            "pilot_fidelity",
            self.pilot_fidelity.is_some(),
            s.pilot_fidelity.is_some(),
        );
        add(
            "control_calibration",
            self.control_calibration.is_some(),
            s.control_calibration.is_some(),
        );
        add(
            "control_extra",
            self.control_extra.is_some(),
            s.control_extra.is_some(),
        );
        names
    }
}

/// `continue with savme estimate CAMPAIGN [--config FILE] [--out DIR] --resume` (or
/// `--storage … --campaign NAME` for a database's campaign).
fn resume_hint(a: &Args) -> String {
    let mut s = match (&a.dir, &a.store.campaign) {
        (Some(dir), _) => format!("continue with savme estimate {}", dir.display()),
        (None, Some(name)) => format!(
            "continue with savme estimate --storage URL --campaign {:?}",
            name
        ),
        (None, None) => "continue with savme estimate".to_string(),
    };
    if let Some(c) = &a.config {
        s += &format!(" --config {}", c.display());
    }
    if let Some(o) = &a.out {
        s += &format!(" --out {}", o.display());
    }
    s + " --resume"
}

/// An estimate a signal stopped, as [`Failure::Interrupted`] saying how to continue; any other
/// error given back.
pub fn interrupted(e: EstimateError, hint: &str) -> Result<Failure, EstimateError> {
    match e {
        EstimateError::Stopped { .. } => Ok(Failure::Interrupted(format!(
            "interrupted ({}): {e}; {hint}",
            super::signals::received_name()
        ))),
        other => Err(other),
    }
}

/// Refuses a campaign file that describes another campaign than the one estimated (another
/// simulator or other scenarios), naming what differs — rather than blaming a scenario later.
fn same_campaign(
    file: &std::path::Path,
    theirs: &savme::campaign::Protocol,
    ours: &savme::campaign::Protocol,
    campaign: &str,
) -> Result<(), Failure> {
    let mut differs = Vec::new();
    if !savme::adapter::same_simulator(&ours.simulator, &theirs.simulator) {
        differs.push(format!(
            "simulator {:?} there, {:?} in the file",
            ours.simulator, theirs.simulator
        ));
    }
    for (what, a, b) in [
        (
            "train_scenarios",
            &ours.train_scenarios,
            &theirs.train_scenarios,
        ),
        (
            "test_scenarios",
            &ours.test_scenarios,
            &theirs.test_scenarios,
        ),
    ] {
        if a != b {
            differs.push(format!("{what} {a:?} there, {b:?} in the file"));
        }
    }
    if differs.is_empty() {
        return Ok(());
    }
    Err(usage(format!(
        "--config {}: this campaign file describes another campaign than {campaign} ({}); give the campaign file the campaign was run with",
        file.display(),
        differs.join("; ")
    )))
}

/// A usage error (exit 2) for what the flags said wrong, a runtime error otherwise.
fn failure(e: EstimateError) -> Failure {
    match e {
        EstimateError::Setting { .. }
        | EstimateError::NominalSyntax { .. }
        | EstimateError::UnknownBudget { .. }
        | EstimateError::UnknownScenario { .. }
        | EstimateError::ChangedOnResume { .. }
        | EstimateError::Estimation(_) => usage(e),
        other => Failure::Runtime(other.to_string()),
    }
}

/// The campaign file of `--config` (its protocol, problem and `[estimate]` section).
fn campaign_file(a: &Args) -> Result<Option<compose::FileCampaign>, Failure> {
    a.config
        .as_ref()
        .map(|path| {
            // A signal while the file is read stops the reading.
            super::signals::while_loading();
            let loaded = compose::campaign_file(path, &Default::default());
            super::signals::loaded(path)?;
            loaded.map_err(|e| Failure::Runtime(e.to_string()))
        })
        .transpose()
}

/// The settings (defaults ← the file's `[estimate]` ← the flags) and the keys given.
fn settings_of(
    a: &Args,
    file: Option<&compose::FileCampaign>,
) -> Result<(EstimateSettings, Vec<&'static str>), Failure> {
    let section = file.and_then(|c| c.file.common().estimate.as_ref().map(|e| (c, e)));
    let base = match section {
        Some((c, section)) => EstimateSettings::from_section(section, &c.file.common().path)
            .map_err(|e| Failure::Runtime(e.to_string()))?,
        None => EstimateSettings::default(),
    };
    let settings = a.settings(base).map_err(failure)?;
    Ok((settings, a.given(section.map(|(_, e)| e))))
}

/// The campaign to read: a directory or a database's campaign.
fn place_of(a: &Args) -> Result<compose::Place, Failure> {
    match (&a.dir, a.store.database()?) {
        (Some(_), Some(_)) => Err(usage("give the campaign directory or --storage, not both")),
        (None, None) => Err(usage(
            "give the campaign directory (or --storage URL --campaign NAME)",
        )),
        (Some(dir), None) => Ok(compose::Place::Dir(dir.clone())),
        (None, Some((db, name))) => Ok(super::database::place(db, name)),
    }
}

/// Prints the outcome: the changed stopping rules, then the table (or `--json`).
fn print_outcome(a: &Args, outcome: &EstimateOutcome) -> Result<(), Failure> {
    for change in &outcome.changed_on_resume {
        eprintln!(
            "savme: resumed with a changed stopping rule (the runs drawn are the same): {change}"
        );
    }
    if a.json {
        return super::print(&outcome.summary_json()).map_err(Failure::Runtime);
    }
    super::print(&format!(
        "{}\nwritten to {}\n",
        outcome.table_md,
        super::shown_path(&outcome.out)
    ))
    .map_err(Failure::Runtime)
}

pub fn run(a: Args) -> Result<(), Failure> {
    let file = campaign_file(&a)?;
    let (settings, given) = settings_of(&a, file.as_ref())?;
    let place = place_of(&a)?;
    let source = place.source();
    let protocol = source
        .protocol()
        .map_err(|e| Failure::Runtime(e.to_string()))?;
    if let (Some(c), Some(path)) = (&file, &a.config) {
        same_campaign(path, &c.protocol, &protocol, &source.location())?;
        // The φ-spaces the campaign ran with (kept beside a campaign in a directory; without
        // the `postgres` feature a directory is the only place).
        #[cfg_attr(not(feature = "postgres"), allow(irrefutable_let_patterns))]
        if let compose::Place::Dir(dir) = &place {
            let scenarios = &c.file.common().scenarios;
            super::phi::check(dir, path, &scenarios.spaces, &scenarios.openscenario)?;
        }
    }
    // The nominals the campaign file's OpenSCENARIO files declare, under the flags' and
    // the [estimate] section's.
    let settings = match &file {
        Some(c) => settings.with_declared(
            &c.file.common().scenarios.nominal,
            &protocol.train_scenarios,
        ),
        None => settings,
    };
    let hint = resume_hint(&a);
    let display = std::cell::RefCell::new(Progress::new(a.quiet));
    let configured = |problem: Problem| {
        let run = EstimateRun::new(place.source(), problem, settings.clone())
            .stop_on(super::signals::stop_on_signals(&hint))
            .progress(|p| display.borrow_mut().show(p))
            .resume(a.resume)
            .given(given.iter().copied())
            .jobs(
                a.jobs
                    .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get())),
            );
        match &a.out {
            Some(out) => run.out(out),
            None => run,
        }
    };
    let outcome = match file {
        Some(c) => {
            let sim = c.file.simulator(&super::worker_command)?;
            configured(c.problem).run(&sim)
        }
        None => {
            let sim = compose::bundled_simulator(&protocol).map_err(|_| {
                usage(format!(
                    "the campaign ran on `{}`, not the bundled simulator: give --config FILE (its campaign file)",
                    protocol.simulator
                ))
            })?;
            configured(Problem::from(savme_sim::problem(protocol.fidelity_bins))).run(&sim)
        }
    }
    .map_err(|e| {
        display.borrow_mut().finish();
        interrupted(e, &hint).unwrap_or_else(failure)
    })?;
    display.borrow_mut().finish();
    print_outcome(&a, &outcome)
}
