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
