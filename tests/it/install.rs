//! A lone copy of the savme binary packs the bundled simulator as an FMU (issue 39 item 3; issue
//! 30 item 4 before): the simulator's FMU library is embedded in the binary at build time, so a
//! binary copied alone into an empty directory (or installed by `cargo install`, which installs
//! only the binary) packs FMI 2.0 and 3.0 FMUs that savme validates (library loaded and
//! instantiated in a child) and that carry byte for byte the library cargo built. `--library`
//! and `SAVME_SIM_FMU_LIBRARY` still choose another library, and a missing one is named.
//!
//! The binary under test is this build's, copied alone into a fresh directory; `scripts/test`
//! also runs `cargo install --path .` and sets `SAVME_INSTALLED_SAVME` to the installed
//! binary, which is then checked the same way (`SAVME_REQUIRE_INSTALL=1` makes its absence a
//! failure).
use crate::common;

use common::made_dir;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The FMU library cargo built for the test binary's savme (`deps/`: the one it embeds; the copy
/// beside it is refreshed only when savme-sim-fmu itself is built as a root).
fn built_library() -> PathBuf {
    let name = "libsavme_sim_fmu.so";
    let exe = Path::new(env!("CARGO_BIN_EXE_savme"));
    let dir = exe.parent().unwrap();
    [dir.join("deps").join(name), dir.join(name)]
        .into_iter()
        .find(|p| p.is_file())
        .unwrap_or_else(|| panic!("{name} not built beside {}", exe.display()))
}

/// `exe ARGS` run in `dir` without `SAVME_SIM_FMU_LIBRARY` (unless given): success and output.
fn run_in(dir: &Path, exe: &Path, args: &[&str], library_var: Option<&str>) -> (bool, String) {
    let mut cmd = Command::new(exe);
    cmd.args(args)
        .current_dir(dir)
        .env_remove("SAVME_SIM_FMU_LIBRARY");
    if let Some(v) = library_var {
        cmd.env("SAVME_SIM_FMU_LIBRARY", v);
    }
    let out = cmd.output().unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    (out.status.success(), text)
}

/// The library file inside an `.fmu` (`binaries/<platform>/savme_sim_fmu.so`).
fn packed_library(fmu: &Path) -> Vec<u8> {
    let mut zip = zip::ZipArchive::new(std::fs::File::open(fmu).unwrap()).unwrap();
    let name = (0..zip.len())
        .map(|i| zip.by_index(i).unwrap().name().to_string())
        .find(|n| n.starts_with("binaries/") && n.ends_with(".so"))
        .unwrap_or_else(|| panic!("{}: no library in the archive", fmu.display()));
    let mut bytes = Vec::new();
    zip.by_name(&name).unwrap().read_to_end(&mut bytes).unwrap();
    bytes
}

/// `binary` copied alone into an empty directory packs valid FMUs of both versions from its
/// embedded library; `--library` / `SAVME_SIM_FMU_LIBRARY` naming a missing file are refused,
/// naming it and where it came from.
fn check_lone_binary(binary: &Path, what: &str) {
    let dir = made_dir(what);
    let exe = dir.join("savme");
    std::fs::copy(binary, &exe).unwrap();
    let built = std::fs::read(built_library()).unwrap();
    for fmi in ["2", "3"] {
        let (ok, text) = run_in(
            &dir,
            &exe,
            &["fmu", "pack", "--fmi", fmi, "--out", "sim.fmu"],
            None,
        );
        assert!(ok, "{what}: FMI {fmi}: {text}");
        assert!(
            text.contains("library embedded in this binary"),
            "{what}: {text}"
        );
        let (ok, text) = run_in(&dir, &exe, &["fmu", "validate", "sim.fmu"], None);
        assert!(ok && text.contains("valid"), "{what}: FMI {fmi}: {text}");
        let packed = packed_library(&dir.join("sim.fmu"));
        if what == "copied" {
            // This build's binary embeds the very library cargo built beside it.
            assert!(
                packed == built,
                "{what}: the packed library differs from {}",
                built_library().display()
            );
        } else {
            assert!(
                packed.starts_with(b"\x7fELF"),
                "{what}: the packed library is no ELF file"
            );
        }
    }
    let missing = dir.join("no-such.so");
    let missing = missing.to_str().unwrap();
    let (ok, text) = run_in(&dir, &exe, &["fmu", "pack", "--library", missing], None);
    assert!(
        !ok && text.contains(missing) && text.contains("--library"),
        "{what}: {text}"
    );
    let (ok, text) = run_in(&dir, &exe, &["fmu", "pack"], Some(missing));
    assert!(
        !ok && text.contains(missing) && text.contains("SAVME_SIM_FMU_LIBRARY"),
        "{what}: {text}"
    );
    // A given library is the one packed.
    let given = built_library();
    let (ok, text) = run_in(
        &dir,
        &exe,
        &["fmu", "pack", "--library", given.to_str().unwrap()],
        None,
    );
    assert!(
        ok && text.contains(given.to_str().unwrap()),
        "{what}: {text}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_lone_copy_of_the_binary_packs_an_fmu() {
    check_lone_binary(Path::new(env!("CARGO_BIN_EXE_savme")), "copied");
}

#[test]
fn the_cargo_installed_binary_packs_an_fmu_alone() {
    match std::env::var_os("SAVME_INSTALLED_SAVME") {
        Some(path) => check_lone_binary(Path::new(&path), "installed"),
        None if std::env::var_os("SAVME_REQUIRE_INSTALL").is_some() => {
            panic!("SAVME_REQUIRE_INSTALL is set but SAVME_INSTALLED_SAVME is not")
        }
        None => eprintln!(
            "SKIPPED: SAVME_INSTALLED_SAVME is not set (scripts/test runs `cargo install --path .` and sets it)"
        ),
    }
}
