//! What an estimate stores per trial ([`EstimateLine`]) and writes at the end
//! ([`EstimateOutcome`]: `summary.json`, `table.md`).

use super::posterior::Trained;
use super::{EstimateError, EstimateSettings};
use crate::log::RunLine;
use crate::outputs::FORMAT_VERSION;
use crate::CampaignError;
use savme_kernel::estimation::{
    ControlPart, ControlPlan, Estimate, Estimation, EstimationTrial, Fidelity,
};
use savme_kernel::Assignment;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::PathBuf;

/// One run of an estimate, as stored in its `trials.jsonl`: an HF run (`hf`), or the LF run
/// (`lf`) of a multi-fidelity estimate's pilot round.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EstimateLine {
    /// The estimation's trial id (0, 1, … in ask order).
    pub id: u64,
    /// The scenario.
    pub scenario: String,
    /// φ, drawn from the proposal.
    pub phi: Assignment,
    /// q(φ): the proposal's density.
    pub q: f64,
    /// p(φ): the nominal's density.
    pub p: f64,
    /// p(φ) / q(φ).
    pub weight: f64,
    /// The cross-entropy pilot round of a refinement trial (not part of the estimate).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub round: Option<u32>,
    /// The HF run (every trial but an LF pilot's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hf: Option<RunLine>,
    /// The LF run at θ_LF* of a pilot trial with `pilot_fidelity` = `lf`, or of a control
    /// variate's run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lf: Option<RunLine>,
    /// With control variates (`control_calibration`): `calibration` or `paired` (a pair's
    /// HF or LF run: two consecutive lines, same φ) or `extra` (an LF-only run).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub control: Option<ControlPart>,
}

impl EstimateLine {
    /// The line of trial `t`, whose run (at `t.fidelity`) is `run`.
    pub(crate) fn new(t: &EstimationTrial, run: RunLine) -> Self {
        let (hf, lf) = match t.fidelity {
            Fidelity::Hf => (Some(run), None),
            Fidelity::Lf => (None, Some(run)),
        };
        EstimateLine {
            id: t.id,
            scenario: t.scenario.to_string(),
            phi: t.phi.clone(),
            q: t.q,
            p: t.p,
            weight: t.weight,
            round: t.round,
            hf,
            lf,
            control: t.control,
        }
    }

    /// The line's run (HF or LF), if it has exactly one.
    pub fn run(&self) -> Option<&RunLine> {
        match (&self.hf, &self.lf) {
            (Some(r), None) | (None, Some(r)) => Some(r),
            _ => None,
        }
    }

    /// Checks that the stored line is the trial asked again (same id, scenario, φ and
    /// densities); the message names the first field that differs.
    pub(crate) fn check(&self, asked: &EstimationTrial) -> Result<(), String> {
        let differs = |field: &str, stored: String, now: String| {
            Err(format!(
                "`{field}` is {stored} but the estimate asks {now} here (an edited line, or other settings)"
            ))
        };
        if self.id != asked.id {
            return differs("id", self.id.to_string(), asked.id.to_string());
        }
        if self.scenario != *asked.scenario {
            return differs(
                "scenario",
                self.scenario.clone(),
                asked.scenario.to_string(),
            );
        }
        if self.round != asked.round {
            let show = |r: Option<u32>| r.map_or("none".to_string(), |r| r.to_string());
            return differs("round", show(self.round), show(asked.round));
        }
        if self.phi != asked.phi {
            return differs("phi", self.phi.to_string(), asked.phi.to_string());
        }
        let stored = match (&self.hf, &self.lf) {
            (Some(_), None) => Fidelity::Hf,
            (None, Some(_)) => Fidelity::Lf,
            _ => return Err("a line holds exactly one run, `hf` or `lf`".into()),
        };
        if stored != asked.fidelity {
            return differs(
                "hf/lf",
                format!("an {} run", stored.key().to_uppercase()),
                format!("an {} run", asked.fidelity.key().to_uppercase()),
            );
        }
        if self.control != asked.control {
            let show = |c: Option<ControlPart>| {
                c.map_or("none".to_string(), |c| {
                    serde_json::to_string(&c).unwrap_or_default()
                })
            };
            return differs("control", show(self.control), show(asked.control));
        }
        for (field, stored, now) in [
            ("q", self.q, asked.q),
            ("p", self.p, asked.p),
            ("weight", self.weight, asked.weight),
        ] {
            if stored.to_bits() != now.to_bits() {
                return differs(field, stored.to_string(), now.to_string());
            }
        }
        Ok(())
    }
}

/// Why an estimate stopped.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// The total's interval reached ± `target_width` (with `min_failures` failures).
    TargetWidth,
    /// `max_runs` HF runs were made first.
    MaxRuns,
}

/// A finished estimate.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Serialize)]
pub struct EstimateOutcome {
    /// The settings it ran with.
    pub settings: EstimateSettings,
    /// The estimate per scenario and in total.
    pub estimate: Estimate,
    /// Why it stopped.
    pub stopped: StopReason,
    /// The proposal's learned part: per scenario, per variable, each bin's probability (of
    /// the product proposal; with `proposal` = `joint` the first pilot round drew from these
    /// bins, and the later rounds and the estimate from the fitted mixture).
    pub proposal: BTreeMap<String, BTreeMap<String, Vec<f64>>>,
    /// The campaign stage each scenario's posterior was learned in.
    pub learned_in: BTreeMap<String, String>,
    /// Told trials of those stages (one HF run each, plus an LF run), all their scenarios.
    pub training_hf_runs: u64,
    /// Of which in the estimated scenarios.
    pub training_hf_runs_of_scenarios: u64,
    /// HF runs of the estimate (= `estimate.runs`), reused pilot runs included.
    pub estimate_hf_runs: u64,
    /// The summed HF cost of the estimate's runs (the campaign's cost measure).
    pub estimate_hf_cost: f64,
    /// HF runs of the cross-entropy pilot rounds (0 without refinement). Every HF run made:
    /// `estimate_hf_runs + pilot_hf_runs − pilot_hf_runs_reused`.
    pub pilot_hf_runs: u64,
    /// Of which in the estimate too (the last `refine_reuse` rounds).
    pub pilot_hf_runs_reused: u64,
    /// Of which failed.
    pub pilot_failures: u64,
    /// Their summed HF cost.
    pub pilot_hf_cost: f64,
    /// LF runs of the pilot rounds at θ_LF* (`pilot_fidelity` = `lf`; else 0 and absent).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub pilot_lf_runs: u64,
    /// Their summed cost (the campaign's cost measure; absent without LF runs).
    #[serde(default, skip_serializing_if = "is_zero_cost")]
    pub pilot_lf_cost: f64,
    /// θ_LF*, the LF runs' fidelity settings (absent without LF runs).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub theta_lf: Option<Assignment>,
    /// The control variates' runs and plans (`control_calibration`; absent without them).
    #[serde(flatten)]
    pub control: ControlOutcome,
    /// Every run made, HF and LF, in HF runs of equal cost: (HF cost + LF cost) / the mean
    /// cost of one HF run here. Without an LF pilot, the HF runs made.
    pub hf_equivalent_runs: f64,
    /// Runs replayed from `trials.jsonl` (resume).
    pub replayed: u64,
    /// Seconds this process spent running.
    pub elapsed_seconds: f64,
    /// Where the outputs are.
    pub out: PathBuf,
    /// The stopping rules this resume changed (`max_runs: 40 → 100`), if any.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub changed_on_resume: Vec<String>,
    /// `table.md`'s text.
    #[serde(skip)]
    pub table_md: String,
}

/// The control variates' part of an [`EstimateOutcome`] (its fields appear in
/// `summary.json` next to the others, each only when non-zero).
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Default, Serialize)]
pub struct ControlOutcome {
    /// The calibration pairs' HF runs (their LF runs are in `control_lf_runs`); not part of
    /// the estimate.
    #[serde(skip_serializing_if = "is_zero")]
    pub calibration_hf_runs: u64,
    /// Every LF run after the pilot (calibration, pairs, extra).
    #[serde(skip_serializing_if = "is_zero")]
    pub control_lf_runs: u64,
    /// Their summed cost.
    #[serde(skip_serializing_if = "is_zero_cost")]
    pub control_lf_cost: f64,
    /// What the calibration chose, per scenario (also in each scenario's
    /// `estimate.scenarios[i].control`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub control_plans: Option<BTreeMap<String, ControlPlan>>,
}

impl ControlOutcome {
    /// The control variates' counts, costs and plans (all zero without them).
    fn of(estimation: &Estimation, lines: &[EstimateLine]) -> Self {
        let control_lf = || lines.iter().filter(|l| l.lf.is_some() && l.round.is_none());
        ControlOutcome {
            calibration_hf_runs: lines
                .iter()
                .filter(|l| l.hf.is_some() && l.control == Some(ControlPart::Calibration))
                .count() as u64,
            control_lf_runs: control_lf().count() as u64,
            control_lf_cost: control_lf()
                .filter_map(EstimateLine::run)
                .map(|r| r.runtime)
                .sum(),
            control_plans: estimation.control_plans().map(|plans| {
                estimation
                    .scenarios()
                    .iter()
                    .zip(plans)
                    .map(|(n, p)| (n.to_string(), *p))
                    .collect()
            }),
        }
    }
}

fn is_zero(n: &u64) -> bool {
    *n == 0
}

fn is_zero_cost(c: &f64) -> bool {
    *c == 0.0
}

/// `summary.json` of an estimate: its `format_version`, then the outcome's fields.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Serialize)]
pub struct EstimateSummary<'a> {
    /// The layout version of savme's JSON documents (1 for now; a script checks it).
    pub format_version: u32,
    /// The estimate.
    #[serde(flatten)]
    pub outcome: &'a EstimateOutcome,
}

/// What the estimate table's columns mean, written under it (`table.md`, printed).
pub(crate) const ESTIMATE_LEGEND: &str = "±: the 95 % interval's half-width relative to the \
estimate (what --target-width bounds). ESS: Kish's effective sample size (Σw)²/Σw² of the \
scenario's runs; failure ESS: the same over its failures' weights (how many equally weighted \
failures the estimate rests on). Mean weight: the mean of w = p(φ)/q(φ), 1 in expectation (far \
from 1: the proposal misses part of the nominal). Probabilities are rounded to two significant \
digits; summary.json holds the raw values. docs/ESTIMATION.md explains the estimator.";

impl EstimateOutcome {
    #[allow(clippy::too_many_arguments)] // the parts of one outcome, assembled in one place
    pub(crate) fn new(
        estimation: &Estimation,
        settings: &EstimateSettings,
        trained: &Trained,
        lines: Vec<EstimateLine>,
        stopped: StopReason,
        replayed: u64,
        elapsed_seconds: f64,
        out: PathBuf,
    ) -> Self {
        let proposal = trained
            .scenarios
            .iter()
            .enumerate()
            .map(|(i, (s, _))| {
                let bins = estimation.bin_probabilities(i).unwrap_or(&[]);
                let vars = s
                    .space
                    .variables()
                    .iter()
                    .zip(bins)
                    .map(|(v, b)| (v.name.to_string(), b.clone()))
                    .collect();
                (s.name.to_string(), vars)
            })
            .collect();
        let estimate = estimation.estimate();
        let refine = settings.refine();
        // Whether a line's run counts in the estimate: after the pilot, or a reused round.
        let in_estimate = |l: &EstimateLine| match (l.round, refine) {
            (None, _) => l.control != Some(ControlPart::Calibration),
            (Some(r), Some(refine)) => r + refine.reuse >= refine.rounds,
            (Some(_), None) => false,
        };
        let cost = |lines: &mut dyn Iterator<Item = &EstimateLine>| -> f64 {
            lines.filter_map(EstimateLine::run).map(|r| r.runtime).sum()
        };
        let pilot = estimation.pilot_runs();
        let lf_pilot = settings.pilot_fidelity == Fidelity::Lf;
        let pilot_runs: u64 = pilot.iter().map(|p| p.0).sum();
        let hf_lines = || lines.iter().filter(|l| l.hf.is_some());
        let lf_cost = cost(&mut lines.iter().filter(|l| l.lf.is_some()));
        let (hf_runs, hf_cost) = (hf_lines().count(), cost(&mut hf_lines()));
        let hf_equivalent_runs = if hf_runs > 0 && hf_cost > 0.0 {
            hf_runs as f64 + lf_cost / (hf_cost / hf_runs as f64)
        } else {
            hf_runs as f64
        };
        let mut o = EstimateOutcome {
            settings: settings.clone(),
            stopped,
            proposal,
            learned_in: trained.stages.clone(),
            training_hf_runs: trained.stage_runs,
            training_hf_runs_of_scenarios: trained.scenario_runs,
            estimate_hf_runs: estimate.runs,
            estimate_hf_cost: cost(&mut lines.iter().filter(|l| l.hf.is_some() && in_estimate(l))),
            pilot_hf_runs: if lf_pilot { 0 } else { pilot_runs },
            pilot_failures: pilot.iter().map(|p| p.1).sum(),
            pilot_hf_runs_reused: lines
                .iter()
                .filter(|l| l.round.is_some() && in_estimate(l))
                .count() as u64,
            pilot_hf_cost: cost(&mut lines.iter().filter(|l| l.round.is_some() && l.hf.is_some())),
            pilot_lf_runs: if lf_pilot { pilot_runs } else { 0 },
            pilot_lf_cost: cost(&mut lines.iter().filter(|l| l.lf.is_some() && l.round.is_some())),
            theta_lf: trained.theta_lf.clone(),
            control: ControlOutcome::of(estimation, &lines),
            hf_equivalent_runs,
            estimate,
            replayed,
            elapsed_seconds,
            out,
            changed_on_resume: Vec::new(),
            table_md: String::new(),
        };
        o.table_md = o.table();
        o
    }

    /// The table of `table.md`: per scenario and in total, the estimate with its 95 %
    /// interval, relative half-width and effective sample sizes, then [`ESTIMATE_LEGEND`].
    fn table(&self) -> String {
        use std::fmt::Write;
        let e = &self.estimate;
        let mut t = format!(
            "# P(failure) under the nominal distribution\n\nImportance sampling, defensive mixture q = (1 − ε)·p̂_ψ + ε·nominal, ε = {}; stopped: {}.\n\n",
            self.settings.epsilon,
            match self.stopped {
                StopReason::TargetWidth => "target width reached",
                StopReason::MaxRuns => "run budget reached",
            }
        );
        t += "| scenario | p(s) | HF runs | failures | P(failure) | 95 % interval | ± | ESS | failure ESS | mean weight |\n|---|---|---|---|---|---|---|---|---|---|\n";
        let pct = |r: f64| {
            if r.is_finite() {
                format!("{:.1} %", 100.0 * r)
            } else {
                "—".into()
            }
        };
        let p = crate::report::format_probability;
        for s in &e.scenarios {
            let i = &s.estimate;
            let _ = writeln!(
                t,
                "| {} | {:.3} | {} | {} | {} | [{}, {}] | {} | {:.0} | {:.1} | {:.3} |",
                s.scenario,
                s.probability,
                s.runs,
                s.failures,
                p(i.mean),
                p(i.lo),
                p(i.hi),
                pct(i.relative_half_width()),
                s.ess,
                s.failure_ess,
                s.mean_weight
            );
        }
        let i = &e.total;
        let _ = writeln!(
            t,
            "| **total (weighted by p(s))** | 1 | {} | {} | {} | [{}, {}] | {} | | | |",
            e.runs,
            e.failures,
            p(i.mean),
            p(i.lo),
            p(i.hi),
            pct(i.relative_half_width())
        );
        t += &self.table_notes();
        t
    }

    /// The lines under the table: where the proposal was learned, the refinement and the
    /// joint proposal if any, then [`ESTIMATE_LEGEND`].
    fn table_notes(&self) -> String {
        use std::fmt::Write;
        let mut t = String::new();
        let _ = write!(
            t,
            "\nThe proposal was learned in {} ({} trials, {} of them in these scenarios).\n",
            self.learned_in
                .values()
                .cloned()
                .collect::<std::collections::BTreeSet<_>>()
                .into_iter()
                .collect::<Vec<_>>()
                .join(", "),
            self.training_hf_runs,
            self.training_hf_runs_of_scenarios
        );
        if let Some(r) = self.settings.refine() {
            let used = match r.reuse {
                0 => "they refit the proposal and are not part of the estimate".to_string(),
                k => format!(
                    "they refit the proposal; the last {k} (these {} runs) are part of the estimate too, each run weighted by its own round's proposal",
                    self.pilot_hf_runs_reused
                ),
            };
            if self.settings.pilot_fidelity == Fidelity::Lf {
                let theta = self
                    .theta_lf
                    .as_ref()
                    .map_or_else(String::new, |t| format!(" {t}"));
                let _ = writeln!(
                    t,
                    "Multi-fidelity: the cross-entropy refinement ran {} rounds of {} LF runs at the campaign's learned θ_LF*{theta} ({} runs made, {} LF failures, cost {:.4e}); they fit the proposal and are not part of the estimate, which uses HF runs only. Every run made is worth {:.0} HF runs (LF runs charged at their cost).",
                    r.rounds, r.runs, self.pilot_lf_runs, self.pilot_failures, self.pilot_lf_cost, self.hf_equivalent_runs
                );
            } else {
                let _ = writeln!(
                    t,
                    "Cross-entropy refinement before the estimate: {} rounds of {} HF runs ({} runs made, {} failures); {used}.",
                    r.rounds, r.runs, self.pilot_hf_runs, self.pilot_failures
                );
            }
            if let Some(j) = self.settings.config(0).joint {
                let _ = writeln!(
                    t,
                    "Joint proposal: after each round a mixture of at most {} components over the whole of φ is fitted to the pilot's weighted failures (or, while there are fewer than 100, its failures and closest near-misses by robustness).",
                    j.components
                );
            }
        }
        t += &self.control_notes();
        let _ = writeln!(t, "\n{ESTIMATE_LEGEND}");
        t
    }

    /// The control variates' lines under the table: the calibration's plan per scenario.
    fn control_notes(&self) -> String {
        use std::fmt::Write;
        let mut t = String::new();
        let Some(plans) = &self.control.control_plans else {
            return t;
        };
        let _ = writeln!(
            t,
            "Control variates: {} calibration pairs (HF and LF at θ_LF*{}, not part of the estimate; {} LF runs after the pilot in all, cost {:.4e}) chose per scenario:",
            self.settings.control_calibration,
            self.theta_lf.as_ref().map_or_else(String::new, |t| format!(" {t}")),
            self.control.control_lf_runs,
            self.control.control_lf_cost
        );
        for (scenario, p) in plans {
            let chosen = if p.use_lf {
                format!(
                    "every estimate draw at HF and LF plus {} extra LF runs, α = {:.4} (predicted cost × variance {:.2} of HF only)",
                    p.extra, p.alpha, p.predicted_factor
                )
            } else {
                "HF runs only (the LF does not pay)".to_string()
            };
            let _ = writeln!(
                t,
                "- {scenario}: ρ(w·f_HF, w·f_LF) = {:.3} over {} pairs ({} HF, {} LF failures), LF/HF cost {:.3}: {chosen}.",
                p.rho, p.calibration_pairs, p.calibration_hf_failures, p.calibration_lf_failures, p.cost_ratio
            );
        }
        let _ = writeln!(
            t,
            "Every run made is worth {:.0} HF runs (LF runs charged at their cost).",
            self.hf_equivalent_runs
        );
        t
    }

    /// `summary.json`'s text (what `savme estimate --json` prints): an [`EstimateSummary`].
    pub fn summary_json(&self) -> String {
        let summary = EstimateSummary {
            format_version: FORMAT_VERSION,
            outcome: self,
        };
        serde_json::to_string_pretty(&summary).unwrap_or_default() + "\n"
    }

    /// Writes `summary.json` and `table.md` into the output directory.
    pub(crate) fn write(&self) -> Result<(), EstimateError> {
        let write = |name: &str, text: String| {
            let path = self.out.join(name);
            savme_store::safe_file::write_file(&path, text.as_bytes())
                .map_err(|e| CampaignError::io(&path, e))
        };
        write("summary.json", self.summary_json())?;
        write(
            "table.md",
            format!(
                "{}\n<!-- savme format_version {FORMAT_VERSION} -->\n",
                self.table_md
            ),
        )?;
        Ok(())
    }
}
