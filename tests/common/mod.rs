//! Helpers shared by the integration tests (each test file takes what it needs).
#![allow(dead_code)]

pub mod campaign;
pub mod postgres;

/// The SQL block that follows the marker `<!-- NAME -->` in `docs/DISTRIBUTED.md` (so that the
/// tests run exactly what the docs show).
pub fn doc_sql(marker: &str) -> String {
    let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/DISTRIBUTED.md"))
        .expect("docs/DISTRIBUTED.md");
    let at = doc
        .find(&format!("<!-- {marker} -->"))
        .unwrap_or_else(|| panic!("no `<!-- {marker} -->` in docs/DISTRIBUTED.md"));
    let rest = &doc[at..];
    let start = rest.find("```sql\n").expect("a ```sql block") + "```sql\n".len();
    let end = rest[start..].find("```").expect("the block's end");
    rest[start..start + end].to_string()
}

/// FMPy (PyPI `fmpy`), the independent FMI client, if the environment provides it:
/// `scripts/test` installs it into a virtual environment and sets SAVME_FMPY_PYTHON and
/// SAVME_REQUIRE_FMPY=1 (then a missing FMPy fails instead of skipping).
pub fn fmpy_python() -> Option<String> {
    let python = std::env::var("SAVME_FMPY_PYTHON").ok();
    let required = std::env::var("SAVME_REQUIRE_FMPY").is_ok_and(|v| v == "1");
    match python {
        Some(p) => Some(p),
        None if required => panic!("SAVME_REQUIRE_FMPY=1 but SAVME_FMPY_PYTHON is not set"),
        None => {
            eprintln!("FMPy cross-check skipped: set SAVME_FMPY_PYTHON to a python with fmpy");
            None
        }
    }
}
