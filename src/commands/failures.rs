//! `savme failures DIR`: every HF failure a campaign found — stage, trial, scenario, φ, what
//! the LF run said — as a table or (`--json`) one JSON object per line, each with the
//! `savme simulate` command that replays it when the campaign ran the bundled camera/lidar
//! simulator.

use super::Failure;
use savme::campaign::config::SENSORS;
use savme::campaign::load_protocol;
use savme::campaign::log::read_dir_lines;
use savme::campaign::report::failures::{as_flag, found_failures, hf_runs, Filter, FoundFailure};
use std::fmt::Write as _;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The campaign directory (the `--out` of savme reproduce or savme run).
    campaign: PathBuf,
    /// Only the failures of this stage (e.g. baseline-train, train@0.3, screen@0.3);
    /// repeatable.
    #[arg(long = "stage", value_name = "STAGE")]
    stages: Vec<String>,
    /// Only the failures of this scenario; repeatable.
    #[arg(long = "scenario", value_name = "NAME")]
    scenarios: Vec<String>,
    /// One JSON object per failure and line (stage, index, id, scenario, phi, theta_lf,
    /// lf_failure, outcome, hf_runtime, replay).
    #[arg(long)]
    json: bool,
}

pub fn run(a: Args) -> Result<(), Failure> {
    let runtime = |e: savme::campaign::CampaignError| Failure::Runtime(e.to_string());
    let protocol = load_protocol(&a.campaign).map_err(runtime)?;
    let labels: Vec<String> = protocol.stages().iter().map(|s| s.label()).collect();
    let scenarios = [&protocol.train_scenarios[..], &protocol.test_scenarios[..]].concat();
    for s in &a.stages {
        if !labels.contains(s) {
            return Err(Failure::Usage(format!(
                "--stage `{s}`: the campaign has no such stage (its stages: {})",
                labels.join(", ")
            )));
        }
    }
    for s in &a.scenarios {
        if !scenarios.contains(s) {
            return Err(Failure::Usage(format!(
                "--scenario `{s}`: the campaign has no such scenario (its scenarios: {})",
                scenarios.join(", ")
            )));
        }
    }
    let lines: Vec<_> = read_dir_lines(&a.campaign)
        .map_err(runtime)?
        .into_iter()
        .map(|(_, l)| l)
        .collect();
    let hf_runs = hf_runs(&lines);
    let filter = Filter {
        stages: a.stages,
        scenarios: a.scenarios,
    };
    let found = found_failures(&lines, &filter);
    // Only the bundled camera/lidar simulator is what `savme simulate` runs.
    let replay = |f: &FoundFailure| {
        (protocol.simulator == SENSORS).then(|| {
            format!(
                "savme simulate --scenario {} --phi {}",
                f.scenario,
                as_flag(&f.phi)
            )
        })
    };
    let text = if a.json {
        json_lines(&found, replay)?
    } else {
        table(&found, hf_runs, &a.campaign, replay)
    };
    super::print(&text).map_err(Failure::Runtime)
}

fn json_lines(
    found: &[FoundFailure],
    replay: impl Fn(&FoundFailure) -> Option<String>,
) -> Result<String, Failure> {
    let mut out = String::new();
    for f in found {
        let mut v = serde_json::to_value(f).map_err(|e| Failure::Runtime(e.to_string()))?;
        v["replay"] = replay(f).into();
        let _ = writeln!(out, "{v}");
    }
    Ok(out)
}

fn table(
    found: &[FoundFailure],
    hf_runs: usize,
    dir: &std::path::Path,
    replay: impl Fn(&FoundFailure) -> Option<String>,
) -> String {
    let mut out = format!(
        "{} HF failures in {} (of {hf_runs} HF runs in all its stages)\n",
        found.len(),
        dir.display()
    );
    for f in found {
        let lf = match f.lf_failure {
            Some(true) => "LF failed too",
            Some(false) => "LF missed it",
            None => "HF only",
        };
        let _ = writeln!(
            out,
            "{} #{}  {}  {}  [{lf}]",
            f.stage, f.index, f.scenario, f.phi
        );
        if let Some(r) = replay(f) {
            let _ = writeln!(out, "    {r}");
        }
    }
    out
}
