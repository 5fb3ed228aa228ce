//! [`Session`]: a connection that survives a server restart — every statement goes through
//! [`Session::run`], which reconnects with backoff (and listens again) when the connection is
//! lost, then runs the statement once more. Statements run often (the queue's claim, finish,
//! submit, read) are prepared once per connection ([`Conn::prepared`]): an unprepared
//! statement costs the client two round trips to the server (parse, then execute), a prepared
//! one one.

use super::{application_name, connection_lost, queue, Database};
use postgres::fallible_iterator::FallibleIterator;
use postgres::{Client, Statement};
use savme_store::StoreError;
use std::collections::HashMap;
use std::time::Duration;

/// The connection [`Session::run`] hands its operation: the client (by `Deref`), and the
/// statements prepared on it.
pub struct Conn<'a> {
    client: &'a mut Client,
    prepared: &'a mut HashMap<&'static str, Statement>,
}

impl Conn<'_> {
    /// `sql` prepared on this connection (the first time it is asked for, once).
    pub fn prepared(&mut self, sql: &'static str) -> Result<Statement, postgres::Error> {
        if let Some(s) = self.prepared.get(sql) {
            return Ok(s.clone());
        }
        let s = self.client.prepare(sql)?;
        self.prepared.insert(sql, s.clone());
        Ok(s)
    }
}

impl std::ops::Deref for Conn<'_> {
    type Target = Client;
    fn deref(&self) -> &Client {
        self.client
    }
}

impl std::ops::DerefMut for Conn<'_> {
    fn deref_mut(&mut self) -> &mut Client {
        self.client
    }
}

/// A reconnecting connection (the coordinator's queue connection, each worker thread's).
pub struct Session {
    db: Database,
    role: String,
    client: Client,
    channels: Vec<String>,
    /// Session settings (`SET …`), made again after every reconnect.
    settings: Vec<String>,
    /// Statements prepared on `client` (forgotten when it is replaced).
    prepared: HashMap<&'static str, Statement>,
    /// How many times the connection was replaced.
    reconnects: u64,
}

impl Session {
    /// Connects (with backoff) as savme `role` (shown in `pg_stat_activity`).
    pub fn connect(db: &Database, role: &str) -> Result<Session, StoreError> {
        let client = db.connect(&application_name(role))?;
        Ok(Session {
            db: db.clone(),
            role: role.into(),
            client,
            channels: Vec::new(),
            settings: Vec::new(),
            prepared: HashMap::new(),
            reconnects: 0,
        })
    }

    /// The database.
    pub fn database(&self) -> &Database {
        &self.db
    }

    /// How many times the connection was lost and made again.
    pub fn reconnects(&self) -> u64 {
        self.reconnects
    }

    /// Listens on `channel` (again after every reconnect).
    pub fn listen(&mut self, channel: &str) -> Result<(), StoreError> {
        self.channels.push(channel.into());
        let channel = channel.to_string();
        self.run(|c| queue::listen(&mut **c, &channel))
    }

    /// Stops listening on `channel`.
    pub fn unlisten(&mut self, channel: &str) -> Result<(), StoreError> {
        self.channels.retain(|c| c != channel);
        let sql = format!("UNLISTEN \"{channel}\"");
        self.run(|c| c.batch_execute(&sql))
    }

    /// Makes session setting `sql` (e.g. `SET synchronous_commit = off`), again after every
    /// reconnect.
    pub fn set(&mut self, sql: &str) -> Result<(), StoreError> {
        self.settings.push(sql.into());
        let sql = sql.to_string();
        self.run(|c| c.batch_execute(&sql))
    }

    /// Runs `op`; when the connection is lost, reconnects with backoff and runs it again (up
    /// to five times). An error names the database, never its password.
    pub fn run<T>(
        &mut self,
        mut op: impl FnMut(&mut Conn<'_>) -> Result<T, postgres::Error>,
    ) -> Result<T, StoreError> {
        let mut tries = 0;
        loop {
            let mut conn = Conn {
                client: &mut self.client,
                prepared: &mut self.prepared,
            };
            match op(&mut conn) {
                Ok(v) => return Ok(v),
                Err(e) if tries < 5 && connection_lost(&self.client, &e) => {
                    tries += 1;
                    eprintln!(
                        "savme {}: {}: connection lost ({}); reconnecting",
                        self.role,
                        self.db.location(),
                        self.db.redact(&e.to_string())
                    );
                    self.reconnect()?;
                }
                Err(e) => return Err(self.db.error(self.db.location(), &e)),
            }
        }
    }

    fn reconnect(&mut self) -> Result<(), StoreError> {
        self.client = self.db.connect(&application_name(&self.role))?;
        self.prepared.clear();
        self.reconnects += 1;
        for sql in self.settings.clone() {
            self.client
                .batch_execute(&sql)
                .map_err(|e| self.db.error(self.db.location(), &e))?;
        }
        for channel in self.channels.clone() {
            queue::listen(&mut self.client, &channel)
                .map_err(|e| self.db.error(self.db.location(), &e))?;
        }
        Ok(())
    }

    /// Waits up to `timeout` for a notification on the channels listened to; true if one
    /// came (all pending ones are consumed). A lost connection is re-established (and
    /// reported as a notification, since one may have been missed).
    pub fn wait(&mut self, timeout: Duration) -> Result<bool, StoreError> {
        if self.client.is_closed() {
            self.run(|c| c.batch_execute("SELECT 1"))?;
            return Ok(true);
        }
        let first = self.client.notifications().timeout_iter(timeout).next();
        match first {
            Ok(None) => Ok(false),
            Ok(Some(_)) => {
                let mut n = self.client.notifications();
                let mut pending = n.iter();
                while let Ok(Some(_)) = pending.next() {}
                Ok(true)
            }
            Err(e) => {
                if connection_lost(&self.client, &e) {
                    self.run(|c| c.batch_execute("SELECT 1"))?;
                    Ok(true)
                } else {
                    Err(self.db.error(self.db.location(), &e))
                }
            }
        }
    }
}
