//! `savme failures DIR`: every HF failure a campaign found — stage, trial, scenario, φ, what
//! the LF run said — as a table or (`--json`) one JSON object per line, each with the
//! `savme simulate` command that replays it when the campaign ran the bundled camera/lidar
//! simulator. The campaign is a directory or (`--storage URL --campaign NAME`) a database's.

use super::Failure;
use savme::campaign::log::LogLine;
use savme::campaign::report::failures::{as_flag, found_failures, hf_runs, Filter, FoundFailure};
use savme::campaign::{CampaignError, Protocol};
use savme::compose::{Place, IDEAL, SENSORS};
use std::fmt::Write as _;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The campaign directory (the `--out` of savme reproduce or savme run); or give
    /// --storage URL --campaign NAME for a campaign kept in PostgreSQL.
    #[arg(value_name = "DIR")]
    dir: Option<PathBuf>,
    #[command(flatten)]
    store: super::StorageArgs,
    /// Only the failures of this stage (e.g. baseline-train, train@0.3, screen@0.3);
    /// repeatable.
    #[arg(long = "stage", value_name = "STAGE")]
    stages: Vec<String>,
    /// Only the failures of this scenario; repeatable.
    #[arg(long = "scenario", value_name = "NAME")]
    scenarios: Vec<String>,
    /// One JSON object per failure and line (format_version, stage, index, id, scenario, phi,
    /// theta_lf, lf_failure, outcome, hf_runtime, replay, replay_unavailable; schema:
    /// docs/schemas/failures-line.schema.json).
    #[arg(long)]
    json: bool,
}

/// The campaign's protocol and lines, from its directory or its database (read without the
/// coordinator's lock: a running campaign can be listed), and how to name it.
fn campaign(a: &Args) -> Result<(Protocol, Vec<LogLine>, String), Failure> {
    let runtime = |e: CampaignError| Failure::Runtime(e.to_string());
    let place = match (&a.dir, a.store.database()?) {
        (Some(_), Some(_)) => {
            return Err(Failure::Usage(
                "give the campaign directory or --storage, not both".into(),
            ))
        }
        (None, None) => {
            return Err(Failure::Usage(
                "give the campaign directory (or --storage URL --campaign NAME)".into(),
            ))
        }
        (Some(dir), None) => Place::Dir(dir.clone()),
        (None, Some((db, name))) => super::database::place(db, name),
    };
    let source = place.source();
    let read = || -> Result<_, CampaignError> { Ok((source.protocol()?, source.lines()?)) };
    let (protocol, lines) = match &place {
        #[cfg(feature = "postgres")]
        Place::Database(db, _) => super::storage::connecting(db, read),
        Place::Dir(_) => read(),
    }
    .map_err(runtime)?;
    let lines = lines.into_iter().map(|(_, l)| l).collect();
    Ok((protocol, lines, source.location()))
}

pub fn run(a: Args) -> Result<(), Failure> {
    let (protocol, lines, place) = campaign(&a)?;
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
    let hf_runs = hf_runs(&lines);
    let filter = Filter {
        stages: a.stages,
        scenarios: a.scenarios,
    };
    let found = found_failures(&lines, &filter);
    // `savme simulate` runs the bundled simulator, with either perception.
    let perception = match protocol.simulator.as_str() {
        SENSORS => Some(""),
        IDEAL => Some(" --perception ideal"),
        _ => None,
    };
    let replay = |f: &FoundFailure| {
        perception.map(|p| {
            format!(
                "savme simulate --scenario {} --phi {}{p}",
                f.scenario,
                as_flag(&f.phi)
            )
        })
    };
    let unavailable = perception.is_none().then(|| {
        format!(
            "the campaign ran simulator `{}`; `savme simulate` replays only the bundled driving simulator's runs ({SENSORS}, {IDEAL})",
            protocol.simulator
        )
    });
    let text = if a.json {
        json_lines(&found, replay, unavailable.as_deref())?
    } else {
        table(&found, hf_runs, &place, replay, unavailable.as_deref())
    };
    super::print(&text).map_err(Failure::Runtime)
}

fn json_lines(
    found: &[FoundFailure],
    replay: impl Fn(&FoundFailure) -> Option<String>,
    unavailable: Option<&str>,
) -> Result<String, Failure> {
    let mut out = String::new();
    for f in found {
        let line = savme::json::FailureLine {
            format_version: savme::json::FORMAT_VERSION,
            failure: f.clone(),
            replay: replay(f),
            replay_unavailable: unavailable.map(str::to_string),
        };
        let v = serde_json::to_string(&line).map_err(|e| Failure::Runtime(e.to_string()))?;
        let _ = writeln!(out, "{v}");
    }
    Ok(out)
}

fn table(
    found: &[FoundFailure],
    hf_runs: usize,
    place: &str,
    replay: impl Fn(&FoundFailure) -> Option<String>,
    unavailable: Option<&str>,
) -> String {
    let mut out = format!(
        "{} HF failures in {} (of {hf_runs} HF runs in all its stages)\n",
        found.len(),
        place
    );
    if let (Some(why), false) = (unavailable, found.is_empty()) {
        let _ = writeln!(out, "(no replay commands: {why})");
    }
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
