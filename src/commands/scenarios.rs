//! `savme scenarios`: the bundled simulator's scenarios with their parameter spaces, as text
//! or (`--json`) as JSON.

use savme::json;
use savme::kernel::Domain;
use savme_sim::scenario::{self, ScenarioInfo, SCENARIOS};

#[derive(clap::Args)]
pub struct Args {
    /// Print the scenarios as JSON (one document; units given per parameter; schema:
    /// docs/schemas/scenarios.schema.json).
    #[arg(long)]
    json: bool,
}

pub fn run(a: Args) -> Result<(), String> {
    if a.json {
        super::print(&(serde_json::to_string(&scenarios_json()).map_err(|e| e.to_string())? + "\n"))
    } else {
        super::print(&scenarios_text())
    }
}

fn role(info: &ScenarioInfo) -> &'static str {
    if info.training() {
        "meta-training"
    } else {
        "meta-testing"
    }
}

/// `savme scenarios`: the listing.
fn scenarios_text() -> String {
    use std::fmt::Write;
    let mut out = String::new();
    for info in &SCENARIOS {
        let _ = writeln!(
            out,
            "{:>2}  {}  ({}, {} s of simulated driving)",
            info.id,
            info.name,
            role(info),
            info.duration
        );
        let _ = writeln!(out, "    {}", info.description);
        for v in scenario::phi_space(info).variables() {
            if let Domain::Continuous { lo, hi, bins, .. } = v.domain {
                let range = format!("[{lo}, {hi}] {}", scenario::unit(&v.name));
                let _ = writeln!(out, "    {:<18} {range:<18} in {bins} bins", v.name);
            }
        }
    }
    out
}

/// `savme scenarios --json` (schema: docs/schemas/scenarios.schema.json).
fn scenarios_json() -> json::ScenarioList {
    let scenarios = SCENARIOS
        .iter()
        .map(|info| json::Scenario {
            id: info.id,
            name: info.name.to_string(),
            role: if info.training() {
                json::Role::MetaTraining
            } else {
                json::Role::MetaTesting
            },
            duration_s: info.duration,
            description: info.description.to_string(),
            parameters: scenario::phi_space(info)
                .variables()
                .iter()
                .map(|v| json::Parameter {
                    name: v.name.to_string(),
                    domain: v.domain.clone(),
                    unit: scenario::unit(&v.name).to_string(),
                })
                .collect(),
        })
        .collect();
    json::ScenarioList {
        format_version: json::FORMAT_VERSION,
        scenarios,
    }
}
