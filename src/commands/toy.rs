//! `savme toy`: the paper's protocol on the toy simulator (a one-dimensional braking model
//! that runs in microseconds) — to try savme, and to try and benchmark distribution:
//! `--sleep-ms N` makes every run sleep N ms first, like a slow vendor simulator that uses no
//! CPU; `--null` runs nothing at all.

use super::{
    config_failure, resume_dir, run_campaign, run_repeated, stored_protocol, usage,
    CampaignStorageArgs, Failure, ProtocolArgs, RunnerArgs, Target,
};
use savme::adapter::simulator_of_label;
use savme::campaign::config::{self, toy_label, NULL};
use savme::campaign::store::TrialStore;
use savme::campaign::{load_protocol, load_repeat, Cost};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Output directory (default savme-toy-results).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Continue the campaign in DIR; with --storage, the database's campaign (no DIR).
    #[arg(long, value_name = "DIR", num_args = 0..=1)]
    resume: Option<Option<PathBuf>>,
    /// Every run sleeps this many milliseconds first (default 0).
    #[arg(long, value_name = "MS", conflicts_with = "null")]
    sleep_ms: Option<u64>,
    /// The null simulator: every run passes at once (measures savme's own cost). Its runs
    /// take no time, so its cost is work units (--cost work, the default with --null).
    #[arg(long)]
    null: bool,
    #[command(flatten)]
    protocol: ProtocolArgs,
    #[command(flatten)]
    storage: CampaignStorageArgs,
    #[command(flatten)]
    runner: RunnerArgs,
}

/// The end of `savme toy --help`: the protocol it runs without protocol flags (the quick
/// preset on the toy scenarios), read from the preset itself.
pub fn defaults_help() -> String {
    match config::toy(config::TOY, &Default::default()) {
        Ok((p, _)) => {
            let budgets: Vec<String> = p.budgets.iter().map(f64::to_string).collect();
            format!(
                "Without protocol flags: the quick preset — seed {}, budgets {}; per budget {} \
                 meta-training iterations, {} evaluation trials and {} meta-testing iterations per \
                 prior; baselines of {} and {} trials ({} trials in all); meta-training on {}, \
                 meta-testing on {}. Each protocol flag overrides one of these values.",
                p.seed,
                budgets.join(","),
                p.train_iterations,
                p.eval_iterations,
                p.test_iterations,
                p.baseline_train_iterations,
                p.baseline_test_iterations,
                p.total_trials(),
                p.train_scenarios.join(", "),
                p.test_scenarios.join(", ")
            )
        }
        Err(e) => format!("(the toy preset does not build: {e})"),
    }
}

/// The longest `--sleep-ms` a run may take: one hour (a larger value would make a run that
/// never ends in practice; 2⁶⁴ − 1 ms is 585 million years).
pub const MAX_SLEEP_MS: u64 = 3_600_000;

pub fn run(a: Args) -> Result<(), Failure> {
    if let Some(ms) = a.sleep_ms.filter(|&ms| ms > MAX_SLEEP_MS) {
        return Err(usage(format!(
            "--sleep-ms: {ms} ms per run is more than the maximum, {MAX_SLEEP_MS} ms (one hour)"
        )));
    }
    let mut overrides = a.protocol.overrides();
    let store = a.storage.open()?;
    let remote = a.storage.remote(store.as_ref())?;
    let resume = resume_dir(a.resume, a.out.as_deref(), store.is_some())?;
    if resume.is_some() && overrides.any() {
        return Err(usage("protocol: `--resume`: a resumed campaign keeps its protocol; give only --resume, --out, --storage, --campaign, --remote, --jobs and --quiet"));
    }
    if resume.is_some() && (a.null || a.sleep_ms.is_some()) {
        return Err(usage(
            "--resume: a resumed campaign keeps its simulator; give neither --null nor --sleep-ms",
        ));
    }
    if a.null && resume.is_none() {
        // A null run takes no measurable time: the kernel refuses a wall-clock cost of 0.
        match overrides.cost {
            Some(Cost::Wall) => {
                return Err(usage("--null: its runs take no time, so they have no wall-clock cost: give --cost work (the default with --null)"));
            }
            Some(Cost::Work) => {}
            None => overrides.cost = Some(Cost::Work),
        }
    }
    let label = if a.null {
        NULL.to_string()
    } else {
        toy_label(a.sleep_ms.unwrap_or(0))
    };
    // `--repeat N` runs N seeds as `reproduce` and `run` do (it was ignored here); a resumed
    // repeated campaign keeps its count.
    let mut repeat = config::check_repeat(overrides.repeat).map_err(config_failure)?;
    let mut store = store;
    let protocol = match (&resume, store.as_mut()) {
        (Some(dir), None) => Some(match load_repeat(dir).map_err(|e| e.to_string())? {
            Some(file) => {
                repeat = Some(file.repeat);
                file.protocol
            }
            None => load_protocol(dir).map_err(|e| e.to_string())?,
        }),
        (Some(_), Some(s)) => Some(stored_protocol(s)?),
        (None, _) => None,
    };
    let label = protocol.as_ref().map_or(label, |p| p.simulator.clone());
    let (fresh, problem) = config::toy(&label, &overrides).map_err(config_failure)?;
    let protocol = protocol.unwrap_or(fresh);
    let sim = simulator_of_label(&protocol.simulator)
        .ok_or_else(|| format!("`{}` is not a toy simulator", protocol.simulator))?;
    let out = a.out.unwrap_or_else(|| PathBuf::from("savme-toy-results"));
    let target = Target {
        out: match &resume {
            Some(dir) if store.is_none() => dir.clone(),
            _ => out,
        },
        resume: resume.is_some(),
        store: store.map(|s| Box::new(s) as Box<dyn TrialStore>),
        remote,
        hint: None,
    };
    if let Some(n) = repeat {
        return run_repeated(protocol, problem, n, target, &a.runner, &sim);
    }
    let frames = savme::adapter::frames_of_label(&protocol.simulator);
    run_campaign(protocol, problem, target, &a.runner, frames, &sim)
}
