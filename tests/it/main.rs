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
//! `tests/record.rs` (the `rerun` feature's recording tests) stays a binary of its own: it is
//! built with `--features rerun`, and only it needs that feature.

#[path = "../common/mod.rs"]
mod common;

mod build_graph;
mod cli;
mod cost_budget;
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
mod postgres;
mod python_package;
mod readme_numbers;
mod reference_fmu;
mod reliability;
mod repeat;
mod reproduce;
mod schemas;
mod screening;
mod serve;
mod vendor_fmu;
