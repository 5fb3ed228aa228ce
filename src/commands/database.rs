//! The PostgreSQL pieces the commands use (`--storage`, `--remote`, `savme worker`).
//!
//! With the `postgres` feature they are savme-postgres's. Without it (the default build: the
//! main job never uses a database, and the PostgreSQL client with its TLS stack and tokio was
//! about a quarter of a cold release build) they are stand-ins with no values: every way of
//! making a [`Database`] fails with [`MISSING`], so no store, work queue or worker can exist,
//! and the commands that take them need no `cfg` of their own. `savme worker` refuses with the
//! same message ([`available`]).

#[cfg(feature = "postgres")]
pub use savme::postgres::{
    check_name, reconnect_for, worker_url, Database, PostgresStore, Remote, RemoteOptions,
};

#[cfg(not(feature = "postgres"))]
pub use absent::{
    check_name, reconnect_for, worker_url, Database, PostgresStore, Remote, RemoteOptions,
};

/// What a build without the `postgres` feature answers to every PostgreSQL flag and command
/// (a usage error: exit status 2).
pub const MISSING: &str = "this savme was built without PostgreSQL support (the `postgres` \
     feature), which --storage, --storage-file, --remote and `savme worker` need: build it with \
     `cargo install --path . --features postgres` (or `cargo build --release --features postgres`)";

/// `Ok` if this build has the `postgres` feature, else [`MISSING`].
pub fn available() -> Result<(), &'static str> {
    if cfg!(feature = "postgres") {
        Ok(())
    } else {
        Err(MISSING)
    }
}

/// Where a failures or estimate command reads the campaign of `db`.
pub fn place(db: Database, name: String) -> savme::compose::Place {
    #[cfg(feature = "postgres")]
    return savme::compose::Place::Database(Box::new(db), name);
    #[cfg(not(feature = "postgres"))]
    {
        let _ = name;
        match db {}
    }
}

/// The stand-ins of a build without the `postgres` feature: uninhabited types (a value of one
/// cannot exist, so their methods are never called) with savme-postgres's signatures.
#[cfg(not(feature = "postgres"))]
mod absent {
    use super::MISSING;
    use savme::campaign::executor::{Done, RemoteRunner, Runner, Task};
    use savme::campaign::store::{Loaded, ProtocolKeeper, Record, StoreError, TrialStore};
    use savme::campaign::CampaignError;
    use serde_json::Value;
    use std::path::Path;
    use std::time::Duration;

    /// A database URL this build cannot use: displays [`MISSING`].
    #[derive(Debug, thiserror::Error)]
    #[error("{MISSING}")]
    pub struct Missing;

    /// No database: [`Database::parse`] and [`Database::from_file`] always fail.
    pub enum Database {}

    impl Database {
        pub fn parse(_url: &str) -> Result<Database, Missing> {
            Err(Missing)
        }

        pub fn from_file(_path: &Path) -> Result<Database, Missing> {
            Err(Missing)
        }

        pub fn location(&self) -> &str {
            match *self {}
        }

        pub fn redact(&self, _text: &str) -> String {
            match *self {}
        }
    }

    pub fn check_name(_name: &str) -> Result<(), Missing> {
        Err(Missing)
    }

    pub fn reconnect_for() -> Duration {
        Duration::ZERO
    }

    pub fn worker_url(db: &Database) -> String {
        match *db {}
    }

    /// No campaign in a database.
    #[derive(Debug)]
    pub enum PostgresStore {}

    impl PostgresStore {
        pub fn open(db: &Database, _name: &str) -> Result<PostgresStore, Missing> {
            match *db {}
        }

        pub fn database(&self) -> &Database {
            match *self {}
        }
    }

    impl TrialStore for PostgresStore {
        fn location(&self) -> String {
            match *self {}
        }

        fn load(&mut self) -> Result<Loaded, StoreError> {
            match *self {}
        }

        fn append_all(&mut self, _records: &[&dyn Record]) -> Result<(), StoreError> {
            match *self {}
        }
    }

    impl ProtocolKeeper for PostgresStore {
        fn load_protocol(&mut self) -> Result<Option<Value>, StoreError> {
            match *self {}
        }

        fn save_protocol(&mut self, _protocol: &Value) -> Result<(), StoreError> {
            match *self {}
        }
    }

    /// The coordinator's options of a work queue (made by `CampaignStorageArgs::remote` only
    /// when it has a store, which never exists here: nothing reads them).
    #[allow(dead_code)]
    pub struct RemoteOptions {
        pub worker_wait: Duration,
        pub resume_command: String,
        pub worker_roles: Vec<String>,
    }

    /// No work queue.
    pub enum Remote {}

    impl Remote {
        pub fn open(
            store: &PostgresStore,
            _options: RemoteOptions,
        ) -> Result<Remote, CampaignError> {
            match *store {}
        }
    }

    impl Runner for Remote {
        fn submit(&mut self, _task: Task) -> Result<(), CampaignError> {
            match *self {}
        }

        fn next_done(&mut self) -> Result<Done, CampaignError> {
            match *self {}
        }
    }

    impl RemoteRunner for Remote {
        fn finish(self: Box<Self>) -> Result<(), CampaignError> {
            match *self {}
        }
    }
}
