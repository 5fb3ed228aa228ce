//! The root package's integration tests in one test binary (`cargo test --test it`): one
//! harness links savme's dependency graph once instead of once per file, and its tests run side
//! by side (the slow external suites — pytest, Ray, highway-env, VerifAI — overlap with the
//! rest). Each former `tests/NAME.rs` is the module `NAME` here, its tests named `NAME::…`:
//!
//! ```sh
//! cargo test --test it                      # all of them
//! cargo test --test it reproduce::          # one file's tests
//! cargo test --test it schemas::campaign_documents_match_their_schemas  # one test
//! ```
//!
//! `postgres` and `distributed` need the `postgres` feature (a real PostgreSQL server; `scripts/test`
//! builds with it); `postgres_feature` checks a build without it.
//!
//! Two stay binaries of their own: `tests/record.rs` (the `rerun` feature's recording tests:
//! built with `--features rerun`, only it needs that feature); `tests/python_package.rs` (in this
//! binary the pytest suite's two SIGINT tests failed in one cold `scripts/test` — the interrupted
//! Python campaigns ran on as if SIGINT were ignored — not understood yet; it passes in its own).
//! (`fuzz` was apart too: its store property was refused "already open in this process" here.
//! The cause was the store's lock: a child forked by another test's thread kept the lock's file
//! open until its exec, and the lock outlived the dropped store there; the lock is now released
//! on drop — `savme_store::StoreLock`, tested in crates/store/src/lock.rs.)

#[path = "../common/mod.rs"]
mod common;

mod build_graph;
mod cli;
mod cost_budget;
#[cfg(feature = "postgres")]
mod distributed;
mod estimate;
mod failures;
mod figures;
mod fmu;
mod fuzz;
mod help_examples;
mod highway_env;
mod install;
mod interop;
mod ladder;
mod openscenario;
mod openscenario_load;
#[cfg(feature = "postgres")]
mod postgres;
mod postgres_feature;
mod readme_numbers;
mod reference_fmu;
mod reliability;
mod repeat;
mod reproduce;
mod schemas;
mod screening;
mod serve;
mod vendor_fmu;
