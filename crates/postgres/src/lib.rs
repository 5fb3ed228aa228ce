//! # savme-postgres
//!
//! A savme campaign kept in PostgreSQL (`--storage postgresql://…`): the trial store
//! ([`PostgresStore`]), the connection and its TLS ([`Database`], [`tls`]), the work queue
//! ([`queue`]) through which the coordinator's [`Remote`] runner hands HF/LF runs to
//! [`worker`] processes on any host, and the schema they share ([`schema`]).
//!
//! Everything here implements a seam of `savme-campaign` or `savme-store`: [`PostgresStore`]
//! is a [`TrialStore`](savme_store::TrialStore), [`Remote`] a
//! [`Runner`](savme_campaign::executor::Runner). Nothing above this crate writes SQL.
#![warn(missing_docs)]

mod campaign;
mod command;
mod connect;
mod lines;
mod locked;
pub mod queue;
mod remote;
pub mod schema;
mod session;
mod source;
mod store;
pub mod tls;
pub mod worker;

pub use campaign::{
    application_name, campaign_id, check_name, connection_lost, find_campaign, host_name,
    stored_simulator, MAX_NAME,
};
pub use command::{shell_quote, worker_command, worker_url};
pub use connect::{reconnect_for, Database, RECONNECT_FOR};
pub use remote::{Remote, RemoteOptions, HEARTBEAT};
pub use session::{Conn, Session};
pub use source::PostgresSource;
pub use store::{read_campaign, PostgresStore};
