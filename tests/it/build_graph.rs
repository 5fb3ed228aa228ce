//! `cargo build --workspace`, `cargo install --path .`, the Python wheel and `cargo test` share
//! one build of every crate (issue 39 item 2).
//!
//! The tests' dev-dependencies, and the other workspace members (the wheel's PyO3 macros), turn
//! on features of crates the savme binary uses too; a crate built with other features is a
//! second build of it and of every crate above it (syn, serde, the kernel, the whole workspace,
//! the savme binary). The root `Cargo.toml` turns those features on for savme itself ("Feature
//! alignment"). These tests fail when a dependency change splits the graphs again, naming each
//! crate whose features differ: turn the missing features on there.
use std::collections::{BTreeMap, BTreeSet};
use std::process::Command;

/// Every package of the graph of `packages` (`--workspace` or `-p NAME`) over `edges`
/// (`cargo tree -e`), with its feature sets (a crate built for the host and for the target may
/// have two).
fn features(packages: &[&str], edges: &str) -> Graph {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(&cargo)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["tree", "--locked", "--offline", "-e", edges])
        .args(packages)
        .args(["--prefix", "none", "--format", "{p} [{f}]"])
        .output()
        .unwrap_or_else(|e| panic!("{cargo} tree: {e}"));
    assert!(
        out.status.success(),
        "{cargo} tree {packages:?} -e {edges} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut graph = Graph::new();
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let line = line.trim_end_matches(" (*)");
        let Some((package, features)) = line.rsplit_once(" [") else {
            continue;
        };
        let features = features.trim_end_matches(']').to_string();
        graph
            .entry(package.to_string())
            .or_default()
            .insert(features);
    }
    graph
}

type Graph = BTreeMap<String, BTreeSet<String>>;

/// The crates of `part` whose features differ from `whole`'s (`part`'s packages must all be in
/// `whole`), one line each, the graphs named.
fn split((whole, whole_name): (&Graph, &str), (part, part_name): (&Graph, &str)) -> Vec<String> {
    part.iter()
        .filter(|(package, features)| whole.get(*package) != Some(features))
        .map(|(package, features)| {
            format!(
                "{package}: {part_name} {features:?}, {whole_name} {:?}",
                whole.get(package)
            )
        })
        .collect()
}

const HINT: &str = "a second build of them and of everything above them; turn the features on \
                    in the root Cargo.toml's \"Feature alignment\" dependencies";

#[test]
fn the_tests_build_every_dependency_with_the_builds_features() {
    let build = features(&["--workspace"], "normal,build");
    let tests = features(&["--workspace"], "normal,build,dev");
    assert!(
        build.len() > 100,
        "too few packages in the build graph: {build:?}"
    );
    // Every crate of the build is in the tests' graph, with the same features.
    let split = split((&tests, "the tests"), (&build, "the build"));
    assert!(
        split.is_empty(),
        "the tests' dev-dependencies build these crates with other features than \
         `cargo build --workspace` ({HINT}):\n{}",
        split.join("\n")
    );
}

#[test]
fn cargo_install_and_the_wheel_build_every_dependency_with_the_builds_features() {
    let build = features(&["--workspace"], "normal,build");
    for (package, what) in [
        ("savme", "`cargo install --path .`"),
        ("savme-py", "the Python wheel (maturin)"),
    ] {
        let alone = features(&["-p", package], "normal,build");
        assert!(
            alone.len() > 100,
            "too few packages in {package}'s graph: {alone:?}"
        );
        let mut split = split((&build, "the workspace build"), (&alone, package));
        // `cargo install --path .` installs the default build (no `postgres`, which the wheel
        // and scripts/test turn on): savme itself is built again, nothing below it.
        if package == "savme" {
            split.retain(|line| !line.starts_with("savme v"));
        }
        assert!(
            split.is_empty(),
            "{what} builds these crates with other features than `cargo build --workspace` \
             ({HINT}):\n{}",
            split.join("\n")
        );
    }
}
