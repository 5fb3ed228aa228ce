//! `savme scenarios`: the bundled simulator's scenarios with their parameter spaces, as text
//! or (`--json`) as JSON.

use savme::kernel::Domain;
use savme_sim::scenario::{self, ScenarioInfo, SCENARIOS};

#[derive(clap::Args)]
pub struct Args {
    /// Print the scenarios as JSON (one document; units given per parameter).
    #[arg(long)]
    json: bool,
}

pub fn run(a: Args) -> Result<(), String> {
    if a.json {
        super::print(&(scenarios_json().to_string() + "\n"))
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

/// `savme scenarios --json`.
fn scenarios_json() -> serde_json::Value {
    let scenarios: Vec<_> = SCENARIOS
        .iter()
        .map(|info| {
            serde_json::json!({
                "id": info.id,
                "name": info.name,
                "role": role(info),
                "duration_s": info.duration,
                "description": info.description,
                "parameters": scenario::phi_space(info).variables().iter().map(|v| {
                    let mut p = serde_json::to_value(v).unwrap_or_default();
                    if let Some(o) = p.as_object_mut() {
                        o.insert("unit".into(), scenario::unit(&v.name).into());
                    }
                    p
                }).collect::<Vec<_>>(),
            })
        })
        .collect();
    serde_json::json!({ "format_version": 1, "scenarios": scenarios })
}
