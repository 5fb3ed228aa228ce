//! What a campaign found, computed from its trials alone (so that every output can be checked
//! against `trials.jsonl`): the paper's Table III and Table IV, break-even times and the
//! meta-testing gain.

use super::log::{self, TrialLine};
use super::protocol::{Cost, Protocol, Stage, StageKind};
use savme_kernel::metrics::{break_even, speedup, Accounting, FailureCurve};
use savme_kernel::{Assignment, Outcome, Space};
use serde::Serialize;
use std::fmt::Write as _;

pub mod ablation;
pub mod failures;
pub mod intervals;
pub mod repeated;
pub mod screening;

/// Failure counts of an HF-only baseline stage.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Baseline {
    /// Trials.
    pub trials: u64,
    /// Trials whose HF run failed.
    pub failures: u64,
    /// failures / trials.
    pub failure_rate: f64,
    /// Sum of the HF costs.
    pub runtime: f64,
}

/// The evaluation of one budget (a row of Table III).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Evaluation {
    /// Trials.
    pub trials: u64,
    /// TP / trials: failures the LF simulator alone would have found.
    pub tp_rate: f64,
    /// Mean t_LF / t_HF.
    pub mean_lf_cost: f64,
    /// (TP-rate / mean LF cost) / baseline failure rate; None if undefined.
    pub speedup: Option<f64>,
    /// Counts per class: TP, TN, FP, FN.
    pub tp: u64,
    /// Both runs passed.
    pub tn: u64,
    /// Only the LF run failed.
    pub fp: u64,
    /// Only the HF run failed (`fn` in JSON).
    #[serde(rename = "fn")]
    pub fn_: u64,
    /// The learned fidelity θ_LF* (the evaluation's θ_LF).
    pub theta_star: Option<Assignment>,
}

/// Meta-training at one budget.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Training {
    /// Trials.
    pub trials: u64,
    /// Trials whose HF run failed.
    pub hf_failures: u64,
    /// TP-rate over the training trials.
    pub tp_rate: f64,
    /// Mean t_LF / t_HF over the training trials.
    pub mean_lf_cost: f64,
    /// Cost of all runs (HF + LF).
    pub runtime: f64,
    /// The cost from which on meta-training has found more failures than the baseline (both
    /// charged for every run they made); None if not reached within the shorter of the two.
    pub break_even: Option<f64>,
}

/// Failures found by the learned prior, the uniform prior and the baseline by a common cost
/// horizon, under one accounting.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FoundByHorizon {
    /// The horizon: the smallest total cost of the three runs compared.
    pub horizon: f64,
    /// Failures found with the meta-training posterior as the fidelity prior.
    pub learned: u64,
    /// Failures found with a uniform fidelity prior.
    pub uniform: u64,
    /// Failures found by the baseline (uniform φ, HF only).
    pub baseline: u64,
    /// learned / uniform − 1; None if the uniform prior found none.
    pub gain_vs_uniform: Option<f64>,
    /// learned / baseline − 1; None if the baseline found none.
    pub gain_vs_baseline: Option<f64>,
}

/// Meta-testing at one budget.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MetaTesting {
    /// Every run charged (HF + LF), a failure found when the HF run fails: meta-testing as it
    /// runs. This is what `meta_testing.png` shows.
    pub all_runs: FoundByHorizon,
    /// Only the LF runs charged, a failure found when the LF run finds a true one (TP): the
    /// failures the learned-fidelity simulator itself finds per LF runtime.
    pub lf_only: FoundByHorizon,
    /// LF screening with HF confirmation (no audit) as the deployment-realistic accounting:
    /// the LF run charged, the HF run only to confirm an LF failure; a failure is found when
    /// the HF run confirms it (TP).
    pub screened: FoundByHorizon,
    /// Total cost of the learned-prior and uniform-prior runs.
    pub learned_runtime: f64,
    /// See `learned_runtime`.
    pub uniform_runtime: f64,
}

/// Everything about one budget.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BudgetReport {
    /// C_budget.
    pub budget: f64,
    /// Meta-training (None until it ran).
    pub training: Option<Training>,
    /// Evaluation (None until it ran).
    pub evaluation: Option<Evaluation>,
    /// Meta-testing (None until it ran).
    pub meta_testing: Option<MetaTesting>,
    /// The prior-strength ablation (None without `prior_strengths`, or until it ran).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ablation: Option<ablation::Ablation>,
    /// LF screening with HF confirmation (None without a screening stage, or until it ran).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub screening: Option<screening::Screening>,
}

/// The campaign's results.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    /// The protocol.
    pub protocol: Protocol,
    /// Baseline on the meta-training scenarios.
    pub baseline_train: Option<Baseline>,
    /// Baseline on the meta-testing scenarios.
    pub baseline_test: Option<Baseline>,
    /// Per budget.
    pub budgets: Vec<BudgetReport>,
}

fn stage_lines<'a>(lines: &'a [TrialLine], stage: &Stage) -> Vec<&'a TrialLine> {
    let id = stage.id();
    lines.iter().filter(|l| l.stage == id).collect()
}

fn stage_of(p: &Protocol, kind: StageKind, budget: Option<f64>) -> Stage {
    p.stages()
        .into_iter()
        .find(|s| s.kind == kind && s.budget == budget)
        .unwrap_or(Stage {
            kind,
            budget,
            iterations: 0,
            strength: None,
        })
}

/// Found failures over cost, every run charged (HF + LF for paired trials).
pub fn curve(lines: &[&TrialLine]) -> FailureCurve {
    curve_as(lines, Accounting::AllRuns)
}

/// Found failures over cost under `accounting` (HF-only trials: their HF run either way).
pub fn curve_as(lines: &[&TrialLine], accounting: Accounting) -> FailureCurve {
    let mut c = FailureCurve::new();
    for l in lines {
        let (cost, found) = match (accounting, l.lf) {
            (_, None) => (l.hf.runtime, l.hf.failure),
            (Accounting::AllRuns, Some(lf)) => (l.hf.runtime + lf.runtime, l.hf.failure),
            (Accounting::LfOnly, Some(lf)) => (lf.runtime, l.hf.failure && lf.failure),
            (Accounting::Screened, Some(lf)) => (
                lf.runtime + if lf.failure { l.hf.runtime } else { 0.0 },
                l.hf.failure && lf.failure,
            ),
        };
        c.push(cost, found);
    }
    c
}

/// Found failures of three runs by the smallest of their total costs.
fn found_by_horizon(
    learned: &[&TrialLine],
    uniform: &[&TrialLine],
    base: &[&TrialLine],
    accounting: Accounting,
) -> FoundByHorizon {
    let (lc, uc, bc) = (
        curve_as(learned, accounting),
        curve_as(uniform, accounting),
        curve_as(base, accounting),
    );
    let mut horizon = lc.end().min(uc.end());
    if !base.is_empty() {
        horizon = horizon.min(bc.end());
    }
    let (l, u, b) = (
        lc.failures_at(horizon),
        uc.failures_at(horizon),
        bc.failures_at(horizon),
    );
    let gain = |a: u64, b: u64| (b > 0).then(|| a as f64 / b as f64 - 1.0);
    FoundByHorizon {
        horizon,
        learned: l,
        uniform: u,
        baseline: b,
        gain_vs_uniform: gain(l, u),
        gain_vs_baseline: gain(l, b),
    }
}

fn baseline(lines: &[&TrialLine]) -> Option<Baseline> {
    if lines.is_empty() {
        return None;
    }
    let failures = lines.iter().filter(|l| l.hf.failure).count() as u64;
    Some(Baseline {
        trials: lines.len() as u64,
        failures,
        failure_rate: failures as f64 / lines.len() as f64,
        runtime: lines.iter().map(|l| l.hf.runtime).sum(),
    })
}

fn paired_stats(lines: &[&TrialLine]) -> ([u64; 4], f64) {
    let mut counts = [0u64; 4];
    let mut ratio = 0.0;
    for l in lines {
        match l.outcome {
            Some(Outcome::TP) => counts[0] += 1,
            Some(Outcome::TN) => counts[1] += 1,
            Some(Outcome::FP) => counts[2] += 1,
            Some(Outcome::FN) => counts[3] += 1,
            None => {}
        }
        ratio += l.cost_ratio.unwrap_or(0.0);
    }
    (counts, ratio)
}

impl Report {
    /// The report of `lines` (all trials of a campaign run with `protocol`, possibly
    /// incomplete: stages without trials are left out).
    pub fn from_trials(protocol: &Protocol, lines: &[TrialLine]) -> Report {
        let get = |kind, budget| stage_lines(lines, &stage_of(protocol, kind, budget));
        let base_train = get(StageKind::BaselineTrain, None);
        let base_test = get(StageKind::BaselineTest, None);
        let baseline_train = baseline(&base_train);
        let baseline_test = baseline(&base_test);
        let base_curve = curve(&base_train);
        let budgets = protocol
            .budgets
            .iter()
            .map(|&b| {
                let train = get(StageKind::Train, Some(b));
                let eval = get(StageKind::Evaluate, Some(b));
                let learned = get(StageKind::TestLearned, Some(b));
                let uniform = get(StageKind::TestUniform, Some(b));
                let training = (!train.is_empty()).then(|| {
                    let (c, ratio) = paired_stats(&train);
                    let n = train.len() as f64;
                    let tc = curve(&train);
                    Training {
                        trials: train.len() as u64,
                        hf_failures: train.iter().filter(|l| l.hf.failure).count() as u64,
                        tp_rate: c[0] as f64 / n,
                        mean_lf_cost: ratio / n,
                        runtime: tc.end(),
                        break_even: (!base_train.is_empty())
                            .then(|| break_even(&tc, &base_curve))
                            .flatten(),
                    }
                });
                let evaluation = (!eval.is_empty()).then(|| {
                    let (c, ratio) = paired_stats(&eval);
                    let n = eval.len() as f64;
                    let (tp_rate, mean_lf_cost) = (c[0] as f64 / n, ratio / n);
                    Evaluation {
                        trials: eval.len() as u64,
                        tp_rate,
                        mean_lf_cost,
                        speedup: baseline_train
                            .and_then(|base| speedup(tp_rate, mean_lf_cost, base.failure_rate)),
                        tp: c[0],
                        tn: c[1],
                        fp: c[2],
                        fn_: c[3],
                        theta_star: eval[0].theta_lf.clone(),
                    }
                });
                let meta_testing =
                    (!learned.is_empty() && !uniform.is_empty()).then(|| MetaTesting {
                        all_runs: found_by_horizon(
                            &learned,
                            &uniform,
                            &base_test,
                            Accounting::AllRuns,
                        ),
                        lf_only: found_by_horizon(
                            &learned,
                            &uniform,
                            &base_test,
                            Accounting::LfOnly,
                        ),
                        screened: found_by_horizon(
                            &learned,
                            &uniform,
                            &base_test,
                            Accounting::Screened,
                        ),
                        learned_runtime: curve(&learned).end(),
                        uniform_runtime: curve(&uniform).end(),
                    });
                BudgetReport {
                    budget: b,
                    training,
                    evaluation,
                    meta_testing,
                    ablation: ablation::at_budget(protocol, lines, b),
                    screening: None,
                }
            })
            .collect();
        Report {
            protocol: protocol.clone(),
            baseline_train,
            baseline_test,
            budgets,
        }
    }

    /// Adds the screening stages' results (`screened`: their lines; `trials`: every other
    /// trial of the campaign, for the paired evaluation and the baseline it is compared with).
    pub fn add_screening(&mut self, screened: &[log::ScreenLine], trials: &[TrialLine]) {
        let p = &self.protocol;
        let base = stage_lines(trials, &stage_of(p, StageKind::BaselineTrain, None));
        for b in &mut self.budgets {
            let id = stage_of(p, StageKind::Screen, Some(b.budget)).id();
            let lines: Vec<&log::ScreenLine> = screened.iter().filter(|l| l.stage == id).collect();
            let eval = stage_lines(trials, &stage_of(p, StageKind::Evaluate, Some(b.budget)));
            b.screening = screening::report(&lines, &eval, &base, p.audit_fraction);
        }
    }

    /// Table III: baseline and each budget's TP-rate, mean LF cost and speedup (Markdown),
    /// followed by [`TABLE_III_LEGEND`].
    pub fn table_md(&self) -> String {
        let p = &self.protocol;
        let mut s = String::new();
        let _ = writeln!(s, "# Meta-training results (the paper's Table III)\n");
        let _ = writeln!(
            s,
            "Evaluation: {} trials per budget with θ_LF = MAP of p_ω and φ ~ p_ψ, after {} \
             meta-training iterations on {}. Baseline: {} trials with φ uniform, \
             high fidelity only. Cost: {}. Seed {}. {}\n",
            p.eval_iterations,
            p.train_iterations,
            scenarios(p.train_scenarios.len()),
            p.baseline_train_iterations,
            cost_name(p.cost),
            p.seed,
            simulated(p)
        );
        let _ = writeln!(
            s,
            "| C_budget | TP-rate | mean LF cost | speedup | TP-rate 95 % interval (Wilson) |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|");
        let wilson = |k: u64, n: u64| match intervals::Interval::wilson(k, n) {
            Some(intervals::Interval {
                lo: Some(lo),
                hi: Some(hi),
                ..
            }) => format!("[{lo:.2}, {hi:.2}]"),
            _ => "–".into(),
        };
        match &self.baseline_train {
            Some(b) => {
                let _ = writeln!(
                    s,
                    "| baseline | {:.2} | 1.00 | 1.00 | {} |",
                    b.failure_rate,
                    wilson(b.failures, b.trials)
                );
            }
            None => {
                let _ = writeln!(s, "| baseline | – | – | – | – |");
            }
        }
        for b in &self.budgets {
            match &b.evaluation {
                Some(e) => {
                    let _ = writeln!(
                        s,
                        "| {} | {:.2} | {:.2} | {} | {} |",
                        b.budget,
                        e.tp_rate,
                        e.mean_lf_cost,
                        e.speedup.map_or("–".into(), |x| format!("{x:.2}")),
                        wilson(e.tp, e.trials)
                    );
                }
                None => {
                    let _ = writeln!(s, "| {} | – | – | – | – |", b.budget);
                }
            }
        }
        let _ = writeln!(s, "\n{TABLE_III_LEGEND}");
        s
    }

    /// Table IV: the learned fidelity setting per budget next to θ_HF (Markdown).
    pub fn fidelity_md(&self, space: &Space, theta_hf: &Assignment) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# Learned fidelity settings (the paper's Table IV)\n");
        let _ = writeln!(
            s,
            "θ_LF* = MAP of p_ω after meta-training, per budget. Continuous settings show the \
             representative value of the chosen bin, with the bin in brackets. {}\n",
            simulated(&self.protocol)
        );
        let _ = write!(s, "| setting | θ_HF |");
        for b in &self.budgets {
            let _ = write!(s, " C_budget = {} |", b.budget);
        }
        let _ = writeln!(s);
        let _ = write!(s, "|---|---|");
        for _ in &self.budgets {
            let _ = write!(s, "---|");
        }
        let _ = writeln!(s);
        for var in space.variables() {
            let name: &str = &var.name;
            let hf = theta_hf
                .get(name)
                .map_or("–".into(), |v| format_value(var, v, false));
            if ignored(&self.protocol, name) {
                let _ = write!(s, "| {name} (ignored: not learned) | {hf} |");
            } else {
                let _ = write!(s, "| {name} | {hf} |");
            }
            for b in &self.budgets {
                let v = b
                    .evaluation
                    .as_ref()
                    .and_then(|e| e.theta_star.as_ref())
                    .and_then(|t| t.get(name))
                    .map_or("–".into(), |v| format_value(var, v, true));
                let _ = write!(s, " {v} |");
            }
            let _ = writeln!(s);
        }
        s
    }

    /// The human summary printed at the end: break-even times and meta-testing gains.
    pub fn findings_text(&self) -> String {
        let p = &self.protocol;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "Break-even (meta-training vs baseline, every run charged):"
        );
        for b in &self.budgets {
            let text = match b.training.as_ref().map(|t| t.break_even) {
                Some(Some(t)) => format!("after {}", format_cost(p.cost, t)),
                Some(None) => "not reached within the common runtime".into(),
                None => "not run".into(),
            };
            let _ = writeln!(s, "  C_budget = {}: {text}", b.budget);
        }
        let _ = writeln!(
            s,
            "Meta-testing (scenarios {}), failures found by the same runtime, learned vs uniform \
             fidelity prior vs baseline:",
            p.test_scenarios.join(", ")
        );
        let pct = |g: Option<f64>| g.map_or("n/a".into(), |g| format!("{:+.0} %", 100.0 * g));
        for b in &self.budgets {
            match &b.meta_testing {
                Some(m) => {
                    for (what, f) in [
                        ("every run charged", &m.all_runs),
                        ("LF runs only (TP)", &m.lf_only),
                        ("LF screening, HF confirms (TP)", &m.screened),
                    ] {
                        let _ = writeln!(
                            s,
                            "  C_budget = {}, {what}: {} vs {} vs {} by {} — {} over the uniform prior, {} over the baseline",
                            b.budget,
                            f.learned,
                            f.uniform,
                            f.baseline,
                            format_cost(p.cost, f.horizon),
                            pct(f.gain_vs_uniform),
                            pct(f.gain_vs_baseline)
                        );
                    }
                }
                None => {
                    let _ = writeln!(s, "  C_budget = {}: not run", b.budget);
                }
            }
        }
        for b in &self.budgets {
            if let Some(x) = &b.screening {
                let times = |v: Option<f64>| v.map_or("n/a".into(), |v| format!("{v:.2} ×"));
                let _ = writeln!(
                    s,
                    "LF screening with HF confirmation, C_budget = {}: {} confirmed of {} LF failures in {} trials ({}); {} vs the paired evaluation, {} vs the baseline; audit {} of {} LF passes (α = {}): miss rate {}",
                    b.budget,
                    x.counts.confirmed,
                    x.counts.lf_failures,
                    x.counts.trials,
                    format_cost(p.cost, x.counts.runtime()),
                    times(x.vs_paired),
                    times(x.vs_baseline),
                    x.counts.audit_misses,
                    x.counts.audited,
                    x.audit_fraction,
                    x.miss_rate.map_or("n/a".into(), |i| i.show(3)),
                );
            }
        }
        let ablations: Vec<_> = self
            .budgets
            .iter()
            .filter_map(|b| b.ablation.as_ref().map(|a| (b.budget, a)))
            .collect();
        if !ablations.is_empty() {
            let _ = writeln!(
                s,
                "Prior-strength ablation (failures by the common runtime, every run charged; gain over strength 0 = uniform prior):"
            );
        }
        for (budget, a) in ablations {
            let rows: Vec<String> = a
                .rows
                .iter()
                .map(|r| format!("{}: {} ({})", r.strength, r.all_runs, pct(r.gain_all_runs)))
                .collect();
            let _ = writeln!(s, "  C_budget = {budget}: {}", rows.join(", "));
        }
        s
    }
}

/// What Table III's columns mean, written under it (`table.md`, the printed table) so that
/// its numbers can be read without the paper or the code.
pub const TABLE_III_LEGEND: &str = "TP-rate: the share of evaluation trials whose HF and LF \
runs both fail (for the baseline: its HF failure rate). Mean LF cost: the LF run's cost over \
its HF run's, averaged over the evaluation trials. Speedup = (TP-rate / mean LF cost) / \
baseline failure rate (the paper's definition): how many times more failures per unit of \
runtime the learned fidelity alone finds than the HF-only baseline.";

/// "1 scenario", "8 scenarios".
fn scenarios(n: usize) -> String {
    format!("{n} scenario{}", if n == 1 { "" } else { "s" })
}

/// The bundled simulator with idealised perception (`savme reproduce --perception ideal`).
pub const IDEAL_SIMULATOR: &str = "savme-sim/ideal";
/// The only fidelity setting idealised perception reads (the simulation rate); it ignores
/// every camera and lidar setting.
pub const IDEAL_READS: &str = "simulation_rate_hz";

/// What ran the trials, in words: the simulator and, for the bundled one, its perception.
fn simulated(p: &Protocol) -> String {
    match p.simulator.as_str() {
        IDEAL_SIMULATOR => format!(
            "Simulator: `{IDEAL_SIMULATOR}` — idealised perception (ground truth with noise): it \
             reads only {IDEAL_READS}, so the camera and lidar settings change nothing and their \
             learned values are arbitrary (fidelity.md marks them)."
        ),
        "savme-sim/sensors" => {
            "Simulator: `savme-sim/sensors` — camera + lidar perception (the paper's).".into()
        }
        other => format!("Simulator: `{other}`."),
    }
}

/// Whether the campaign's simulator ignores fidelity setting `name`.
fn ignored(p: &Protocol, name: &str) -> bool {
    p.simulator == IDEAL_SIMULATOR && name != IDEAL_READS
}

fn cost_name(c: Cost) -> &'static str {
    match c {
        Cost::Wall => "measured wall-clock time",
        Cost::Work => "deterministic work units",
    }
}

/// A cumulative cost for people: minutes, seconds, milliseconds or microseconds for
/// wall-clock; work units, thousands or millions of them.
///
/// ```
/// use savme_campaign::report::format_cost;
/// use savme_campaign::Cost;
/// assert_eq!(format_cost(Cost::Wall, 0.0123), "12.3 ms");
/// assert_eq!(format_cost(Cost::Work, 800.0), "800 work units");
/// ```
pub fn format_cost(c: Cost, v: f64) -> String {
    match c {
        Cost::Wall => format_seconds(v),
        Cost::Work if v >= 1e7 => format!("{:.1} M work units", v / 1e6),
        Cost::Work if v >= 1e4 => format!("{:.0} k work units", v / 1e3),
        Cost::Work => format!("{v:.0} work units"),
    }
}

/// A duration for people: `2.5 min` from two minutes on, `1.5 s`, `12.3 ms`, `4.2 µs`, `0 s` —
/// never `0.0 s` for a time below a second.
///
/// ```
/// use savme_campaign::report::format_seconds;
/// assert_eq!(format_seconds(0.0042), "4.2 ms");
/// assert_eq!(format_seconds(3.1e-6), "3.1 µs");
/// assert_eq!(format_seconds(41.25), "41.2 s");
/// ```
pub fn format_seconds(s: f64) -> String {
    match s {
        s if s >= 120.0 => format!("{:.1} min", s / 60.0),
        s if s >= 1.0 => format!("{s:.1} s"),
        s if s >= 1e-3 => format!("{:.1} ms", s * 1e3),
        s if s > 0.0 => format!("{:.1} µs", s * 1e6),
        _ => "0 s".into(),
    }
}

/// A probability as a person reads it: two significant digits (`0.081`, `0.22`, `0.00084`,
/// `0`), and below 0.0001 in scientific notation (`2.0e-6`); the raw value is in the JSON
/// outputs.
///
/// ```
/// use savme_campaign::report::format_probability;
/// assert_eq!(format_probability(8.065e-2), "0.081");
/// assert_eq!(format_probability(2.164e-1), "0.22");
/// assert_eq!(format_probability(0.0), "0");
/// assert_eq!(format_probability(1.0), "1.0");
/// assert_eq!(format_probability(8.4e-4), "0.00084");
/// assert_eq!(format_probability(2.04e-6), "2.0e-6");
/// assert_eq!(format_probability(f64::NAN), "—");
/// ```
pub fn format_probability(x: f64) -> String {
    match x {
        x if !x.is_finite() => "—".into(),
        0.0 => "0".into(),
        x if x.abs() < 1e-4 => format!("{x:.1e}"),
        x => {
            let digits = (1 - x.abs().log10().floor() as i32).max(0) as usize;
            format!("{x:.digits$}")
        }
    }
}

fn format_value(var: &savme_kernel::Variable, v: &savme_kernel::Value, with_bin: bool) -> String {
    match (v.as_f64(), var.arm_of(v).and_then(|a| var.bin(a))) {
        (Some(x), Some((lo, hi))) if with_bin => format!("{} [{}, {}]", sig(x), sig(lo), sig(hi)),
        _ => v.to_string(),
    }
}

/// Three significant digits.
fn sig(x: f64) -> String {
    if x == 0.0 {
        return "0".into();
    }
    let digits = (2 - x.abs().log10().floor() as i32).max(0) as usize;
    format!("{x:.digits$}")
}

#[cfg(test)]
mod tests {
    use super::{Protocol, Report, TABLE_III_LEGEND};

    #[test]
    fn the_perception_is_stated_and_the_settings_it_ignores_are_marked() {
        let space = savme_kernel::Space::new(vec![
            savme_kernel::Variable::discrete("simulation_rate_hz", [2, 10]),
            savme_kernel::Variable::boolean("camera_disable_shadows"),
        ])
        .unwrap();
        let hf = savme_kernel::Assignment::new()
            .with("simulation_rate_hz", 10)
            .with("camera_disable_shadows", false);
        let ideal = Protocol::quick(super::IDEAL_SIMULATOR, vec!["a".into()], vec!["b".into()]);
        let r = Report::from_trials(&ideal, &[]);
        assert!(
            r.table_md().contains("idealised perception"),
            "{}",
            r.table_md()
        );
        let f = r.fidelity_md(&space, &hf);
        assert!(
            f.contains("| camera_disable_shadows (ignored: not learned) |"),
            "{f}"
        );
        assert!(f.contains("| simulation_rate_hz |"), "{f}");
        let sensors = Protocol::quick("savme-sim/sensors", vec!["a".into()], vec!["b".into()]);
        let r = Report::from_trials(&sensors, &[]);
        assert!(r.table_md().contains("camera + lidar perception"));
        assert!(!r.fidelity_md(&space, &hf).contains("ignored"));
    }

    #[test]
    fn table_iii_says_what_its_columns_mean() {
        let p = Protocol::quick("toy", vec!["a".into()], vec!["b".into()]);
        let table = Report::from_trials(&p, &[]).table_md();
        let header = table
            .lines()
            .position(|l| l.starts_with("| C_budget | TP-rate | mean LF cost | speedup |"));
        let legend = table.lines().position(|l| l == TABLE_III_LEGEND);
        assert!(
            matches!((header, legend), (Some(h), Some(l)) if h < l),
            "{table}"
        );
        for column in [
            "TP-rate:",
            "Mean LF cost:",
            "Speedup = (TP-rate / mean LF cost)",
        ] {
            assert!(TABLE_III_LEGEND.contains(column), "{column}");
        }
    }
}
