//! savme in the tools AV safety teams already use, run in the interop environment that
//! `scripts/test` makes (`target/interop-venv`: VerifAI 2.2 with Scenic 3, scenariogeneration
//! and the savme wheel): the pytest suite `python/interop` — `savme.verifai.SavmeSampler`
//! inside VerifAI's own falsifier, `savme.scenic.ScenicSearch` on Scenic programs in Scenic's
//! Newtonian simulator, and the VerifAI falsification example.
//!
//! Without `SAVME_INTEROP_PYTHON` the test skips loudly; with `SAVME_REQUIRE_INTEROP=1` (set
//! by `scripts/test`) it fails instead.

use std::path::PathBuf;
use std::process::Command;

#[test]
fn the_verifai_and_scenic_suite_passes() {
    let required = std::env::var("SAVME_REQUIRE_INTEROP").is_ok_and(|v| v == "1");
    let Some(python) = std::env::var_os("SAVME_INTEROP_PYTHON") else {
        let msg = "SAVME_INTEROP_PYTHON is not set (a python with verifai, scenic and the savme \
                   wheel; scripts/test makes one): SKIPPING the VerifAI/Scenic interop suite";
        assert!(!required, "{msg} — but SAVME_REQUIRE_INTEROP=1 requires it");
        eprintln!("\n*** {msg} ***\n");
        return;
    };
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("python/interop");
    let out = Command::new(&python)
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
        .current_dir(&dir)
        .output()
        .unwrap_or_else(|e| panic!("{}: {e}", PathBuf::from(&python).display()));
    let text = String::from_utf8_lossy(&out.stdout);
    eprintln!("{text}{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "the interop suite failed:\n{text}");
    assert!(
        !text.contains("skipped"),
        "no interop test may skip:\n{text}"
    );
}
