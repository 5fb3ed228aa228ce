//! Every protocol value, declared once.
//!
//! One declaration per value (its name, type, flag, help text and the stages it changes) in
//! `protocol_values!` below. From it come:
//! - [`Overrides`], the values given by a front end (None: keep the preset's), with
//!   [`Overrides::then`] (a file's values, then the command line's) and [`Overrides::apply`];
//! - the command-line flags: [`Overrides`] is a `clap::Args` (`--train-iterations`, …; each
//!   help text is the declaration's doc comment);
//! - the campaign file's `[campaign]` keys and the Python keyword arguments:
//!   [`Overrides::from_entries`] reads them by name, refusing an unknown name and naming the key
//!   of a value of the wrong type;
//! - [`VALUES`], the list a test walks to prove that every value is reachable from the command
//!   line, a campaign file and Python under the same name, and that the docs can list.
//!
//! Adding a protocol value is one edit: a field of [`Protocol`] and a line here.
//!
//! ```
//! use savme_campaign::values::{Overrides, VALUES};
//! use savme_campaign::Protocol;
//! let o = Overrides::from_entries([("budgets", serde_json::json!([0.3]))])?;
//! let mut p = Protocol::paper("sim", vec!["a".into()], vec!["b".into()]);
//! o.apply(&mut p, &|s: &str| Some(s.to_string()), "")?;
//! assert_eq!(p.budgets, [0.3]);
//! assert!(VALUES.iter().any(|v| v.name == "screen_iterations" && v.flag == "screen-iterations"));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use super::{
    Allocate, CampaignError, Cost, Deploy, LadderTraining, LogBins, Method, Protocol, ScreenLf,
    Search, ThetaLfChoice, Transfer,
};
use savme_kernel::EliteMixture;
use serde::Deserialize;

/// One protocol value as declared.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ValueDef {
    /// Its name: the field of `protocol.json`, the `[campaign]` key and the Python keyword.
    pub name: &'static str,
    /// The command-line flag (without `--`).
    pub flag: &'static str,
    /// Older spellings of the flag, still accepted.
    pub aliases: &'static [&'static str],
    /// What it is (the flag's help text).
    pub help: &'static str,
    /// The stages whose trials it changes.
    pub stages: &'static str,
    /// Whether it is a field of [`Protocol`] (else the command reads it: `repeat`).
    pub in_protocol: bool,
}

/// A value given under a name no protocol value has, or of the wrong type.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{key}`: {message}")]
pub struct ValueError {
    /// The name as given.
    pub key: String,
    /// What is wrong (for an unknown name: the known names).
    pub message: String,
}

macro_rules! apply_value {
    (protocol, $p:ident, $o:ident, $name:ident) => {
        if let Some(v) = &$o.$name {
            $p.$name = v.clone();
        }
    };
    (optional, $p:ident, $o:ident, $name:ident) => {
        if let Some(v) = &$o.$name {
            $p.$name = Some(v.clone());
        }
    };
    (scenarios, $p:ident, $o:ident, $name:ident) => {};
    (command, $p:ident, $o:ident, $name:ident) => {};
}

macro_rules! in_protocol {
    (protocol) => {
        true
    };
    (scenarios) => {
        true
    };
    (optional) => {
        true
    };
    (command) => {
        false
    };
}

/// Declares every protocol value once; see the module docs for what is derived.
macro_rules! protocol_values {
    ($(
        $(#[doc = $doc:literal])+
        $name:ident: $ty:ty, flag = $flag:literal, aliases = [$($alias:literal),*],
        stages = $stages:literal, to = $to:ident $(, cli($($cli:tt)*))?;
    )+) => {
        /// Protocol values given by a front end (None: keep the value before): command-line
        /// flags, a campaign file's `[campaign]` section, Python keyword arguments. Scenarios
        /// are given as the user wrote them and resolved by [`Overrides::apply`].
        #[derive(Debug, Clone, Default, PartialEq, clap::Args, serde::Serialize)]
        pub struct Overrides {
            $(
                $(#[doc = $doc])+
                #[arg(long = $flag, $(visible_alias = $alias,)* $($($cli)*)?)]
                pub $name: Option<$ty>,
            )+
        }

        /// Every protocol value, in declaration order.
        pub const VALUES: &[ValueDef] = &[$(
            ValueDef {
                name: stringify!($name),
                flag: $flag,
                aliases: &[$($alias),*],
                help: concat!($($doc, "\n"),+),
                stages: $stages,
                in_protocol: in_protocol!($to),
            },
        )+];

        impl Overrides {
            /// `self`, with every value `later` gives replacing this one's (a file's values,
            /// then the command line's).
            pub fn then(self, later: &Overrides) -> Overrides {
                Overrides {
                    $($name: later.$name.clone().or(self.$name),)+
                }
            }

            /// Whether the value named `name` is given.
            pub fn is_given(&self, name: &str) -> bool {
                match name {
                    $(stringify!($name) => self.$name.is_some(),)+
                    _ => false,
                }
            }

            /// Reads values by name (a `[campaign]` section, Python keyword arguments): an
            /// unknown name, or a value of the wrong type, is an error naming it.
            pub fn from_entries<'de, K, D>(
                entries: impl IntoIterator<Item = (K, D)>,
            ) -> Result<Overrides, ValueError>
            where
                K: AsRef<str>,
                D: serde::Deserializer<'de>,
                D::Error: std::fmt::Display,
            {
                let mut o = Overrides::default();
                for (key, value) in entries {
                    let key = key.as_ref();
                    let bad = |e: D::Error| ValueError {
                        key: key.to_string(),
                        message: e.to_string(),
                    };
                    // The generic arm of `elite` is shadowed by its own.
                    #[allow(unreachable_patterns)]
                    match key {
                        // The elite parameters a user names, over the defaults: the switches
                        // left out stay on (`EliteMixture::with`).
                        "elite" => {
                            let given = serde_json::Map::<String, serde_json::Value>::deserialize(value)
                                .map_err(bad)?;
                            o.elite = Some(EliteMixture::with(given).map_err(|e| ValueError {
                                key: key.to_string(),
                                message: format!("elite parameters: {e}"),
                            })?);
                        }
                        $(stringify!($name) => {
                            o.$name = Some(<$ty>::deserialize(value).map_err(bad)?)
                        })+
                        _ => return Err(ValueError {
                            key: key.to_string(),
                            message: format!(
                                "not a protocol value (known: {})",
                                VALUES.iter().map(|v| v.name).collect::<Vec<_>>().join(", ")
                            ),
                        }),
                    }
                }
                Ok(o)
            }

            /// Sets the protocol's fields that are given (not the scenarios; not `repeat`).
            fn apply_fields(&self, p: &mut Protocol) {
                $(apply_value!($to, p, self, $name);)+
            }
        }
    };
}

protocol_values! {
    /// Master seed; every kernel's seed is derived from it and the stage's name.
    seed: u64, flag = "seed", aliases = [], stages = "all", to = protocol,
        cli(allow_negative_numbers = true, value_parser = parse_seed);
    /// Cost of a run: measured wall-clock time, or deterministic work units (the same seed
    /// gives the same campaign).
    cost: Cost, flag = "cost", aliases = [], stages = "all", to = protocol, cli(value_enum);
    /// Compute budgets C_budget, comma-separated, each in (0, 1].
    budgets: Vec<f64>, flag = "budgets", aliases = [],
        stages = "train, evaluate, screen, test-*", to = protocol, cli(value_delimiter = ',');
    /// Meta-training iterations per budget.
    train_iterations: u64, flag = "train-iterations", aliases = ["iterations"],
        stages = "train", to = protocol;
    /// Evaluation trials per budget (θ_LF = MAP, φ ~ p_ψ).
    eval_iterations: u64, flag = "eval-iterations", aliases = [], stages = "evaluate",
        to = protocol;
    /// Meta-testing iterations per budget and prior.
    test_iterations: u64, flag = "test-iterations", aliases = [], stages = "test-*",
        to = protocol;
    /// Baseline trials (uniform φ, HF only) on the meta-training scenarios.
    baseline_train_iterations: u64, flag = "baseline-train-iterations",
        aliases = ["baseline-iterations"], stages = "baseline-train", to = protocol;
    /// Baseline trials on the meta-testing scenarios.
    baseline_test_iterations: u64, flag = "baseline-test-iterations", aliases = [],
        stages = "baseline-test", to = protocol;
    /// Meta-training scenarios (numbers or names, comma-separated).
    train_scenarios: Vec<String>, flag = "train-scenarios", aliases = [],
        stages = "baseline-train, train, evaluate, screen", to = scenarios,
        cli(value_delimiter = ',');
    /// Meta-testing scenarios (numbers or names, comma-separated).
    test_scenarios: Vec<String>, flag = "test-scenarios", aliases = [],
        stages = "baseline-test, test-*", to = scenarios, cli(value_delimiter = ',');
    /// Bins per continuous fidelity setting.
    fidelity_bins: u32, flag = "fidelity-bins", aliases = [], stages = "all but the baselines",
        to = protocol;
    /// How log-scaled variables (the bundled simulator's view and clipping distances) are cut
    /// into bins: savme (equal ratios, log-uniform inside) or paper (the authors' code: equal
    /// steps of ln(x − lo + 1), docs/RESULTS.md "Log bins").
    log_bins: LogBins, flag = "log-bins", aliases = [], stages = "all", to = protocol,
        cli(value_enum);
    /// Strength of the transferred fidelity prior in meta-testing (power prior; 1 = the
    /// meta-training posterior as is); with transfer = auto, the largest strength auto may
    /// choose (its candidates are 0, 0.03, 0.1, 0.3, 0.6 and 1 times it).
    prior_strength: f64, flag = "prior-strength", aliases = [], stages = "test-learned",
        to = protocol;
    /// Trials in flight at once: asked, not yet told (at most 2 runs each). Keeps up to about
    /// 2 × window jobs or `savme worker` threads busy; set it to the number of threads that run
    /// the campaign. Changes the trials (the number of jobs does not): a window that is a large
    /// share of a stage's iterations finds fewer failures per cost (docs/DISTRIBUTED.md, "The
    /// window").
    window: usize, flag = "window", aliases = [], stages = "all", to = protocol;
    /// Meta-testing prior-strength ablation: strengths to compare, comma-separated (0 = the
    /// uniform prior), e.g. 0,0.1,0.3,1.
    prior_strengths: Vec<f64>, flag = "prior-strengths", aliases = [], stages = "test-learned-s*",
        to = protocol, cli(value_delimiter = ',');
    /// LF screening with HF confirmation: trials per budget after the evaluation (0: none).
    screen_iterations: u64, flag = "screen-iterations", aliases = [], stages = "screen",
        to = protocol, cli(value_name = "N");
    /// Fraction α of LF passes the screening re-runs on HF to estimate the miss rate.
    audit_fraction: f64, flag = "audit-fraction", aliases = [], stages = "screen",
        to = protocol, cli(value_name = "ALPHA");
    /// How φ is searched in meta-training and meta-testing: the paper's independent bins, or
    /// a joint proposal around the failures found (`elite`).
    search: Search, flag = "search", aliases = [], stages = "train, test-*", to = protocol,
        cli(value_enum);
    /// The elite search's parameters, e.g. `explore=0.1,tries=8` (a table in a campaign file,
    /// a dict in Python); the others keep their defaults, and all are stored with the campaign.
    /// Only with search = elite.
    elite: EliteMixture, flag = "elite", aliases = [], stages = "train, test-*",
        to = optional, cli(value_parser = parse_elite, value_name = "KEY=VALUE,…");
    /// Share of the learning trials that also run LF once θ_LF* has settled, in (0, 1]; the
    /// others run HF only and still teach the φ search (1: every trial, the paper's).
    pair_fraction: f64, flag = "pair-fraction", aliases = [], stages = "train, test-*",
        to = protocol, cli(value_name = "F");
    /// Observations the greedy arm of every fidelity variable needs before θ_LF* counts as
    /// settled and `pair_fraction` applies.
    pair_settle: u64, flag = "pair-settle", aliases = [], stages = "train, test-*",
        to = protocol, cli(value_name = "N");
    /// What the deployed search does with what the search learned: frozen (the paper's),
    /// exploit (the elite proposal draws for failures, not for new cells; search = elite),
    /// learn (every evaluation and screening result keeps teaching the φ search) or adaptive
    /// (both).
    deployment: Deploy, flag = "deployment", aliases = [], stages = "evaluate, screen",
        to = protocol, cli(value_enum);
    /// Which screened trials run LF first: always (the paper's), or where-it-pays (per
    /// scenario, while the LF run costs less than the HF passes it is expected to save; the
    /// others run HF directly).
    screen_lf: ScreenLf, flag = "screen-lf", aliases = [], stages = "screen", to = protocol,
        cli(value_enum);
    /// What the campaign searches with, before the values given here: tuned (savme's search
    /// by cost: search = elite, allocation = cost-rate-scout, deployment = adaptive, screen_lf =
    /// where-it-pays, pair_fraction = 0.25; the default of `savme run` and Python campaigns)
    /// or paper (the paper's SAVME; the default of `savme reproduce`).
    method: Method, flag = "method", aliases = [], stages = "train, evaluate, screen, test-*",
        to = command, cli(value_enum);
    /// How each trial's scenario is chosen: weights (drawn from p(s): the same share of the
    /// trials each, the paper's), cost-rate (a bandit by HF failures per unit cost, each
    /// scenario kept above `coverage_floor` × its share of p(s) in cost), cost-rate-recent
    /// (the same bandit, each scenario's failures and cost forgotten with a half-life of 20
    /// told trials) or cost-rate-scout (the same, and until its first HF failure a scenario
    /// keeps its whole share of p(s) in cost and runs HF only; the tuned method's).
    allocation: Allocate, flag = "allocation", aliases = [], stages = "train, evaluate, screen, test-*",
        to = protocol, cli(value_enum);
    /// The cost-rate allocation's coverage floor in [0, 1]: every scenario gets at least this
    /// share of its weight's share of the cost (1: the cost split by the weights).
    coverage_floor: f64, flag = "coverage-floor", aliases = [], stages = "train, evaluate, screen, test-*",
        to = protocol, cli(value_name = "F", allow_negative_numbers = true);
    /// The cost of each search stage (meta-training, meta-testing) in the cost measure's unit
    /// (work units with cost = work, seconds with wall): the stage runs until its runs have
    /// cost this much, instead of for its iterations.
    search_budget: f64, flag = "search-budget", aliases = [], stages = "train, test-*",
        to = optional, cli(value_name = "COST", allow_negative_numbers = true);
    /// The cost of each deployed search (the LF screening stage) in the cost measure's unit;
    /// adds the screening stage if `screen_iterations` is 0.
    deploy_budget: f64, flag = "deploy-budget", aliases = [], stages = "screen",
        to = optional, cli(value_name = "COST", allow_negative_numbers = true);
    /// How evaluation and screening choose θ_LF*: map (the paper's: the MAP arm of each
    /// fidelity variable) or evidence (the highest lower 10 % quantile of each arm's Beta
    /// belief, every false alarm charged as 1 / C_budget losses).
    theta_lf_choice: ThetaLfChoice, flag = "theta-lf-choice", aliases = [],
        stages = "evaluate, screen", to = protocol, cli(value_enum);
    /// How strongly meta-testing's learned prior carries the meta-training evidence: fixed
    /// (`prior_strength` for every setting, the paper's) or auto (per setting, the strength
    /// whose prior from the other training scenarios best predicts each held-out one,
    /// leave-one-scenario-out; 0, the uniform prior, where they disagree or gain less than a
    /// nat per held-out scenario).
    transfer: Transfer, flag = "transfer", aliases = [], stages = "test-learned", to = protocol,
        cli(value_enum);
    /// A fidelity ladder: two or more of the budgets, cheapest first, comma-separated (e.g.
    /// 0.1,0.3). Each level is meta-trained with its own θ_LF; the screening stage at the top
    /// budget runs the cheapest level's LF first and confirms its failures at the next level
    /// up, HF last (with screen_lf = where-it-pays, only the levels that pay). Empty: the
    /// two-level screening at each budget.
    ladder: Vec<f64>, flag = "ladder", aliases = [], stages = "screen", to = protocol,
        cli(value_delimiter = ',', value_name = "BUDGETS");
    /// How a ladder's levels are meta-trained: separate (each level its own `train@B` stage
    /// and trials) or shared (only the top level meta-trains; each level below reads its θ_LF*
    /// off the top level's paired trials re-credited at its own budget, so the ladder costs
    /// the meta-training of one level; the levels below the top are then not in budgets).
    ladder_training: LadderTraining, flag = "ladder-training", aliases = [],
        stages = "screen", to = protocol, cli(value_enum);
    /// Run the protocol with N seeds (seed, seed + 1, …), in parallel, each in
    /// `OUT/seed-<s>/`; OUT gets the results over the seeds with 95 % intervals.
    repeat: u32, flag = "repeat", aliases = [], stages = "all (one campaign per seed)",
        to = command, cli(value_name = "N");
}

/// Parses `--seed`: a whole number from 0 to 2⁶⁴ − 1, a negative one named as such (clap's
/// own message for `-1` was a tip to write `-- -1`, which a seed cannot be).
pub fn parse_seed(s: &str) -> Result<u64, String> {
    s.trim().parse().map_err(|_| {
        format!(
            "a seed is a whole number from 0 to {}{}",
            u64::MAX,
            if s.trim_start().starts_with('-') {
                " (not negative)"
            } else {
                ""
            }
        )
    })
}

/// Parses `--elite`: `key=value` pairs of the elite mixture's parameters, comma-separated;
/// an unknown key or a value out of range is named.
pub fn parse_elite(s: &str) -> Result<EliteMixture, String> {
    let mut map = serde_json::Map::new();
    for pair in s.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (key, value) = pair
            .split_once('=')
            .ok_or_else(|| format!("`{pair}`: give key=value, e.g. explore=0.1,tries=8"))?;
        let value = value.trim();
        let number = match (value.parse::<u64>(), value.parse::<bool>()) {
            (Ok(n), _) => serde_json::Value::from(n),
            // Switches (`per_cost=false`).
            (_, Ok(b)) => serde_json::Value::from(b),
            _ => value
                .parse::<f64>()
                .ok()
                .and_then(|x| serde_json::Number::from_f64(x).map(Into::into))
                .ok_or_else(|| format!("`{key}`: `{value}` is neither a number nor true/false"))?,
        };
        map.insert(key.trim().to_string(), number);
    }
    let m = EliteMixture::with(map).map_err(|e| format!("elite parameters: {e}"))?;
    m.validate().map_err(|e| e.to_string())?;
    Ok(m)
}

/// Refuses a value given where it would do nothing.
fn idle(field: &str, message: String) -> Result<(), CampaignError> {
    Err(CampaignError::Protocol {
        field: field.into(),
        message,
    })
}

impl Overrides {
    /// True when any value was given.
    pub fn any(&self) -> bool {
        *self != Overrides::default()
    }

    /// Applies the values to `p`; `scenario` turns a scenario as given into its name (None:
    /// unknown, an error listing `known`). Does not validate the values one by one, but
    /// refuses a value that would do nothing: `audit_fraction` without screening
    /// (`screen_iterations` 0), whoever gave it (a flag, a campaign file, Python).
    pub fn apply(
        &self,
        p: &mut Protocol,
        scenario: &dyn Fn(&str) -> Option<String>,
        known: &str,
    ) -> Result<(), CampaignError> {
        if let Some(m) = self.method {
            m.apply(p);
        }
        self.apply_fields(p);
        // (A value outside [0, 1] is refused as such by the validation.)
        let in_range = |a: f64| (0.0..=1.0).contains(&a);
        let screens = if p.deploy_budget.is_some() {
            1
        } else {
            p.screen_iterations
        };
        if let (Some(alpha), 0) = (self.audit_fraction.filter(|&a| in_range(a)), screens) {
            return Err(CampaignError::Protocol {
                field: "audit_fraction".into(),
                message: format!(
                    "{alpha} would do nothing: it is the fraction of LF passes the screening stage re-runs on HF, and there is no screening (screen_iterations is 0); give screen_iterations too, or leave audit_fraction out"
                ),
            });
        }
        if let (Some(ScreenLf::WhereItPays), 0) = (self.screen_lf, screens) {
            return idle(
                "screen_lf",
                "where-it-pays would do nothing: it decides which screened trials run LF first, and there is no screening (screen_iterations is 0); give screen_iterations too, or leave screen_lf out".into(),
            );
        }
        let names = |given: &[String]| -> Result<Vec<String>, CampaignError> {
            given
                .iter()
                .map(|k| {
                    scenario(k.trim()).ok_or_else(|| CampaignError::UnknownScenario {
                        name: k.trim().into(),
                        known: known.into(),
                    })
                })
                .collect()
        };
        self.settle_search(p)?;
        if let Some(v) = &self.train_scenarios {
            p.train_scenarios = names(v)?;
        }
        if let Some(v) = &self.test_scenarios {
            p.test_scenarios = names(v)?;
        }
        Ok(())
    }
}

impl Overrides {
    /// Stores the elite parameters of an elite search (the defaults of the day unless given),
    /// and refuses elite parameters without the elite search and a `pair_settle` with every
    /// trial paired (they would do nothing).
    fn settle_search(&self, p: &mut Protocol) -> Result<(), CampaignError> {
        if p.search == Search::Elite {
            p.elite.get_or_insert_with(EliteMixture::default);
        } else if self.elite.is_some() {
            return idle(
                "elite",
                "the elite parameters would do nothing: the search is the paper's bins; give search = elite too, or leave elite out".into(),
            );
        }
        if let (Some(n), true) = (self.pair_settle, p.pair_fraction == 1.0) {
            return idle(
                "pair_settle",
                format!("{n} would do nothing: every learning trial is paired (pair_fraction is 1); give pair_fraction too, or leave pair_settle out"),
            );
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    /// Elite parameters named in a campaign file, in Python or with `--elite` keep the
    /// defaults of the others, switches included (they read as off before).
    #[test]
    fn named_elite_parameters_keep_the_other_defaults() {
        let want = EliteMixture {
            explore: 0.1,
            ..EliteMixture::default()
        };
        assert!(want.per_cost && want.rho_model);
        let table: toml::Table = toml::from_str("elite = { explore = 0.1 }").unwrap();
        let o = Overrides::from_entries(table).unwrap();
        assert_eq!(o.elite, Some(want));
        assert_eq!(parse_elite("explore=0.1"), Ok(want));
        let off = parse_elite("explore=0.1,rho_model=false").unwrap();
        assert!(!off.rho_model && off.per_cost);
        let e = Overrides::from_entries(
            toml::from_str::<toml::Table>("elite = { explor = 1 }").unwrap(),
        )
        .unwrap_err();
        assert!(e.to_string().contains("explor"), "{e}");
    }

    #[derive(Debug, clap::Parser)]
    struct Cli {
        #[command(flatten)]
        values: Overrides,
    }

    /// Every value in the protocol.json of a protocol is declared, and every declared value
    /// of the protocol is in protocol.json under the same name.
    #[test]
    fn every_protocol_field_is_declared_once() {
        // Every optional field set to a value that is written (defaults may be left out).
        let p = Protocol {
            prior_strengths: vec![0.0, 0.5],
            screen_iterations: 3,
            search: Search::Elite,
            elite: Some(EliteMixture::default()),
            pair_fraction: 0.5,
            pair_settle: 5,
            deployment: Deploy::Adaptive,
            screen_lf: ScreenLf::WhereItPays,
            log_bins: LogBins::Paper,
            allocation: Allocate::CostRate,
            coverage_floor: 0.5,
            search_budget: Some(1e9),
            deploy_budget: Some(1e8),
            theta_lf_choice: ThetaLfChoice::Evidence,
            transfer: Transfer::Auto,
            ladder: vec![0.2, 0.3],
            ladder_training: LadderTraining::Shared,
            ..Protocol::paper("s", vec!["a".into()], vec!["b".into()])
        };
        let json = serde_json::to_value(&p).unwrap();
        let fields: Vec<&str> = json
            .as_object()
            .unwrap()
            .keys()
            .map(|k| k.as_str())
            .collect();
        for v in VALUES.iter().filter(|v| v.in_protocol) {
            assert!(
                fields.contains(&v.name),
                "{} is not a protocol field",
                v.name
            );
        }
        // What a front end cannot set: the layout version, the simulator's label, and what
        // the campaign file gives per scenario or per FMU (weights, on_error).
        let not_values = ["format_version", "simulator", "weights", "on_error"];
        for f in fields {
            assert!(
                not_values.contains(&f) || VALUES.iter().any(|v| v.name == f),
                "protocol field {f} has no declaration"
            );
        }
    }

    #[test]
    fn each_value_is_a_flag_with_its_name_and_help() {
        let cmd = Cli::command();
        for v in VALUES {
            let arg = cmd
                .get_arguments()
                .find(|a| a.get_id() == v.name)
                .unwrap_or_else(|| panic!("no flag for {}", v.name));
            assert_eq!(arg.get_long(), Some(v.flag));
            assert_eq!(v.flag, v.name.replace('_', "-"), "flag and name differ");
            let help = arg.get_help().map(|h| h.to_string()).unwrap_or_default();
            let start: String = help.chars().take(20).collect();
            assert!(
                !help.is_empty() && v.help.trim_start().starts_with(&start),
                "{}: {help:?} vs {:?}",
                v.name,
                v.help
            );
        }
    }

    #[test]
    fn an_audit_fraction_without_screening_is_refused_naming_both_values() {
        let mut p = Protocol::paper("sim", vec!["a".into()], vec!["b".into()]);
        let known = |s: &str| Some(s.to_string());
        let alone = Overrides::from_entries([("audit_fraction", serde_json::json!(0.5))]).unwrap();
        let e = alone.apply(&mut p, &known, "").unwrap_err().to_string();
        assert!(e.contains("`audit_fraction`: 0.5 would do nothing"), "{e}");
        assert!(e.contains("screen_iterations is 0"), "{e}");
        let with = Overrides::from_entries([
            ("audit_fraction", serde_json::json!(0.5)),
            ("screen_iterations", serde_json::json!(4)),
        ])
        .unwrap();
        with.apply(&mut p, &known, "").unwrap();
        assert_eq!((p.audit_fraction, p.screen_iterations), (0.5, 4));
    }

    #[test]
    fn an_elite_search_stores_its_parameters_and_idle_values_are_refused() {
        let known = |s: &str| Some(s.to_string());
        let paper = || Protocol::paper("sim", vec!["a".into()], vec!["b".into()]);
        let mut p = paper();
        let elite = Overrides::from_entries([("search", serde_json::json!("elite"))]).unwrap();
        elite.apply(&mut p, &known, "").unwrap();
        assert_eq!(p.elite, Some(EliteMixture::default()));
        let json = serde_json::to_string(&p).unwrap();
        assert!(json.contains(r#""elite":{"explore":0.05"#), "{json}");
        // Given as a partial table: the rest are the defaults.
        let mut p = paper();
        let tuned = Overrides::from_entries([
            ("search", serde_json::json!("elite")),
            ("elite", serde_json::json!({"explore": 0.3})),
        ])
        .unwrap();
        tuned.apply(&mut p, &known, "").unwrap();
        assert_eq!(
            p.elite.map(|m| (m.explore, m.tries)),
            Some((0.3, EliteMixture::default().tries))
        );
        let e =
            Overrides::from_entries([("elite", serde_json::json!({"explor": 0.3}))]).unwrap_err();
        assert_eq!(e.key, "elite");
        assert!(e.message.contains("explor"), "{e}");
        let alone = Overrides::from_entries([("elite", serde_json::json!({}))]).unwrap();
        let e = alone
            .apply(&mut paper(), &known, "")
            .unwrap_err()
            .to_string();
        assert!(e.contains("`elite`") && e.contains("search = elite"), "{e}");
        let settle = Overrides::from_entries([("pair_settle", serde_json::json!(5))]).unwrap();
        let e = settle
            .apply(&mut paper(), &known, "")
            .unwrap_err()
            .to_string();
        assert!(e.contains("`pair_settle`: 5 would do nothing"), "{e}");
        let mut p = paper();
        p.pair_fraction = 0.0;
        let e = p.validate().unwrap_err().to_string();
        assert!(e.contains("`pair_fraction`") && e.contains("(0, 1]"), "{e}");
        let mut p = paper();
        p.elite = Some(EliteMixture {
            tries: 0,
            ..EliteMixture::default()
        });
        let e = p.validate().unwrap_err().to_string();
        assert!(e.contains("`elite`") && e.contains("tries"), "{e}");
    }

    #[test]
    fn the_elite_flag_reads_key_value_pairs_and_names_bad_ones() {
        use clap::Parser;
        let cli = Cli::try_parse_from(["x", "--elite", "explore=0.1, tries=4"]).unwrap();
        let m = cli.values.elite.unwrap();
        assert_eq!(
            (m.explore, m.tries, m.jump),
            (0.1, 4, EliteMixture::default().jump)
        );
        // A switch takes true or false.
        let cli = Cli::try_parse_from(["x", "--elite", "per_cost=false"]).unwrap();
        assert!(!cli.values.elite.unwrap().per_cost);
        for (bad, says) in [
            ("explore", "key=value"),
            (
                "explore=x",
                "`explore`: `x` is neither a number nor true/false",
            ),
            ("per_cost=maybe", "`per_cost`: `maybe` is neither"),
            ("explore=true", "explore"),
            ("bandwith=0.1", "bandwith"),
            ("bandwidth=2", "bandwidth"),
        ] {
            let e = Cli::try_parse_from(["x", "--elite", bad])
                .unwrap_err()
                .to_string();
            assert!(e.contains("--elite") && e.contains(says), "{bad}: {e}");
        }
    }

    #[test]
    fn old_flag_spellings_still_parse() {
        use clap::Parser;
        let cli =
            Cli::try_parse_from(["x", "--iterations", "7", "--baseline-iterations", "9"]).unwrap();
        assert_eq!(cli.values.train_iterations, Some(7));
        assert_eq!(cli.values.baseline_train_iterations, Some(9));
    }

    #[test]
    fn entries_refuse_unknown_names_and_wrong_types_naming_the_key() {
        let e = Overrides::from_entries([("budget", serde_json::json!(0.3))]).unwrap_err();
        assert_eq!(e.key, "budget");
        assert!(e.message.contains("budgets"), "{e}");
        let e = Overrides::from_entries([("seed", serde_json::json!("x"))]).unwrap_err();
        assert_eq!(e.key, "seed");
        let e = Overrides::from_entries([("cost", serde_json::json!("fast"))]).unwrap_err();
        assert!(e.message.contains("wall"), "{e}");
    }

    #[test]
    fn every_value_round_trips_through_entries() {
        // A value for each declared name, read back by name: nothing is dropped on the way.
        let given = Overrides {
            seed: Some(5),
            cost: Some(Cost::Work),
            budgets: Some(vec![0.25]),
            train_iterations: Some(3),
            eval_iterations: Some(4),
            test_iterations: Some(5),
            baseline_train_iterations: Some(6),
            baseline_test_iterations: Some(7),
            train_scenarios: Some(vec!["a".into()]),
            test_scenarios: Some(vec!["b".into()]),
            fidelity_bins: Some(3),
            log_bins: Some(LogBins::Paper),
            prior_strength: Some(0.5),
            window: Some(2),
            prior_strengths: Some(vec![0.0, 0.5]),
            screen_iterations: Some(8),
            audit_fraction: Some(0.2),
            search: Some(Search::Elite),
            elite: Some(EliteMixture {
                explore: 0.2,
                ..EliteMixture::default()
            }),
            pair_fraction: Some(0.25),
            pair_settle: Some(12),
            deployment: Some(Deploy::Adaptive),
            screen_lf: Some(ScreenLf::WhereItPays),
            method: Some(Method::Paper),
            allocation: Some(Allocate::CostRate),
            coverage_floor: Some(0.5),
            search_budget: Some(1e9),
            deploy_budget: Some(2e8),
            theta_lf_choice: Some(ThetaLfChoice::Evidence),
            transfer: Some(Transfer::Auto),
            ladder: Some(vec![0.2, 0.25]),
            ladder_training: Some(LadderTraining::Shared),
            repeat: Some(2),
        };
        let json = serde_json::to_value(&given).unwrap();
        let entries = json.as_object().unwrap().clone();
        assert_eq!(entries.len(), VALUES.len());
        let back = Overrides::from_entries(entries).unwrap();
        assert_eq!(back, given);
        for v in VALUES {
            assert!(back.is_given(v.name), "{}", v.name);
        }
    }
}
