//! `savme fidelity`: the 16 fidelity settings (the paper's Table II) with their θ_HF values.

use savme::json;
use savme::kernel::Domain;
use savme_sim::fidelity;

#[derive(clap::Args)]
pub struct Args {
    /// Print the settings as JSON (with θ_HF and units; schema:
    /// docs/schemas/fidelity.schema.json).
    #[arg(long)]
    json: bool,
}

pub fn run(a: Args) -> Result<(), String> {
    if a.json {
        super::print(&(serde_json::to_string(&fidelity_json()).map_err(|e| e.to_string())? + "\n"))
    } else {
        super::print(&fidelity_text())
    }
}

/// `savme fidelity --json` (schema: docs/schemas/fidelity.schema.json): every setting as the
/// kernel writes a variable, with its unit and θ_HF value.
fn fidelity_json() -> json::FidelityList {
    let hf = fidelity::theta_hf();
    let settings = fidelity::space(10)
        .variables()
        .iter()
        .map(|v| json::Setting {
            name: v.name.to_string(),
            domain: v.domain.clone(),
            unit: fidelity::unit(&v.name).map(str::to_owned),
            hf: hf.get(&v.name).cloned(),
        })
        .collect();
    json::FidelityList {
        format_version: json::FORMAT_VERSION,
        settings,
    }
}

/// `savme fidelity`: the 16 fidelity settings of Table II with their θ_HF values.
fn fidelity_text() -> String {
    use std::fmt::Write;
    let mut out = String::from(
        "setting                           type        values / range              θ_HF\n",
    );
    let hf = fidelity::theta_hf();
    for v in fidelity::space(10).variables() {
        let (kind, range) = match &v.domain {
            Domain::Discrete { values } => (
                "discrete",
                format!(
                    "{{{}}}",
                    values
                        .iter()
                        .map(ToString::to_string)
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ),
            Domain::Continuous { lo, hi, bins, .. } => {
                ("continuous", format!("[{lo}, {hi}] m, {bins} log bins"))
            }
        };
        let hf_value = hf.get(&v.name).map_or(String::new(), ToString::to_string);
        let _ = writeln!(out, "{:<33} {kind:<11} {range:<27} {hf_value}", v.name);
    }
    out
}
