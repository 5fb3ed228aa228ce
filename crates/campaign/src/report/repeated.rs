//! The results of a campaign repeated with N seeds: every number of the single-campaign
//! [`Report`] as the mean over the seeds with a Student-t 95 % interval, the per-seed values
//! beside it, and binomial (Wilson) intervals on the TP-rate and the baseline failure rate.

use super::intervals::Interval;
use super::text::{cost_name, scenarios};
use super::Report;
use crate::protocol::Protocol;
use serde::Serialize;
use std::fmt::Write as _;

/// One number over the seeds: mean with its t interval, and the value of every seed (None
/// where it is undefined in that seed, e.g. a speedup without baseline failures).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Stat {
    /// Mean over the seeds where it is defined, with its 95 % interval (None if in none).
    pub mean: Option<Interval>,
    /// The value of each seed, in seed order.
    pub per_seed: Vec<Option<f64>>,
}

impl Stat {
    /// The statistic of per-seed values.
    pub fn of(per_seed: Vec<Option<f64>>) -> Stat {
        let defined: Vec<f64> = per_seed.iter().flatten().copied().collect();
        Stat {
            mean: Interval::t_mean(&defined),
            per_seed,
        }
    }

    /// `mean [lo, hi]`, or `–` if undefined in every seed.
    pub fn show(&self, digits: usize) -> String {
        self.mean.map_or("–".into(), |i| i.show(digits))
    }

    /// Seeds in which the value is defined.
    pub fn defined(&self) -> usize {
        self.per_seed.iter().flatten().count()
    }
}

/// A proportion over the seeds: the per-seed rates (with their Wilson intervals), the mean
/// with its t interval, and the pooled Wilson interval of all seeds' trials together.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Rate {
    /// Mean of the per-seed rates with its t interval, and the rates.
    pub over_seeds: Stat,
    /// Successes and trials pooled over the seeds, with the Wilson interval.
    pub pooled: Option<Interval>,
    /// Each seed's Wilson interval.
    pub per_seed_wilson: Vec<Option<Interval>>,
}

impl Rate {
    /// The rate of `(successes, trials)` per seed (None: the stage did not run).
    pub fn of(counts: &[Option<(u64, u64)>]) -> Rate {
        let (k, n) = counts
            .iter()
            .flatten()
            .fold((0, 0), |(k, n), (a, b)| (k + a, n + b));
        let mut over_seeds = Stat::of(
            counts
                .iter()
                .map(|c| c.filter(|c| c.1 > 0).map(|(k, n)| k as f64 / n as f64))
                .collect(),
        );
        // A rate lies in [0, 1]: the t interval of few seeds may reach past either end.
        if let Some(i) = &mut over_seeds.mean {
            i.lo = i.lo.map(|x| x.max(0.0));
            i.hi = i.hi.map(|x| x.min(1.0));
        }
        Rate {
            over_seeds,
            pooled: Interval::wilson(k, n),
            per_seed_wilson: counts
                .iter()
                .map(|c| c.and_then(|(k, n)| Interval::wilson(k, n)))
                .collect(),
        }
    }
}

/// Meta-testing at one budget over the seeds.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RepeatedMetaTesting {
    /// Failures found by the common horizon (every run charged) with the learned prior.
    pub learned: Stat,
    /// … with the uniform prior.
    pub uniform: Stat,
    /// … by the baseline.
    pub baseline: Stat,
    /// learned / uniform − 1, every run charged.
    pub gain_vs_uniform: Stat,
    /// learned / uniform − 1, LF runs only (TP).
    pub gain_vs_uniform_lf_only: Stat,
    /// learned / baseline − 1, every run charged.
    pub gain_vs_baseline: Stat,
    /// learned / uniform − 1 under LF screening with HF confirmation.
    pub gain_vs_uniform_screened: Stat,
}

/// LF screening at one budget over the seeds.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RepeatedScreening {
    /// Confirmed failures per runtime / the paired evaluation's HF failures per runtime.
    pub vs_paired: Stat,
    /// … / the baseline's.
    pub vs_baseline: Stat,
    /// The miss rate among LF passes from the audits (pooled with Wilson, and per seed).
    pub miss_rate: Rate,
    /// Share of LF failures confirmed by HF.
    pub confirmed_share: Rate,
}

/// One strength of the prior-strength ablation over the seeds.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RepeatedStrength {
    /// The strength (0 = uniform prior).
    pub strength: f64,
    /// Failures found by the common horizon, every run charged.
    pub found: Stat,
    /// Gain over the uniform prior, every run charged.
    pub gain_all_runs: Stat,
    /// Gain over the uniform prior, LF runs only.
    pub gain_lf_only: Stat,
    /// Mean LF cost of the stage.
    pub mean_lf_cost: Stat,
}

/// Everything about one budget over the seeds.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RepeatedBudget {
    /// C_budget.
    pub budget: f64,
    /// Evaluation TP-rate (TP of the evaluation trials).
    pub tp_rate: Rate,
    /// Evaluation mean LF cost.
    pub mean_lf_cost: Stat,
    /// Speedup (the paper's definition).
    pub speedup: Stat,
    /// Break-even cost of meta-training vs the baseline (None in a seed where not reached).
    pub break_even: Stat,
    /// Meta-testing.
    pub meta_testing: RepeatedMetaTesting,
    /// The prior-strength ablation (empty without one).
    pub ablation: Vec<RepeatedStrength>,
    /// LF screening (None without a screening stage).
    pub screening: Option<RepeatedScreening>,
}

/// The results of N seeds of one protocol.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RepeatedReport {
    /// The protocol of the first seed (the others differ only in `seed`).
    pub protocol: Protocol,
    /// The seeds, in order.
    pub seeds: Vec<u64>,
    /// HF failure rate of the baseline on the meta-training scenarios.
    pub baseline_train: Rate,
    /// HF failure rate of the baseline on the meta-testing scenarios.
    pub baseline_test: Rate,
    /// Per budget.
    pub budgets: Vec<RepeatedBudget>,
}

impl RepeatedReport {
    /// Aggregates the reports of one protocol run with different seeds (in seed order).
    pub fn from_reports(reports: &[Report]) -> RepeatedReport {
        let protocol = reports
            .first()
            .map(|r| r.protocol.clone())
            .unwrap_or_else(|| Protocol::paper("", vec![], vec![]));
        let base = |f: fn(&Report) -> Option<super::Baseline>| {
            let counts: Vec<_> = reports
                .iter()
                .map(|r| f(r).map(|b| (b.failures, b.trials)))
                .collect();
            Rate::of(&counts)
        };
        let budgets = protocol
            .budgets
            .iter()
            .enumerate()
            .map(|(i, &b)| budget(reports, i, b))
            .collect();
        RepeatedReport {
            seeds: reports.iter().map(|r| r.protocol.seed).collect(),
            protocol,
            baseline_train: base(|r| r.baseline_train),
            baseline_test: base(|r| r.baseline_test),
            budgets,
        }
    }

    /// Table III with intervals, meta-testing, the screening and the ablation (Markdown):
    /// one document, its sections written in order.
    pub fn table_md(&self) -> String {
        let mut s = String::new();
        self.table_iii(&mut s);
        self.meta_testing_md(&mut s);
        if self.budgets.iter().any(|b| b.screening.is_some()) {
            self.screening_md(&mut s);
        }
        if self.budgets.iter().any(|b| !b.ablation.is_empty()) {
            self.ablation_md(&mut s);
        }
        s
    }

    /// Table III over the seeds.
    fn table_iii(&self, s: &mut String) {
        let p = &self.protocol;
        let n = self.seeds.len();
        let _ = writeln!(
            s,
            "# Meta-training results over {n} seeds (the paper's Table III with 95 % intervals)\n"
        );
        let _ = writeln!(
            s,
            "Seeds {}. Per seed: {} evaluation trials per budget after {} meta-training \
             iterations on {}; baseline {} trials. Cost: {}. Each cell: mean over the \
             seeds [Student-t 95 % interval]; rates also pooled over all seeds' trials [Wilson \
             95 % interval].\n",
            seed_list(&self.seeds),
            p.eval_iterations,
            p.train_iterations,
            scenarios(p.train_scenarios.len()),
            p.baseline_train_iterations,
            cost_name(p.cost),
        );
        let _ = writeln!(
            s,
            "| C_budget | TP-rate (mean of seeds) | TP-rate (pooled, Wilson) | mean LF cost | speedup | break-even |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|");
        let _ = writeln!(
            s,
            "| baseline | {} | {} | 1.00 | 1.00 | – |",
            self.baseline_train.over_seeds.show(3),
            show_opt(self.baseline_train.pooled, 3)
        );
        for b in &self.budgets {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} ({} of {n} seeds) |",
                b.budget,
                b.tp_rate.over_seeds.show(3),
                show_opt(b.tp_rate.pooled, 3),
                b.mean_lf_cost.show(3),
                b.speedup.show(1),
                show_cost(&b.break_even, p.cost),
                b.break_even.defined(),
            );
        }
    }

    /// The meta-testing section.
    fn meta_testing_md(&self, s: &mut String) {
        let p = &self.protocol;
        let _ = writeln!(s, "\n{}", super::TABLE_III_LEGEND);
        let _ = writeln!(
            s,
            "\n## Meta-testing (scenarios {}), failures found by the common runtime\n",
            p.test_scenarios.join(", ")
        );
        let _ = writeln!(
            s,
            "Baseline failure rate on these scenarios: {} (pooled {}).\n",
            self.baseline_test.over_seeds.show(3),
            show_opt(self.baseline_test.pooled, 3)
        );
        let _ = writeln!(
            s,
            "| C_budget | learned prior | uniform prior | baseline | gain vs uniform (every run) | gain vs uniform (LF only) | gain vs baseline |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|---|");
        for b in &self.budgets {
            let m = &b.meta_testing;
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} |",
                b.budget,
                m.learned.show(1),
                m.uniform.show(1),
                m.baseline.show(1),
                m.gain_vs_uniform.show(2),
                m.gain_vs_uniform_lf_only.show(2),
                m.gain_vs_baseline.show(2),
            );
        }
    }

    /// The screening section.
    fn screening_md(&self, s: &mut String) {
        let p = &self.protocol;
        let _ = writeln!(
            s,
            "\n## LF screening with HF confirmation ({} trials per budget and seed, audit α = {})\n",
            p.screen_iterations, p.audit_fraction
        );
        let _ = writeln!(
            s,
            "| C_budget | confirmed failures / runtime vs paired evaluation | vs HF-only baseline | LF failures confirmed (pooled) | miss rate of LF passes (pooled audit) | meta-testing gain vs uniform (screened) |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|");
        for b in &self.budgets {
            if let Some(x) = &b.screening {
                let _ = writeln!(
                    s,
                    "| {} | {} × | {} × | {} | {} | {} |",
                    b.budget,
                    x.vs_paired.show(2),
                    x.vs_baseline.show(1),
                    show_opt(x.confirmed_share.pooled, 3),
                    show_opt(x.miss_rate.pooled, 3),
                    b.meta_testing.gain_vs_uniform_screened.show(2),
                );
            }
        }
    }

    /// The prior-strength ablation section.
    fn ablation_md(&self, s: &mut String) {
        let p = &self.protocol;
        let _ = writeln!(
            s,
            "\n## Prior-strength ablation of meta-testing\n\nStrength 0 is the uniform prior, \
             {} the protocol's learned prior. Gain = found failures / the uniform prior's − 1 \
             by the common runtime of all strengths.\n",
            p.prior_strength
        );
        let _ = writeln!(
            s,
            "| C_budget | strength | found (every run) | gain (every run) | gain (LF only) | mean LF cost |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|");
        for b in &self.budgets {
            for r in &b.ablation {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {} | {} |",
                    b.budget,
                    r.strength,
                    r.found.show(1),
                    r.gain_all_runs.show(2),
                    r.gain_lf_only.show(2),
                    r.mean_lf_cost.show(3)
                );
            }
        }
    }
}

/// `1–5` for consecutive seeds, else a list.
fn seed_list(seeds: &[u64]) -> String {
    match (seeds.first(), seeds.last()) {
        (Some(a), Some(b)) if seeds.windows(2).all(|w| w[1] == w[0] + 1) && a != b => {
            format!("{a}–{b}")
        }
        _ => seeds
            .iter()
            .map(u64::to_string)
            .collect::<Vec<_>>()
            .join(", "),
    }
}

/// A cost statistic for people (`41.2 s [30.1 s, 52.3 s]`, `2.7 M work units […]`).
fn show_cost(s: &Stat, cost: crate::protocol::Cost) -> String {
    let f = |v: f64| super::format_cost(cost, v);
    match s.mean {
        Some(Interval {
            mean,
            lo: Some(lo),
            hi: Some(hi),
            ..
        }) => format!("{} [{}, {}]", f(mean), f(lo), f(hi)),
        Some(i) => f(i.mean),
        None => "–".into(),
    }
}

fn show_opt(i: Option<Interval>, digits: usize) -> String {
    i.map_or("–".into(), |i| i.show(digits))
}

/// The aggregate of budget `i` (= `b`).
fn budget(reports: &[Report], i: usize, b: f64) -> RepeatedBudget {
    fn at(r: &Report, i: usize) -> Option<&super::BudgetReport> {
        r.budgets.get(i)
    }
    let stat = |f: &dyn Fn(&super::BudgetReport) -> Option<f64>| {
        Stat::of(reports.iter().map(|r| at(r, i).and_then(f)).collect())
    };
    let eval = |f: fn(&super::Evaluation) -> Option<f64>| {
        stat(&move |x: &super::BudgetReport| x.evaluation.as_ref().and_then(f))
    };
    let meta = |f: fn(&super::MetaTesting) -> Option<f64>| {
        stat(&move |x: &super::BudgetReport| x.meta_testing.as_ref().and_then(f))
    };
    let counts: Vec<_> = reports
        .iter()
        .map(|r| at(r, i).and_then(|x| x.evaluation.as_ref().map(|e| (e.tp, e.trials))))
        .collect();
    let strengths = reports
        .first()
        .map(|r| r.protocol.prior_strengths.clone())
        .unwrap_or_default();
    let ablation = strengths
        .iter()
        .enumerate()
        .map(|(k, &strength)| {
            let row = |f: fn(&super::ablation::StrengthRow) -> Option<f64>| {
                stat(&move |x: &super::BudgetReport| {
                    x.ablation.as_ref().and_then(|a| a.rows.get(k)).and_then(f)
                })
            };
            RepeatedStrength {
                strength,
                found: row(|r| Some(r.all_runs as f64)),
                gain_all_runs: row(|r| r.gain_all_runs),
                gain_lf_only: row(|r| r.gain_lf_only),
                mean_lf_cost: row(|r| Some(r.mean_lf_cost)),
            }
        })
        .collect();
    RepeatedBudget {
        budget: b,
        tp_rate: Rate::of(&counts),
        mean_lf_cost: eval(|e| Some(e.mean_lf_cost)),
        speedup: eval(|e| e.speedup),
        break_even: stat(&|x| x.training.as_ref().and_then(|t| t.break_even)),
        meta_testing: RepeatedMetaTesting {
            learned: meta(|m| Some(m.all_runs.learned as f64)),
            uniform: meta(|m| Some(m.all_runs.uniform as f64)),
            baseline: meta(|m| Some(m.all_runs.baseline as f64)),
            gain_vs_uniform: meta(|m| m.all_runs.gain_vs_uniform),
            gain_vs_uniform_lf_only: meta(|m| m.lf_only.gain_vs_uniform),
            gain_vs_baseline: meta(|m| m.all_runs.gain_vs_baseline),
            gain_vs_uniform_screened: meta(|m| m.screened.gain_vs_uniform),
        },
        ablation,
        screening: screening(reports, i),
    }
}

/// The screening of budget `i` over the seeds (None if no seed screened).
fn screening(reports: &[Report], i: usize) -> Option<RepeatedScreening> {
    let per: Vec<Option<&super::screening::Screening>> = reports
        .iter()
        .map(|r| r.budgets.get(i).and_then(|b| b.screening.as_ref()))
        .collect();
    if per.iter().all(Option::is_none) {
        return None;
    }
    let stat = |f: fn(&super::screening::Screening) -> Option<f64>| {
        Stat::of(per.iter().map(|s| s.and_then(f)).collect())
    };
    let rate = |f: fn(&super::screening::Screening) -> (u64, u64)| {
        Rate::of(&per.iter().map(|s| s.map(f)).collect::<Vec<_>>())
    };
    Some(RepeatedScreening {
        vs_paired: stat(|s| s.vs_paired),
        vs_baseline: stat(|s| s.vs_baseline),
        miss_rate: rate(|s| (s.counts.audit_misses, s.counts.audited)),
        confirmed_share: rate(|s| (s.counts.confirmed, s.counts.lf_failures)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rate_pools_the_seeds_and_keeps_each_seeds_interval() {
        let r = Rate::of(&[Some((20, 100)), Some((30, 100)), None]);
        assert_eq!(r.over_seeds.per_seed, [Some(0.2), Some(0.3), None]);
        let pooled = r.pooled.unwrap();
        assert_eq!((pooled.mean, pooled.n), (0.25, 200));
        assert!(pooled.lo.unwrap() < 0.25 && pooled.hi.unwrap() > 0.25);
        assert!(r.per_seed_wilson[2].is_none());
        assert_eq!(r.over_seeds.mean.unwrap().n, 2);
    }

    #[test]
    fn seed_lists_are_ranges_when_consecutive() {
        assert_eq!(seed_list(&[1, 2, 3]), "1–3");
        assert_eq!(seed_list(&[1, 5]), "1, 5");
        assert_eq!(seed_list(&[4]), "4");
    }
}
