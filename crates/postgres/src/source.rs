//! [`PostgresSource`]: a database's campaign read back without its lock (the
//! [`CampaignSource`] of `savme estimate` and `savme failures` with `--storage`).

use crate::{read_campaign, Database};
use savme_campaign::log::LogLine;
use savme_campaign::source::CampaignSource;
use savme_campaign::{CampaignError, Protocol};

/// Campaign `name` in the database `db`, read with plain `SELECT`s: nothing in the database
/// changes, and a campaign a coordinator holds can be read.
#[derive(Debug, Clone)]
pub struct PostgresSource {
    db: Database,
    name: String,
}

impl PostgresSource {
    /// The campaign `name` in `db`.
    pub fn new(db: Database, name: impl Into<String>) -> PostgresSource {
        PostgresSource {
            db,
            name: name.into(),
        }
    }
}

impl CampaignSource for PostgresSource {
    fn location(&self) -> String {
        format!("{}, campaign {:?}", self.db.location(), self.name)
    }

    fn protocol(&self) -> Result<Protocol, CampaignError> {
        let place = self.location();
        let (saved, _) = read_campaign(&self.db, &self.name)?;
        let saved = saved.ok_or_else(|| CampaignError::NoProtocol {
            store: place.clone(),
        })?;
        let protocol: Protocol = serde_json::from_value(saved).map_err(|e| CampaignError::Log {
            store: format!("{place}, protocol"),
            line: 1,
            message: e.to_string(),
        })?;
        protocol.validate()?;
        Ok(protocol)
    }

    fn lines(&self) -> Result<Vec<(u64, LogLine)>, CampaignError> {
        let place = self.location();
        let (_, loaded) = read_campaign(&self.db, &self.name)?;
        loaded
            .lines
            .iter()
            .map(|l| Ok((l.line, LogLine::from_stored(l, &place)?)))
            .collect()
    }
}
