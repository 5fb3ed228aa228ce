//! `savme run --config campaign.toml`: the paper's protocol on FMUs the user names, and
//! `savme fmu pack`: the bundled simulator as an FMU.
//!
//! A campaign file names the HF and LF FMUs, how runs execute (stop time, step size, failure
//! signal, cost, isolation), the fidelity space with θ_HF and the scenarios with their
//! parameters — each bound to an FMU variable by name. [`savme_fmu::campaign_file`] reads and
//! checks it against the FMUs; this module applies its `[campaign]` section to the paper's
//! protocol. Every error names the file, the line and the key. See `examples/fmu/campaign.toml`.

use crate::campaign::{
    self, CampaignError, CampaignOutcome, Cost, OnError, Options, Problem, Protocol,
};
use savme_fmu::campaign_file::{self, CampaignFile};
use savme_fmu::worker::{IsolatedSimulator, WorkerInit};
use savme_fmu::FmuSimulator;
use savme_kernel::{Assignment, Role, SimError, SimResult, Simulator};
use std::path::{Path, PathBuf};
use std::time::Duration;

pub use savme_fmu::campaign_file::ConfigError;

/// A loaded campaign: protocol, problem, how to build its simulator, and where to write.
#[derive(Debug)]
pub struct Campaign {
    /// The protocol.
    pub protocol: Protocol,
    /// The spaces.
    pub problem: Problem,
    /// What the worker processes (or the in-process simulator) are built from.
    pub init: WorkerInit,
    /// Run each evaluation in a worker process.
    pub isolate: bool,
    /// Per-run timeout with isolation.
    pub timeout: Duration,
    /// The output directory named in the file (relative to it), if any.
    pub out: Option<PathBuf>,
}

impl Campaign {
    /// Reads and checks `path`: the TOML, then the FMUs (opened, every binding and signal
    /// type-checked against both), then the protocol its `[campaign]` section gives.
    pub fn load(path: &Path) -> Result<Campaign, ConfigError> {
        let file = CampaignFile::load(path, &|bins| {
            (
                savme_kernel::paper::fidelity_space(bins),
                savme_kernel::paper::theta_hf(),
            )
        })?;
        let protocol = protocol(&file)?;
        Ok(Campaign {
            protocol,
            problem: Problem {
                fidelity: file.fidelity,
                theta_hf: file.theta_hf,
                scenarios: file.scenarios,
            },
            init: file.init,
            isolate: file.isolate,
            timeout: file.timeout,
            out: file.campaign.out,
        })
    }
}

/// The paper's protocol with the file's `[campaign]` settings, validated; an error names the
/// key (and its line when the file gives it).
fn protocol(file: &CampaignFile) -> Result<Protocol, ConfigError> {
    let c = &file.campaign;
    let mut p = Protocol::paper(&file.label, file.train.clone(), file.test.clone());
    let set = |slot: &mut u64, v: Option<u64>| {
        if let Some(v) = v {
            *slot = v;
        }
    };
    set(&mut p.seed, c.seed);
    if let Some(b) = &c.budgets {
        p.budgets = b.clone();
    }
    set(&mut p.train_iterations, c.train_iterations);
    set(&mut p.eval_iterations, c.eval_iterations);
    set(&mut p.test_iterations, c.test_iterations);
    set(
        &mut p.baseline_train_iterations,
        c.baseline_train_iterations,
    );
    set(&mut p.baseline_test_iterations, c.baseline_test_iterations);
    if let Some(bins) = c.fidelity_bins {
        p.fidelity_bins = bins;
    }
    if let Some(cost) = c.cost {
        p.cost = match cost {
            campaign_file::Cost::Wall => Cost::Wall,
            campaign_file::Cost::Work => Cost::Work,
        };
    }
    if let Some(w) = c.window {
        p.window = w;
    }
    if let Some(s) = c.prior_strength {
        p.prior_strength = s;
    }
    p.weights = file.weights.clone();
    p.on_error = if file.skip_failed_runs {
        OnError::Skip
    } else {
        OnError::Abort
    };
    let err = |line, key: Option<String>, message| ConfigError {
        file: file.path.display().to_string(),
        line,
        key,
        message,
    };
    p.validate().map_err(|e| match e {
        CampaignError::Protocol { field, message } => match field.as_str() {
            "train_scenarios" | "test_scenarios" => {
                err(None, Some("scenario.role".into()), message)
            }
            "weights" => err(None, Some("scenario.weight".into()), message),
            other => err(
                c.lines.get(other).copied(),
                Some(format!("campaign.{other}")),
                message,
            ),
        },
        other => err(None, None, other.to_string()),
    })?;
    Ok(p)
}

/// The simulator a campaign runs on: in-process, or in worker processes.
#[derive(Debug, Clone)]
pub enum FmuBackend {
    /// In this process.
    InProcess(FmuSimulator),
    /// In `savme fmu-worker` child processes.
    Isolated(IsolatedSimulator),
}

impl Simulator for FmuBackend {
    fn simulate(
        &mut self,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
    ) -> Result<SimResult, SimError> {
        match self {
            FmuBackend::InProcess(s) => s.simulate(scenario, phi, fidelity),
            FmuBackend::Isolated(s) => s.simulate(scenario, phi, fidelity),
        }
    }

    fn simulate_as(
        &mut self,
        role: Role,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
    ) -> Result<SimResult, SimError> {
        match self {
            FmuBackend::InProcess(s) => s.simulate_as(role, scenario, phi, fidelity),
            FmuBackend::Isolated(s) => s.simulate_as(role, scenario, phi, fidelity),
        }
    }
}

/// Runs `savme run --config FILE`: loads and checks the campaign, then runs (or resumes) it;
/// returns the outcome and the campaign's problem (for printing its fidelity table).
pub fn run(
    config: &Path,
    out: Option<PathBuf>,
    resume: bool,
    jobs: Option<usize>,
    quiet: bool,
    record: &crate::recording::RecordRequest,
) -> Result<(CampaignOutcome, Problem), String> {
    let c = Campaign::load(config).map_err(|e| e.to_string())?;
    let out = out
        .or(c.out.clone())
        .unwrap_or_else(|| PathBuf::from("savme-fmu-results"));
    let backend = if c.isolate {
        let exe = std::env::current_exe()
            .map_err(|e| format!("cannot find the savme binary for the FMU workers: {e}"))?;
        FmuBackend::Isolated(
            IsolatedSimulator::new(
                vec![exe.display().to_string(), "fmu-worker".into()],
                &c.init,
                c.timeout,
            )
            .map_err(|e| e.to_string())?,
        )
    } else {
        FmuBackend::InProcess(c.init.simulator().map_err(|e| e.to_string())?)
    };
    let mut opts = Options::new(out);
    opts.resume = resume;
    opts.quiet = quiet;
    if let Some(j) = jobs {
        if j == 0 {
            return Err("--jobs: must be at least 1".into());
        }
        opts.jobs = j;
    }
    // Trials of scenarios the bundled simulator knows (the packed savme-sim FMU's) get sensor
    // frames, re-run in-process; the learning is recorded for any FMU.
    let recording = crate::recording::start(
        record,
        savme_sim::sim::DrivingSimulator::default(),
        c.problem.theta_hf.clone(),
    )
    .map_err(|e| e.to_string())?;
    let outcome = match recording {
        None => campaign::run(&c.protocol, &c.problem, &backend, &opts),
        Some(mut r) => {
            let result =
                campaign::run_observed(&c.protocol, &c.problem, &backend, &opts, r.observer());
            r.finish().map_err(|e| e.to_string())?;
            result
        }
    }
    .map_err(|e| e.to_string())?;
    Ok((outcome, c.problem))
}

/// Where the bundled simulator's FMU library is: given, or next to the savme binary (cargo
/// builds it there as `deps/libsavme_sim_fmu.so`).
pub fn find_library(given: Option<&Path>) -> Result<PathBuf, String> {
    if let Some(p) = given {
        return if p.exists() {
            Ok(p.to_path_buf())
        } else {
            Err(format!("{}: no such library", p.display()))
        };
    }
    let name = format!(
        "{}{}{}",
        std::env::consts::DLL_PREFIX,
        savme_sim_fmu::MODEL_IDENTIFIER,
        std::env::consts::DLL_SUFFIX
    );
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    let dir = exe.parent().unwrap_or(Path::new("."));
    let candidates = [
        dir.join(&name),
        dir.join("deps").join(&name),
        dir.join("..").join(&name),
    ];
    candidates
        .iter()
        .find(|p| p.exists())
        .cloned()
        .ok_or_else(|| {
            format!(
                "{name} not found next to {} (build it with `cargo build --release -p savme-sim-fmu`, or give --library PATH)",
                exe.display()
            )
        })
}

/// `savme fmu pack`: writes the bundled simulator as an `.fmu`.
pub fn pack(out: &Path, library: Option<&Path>) -> Result<String, String> {
    let lib = find_library(library)?;
    savme_fmi_export::pack(
        &savme_sim_fmu::model_description(),
        savme_sim_fmu::MODEL_IDENTIFIER,
        &lib,
        out,
    )
    .map_err(|e| e.to_string())?;
    Ok(format!(
        "wrote {} (library {})\n",
        out.display(),
        lib.display()
    ))
}

/// Re-exported for the worker subcommand.
pub fn serve_worker() -> std::io::Result<()> {
    savme_fmu::worker::serve(std::io::stdin().lock(), std::io::stdout().lock())
}
