//! The campaign file's optional `[estimate]` section: `savme run` estimates P(failure) under
//! the nominal distribution after the campaign (see `savme estimate`).
//!
//! ```toml
//! [estimate]
//! epsilon = 0.1          # the nominal's share of the proposal, in (0, 1]
//! target_width = 0.1     # stop at ±10 % …
//! max_runs = 10000       # … or after this many HF runs
//! min_failures = 10
//! budget = 0.3           # whose meta-training posterior (default: the first budget)
//! seed = 7
//! scenarios = ["cut_in"] # default: every meta-training scenario
//! tilt = "posterior"     # or "nominal-weighted"
//! refine_rounds = 3      # cross-entropy pilot rounds …
//! refine_runs = 2000     # … of this many HF runs
//! proposal = "joint"     # or "product" (the default): what the pilot fits
//! joint_components = 8   # the joint proposal's most mixture components
//! pilot_fidelity = "lf"  # or "hf" (the default): the pilot runs at the learned θ_LF*
//! control_calibration = 2000  # LF runs as control variates: calibration pairs (0: off)
//! control_extra = 3      # extra LF runs per pair (default: chosen by the calibration)
//! [estimate.nominal.cut_in]
//! gap = { distribution = "normal", mean = 5.0, sd = 1.0 }
//! lane = { distribution = "weights", weights = [4, 2, 1] }
//! ```

use crate::Source;
use savme_kernel::estimation::{Fidelity, Nominal, ProposalKind, Tilt};
use std::collections::BTreeMap;
use toml::Spanned;

/// The section as serde reads it.
pub(crate) mod raw {
    use super::{Nominal, Spanned};
    use serde::Deserialize;
    use std::collections::BTreeMap;

    #[derive(Debug, Default, Deserialize)]
    #[serde(deny_unknown_fields)]
    pub struct EstimateSection {
        pub epsilon: Option<Spanned<f64>>,
        pub target_width: Option<Spanned<f64>>,
        pub max_runs: Option<Spanned<u64>>,
        pub min_failures: Option<Spanned<u64>>,
        pub budget: Option<Spanned<f64>>,
        pub seed: Option<Spanned<u64>>,
        pub scenarios: Option<Spanned<Vec<String>>>,
        pub tilt: Option<Spanned<super::Tilt>>,
        pub refine_rounds: Option<Spanned<u32>>,
        pub refine_runs: Option<Spanned<u64>>,
        pub refine_reuse: Option<Spanned<u32>>,
        pub proposal: Option<Spanned<super::ProposalKind>>,
        pub joint_components: Option<Spanned<u32>>,
        pub pilot_fidelity: Option<Spanned<super::Fidelity>>,
        pub control_calibration: Option<Spanned<u64>>,
        pub control_extra: Option<Spanned<u32>>,
        #[serde(default)]
        pub nominal: BTreeMap<String, BTreeMap<String, Spanned<Nominal>>>,
    }
}

/// The `[estimate]` section as written, every key optional (the caller supplies the defaults
/// and validates the values).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EstimateSection {
    /// `epsilon`.
    pub epsilon: Option<f64>,
    /// `target_width`.
    pub target_width: Option<f64>,
    /// `max_runs`.
    pub max_runs: Option<u64>,
    /// `min_failures`.
    pub min_failures: Option<u64>,
    /// `budget`.
    pub budget: Option<f64>,
    /// `seed`.
    pub seed: Option<u64>,
    /// `scenarios`.
    pub scenarios: Option<Vec<String>>,
    /// `tilt`: `"posterior"` or `"nominal-weighted"`.
    pub tilt: Option<Tilt>,
    /// `refine_rounds`: cross-entropy pilot rounds before the estimate.
    pub refine_rounds: Option<u32>,
    /// `refine_runs`: HF runs per pilot round.
    pub refine_runs: Option<u64>,
    /// `refine_reuse`: how many of the last pilot rounds also count toward the estimate.
    pub refine_reuse: Option<u32>,
    /// `proposal`: `"product"` or `"joint"`.
    pub proposal: Option<ProposalKind>,
    /// `joint_components`: the joint proposal's most mixture components.
    pub joint_components: Option<u32>,
    /// `pilot_fidelity`: `"hf"` or `"lf"` (the multi-fidelity estimator: pilot rounds at the
    /// campaign's learned θ_LF*).
    pub pilot_fidelity: Option<Fidelity>,
    /// `control_calibration`: LF runs as control variates, this many calibration pairs.
    pub control_calibration: Option<u64>,
    /// `control_extra`: extra LF-only runs per pair of the control variates.
    pub control_extra: Option<u32>,
    /// `[estimate.nominal.<scenario>] <variable> = { distribution = … }`.
    pub nominal: BTreeMap<String, BTreeMap<String, Nominal>>,
    /// The 1-based line of the `[estimate]` table.
    pub line: usize,
    /// The line of each key given (`"epsilon"`, `"nominal.cut_in.gap"`), to name it in an
    /// error found later.
    pub lines: BTreeMap<String, usize>,
}

impl EstimateSection {
    /// The line of `key`, else of the section.
    pub fn line_of(&self, key: &str) -> usize {
        self.lines.get(key).copied().unwrap_or(self.line)
    }
}

/// The section without its spans.
pub(crate) fn section(src: &Source, e: Spanned<raw::EstimateSection>) -> EstimateSection {
    let line = src.line(e.span());
    let e = e.into_inner();
    let mut lines = BTreeMap::new();
    let mut take = |key: &str, span: Option<std::ops::Range<usize>>| {
        if let Some(span) = span {
            lines.insert(key.to_string(), src.line(span));
        }
    };
    macro_rules! field {
        ($name:ident) => {{
            take(stringify!($name), e.$name.as_ref().map(Spanned::span));
            e.$name.map(Spanned::into_inner)
        }};
    }
    let mut s = EstimateSection {
        epsilon: field!(epsilon),
        target_width: field!(target_width),
        max_runs: field!(max_runs),
        min_failures: field!(min_failures),
        budget: field!(budget),
        seed: field!(seed),
        scenarios: field!(scenarios),
        tilt: field!(tilt),
        refine_rounds: field!(refine_rounds),
        refine_runs: field!(refine_runs),
        refine_reuse: field!(refine_reuse),
        proposal: field!(proposal),
        joint_components: field!(joint_components),
        pilot_fidelity: field!(pilot_fidelity),
        control_calibration: field!(control_calibration),
        control_extra: field!(control_extra),
        nominal: BTreeMap::new(),
        line,
        lines: BTreeMap::new(),
    };
    for (scenario, vars) in e.nominal {
        let mut out = BTreeMap::new();
        for (variable, n) in vars {
            take(&format!("nominal.{scenario}.{variable}"), Some(n.span()));
            out.insert(variable, n.into_inner());
        }
        s.nominal.insert(scenario, out);
    }
    s.lines = lines;
    s
}
