//! The campaign file: the TOML that `savme run --config` and `savme.campaign.load` read.
//!
//! This crate reads the parts of the file that belong to the campaign — `[campaign]` (the
//! protocol's values and `out`), `[estimate]`, the fidelity space with θ_HF and the scenarios —
//! into a [`CampaignFile`]; the simulator adapter reads its own sections (for FMUs: `[fmu]` and
//! `[failure]`, see `savme_fmu::campaign_file`) from the same [`Source`] and turns the
//! bindings kept here (which simulator variable each savme variable sets) into its run
//! specification. Every error is a [`ConfigError`] naming the file and, where known, the line
//! and the key.
//!
//! ```toml
//! [campaign]                     # optional; every key optional (see CampaignSection)
//! budgets = [0.3]
//!
//! [estimate]                     # optional: P(failure) under the nominal after the campaign
//! target_width = 0.1             # (see EstimateSection for every key)
//!
//! [fidelity]                     # paper = true, or variables:
//! [[fidelity.variable]]
//! name = "rate"                  # bound to the simulator variable `rate` unless fmu = "…"
//! values = [2, 4, 10]            # or range = [lo, hi], bins = 10, scale = "linear" | "log" | "shifted-log"
//! hf = 10                        # θ_HF
//! # drives = "step_size"         # or "tolerance": the variable IS the step size (seconds) or
//! #                              # the tolerance, bound to no simulator variable
//!
//! [[scenario]]
//! name = "cut_in"
//! role = "train"                 # or "test"
//! weight = 1.0                   # p(s) weight, default 1
//! fixed = { scenario = 5 }       # simulator parameters set for every run of this scenario
//! [[scenario.phi]]
//! name = "gap"
//! range = [2.0, 8.0]
//!
//! [[scenario]]                   # φ from an OpenSCENARIO ParameterValueDistribution file:
//! name = "cut_out"               # each parameter a φ variable bound to the simulator variable
//! role = "test"                  # of its name (or the one `bind` gives), its stochastic
//! openscenario = "cut_out.xosc"  # distribution the nominal of `[estimate]`
//! bind = { EgoSpeed = "ego_speed" }
//! ```

mod error;
mod estimate;
mod fidelity;
mod scenario;
mod section;
mod source;
mod variable;

pub use error::ConfigError;
pub use estimate::EstimateSection;
pub use fidelity::{Bound, Fidelity, Setting};
pub use scenario::{ScenarioBindings, ScenarioLines, Scenarios};
pub use section::CampaignSection;
pub use source::{line_of, resolve, Source};
pub use variable::{toml_value, Drives, Named};

use savme_kernel::{Assignment, Space};
use std::path::{Path, PathBuf};
use toml::Spanned;

/// The campaign's sections of a file.
#[derive(Debug, serde::Deserialize)]
struct Sections {
    #[serde(default)]
    campaign: section::RawCampaignSection,
    estimate: Option<Spanned<estimate::raw::EstimateSection>>,
    fidelity: Spanned<fidelity::FidelitySection>,
    #[serde(rename = "scenario")]
    scenarios: Spanned<Vec<Spanned<scenario::ScenarioSection>>>,
}

/// The top-level keys this crate reads.
pub const SECTIONS: [&str; 4] = ["campaign", "estimate", "fidelity", "scenario"];

/// The campaign's part of a campaign file, read and checked.
#[derive(Debug, Clone)]
pub struct CampaignFile {
    /// The file.
    pub path: PathBuf,
    /// The `[campaign]` section.
    pub campaign: CampaignSection,
    /// The `[estimate]` section: estimate P(failure) after the campaign (`savme run`).
    pub estimate: Option<EstimateSection>,
    /// `[fidelity]`.
    pub fidelity: Fidelity,
    /// `[[scenario]]`.
    pub scenarios: Scenarios,
}

impl CampaignFile {
    /// Reads the campaign's sections of `src` (the file at `path`), refusing a top-level key
    /// that is neither one of [`SECTIONS`] nor one of the adapter's `adapter_sections`.
    /// `paper(bins)` gives the fidelity space and θ_HF of `[fidelity] paper = true` (called
    /// with `[campaign] fidelity_bins`, between 1 and [`savme_kernel::MAX_ARMS`]).
    ///
    /// ```
    /// use savme_campaign_file::{CampaignFile, Source};
    /// let text = r#"
    /// [fmu]
    /// hf = "model.fmu"
    /// [fidelity]
    /// [[fidelity.variable]]
    /// name = "rate"
    /// values = [2, 10]
    /// hf = 10
    /// [[scenario]]
    /// name = "cut_in"
    /// role = "train"
    /// [[scenario.phi]]
    /// name = "gap"
    /// range = [2.0, 8.0]
    /// "#;
    /// let src = Source::new("c.toml", text);
    /// let file = CampaignFile::parse(&src, "c.toml".as_ref(), &["fmu"], &|_| unreachable!())?;
    /// assert_eq!(file.scenarios.train, ["cut_in"]);
    /// assert_eq!(file.fidelity.space.variables()[0].name.as_ref(), "rate");
    /// // The adapter's sections are its own: an unknown one is refused, at its line.
    /// let err = CampaignFile::parse(&src, "c.toml".as_ref(), &[], &|_| unreachable!());
    /// assert_eq!(err.unwrap_err().line, Some(2));
    /// # Ok::<(), savme_campaign_file::ConfigError>(())
    /// ```
    pub fn parse(
        src: &Source,
        path: &Path,
        adapter_sections: &[&str],
        paper: &dyn Fn(u32) -> (Space, Assignment),
    ) -> Result<CampaignFile, ConfigError> {
        let known: Vec<&str> = adapter_sections.iter().copied().chain(SECTIONS).collect();
        src.check_sections(&known)?;
        let s: Sections = src.parse()?;
        let base = path.parent().unwrap_or(Path::new("."));
        let campaign = section::read(src, s.campaign, base)?;
        let estimate = s.estimate.map(|e| estimate::section(src, e));
        let fidelity = fidelity::read(src, &s.fidelity, &campaign, paper)?;
        let scenarios = scenario::read(src, &s.scenarios, base)?;
        Ok(CampaignFile {
            path: path.to_path_buf(),
            campaign,
            estimate,
            fidelity,
            scenarios,
        })
    }
}
