//! A protocol's stages: what each does ([`StageKind`]), its identity ([`StageId`]: kind,
//! budget and, for a prior-strength ablation stage, the strength) and how many trials it runs
//! ([`Stage`]).
//!
//! A stage's label (`train@0.3`, `test-learned-s0.1@0.3`) is how a [`StageId`] is written in
//! `trials.jsonl`, in progress lines and in the kernels' seeds; it is formatted exactly as
//! savme always wrote it ([`Compact`] numbers), so stored campaigns and seeds stay as they
//! were. Replay compares typed ids, never strings; a stored label that is not one savme writes
//! is refused, naming it ([`BadStageLabel`]). People see [`StageId::title`].
//!
//! ```
//! use savme_campaign::protocol::{StageId, StageKind};
//! let id: StageId = "test-learned-s0.1@0.3".parse()?;
//! assert_eq!((id.kind, id.budget, id.strength), (StageKind::TestLearned, Some(0.3), Some(0.1)));
//! assert_eq!(id.to_string(), "test-learned-s0.1@0.3");
//! assert_eq!(id.title(), "meta-testing with the learned prior (strength 0.1), budget 0.3");
//! assert!("train@0.30".parse::<StageId>().is_err()); // not as savme writes it
//! # Ok::<(), savme_campaign::protocol::BadStageLabel>(())
//! ```

use serde::{Deserialize, Serialize};

/// What a stage does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum StageKind {
    /// Uniform φ on the meta-training scenarios, HF only.
    BaselineTrain,
    /// Meta-training at a budget.
    Train,
    /// Evaluation of the meta-training posterior at a budget.
    Evaluate,
    /// LF screening with HF confirmation of the meta-training posterior at a budget.
    Screen,
    /// Uniform φ on the meta-testing scenarios, HF only.
    BaselineTest,
    /// Meta-testing with the meta-training posterior as the fidelity prior.
    TestLearned,
    /// Meta-testing with a uniform fidelity prior.
    TestUniform,
}

impl StageKind {
    /// The kind whose [`name`](StageKind::name) is `name`.
    pub fn named(name: &str) -> Option<StageKind> {
        [
            StageKind::BaselineTrain,
            StageKind::Train,
            StageKind::Evaluate,
            StageKind::Screen,
            StageKind::BaselineTest,
            StageKind::TestLearned,
            StageKind::TestUniform,
        ]
        .into_iter()
        .find(|k| k.name() == name)
    }

    /// The kebab-case name.
    pub fn name(self) -> &'static str {
        match self {
            StageKind::BaselineTrain => "baseline-train",
            StageKind::Train => "train",
            StageKind::Evaluate => "evaluate",
            StageKind::Screen => "screen",
            StageKind::BaselineTest => "baseline-test",
            StageKind::TestLearned => "test-learned",
            StageKind::TestUniform => "test-uniform",
        }
    }
}

/// One stage of the protocol: its identity ([`Stage::id`]) and its trials.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stage {
    /// What it does.
    pub kind: StageKind,
    /// Its budget (None for the baselines).
    pub budget: Option<f64>,
    /// Trials it runs.
    pub iterations: u64,
    /// The fidelity prior's strength of a prior-strength ablation stage (None: the protocol's
    /// `prior_strength` for `test-learned`, nothing for the others).
    pub strength: Option<f64>,
    /// The stage's cost budget (the protocol's `search_budget` or `deploy_budget`): it runs
    /// until its told runs have cost this much, `iterations` being only a cap. None: it runs
    /// `iterations` trials.
    pub spend: Option<f64>,
}

/// A budget or strength as it appears in stage labels, directory names and messages: as Rust
/// prints it (`0.3`, `0.05`) when that is at most [`Compact::MAX_PLAIN`] characters, else in
/// scientific notation (`1e-300`, not 300 zeros). Labels of every budget shorter than that are
/// unchanged, so the kernels' seeds (derived from the labels) and stored campaigns are too.
///
/// ```
/// use savme_campaign::protocol::Compact;
/// assert_eq!(Compact(0.3).to_string(), "0.3");
/// assert_eq!(Compact(1e-300).to_string(), "1e-300");
/// assert_eq!(Compact(1e300).to_string(), "1e300");
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Compact(pub f64);

impl Compact {
    /// The longest plain rendering kept as is.
    pub const MAX_PLAIN: usize = 20;
}

impl std::fmt::Display for Compact {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let plain = self.0.to_string();
        if plain.len() <= Self::MAX_PLAIN {
            f.write_str(&plain)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

impl Stage {
    /// What the stage runs, for people: `300 trials`, or with a cost budget `trials until
    /// 4e10 of cost are spent` (numbers as [`Compact`] writes them).
    pub fn planned(&self) -> String {
        match self.spend {
            Some(budget) => format!("trials until {} of cost are spent", Compact(budget)),
            None => format!("{} trials", self.iterations),
        }
    }

    /// The kernel phase its trials are asked in.
    pub fn phase(&self) -> savme_kernel::Phase {
        use savme_kernel::Phase;
        match self.kind {
            StageKind::BaselineTrain | StageKind::BaselineTest => Phase::Baseline,
            StageKind::Train => Phase::Train,
            StageKind::Evaluate | StageKind::Screen => Phase::Evaluate,
            StageKind::TestLearned | StageKind::TestUniform => Phase::Test,
        }
    }

    /// Its identity.
    pub fn id(&self) -> StageId {
        StageId {
            kind: self.kind,
            budget: self.budget,
            strength: self.strength,
        }
    }

    /// Its label in `trials.jsonl` and progress bars, e.g. `train@0.3`, or
    /// `test-learned-s0.1@0.3` for a prior-strength ablation stage ([`StageId`]'s `Display`).
    pub fn label(&self) -> String {
        self.id().to_string()
    }
}

/// A stage's identity: what it does, at which budget, with which prior strength (an ablation
/// stage). Written and read as its label (see the module docs); compared as typed values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StageId {
    /// What the stage does.
    pub kind: StageKind,
    /// Its budget (None for the baselines).
    pub budget: Option<f64>,
    /// The prior strength of a prior-strength ablation stage.
    pub strength: Option<f64>,
}

/// A stored stage label savme cannot read: not a stage kind, a bad number, or not written as
/// savme writes it.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{label}` is not a stage label ({reason}); savme writes labels such as `baseline-train`, `train@0.3` or `test-learned-s0.1@0.3`")]
pub struct BadStageLabel {
    /// The label as stored.
    pub label: String,
    /// What is wrong with it.
    pub reason: String,
}

impl StageId {
    /// The stage `kind` at `budget` (no ablation strength).
    pub fn new(kind: StageKind, budget: Option<f64>) -> StageId {
        StageId {
            kind,
            budget,
            strength: None,
        }
    }

    /// A readable name for people (summaries, tables): `meta-training, budget 0.3`.
    pub fn title(&self) -> String {
        let what = match self.kind {
            StageKind::BaselineTrain => "baseline on the meta-training scenarios",
            StageKind::Train => "meta-training",
            StageKind::Evaluate => "evaluation",
            StageKind::Screen => "LF screening",
            StageKind::BaselineTest => "baseline on the meta-testing scenarios",
            StageKind::TestLearned => "meta-testing with the learned prior",
            StageKind::TestUniform => "meta-testing with a uniform prior",
        };
        let what = match self.strength {
            Some(s) => format!("{what} (strength {})", Compact(s)),
            None => what.to_string(),
        };
        match self.budget {
            Some(b) => format!("{what}, budget {}", Compact(b)),
            None => what,
        }
    }
}

impl std::fmt::Display for StageId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.kind.name())?;
        if let Some(s) = self.strength {
            write!(f, "-s{}", Compact(s))?;
        }
        if let Some(b) = self.budget {
            write!(f, "@{}", Compact(b))?;
        }
        Ok(())
    }
}

impl std::str::FromStr for StageId {
    type Err = BadStageLabel;

    fn from_str(label: &str) -> Result<StageId, BadStageLabel> {
        let bad = |reason: &str| BadStageLabel {
            label: label.to_string(),
            reason: reason.to_string(),
        };
        let number = |text: &str, what: &str| {
            text.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| bad(&format!("its {what} `{text}` is not a number")))
        };
        let (head, budget) = match label.split_once('@') {
            Some((head, b)) => (head, Some(number(b, "budget")?)),
            None => (label, None),
        };
        let ablation = head
            .rsplit_once("-s")
            .and_then(|(name, s)| Some((StageKind::named(name)?, s)));
        let (kind, strength) = match (StageKind::named(head), ablation) {
            (Some(kind), _) => (kind, None),
            (None, Some((kind, s))) => (kind, Some(number(s, "prior strength")?)),
            (None, None) => return Err(bad(&format!("`{head}` is not a stage kind"))),
        };
        let id = StageId {
            kind,
            budget,
            strength,
        };
        if id.to_string() != label {
            return Err(bad(&format!("savme writes it `{id}`")));
        }
        Ok(id)
    }
}

impl Serialize for StageId {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for StageId {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<StageId, D::Error> {
        let label = std::borrow::Cow::<'de, str>::deserialize(d)?;
        label.parse().map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_label_savme_writes_reads_back_as_the_same_id() {
        let kinds = [
            StageKind::BaselineTrain,
            StageKind::Train,
            StageKind::Evaluate,
            StageKind::Screen,
            StageKind::BaselineTest,
            StageKind::TestLearned,
            StageKind::TestUniform,
        ];
        for kind in kinds {
            for budget in [None, Some(0.3), Some(0.05), Some(1.0), Some(1e-300)] {
                for strength in [None, Some(0.1), Some(2.0)] {
                    let id = StageId {
                        kind,
                        budget,
                        strength,
                    };
                    let label = id.to_string();
                    assert_eq!(label.parse::<StageId>(), Ok(id), "{label}");
                }
            }
        }
        assert_eq!(
            StageId::new(StageKind::Train, Some(0.3)).to_string(),
            "train@0.3"
        );
        assert_eq!(
            StageId::new(StageKind::BaselineTest, None).to_string(),
            "baseline-test"
        );
        assert_eq!(
            StageId::new(StageKind::Train, Some(1e-300)).to_string(),
            "train@1e-300"
        );
    }

    #[test]
    fn a_bad_label_says_what_is_wrong() {
        let cases = [
            ("trian@0.3", "`trian` is not a stage kind"),
            ("train@x", "its budget `x` is not a number"),
            ("train@0.30", "savme writes it `train@0.3`"),
            ("train@inf", "its budget `inf` is not a number"),
            (
                "test-learned-sx@0.3",
                "its prior strength `x` is not a number",
            ),
            ("", "`` is not a stage kind"),
        ];
        for (label, reason) in cases {
            let e = label.parse::<StageId>().unwrap_err();
            assert!(e.to_string().contains(reason), "{label}: {e}");
        }
        let e = serde_json::from_str::<StageId>("\"evaluate@\"").unwrap_err();
        assert!(
            e.to_string().contains("`evaluate@` is not a stage label"),
            "{e}"
        );
        assert_eq!(
            serde_json::to_string(&StageId::new(StageKind::Evaluate, Some(0.3))).unwrap(),
            "\"evaluate@0.3\""
        );
    }
}
