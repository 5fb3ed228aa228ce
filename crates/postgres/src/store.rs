//! [`PostgresStore`]: a campaign's trial lines, its protocol and (for `savme worker`) its work
//! queue in a PostgreSQL database shared by any number of hosts — `--storage postgresql://…`.
//!
//! - **Schema**: created and migrated by savme in the schema `savme` ([`schema`]): `campaigns`
//!   (name, protocol), `trials` (every line, with each field of a trial line as a column for
//!   SQL), `runs` (the work queue), `schema_version`.
//! - **One coordinator**: opening takes the campaign's coordinator lock — its row of
//!   `savme.coordinators`, naming this server session (`savme.take_lock`); a second opener is
//!   refused at once, naming the holder as the server identifies its session (its role, address
//!   and server process, and the `application_name` where savme puts its pid and host). The lock
//!   is held while the session lives, so it goes with it, even after `kill -9`; a worker role,
//!   which may not write the table, can neither take nor fake it.
//! - **One connection**: the lock belongs to a session, so the store keeps exactly one
//!   connection for its life rather than a pool (a pooled connection could be another
//!   session). If it breaks (the server restarts), the store reconnects with backoff, takes
//!   the lock again, and finishes the write it was doing exactly once (line numbers are the
//!   primary key, and it checks what reached the table).
//!
//! ```no_run
//! use savme_postgres::{Database, PostgresStore};
//! use savme_store::TrialStore;
//! let db = Database::parse("postgresql://savme@db.example/safety")?;
//! let mut store = PostgresStore::open(&db, "night-run-1")?;
//! store.append(&serde_json::json!({"stage": "train@0.3", "index": 0}))?;
//! assert_eq!(store.load()?.lines.len(), 1);
//! # Ok::<(), savme_store::StoreError>(())
//! ```

use crate::campaign::{application_name, check_name, find_campaign};
use crate::lines::Columns;
use crate::locked::Locked;
use crate::Database;
use savme_store::{Loaded, ProtocolKeeper, Record, StoreError, StoredLine, TrialStore, FORMAT};
use serde_json::Value;
use std::sync::{Arc, Mutex, MutexGuard};

/// A campaign in a PostgreSQL database, held exclusively (see the module docs).
pub struct PostgresStore {
    db: Database,
    name: String,
    campaign: i32,
    location: String,
    /// The connection holding the lock (shared with a [`Remote`](crate::Remote)).
    locked: Arc<Mutex<Locked>>,
}

impl std::fmt::Debug for PostgresStore {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PostgresStore")
            .field("location", &self.location)
            .finish_non_exhaustive()
    }
}

impl PostgresStore {
    /// Connects to `db` (with backoff), creates or migrates savme's schema, creates campaign
    /// `name` if it is new, and takes its coordinator lock — or fails with
    /// [`StoreError::Held`] naming the process that holds it.
    pub fn open(db: &Database, name: &str) -> Result<PostgresStore, StoreError> {
        check_name(name)?;
        let locked = Locked::open(db, name)?;
        Ok(PostgresStore {
            location: locked.location.clone(),
            db: db.clone(),
            name: name.into(),
            campaign: locked.campaign,
            locked: Arc::new(Mutex::new(locked)),
        })
    }

    /// The campaign's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The campaign's id in `savme.campaigns`.
    pub fn campaign_id(&self) -> i32 {
        self.campaign
    }

    /// The database.
    pub fn database(&self) -> &Database {
        &self.db
    }

    /// The locked connection, shared with the campaign's [`Remote`](crate::Remote), which
    /// commits this store's lines with its queue updates ([`Locked`]).
    pub(crate) fn shared(&self) -> Arc<Mutex<Locked>> {
        self.locked.clone()
    }

    fn lock(&self) -> MutexGuard<'_, Locked> {
        self.locked.lock().unwrap_or_else(|p| p.into_inner())
    }
}

const SELECT_LINES: &str =
    "SELECT line, v, body::text FROM savme.trials WHERE campaign_id = $1 ORDER BY line";
const SELECT_PROTOCOL: &str = "SELECT protocol::text FROM savme.campaigns WHERE id = $1";

/// The rows of [`SELECT_LINES`] as stored lines; a line of another format version, or not a
/// JSON object, is an error naming it.
fn lines_of(location: &str, rows: &[postgres::Row]) -> Result<Loaded, StoreError> {
    let mut loaded = Loaded::default();
    for row in rows {
        let line: i64 = row.get(0);
        let v: i32 = row.get(1);
        let body: String = row.get(2);
        let bad = |message: String| StoreError::BadLine {
            store: location.to_string(),
            line: line as u64,
            message,
        };
        if v as u64 != FORMAT {
            return Err(bad(format!(
                "store format version {v} is not supported (this savme reads version {FORMAT})"
            )));
        }
        let value: Value =
            serde_json::from_str(&body).map_err(|e| bad(format!("not JSON: {e}")))?;
        if !value.is_object() {
            return Err(bad("not a JSON object".into()));
        }
        loaded.lines.push(StoredLine {
            line: line as u64,
            value,
        });
    }
    Ok(loaded)
}

/// The stored protocol's text as JSON (None: not saved yet).
fn protocol_of(location: &str, text: Option<String>) -> Result<Option<Value>, StoreError> {
    text.map(|t| {
        serde_json::from_str(&t).map_err(|e| StoreError::BadLine {
            store: format!("{location} protocol"),
            line: e.line() as u64,
            message: e.to_string(),
        })
    })
    .transpose()
}

/// Campaign `name`'s protocol (None: not saved yet) and trial lines, read **without** its
/// coordinator lock and without changing the database (no schema, no campaign row is
/// created): a campaign still running can be read. A database without savme's schema, or
/// without the campaign, is an error naming it.
pub fn read_campaign(db: &Database, name: &str) -> Result<(Option<Value>, Loaded), StoreError> {
    check_name(name)?;
    let location = format!("{}, campaign {name:?}", db.location());
    let mut client = db.connect(&application_name("reader"))?;
    let err = |e: postgres::Error| db.error(&location, &e);
    let has_schema: bool = client
        .query_one("SELECT to_regclass('savme.campaigns') IS NOT NULL", &[])
        .map_err(err)?
        .get(0);
    let id = match has_schema {
        true => find_campaign(&mut client, name).map_err(err)?,
        false => None,
    };
    let Some(id) = id else {
        return Err(StoreError::Database {
            store: location,
            message: "no such campaign in this database (none was started under this name)".into(),
        });
    };
    let text: Option<String> = client
        .query_one(SELECT_PROTOCOL, &[&id])
        .map_err(err)?
        .get(0);
    let rows = client.query(SELECT_LINES, &[&id]).map_err(err)?;
    Ok((protocol_of(&location, text)?, lines_of(&location, &rows)?))
}

impl TrialStore for PostgresStore {
    fn location(&self) -> String {
        self.location.clone()
    }

    fn load(&mut self) -> Result<Loaded, StoreError> {
        let mut locked = self.lock();
        locked.commit(&[], &[])?;
        let rows = locked.retrying(|c, _, id, _| c.query(SELECT_LINES, &[&id]))?;
        lines_of(&self.location, &rows)
    }

    /// Stores the lines in one transaction — at once, or, in a campaign whose runs go through
    /// the work queue, at the coordinator's next wait, in one transaction with its queue
    /// update (`Locked`).
    fn append_all(&mut self, records: &[&dyn Record]) -> Result<(), StoreError> {
        let mut rows = Vec::with_capacity(records.len());
        for record in records {
            let object = record.object().map_err(|message| StoreError::BadLine {
                store: self.location.clone(),
                line: 0,
                message,
            })?;
            let mut body = String::with_capacity(object.len() + 2);
            body.push('{');
            body.push_str(&String::from_utf8_lossy(&object));
            body.push('}');
            rows.push((body, Columns::of(*record)));
        }
        self.lock().append(rows)
    }

    fn protocol_keeper(&mut self) -> Option<&mut dyn ProtocolKeeper> {
        Some(self)
    }
}

/// The protocol lives in the campaign's row (`savme.campaigns.protocol`).
impl ProtocolKeeper for PostgresStore {
    fn load_protocol(&mut self) -> Result<Option<Value>, StoreError> {
        let text: Option<String> = self
            .lock()
            .retrying(|c, _, id, _| Ok(c.query_one(SELECT_PROTOCOL, &[&id])?.get(0)))?;
        protocol_of(&self.location, text)
    }

    fn save_protocol(&mut self, protocol: &Value) -> Result<(), StoreError> {
        let text = protocol.to_string();
        self.lock().retrying(|c, _, id, _| {
            c.execute(
                "UPDATE savme.campaigns SET protocol = $2::text::json WHERE id = $1",
                &[&id, &text],
            )
            .map(|_| ())
        })
    }
}
