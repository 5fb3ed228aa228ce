//! What a report says in words: Table III (`table.md`), Table IV (`fidelity.md`), the
//! findings printed at the end of a campaign, and how costs, durations and probabilities are
//! written for people.

use super::fidelity::FidelityReport;
use super::{intervals, Report};
use crate::protocol::{Cost, LadderTraining, Protocol, ThetaLfChoice, Transfer};
use savme_kernel::{Assignment, Space};
use std::fmt::Write as _;

impl Report {
    /// Table III: baseline and each budget's TP-rate, mean LF cost and speedup (Markdown),
    /// followed by [`TABLE_III_LEGEND`].
    pub fn table_md(&self) -> String {
        let p = &self.protocol;
        let mut s = String::new();
        let _ = writeln!(s, "# Meta-training results (the paper's Table III)\n");
        let _ = writeln!(
            s,
            "Evaluation: {} trials per budget with {} and φ ~ p_ψ, after {} \
             meta-training iterations on {}. Baseline: {} trials with φ uniform, \
             high fidelity only. Cost: {}. Seed {}. {}\n",
            p.eval_iterations,
            match p.theta_lf_choice {
                ThetaLfChoice::Map => "θ_LF = MAP of p_ω",
                ThetaLfChoice::Evidence => "θ_LF* chosen from evidence (fidelity.md)",
            },
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
        self.ladder_md(&mut s);
        s
    }

    /// The screening stage of a fidelity ladder, per level (Table III above has a row per
    /// level: each level's own evaluation; Table IV a column), against every two-level
    /// screening stage of the campaign (Markdown; nothing without a ladder).
    fn ladder_md(&self, s: &mut String) {
        let c = self.protocol.cost;
        let per_cost = |x: &super::screening::Screening| {
            x.confirmed_per_runtime
                .map_or("–".into(), |r| format!("{:.3e}", r))
        };
        for b in &self.budgets {
            let Some(x) = b.screening.as_ref().filter(|x| x.levels.len() > 1) else {
                continue;
            };
            let names: Vec<String> = x.levels.iter().map(|l| level_name(l.budget)).collect();
            let _ = writeln!(
                s,
                "\n## Fidelity ladder {} → HF ({} screened trials)\n",
                names.join(" → "),
                x.counts.trials
            );
            let _ = writeln!(
                s,
                "{}; a level's LF failure goes to the next level up, the last level's to HF.\n",
                match self.protocol.ladder_training {
                    LadderTraining::Separate => "Each level runs the θ_LF* of its own meta-training (Table III's row and Table IV's column of its budget)",
                    LadderTraining::Shared => "Only the top level meta-trained (ladder_training = shared): each level below runs the θ_LF* read off the top level's meta-training trials re-credited at its own budget, so the ladder cost the meta-training of one level",
                }
            );
            let _ = writeln!(
                s,
                "| level | LF runs | flagged (sent up) | of those, HF failures | skipped (did not pay) | cost of its runs |"
            );
            let _ = writeln!(s, "|---|---|---|---|---|---|");
            for (l, name) in x.levels.iter().zip(&names) {
                let _ = writeln!(
                    s,
                    "| {name} | {} | {} | {} | {} | {} |",
                    l.runs,
                    l.flagged,
                    l.confirmed,
                    l.skipped,
                    format_cost(c, l.runtime)
                );
            }
            let hf_runs =
                x.counts.lf_failures + x.counts.audited + x.counts.margin_checks + x.counts.direct;
            let _ = writeln!(
                s,
                "| HF | {hf_runs} | {} HF failures | | | {} |",
                x.counts.found() + x.counts.audit_misses,
                format_cost(c, x.counts.hf_runtime)
            );
            let _ = writeln!(
                s,
                "\nHF-confirmed failures per unit of cost, every run charged:\n\n- the ladder: {} ({} in {})",
                per_cost(x),
                x.counts.found(),
                format_cost(c, x.counts.runtime())
            );
            for other in &self.budgets {
                if let Some(y) = other.screening.as_ref().filter(|y| y.levels.len() == 1) {
                    let _ = writeln!(
                        s,
                        "- two-level screening at C_budget = {}: {} ({} in {})",
                        other.budget,
                        per_cost(y),
                        y.counts.found(),
                        format_cost(c, y.counts.runtime())
                    );
                }
            }
        }
    }

    /// Table IV: the learned fidelity setting per budget next to θ_HF (Markdown).
    pub fn fidelity_md(&self, space: &Space, theta_hf: &Assignment) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# Learned fidelity settings (the paper's Table IV)\n");
        let rule = match self.protocol.theta_lf_choice {
            ThetaLfChoice::Map => "MAP of p_ω",
            ThetaLfChoice::Evidence => {
                "chosen from evidence (per setting, the highest lower 10 % quantile of each \
                 arm's Beta belief, every false alarm charged as 1 / C_budget losses)"
            }
        };
        let _ = writeln!(
            s,
            "θ_LF* = {rule} after meta-training, per budget. Continuous settings show the \
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
        self.shared_levels_md(&mut s, space);
        for b in &self.budgets {
            if let Some(f) = &b.fidelity {
                evidence_md(&mut s, b.budget, f);
                transfer_md(&mut s, b.budget, f);
                phi_transfer_md(&mut s, b.budget, f);
            }
        }
        s
    }

    /// Table IV's columns of a shared ladder's levels below its top (nothing without one).
    fn shared_levels_md(&self, s: &mut String, space: &Space) {
        for b in &self.budgets {
            let Some(f) = b.fidelity.as_ref().filter(|f| !f.shared_levels.is_empty()) else {
                continue;
            };
            let _ = writeln!(
                s,
                "\n## The ladder's levels below C_budget = {} (shared meta-training)\n\n\
                 θ_LF* of each level, read off the meta-training trials of C_budget = {} \
                 re-credited at the level's budget (`ladder_training = shared`).\n",
                b.budget, b.budget
            );
            let _ = write!(s, "| setting |");
            for l in &f.shared_levels {
                let _ = write!(s, " C = {} |", l.budget);
            }
            let _ = writeln!(s, "\n|---|{}", "---|".repeat(f.shared_levels.len()));
            for var in space.variables() {
                let _ = write!(s, "| {} |", var.name);
                for l in &f.shared_levels {
                    let v = l
                        .theta_lf
                        .get(&var.name)
                        .map_or("–".into(), |v| format_value(var, v, true));
                    let _ = write!(s, " {v} |");
                }
                let _ = writeln!(s);
            }
        }
    }

    /// The human summary printed at the end: break-even times, meta-testing gains, the
    /// screening stage and the prior-strength ablation.
    pub fn findings_text(&self) -> String {
        let mut s = String::new();
        self.break_even_text(&mut s);
        self.meta_testing_text(&mut s);
        self.screening_text(&mut s);
        self.ablation_text(&mut s);
        s
    }

    fn break_even_text(&self, s: &mut String) {
        let _ = writeln!(
            s,
            "Break-even (meta-training vs baseline, every run charged):"
        );
        for b in &self.budgets {
            let text = match b.training.as_ref().map(|t| t.break_even) {
                Some(Some(t)) => format!("after {}", format_cost(self.protocol.cost, t)),
                Some(None) => "not reached within the common runtime".into(),
                None => "not run".into(),
            };
            let _ = writeln!(s, "  C_budget = {}: {text}", b.budget);
        }
    }

    fn meta_testing_text(&self, s: &mut String) {
        let p = &self.protocol;
        let _ = writeln!(
            s,
            "Meta-testing (scenarios {}), failures found by the same runtime, learned vs uniform \
             fidelity prior vs baseline:",
            p.test_scenarios.join(", ")
        );
        for b in &self.budgets {
            let Some(m) = &b.meta_testing else {
                let _ = writeln!(s, "  C_budget = {}: not run", b.budget);
                continue;
            };
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
                    percent(f.gain_vs_uniform),
                    percent(f.gain_vs_baseline)
                );
            }
        }
    }

    fn screening_text(&self, s: &mut String) {
        for b in &self.budgets {
            if let Some(x) = &b.screening {
                let times = |v: Option<f64>| v.map_or("n/a".into(), |v| format!("{v:.2} ×"));
                let ladder = match x.levels.len() {
                    0 | 1 => String::new(),
                    _ => format!(
                        " (ladder {} → HF)",
                        (x.levels.iter().map(|l| level_name(l.budget)))
                            .collect::<Vec<_>>()
                            .join(" → ")
                    ),
                };
                let _ = writeln!(
                    s,
                    "LF screening with HF confirmation, C_budget = {}{ladder}: {} confirmed of {} LF failures in {} trials ({}); {} vs the paired evaluation, {} vs the baseline; audit {} of {} LF passes (α = {}): miss rate {}",
                    b.budget,
                    x.counts.confirmed,
                    x.counts.lf_failures,
                    x.counts.trials,
                    format_cost(self.protocol.cost, x.counts.runtime()),
                    times(x.vs_paired),
                    times(x.vs_baseline),
                    x.counts.audit_misses,
                    x.counts.audited,
                    x.audit_fraction,
                    x.miss_rate.map_or("n/a".into(), |i| i.show(3)),
                );
            }
        }
    }

    fn ablation_text(&self, s: &mut String) {
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
                .map(|r| {
                    let gain = percent(r.gain_all_runs);
                    format!("{}: {} ({gain})", r.strength, r.all_runs)
                })
                .collect();
            let _ = writeln!(s, "  C_budget = {budget}: {}", rows.join(", "));
        }
    }
}

/// A rate as `0.12`, `–` when undefined.
/// A ladder level as the tables name it: `C = 0.1`.
fn level_name(budget: Option<f64>) -> String {
    budget.map_or("LF".into(), |b| format!("C = {b}"))
}

fn rate(r: Option<f64>) -> String {
    r.map_or("–".into(), |r| format!("{r:.2}"))
}

/// What stands behind θ_LF* at one budget: per setting, the arm's meta-training tries and its
/// false-alarm and miss rates on HF; then θ_LF* on the evaluation's own trials.
fn evidence_md(s: &mut String, budget: f64, f: &FidelityReport) {
    if f.settings.is_empty() {
        return;
    }
    let _ = writeln!(
        s,
        "\n## θ_LF* at C_budget = {budget}: the evidence per setting\n\n\
         Meta-training trials that tried the chosen arm (paired, crediting p_ω), its fidelity \
         successes (Table I), false-alarm rate FP / (FP + TN) and miss rate FN / (TP + FN) on \
         HF, and mean LF cost.\n"
    );
    let _ = writeln!(
        s,
        "| setting | arm | tried | successes | false alarms | misses | mean LF cost |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|");
    for c in &f.settings {
        let t = &c.tally;
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} ({}) | {} ({}) | {} |",
            c.variable,
            c.arm,
            t.tried,
            t.successes,
            rate(c.false_alarm_rate),
            t.fp,
            rate(c.miss_rate),
            t.fn_,
            rate(t.mean_cost())
        );
    }
    if let Some(e) = &f.evaluation {
        let _ = writeln!(
            s,
            "\nθ_LF* on the {} evaluation trials (all settings together): false-alarm rate {}, \
             miss rate {}.",
            e.trials,
            rate(e.false_alarm_rate),
            rate(e.miss_rate)
        );
    }
}

/// The learned prior's strength at one budget, and why (the held-out likelihoods).
fn transfer_md(s: &mut String, budget: f64, f: &FidelityReport) {
    let t = &f.transfer;
    let _ = writeln!(
        s,
        "\n## Transfer to meta-testing at C_budget = {budget} ({})\n",
        match t.mode {
            Transfer::Fixed => "fixed: `prior_strength` for every setting",
            Transfer::Auto => "auto: per setting, leave-one-scenario-out",
        }
    );
    let Some(c) = &t.choice else {
        let _ = writeln!(
            s,
            "Fewer than two meta-training scenarios with evidence: no held-out check{}.",
            if t.mode == Transfer::Auto {
                ", so nothing is transferred (strength 0, the uniform prior)"
            } else {
                ""
            }
        );
        return;
    };
    let _ = writeln!(
        s,
        "Held-out log-likelihood of each of the {} meta-training scenarios' fidelity outcomes \
         under the prior from the others, summed, per candidate strength (0 = the uniform \
         prior; higher is better; a strength above 0 is taken only if it gains at least {} nat \
         per held-out scenario over 0){}.\n",
        c.scenarios,
        savme_kernel::evidence::MIN_GAIN_PER_SCENARIO,
        if t.mode == Transfer::Fixed {
            "; auto would take the best, the campaign used the fixed strength"
        } else {
            ""
        }
    );
    let _ = write!(s, "| setting | used |");
    for x in &c.candidates {
        let _ = write!(s, " {x} |");
    }
    let _ = writeln!(s);
    let _ = writeln!(s, "|---|---|{}", "---|".repeat(c.candidates.len()));
    let mut row = |name: &str, used: String, ll: &[f64]| {
        let _ = write!(s, "| {name} | {used} |");
        for x in ll {
            let _ = write!(s, " {x:.1} |");
        }
        let _ = writeln!(s);
    };
    for (v, used) in c.variables.iter().zip(&t.strengths) {
        row(&v.variable, used.to_string(), &v.log_likelihood);
    }
    row("(all settings)", "".into(), &c.total);
}

/// The φ (p_ψ) transfer at one budget: per meta-testing scenario and φ variable, the
/// training scenarios sharing it, the strength and why.
fn phi_transfer_md(s: &mut String, budget: f64, f: &FidelityReport) {
    let phi = &f.transfer.phi;
    if phi.is_empty() {
        return;
    }
    let _ = writeln!(
        s,
        "\n## φ (p_ψ) transfer to meta-testing at C_budget = {budget}\n"
    );
    let shared = phi
        .iter()
        .any(|t| t.transfer.variables.iter().any(|v| !v.scenarios.is_empty()));
    if !shared {
        let _ = writeln!(
            s,
            "No meta-testing scenario shares a φ variable (the same name and domain: range, \
             bins and scale, or values) with a meta-training scenario: p_ψ starts at the \
             uniform prior, nothing to transfer."
        );
        return;
    }
    let candidates = &phi[0].transfer.candidates;
    let _ = writeln!(
        s,
        "Per φ variable a meta-testing scenario shares with meta-training scenarios (same name \
         and domain), the held-out log-likelihood of each sharing scenario's failures per bin \
         under the prior from the others, summed, per candidate strength (0 = the uniform \
         prior; a strength above 0 only if it gains at least {} nat per held-out scenario){}.\n",
        savme_kernel::evidence::MIN_GAIN_PER_SCENARIO,
        match f.transfer.mode {
            Transfer::Fixed => {
                "; the strengths are what auto would choose: the campaign (transfer fixed) \
                 transferred no φ"
            }
            Transfer::Auto => "",
        }
    );
    let _ = write!(s, "| scenario | φ variable | shared with | strength |");
    for x in candidates {
        let _ = write!(s, " {x} |");
    }
    let _ = writeln!(s, " why |");
    let _ = writeln!(
        s,
        "|---|---|---|---|{}---|",
        "---|".repeat(candidates.len())
    );
    for t in phi {
        for v in &t.transfer.variables {
            let _ = write!(
                s,
                "| {} | {} | {} | {} |",
                t.scenario,
                v.variable,
                if v.scenarios.is_empty() {
                    "–".to_string()
                } else {
                    v.scenarios.join(", ")
                },
                v.strength
            );
            for c in 0..candidates.len() {
                match v.log_likelihood.get(c) {
                    Some(x) => {
                        let _ = write!(s, " {x:.1} |");
                    }
                    None => {
                        let _ = write!(s, " – |");
                    }
                }
            }
            let _ = writeln!(s, " {} |", v.why());
        }
    }
}

/// A gain as a signed percentage (`+59 %`), `n/a` when there is none.
fn percent(g: Option<f64>) -> String {
    g.map_or("n/a".into(), |g| format!("{:+.0} %", 100.0 * g))
}

/// What Table III's columns mean, written under it (`table.md`, the printed table) so that
/// its numbers can be read without the paper or the code.
pub const TABLE_III_LEGEND: &str = "TP-rate: the share of evaluation trials whose HF and LF \
runs both fail (for the baseline: its HF failure rate). Mean LF cost: the LF run's cost over \
its HF run's, averaged over the evaluation trials. Speedup = (TP-rate / mean LF cost) / \
baseline failure rate (the paper's definition): how many times more failures per unit of \
runtime the learned fidelity alone finds than the HF-only baseline.";

/// "1 scenario", "8 scenarios".
pub(super) fn scenarios(n: usize) -> String {
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

pub(super) fn cost_name(c: Cost) -> &'static str {
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

/// A duration for people (`2.5 min`, `1.5 s`, `12.3 ms`, `4.2 µs`, `0 s`): the figures' own
/// (savme-plot's), so that tables, progress lines and figures say durations alike.
pub use savme_plot::format_seconds;

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
