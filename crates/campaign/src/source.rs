//! [`CampaignSource`]: a campaign read back without its lock — its protocol and its trial
//! lines — wherever it is kept. What reads a finished (or running) campaign (`savme
//! estimate`, `savme failures`) reads it through this seam: a directory ([`DirSource`]) here,
//! a database's campaign in `savme-postgres`.
//!
//! ```no_run
//! use savme_campaign::source::{CampaignSource, DirSource};
//! let campaign = DirSource::new("savme-results");
//! let protocol = campaign.protocol()?;
//! let lines = campaign.lines()?;
//! println!("{}: {} stages, {} lines", campaign.location(), protocol.stages().len(), lines.len());
//! # Ok::<(), savme_campaign::CampaignError>(())
//! ```

use super::log::LogLine;
use super::{CampaignError, Protocol};
use std::path::{Path, PathBuf};

/// A campaign to read (not to run): reading takes no lock and changes nothing, so a running
/// campaign can be read too.
pub trait CampaignSource {
    /// Where it is, for messages (never a password).
    fn location(&self) -> String;
    /// Its protocol, checked.
    fn protocol(&self) -> Result<Protocol, CampaignError>;
    /// Its trial lines with their line numbers, in store order.
    fn lines(&self) -> Result<Vec<(u64, LogLine)>, CampaignError>;
    /// Where the lines are, for a message about one of them (default: [`location`](Self::location)).
    fn lines_location(&self) -> String {
        self.location()
    }
    /// The campaign's own directory, if it has one (default place of derived outputs such as
    /// an estimate).
    fn dir(&self) -> Option<&Path> {
        None
    }
}

impl<T: CampaignSource + ?Sized> CampaignSource for Box<T> {
    fn location(&self) -> String {
        (**self).location()
    }
    fn protocol(&self) -> Result<Protocol, CampaignError> {
        (**self).protocol()
    }
    fn lines(&self) -> Result<Vec<(u64, LogLine)>, CampaignError> {
        (**self).lines()
    }
    fn lines_location(&self) -> String {
        (**self).lines_location()
    }
    fn dir(&self) -> Option<&Path> {
        (**self).dir()
    }
}

/// A campaign directory: `protocol.json` and `trials.jsonl`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DirSource {
    dir: PathBuf,
}

impl DirSource {
    /// The campaign in `dir`.
    pub fn new(dir: impl Into<PathBuf>) -> DirSource {
        DirSource { dir: dir.into() }
    }
}

impl CampaignSource for DirSource {
    fn location(&self) -> String {
        self.dir.display().to_string()
    }

    fn protocol(&self) -> Result<Protocol, CampaignError> {
        super::load_protocol(&self.dir)
    }

    fn lines(&self) -> Result<Vec<(u64, LogLine)>, CampaignError> {
        super::log::read_dir_lines(&self.dir)
    }

    fn lines_location(&self) -> String {
        super::Outputs::in_dir(&self.dir)
            .trials
            .display()
            .to_string()
    }

    fn dir(&self) -> Option<&Path> {
        Some(&self.dir)
    }
}
