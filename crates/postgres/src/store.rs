//! [`PostgresStore`]: a campaign's trial lines, its protocol and (for `savme worker`) its work
//! queue in a PostgreSQL database shared by any number of hosts — `--storage postgresql://…`.
//!
//! - **Schema**: created and migrated by savme in the schema `savme` ([`schema`]): `campaigns`
//!   (name, protocol), `trials` (every line, with each field of a trial line as a column for
//!   SQL), `runs` (the work queue), `schema_version`.
//! - **One coordinator**: opening takes the session-level advisory lock
//!   `pg_try_advisory_lock(schema::LOCK_CLASS, campaign id)`; a second opener is refused at
//!   once, naming the holder's `application_name` (savme puts its pid and host there). The
//!   server releases the lock when the holder's session ends, even after `kill -9`.
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

use crate::locked::Locked;
use crate::Database;
use postgres::{Client, GenericClient, Statement};
use savme_campaign::log::{LogLine, RunLine, TrialLine};
use savme_store::{Loaded, ProtocolKeeper, Record, StoreError, StoredLine, TrialStore, FORMAT};
use serde_json::Value;
use std::sync::{Arc, Mutex, MutexGuard};

/// The longest campaign name.
pub const MAX_NAME: usize = 200;

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
/// savme schema, no such campaign or no protocol yet (a worker waits for its coordinator).
pub fn stored_simulator(
    client: &mut Client,
    name: &str,
) -> Result<Option<String>, postgres::Error> {
    let exists: bool = client
        .query_one("SELECT to_regclass('savme.campaigns') IS NOT NULL", &[])?
        .get(0);
    if !exists {
        return Ok(None);
    }
    Ok(client
        .query_opt(
            "SELECT protocol->>'simulator' FROM savme.campaigns WHERE name = $1",
            &[&name],
        )?
        .and_then(|r| r.get(0)))
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

/// A line's fields as the typed columns of `savme.trials`, read from the typed record (a
/// campaign's [`LogLine`]); any other record (a journal's event) fills none.
#[derive(Default)]
pub(crate) struct Columns {
    stage: Option<String>,
    idx: Option<i64>,
    trial_id: Option<i64>,
    phase: Option<String>,
    budget: Option<f64>,
    scenario: Option<String>,
    phi: Option<String>,
    theta_lf: Option<String>,
    hf: RunColumns,
    lf: RunColumns,
    cost_ratio: Option<f64>,
    outcome: Option<String>,
    credit_fidelity: Option<bool>,
    credit_scenario: Option<bool>,
    error: Option<String>,
}

#[derive(Default)]
struct RunColumns {
    failure: Option<bool>,
    runtime: Option<f64>,
    wall_seconds: Option<f64>,
    work: Option<i64>,
}

impl RunColumns {
    fn of(run: Option<&RunLine>) -> RunColumns {
        run.map_or_else(RunColumns::default, |r| RunColumns {
            failure: Some(r.failure),
            runtime: Some(r.runtime),
            wall_seconds: Some(r.wall_seconds),
            work: r.work.and_then(|w| i64::try_from(w).ok()),
        })
    }
}

/// A value's JSON text (an assignment for a `jsonb` column), or its name (a unit variant such
/// as a phase or an outcome, as the line stores it).
fn json<T: serde::Serialize>(value: &T) -> Option<String> {
    serde_json::to_string(value).ok()
}

fn name<T: serde::Serialize>(value: &T) -> Option<String> {
    match serde_json::to_value(value).ok()? {
        Value::String(s) => Some(s),
        _ => None,
    }
}

impl Columns {
    /// The columns of `record`: a trial line's fields, or none for any other record.
    fn of(record: &dyn Record) -> Columns {
        match record.as_any().downcast_ref::<LogLine>() {
            Some(LogLine::Trial(t)) => Columns::of_trial(t),
            Some(LogLine::Failed(f)) => Columns {
                stage: Some(f.stage.to_string()),
                idx: i64::try_from(f.index).ok(),
                trial_id: i64::try_from(f.id).ok(),
                scenario: Some(f.scenario.clone()),
                phi: json(&f.phi),
                theta_lf: f.theta_lf.as_ref().and_then(json),
                error: Some(f.error.clone()),
                ..Columns::default()
            },
            Some(LogLine::Screen(s)) => Columns {
                stage: Some(s.stage.to_string()),
                idx: i64::try_from(s.index).ok(),
                trial_id: i64::try_from(s.id).ok(),
                budget: s.budget,
                scenario: Some(s.scenario.clone()),
                phi: json(&s.phi),
                theta_lf: s.theta_lf.as_ref().and_then(json),
                hf: RunColumns::of(s.hf.as_ref()),
                lf: RunColumns::of(Some(&s.lf)),
                outcome: s.outcome.as_ref().and_then(name),
                ..Columns::default()
            },
            None => Columns::default(),
        }
    }

    fn of_trial(t: &TrialLine) -> Columns {
        Columns {
            stage: Some(t.stage.to_string()),
            idx: i64::try_from(t.index).ok(),
            trial_id: i64::try_from(t.id).ok(),
            phase: name(&t.phase),
            budget: t.budget,
            scenario: Some(t.scenario.clone()),
            phi: json(&t.phi),
            theta_lf: t.theta_lf.as_ref().and_then(json),
            hf: RunColumns::of(Some(&t.hf)),
            lf: RunColumns::of(t.lf.as_ref()),
            cost_ratio: t.cost_ratio,
            outcome: t.outcome.as_ref().and_then(name),
            credit_fidelity: t.credit.fidelity,
            credit_scenario: t.credit.scenario,
            error: None,
        }
    }
}

pub(crate) const INSERT: &str =
    "INSERT INTO savme.trials (campaign_id, line, v, body, stage, idx, trial_id, phase,
    budget, scenario, phi, theta_lf, hf_failure, hf_runtime, hf_wall_seconds, hf_work,
    lf_failure, lf_runtime, lf_wall_seconds, lf_work, cost_ratio, outcome, credit_fidelity,
    credit_scenario, error)
  VALUES ($1, $2, $3, $4::text::json, $5, $6, $7, $8, $9, $10, $11::text::jsonb,
    $12::text::jsonb, $13, $14, $15, $16, $17, $18, $19, $20, $21, $22, $23, $24, $25)";

/// Inserts `rows` (text, fields) as lines `first..` with the prepared `statement` (in the
/// caller's transaction).
pub(crate) fn insert_lines(
    client: &mut impl GenericClient,
    statement: &Statement,
    campaign: i32,
    first: i64,
    rows: &[(String, Columns)],
) -> Result<(), postgres::Error> {
    for (k, (text, columns)) in rows.iter().enumerate() {
        insert_one(client, statement, campaign, first + k as i64, text, columns)?;
    }
    Ok(())
}

/// Inserts one line.
fn insert_one(
    client: &mut impl GenericClient,
    statement: &Statement,
    campaign: i32,
    line: i64,
    text: &String,
    c: &Columns,
) -> Result<(), postgres::Error> {
    let v = FORMAT as i32;
    client
        .execute(
            statement,
            &[
                &campaign,
                &line,
                &v,
                text,
                &c.stage,
                &c.idx,
                &c.trial_id,
                &c.phase,
                &c.budget,
                &c.scenario,
                &c.phi,
                &c.theta_lf,
                &c.hf.failure,
                &c.hf.runtime,
                &c.hf.wall_seconds,
                &c.hf.work,
                &c.lf.failure,
                &c.lf.runtime,
                &c.lf.wall_seconds,
                &c.lf.work,
                &c.cost_ratio,
                &c.outcome,
                &c.credit_fidelity,
                &c.credit_scenario,
                &c.error,
            ],
        )
        .map(|_| ())
}

impl TrialStore for PostgresStore {
    fn location(&self) -> String {
        self.location.clone()
    }

    fn load(&mut self) -> Result<Loaded, StoreError> {
        let mut locked = self.lock();
        locked.commit(&[])?;
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
