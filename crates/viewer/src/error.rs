//! [`RecordError`]: why recording failed — the one type every module of the viewer shares,
//! so that it sits below all of them.

/// Why recording failed (the message says what; callers add no prefix of their own).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct RecordError(pub(crate) String);

impl RecordError {
    /// An error saying `message` (e.g. from a simulator's `TrialFrames`).
    ///
    /// ```
    /// let e = savme_viewer::RecordError::new("φ has no `gap`");
    /// assert_eq!(e.to_string(), "φ has no `gap`");
    /// ```
    pub fn new(message: impl Into<String>) -> Self {
        RecordError(message.into())
    }
}

pub(crate) fn err(e: impl std::fmt::Display) -> RecordError {
    RecordError(e.to_string())
}
