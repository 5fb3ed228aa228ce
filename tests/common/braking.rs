//! The `braking` example FMU as vendors ship them (`examples/fmu/braking`: C against the FMI
//! 2.0 and 3.0 C APIs), compiled here with the system C compiler (`$CC`, else `cc`) and packed
//! with its resources (`tests/it/vendor_fmu.rs`, `tests/it/openscenario.rs`). The root package's
//! tests cannot link savme-fmu-testkit, which builds the same library: its exported FMI
//! symbols would clash with savme-sim-fmu's.

use super::made_dir;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// `examples/fmu/braking`.
pub fn example() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/fmu/braking")
}

/// Compiles `examples/fmu/braking/<source>` (`$CC`, else `cc`) into `dir`.
pub fn compile(source: &str, dir: &str) -> PathBuf {
    let lib = made_dir(dir).join(format!("braking.{}", std::env::consts::DLL_EXTENSION));
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    let status = Command::new(&cc)
        .args(["-shared", "-fPIC", "-O2", "-fvisibility=hidden", "-o"])
        .arg(&lib)
        .arg(example().join(source))
        .arg("-lm")
        .status()
        .unwrap_or_else(|e| panic!("the C compiler `{cc}` (set CC): {e}"));
    assert!(status.success(), "compiling {source} failed");
    lib
}

/// The braking example's shared library, compiled once from `braking.c`.
pub fn braking_library() -> &'static Path {
    static LIB: OnceLock<PathBuf> = OnceLock::new();
    LIB.get_or_init(|| compile("braking.c", "braking-lib"))
}

/// The FMI 3.0 braking example's shared library, compiled once from `braking3.c`.
pub fn braking3_library() -> &'static Path {
    static LIB: OnceLock<PathBuf> = OnceLock::new();
    LIB.get_or_init(|| compile("braking3.c", "braking3-lib"))
}

/// `braking3.fmu` (FMI 3.0) in `dir`, with its resources.
pub fn pack3(dir: &Path) -> PathBuf {
    let out = dir.join("braking3.fmu");
    let xml = std::fs::read_to_string(example().join("modelDescription3.xml")).unwrap();
    let friction = std::fs::read(example().join("resources/friction.txt")).unwrap();
    savme_fmi_export::pack_with(
        &xml,
        "braking",
        braking3_library(),
        &[("resources/friction.txt", &friction)],
        &out,
    )
    .unwrap();
    out
}

/// `braking.fmu` in `dir` with `xml` as its model description (and its resources).
pub fn pack(dir: &Path, xml: &str) -> PathBuf {
    let out = dir.join("braking.fmu");
    let friction = std::fs::read(example().join("resources/friction.txt")).unwrap();
    savme_fmi_export::pack_with(
        xml,
        "braking",
        braking_library(),
        &[("resources/friction.txt", &friction)],
        &out,
    )
    .unwrap();
    out
}

/// The example's FMI 2.0 model description.
pub fn model_description() -> String {
    std::fs::read_to_string(example().join("modelDescription.xml")).unwrap()
}
