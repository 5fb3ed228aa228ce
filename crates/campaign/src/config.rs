//! A campaign's [`Protocol`] and [`Problem`], from a preset or a campaign file plus the
//! command line's flags — in one place, for every command: a preset (or a file's `[campaign]`
//! section) first, then the flags, then validation.

use super::{CampaignError, Cost, Problem, Protocol};
use savme_fmu::campaign_file::{self, CampaignSection};

/// Protocol values given on the command line or in a campaign file (None: keep the value
/// before). Scenarios are given as the user wrote them and resolved by [`Overrides::apply`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Overrides {
    /// Master seed.
    pub seed: Option<u64>,
    /// Cost measure.
    pub cost: Option<super::Cost>,
    /// Compute budgets.
    pub budgets: Option<Vec<f64>>,
    /// Meta-training iterations per budget.
    pub train_iterations: Option<u64>,
    /// Evaluation trials per budget.
    pub eval_iterations: Option<u64>,
    /// Meta-testing iterations per budget and prior.
    pub test_iterations: Option<u64>,
    /// Baseline trials on the meta-training scenarios.
    pub baseline_train_iterations: Option<u64>,
    /// Baseline trials on the meta-testing scenarios.
    pub baseline_test_iterations: Option<u64>,
    /// Bins per continuous fidelity setting.
    pub fidelity_bins: Option<u32>,
    /// Power-prior strength of the meta-testing prior.
    pub prior_strength: Option<f64>,
    /// Trials in flight.
    pub window: Option<usize>,
    /// Meta-training scenarios (numbers or names, resolved by the caller's lookup).
    pub train_scenarios: Option<Vec<String>>,
    /// Meta-testing scenarios.
    pub test_scenarios: Option<Vec<String>>,
    /// The meta-testing prior-strength ablation.
    pub prior_strengths: Option<Vec<f64>>,
    /// LF screening trials per budget.
    pub screen_iterations: Option<u64>,
    /// Audit fraction of the screening.
    pub audit_fraction: Option<f64>,
    /// Seeds to run the protocol with ([`super::Repeated`]); not part of the protocol (each
    /// seed's `protocol.json` differs only in its seed), read by the command.
    pub repeat: Option<u32>,
}

impl Overrides {
    /// True when any value was given.
    pub fn any(&self) -> bool {
        *self != Overrides::default()
    }

    /// `self`, with every value `later` gives replacing this one's (a file's values, then the
    /// command line's).
    pub fn then(self, later: &Overrides) -> Overrides {
        let l = later.clone();
        Overrides {
            seed: l.seed.or(self.seed),
            cost: l.cost.or(self.cost),
            budgets: l.budgets.or(self.budgets),
            train_iterations: l.train_iterations.or(self.train_iterations),
            eval_iterations: l.eval_iterations.or(self.eval_iterations),
            test_iterations: l.test_iterations.or(self.test_iterations),
            baseline_train_iterations: l
                .baseline_train_iterations
                .or(self.baseline_train_iterations),
            baseline_test_iterations: l.baseline_test_iterations.or(self.baseline_test_iterations),
            fidelity_bins: l.fidelity_bins.or(self.fidelity_bins),
            prior_strength: l.prior_strength.or(self.prior_strength),
            window: l.window.or(self.window),
            train_scenarios: l.train_scenarios.or(self.train_scenarios),
            test_scenarios: l.test_scenarios.or(self.test_scenarios),
            prior_strengths: l.prior_strengths.or(self.prior_strengths),
            repeat: l.repeat.or(self.repeat),
            screen_iterations: l.screen_iterations.or(self.screen_iterations),
            audit_fraction: l.audit_fraction.or(self.audit_fraction),
        }
    }

    /// Applies the values to `p`; `scenario` turns a scenario as given into its name (None:
    /// unknown, an error listing `known`). Does not validate.
    pub fn apply(
        &self,
        p: &mut Protocol,
        scenario: &dyn Fn(&str) -> Option<String>,
        known: &str,
    ) -> Result<(), CampaignError> {
        fn set<T: Clone>(slot: &mut T, v: &Option<T>) {
            if let Some(v) = v {
                *slot = v.clone();
            }
        }
        set(&mut p.seed, &self.seed);
        set(&mut p.cost, &self.cost);
        set(&mut p.budgets, &self.budgets);
        set(&mut p.train_iterations, &self.train_iterations);
        set(&mut p.eval_iterations, &self.eval_iterations);
        set(&mut p.test_iterations, &self.test_iterations);
        set(
            &mut p.baseline_train_iterations,
            &self.baseline_train_iterations,
        );
        set(
            &mut p.baseline_test_iterations,
            &self.baseline_test_iterations,
        );
        set(&mut p.fidelity_bins, &self.fidelity_bins);
        set(&mut p.prior_strength, &self.prior_strength);
        set(&mut p.window, &self.window);
        set(&mut p.prior_strengths, &self.prior_strengths);
        set(&mut p.screen_iterations, &self.screen_iterations);
        set(&mut p.audit_fraction, &self.audit_fraction);
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
        if let Some(v) = &self.train_scenarios {
            p.train_scenarios = names(v)?;
        }
        if let Some(v) = &self.test_scenarios {
            p.test_scenarios = names(v)?;
        }
        Ok(())
    }
}

/// The number of seeds `repeat` asks for (None: one campaign, not a repeated one), checked
/// against [`super::MAX_REPEAT`].
///
/// ```
/// use savme_campaign::config::check_repeat;
/// assert_eq!(check_repeat(Some(5)).unwrap(), Some(5));
/// assert_eq!(check_repeat(None).unwrap(), None);
/// assert!(check_repeat(Some(0)).unwrap_err().to_string().contains("`repeat`"));
/// ```
pub fn check_repeat(repeat: Option<u32>) -> Result<Option<u32>, CampaignError> {
    match repeat {
        Some(n) if n == 0 || n > super::MAX_REPEAT => Err(CampaignError::Protocol {
            field: "repeat".into(),
            message: format!("{n} is not between 1 and {}", super::MAX_REPEAT),
        }),
        r => Ok(r),
    }
}

/// The simulator label of the toy simulator (`savme toy`).
pub const TOY: &str = "savme-toy";
/// The simulator label of the null simulator (`savme toy --null`).
pub const NULL: &str = "savme-null";

/// The label of the toy simulator sleeping `ms` milliseconds per run.
pub fn toy_label(ms: u64) -> String {
    if ms == 0 {
        TOY.into()
    } else {
        format!("{TOY}/sleep={ms}ms")
    }
}

/// The protocol and problem of a campaign on the toy simulator (`savme toy`): the quick
/// preset's stages on its two scenarios (`stopped_obstacle` for meta-training,
/// `braking_lead` for meta-testing), under the simulator `label`, validated.
pub fn toy(label: &str, o: &Overrides) -> Result<(Protocol, Problem), CampaignError> {
    let (train, test) = (
        vec![crate::toy::SCENARIOS[0].to_string()],
        vec![crate::toy::SCENARIOS[1].to_string()],
    );
    let mut p = Protocol::quick(label, train, test);
    let lookup = |k: &str| crate::toy::phi_space(k).map(|_| k.to_string());
    o.apply(&mut p, &lookup, &crate::toy::SCENARIOS.join(", "))?;
    p.validate()?;
    let (fidelity, theta_hf) = crate::toy::fidelity();
    let scenarios = crate::toy::SCENARIOS
        .iter()
        .filter_map(|s| crate::toy::phi_space(s).map(|space| (s.to_string(), space)))
        .collect();
    Ok((
        p,
        Problem {
            fidelity,
            theta_hf,
            scenarios,
        },
    ))
}

impl From<&CampaignSection> for Overrides {
    /// A campaign file's `[campaign]` section as overrides of the paper's protocol.
    fn from(c: &CampaignSection) -> Self {
        Overrides {
            seed: c.seed,
            cost: c.cost.map(|c| match c {
                campaign_file::Cost::Wall => Cost::Wall,
                campaign_file::Cost::Work => Cost::Work,
            }),
            budgets: c.budgets.clone(),
            train_iterations: c.train_iterations,
            eval_iterations: c.eval_iterations,
            test_iterations: c.test_iterations,
            baseline_train_iterations: c.baseline_train_iterations,
            baseline_test_iterations: c.baseline_test_iterations,
            fidelity_bins: c.fidelity_bins,
            prior_strength: c.prior_strength,
            window: c.window,
            train_scenarios: None,
            test_scenarios: None,
            prior_strengths: c.prior_strengths.clone(),
            repeat: c.repeat,
            screen_iterations: c.screen_iterations,
            audit_fraction: c.audit_fraction,
        }
    }
}
