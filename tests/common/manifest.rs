//! The inputs hash `scripts/figures` and `scripts/numbers` record for a generator: sha256 over,
//! for each input file in byte order of its path (a directory stands for every file under it),
//! the path, a NUL, the contents and a NUL. tests/it/figures.rs and tests/it/readme_numbers.rs compare
//! it with the recorded one.
use serde_json::Value;
use sha2::{Digest, Sha256};
use std::path::Path;

/// The repository's root.
pub fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Lower-case hex of `bytes`.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Every file under `path` (itself if a file), relative to the repository.
fn files(path: &str, out: &mut Vec<String>) {
    let full = root().join(path);
    if full.is_dir() {
        for entry in std::fs::read_dir(&full).unwrap() {
            let name = entry.unwrap().file_name().to_string_lossy().into_owned();
            files(&format!("{path}/{name}"), out);
        }
    } else {
        out.push(path.to_string());
    }
}

/// The hash of a generator's `inputs` (a JSON array of paths relative to the repository).
pub fn inputs_hash(inputs: &[Value]) -> String {
    let mut all = Vec::new();
    for i in inputs {
        files(i.as_str().expect("an input path"), &mut all);
    }
    all.sort();
    let mut h = Sha256::new();
    for f in &all {
        h.update(f.as_bytes());
        h.update([0]);
        h.update(std::fs::read(root().join(f)).unwrap());
        h.update([0]);
    }
    hex(&h.finalize())
}
