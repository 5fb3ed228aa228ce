//! `savme fmu pack` (the bundled simulator as an FMU) and the hidden `savme fmu-worker` (serves
//! isolated FMU evaluations to `savme run`).

use std::path::{Path, PathBuf};

#[derive(clap::Subcommand)]
pub enum Command {
    /// Write the bundled driving simulator as an FMI 2.0 co-simulation FMU.
    Pack {
        /// The .fmu to write.
        #[arg(long, default_value = "savme-sim.fmu")]
        out: PathBuf,
        /// The simulator's shared library (default: found next to this binary).
        #[arg(long)]
        library: Option<PathBuf>,
    },
}

pub fn run(c: Command) -> Result<(), String> {
    match c {
        Command::Pack { out, library } => {
            pack(&out, library.as_deref()).and_then(|t| super::print(&t))
        }
    }
}

/// Where the bundled simulator's FMU library is: given, or next to the savme binary (cargo
/// builds it there as `deps/libsavme_sim_fmu.so`).
fn find_library(given: Option<&Path>) -> Result<PathBuf, String> {
    if let Some(p) = given {
        return if p.exists() {
            Ok(p.to_path_buf())
        } else {
            Err(format!("{}: no such library", p.display()))
        };
    }
    let name = format!(
        "{}{}{}",
        std::env::consts::DLL_PREFIX,
        savme_sim_fmu::MODEL_IDENTIFIER,
        std::env::consts::DLL_SUFFIX
    );
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    let dir = exe.parent().unwrap_or(Path::new("."));
    let candidates = [
        dir.join(&name),
        dir.join("deps").join(&name),
        dir.join("..").join(&name),
    ];
    candidates
        .iter()
        .find(|p| p.exists())
        .cloned()
        .ok_or_else(|| {
            format!(
                "{name} not found next to {} (build it with `cargo build --release -p savme-sim-fmu`, or give --library PATH)",
                exe.display()
            )
        })
}

/// Writes the bundled simulator as an `.fmu`.
fn pack(out: &Path, library: Option<&Path>) -> Result<String, String> {
    let lib = find_library(library)?;
    savme_fmi_export::pack(
        &savme_sim_fmu::model_description(),
        savme_sim_fmu::MODEL_IDENTIFIER,
        &lib,
        out,
    )
    .map_err(|e| e.to_string())?;
    Ok(format!(
        "wrote {} (library {})\n",
        out.display(),
        lib.display()
    ))
}

/// `savme fmu-worker`: serves evaluations on stdin/stdout.
pub fn worker() -> Result<(), String> {
    savme_fmu::worker::serve(std::io::stdin().lock(), std::io::stdout().lock())
        .map_err(|e| e.to_string())
}
