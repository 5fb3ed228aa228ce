//! A campaign's row and the connection's name: the campaign name checked, its id (created if
//! new), its stored simulator label; `application_name` and the host savme puts there, and
//! whether an error means the connection was lost.

use postgres::Client;
use savme_store::StoreError;

/// The longest campaign name.
pub const MAX_NAME: usize = 200;

/// A campaign name must be 1 to [`MAX_NAME`] characters, none of them a control character.
pub fn check_name(name: &str) -> Result<(), StoreError> {
    if name.is_empty() || name.chars().count() > MAX_NAME || name.chars().any(char::is_control) {
        return Err(StoreError::Database {
            store: "--campaign".into(),
            message: format!(
                "{name:?} is not a campaign name (1 to {MAX_NAME} characters, no control characters)"
            ),
        });
    }
    Ok(())
}

/// This process as `application_name`: its role, pid and host.
pub fn application_name(role: &str) -> String {
    format!("savme {role} pid {} on {}", std::process::id(), host_name())
}

/// This host's name (as in messages that say where something happened).
pub fn host_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|h| h.trim().to_string())
        .unwrap_or_else(|_| "unknown host".into())
}

/// Whether a failed statement means the connection is gone (the server restarted or the
/// network broke), so that reconnecting may help.
pub fn connection_lost(client: &Client, e: &postgres::Error) -> bool {
    if client.is_closed() || e.is_closed() {
        return true;
    }
    match e.as_db_error() {
        // Class 08: connection exception; 57: operator intervention (shutdown, terminate).
        Some(db) => {
            let code = db.code().code();
            code.starts_with("08") || code.starts_with("57")
        }
        None => std::error::Error::source(e).is_some_and(|s| s.is::<std::io::Error>()),
    }
}

/// The id of campaign `name`, creating its row if missing.
pub fn campaign_id(client: &mut Client, name: &str) -> Result<i32, postgres::Error> {
    client.execute(
        "INSERT INTO savme.campaigns (name) VALUES ($1) ON CONFLICT (name) DO NOTHING",
        &[&name],
    )?;
    Ok(client
        .query_one("SELECT id FROM savme.campaigns WHERE name = $1", &[&name])?
        .get(0))
}

/// The id of an existing campaign `name`, if any (for workers, which never create one).
pub fn find_campaign(client: &mut Client, name: &str) -> Result<Option<i32>, postgres::Error> {
    Ok(client
        .query_opt("SELECT id FROM savme.campaigns WHERE name = $1", &[&name])?
        .map(|r| r.get(0)))
}

/// The simulator label of campaign `name`'s stored protocol — None while the database has no
/// savme schema (or one older than this savme's, not yet migrated by a coordinator), no such
/// campaign, no protocol yet, or this session's role may not work on it (a worker waits for
/// its coordinator). Read through `savme.worker_campaign`, which a worker role may call.
pub fn stored_simulator(
    client: &mut Client,
    name: &str,
) -> Result<Option<String>, postgres::Error> {
    Ok(crate::queue::worker_campaign(client, name)?.and_then(|c| c.simulator))
}
