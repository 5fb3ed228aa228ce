//! Where a campaign command keeps its trials when not in its output directory: the
//! `--storage`/`--campaign` flags, connecting to the PostgreSQL database (saying so when it is
//! slow), the resume command a database campaign prints, and the protocol it keeps.

use super::*;
/// Where a campaign is kept when not in its output directory: a PostgreSQL database.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct StorageArgs {
    /// Keep the campaign (protocol, trials, work queue) in a PostgreSQL database instead of
    /// the output directory: postgresql://USER@HOST[:PORT]/DB. The password comes from the
    /// URL, PGPASSWORD or ~/.pgpass, and is never printed. Needs a build with the `postgres`
    /// feature (cargo install --path . --features postgres).
    #[arg(long, value_name = "URL", conflicts_with = "storage_file")]
    pub(super) storage: Option<String>,
    /// Read the --storage URL from the first line of FILE that is neither empty nor a `#`
    /// comment (keeps the password off the command line and out of `ps`).
    #[arg(long, value_name = "FILE")]
    pub(super) storage_file: Option<PathBuf>,
    /// The campaign's name in the database (with --storage).
    #[arg(long, value_name = "NAME")]
    pub(super) campaign: Option<String>,
}

/// A campaign's coordinator (`reproduce`, `run`, `toy`): where the campaign is kept, and
/// whether `savme worker` processes run its simulations. `serve` and `worker` take only
/// [`StorageArgs`], so that they refuse these flags instead of ignoring them.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct CampaignStorageArgs {
    #[command(flatten)]
    pub store: StorageArgs,
    /// Run the HF and LF runs by `savme worker` processes (on any hosts) through the
    /// database's work queue instead of local threads (with --storage). The trials are the
    /// same.
    #[arg(long)]
    pub(super) remote: bool,
    /// With --remote: say so on stderr when no run finished for this many seconds (no worker
    /// started, or the workers stopped), then keep waiting.
    #[arg(long, value_name = "SECONDS", default_value_t = 60.0)]
    pub(super) worker_wait: f64,
    /// With --remote: a database role allowed to work on this campaign (repeatable). It is
    /// granted savme's worker functions and no right on any table: a role that may not write
    /// trials (a worker role) works only on the campaigns it is allowed on, and the server
    /// checks its results (docs/DISTRIBUTED.md).
    #[arg(long, value_name = "ROLE")]
    pub(super) worker_role: Vec<String>,
}

impl StorageArgs {
    /// Whether a database was named (--storage or --storage-file).
    pub fn given(&self) -> bool {
        self.storage.is_some() || self.storage_file.is_some()
    }

    /// The database given, if any (checked: a campaign name goes with it).
    pub fn database(&self) -> Result<Option<(Database, String)>, Failure> {
        let db = match (&self.storage, &self.storage_file) {
            (Some(url), _) => Database::parse(url),
            (None, Some(file)) => Database::from_file(file),
            (None, None) => {
                if self.campaign.is_some() {
                    return Err(usage("--campaign names a campaign in a database: give --storage URL (or --storage-file FILE) too"));
                }
                return Ok(None);
            }
        }
        // A URL or option savme refuses is a refused value, as clap's own (exit status 2).
        .map_err(usage)?;
        let name = self.campaign.clone().ok_or_else(|| {
            usage("--storage needs --campaign NAME (the campaign's name in the database)")
        })?;
        database::check_name(&name).map_err(usage)?;
        Ok(Some((db, name)))
    }

    /// The flags naming this database and campaign, for a command to run again (the URL's
    /// password redacted by `db`).
    pub fn flags(&self, db: &Database) -> String {
        let campaign = self.campaign.as_deref().unwrap_or("NAME");
        match (&self.storage, &self.storage_file) {
            (Some(url), _) => format!("--storage {} --campaign {campaign}", db.redact(url)),
            (None, Some(file)) => {
                format!("--storage-file {} --campaign {campaign}", file.display())
            }
            (None, None) => format!("--campaign {campaign}"),
        }
    }

    /// The flags naming this database and campaign for a process started again on this host,
    /// unquoted: `--storage URL` (its location: never the password) or `--storage-file FILE`,
    /// then `--campaign NAME`.
    #[cfg(feature = "postgres")]
    pub fn restart_words(&self, db: &Database) -> Vec<String> {
        let mut words = match &self.storage_file {
            Some(file) => vec!["--storage-file".into(), file.display().to_string()],
            None => vec!["--storage".into(), database::worker_url(db)],
        };
        words.push("--campaign".into());
        words.push(self.campaign.clone().unwrap_or_else(|| "NAME".into()));
        words
    }

    /// Opens (and locks) the campaign in the database given, if any.
    pub fn open(&self) -> Result<Option<PostgresStore>, Failure> {
        match self.database()? {
            Some((db, name)) => connecting(&db, || PostgresStore::open(&db, &name))
                .map(Some)
                .map_err(|e| Failure::Runtime(e.to_string())),
            None => Ok(None),
        }
    }
}

/// Runs `connect` (which retries an unreachable server for up to
/// [`database::reconnect_for`]), saying on standard error when it has
/// not connected after a few seconds — a wrong host or port would otherwise mean a silent wait.
pub fn connecting<T>(db: &Database, connect: impl FnOnce() -> T) -> T {
    let patience = database::reconnect_for();
    let message = format!(
        "savme: no connection to {} yet; retrying for up to {} s (SAVME_RECONNECT_SECONDS changes that; Ctrl-C stops)",
        db.location(),
        patience.as_secs()
    );
    say_if_slow(Duration::from_secs(3), || eprintln!("{message}"), connect)
}

/// Runs `work`; if it has not returned after `after`, calls `say` (once, from another thread)
/// while it goes on. Returns as soon as `work` does.
pub(super) fn say_if_slow<T>(
    after: Duration,
    say: impl FnOnce() + Send,
    work: impl FnOnce() -> T,
) -> T {
    let (done, finished) = std::sync::mpsc::channel::<()>();
    std::thread::scope(|s| {
        s.spawn(move || {
            if finished.recv_timeout(after) == Err(std::sync::mpsc::RecvTimeoutError::Timeout) {
                say();
            }
        });
        let result = work();
        drop(done); // wakes the timer at once
        result
    })
}

impl CampaignStorageArgs {
    /// Opens (and locks) the campaign in the database given, if any; `--remote` needs one.
    pub fn open(&self) -> Result<Option<PostgresStore>, Failure> {
        if self.remote {
            database::available().map_err(usage)?;
        }
        if self.remote && !self.store.given() {
            return Err(usage("--remote runs trials through a database's work queue: give --storage URL --campaign NAME too"));
        }
        self.store.open()
    }

    /// The work queue of `store`'s campaign, with --remote.
    pub fn remote(&self, store: Option<&PostgresStore>) -> Result<Option<Remote>, Failure> {
        let Some(store) = store.filter(|_| self.remote) else {
            return Ok(None);
        };
        if !(self.worker_wait.is_finite() && self.worker_wait > 0.0) {
            return Err(usage(format!(
                "--worker-wait: {} is not a positive number of seconds",
                self.worker_wait
            )));
        }
        let options = RemoteOptions {
            worker_wait: Duration::from_secs_f64(self.worker_wait),
            resume_command: resume_command(store.database()),
            worker_roles: self.worker_role.clone(),
        };
        Remote::open(store, options).map(Some).map_err(|e| match e {
            CampaignError::Store(savme::campaign::store::StoreError::Database {
                ref store,
                ..
            }) if store == "--worker-role" => usage(e),
            e => Failure::Runtime(e.to_string()),
        })
    }
}

/// The command that resumes this coordinator's campaign: its subcommand with the flags a
/// resumed campaign takes (`--config`, `--out`, `--storage` — its URL without the password —,
/// `--campaign`, `--remote`, `--worker-role`, `--worker-wait`), then `--resume`; shell-quoted.
/// Workers print it when their coordinator is gone. For `savme run`, which rebuilds its
/// protocol from its file and flags, its whole command line (`run::resume_words`).
fn resume_command(db: &Database) -> String {
    // `savme run` rebuilds its protocol from the file and its flags: it repeats them all.
    let given: Vec<String> = std::env::args().skip(1).collect();
    if given.first().is_some_and(|c| c == "run") {
        let words = super::run::resume_words(&given[1..], Some(&database::worker_url(db)), "");
        let quoted: Vec<String> = words
            .iter()
            .map(|w| savme::campaign::shell_quote(w))
            .collect();
        return quoted.join(" ");
    }
    const KEPT: &[&str] = &[
        "--config",
        "--out",
        "--storage",
        "--storage-file",
        "--campaign",
        "--worker-role",
        "--worker-wait",
    ];
    let mut args = std::env::args().skip(1);
    let mut words: Vec<String> = vec!["savme".into()];
    words.extend(args.next());
    while let Some(arg) = args.next() {
        let (flag, inline) = match arg.split_once('=') {
            Some((f, v)) if f.starts_with("--") => (f.to_string(), Some(v.to_string())),
            _ => (arg.clone(), None),
        };
        if flag == "--remote" {
            words.push(flag);
            continue;
        }
        if !KEPT.contains(&flag.as_str()) {
            continue;
        }
        let Some(value) = inline.or_else(|| args.next()) else {
            continue;
        };
        let value = match flag.as_str() {
            "--storage" => database::worker_url(db),
            _ => db.redact(&value),
        };
        words.extend([flag, value]);
    }
    words.push("--resume".into());
    let quoted: Vec<String> = words
        .iter()
        .map(|w| savme::campaign::shell_quote(w))
        .collect();
    quoted.join(" ")
}

/// The protocol a database keeps for campaign `store` (for `--resume`).
pub fn stored_protocol(store: &mut PostgresStore) -> Result<Protocol, String> {
    let location = store.location();
    let value = store
        .load_protocol()
        .map_err(|e| e.to_string())?
        .ok_or_else(|| {
            savme::campaign::CampaignError::NothingToResumeIn {
                store: location.clone(),
            }
            .to_string()
        })?;
    serde_json::from_value(value).map_err(|e| format!("{location}, protocol: {e}"))
}
