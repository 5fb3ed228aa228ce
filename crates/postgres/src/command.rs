//! Commands savme suggests in its messages (`savme worker …`, the coordinator's `--resume`),
//! quoted for a POSIX shell so that they can be pasted as they are printed (a URL's `&` or `?`,
//! a campaign name with spaces).

use crate::Database;

/// Quoting for a POSIX shell: savme-campaign's (the CLI quotes its directory campaigns' commands
/// without this crate).
pub use savme_campaign::shell_quote;

/// The URL a worker on another host is told to use: the database's location (never its
/// password), which keeps the `sslmode` and `sslrootcert` the URL gave.
pub fn worker_url(db: &Database) -> String {
    db.location().to_string()
}

/// `savme worker --storage URL --campaign NAME`, shell-quoted, for campaign `name` of `db`.
///
/// ```
/// use savme_postgres::{worker_command, Database};
/// let db = Database::parse("postgresql://w:pw@db.lab/safety?sslmode=require").unwrap();
/// assert_eq!(
///     worker_command(&db, "night 1"),
///     "savme worker --storage 'postgresql://w@db.lab:5432/safety?sslmode=require' --campaign 'night 1'"
/// );
/// ```
pub fn worker_command(db: &Database, name: &str) -> String {
    format!(
        "savme worker --storage {} --campaign {}",
        shell_quote(&worker_url(db)),
        shell_quote(name)
    )
}
