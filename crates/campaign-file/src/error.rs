//! The one error of a campaign file.

/// A problem with a campaign file: where it is and what is wrong. Displayed as
/// ``FILE, line N, key `K`: message`` (line and key when known).
///
/// ```
/// use savme_campaign_file::ConfigError;
/// let e = ConfigError {
///     file: "campaign.toml".into(),
///     line: Some(12),
///     key: Some("campaign.budgets".into()),
///     message: "1.3 is outside (0, 1]".into(),
/// };
/// assert_eq!(
///     e.to_string(),
///     "campaign.toml, line 12, key `campaign.budgets`: 1.3 is outside (0, 1]"
/// );
/// ```
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{file}{}{}: {message}", line.map_or(String::new(), |l| format!(", line {l}")), key.as_ref().map_or(String::new(), |k| format!(", key `{k}`")))]
pub struct ConfigError {
    /// The campaign file.
    pub file: String,
    /// 1-based line, when known.
    pub line: Option<usize>,
    /// The key, when known.
    pub key: Option<String>,
    /// What is wrong.
    pub message: String,
}
