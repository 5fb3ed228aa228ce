//! The failures a campaign found: every HF run that failed, with where it was found and what
//! replays it — what a safety team takes from a campaign to triage.
//!
//! HF failures come from the told trials (baseline, meta-training, evaluation, meta-testing)
//! and from screening stages (an LF failure confirmed on HF, or an audited LF pass that HF
//! failed: a miss). Withdrawn trials (their simulation failed) ran no outcome and are not
//! listed.
//!
//! ```
//! use savme_campaign::log::{LogLine, TrialLine};
//! use savme_campaign::report::failures::{found_failures, Filter};
//! let line = r#"{"stage":"baseline-train","index":0,"id":0,"phase":"baseline","budget":null,
//!   "scenario":"cut_in","phi":{"gap":4.5},"theta_lf":null,
//!   "hf":{"failure":true,"runtime":2.0,"wall_seconds":0.1},"lf":null,"cost_ratio":null,"outcome":null,
//!   "credit":{"fidelity":null,"scenario":null}}"#;
//! let t: TrialLine = serde_json::from_str(line)?;
//! let found = found_failures(&[LogLine::Trial(t)], &Filter::default());
//! assert_eq!(found.len(), 1);
//! assert_eq!((found[0].stage.as_str(), found[0].phi.get_f64("gap")), ("baseline-train", Some(4.5)));
//! # Ok::<(), serde_json::Error>(())
//! ```

use crate::log::LogLine;
use savme_kernel::{Assignment, Outcome};
use serde::Serialize;

/// One HF failure.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FoundFailure {
    /// The stage label (`train@0.3`, `screen@0.3`, …).
    pub stage: String,
    /// The trial's position in its stage, from 0.
    pub index: u64,
    /// The kernel's trial id.
    pub id: u64,
    /// The scenario.
    pub scenario: String,
    /// The scenario parameters φ that made the HF run fail.
    pub phi: Assignment,
    /// The LF settings of the trial (None for HF-only trials).
    pub theta_lf: Option<Assignment>,
    /// What the LF run said (None for HF-only trials): true = it failed too (TP), false = it
    /// missed the failure (FN).
    pub lf_failure: Option<bool>,
    /// TP / FN of a paired trial (None for HF-only trials).
    pub outcome: Option<Outcome>,
    /// The HF run's cost (the campaign's cost measure).
    pub hf_runtime: f64,
}

/// Which failures to list (empty: all).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Filter {
    /// Only these stage labels.
    pub stages: Vec<String>,
    /// Only these scenarios.
    pub scenarios: Vec<String>,
}

impl Filter {
    fn keeps(&self, stage: &str, scenario: &str) -> bool {
        (self.stages.is_empty() || self.stages.iter().any(|s| s == stage))
            && (self.scenarios.is_empty() || self.scenarios.iter().any(|s| s == scenario))
    }
}

/// The HF failures among `lines` that `filter` keeps, in line order.
pub fn found_failures(lines: &[LogLine], filter: &Filter) -> Vec<FoundFailure> {
    lines
        .iter()
        .filter_map(|line| match line {
            LogLine::Trial(t) if t.hf.failure => Some(FoundFailure {
                stage: t.stage.to_string(),
                index: t.index,
                id: t.id,
                scenario: t.scenario.clone(),
                phi: t.phi.clone(),
                theta_lf: t.theta_lf.clone(),
                lf_failure: t.lf.as_ref().map(|r| r.failure),
                outcome: t.outcome,
                hf_runtime: t.hf.runtime,
            }),
            LogLine::Screen(s) => {
                s.hf.as_ref()
                    .filter(|hf| hf.failure)
                    .map(|hf| FoundFailure {
                        stage: s.stage.to_string(),
                        index: s.index,
                        id: s.id,
                        scenario: s.scenario.clone(),
                        phi: s.phi.clone(),
                        theta_lf: s.theta_lf.clone(),
                        lf_failure: s.lf.map(|lf| lf.failure),
                        outcome: s.outcome,
                        hf_runtime: hf.runtime,
                    })
            }
            LogLine::Trial(_) | LogLine::Failed(_) => None,
        })
        .filter(|f| filter.keeps(&f.stage, &f.scenario))
        .collect()
}

/// How many HF runs `lines` hold (every told trial; a screening trial when it ran HF).
pub fn hf_runs(lines: &[LogLine]) -> usize {
    lines
        .iter()
        .filter(|l| match l {
            LogLine::Trial(_) => true,
            LogLine::Screen(s) => s.hf.is_some(),
            LogLine::Failed(_) => false,
        })
        .count()
}

/// `name=value,…` of an assignment, every value exact (shortest round-trip form): what
/// `savme simulate --phi` reads back.
pub fn as_flag(a: &Assignment) -> String {
    a.iter()
        .map(|(n, v)| format!("{n}={v}"))
        .collect::<Vec<_>>()
        .join(",")
}
