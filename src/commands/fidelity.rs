//! `savme fidelity`: the 16 fidelity settings (the paper's Table II) with their θ_HF values.

use savme::kernel::Domain;
use savme_sim::fidelity;

#[derive(clap::Args)]
pub struct Args {
    /// Print the settings as JSON (with θ_HF and units).
    #[arg(long)]
    json: bool,
}

pub fn run(a: Args) -> Result<(), String> {
    if a.json {
        super::print(&(fidelity_json().to_string() + "\n"))
    } else {
        super::print(&fidelity_text())
    }
}

/// `savme fidelity --json`: every setting as the kernel writes a variable, with its unit and
/// θ_HF value.
fn fidelity_json() -> serde_json::Value {
    let hf = fidelity::theta_hf();
    let settings: Vec<_> = fidelity::space(10)
        .variables()
        .iter()
        .map(|v| {
            let mut s = serde_json::to_value(v).unwrap_or_default();
            if let Some(o) = s.as_object_mut() {
                o.insert("unit".into(), fidelity::unit(&v.name).into());
                o.insert(
                    "hf".into(),
                    serde_json::to_value(hf.get(&v.name)).unwrap_or_default(),
                );
            }
            s
        })
        .collect();
    serde_json::json!({ "format_version": 1, "settings": settings })
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
