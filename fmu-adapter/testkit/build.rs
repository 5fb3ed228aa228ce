//! Compiles the test FMUs written in C, as vendors write them: `braking` (the example of
//! `examples/fmu/braking`: resources, an enumeration, a String parameter, bounds, stop
//! requests, logger messages), `braking3` (the same model against the FMI 3.0 C API), `braking_once` (the same, refusing a second live instance in a
//! process), `stairs` (the third-party quirks of issue 26, both C APIs: `c/stairs.c`) and
//! `crash_on_load` (dies while its library is loaded). Their paths reach the crate as
//! `SAVME_BRAKING_LIB`, `SAVME_BRAKING3_LIB`, `SAVME_BRAKING_ONCE_LIB`, `SAVME_STAIRS_LIB` and
//! `SAVME_CRASH_ON_LOAD_LIB`.

use std::path::{Path, PathBuf};
use std::process::Command;

fn shared_library(src: &Path, stem: &str, defines: &[&str], out_dir: &Path) -> PathBuf {
    println!("cargo:rerun-if-changed={}", src.display());
    let out = out_dir.join(format!(
        "{}{stem}{}",
        std::env::consts::DLL_PREFIX,
        std::env::consts::DLL_SUFFIX
    ));
    let compiler = cc::Build::new().opt_level(2).get_compiler();
    let mut cmd: Command = compiler.to_command();
    cmd.args(["-shared", "-fPIC", "-fvisibility=hidden"])
        .args(defines.iter().map(|d| format!("-D{d}")))
        .arg("-o")
        .arg(&out)
        .arg(src)
        .arg("-lm");
    let status = cmd
        .status()
        .unwrap_or_else(|e| panic!("cannot run the C compiler for {}: {e}", src.display()));
    assert!(status.success(), "compiling {} failed", src.display());
    out
}

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("set by cargo"));
    let out_dir = PathBuf::from(std::env::var("OUT_DIR").expect("set by cargo"));
    let braking = manifest.join("../../examples/fmu/braking/braking.c");
    let lib = shared_library(&braking, "braking", &[], &out_dir);
    println!("cargo:rustc-env=SAVME_BRAKING_LIB={}", lib.display());
    println!(
        "cargo:rerun-if-changed={}",
        manifest
            .join("../../examples/fmu/braking/model.c")
            .display()
    );
    let braking3 = manifest.join("../../examples/fmu/braking/braking3.c");
    let lib = shared_library(&braking3, "braking3", &[], &out_dir);
    println!("cargo:rustc-env=SAVME_BRAKING3_LIB={}", lib.display());
    let lib = shared_library(&braking, "braking_once", &["BRAKING_ONLY_ONCE"], &out_dir);
    println!("cargo:rustc-env=SAVME_BRAKING_ONCE_LIB={}", lib.display());
    let stairs = manifest.join("c/stairs.c");
    let lib = shared_library(&stairs, "stairs", &[], &out_dir);
    println!("cargo:rustc-env=SAVME_STAIRS_LIB={}", lib.display());
    let crash = manifest.join("c/crash_on_load.c");
    let lib = shared_library(&crash, "crash_on_load", &[], &out_dir);
    println!("cargo:rustc-env=SAVME_CRASH_ON_LOAD_LIB={}", lib.display());
    println!("cargo:rerun-if-changed=build.rs");
}
