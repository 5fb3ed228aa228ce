//! `savme fidelity`: the 16 fidelity settings (the paper's Table I) with their θ_HF values.

use savme::kernel::Domain;
use savme_sim::fidelity;

pub fn run() -> Result<(), String> {
    super::print(&fidelity_text())
}

/// `savme fidelity`: the 16 fidelity settings of Table I with their θ_HF values.
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
