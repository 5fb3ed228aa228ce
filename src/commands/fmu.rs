//! `savme fmu pack` (the bundled simulator as an FMU), `savme fmu info` / `validate` (any FMU,
//! like `fmpy info` / `validate`), and the hidden `savme fmu-worker` (serves isolated FMU
//! evaluations to `savme run`).

use std::path::{Path, PathBuf};

#[derive(clap::Subcommand)]
pub enum Command {
    /// Write the bundled driving simulator as an FMI 2.0 (or, with `--fmi 3`, FMI 3.0)
    /// co-simulation FMU.
    Pack {
        /// The .fmu to write.
        #[arg(long, default_value = "savme-sim.fmu")]
        out: PathBuf,
        /// The FMI version: 2 (FMI 2.0) or 3 (FMI 3.0; binaries/<arch>-<os>/).
        #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u8).range(2..=3))]
        fmi: u8,
        /// The simulator's shared library (libsavme_sim_fmu.so) [default: $SAVME_SIM_FMU_LIBRARY,
        /// else the one built into this binary].
        #[arg(long)]
        library: Option<PathBuf>,
    },
    /// Show an FMU: FMI version, kinds, platforms, capabilities, default experiment, and its
    /// variables with causality, type, start, min/max, unit (and enumeration items).
    Info {
        /// The .fmu.
        file: PathBuf,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Make every check savme makes on an FMU before a campaign: archive, model description,
    /// FMI 2.0 or 3.0 co-simulation, a binary for this platform, every variable's declaration,
    /// and the library (loaded, its FMI functions, instantiated with its GUID or instantiation
    /// token and resources — in a child process). Exit status 0, or 1 with the list of
    /// problems.
    Validate {
        /// The .fmu.
        file: PathBuf,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// The library part of `validate`, in this process: prints the problems as JSON.
    #[command(hide = true)]
    ValidateLibrary {
        /// The .fmu.
        file: PathBuf,
    },
}

pub fn run(c: Command) -> Result<(), String> {
    match c {
        Command::Pack { out, library, fmi } => {
            pack(&out, library.as_deref(), fmi).and_then(|t| super::print(&t))
        }
        Command::Info { file, json } => {
            let info = savme_fmu::inspect::Info::read(&file).map_err(|e| e.to_string())?;
            let text = if json {
                let doc = savme::json::FmuInfo {
                    format_version: savme::json::FORMAT_VERSION,
                    info,
                };
                serde_json::to_string_pretty(&doc).map_err(|e| e.to_string())? + "\n"
            } else {
                info.text()
            };
            super::print(&text)
        }
        Command::Validate { file, json } => validate(&file, json),
        Command::ValidateLibrary { file } => {
            let problems = savme_fmu::inspect::load_problems(&file);
            super::print(&(serde_json::to_string(&problems).map_err(|e| e.to_string())? + "\n"))
        }
    }
}

/// `savme fmu validate`: the checks without loading, then (if they pass) the library's in a
/// child process (`savme fmu validate-library`), so that one that crashes is a problem.
fn validate(file: &Path, json: bool) -> Result<(), String> {
    let mut problems = savme_fmu::inspect::problems(file);
    if problems.is_empty() {
        problems = library_problems(file)?;
    }
    let shown = file.display().to_string();
    let text = if json {
        let report = savme::json::FmuValidation {
            format_version: savme::json::FORMAT_VERSION,
            fmu: shown.clone(),
            valid: problems.is_empty(),
            problems: problems.clone(),
        };
        serde_json::to_string_pretty(&report).map_err(|e| e.to_string())? + "\n"
    } else if problems.is_empty() {
        format!("{shown}: valid — every check savme makes before a campaign passes\n")
    } else {
        let mut t = format!("{shown}: {} problem(s)\n", problems.len());
        for p in &problems {
            t.push_str(&format!("  - {p}\n"));
        }
        t
    };
    super::print(&text)?;
    if problems.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "{shown}: not valid ({} problem(s))",
            problems.len()
        ))
    }
}

/// The command that checks one FMU's library in a child process: this binary's `fmu
/// validate-library` (the FMU's path appended).
pub fn probe_command() -> Result<Vec<String>, String> {
    let exe = std::env::current_exe().map_err(|e| format!("cannot find the savme binary: {e}"))?;
    Ok(vec![
        exe.display().to_string(),
        "fmu".into(),
        "validate-library".into(),
    ])
}

/// The library checks of `file`, run by this binary in a child process.
fn library_problems(file: &Path) -> Result<Vec<String>, String> {
    // The child's unpacked copy is removed once it has ended, also after a crash.
    let out = savme_fmu::inspect::run_probe(&probe_command()?, file)
        .map_err(|e| format!("cannot start the library check: {e}"))?;
    if out.status.success() {
        return serde_json::from_slice(&out.stdout)
            .map_err(|e| format!("the library check answered badly: {e}"));
    }
    #[cfg(unix)]
    {
        use std::os::unix::process::ExitStatusExt;
        if let Some(sig) = out.status.signal() {
            return Ok(vec![format!(
                "{}: the library crashed while it was loaded or instantiated (killed by signal {sig})",
                file.display()
            )]);
        }
    }
    Ok(vec![format!(
        "{}: the library check failed ({}): {}",
        file.display(),
        out.status,
        String::from_utf8_lossy(&out.stderr).trim()
    )])
}

/// The environment variable that names the bundled simulator's FMU library.
pub const LIBRARY_VAR: &str = "SAVME_SIM_FMU_LIBRARY";

/// The bundled simulator's FMU library, built by cargo with this binary and embedded in it
/// (`None` only in a build without it, e.g. under `cargo check`).
const EMBEDDED_LIBRARY: Option<&[u8]> = savme_embed::embed_built!("SAVME_SIM_FMU_EMBED");

/// The library `savme fmu pack` puts into the FMU: a file given by `--library` or
/// `SAVME_SIM_FMU_LIBRARY`, else the one embedded in this binary.
enum Library {
    File(PathBuf),
    Embedded(&'static [u8]),
}

impl Library {
    /// Given (`--library`), named by `SAVME_SIM_FMU_LIBRARY`, else embedded in the binary; a
    /// binary built without it (only `cargo check` builds one) looks beside itself — next to
    /// it (cargo builds it there as `deps/libsavme_sim_fmu.so`) or in `../lib/savme/`.
    fn find(given: Option<&Path>) -> Result<Library, String> {
        let named = |p: &Path, by: &str| {
            if p.is_file() {
                Ok(Library::File(p.to_path_buf()))
            } else {
                Err(format!("{}: no such library ({by})", p.display()))
            }
        };
        if let Some(p) = given {
            return named(p, "--library");
        }
        if let Some(p) = std::env::var_os(LIBRARY_VAR).filter(|v| !v.is_empty()) {
            return named(Path::new(&p), LIBRARY_VAR);
        }
        match EMBEDDED_LIBRARY {
            Some(bytes) => Ok(Library::Embedded(bytes)),
            None => beside_binary().map(Library::File),
        }
    }

    fn bytes(&self) -> Result<std::borrow::Cow<'static, [u8]>, String> {
        match self {
            Library::Embedded(b) => Ok((*b).into()),
            Library::File(p) => std::fs::read(p)
                .map(Into::into)
                .map_err(|e| format!("{}: {e}", p.display())),
        }
    }

    fn describe(&self) -> String {
        match self {
            Library::Embedded(_) => "embedded in this binary".to_string(),
            Library::File(p) => p.display().to_string(),
        }
    }
}

/// The library installed beside the binary (only a build without the embedded one looks).
fn beside_binary() -> Result<PathBuf, String> {
    let name = format!(
        "{}{}{}",
        std::env::consts::DLL_PREFIX,
        savme_sim_fmu::MODEL_IDENTIFIER,
        std::env::consts::DLL_SUFFIX
    );
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    let dir = exe.parent().unwrap_or(Path::new("."));
    let installed = dir.parent().unwrap_or(dir).join("lib").join("savme");
    let candidates = [
        dir.join(&name),
        dir.join("deps").join(&name),
        dir.join("..").join(&name),
        installed.join(&name),
    ];
    candidates
        .iter()
        .find(|p| p.is_file())
        .cloned()
        .ok_or_else(|| {
            format!(
            "this savme was built without the bundled simulator's FMU library, and {name} is not \
             beside {} (looked in {}): give --library PATH (or set {LIBRARY_VAR}), or build \
             savme with `cargo build --release` — docs/INSTALL.md",
            exe.display(),
            candidates
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", "),
        )
        })
}

/// Writes the bundled simulator as an `.fmu` of FMI version `fmi` (2 or 3): the same library
/// (it exports both C APIs) with that version's model description.
fn pack(out: &Path, library: Option<&Path>, fmi: u8) -> Result<String, String> {
    let lib = Library::find(library)?;
    let description = if fmi == 3 {
        savme_sim_fmu::model_description3()
    } else {
        savme_sim_fmu::model_description()
    };
    let archive = savme_fmi_export::pack_library_bytes(
        &description,
        savme_sim_fmu::MODEL_IDENTIFIER,
        &lib.bytes()?,
        &[],
    )
    .map_err(|e| e.to_string())?;
    // Never through a link at `out` (a symbolic link, or a file other names share): refused,
    // naming the path, and whatever it points at left unchanged.
    savme::store::safe_file::write_file(out, &archive)
        .map_err(|e| format!("{}: {e}", out.display()))?;
    Ok(format!(
        "wrote {} (FMI {fmi}.0, library {})\n",
        out.display(),
        lib.describe()
    ))
}

/// `savme fmu-worker`: serves evaluations on stdin/stdout.
pub fn worker() -> Result<(), String> {
    savme_fmu::worker::serve(std::io::stdin().lock(), std::io::stdout().lock())
        .map_err(|e| e.to_string())
}
