//! What an estimate runs with ([`EstimateSettings`]) and why it may not run ([`EstimateError`]).

use crate::CampaignError;
use savme_kernel::estimation::{
    Control, EstimationError, Fidelity, Joint, Nominal, ProposalKind, Refine, Tilt,
    DEFAULT_COMPONENTS, MAX_COMPONENTS,
};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::PathBuf;

/// How `savme estimate` runs: which trained posterior, ε, the nominal, when to stop.
/// Stored as `estimate.json` in the output directory; a resumed estimate keeps it.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EstimateSettings {
    /// The budget whose meta-training posterior builds the proposal (None: the protocol's
    /// first budget).
    pub budget: Option<f64>,
    /// The nominal's share ε of the proposal, in (0, 1]; 1 is plain Monte Carlo.
    pub epsilon: f64,
    /// Seed of the proposal's draws (None: derived from the campaign's seed and the budget).
    pub seed: Option<u64>,
    /// Stop once the total's 95 % interval is within ± this fraction of the estimate (and
    /// `min_failures` failures were seen); None: run `max_runs`.
    pub target_width: Option<f64>,
    /// The most runs to make (HF, and the pilot's LF runs with `pilot_fidelity` = `lf`).
    pub max_runs: u64,
    /// Failures needed before the target width may stop the estimate (a normal interval on
    /// a handful of failures is not trustworthy).
    pub min_failures: u64,
    /// The scenarios to estimate (empty: every meta-training scenario).
    #[serde(default)]
    pub scenarios: Vec<String>,
    /// Non-uniform nominals, by scenario then variable.
    #[serde(default)]
    pub nominal: BTreeMap<String, BTreeMap<String, Nominal>>,
    /// How the proposal weighs the bins: `posterior` (the posterior means; default) or
    /// `nominal-weighted` (× the nominal's bin probability).
    #[serde(default)]
    pub tilt: Tilt,
    /// Cross-entropy pilot rounds that refit the proposal before the estimate (0: none).
    #[serde(default)]
    pub refine_rounds: u32,
    /// Runs per pilot round (HF, or LF with `pilot_fidelity` = `lf`; counted in `max_runs`;
    /// not part of the estimate unless reused).
    #[serde(default)]
    pub refine_runs: u64,
    /// How many of the last pilot rounds also count toward the estimate, each trial with its
    /// own round's weight (0: none; at most `refine_rounds`).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub refine_reuse: u32,
    /// The proposal the pilot rounds fit: `product` (each variable's bins; default) or
    /// `joint` (a mixture over the whole of φ, fitted to the pilot's weighted failures and
    /// near-misses; needs `refine_rounds`).
    #[serde(default, skip_serializing_if = "is_product")]
    pub proposal: ProposalKind,
    /// The most mixture components of a joint proposal (default 8; only with `proposal` =
    /// `joint`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub joint_components: Option<u32>,
    /// The fidelity of the pilot rounds: `hf` (default) or `lf` — the multi-fidelity
    /// estimator: the proposal is fitted on LF runs at the campaign's learned θ_LF* (cheap),
    /// the estimate uses HF runs only (unbiased for the HF probability). Needs
    /// `refine_rounds`; `refine_reuse` must be 0.
    #[serde(default, skip_serializing_if = "Fidelity::is_hf")]
    pub pilot_fidelity: Fidelity,
    /// LF runs at the campaign's learned θ_LF* as control variates for the HF estimate
    /// (multi-fidelity Monte Carlo): this many calibration pairs (φ run at HF and at LF,
    /// not part of the estimate) choose α and the LF runs per pair, then every estimate
    /// draw runs at both fidelities, plus extra LF-only draws — or HF only, when the measured
    /// correlation and costs say the LF does not pay. 0 (default): off.
    #[serde(default, skip_serializing_if = "is_zero_u64")]
    pub control_calibration: u64,
    /// Extra LF-only runs per estimate pair with control variates, 0..=64 (None: chosen
    /// from the calibration; 0: HF only after it). Needs `control_calibration`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub control_extra: Option<u32>,
}

fn is_zero(n: &u32) -> bool {
    *n == 0
}

fn is_zero_u64(n: &u64) -> bool {
    *n == 0
}

fn is_product(p: &ProposalKind) -> bool {
    *p == ProposalKind::Product
}

/// The settings left out of `estimate.json` at their default (so that older files read the
/// same).
const SKIPPED_AT_DEFAULT: &[&str] = &[
    "refine_reuse",
    "proposal",
    "joint_components",
    "pilot_fidelity",
    "control_calibration",
    "control_extra",
];

/// The stored value of a setting left out of `estimate.json` because it has its default.
fn absent(name: &str) -> serde_json::Value {
    match name {
        "proposal" => serde_json::Value::from("product"),
        "pilot_fidelity" => serde_json::Value::from("hf"),
        "joint_components" | "control_extra" => serde_json::Value::Null,
        _ => serde_json::Value::from(0),
    }
}

/// The most HF runs one estimate may make.
pub const MAX_RUNS: u64 = 100_000_000;

impl Default for EstimateSettings {
    fn default() -> Self {
        EstimateSettings {
            budget: None,
            epsilon: 0.1,
            seed: None,
            target_width: Some(0.1),
            max_runs: 10_000,
            min_failures: 10,
            scenarios: Vec::new(),
            nominal: BTreeMap::new(),
            tilt: Tilt::Posterior,
            refine_rounds: 0,
            refine_runs: 0,
            refine_reuse: 0,
            proposal: ProposalKind::Product,
            joint_components: None,
            pilot_fidelity: Fidelity::Hf,
            control_calibration: 0,
            control_extra: None,
        }
    }
}

/// The settings that only decide when an estimate stops: a resume may change them.
pub const STOPPING_RULES: &[&str] = &["max_runs", "target_width", "min_failures"];

/// The settings a resume runs with: `stored`, with each setting named in `given` (None: every
/// one) compared with `wanted`'s. A stopping rule that differs is applied (listed as
/// `name: stored → given`); any other difference is [`EstimateError::ChangedOnResume`].
///
/// ```
/// use savme_campaign::estimate::{settings_on_resume, EstimateSettings};
/// let stored = EstimateSettings::default();
/// let mut wanted = stored.clone();
/// wanted.max_runs = 50;
/// let (s, changed) = settings_on_resume("e/estimate.json".as_ref(), stored.clone(), &wanted, None)?;
/// assert_eq!((s.max_runs, changed), (50, vec!["max_runs: 10000 → 50".to_string()]));
/// wanted.epsilon = 0.5;
/// let e = settings_on_resume("e/estimate.json".as_ref(), stored.clone(), &wanted, Some(&["epsilon".into()]));
/// assert!(e.unwrap_err().to_string().contains("`epsilon` = 0.1, and this resume gives 0.5"));
/// // Not given: the stored value is kept.
/// let (s, _) = settings_on_resume("e/estimate.json".as_ref(), stored, &wanted, Some(&[]))?;
/// assert_eq!(s.epsilon, 0.1);
/// # Ok::<(), savme_campaign::estimate::EstimateError>(())
/// ```
pub fn resumed(
    file: &std::path::Path,
    stored: EstimateSettings,
    wanted: &EstimateSettings,
    given: Option<&[String]>,
) -> Result<(EstimateSettings, Vec<String>), EstimateError> {
    let as_map = |s: &EstimateSettings| match serde_json::to_value(s) {
        Ok(serde_json::Value::Object(m)) => m,
        _ => serde_json::Map::new(),
    };
    let (mut merged, mut wanted) = (as_map(&stored), as_map(wanted));
    // Settings left out of the JSON at their default are compared as that default.
    for name in SKIPPED_AT_DEFAULT {
        if !wanted.contains_key(*name) {
            wanted.insert(name.to_string(), absent(name));
        }
    }
    let mut changed = Vec::new();
    for (name, value) in &wanted {
        if given.is_some_and(|g| !g.iter().any(|n| n == name)) {
            continue;
        }
        let was = merged.get(name).cloned().unwrap_or_else(|| absent(name));
        if was == *value {
            continue;
        }
        if !STOPPING_RULES.contains(&name.as_str()) {
            return Err(EstimateError::ChangedOnResume {
                file: file.to_path_buf(),
                setting: name.clone(),
                stored: was.to_string(),
                given: value.to_string(),
            });
        }
        changed.push(format!("{name}: {was} → {value}"));
        merged.insert(name.clone(), value.clone());
    }
    let settings = serde_json::from_value(serde_json::Value::Object(merged)).unwrap_or(stored);
    Ok((settings, changed))
}

impl EstimateSettings {
    /// The cross-entropy refinement these settings ask for, if any.
    pub fn refine(&self) -> Option<Refine> {
        (self.refine_rounds > 0).then_some(Refine {
            rounds: self.refine_rounds,
            runs: self.refine_runs,
            reuse: self.refine_reuse,
        })
    }

    /// The kernel's configuration of these settings with the seed `seed`.
    pub fn config(&self, seed: u64) -> savme_kernel::estimation::EstimationConfig {
        savme_kernel::estimation::EstimationConfig {
            epsilon: self.epsilon,
            seed,
            nominal: self.nominal.clone(),
            tilt: self.tilt,
            refine: self.refine(),
            joint: (self.proposal == ProposalKind::Joint).then(|| Joint {
                components: self.joint_components.unwrap_or(DEFAULT_COMPONENTS),
            }),
            pilot_fidelity: self.pilot_fidelity,
            control: self.control(),
        }
    }

    /// The control variates these settings ask for, if any.
    pub fn control(&self) -> Option<Control> {
        (self.control_calibration > 0).then_some(Control {
            calibration: self.control_calibration,
            extra: self.control_extra,
        })
    }

    /// Whether the estimate runs LF at θ_LF* (an LF pilot, or control variates).
    pub fn uses_lf(&self) -> bool {
        self.pilot_fidelity == Fidelity::Lf || self.control_calibration > 0
    }

    /// Checks every value; the error names the key.
    ///
    /// ```
    /// use savme_campaign::estimate::EstimateSettings;
    /// let mut s = EstimateSettings::default();
    /// assert!(s.validate().is_ok());
    /// s.target_width = Some(0.0);
    /// assert_eq!(
    ///     s.validate().unwrap_err().to_string(),
    ///     "estimate: `target_width`: must be a finite number > 0 (0.1 is ±10 %), got 0"
    /// );
    /// ```
    pub fn validate(&self) -> Result<(), EstimateError> {
        let bad = |key: &str, message: String| {
            Err(EstimateError::Setting {
                key: key.into(),
                message,
            })
        };
        if !(self.epsilon > 0.0 && self.epsilon <= 1.0) {
            return bad(
                "epsilon",
                format!(
                    "must lie in (0, 1] (1 is plain Monte Carlo), got {}",
                    self.epsilon
                ),
            );
        }
        if let Some(w) = self.target_width {
            if !(w.is_finite() && w > 0.0) {
                return bad(
                    "target_width",
                    format!("must be a finite number > 0 (0.1 is ±10 %), got {w}"),
                );
            }
        }
        if self.max_runs == 0 || self.max_runs > MAX_RUNS {
            return bad(
                "max_runs",
                format!("must lie in 1..={MAX_RUNS}, got {}", self.max_runs),
            );
        }
        if let Some(b) = self.budget {
            if !(b > 0.0 && b <= 1.0) {
                return bad("budget", format!("must lie in (0, 1], got {b}"));
            }
        }
        self.validate_refine()?;
        for (i, s) in self.scenarios.iter().enumerate() {
            if self.scenarios[..i].contains(s) {
                return bad("scenarios", format!("`{s}` is listed twice"));
            }
        }
        Ok(())
    }
}

impl EstimateSettings {
    /// `control_calibration` ≥ 2 (when on), `control_extra` ≤ 64 and only with it, no reuse.
    fn validate_control(&self) -> Result<(), EstimateError> {
        let bad = |key: &str, message: String| {
            Err(EstimateError::Setting {
                key: key.into(),
                message,
            })
        };
        let max = savme_kernel::estimation::MAX_EXTRA;
        match (self.control_calibration, self.control_extra) {
            (0, Some(k)) => bad(
                "control_extra",
                format!("{k} extra LF runs per pair need `control_calibration` (the control variates' calibration pairs) too"),
            ),
            (1, _) => bad(
                "control_calibration",
                "must be 0 (off) or at least 2 pairs (at least 2 per estimated scenario), got 1".into(),
            ),
            (_, Some(k)) if k > max => bad(
                "control_extra",
                format!("must lie in 0..={max} extra LF runs per pair, got {k}"),
            ),
            (c, _) if c > 0 && self.refine_reuse > 0 => bad(
                "refine_reuse",
                format!(
                    "{} pilot rounds to reuse, but with control variates (`control_calibration`) the estimate is that of its own pairs: leave it at 0",
                    self.refine_reuse
                ),
            ),
            (c, _) if c >= self.max_runs => bad(
                "control_calibration",
                format!("{c} calibration pairs (2 runs each) leave no runs of `max_runs` = {} for the estimate", self.max_runs),
            ),
            _ => Ok(()),
        }
    }

    fn validate_refine(&self) -> Result<(), EstimateError> {
        let bad = |key: &str, message: String| {
            Err(EstimateError::Setting {
                key: key.into(),
                message,
            })
        };
        match (self.proposal, self.joint_components) {
            (ProposalKind::Product, Some(k)) => {
                return bad(
                    "joint_components",
                    format!("{k} components need `proposal` = \"joint\" (the product proposal has none)"),
                )
            }
            (_, Some(k)) if k == 0 || k > MAX_COMPONENTS => {
                return bad(
                    "joint_components",
                    format!("must lie in 1..={MAX_COMPONENTS}, got {k}"),
                )
            }
            (ProposalKind::Joint, _) if self.refine_rounds == 0 => {
                return bad(
                    "proposal",
                    "the joint proposal is fitted by the cross-entropy pilot rounds: give `refine_rounds` and `refine_runs` too".into(),
                )
            }
            _ => {}
        }
        if self.pilot_fidelity == Fidelity::Lf {
            if self.refine_rounds == 0 {
                return bad(
                    "pilot_fidelity",
                    "`lf` runs the cross-entropy pilot rounds at the campaign's learned θ_LF*: give `refine_rounds` and `refine_runs` too".into(),
                );
            }
            if self.refine_reuse > 0 {
                return bad(
                    "refine_reuse",
                    format!(
                        "{} pilot rounds to reuse, but the pilot runs at LF (`pilot_fidelity` = \"lf\") and the estimate is about HF failures: leave it at 0",
                        self.refine_reuse
                    ),
                );
            }
        }
        self.validate_control()?;
        if self.refine_reuse > self.refine_rounds {
            return bad(
                "refine_reuse",
                format!(
                    "{} pilot rounds to reuse in the estimate, but `refine_rounds` is {}",
                    self.refine_reuse, self.refine_rounds
                ),
            );
        }
        match (self.refine_rounds, self.refine_runs) {
            (0, 0) => Ok(()),
            (0, runs) => bad(
                "refine_runs",
                format!("{runs} runs per round but no `refine_rounds`: give both, or neither"),
            ),
            (rounds, 0) => bad(
                "refine_runs",
                format!("{rounds} refinement rounds need `refine_runs` ≥ 1 runs per round"),
            ),
            (rounds, runs) if u64::from(rounds).saturating_mul(runs) >= self.max_runs => bad(
                "refine_runs",
                format!(
                    "{rounds} rounds of {runs} runs leave none of `max_runs` = {} for the estimate",
                    self.max_runs
                ),
            ),
            _ => Ok(()),
        }
    }
}

/// Why an estimate could not run. Every variant names its culprit.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EstimateError {
    /// A setting is invalid.
    #[error("estimate: `{key}`: {message}")]
    Setting {
        /// The key (as in `estimate.json`; the flag is the key with dashes).
        key: String,
        /// What is wrong.
        message: String,
    },
    /// A `--nominal` declaration that cannot be read.
    #[error("estimate: --nominal `{given}`: {message}")]
    NominalSyntax {
        /// What was given.
        given: String,
        /// What is wrong.
        message: String,
    },
    /// The campaign has not (yet) trained the posterior the estimate needs.
    #[error("{campaign}: stage `{stage}` has {told} of its {needed} trials; finish the campaign (savme reproduce/run --resume) before estimating")]
    NotTrained {
        /// The campaign (its directory, or its database and name).
        campaign: String,
        /// The training stage.
        stage: String,
        /// Its told trials.
        told: u64,
        /// The protocol's iterations.
        needed: u64,
    },
    /// A multi-fidelity estimate (`pilot_fidelity` = `lf`) of a campaign that has no learned
    /// θ_LF* at the budget (its evaluation stage, which runs θ_LF*, has no trial yet).
    #[error("{campaign}: `pilot_fidelity` = \"lf\" runs the pilot at the learned θ_LF* of budget {budget}, which the campaign's stage `{stage}` has not run yet (no trial with θ_LF there), and so do the control variates (`control_calibration`); finish the campaign, or use `pilot_fidelity` = \"hf\" without control variates")]
    NoLearnedFidelity {
        /// The campaign.
        campaign: String,
        /// The budget.
        budget: f64,
        /// The evaluation stage.
        stage: String,
    },
    /// The campaign has no directory of its own (it is kept in a database): the estimate
    /// needs an output directory.
    #[error(
        "{campaign} has no directory of its own: give the estimate an output directory (--out DIR)"
    )]
    NoOutputDirectory {
        /// The campaign.
        campaign: String,
    },
    /// A budget the campaign did not train.
    #[error("estimate: `budget`: the campaign trained budgets {known}, not {budget}")]
    UnknownBudget {
        /// The budget given.
        budget: f64,
        /// The campaign's budgets.
        known: String,
    },
    /// A scenario the campaign did not learn.
    #[error("estimate: scenario `{name}` was not learned by this campaign (learned: {known})")]
    UnknownScenario {
        /// The name given.
        name: String,
        /// The learned scenarios.
        known: String,
    },
    /// The output directory already holds an estimate (and no resume was asked).
    #[error("{} already holds an estimate; continue it with --resume, or give another --out", dir.display())]
    Exists {
        /// The directory.
        dir: PathBuf,
    },
    /// A resume of a directory without an estimate.
    #[error("{}: no estimate to resume (no estimate.json)", dir.display())]
    NothingToResume {
        /// The directory.
        dir: PathBuf,
    },
    /// A resume gives a setting that changes the runs drawn, other than the stored one.
    #[error("{}: the estimate was started with `{setting}` = {stored}, and this resume gives {given}: a resumed estimate keeps the settings its runs were drawn with; leave `{setting}` as it was, or start a new estimate in another output directory", file.display())]
    ChangedOnResume {
        /// The stored settings (`estimate.json`).
        file: PathBuf,
        /// The setting's name.
        setting: String,
        /// Its stored value (JSON).
        stored: String,
        /// The value given (JSON).
        given: String,
    },
    /// A stored estimate trial that is not what the settings give (edited, or another run).
    #[error("{store}, line {line}: {message}")]
    Diverged {
        /// The trial store.
        store: String,
        /// 1-based line.
        line: u64,
        /// What differs.
        message: String,
    },
    /// An HF run failed; the estimate stops rather than drop the trial (dropping would bias
    /// it). Resume runs the trial again.
    #[error("estimate trial {trial} (scenario `{scenario}`, φ = {phi}): {message}")]
    Simulation {
        /// The trial id.
        trial: u64,
        /// Its scenario.
        scenario: String,
        /// Its parameters.
        phi: String,
        /// What failed.
        message: String,
    },
    /// A stop was requested ([`EstimateRun::stop_on`]): the runs in flight were told and
    /// stored, no more were asked; resume continues the estimate.
    ///
    /// [`EstimateRun::stop_on`]: super::EstimateRun::stop_on
    #[error("estimate stopped after {told} HF runs, every one stored in {}", store.display())]
    Stopped {
        /// HF runs told (replayed ones included).
        told: u64,
        /// The estimate's trial store.
        store: PathBuf,
    },
    /// The estimation could not be set up (ε, a nominal, a posterior).
    #[error("estimate: {0}")]
    Estimation(#[from] EstimationError),
    /// The campaign (protocol, store, files) could not be read, or outputs written.
    #[error(transparent)]
    Campaign(#[from] CampaignError),
}

impl EstimateSettings {
    /// The settings of a campaign file's `[estimate]` section (defaults for the keys not
    /// given), checked: the error names the file, the line and the key.
    pub fn from_section(
        section: &savme_campaign_file::EstimateSection,
        file: &std::path::Path,
    ) -> Result<EstimateSettings, savme_campaign_file::ConfigError> {
        let d = EstimateSettings::default();
        let s = EstimateSettings {
            budget: section.budget,
            epsilon: section.epsilon.unwrap_or(d.epsilon),
            seed: section.seed,
            target_width: section.target_width.or(d.target_width),
            max_runs: section.max_runs.unwrap_or(d.max_runs),
            min_failures: section.min_failures.unwrap_or(d.min_failures),
            scenarios: section.scenarios.clone().unwrap_or_default(),
            nominal: section.nominal.clone(),
            tilt: section.tilt.unwrap_or_default(),
            refine_rounds: section.refine_rounds.unwrap_or(0),
            refine_runs: section.refine_runs.unwrap_or(0),
            refine_reuse: section.refine_reuse.unwrap_or(0),
            proposal: section.proposal.unwrap_or_default(),
            joint_components: section.joint_components,
            pilot_fidelity: section.pilot_fidelity.unwrap_or_default(),
            control_calibration: section.control_calibration.unwrap_or(0),
            control_extra: section.control_extra,
        };
        let error = |key: String, message: String| savme_campaign_file::ConfigError {
            file: file.display().to_string(),
            line: Some(section.line_of(&key)),
            key: Some(format!("estimate.{key}")),
            message,
        };
        // An empty list would estimate every meta-training scenario, as no list does: say so
        // rather than run what the file seems not to ask for.
        if section.scenarios.as_ref().is_some_and(Vec::is_empty) {
            return Err(error(
                "scenarios".into(),
                "the list is empty: name scenarios, or leave the key out to estimate every \
                 meta-training scenario"
                    .into(),
            ));
        }
        match s.validate() {
            Err(EstimateError::Setting { key, message }) => Err(error(key, message)),
            _ => Ok(s),
        }
    }

    /// These settings with the nominal distributions a campaign file's scenarios declare in
    /// their OpenSCENARIO files (`declared`, by scenario then variable) added for the
    /// scenarios the estimate covers (`scenarios`, or `train` — the protocol's meta-training
    /// scenarios — when none are named). A nominal these settings already give for a variable
    /// (`[estimate.nominal]`, `--nominal`) wins.
    ///
    /// ```
    /// use savme_campaign::estimate::EstimateSettings;
    /// use savme_kernel::estimation::Nominal;
    /// use std::collections::BTreeMap;
    /// let normal = Nominal::Normal { mean: 16.0, sd: 3.0 };
    /// let declared = BTreeMap::from([
    ///     ("dry".to_string(), BTreeMap::from([("speed".to_string(), normal.clone())])),
    ///     ("icy".to_string(), BTreeMap::from([("speed".to_string(), normal.clone())])),
    /// ]);
    /// let s = EstimateSettings::default().with_declared(&declared, &["dry".to_string()]);
    /// assert_eq!(s.nominal["dry"]["speed"], normal);
    /// assert!(!s.nominal.contains_key("icy"), "not estimated");
    /// ```
    pub fn with_declared(
        mut self,
        declared: &BTreeMap<String, BTreeMap<String, Nominal>>,
        train: &[String],
    ) -> EstimateSettings {
        let covered = if self.scenarios.is_empty() {
            train.to_vec()
        } else {
            self.scenarios.clone()
        };
        for scenario in covered {
            let Some(vars) = declared.get(&scenario).filter(|v| !v.is_empty()) else {
                continue;
            };
            let given = self.nominal.entry(scenario).or_default();
            for (variable, nominal) in vars {
                given
                    .entry(variable.clone())
                    .or_insert_with(|| nominal.clone());
            }
        }
        self
    }

    /// Checks the budget against the protocol, and the nominal and the scenarios against the
    /// campaign's problem, before it runs (the posterior is not known yet: uniform ones stand
    /// in). The error names the budget, or the scenario and variable.
    pub fn check(
        &self,
        protocol: &crate::Protocol,
        problem: &crate::Problem,
    ) -> Result<(), EstimateError> {
        self.validate()?;
        if let Some(budget) = self.budget.filter(|b| !protocol.budgets.contains(b)) {
            let known: Vec<String> = protocol.budgets.iter().map(f64::to_string).collect();
            return Err(EstimateError::UnknownBudget {
                budget,
                known: known.join(", "),
            });
        }
        let names = if self.scenarios.is_empty() {
            &protocol.train_scenarios
        } else {
            &self.scenarios
        };
        let scenarios = super::posterior::untrained(names, protocol, problem)?;
        savme_kernel::estimation::Estimation::new(&scenarios, &self.config(0))?;
        Ok(())
    }
}
