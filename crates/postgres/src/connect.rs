//! [`Database`]: where a PostgreSQL store is — parsed once from a `postgresql://` URL (or a
//! libpq `key=value` string, or a `--storage-file` holding either), shown everywhere without its
//! password, and connected to with bounded exponential backoff.
//!
//! Credentials come from the URL, `PGPASSWORD`, or `~/.pgpass` (`PGPASSFILE`), in that order,
//! as libpq takes them. They are kept only inside the connection configuration: every message
//! savme prints names the store by [`Database::location`] (user, host, port, database — no
//! password), and every error text from the client is passed through [`Database::redact`].
//!
//! TLS follows libpq's `sslmode` and `sslrootcert` (see [`super::tls`]).

use super::tls::{take_ssl_options, Tls};
use postgres::config::Host;
use postgres::{Client, Config, NoTls};
use savme_store::StoreError;
use std::path::Path;
use std::str::FromStr;
use std::time::{Duration, Instant};

/// A database to connect to: the parsed connection configuration and its printable name.
#[derive(Clone)]
pub struct Database {
    config: Config,
    location: String,
    secrets: Vec<String>,
    tls: Tls,
}

impl std::fmt::Debug for Database {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Database")
            .field("location", &self.location)
            .finish_non_exhaustive()
    }
}

/// How long [`Database::connect`] keeps trying before it gives up, unless the environment
/// variable `SAVME_RECONNECT_SECONDS` says otherwise (a restarting server is back within
/// seconds; a host that does not answer is reported after this).
pub const RECONNECT_FOR: Duration = Duration::from_secs(60);

/// [`RECONNECT_FOR`], or `SAVME_RECONNECT_SECONDS` when set to a number of seconds.
pub fn reconnect_for() -> Duration {
    std::env::var("SAVME_RECONNECT_SECONDS")
        .ok()
        .and_then(|s| s.trim().parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s >= 0.0)
        .map_or(RECONNECT_FOR, Duration::from_secs_f64)
}

impl Database {
    /// Parses a `postgresql://` (or `postgres://`) URL or a `key=value` connection string.
    /// The error never repeats the text given (it may hold a password).
    ///
    /// ```
    /// use savme_postgres::Database;
    /// let db = Database::parse("postgresql://alice:hunter2@db.example:6543/safety")?;
    /// assert_eq!(db.location(), "postgresql://alice@db.example:6543/safety");
    /// assert!(!format!("{db:?}").contains("hunter2"));
    /// assert_eq!(db.redact("auth failed for hunter2"), "auth failed for ***");
    /// # Ok::<(), savme_store::StoreError>(())
    /// ```
    pub fn parse(url: &str) -> Result<Database, StoreError> {
        let url = url.trim();
        let bad = |message: String| StoreError::Database {
            store: "--storage".into(),
            message,
        };
        // tokio-postgres reads neither `sslrootcert` nor the `verify-*` modes: savme does.
        let (rest, ssl) = take_ssl_options(url).unwrap_or_else(|| (url.into(), Default::default()));
        let mut config = Config::from_str(&rest).map_err(|e| {
            bad(format!(
                "not a PostgreSQL connection URL: {}",
                redact_in(&e.to_string(), &[url.to_string()])
            ))
        })?;
        let tls = Tls::new(&ssl).map_err(bad)?;
        config.ssl_mode(tls.mode.client_mode());
        if config.get_hosts().is_empty() {
            config.host("localhost");
        }
        if config.get_user().is_none() {
            let user = std::env::var("PGUSER")
                .or_else(|_| std::env::var("USER"))
                .unwrap_or_else(|_| "postgres".into());
            config.user(&user);
        }
        if config.get_password().is_none() {
            if let Some(pw) = std::env::var("PGPASSWORD").ok().or_else(|| pgpass(&config)) {
                config.password(pw);
            }
        }
        let mut secrets = Vec::new();
        if let Some(pw) = config.get_password() {
            let pw = String::from_utf8_lossy(pw).into_owned();
            if !pw.is_empty() {
                // Also its URL-encoded form, as it may appear in the URL.
                secrets.push(percent_encode(&pw));
                secrets.push(pw);
            }
        }
        let mut location = location_of(&config);
        // The TLS options the URL gave, so that the commands savme suggests keep them.
        let shown: Vec<String> = [("sslmode", &ssl.mode), ("sslrootcert", &ssl.root_cert)]
            .iter()
            .filter_map(|(k, v)| v.as_ref().map(|v| format!("{k}={v}")))
            .collect();
        if !shown.is_empty() {
            location = format!("{location}?{}", shown.join("&"));
        }
        Ok(Database {
            config,
            location,
            secrets,
            tls,
        })
    }

    /// Reads the connection URL from the first non-empty line of `path` (`--storage-file`, so
    /// that the password is not on the command line).
    pub fn from_file(path: &Path) -> Result<Database, StoreError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| StoreError::io(path.display().to_string(), e))?;
        let line = text
            .lines()
            .map(str::trim)
            .find(|l| !l.is_empty() && !l.starts_with('#'))
            .ok_or_else(|| StoreError::Database {
                store: path.display().to_string(),
                message: "holds no connection URL".into(),
            })?;
        Database::parse(line).map_err(|e| match e {
            StoreError::Database { message, .. } => StoreError::Database {
                store: path.display().to_string(),
                message,
            },
            other => other,
        })
    }

    /// The database as shown in messages: `postgresql://user@host:port/dbname`, never the
    /// password.
    pub fn location(&self) -> &str {
        &self.location
    }

    /// `text` with every occurrence of the password replaced by `***`.
    pub fn redact(&self, text: &str) -> String {
        redact_in(text, &self.secrets)
    }

    /// A database error as a [`StoreError`] naming `store`, its text redacted.
    pub fn error(&self, store: &str, e: &postgres::Error) -> StoreError {
        let mut message = e.to_string();
        if let Some(db) = e.as_db_error() {
            message = format!("{} ({})", db.message(), db.code().code());
        } else if let Some(source) = std::error::Error::source(e) {
            if !message.contains(&source.to_string()) {
                message = format!("{message}: {source}");
            }
        }
        StoreError::Database {
            store: store.into(),
            message: self.redact(&message),
        }
    }

    /// One connection attempt; the flag says whether the failure is final (the server itself
    /// refused: a wrong password, a missing database; or the TLS handshake failed).
    fn attempt(&self, application_name: &str) -> Result<Client, (StoreError, bool)> {
        let mut config = self.config.clone();
        config.application_name(application_name);
        if config.get_connect_timeout().is_none() {
            config.connect_timeout(Duration::from_secs(10));
        }
        let connected = match &self.tls.connector {
            Some(tls) => config.connect(tls.clone()),
            None => config.connect(NoTls),
        };
        connected.map_err(|e| {
            // The server's refusals are final (a wrong password, a missing database), except
            // while it starts or stops (57P03 and the rest of class 57), is out of
            // connections (53300) or reports a connection exception (class 08).
            let permanent = e.as_db_error().is_some_and(|db| {
                let code = db.code().code();
                !(code.starts_with("57") || code.starts_with("08") || code == "53300")
            });
            let mut error = self.error(&self.location, &e);
            // So is a failed TLS handshake (a certificate that does not verify, a server
            // without TLS under sslmode=require): say what was asked.
            let tls = e.to_string().contains("TLS handshake");
            if let (true, StoreError::Database { message, .. }) = (tls, &mut error) {
                *message = format!("{message} ({})", self.tls.explain());
            }
            (error, permanent || tls)
        })
    }

    /// Connects, retrying with exponential backoff (0.1 s doubling to 5 s) for up to
    /// [`reconnect_for`]; the error names the database and the last failure.
    pub fn connect(&self, application_name: &str) -> Result<Client, StoreError> {
        self.connect_for(application_name, reconnect_for())
    }

    /// [`Database::connect`] retrying for up to `patience`. A refusal by the server itself (a
    /// wrong password, a missing database) is not retried.
    pub fn connect_for(
        &self,
        application_name: &str,
        patience: Duration,
    ) -> Result<Client, StoreError> {
        let start = Instant::now();
        let mut pause = Duration::from_millis(100);
        loop {
            match self.attempt(application_name) {
                Ok(c) => return Ok(c),
                Err((e, permanent)) => {
                    if permanent {
                        return Err(e);
                    }
                    if start.elapsed() + pause > patience {
                        return Err(gave_up(e, start.elapsed()));
                    }
                }
            }
            std::thread::sleep(pause);
            pause = (pause * 2).min(Duration::from_secs(5));
        }
    }
}

/// The last connection error of a server that stayed unreachable, saying that savme gave up.
fn gave_up(e: StoreError, after: Duration) -> StoreError {
    match e {
        StoreError::Database { store, message } => StoreError::Database {
            store,
            message: format!(
                "{message} — gave up reconnecting after {:.0} s (SAVME_RECONNECT_SECONDS sets how long)",
                after.as_secs_f64()
            ),
        },
        other => other,
    }
}

/// `text` with every secret replaced by `***`.
fn redact_in(text: &str, secrets: &[String]) -> String {
    secrets
        .iter()
        .filter(|s| !s.is_empty())
        .fold(text.to_string(), |t, s| t.replace(s.as_str(), "***"))
}

/// Percent-encodes everything but unreserved URL characters.
fn percent_encode(s: &str) -> String {
    s.bytes()
        .map(|b| match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'-' | b'.' | b'_' | b'~' => {
                (b as char).to_string()
            }
            _ => format!("%{b:02X}"),
        })
        .collect()
}

/// `postgresql://user@host:port/dbname` (hosts and ports comma-separated when several).
fn location_of(config: &Config) -> String {
    let hosts: Vec<String> = config
        .get_hosts()
        .iter()
        .enumerate()
        .map(|(i, h)| {
            let host = match h {
                Host::Tcp(name) => name.clone(),
                #[cfg(unix)]
                Host::Unix(path) => path.display().to_string(),
            };
            match config.get_ports().get(i).or(config.get_ports().first()) {
                Some(p) => format!("{host}:{p}"),
                None => format!("{host}:5432"),
            }
        })
        .collect();
    let user = config.get_user().unwrap_or("");
    let db = config.get_dbname().unwrap_or(user);
    format!("postgresql://{user}@{}/{db}", hosts.join(","))
}

/// The password `~/.pgpass` (or `PGPASSFILE`) gives for the configuration's first host, port,
/// database and user (`*` matches anything), as libpq reads it — and, as libpq does, not from a
/// file that others may read (a warning says so).
fn pgpass(config: &Config) -> Option<String> {
    let path = std::env::var_os("PGPASSFILE")
        .map(std::path::PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| Path::new(&h).join(".pgpass")))?;
    if !private(&path) {
        return None;
    }
    let text = std::fs::read_to_string(path).ok()?;
    let host = match config.get_hosts().first()? {
        Host::Tcp(h) => h.clone(),
        #[cfg(unix)]
        Host::Unix(_) => "localhost".into(),
    };
    let port = config
        .get_ports()
        .first()
        .copied()
        .unwrap_or(5432)
        .to_string();
    let user = config.get_user()?.to_string();
    let db = config.get_dbname().map_or(user.clone(), str::to_string);
    let wanted = [host, port, db, user];
    text.lines()
        .filter(|l| !l.trim_start().starts_with('#'))
        .find_map(|line| {
            let fields = split_pgpass(line);
            if fields.len() != 5 {
                return None;
            }
            let matches = fields[..4]
                .iter()
                .zip(&wanted)
                .all(|(f, w)| f == "*" || f == w);
            matches.then(|| fields[4].clone())
        })
}

/// A `.pgpass` line's fields (`:` separates, `\` escapes).
/// Whether the password file `path` is readable by its owner only (libpq's rule: a file that
/// the group or others can read or write is ignored, with a warning). A missing file is
/// "private": there is nothing to warn about.
fn private(path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        if let Ok(meta) = std::fs::metadata(path) {
            let mode = meta.permissions().mode();
            if meta.is_file() && mode & 0o077 != 0 {
                static WARNED: std::sync::Once = std::sync::Once::new();
                WARNED.call_once(|| eprintln!(
                    "savme: WARNING: password file {} has group or world access (mode {:o}); it is ignored, as libpq ignores it. Make it private: chmod 600 {}",
                    path.display(),
                    mode & 0o777,
                    path.display()
                ));
                return false;
            }
        }
    }
    true
}

fn split_pgpass(line: &str) -> Vec<String> {
    let mut fields = vec![String::new()];
    let mut chars = line.chars();
    while let Some(c) = chars.next() {
        match c {
            '\\' => {
                if let (Some(n), Some(f)) = (chars.next(), fields.last_mut()) {
                    f.push(n);
                }
            }
            ':' => fields.push(String::new()),
            c => {
                if let Some(f) = fields.last_mut() {
                    f.push(c)
                }
            }
        }
    }
    fields
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_location_never_shows_the_password() {
        let db = Database::parse("postgres://u:p%40ss@h1:7/d").unwrap();
        assert_eq!(db.location(), "postgresql://u@h1:7/d");
        assert_eq!(db.redact("x p@ss y p%40ss"), "x *** y ***");
        let kv = Database::parse("host=/tmp/s port=5 user=w password=zz dbname=c").unwrap();
        assert_eq!(kv.location(), "postgresql://w@/tmp/s:5/c");
    }

    #[test]
    fn a_bad_url_is_refused_without_repeating_it() {
        let e = Database::parse("postgresql://u:topsecret@h:notaport/d")
            .unwrap_err()
            .to_string();
        assert!(e.contains("not a PostgreSQL connection URL"), "{e}");
        assert!(!e.contains("topsecret"), "{e}");
    }

    #[test]
    fn pgpass_lines_are_split_with_escapes() {
        assert_eq!(
            split_pgpass("h:5432:*:u:a\\:b"),
            ["h", "5432", "*", "u", "a:b"]
        );
    }
}
