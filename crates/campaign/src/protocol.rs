//! The paper's experimental protocol as data: which stages run, on which scenarios, for how many
//! iterations, with which budgets and seeds.

use super::CampaignError;
pub use crate::stage::{BadStageLabel, Compact, Stage, StageId, StageKind};
use savme_kernel::{EliteMixture, Pairing};
use serde::{Deserialize, Serialize};

/// How a run's cost is measured (serialisable twin of [`savme_kernel::CostMeasure`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Cost {
    /// Measured wall-clock seconds (the paper's runtime).
    #[default]
    Wall,
    /// Deterministic work units: the same seed gives the same campaign, bit for bit.
    Work,
}

impl Cost {
    /// The kernel's cost measure.
    pub fn measure(self) -> savme_kernel::CostMeasure {
        match self {
            Cost::Wall => savme_kernel::CostMeasure::Wall,
            Cost::Work => savme_kernel::CostMeasure::Work,
        }
    }

    /// Unit of a cumulative cost, for tables and plot axes.
    pub fn unit(self) -> &'static str {
        match self {
            Cost::Wall => "s",
            Cost::Work => "work units",
        }
    }
}

/// The version of the layout of the files a campaign writes: `format_version` in
/// `summary.json` and `protocol.json`, a closing comment in `table.md` and `fidelity.md`
/// (`trials.jsonl` versions each line with its `v` key). It changes when a key is renamed or
/// removed, not when one is added.
pub const FORMAT_VERSION: u32 = 1;

/// How φ is searched in meta-training and meta-testing (the kernel's
/// [`SearchModel`](savme_kernel::SearchModel)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Search {
    /// The paper's independent Beta–Bernoulli bins per φ variable.
    #[default]
    Bins,
    /// A joint proposal per scenario around the failures found (the kernel's `EliteMixture`,
    /// with the protocol's `elite` parameters), mixed with the bins for exploration.
    Elite,
}

impl Search {
    /// The kernel's search model: the bins, or the elite mixture with `elite` (None: the
    /// kernel's current defaults — a protocol.json written before the parameters were stored).
    pub fn model(self, elite: Option<EliteMixture>) -> savme_kernel::SearchModel {
        match self {
            Search::Bins => savme_kernel::SearchModel::IndependentBins,
            Search::Elite => {
                savme_kernel::SearchModel::EliteMixture(elite.unwrap_or_else(EliteMixture::legacy))
            }
        }
    }

    fn is_bins(&self) -> bool {
        *self == Search::Bins
    }
}

/// What the deployed search — the evaluation and LF screening stages — does with what the
/// search learned (the kernel's [`Deployment`](savme_kernel::Deployment)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Deploy {
    /// The paper's: φ drawn from the proposal as the search left it; nothing learned.
    #[default]
    Frozen,
    /// The elite proposal draws for failures: no exploration, no novelty weighting,
    /// candidates ranked by failure odds (needs search = elite).
    Exploit,
    /// Every result keeps teaching the φ search (θ_LF* stays the search's).
    Learn,
    /// Exploit and learn.
    Adaptive,
}

impl Deploy {
    /// The kernel's deployment.
    pub fn kernel(self) -> savme_kernel::Deployment {
        savme_kernel::Deployment {
            learn: matches!(self, Deploy::Learn | Deploy::Adaptive),
            exploit: matches!(self, Deploy::Exploit | Deploy::Adaptive),
        }
    }

    /// Its name in protocol.json, a campaign file and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Deploy::Frozen => "frozen",
            Deploy::Exploit => "exploit",
            Deploy::Learn => "learn",
            Deploy::Adaptive => "adaptive",
        }
    }

    fn is_frozen(&self) -> bool {
        *self == Deploy::Frozen
    }
}

/// Which trials of an LF screening stage run LF first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum ScreenLf {
    /// Every trial: LF first, HF to confirm (the paper's).
    #[default]
    Always,
    /// Per scenario, only while the LF run costs less than the HF passes it is expected to
    /// save; otherwise HF directly (the kernel's screening economy).
    WhereItPays,
}

impl ScreenLf {
    fn is_always(&self) -> bool {
        *self == ScreenLf::Always
    }
}

/// How each trial's scenario is chosen (the kernel's [`Allocation`](savme_kernel::Allocation)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Allocate {
    /// The paper's: drawn from p(s), the scenario weights — the same share of trials each.
    #[default]
    Weights,
    /// A bandit over the scenarios by HF failures per unit cost over each scenario's whole
    /// history, every scenario kept above `coverage_floor` × its share of p(s) in cost.
    CostRate,
    /// The same bandit weighing recent evidence more: its failures and cost forgotten with a
    /// half-life of 20 told trials (`savme_kernel::RECENT_HALF_LIFE`), so a scenario's blind
    /// start (a wide window's first trials) does not keep the campaign away from it (the
    /// tuned method's from issue 42 item 4 until scouting).
    CostRateRecent,
    /// The same, and each scenario scouted until its first HF failure: held at its whole
    /// share of p(s) in cost (floor 1) and its learning trials HF only, so that a scenario
    /// whose failures are hard to find is searched long enough to find them (the tuned
    /// method's; `savme_kernel::CostRate::scout`).
    CostRateScout,
}

impl Allocate {
    /// The kernel's allocation with the coverage floor `floor`.
    pub fn kernel(self, floor: f64) -> savme_kernel::Allocation {
        match self {
            Allocate::Weights => savme_kernel::Allocation::Weights,
            Allocate::CostRate => savme_kernel::Allocation::CostRate(savme_kernel::CostRate {
                floor,
                half_life: None,
                ..savme_kernel::CostRate::default()
            }),
            Allocate::CostRateRecent | Allocate::CostRateScout => {
                savme_kernel::Allocation::CostRate(savme_kernel::CostRate {
                    floor,
                    half_life: Some(savme_kernel::RECENT_HALF_LIFE),
                    scout: self == Allocate::CostRateScout,
                    ..savme_kernel::CostRate::default()
                })
            }
        }
    }

    fn is_weights(&self) -> bool {
        *self == Allocate::Weights
    }
}

/// How log-scaled variables are cut into bins.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum LogBins {
    /// savme's: bins of equal ratio, log-uniform inside (the kernel's log scale).
    #[default]
    Savme,
    /// The authors' SAVME code's: edges equally spaced in ln(x − lo + 1), a shift of its own
    /// inside each bin (the kernel's shifted-log scale).
    Paper,
}

impl LogBins {
    fn is_savme(&self) -> bool {
        *self == LogBins::Savme
    }

    /// The scale log-scaled variables take.
    pub fn scale(self) -> savme_kernel::Scale {
        match self {
            LogBins::Savme => savme_kernel::Scale::Log,
            LogBins::Paper => savme_kernel::Scale::ShiftedLog,
        }
    }
}

/// How evaluation and screening choose θ_LF* from the meta-training posterior.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum ThetaLfChoice {
    /// The paper's: the MAP arm of every fidelity variable (it trusts an arm tried once).
    #[default]
    Map,
    /// From evidence: the highest lower 10 % quantile of each arm's Beta belief, every false
    /// alarm charged as 1 / C_budget losses (the kernel's `Estimator::Evidence`).
    Evidence,
}

impl ThetaLfChoice {
    /// The kernel's estimator.
    pub fn kernel(self) -> savme_kernel::Estimator {
        match self {
            ThetaLfChoice::Map => savme_kernel::Estimator::Map,
            ThetaLfChoice::Evidence => savme_kernel::Estimator::Evidence,
        }
    }

    fn is_map(&self) -> bool {
        *self == ThetaLfChoice::Map
    }
}

/// How strongly meta-testing's learned prior carries the meta-training evidence.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Transfer {
    /// `prior_strength` for every fidelity variable (the paper's: 1).
    #[default]
    Fixed,
    /// Per fidelity variable, the strength whose prior from the other training scenarios best
    /// predicts each held-out training scenario's fidelity outcomes (leave-one-scenario-out;
    /// 0, the uniform prior, when the scenarios disagree or no strength gains a nat per
    /// held-out scenario over it).
    Auto,
}

impl Transfer {
    fn is_fixed(&self) -> bool {
        *self == Transfer::Fixed
    }
}

/// How a fidelity ladder's levels are meta-trained.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum LadderTraining {
    /// Each level is one of the budgets, meta-trained on its own trials (`train@B` each).
    #[default]
    Separate,
    /// Only the ladder's top level meta-trains (`train@top`); each level below reads its
    /// θ_LF* off those paired trials, every one re-credited at the level's own budget (Table
    /// I: a fidelity success when HF and LF agree and t_LF / t_HF ≤ the level's budget) — the
    /// same HF runs, no trial of its own.
    Shared,
}

impl LadderTraining {
    fn is_separate(&self) -> bool {
        *self == LadderTraining::Separate
    }
}

/// What a campaign searches with before any other value is given: savme's search by cost
/// (`savme run`, Python, `savme serve`'s example configuration) or the paper's SAVME (`savme
/// reproduce`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// savme's: the elite search with candidates ranked per expected cost (and, where runs
    /// report a robustness, by a Gaussian process of it), a quarter of the learning trials
    /// paired with an LF run once θ_LF* has settled, the cost-rate allocation over scenarios
    /// (a scenario without a failure yet scouted: its share of the cost, HF only), a deployed search that exploits and keeps learning, LF
    /// screening only where it pays, θ_LF* from evidence and the transfer strength chosen by
    /// leave-one-scenario-out.
    #[default]
    Tuned,
    /// The paper's SAVME: independent bins, every learning trial paired, scenarios from p(s),
    /// a frozen deployment, LF screening of every trial, θ_LF* = MAP, the meta-training posterior transferred at
    /// `prior_strength`.
    Paper,
}

impl Method {
    /// How this method reads θ_LF* off the fidelity posterior: evidence (tuned) or MAP
    /// (paper). The one place the choice is made, for a campaign ([`Method::apply`]), `savme
    /// example-config` (a `savme serve` configuration) and Python's `Kernel` alike.
    pub fn theta_lf_choice(self) -> ThetaLfChoice {
        match self.preset().estimator() {
            savme_kernel::Estimator::Evidence => ThetaLfChoice::Evidence,
            _ => ThetaLfChoice::Map,
        }
    }

    /// The kernel-level part of this method (estimator, search, deployment, allocation), as
    /// `savme example-config`, Python's `Kernel` and the C ABI's builder build it.
    pub fn preset(self) -> savme_kernel::Preset {
        match self {
            Method::Tuned => savme_kernel::Preset::Tuned,
            Method::Paper => savme_kernel::Preset::Paper,
        }
    }

    /// Sets the values this method decides on `p` (the others stay).
    pub fn apply(self, p: &mut Protocol) {
        p.theta_lf_choice = self.theta_lf_choice();
        match self {
            Method::Tuned => {
                p.search = Search::Elite;
                p.elite = Some(EliteMixture::default());
                p.deployment = Deploy::Adaptive;
                p.screen_lf = ScreenLf::WhereItPays;
                // Scouting and the ρ model from a scenario's fourth trial (the elite defaults'
                // `rho_start`): the worst of the bundled scenarios 1–8 against the best
                // VerifAI sampler 0.25× → ≥ 0.8× (docs/RESULTS.md, issue 42, "Scouting").
                p.allocation = Allocate::CostRateScout;
                p.transfer = Transfer::Auto;
                // A quarter of the learning trials pay an LF run once θ_LF* has settled:
                // HF failures per work unit in the search 60.1 → 77.6 per 10⁹ on the bundled
                // scenarios 1–8 with the ρ model (75.3 pairing all), 23.3 → ≈ 24 per 10³ on
                // BouncingBall (docs/RESULTS.md, issue 42).
                p.pair_fraction = TUNED_PAIR_FRACTION;
                // ... once the greedy arm of every fidelity variable holds 10 observations
                // (30 settled after 110–120 of highway-env's 150 search trials: LF runs were
                // 25 % of its work; 10: 18 %, HF failures per wu on roundabout 2.65 → 3.55 on
                // seed 1; docs/RESULTS.md, issue 42).
                p.pair_settle = TUNED_PAIR_SETTLE;
            }
            Method::Paper => {
                p.search = Search::Bins;
                p.elite = None;
                p.deployment = Deploy::Frozen;
                p.screen_lf = ScreenLf::Always;
                p.allocation = Allocate::Weights;
                p.transfer = Transfer::Fixed;
                p.pair_fraction = 1.0;
                p.pair_settle = default_settle();
            }
        }
    }
}

/// The tuned method's [`Protocol::pair_fraction`]: the share of learning trials that also
/// run LF once θ_LF* has settled.
pub const TUNED_PAIR_FRACTION: f64 = 0.25;

/// The tuned method's [`Protocol::pair_settle`]: the observations the greedy arm of every
/// fidelity variable needs before θ_LF* counts as settled and only [`TUNED_PAIR_FRACTION`] of
/// the learning trials is paired (the kernel's default, 30, is the paper-era value: with five
/// fidelity variables it settled late in a 150-trial search).
pub const TUNED_PAIR_SETTLE: u64 = 10;

/// The most trials one stage may run (10⁸: years of simulation even at a millisecond a run).
pub const MAX_ITERATIONS: u64 = 100_000_000;
/// The most trials in flight at once.
pub const MAX_WINDOW: usize = 100_000;
/// The most compute budgets in one protocol.
pub const MAX_BUDGETS: usize = 100;

/// Everything that decides a campaign's trials. Saved as `protocol.json` in the output
/// directory, so that `--resume` continues exactly the same campaign.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Protocol {
    /// The layout version of `protocol.json` ([`FORMAT_VERSION`]); files
    /// written before the key existed read as 1.
    #[serde(default = "first_format")]
    pub format_version: u32,
    /// Master seed; every kernel's seed is derived from it and the stage's name.
    pub seed: u64,
    /// The compute budgets C_budget, each in (0, 1].
    pub budgets: Vec<f64>,
    /// Meta-training iterations per budget.
    pub train_iterations: u64,
    /// Evaluation trials per budget (θ_LF = MAP, φ ~ p_ψ).
    pub eval_iterations: u64,
    /// Meta-testing iterations per budget and prior.
    pub test_iterations: u64,
    /// Baseline trials (uniform φ, HF only) on the meta-training scenarios.
    pub baseline_train_iterations: u64,
    /// Baseline trials on the meta-testing scenarios.
    pub baseline_test_iterations: u64,
    /// Meta-training scenarios (uniform p(s)).
    pub train_scenarios: Vec<String>,
    /// Meta-testing scenarios.
    pub test_scenarios: Vec<String>,
    /// Cost measure.
    pub cost: Cost,
    /// Bins per continuous fidelity setting.
    pub fidelity_bins: u32,
    /// Weight of the meta-training evidence in the meta-testing prior (power prior); with
    /// `transfer = auto` the largest weight auto may choose per setting.
    pub prior_strength: f64,
    /// Trials in flight at once (asked, not yet told). Trials are told in ask order, so the
    /// campaign depends on this, the seed and the cost measure — not on the number of jobs.
    pub window: usize,
    /// Which simulator ran the trials (checked on resume).
    pub simulator: String,
    /// Scenario weights p(s) (a scenario not listed weighs 1).
    #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub weights: std::collections::BTreeMap<String, f64>,
    /// What a failed simulation does: abort the campaign, or skip the trial.
    #[serde(default)]
    pub on_error: OnError,
    /// The prior-strength ablation of meta-testing: the strengths (≥ 0) whose learned-prior
    /// meta-testing is compared. Strength 0 is the uniform prior (the `test-uniform` stage)
    /// and `prior_strength` is the `test-learned` stage (with `transfer = auto` it gets a
    /// stage of its own); every other one adds a stage per budget (`test-learned-s0.1@0.3`).
    /// Empty: no ablation.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub prior_strengths: Vec<f64>,
    /// LF screening trials per budget after the evaluation (φ ~ p_ψ, θ_LF*; HF only to
    /// confirm an LF failure or for the audit). 0: no screening stage.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub screen_iterations: u64,
    /// The fraction α of LF passes re-run on HF in screening, to estimate the miss rate.
    #[serde(default = "default_audit_fraction")]
    pub audit_fraction: f64,
    /// How φ is searched in meta-training and meta-testing (the paper's bins by default; not
    /// written when it is the default, so older protocol.json files read the same).
    #[serde(default, skip_serializing_if = "Search::is_bins")]
    pub search: Search,
    /// The elite search's parameters. A front end (flags, campaign file, Python) that selects
    /// `search = "elite"` stores the defaults of the day here, so a resumed campaign keeps its
    /// parameters when the defaults change. None: the kernel's defaults (and not written).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub elite: Option<EliteMixture>,
    /// Share of the learning trials that also run LF once θ_LF* has settled (the kernel's
    /// [`Pairing`]); 1, the paper's, pairs every trial (and is not written).
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub pair_fraction: f64,
    /// Observations the greedy fidelity arm needs before θ_LF* counts as settled.
    #[serde(default = "default_settle", skip_serializing_if = "is_default_settle")]
    pub pair_settle: u64,
    /// What evaluation and screening do with what the search learned (frozen, the paper's,
    /// is not written).
    #[serde(default, skip_serializing_if = "Deploy::is_frozen")]
    pub deployment: Deploy,
    /// How log-scaled variables are binned (savme's, the default, is not written).
    #[serde(default, skip_serializing_if = "LogBins::is_savme")]
    pub log_bins: LogBins,
    /// Which screened trials run LF first (always, the paper's, is not written).
    #[serde(default, skip_serializing_if = "ScreenLf::is_always")]
    pub screen_lf: ScreenLf,
    /// How each trial's scenario is chosen (weights, the paper's, is not written).
    #[serde(default, skip_serializing_if = "Allocate::is_weights")]
    pub allocation: Allocate,
    /// The cost-rate allocation's coverage floor, in [0, 1].
    #[serde(default = "default_floor", skip_serializing_if = "is_default_floor")]
    pub coverage_floor: f64,
    /// The cost of each search stage (meta-training and meta-testing), in the cost measure's
    /// unit (work units or seconds): the stage runs until its told runs have cost this much,
    /// instead of for its iterations. None: iterations (not written).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub search_budget: Option<f64>,
    /// The cost of each deployed search (the LF screening stage), likewise; it adds the stage
    /// when `screen_iterations` is 0. None: iterations (not written).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub deploy_budget: Option<f64>,
    /// How θ_LF* is chosen (map, the paper's, is not written).
    #[serde(default, skip_serializing_if = "ThetaLfChoice::is_map")]
    pub theta_lf_choice: ThetaLfChoice,
    /// How meta-testing's learned prior is weighted (fixed, the paper's, is not written).
    #[serde(default, skip_serializing_if = "Transfer::is_fixed")]
    pub transfer: Transfer,
    /// A fidelity ladder: the budgets of two or more LF levels, cheapest first, each one of
    /// `budgets` (so each is meta-trained with its own θ_LF). The screening stage at the
    /// ladder's top budget screens down the ladder ([`Protocol::levels`]): the cheapest
    /// level's LF run first, a failure confirmed at the next level up, HF last. Empty: every
    /// screening stage screens with its own budget's θ_LF* alone, the two-level campaign (not
    /// written).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub ladder: Vec<f64>,
    /// How the ladder's levels are meta-trained (separate, the default, is not written).
    #[serde(default, skip_serializing_if = "LadderTraining::is_separate")]
    pub ladder_training: LadderTraining,
}

fn default_floor() -> f64 {
    savme_kernel::CostRate::default().floor
}

fn is_default_floor(x: &f64) -> bool {
    *x == default_floor()
}

fn one() -> f64 {
    1.0
}

fn is_one(x: &f64) -> bool {
    *x == 1.0
}

fn default_settle() -> u64 {
    Pairing::default().settle
}

fn is_default_settle(n: &u64) -> bool {
    *n == default_settle()
}

fn is_zero(n: &u64) -> bool {
    *n == 0
}

fn default_audit_fraction() -> f64 {
    0.1
}

/// What a failed simulation (a crash, a hang, an FMU error) does to a campaign.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum OnError {
    /// Stop the campaign with the error (resumable).
    #[default]
    Abort,
    /// Withdraw the trial (logged with its error in `trials.jsonl`) and ask another one; at
    /// most as many failures per stage as the stage has iterations.
    Skip,
}

/// A protocol error naming `field`.
fn bad(field: &str, message: String) -> Result<(), CampaignError> {
    Err(CampaignError::Protocol {
        field: field.into(),
        message,
    })
}

fn first_format() -> u32 {
    1
}

/// How a stored campaign's simulator label is matched with the one given to resume it, beyond
/// equality (set once by the program that reads campaign files: an FMU campaign's label names
/// its FMUs by path, and one stored with the paths spelled otherwise names the same files).
static SAME_SIMULATOR: std::sync::OnceLock<fn(&str, &str) -> bool> = std::sync::OnceLock::new();

/// Sets how [`Protocol::same_campaign`] matches a stored simulator label (`stored`, `given`)
/// that is not the given one (the first call wins).
pub fn set_simulator_matcher(same: fn(&str, &str) -> bool) {
    let _ = SAME_SIMULATOR.set(same);
}

/// Whether the stored simulator label `stored` names the simulator `given` names: equal, or
/// so by the matcher set with [`set_simulator_matcher`].
pub fn same_simulator(stored: &str, given: &str) -> bool {
    stored == given || SAME_SIMULATOR.get().is_some_and(|same| same(stored, given))
}

impl Protocol {
    /// Whether this stored protocol is `given`: equal, but for a simulator label that names
    /// the same simulator ([`same_simulator`]).
    pub fn same_campaign(&self, given: &Protocol) -> bool {
        self == given
            || (self.simulator != given.simulator
                && same_simulator(&self.simulator, &given.simulator)
                && *self
                    == Protocol {
                        simulator: self.simulator.clone(),
                        ..given.clone()
                    })
    }

    /// The paper's protocol: budgets 0.2/0.3/0.4, 500 meta-training iterations, 100
    /// evaluations, 200 meta-testing iterations; scenarios 1–8 for meta-training and 9–10 for
    /// meta-testing. The baselines get enough trials to span the meta-training runtime.
    pub fn paper(simulator: &str, train: Vec<String>, test: Vec<String>) -> Self {
        Protocol {
            format_version: FORMAT_VERSION,
            seed: 1,
            budgets: vec![0.2, 0.3, 0.4],
            train_iterations: 500,
            eval_iterations: 100,
            test_iterations: 200,
            baseline_train_iterations: 700,
            baseline_test_iterations: 300,
            train_scenarios: train,
            test_scenarios: test,
            cost: Cost::Wall,
            fidelity_bins: 10,
            prior_strength: 1.0,
            window: 4,
            simulator: simulator.into(),
            weights: Default::default(),
            on_error: OnError::Abort,
            prior_strengths: Vec::new(),
            screen_iterations: 0,
            audit_fraction: default_audit_fraction(),
            search: Search::Bins,
            elite: None,
            pair_fraction: 1.0,
            pair_settle: default_settle(),
            deployment: Deploy::Frozen,
            screen_lf: ScreenLf::Always,
            log_bins: LogBins::Savme,
            allocation: Allocate::Weights,
            coverage_floor: default_floor(),
            search_budget: None,
            deploy_budget: None,
            theta_lf_choice: ThetaLfChoice::Map,
            transfer: Transfer::Fixed,
            ladder: Vec::new(),
            ladder_training: LadderTraining::Separate,
        }
    }

    /// `self` with `method`'s values ([`Method::apply`]).
    pub fn with_method(mut self, method: Method) -> Self {
        method.apply(&mut self);
        self
    }

    /// A short preset that still shows the qualitative result (one budget, fewer iterations).
    pub fn quick(simulator: &str, train: Vec<String>, test: Vec<String>) -> Self {
        Protocol {
            budgets: vec![0.3],
            train_iterations: 200,
            eval_iterations: 50,
            test_iterations: 100,
            baseline_train_iterations: 260,
            baseline_test_iterations: 150,
            ..Protocol::paper(simulator, train, test)
        }
    }

    /// Checks the protocol; the error names the offending field.
    pub fn validate(&self) -> Result<(), CampaignError> {
        self.check_budgets()?;
        self.check_iterations()?;
        self.check_sizes()?;
        self.check_ablation_and_screening()?;
        self.check_ladder()?;
        for (name, w) in &self.weights {
            if !(*w > 0.0 && w.is_finite()) {
                return bad("weights", format!("`{name}`: {w} is not a positive weight"));
            }
        }
        Ok(())
    }

    fn check_budgets(&self) -> Result<(), CampaignError> {
        if self.budgets.is_empty() {
            return bad("budgets", "at least one budget is needed".into());
        }
        if self.budgets.len() > MAX_BUDGETS {
            return bad(
                "budgets",
                format!("{} budgets; at most {MAX_BUDGETS}", self.budgets.len()),
            );
        }
        for (i, &b) in self.budgets.iter().enumerate() {
            if !(b > 0.0 && b <= 1.0) {
                return bad("budgets", format!("{b} is outside (0, 1]"));
            }
            if self.budgets[..i].contains(&b) {
                return bad("budgets", format!("{b} is given twice"));
            }
        }
        Ok(())
    }

    fn check_iterations(&self) -> Result<(), CampaignError> {
        for (field, n) in [
            ("train_iterations", self.train_iterations),
            ("eval_iterations", self.eval_iterations),
            ("test_iterations", self.test_iterations),
            ("baseline_train_iterations", self.baseline_train_iterations),
            ("baseline_test_iterations", self.baseline_test_iterations),
        ] {
            if n == 0 {
                return bad(field, "must be at least 1".into());
            }
            if n > MAX_ITERATIONS {
                return bad(
                    field,
                    format!("{n} is more than savme runs in one stage ({MAX_ITERATIONS})"),
                );
            }
        }
        Ok(())
    }

    /// Scenarios, fidelity bins, the prior's strength and the window.
    fn check_sizes(&self) -> Result<(), CampaignError> {
        if self.train_scenarios.is_empty() {
            return bad("train_scenarios", "at least one scenario is needed".into());
        }
        if self.test_scenarios.is_empty() {
            return bad("test_scenarios", "at least one scenario is needed".into());
        }
        if self.fidelity_bins == 0 || self.fidelity_bins as usize > savme_kernel::MAX_ARMS {
            return bad(
                "fidelity_bins",
                format!(
                    "{} is not between 1 and {}",
                    self.fidelity_bins,
                    savme_kernel::MAX_ARMS
                ),
            );
        }
        if !(self.prior_strength > 0.0 && self.prior_strength.is_finite()) {
            return bad(
                "prior_strength",
                format!("{} is not a positive number", self.prior_strength),
            );
        }
        if self.window == 0 || self.window > MAX_WINDOW {
            return bad(
                "window",
                format!("{} is not between 1 and {MAX_WINDOW}", self.window),
            );
        }
        Ok(())
    }

    fn check_ablation_and_screening(&self) -> Result<(), CampaignError> {
        if self.prior_strengths.len() > MAX_BUDGETS {
            return bad(
                "prior_strengths",
                format!(
                    "{} strengths; at most {MAX_BUDGETS}",
                    self.prior_strengths.len()
                ),
            );
        }
        for (i, s) in self.prior_strengths.iter().enumerate() {
            if !(*s >= 0.0 && s.is_finite()) {
                return bad("prior_strengths", format!("{s} is not a number ≥ 0"));
            }
            if self.prior_strengths[..i].contains(s) {
                return bad("prior_strengths", format!("{s} is given twice"));
            }
        }
        if self.screen_iterations > MAX_ITERATIONS {
            return bad(
                "screen_iterations",
                format!(
                    "{} is more than savme runs in one stage ({MAX_ITERATIONS})",
                    self.screen_iterations
                ),
            );
        }
        if !(0.0..=1.0).contains(&self.audit_fraction) {
            return bad(
                "audit_fraction",
                format!("{} is outside [0, 1]", self.audit_fraction),
            );
        }
        self.check_search()
    }

    /// The fidelity ladder: two or more of the budgets, cheapest first and in the order the
    /// budgets are trained, with a screening stage to use it.
    fn check_ladder(&self) -> Result<(), CampaignError> {
        let l = &self.ladder;
        if l.is_empty() {
            if self.ladder_training == LadderTraining::Shared {
                return bad(
                    "ladder_training",
                    "shared would do nothing without a ladder: give ladder too, or leave ladder_training out".into(),
                );
            }
            return Ok(());
        }
        if l.len() < 2 {
            return bad(
                "ladder",
                format!("one level ({}) is the two-level campaign every screening stage already runs: give two or more budgets, cheapest first, or leave ladder out", l[0]),
            );
        }
        let trained = self
            .budgets
            .iter()
            .map(|b| b.to_string())
            .collect::<Vec<_>>();
        if self.ladder_training == LadderTraining::Shared {
            return self.check_shared_ladder();
        }
        let mut at = Vec::with_capacity(l.len());
        for (i, &b) in l.iter().enumerate() {
            let Some(k) = self.budgets.iter().position(|&x| x == b) else {
                return bad(
                    "ladder",
                    format!("{b} is not one of budgets ({}): each level is meta-trained at its own budget, so add it to budgets (or give ladder_training = shared: the levels below the top then read the top level's meta-training)", trained.join(", ")),
                );
            };
            if i > 0 && b <= l[i - 1] {
                return bad(
                    "ladder",
                    format!(
                        "{b} comes after {}: the levels go cheapest first, each budget once",
                        l[i - 1]
                    ),
                );
            }
            at.push(k);
        }
        if let Some(w) = at.windows(2).find(|w| w[0] > w[1]) {
            return bad(
                "ladder",
                format!("budgets lists {} before {}: list the ladder's budgets in its order there too, so that every level is meta-trained before the ladder's screening", self.budgets[w[1]], self.budgets[w[0]]),
            );
        }
        if self.screen_iterations == 0 && self.deploy_budget.is_none() {
            return bad(
                "ladder",
                "a ladder is used by the screening stage, and there is none (screen_iterations is 0): give screen_iterations or deploy_budget too, or leave ladder out".into(),
            );
        }
        Ok(())
    }

    /// A ladder whose levels share the top level's meta-training: the top one of the budgets,
    /// every level below it in (0, top), ascending, and none of them a budget (it would be
    /// meta-trained on its own trials, which the ladder would not use).
    fn check_shared_ladder(&self) -> Result<(), CampaignError> {
        let l = &self.ladder;
        let top = l[l.len() - 1];
        if !self.budgets.contains(&top) {
            return bad(
                "ladder",
                format!("its top level {top} is not one of budgets: with ladder_training = shared the top level is meta-trained and the levels below read their θ_LF* off its trials; add {top} to budgets"),
            );
        }
        for (i, &b) in l.iter().enumerate() {
            if !(b > 0.0 && b <= 1.0) {
                return bad("ladder", format!("{b} is outside (0, 1]"));
            }
            if i > 0 && b <= l[i - 1] {
                return bad(
                    "ladder",
                    format!(
                        "{b} comes after {}: the levels go cheapest first, each budget once",
                        l[i - 1]
                    ),
                );
            }
            if i + 1 < l.len() && self.budgets.contains(&b) {
                return bad(
                    "ladder",
                    format!("{b} is one of budgets: with ladder_training = shared the levels below the top are not meta-trained on their own (they read the top level's trials); leave {b} out of budgets, or give ladder_training = separate"),
                );
            }
        }
        if self.screen_iterations == 0 && self.deploy_budget.is_none() {
            return bad(
                "ladder",
                "a ladder is used by the screening stage, and there is none (screen_iterations is 0): give screen_iterations or deploy_budget too, or leave ladder out".into(),
            );
        }
        Ok(())
    }

    /// The LF levels the screening stage at budget `b` screens with, cheapest first: the
    /// ladder when `b` is its top, else `b` alone (the two-level screening, a ladder of one).
    ///
    /// ```
    /// use savme_campaign::Protocol;
    /// let mut p = Protocol::paper("sim", vec!["a".into()], vec!["b".into()]);
    /// assert_eq!(p.levels(0.3), [0.3]);
    /// p.ladder = vec![0.2, 0.3];
    /// assert_eq!((p.levels(0.3), p.levels(0.2)), (vec![0.2, 0.3], vec![0.2]));
    /// ```
    pub fn levels(&self, b: f64) -> Vec<f64> {
        match self.ladder.last() {
            Some(&top) if top == b => self.ladder.clone(),
            _ => vec![b],
        }
    }

    /// The elite parameters, the pairing and the deployment.
    fn check_search(&self) -> Result<(), CampaignError> {
        if self.deployment.kernel().exploit && self.search != Search::Elite {
            return bad(
                "deployment",
                format!(
                    "{} exploits the elite search's proposal, and the search is the paper's bins; give search = elite too, or deployment = frozen or learn",
                    self.deployment.name()
                ),
            );
        }
        if let Some(m) = &self.elite {
            if let Err(e) = m.validate() {
                return bad("elite", e.to_string());
            }
        }
        if !(0.0..=1.0).contains(&self.coverage_floor) {
            return bad(
                "coverage_floor",
                format!("{} is outside [0, 1]", self.coverage_floor),
            );
        }
        for (field, b) in [
            ("search_budget", self.search_budget),
            ("deploy_budget", self.deploy_budget),
        ] {
            if let Some(b) = b.filter(|b| !(b.is_finite() && *b > 0.0)) {
                return bad(field, format!("{b} is not a positive cost"));
            }
        }
        self.pairing().validate().or_else(|e| {
            bad(
                "pair_fraction",
                format!("{} is outside {}", e.value, e.range),
            )
        })
    }

    /// The kernel's pairing of learning trials.
    pub fn pairing(&self) -> Pairing {
        Pairing {
            fraction: self.pair_fraction,
            settle: self.pair_settle,
        }
    }

    /// The weight of scenario `name` in p(s).
    pub fn weight(&self, name: &str) -> f64 {
        self.weights.get(name).copied().unwrap_or(1.0)
    }

    /// The stages in the order they run.
    pub fn stages(&self) -> Vec<Stage> {
        let stage = |kind, budget, iterations| Stage {
            kind,
            budget,
            iterations,
            strength: None,
            spend: None,
        };
        // A stage with a cost budget runs until it is spent (at most MAX_ITERATIONS trials).
        let spending = |kind, budget, spend: Option<f64>, iterations| Stage {
            spend,
            ..stage(
                kind,
                budget,
                if spend.is_some() {
                    MAX_ITERATIONS
                } else {
                    iterations
                },
            )
        };
        let search = |kind, b| spending(kind, Some(b), self.search_budget, self.test_iterations);
        let mut s = vec![stage(
            StageKind::BaselineTrain,
            None,
            self.baseline_train_iterations,
        )];
        for &b in &self.budgets {
            let (train, screen) = (StageKind::Train, StageKind::Screen);
            s.push(spending(
                train,
                Some(b),
                self.search_budget,
                self.train_iterations,
            ));
            s.push(stage(StageKind::Evaluate, Some(b), self.eval_iterations));
            if self.screen_iterations > 0 || self.deploy_budget.is_some() {
                s.push(spending(
                    screen,
                    Some(b),
                    self.deploy_budget,
                    self.screen_iterations,
                ));
            }
        }
        s.push(stage(
            StageKind::BaselineTest,
            None,
            self.baseline_test_iterations,
        ));
        for &b in &self.budgets {
            for kind in [StageKind::TestLearned, StageKind::TestUniform] {
                s.push(search(kind, b));
            }
            for &strength in self.ablation_strengths() {
                s.push(Stage {
                    strength: Some(strength),
                    ..search(StageKind::TestLearned, b)
                });
            }
        }
        s
    }

    /// The strengths of `prior_strengths` that need a stage of their own: not 0 (that is
    /// `test-uniform`) and not `prior_strength` (that is `test-learned`, unless `transfer =
    /// auto` chooses its strengths: then every strength but 0 has its own stage).
    pub fn ablation_strengths(&self) -> impl Iterator<Item = &f64> {
        let fixed = self.transfer == Transfer::Fixed;
        self.prior_strengths
            .iter()
            .filter(move |&&s| s != 0.0 && (s != self.prior_strength || !fixed))
    }

    /// Total trials over all stages (saturating: an unvalidated protocol may ask for more than
    /// a `u64` holds).
    ///
    /// Stages with a cost budget count as their cap ([`MAX_ITERATIONS`]): see
    /// [`Stage::spend`].
    pub fn total_trials(&self) -> u64 {
        self.stages()
            .iter()
            .fold(0u64, |sum, s| sum.saturating_add(s.iterations))
    }

    /// Total trials over all stages, when every stage runs for its iterations (None: some
    /// stage has a cost budget, so the number of its trials is not known in advance).
    pub fn known_total_trials(&self) -> Option<u64> {
        self.stages()
            .iter()
            .all(|s| s.spend.is_none())
            .then(|| self.total_trials())
    }

    /// The seed of the kernel named `label`: the master seed mixed with the label (FNV-1a,
    /// then SplitMix64), stable across platforms and releases.
    pub fn kernel_seed(&self, label: &str) -> u64 {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in label.bytes() {
            h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
        let mut z = self.seed ^ h;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p() -> Protocol {
        Protocol::paper("test", vec!["a".into()], vec!["b".into()])
    }

    /// The tuned method pairs a quarter of the learning trials once the greedy fidelity arms
    /// hold 10 observations; the paper's pairs every trial and stores no `pair_settle` (its
    /// protocol.json, and so `savme reproduce`'s fixtures, as before).
    #[test]
    fn the_tuned_method_settles_theta_lf_at_ten_observations() {
        let tuned = p().with_method(Method::Tuned);
        assert_eq!((tuned.pair_fraction, tuned.pair_settle), (0.25, 10));
        assert_eq!(tuned.pairing().settle, TUNED_PAIR_SETTLE);
        let json = serde_json::to_value(&tuned).unwrap();
        assert_eq!(json["pair_settle"], 10);
        let paper = tuned.with_method(Method::Paper);
        assert_eq!((paper.pair_fraction, paper.pair_settle), (1.0, 30));
        let json = serde_json::to_value(&paper).unwrap();
        assert!(json.get("pair_settle").is_none(), "{json}");
        // A protocol stored before (no pair_settle) reads the kernel's 30.
        let mut stored = serde_json::to_value(p().with_method(Method::Tuned)).unwrap();
        stored.as_object_mut().unwrap().remove("pair_settle");
        let back: Protocol = serde_json::from_value(stored).unwrap();
        assert_eq!(back.pair_settle, 30);
    }

    #[test]
    fn a_bad_ladder_is_refused_naming_the_ladder_and_why() {
        let with = |budgets: &[f64], ladder: &[f64], screen: u64| Protocol {
            budgets: budgets.to_vec(),
            ladder: ladder.to_vec(),
            screen_iterations: screen,
            ..Protocol::paper("s", vec!["a".into()], vec!["b".into()])
        };
        let refused = |p: Protocol, why: &str| match p.validate() {
            Err(CampaignError::Protocol { field, message }) => {
                assert_eq!(field, "ladder");
                assert!(message.contains(why), "{message}");
            }
            other => panic!("{other:?}"),
        };
        refused(with(&[0.1, 0.3], &[0.3], 5), "one level");
        refused(
            with(&[0.1, 0.3], &[0.1, 0.2], 5),
            "0.2 is not one of budgets (0.1, 0.3)",
        );
        refused(with(&[0.1, 0.3], &[0.3, 0.1], 5), "cheapest first");
        refused(with(&[0.1, 0.3], &[0.1, 0.1], 5), "each budget once");
        refused(
            with(&[0.3, 0.1], &[0.1, 0.3], 5),
            "budgets lists 0.3 before 0.1",
        );
        refused(with(&[0.1, 0.3], &[0.1, 0.3], 0), "screen_iterations is 0");
        let p = with(&[0.05, 0.1, 0.3], &[0.05, 0.1, 0.3], 5);
        p.validate().expect("a three-level ladder");
        assert_eq!(p.levels(0.3), [0.05, 0.1, 0.3]);
        assert_eq!(p.levels(0.1), [0.1]);
        // Shared meta-training: only the top level is a budget.
        let shared = |budgets: &[f64], ladder: &[f64]| Protocol {
            ladder_training: LadderTraining::Shared,
            ..with(budgets, ladder, 5)
        };
        shared(&[0.3], &[0.1, 0.3])
            .validate()
            .expect("a shared ladder");
        shared(&[0.05, 0.3], &[0.1, 0.3])
            .validate()
            .expect("another budget beside it");
        refused(
            shared(&[0.1], &[0.1, 0.3]),
            "top level 0.3 is not one of budgets",
        );
        refused(shared(&[0.1, 0.3], &[0.1, 0.3]), "0.1 is one of budgets");
        refused(shared(&[0.3], &[0.2, 0.1, 0.3]), "cheapest first");
        refused(shared(&[0.3], &[0.0, 0.3]), "0 is outside (0, 1]");
        let json = serde_json::to_value(shared(&[0.3], &[0.1, 0.3])).unwrap();
        assert_eq!(json["ladder_training"], "shared");
        assert!(serde_json::to_value(with(&[0.1, 0.3], &[0.1, 0.3], 5))
            .unwrap()
            .get("ladder_training")
            .is_none());
    }

    #[test]
    fn paper_protocol_has_the_papers_stages() {
        let p = p();
        p.validate().unwrap();
        let labels: Vec<String> = p.stages().iter().map(Stage::label).collect();
        assert_eq!(labels[0], "baseline-train");
        assert_eq!(labels[1..3], ["train@0.2", "evaluate@0.2"]);
        assert!(labels.contains(&"test-learned@0.4".to_string()));
        assert_eq!(labels.len(), 1 + 3 * 2 + 1 + 3 * 2);
        assert_eq!(p.total_trials(), 700 + 3 * 600 + 300 + 3 * 400);
    }

    #[test]
    fn bad_protocols_name_the_field() {
        type Change = Box<dyn Fn(&mut Protocol)>;
        let cases: Vec<(Change, &str)> = vec![
            (Box::new(|p| p.budgets = vec![0.0]), "budgets"),
            (Box::new(|p| p.budgets = vec![1.5]), "budgets"),
            (Box::new(|p| p.budgets = vec![f64::NAN]), "budgets"),
            (Box::new(|p| p.budgets = vec![]), "budgets"),
            (Box::new(|p| p.budgets = vec![0.3, 0.3]), "budgets"),
            (Box::new(|p| p.train_iterations = 0), "train_iterations"),
            (Box::new(|p| p.eval_iterations = 0), "eval_iterations"),
            (Box::new(|p| p.test_scenarios.clear()), "test_scenarios"),
            (Box::new(|p| p.window = 0), "window"),
            (Box::new(|p| p.prior_strength = -1.0), "prior_strength"),
            (
                Box::new(|p| p.train_iterations = 10_000_000_000),
                "train_iterations",
            ),
            (
                Box::new(|p| p.test_iterations = u64::MAX),
                "test_iterations",
            ),
            (Box::new(|p| p.fidelity_bins = 0), "fidelity_bins"),
            (Box::new(|p| p.fidelity_bins = 100_000), "fidelity_bins"),
            (Box::new(|p| p.window = usize::MAX), "window"),
            (Box::new(|p| p.budgets = vec![0.5; 101]), "budgets"),
            (
                Box::new(|p| p.prior_strengths = vec![-0.1]),
                "prior_strengths",
            ),
            (
                Box::new(|p| p.prior_strengths = vec![0.3, 0.3]),
                "prior_strengths",
            ),
            (
                Box::new(|p| p.prior_strengths = vec![f64::INFINITY]),
                "prior_strengths",
            ),
        ];
        for (change, field) in cases {
            let mut p = p();
            change(&mut p);
            match p.validate() {
                Err(CampaignError::Protocol { field: f, .. }) => assert_eq!(f, field),
                other => panic!("expected an error on {field}, got {other:?}"),
            }
        }
    }

    #[test]
    fn the_prior_strength_ablation_adds_a_stage_per_new_strength_and_budget() {
        let mut p = p();
        p.prior_strengths = vec![0.0, 0.1, 0.3, 1.0];
        p.validate().unwrap();
        let labels: Vec<String> = p.stages().iter().map(Stage::label).collect();
        // 0 is test-uniform and 1 is test-learned: two new stages per budget.
        assert_eq!(labels.len(), 1 + 3 * 2 + 1 + 3 * 4);
        let at = labels.iter().position(|l| l == "test-uniform@0.2").unwrap();
        assert_eq!(
            labels[at + 1..at + 3],
            ["test-learned-s0.1@0.2", "test-learned-s0.3@0.2"]
        );
        // With transfer = auto, strength 1 is a stage of its own (the paper's transfer, next
        // to the strengths auto chose).
        p.transfer = Transfer::Auto;
        let labels: Vec<String> = p.stages().iter().map(Stage::label).collect();
        assert_eq!(labels.len(), 1 + 3 * 2 + 1 + 3 * 5);
        assert!(
            labels.contains(&"test-learned-s1@0.3".to_string()),
            "{labels:?}"
        );
        assert_eq!(
            crate::report::ablation::stage_id(&p, 0.3, 1.0).to_string(),
            "test-learned-s1@0.3"
        );
        // An old protocol.json (no key) reads as no ablation, and writes no key.
        let json = serde_json::to_string(&Protocol::paper("t", vec![], vec![])).unwrap();
        assert!(!json.contains("prior_strengths"));
        let back: Protocol = serde_json::from_str(&json).unwrap();
        assert!(back.prior_strengths.is_empty());
    }

    /// `Method::apply` (in protocol terms) and the kernel's `Preset` (in kernel terms) are two
    /// spellings of one method: a protocol set by a method builds the kernels its preset builds
    /// (`savme example-config`, Python's `Kernel` and the C ABI take the preset).
    #[test]
    fn each_method_sets_what_its_kernel_preset_sets() {
        for method in [Method::Tuned, Method::Paper] {
            let p = Protocol::quick("t", vec!["s".into()], vec![]).with_method(method);
            let preset = method.preset();
            assert_eq!(p.search.model(p.elite), preset.search(), "{method:?}");
            assert_eq!(p.deployment.kernel(), preset.deployment(), "{method:?}");
            // Scouting leaves trials unpaired, so it is a campaign's, as is its pairing of a
            // quarter of the trials: the preset's harnesses (Python's `Kernel`, the C ABI,
            // `savme serve`) get θ_LF with every learning trial.
            let mut allocation = preset.allocation();
            if let savme_kernel::Allocation::CostRate(r) = &mut allocation {
                r.scout = p.allocation == Allocate::CostRateScout;
            }
            assert_eq!(
                p.allocation.kernel(p.coverage_floor),
                allocation,
                "{method:?}"
            );
            assert_eq!(p.theta_lf_choice.kernel(), preset.estimator(), "{method:?}");
        }
    }

    /// Issue 40 item 3: a stored protocol whose simulator label the matcher takes for the given
    /// one (an FMU campaign's label with its paths spelled otherwise) is the same campaign;
    /// any other difference still is not.
    #[test]
    fn a_stored_label_the_matcher_accepts_is_the_same_campaign() {
        set_simulator_matcher(|s, g| s == "fmu:./a.fmu|./a.fmu" && g == "fmu:/d/a.fmu|/d/a.fmu");
        let stored = Protocol::quick("fmu:./a.fmu|./a.fmu", vec!["s".into()], vec!["t".into()]);
        let given = Protocol {
            simulator: "fmu:/d/a.fmu|/d/a.fmu".into(),
            ..stored.clone()
        };
        assert!(stored.same_campaign(&given));
        assert!(!given.same_campaign(&stored), "stored, then given");
        assert!(!stored.same_campaign(&Protocol {
            seed: stored.seed + 1,
            ..given.clone()
        }));
        let other = Protocol {
            simulator: "fmu:/e/a.fmu|/e/a.fmu".into(),
            ..stored.clone()
        };
        assert!(!stored.same_campaign(&other));
        assert!(same_simulator("savme-sim", "savme-sim"));
    }

    #[test]
    fn kernel_seeds_differ_by_label_and_seed() {
        let mut p = p();
        let a = p.kernel_seed("train@0.3");
        assert_ne!(a, p.kernel_seed("train@0.2"));
        assert_eq!(a, p.kernel_seed("train@0.3"));
        p.seed = 2;
        assert_ne!(a, p.kernel_seed("train@0.3"));
    }
}
