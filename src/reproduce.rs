//! `savme reproduce`: the paper's protocol on the bundled driving simulator, from command-line
//! arguments to printed tables.

use crate::campaign::{self, CampaignError, CampaignOutcome, Cost, Options, Protocol};
use savme_sim::sim::DrivingSimulator;
use std::fmt::Write as _;
use std::path::PathBuf;

/// The simulator label of the bundled simulator with camera + lidar perception.
pub const SENSORS: &str = "savme-sim/sensors";
/// The simulator label of the bundled simulator with idealised perception.
pub const IDEAL: &str = "savme-sim/ideal";

/// What the command line may change about the protocol (None: keep the preset's value).
#[derive(Debug, Clone, Default)]
pub struct Overrides {
    /// `--quick`: start from the quick preset instead of the paper's protocol.
    pub quick: bool,
    /// `--seed`.
    pub seed: Option<u64>,
    /// `--cost`.
    pub cost: Option<Cost>,
    /// `--budgets`.
    pub budgets: Option<Vec<f64>>,
    /// `--iterations` (meta-training).
    pub train_iterations: Option<u64>,
    /// `--eval-iterations`.
    pub eval_iterations: Option<u64>,
    /// `--test-iterations`.
    pub test_iterations: Option<u64>,
    /// `--baseline-iterations`.
    pub baseline_train_iterations: Option<u64>,
    /// `--baseline-test-iterations`.
    pub baseline_test_iterations: Option<u64>,
    /// `--train-scenarios` (numbers or names).
    pub train_scenarios: Option<Vec<String>>,
    /// `--test-scenarios`.
    pub test_scenarios: Option<Vec<String>>,
    /// `--perception ideal` (default: sensors).
    pub ideal: bool,
    /// `--window`.
    pub window: Option<usize>,
}

impl Overrides {
    /// True when any value that decides the campaign's trials was given.
    pub fn any(&self) -> bool {
        self.quick
            || self.seed.is_some()
            || self.cost.is_some()
            || self.budgets.is_some()
            || self.train_iterations.is_some()
            || self.eval_iterations.is_some()
            || self.test_iterations.is_some()
            || self.baseline_train_iterations.is_some()
            || self.baseline_test_iterations.is_some()
            || self.train_scenarios.is_some()
            || self.test_scenarios.is_some()
            || self.ideal
            || self.window.is_some()
    }
}

/// Scenario numbers (1–10) or names → names; unknown ones are an error naming them.
pub fn scenario_names(keys: &[String]) -> Result<Vec<String>, CampaignError> {
    keys.iter()
        .map(|k| {
            savme_sim::scenario::find(k.trim())
                .map(|s| s.name.to_string())
                .ok_or_else(|| CampaignError::UnknownScenario {
                    name: k.trim().into(),
                    known: "1–10 or their names (see `savme scenarios`)".into(),
                })
        })
        .collect()
}

/// The protocol the arguments ask for, validated.
pub fn protocol(o: &Overrides) -> Result<Protocol, CampaignError> {
    let (train, test) = campaign::driving_scenarios();
    let simulator = if o.ideal { IDEAL } else { SENSORS };
    let mut p = if o.quick {
        Protocol::quick(simulator, train, test)
    } else {
        Protocol::paper(simulator, train, test)
    };
    if let Some(v) = o.seed {
        p.seed = v;
    }
    if let Some(v) = o.cost {
        p.cost = v;
    }
    if let Some(v) = &o.budgets {
        p.budgets = v.clone();
    }
    if let Some(v) = o.train_iterations {
        p.train_iterations = v;
    }
    if let Some(v) = o.eval_iterations {
        p.eval_iterations = v;
    }
    if let Some(v) = o.test_iterations {
        p.test_iterations = v;
    }
    if let Some(v) = o.baseline_train_iterations {
        p.baseline_train_iterations = v;
    }
    if let Some(v) = o.baseline_test_iterations {
        p.baseline_test_iterations = v;
    }
    if let Some(v) = &o.train_scenarios {
        p.train_scenarios = scenario_names(v)?;
    }
    if let Some(v) = &o.test_scenarios {
        p.test_scenarios = scenario_names(v)?;
    }
    if let Some(v) = o.window {
        p.window = v;
    }
    p.validate()?;
    Ok(p)
}

/// The bundled simulator a protocol was run with.
pub fn simulator(p: &Protocol) -> Result<DrivingSimulator, CampaignError> {
    match p.simulator.as_str() {
        SENSORS => Ok(DrivingSimulator::default()),
        IDEAL => Ok(DrivingSimulator::ideal()),
        other => Err(CampaignError::Protocol {
            field: "simulator".into(),
            message: format!("`{other}` is not the bundled simulator ({SENSORS} or {IDEAL})"),
        }),
    }
}

/// Runs `savme reproduce`: a new campaign into `out`, or (with `resume`) the campaign in
/// `out` continued.
pub fn run(
    overrides: &Overrides,
    out: PathBuf,
    resume: bool,
    jobs: Option<usize>,
    quiet: bool,
    record: &crate::recording::RecordRequest,
) -> Result<CampaignOutcome, CampaignError> {
    let p = if resume {
        if overrides.any() {
            return Err(CampaignError::Protocol {
                field: "--resume".into(),
                message: "a resumed campaign keeps its protocol (protocol.json); give only --resume, --jobs and --quiet".into(),
            });
        }
        campaign::load_protocol(&out)?
    } else {
        protocol(overrides)?
    };
    let sim = simulator(&p)?;
    let mut opts = Options::new(out);
    opts.resume = resume;
    opts.quiet = quiet;
    if let Some(j) = jobs {
        if j == 0 {
            return Err(CampaignError::Protocol {
                field: "--jobs".into(),
                message: "must be at least 1".into(),
            });
        }
        opts.jobs = j;
    }
    let problem = campaign::Problem::driving(p.fidelity_bins);
    match crate::recording::start(record, sim, problem.theta_hf.clone())? {
        None => campaign::run(&p, &problem, &sim, &opts),
        Some(mut recorder) => {
            let result = campaign::run_observed(&p, &problem, &sim, &opts, recorder.observer());
            // Close the recording whatever happened, so the file gets its footer.
            recorder.finish()?;
            result
        }
    }
}

/// What `savme reproduce` (and `savme run`) print at the end.
pub fn summary_text(
    o: &CampaignOutcome,
    fidelity: &savme_kernel::Space,
    theta_hf: &savme_kernel::Assignment,
) -> String {
    let mut s = String::new();
    let r = &o.report;
    let _ = writeln!(s, "{}", r.table_md());
    let _ = writeln!(s, "{}", r.fidelity_md(fidelity, theta_hf));
    let _ = writeln!(s, "{}", r.findings_text());
    let _ = writeln!(
        s,
        "{} trials ({} replayed from trials.jsonl, {} run) in {:.1} s; outputs in {}",
        o.replayed + o.ran,
        o.replayed,
        o.ran,
        o.elapsed_seconds,
        o.outputs
            .table
            .parent()
            .map_or_else(|| ".".into(), |p| p.display().to_string())
    );
    s
}
