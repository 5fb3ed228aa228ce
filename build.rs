//! Stamps `savme --version` with the commit it was built from and the enabled features.
//!
//! The commit comes from git (a checkout), else from `.cargo_vcs_info.json` (a package from
//! crates.io records the commit it was packaged from), else "unknown".
use std::path::Path;
use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

/// The commit recorded by `cargo package` (`{"git": {"sha1": "…"}}`).
fn packaged_commit() -> Option<String> {
    let text = std::fs::read_to_string(".cargo_vcs_info.json").ok()?;
    let start = text.find("\"sha1\"")? + "\"sha1\"".len();
    let rest = &text[start..];
    let open = rest.find('"')? + 1;
    let close = rest[open..].find('"')? + open;
    Some(rest[open..close].chars().take(12).collect())
}

fn commit() -> String {
    if Path::new(".cargo_vcs_info.json").exists() {
        return packaged_commit().unwrap_or_else(|| "unknown".into());
    }
    let Some(sha) = git(&["rev-parse", "--short=12", "HEAD"]) else {
        return "unknown".into();
    };
    // Rebuild when HEAD moves (a commit, a checkout).
    for path in ["HEAD", "logs/HEAD"] {
        if let Some(p) = git(&["rev-parse", "--git-path", path]) {
            println!("cargo:rerun-if-changed={p}");
        }
    }
    sha
}

/// Where cargo writes the bundled simulator's FMU library (savme-sim-fmu's `cdylib`, built by
/// the same rustc run as the `rlib` the binary links): `deps/` of this profile's directory, three
/// levels above `OUT_DIR` (`<profile>/build/savme-<hash>/out`). The binary embeds it
/// (`savme_embed::embed_built!`), so that `savme fmu pack` works from a lone copy.
fn sim_fmu_library() -> Option<String> {
    let out = std::path::PathBuf::from(std::env::var_os("OUT_DIR")?);
    let deps = out.ancestors().nth(3)?.join("deps");
    let os = std::env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    let name = match os.as_str() {
        "windows" => "savme_sim_fmu.dll",
        "macos" | "ios" => "libsavme_sim_fmu.dylib",
        _ => "libsavme_sim_fmu.so",
    };
    Some(deps.join(name).to_str()?.to_string())
}

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let mut features: Vec<String> = std::env::vars()
        .filter_map(|(k, _)| k.strip_prefix("CARGO_FEATURE_").map(|f| f.to_lowercase()))
        .filter(|f| f != "default")
        .collect();
    features.sort();
    let features = if features.is_empty() {
        "none".to_string()
    } else {
        features.join(", ")
    };
    println!("cargo:rustc-env=SAVME_COMMIT={}", commit());
    if let Some(path) = sim_fmu_library() {
        println!("cargo:rustc-env=SAVME_SIM_FMU_EMBED={path}");
    }
    println!("cargo:rustc-env=SAVME_FEATURES={features}");
}
