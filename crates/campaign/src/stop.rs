//! [`Stop`]: asking a running campaign to stop between trials (Ctrl-C in the CLI, a
//! `KeyboardInterrupt` in Python, a harness's own deadline).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A request to stop a campaign, shared between the campaign and whoever may ask it to stop.
///
/// The campaign checks it before it waits for the next finished run. Once it is requested, no
/// trial is asked any more, the runs in flight are finished, and [`Campaign::run`] returns
/// [`CampaignError::Stopped`]. Every trial told so far is in the store, so a resumed campaign
/// continues exactly where this one stopped (the untold trials in flight are asked again).
///
/// ```
/// use savme_campaign::Stop;
/// let stop = Stop::new();
/// let for_the_handler = stop.clone();
/// assert!(!stop.is_requested());
/// for_the_handler.request(); // e.g. from a Ctrl-C handler
/// assert!(stop.is_requested());
/// ```
///
/// [`Campaign::run`]: super::Campaign::run
/// [`CampaignError::Stopped`]: super::CampaignError::Stopped
#[derive(Debug, Clone, Default)]
pub struct Stop(Arc<AtomicBool>);

impl Stop {
    /// A stop not yet requested.
    pub fn new() -> Self {
        Self::default()
    }

    /// Asks the campaign to stop (idempotent; safe from any thread or a signal handler).
    pub fn request(&self) {
        self.0.store(true, Ordering::SeqCst);
    }

    /// Whether a stop was requested.
    pub fn is_requested(&self) -> bool {
        self.0.load(Ordering::SeqCst)
    }
}
