//! The FMU sections as serde reads them. Keep the type names: serde names some of them in its
//! messages (e.g. "untagged enum StepSection"). Values an error may be about later are spanned,
//! to name their line.

use serde::Deserialize;
use toml::Spanned;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FmuSection {
    pub hf: Spanned<String>,
    pub lf: Option<Spanned<String>>,
    pub stop_time: Spanned<f64>,
    pub step: Option<Spanned<StepSection>>,
    pub tolerance: Option<Spanned<f64>>,
    #[serde(default = "yes")]
    pub stop_on_failure: bool,
    #[serde(default)]
    pub cost: Option<Spanned<String>>,
    #[serde(default)]
    pub isolate: bool,
    pub timeout_s: Option<Spanned<f64>>,
    #[serde(default)]
    pub on_error: OnError,
    /// Print every FMU log message (also `savme run --fmu-log`).
    #[serde(default)]
    pub log: bool,
    /// Outputs whose values the recordings of trials show over simulated time.
    pub record: Option<Spanned<Vec<Spanned<String>>>>,
}

fn yes() -> bool {
    true
}

#[derive(Debug, Deserialize, Default, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum OnError {
    #[default]
    Abort,
    Skip,
}

#[derive(Debug, Deserialize)]
#[serde(untagged)]
pub enum StepSection {
    Fixed(f64),
    Rate { rate_of: String },
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FailureSection {
    pub boolean: Option<Spanned<String>>,
    /// With `boolean`: a Real or Integer output read as the run's robustness.
    pub robustness: Option<Spanned<String>>,
    pub threshold: Option<Spanned<String>>,
    pub above: Option<Spanned<f64>>,
    pub below: Option<Spanned<f64>>,
}
