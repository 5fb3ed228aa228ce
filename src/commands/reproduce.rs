//! `savme reproduce`: the paper's protocol on the bundled driving simulator.

use super::{
    config_failure, resume_dir, run_campaign, run_repeated, stored_protocol, usage,
    CampaignStorageArgs, Failure, ProtocolArgs, RunnerArgs, Target,
};
use savme::campaign::store::TrialStore;
use savme::campaign::{load_protocol, load_repeat, Cost, Problem, Protocol};
use savme::compose::{self, Preset};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Output directory (default savme-results; created if missing; must not hold a campaign
    /// already, unless the campaign is kept in a database).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Continue the campaign in DIR after an interruption (even `kill -9`); with --storage,
    /// continue the database's campaign (no DIR).
    #[arg(long, value_name = "DIR", num_args = 0..=1)]
    resume: Option<Option<PathBuf>>,
    /// A short preset: one budget, fewer iterations (860 trials, about 100 CPU-seconds).
    #[arg(long)]
    quick: bool,
    /// Perception of the system under test: camera + lidar (the paper's), or idealised
    /// (fast, blind to the sensor settings).
    #[arg(long, value_enum, default_value = "sensors")]
    perception: Perception,
    #[command(flatten)]
    protocol: ProtocolArgs,
    #[command(flatten)]
    storage: CampaignStorageArgs,
    #[command(flatten)]
    runner: RunnerArgs,
}

#[derive(Clone, Copy, PartialEq, clap::ValueEnum)]
enum Perception {
    Sensors,
    Ideal,
}

/// The end of `savme reproduce --help`: the protocol run without protocol flags, and with
/// `--quick`, read from the presets themselves (so that the help cannot drift from them).
pub fn defaults_help() -> String {
    let (train, test) = savme_sim::scenario::train_test_names();
    let paper = Protocol::paper(compose::SENSORS, train.clone(), test.clone());
    let quick = Protocol::quick(compose::SENSORS, train, test);
    let stages = |p: &Protocol| {
        let budgets: Vec<String> = p.budgets.iter().map(f64::to_string).collect();
        format!(
            "budgets {}; per budget {} meta-training iterations, {} evaluation trials and {} \
             meta-testing iterations per prior (learned, uniform); baselines of {} and {} trials \
             ({} trials in all)",
            budgets.join(","),
            p.train_iterations,
            p.eval_iterations,
            p.test_iterations,
            p.baseline_train_iterations,
            p.baseline_test_iterations,
            p.total_trials()
        )
    };
    format!(
        "Without protocol flags: the paper's protocol — seed {}, cost {}, {} meta-training and {} \
         meta-testing scenarios (`savme scenarios`), {}.\n--quick: {}.\nEach protocol flag \
         overrides one of these values; the protocol a campaign ran is written to \
         OUT/protocol.json.",
        paper.seed,
        match paper.cost {
            Cost::Wall => "wall",
            Cost::Work => "work",
        },
        paper.train_scenarios.len(),
        paper.test_scenarios.len(),
        stages(&paper),
        stages(&quick)
    )
}

pub fn run(a: Args) -> Result<(), Failure> {
    let overrides = a.protocol.overrides();
    let preset = Preset {
        quick: a.quick,
        ideal: a.perception == Perception::Ideal,
    };
    let store = a.storage.open()?;
    let remote = a.storage.remote(store.as_ref())?;
    let resume = resume_dir(a.resume, a.out.as_deref(), store.is_some())?;
    if resume.is_some() && (overrides.any() || preset != Preset::default()) {
        return Err(usage("protocol: `--resume`: a resumed campaign keeps its protocol; give only --resume, --out, --storage, --campaign, --remote, --jobs and --quiet"));
    }
    let out = a.out.unwrap_or_else(|| PathBuf::from(DEFAULT_OUT));
    let mut repeat =
        savme::campaign::config::check_repeat(overrides.repeat).map_err(config_failure)?;
    let (protocol, target) = match (resume, store) {
        (Some(dir), None) => (
            match load_repeat(&dir).map_err(|e| e.to_string())? {
                Some(file) => {
                    repeat = Some(file.repeat);
                    file.protocol
                }
                None => load_protocol(&dir).map_err(|e| e.to_string())?,
            },
            Target {
                out: dir,
                resume: true,
                store: None,
                remote: None,
                hint: None,
            },
        ),
        (Some(_), Some(mut store)) => (
            stored_protocol(&mut store)?,
            Target {
                out,
                resume: true,
                store: Some(Box::new(store)),
                remote,
                hint: None,
            },
        ),
        (None, store) => (
            compose::bundled(preset, &overrides)
                .map_err(config_failure)?
                .0,
            Target {
                out,
                resume: false,
                store: store.map(|s| Box::new(s) as Box<dyn TrialStore>),
                remote,
                hint: None,
            },
        ),
    };
    let problem = Problem::from(savme_sim::problem(protocol.fidelity_bins));
    let sim = compose::bundled_simulator(&protocol).map_err(|e| e.to_string())?;
    if let Some(n) = repeat {
        return run_repeated(protocol, problem, n, target, &a.runner, &sim);
    }
    // Recorded trials show what the simulator's adapter offers (the bundled trial view).
    let frames = savme::adapter::frames_of_label(&protocol.simulator);
    run_campaign(protocol, problem, target, &a.runner, frames, &sim)
}

const DEFAULT_OUT: &str = "savme-results";
