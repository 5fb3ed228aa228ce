//! `savme scenarios`: the bundled simulator's scenarios with their parameter spaces.

use savme::kernel::Domain;
use savme_sim::scenario::{self, SCENARIOS};

pub fn run() -> Result<(), String> {
    super::print(&scenarios_text())
}

/// `savme scenarios`: the listing.
fn scenarios_text() -> String {
    use std::fmt::Write;
    let mut out = String::new();
    for info in &SCENARIOS {
        let phase = if info.training() {
            "meta-training"
        } else {
            "meta-testing"
        };
        let _ = writeln!(
            out,
            "{:>2}  {}  ({phase}, {} s)",
            info.id, info.name, info.duration
        );
        let _ = writeln!(out, "    {}", info.description);
        for v in scenario::phi_space(info).variables() {
            if let Domain::Continuous { lo, hi, bins, .. } = v.domain {
                let _ = writeln!(out, "    {:<18} [{lo}, {hi}] in {bins} bins", v.name);
            }
        }
    }
    out
}
