//! [`Locked`]: the coordinator's one connection to its campaign — it holds the campaign's
//! coordinator lock (its row of `savme.coordinators`, naming this server session), knows the last stored line, and commits **batches**: the trial lines told
//! since the last commit together with the runs asked for meanwhile, in one transaction.
//!
//! A [`PostgresStore`](crate::PostgresStore) on its own commits each append at once. Once a
//! [`Remote`](crate::Remote) shares the connection ([`Locked::defer`]), appends are kept in
//! memory and the Remote commits them with its queue update when it next waits for a finished
//! run — one durable commit per wake-up instead of one per trial. Crash safety: the batch is
//! one transaction (all its lines and runs, or none); a coordinator killed before the commit
//! loses only trials whose runs are finished in `savme.runs`, and `--resume` asks the same
//! trials again and finds those results there (the same trials, not run again).

use crate::lines::{insert_lines, Columns};
use crate::{application_name, campaign_id, connection_lost, queue, schema, Database};
use postgres::{Client, Statement};
use savme_campaign::executor::Task;
use savme_store::StoreError;
use std::collections::HashMap;

/// The coordinator's locked connection (see the module docs).
pub(crate) struct Locked {
    pub(crate) db: Database,
    pub(crate) name: String,
    pub(crate) location: String,
    pub(crate) campaign: i32,
    client: Client,
    /// Lines stored so far (the last line number committed).
    lines: i64,
    /// Statements prepared on `client` (forgotten when it is replaced).
    prepared: HashMap<&'static str, Statement>,
    /// Lines appended but not committed yet (only while deferred).
    pending: Vec<(String, Columns)>,
    /// Whether appends wait for the next batch ([`Locked::commit`]).
    deferred: bool,
    /// The connection was replaced since the last commit (the server may have restarted and
    /// lost workers' finishes that were not yet on disk: the next commit writes back the
    /// results the coordinator read since its last commit).
    reconnected: bool,
}

impl Locked {
    /// Connects (with backoff), migrates the schema, creates the campaign row if missing and
    /// takes its lock.
    pub(crate) fn open(db: &Database, name: &str) -> Result<Locked, StoreError> {
        let client = db.connect(&application_name("coordinator"))?;
        let mut locked = Locked {
            db: db.clone(),
            name: name.into(),
            location: format!("{}, campaign {name:?}", db.location()),
            campaign: 0,
            client,
            lines: 0,
            prepared: HashMap::new(),
            pending: Vec::new(),
            deferred: false,
            reconnected: false,
        };
        locked.attach()?;
        // Until a Remote says otherwise, this coordinator runs its trials itself (its
        // campaign's workers say so).
        let campaign = locked.campaign;
        locked.retrying(|c, _, _, _| queue::start_local(c, campaign))?;
        Ok(locked)
    }

    /// From now on, appends wait for the next [`Locked::commit`].
    pub(crate) fn defer(&mut self) {
        self.deferred = true;
    }

    /// On a (new) connection: the schema, the campaign row, the lock, the line count.
    fn attach(&mut self) -> Result<(), StoreError> {
        let err = |s: &Self, e: postgres::Error| s.db.error(&s.location, &e);
        match schema::migrate(&mut self.client) {
            Ok(()) => {}
            Err(schema::SchemaError::Db(e)) => return Err(err(self, e)),
            Err(schema::SchemaError::TooNew(v)) => {
                return Err(StoreError::Database {
                    store: self.location.clone(),
                    message: format!(
                        "the database's savme schema is version {v}, newer than this savme's ({}); use a newer savme",
                        schema::VERSION
                    ),
                })
            }
        }
        self.campaign = campaign_id(&mut self.client, &self.name).map_err(|e| err(self, e))?;
        let locked: bool = self
            .client
            .query_one(
                "SELECT coalesce(savme.take_lock($1), false)",
                &[&self.campaign],
            )
            .map_err(|e| err(self, e))?
            .get(0);
        if !locked {
            return Err(StoreError::Held {
                store: self.location.clone(),
                holder: self.holder(),
            });
        }
        self.lines = self.stored().map_err(|e| err(self, e))?;
        Ok(())
    }

    /// The last line number in the table.
    fn stored(&mut self) -> Result<i64, postgres::Error> {
        Ok(self
            .client
            .query_one(
                "SELECT coalesce(max(line), 0) FROM savme.trials WHERE campaign_id = $1",
                &[&self.campaign],
            )?
            .get(0))
    }

    /// Who holds the campaign's lock, as the server identifies its session: the role it
    /// logged in as, its backend pid, its address, and the name the client gave
    /// (`application_name`: savme puts its pid and host there).
    fn holder(&mut self) -> String {
        let row = self.client.query_opt(
            "SELECT application, client, usename::text, pid FROM savme.coordinators
              WHERE campaign_id = $1",
            &[&self.campaign],
        );
        match row {
            Ok(Some(r)) => {
                let app: Option<String> = r.get(0);
                let addr: Option<String> = r.get(1);
                let (user, pid): (String, i32) = (r.get(2), r.get(3));
                let session = format!(
                    "connected from {} as role {user}, server process {pid}",
                    addr.unwrap_or_default()
                );
                match app.filter(|a| !a.is_empty()) {
                    Some(app) => format!("{app}, {session}"),
                    None => format!("a session not started by savme, {session}"),
                }
            }
            _ => "a process this role may not see".into(),
        }
    }

    /// Runs `op` on the connection; when the connection is lost, reconnects (with backoff,
    /// taking the lock again) and runs it once more, up to five times. `op` is told whether
    /// it is a retry (its earlier attempt may have committed before the connection broke).
    pub(crate) fn retrying<T>(
        &mut self,
        mut op: impl FnMut(
            &mut Client,
            &mut HashMap<&'static str, Statement>,
            i32,
            bool,
        ) -> Result<T, postgres::Error>,
    ) -> Result<T, StoreError> {
        let mut tries = 0;
        loop {
            match op(
                &mut self.client,
                &mut self.prepared,
                self.campaign,
                tries > 0,
            ) {
                Ok(v) => return Ok(v),
                Err(e) if tries < 5 && connection_lost(&self.client, &e) => {
                    tries += 1;
                    eprintln!(
                        "savme: {}: connection lost ({}); reconnecting",
                        self.location,
                        self.db.redact(&e.to_string())
                    );
                    self.client = self.db.connect(&application_name("coordinator"))?;
                    self.prepared.clear();
                    self.reconnected = true;
                    self.attach()?;
                }
                Err(e) => return Err(self.db.error(&self.location, &e)),
            }
        }
    }

    /// Whether lines wait for the next commit.
    pub(crate) fn has_pending(&self) -> bool {
        !self.pending.is_empty()
    }

    /// Appends lines: at once (one transaction), or, deferred, at the next commit.
    pub(crate) fn append(&mut self, rows: Vec<(String, Columns)>) -> Result<(), StoreError> {
        self.pending.extend(rows);
        if self.deferred {
            return Ok(());
        }
        self.commit(&[], &[]).map(|_| ())
    }

    /// Commits the pending lines and queues `tasks` (their row ids returned, in order) in one
    /// transaction. After a reconnect, lines that reached the table are not inserted again
    /// (this connection holds the lock: nobody else writes them); the queue upsert is
    /// idempotent; and `told` — the results read since the last commit, which the told lines
    /// were made from — is written back into rows that lost them (a crashed server loses a
    /// worker's finish that was not on disk yet, although the coordinator read it).
    pub(crate) fn commit(
        &mut self,
        tasks: &[Task],
        told: &[queue::RowResult],
    ) -> Result<Vec<i64>, StoreError> {
        if self.pending.is_empty() && tasks.is_empty() {
            return Ok(Vec::new());
        }
        let rows = std::mem::take(&mut self.pending);
        let first = self.lines + 1;
        let last = self.lines + rows.len() as i64;
        let mut restored = 0;
        let lost = self.reconnected;
        let result = self.retrying(|client, prepared, campaign, retry| {
            let mut tx = client.transaction()?;
            let stored: i64 = match retry && !rows.is_empty() {
                true => tx
                    .query_one(
                        "SELECT coalesce(max(line), 0) FROM savme.trials WHERE campaign_id = $1",
                        &[&campaign],
                    )?
                    .get(0),
                false => first - 1,
            };
            if stored < last {
                let statement = prepare(&mut tx, prepared, crate::lines::INSERT)?;
                let skip = (stored - first + 1).max(0) as usize;
                insert_lines(&mut tx, &statement, campaign, stored + 1, &rows[skip..])?;
            }
            let ids = match tasks.is_empty() {
                true => Vec::new(),
                false => {
                    let statement = prepare(&mut tx, prepared, queue::SUBMIT)?;
                    queue::submit(&mut tx, &statement, campaign, tasks)?
                }
            };
            if (retry || lost) && !told.is_empty() {
                restored = queue::write_back(&mut tx, campaign, told)?;
            }
            tx.commit()?;
            Ok(ids)
        });
        match result {
            Ok(ids) => {
                self.lines = last;
                self.reconnected = false;
                if restored > 0 {
                    eprintln!(
                        "savme: {}: the database lost {restored} result(s) it had committed (a crash before they reached its disk); the coordinator had told their trials and wrote them back",
                        self.location
                    );
                }
                Ok(ids)
            }
            Err(e) => {
                // Not committed: keep the lines, so that a later commit (or the drop) stores
                // them.
                self.pending = rows;
                Err(e)
            }
        }
    }
}

/// `sql` prepared on the transaction's connection (once per connection).
fn prepare(
    tx: &mut postgres::Transaction<'_>,
    prepared: &mut HashMap<&'static str, Statement>,
    sql: &'static str,
) -> Result<Statement, postgres::Error> {
    if let Some(s) = prepared.get(sql) {
        return Ok(s.clone());
    }
    let s = tx.prepare(sql)?;
    prepared.insert(sql, s.clone());
    Ok(s)
}

impl Drop for Locked {
    /// Trials told and not committed (the campaign stopped with an error, or was interrupted)
    /// are stored before the lock goes: every told trial is kept.
    fn drop(&mut self) {
        if self.pending.is_empty() {
            return;
        }
        let n = self.pending.len();
        if let Err(e) = self.commit(&[], &[]) {
            eprintln!(
                "savme: {}: {n} told trial(s) could not be stored ({e}); --resume runs them again",
                self.location
            );
        }
    }
}
