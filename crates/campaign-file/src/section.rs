//! The `[campaign]` section: the protocol's values, as written, and the output directory.

use crate::{resolve, ConfigError, Source};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use toml::Spanned;

/// `[campaign]` as serde reads it: every key with its span (the protocol values are read by
/// name later, by the campaign layer).
pub(crate) type RawCampaignSection = BTreeMap<String, Spanned<toml::Value>>;

/// The `[campaign]` section as written: the protocol's values by key, each optional (the
/// campaign layer reads them by name — `savme_campaign::values` declares every one — supplies
/// the defaults and validates), and the output directory.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CampaignSection {
    /// The protocol values given, by key (`out` not among them).
    pub values: BTreeMap<String, toml::Value>,
    /// `out`, resolved relative to the campaign file.
    pub out: Option<PathBuf>,
    /// The 1-based line of each key given (`"budgets"` → 12), to name the line of an error
    /// found in a value later.
    pub lines: BTreeMap<String, usize>,
}

impl CampaignSection {
    /// `fidelity_bins` as given, if it is a number of bins (the paper's fidelity space needs
    /// it while the file is read; a value of another type is refused by the campaign layer).
    pub fn fidelity_bins(&self) -> Option<i64> {
        self.values
            .get("fidelity_bins")
            .and_then(toml::Value::as_integer)
    }
}

/// The `[campaign]` section without its spans, `out` checked and resolved against `base`.
pub(crate) fn read(
    src: &Source,
    c: RawCampaignSection,
    base: &Path,
) -> Result<CampaignSection, ConfigError> {
    let mut section = CampaignSection::default();
    for (key, value) in c {
        let line = src.line(value.span());
        if key == "out" {
            section.out = Some(resolve(base, &out(src, line, value.get_ref())?));
        } else {
            section.values.insert(key.clone(), value.into_inner());
        }
        section.lines.insert(key, line);
    }
    Ok(section)
}

/// `out`: a non-empty directory name.
fn out(src: &Source, line: usize, value: &toml::Value) -> Result<String, ConfigError> {
    match value {
        toml::Value::String(o) if !o.trim().is_empty() => Ok(o.clone()),
        // "" would resolve to the file's own directory: the campaign beside its simulator.
        toml::Value::String(_) => Err(src.err(
            Some(line),
            Some("campaign.out"),
            "is empty: name the output directory, or leave the key out",
        )),
        other => Err(src.err(
            Some(line),
            Some("campaign.out"),
            format!(
                "must be a directory name (a string), not {}",
                other.type_str()
            ),
        )),
    }
}
