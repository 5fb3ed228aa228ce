//! `cargo build` and `cargo test` share one build of every crate (issue 39 item 2).
//!
//! The tests' dev-dependencies turn on features of crates the build uses too; a crate built with
//! other features is a second build of it and of every crate above it (serde, the kernel, the
//! whole workspace, the savme binary). The root `Cargo.toml` turns those features on for the
//! build as well ("Feature alignment"). This test fails when a dependency change splits the two
//! graphs again, naming each crate whose features differ: turn the missing features on there.
use std::collections::{BTreeMap, BTreeSet};
use std::process::Command;

/// Every package of the workspace's graph over `edges` (`cargo tree -e`), with its feature
/// sets (a crate built for the host and for the target may have two).
fn features(edges: &str) -> BTreeMap<String, BTreeSet<String>> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(&cargo)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["tree", "--workspace", "--locked", "--offline", "-e", edges])
        .args(["--prefix", "none", "--format", "{p} [{f}]"])
        .output()
        .unwrap_or_else(|e| panic!("{cargo} tree: {e}"));
    assert!(
        out.status.success(),
        "{cargo} tree -e {edges} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
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

#[test]
fn the_tests_build_every_dependency_with_the_builds_features() {
    let build = features("normal,build");
    let tests = features("normal,build,dev");
    assert!(
        build.len() > 100,
        "too few packages in the build graph: {build:?}"
    );
    let split: Vec<String> = build
        .iter()
        .filter(|(package, features)| tests.get(*package) != Some(features))
        .map(|(package, features)| {
            format!(
                "{package}: build {features:?}, tests {:?}",
                tests.get(package)
            )
        })
        .collect();
    assert!(
        split.is_empty(),
        "the tests' dev-dependencies build these crates with other features than `cargo build` \
         (a second build of them and of everything above them; turn the features on in the \
         root Cargo.toml's \"Feature alignment\" dependencies):\n{}",
        split.join("\n")
    );
}
