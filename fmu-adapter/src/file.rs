//! Reading and opening an `.fmu`. [`FmuDescription::read`] makes the checks a user needs named
//! errors for without loading anything (missing file, not a zip, no `modelDescription.xml`,
//! not FMI 2.0 or 3.0, no co-simulation, no binary for this platform) and parses the model
//! description; [`FmuFile::open`] then unpacks the archive into a private directory (its
//! `resources/` folder is handed to every instance: as a `file://` URI in FMI 2.0, as a plain
//! path with a trailing separator in FMI 3.0) and loads the shared library once, bound to the
//! API of its version ([`Api`]).

use crate::description::{ModelDescription, VarInfo};
use crate::{fmi3, FmuError};
use libfmi::Fmi2Dll;
use std::collections::HashMap;
use std::ffi::CString;
use std::io::Read;
use std::path::{Path, PathBuf};

pub use crate::description::{VarCausality, VarType};

/// Symbols an FMI 2.0 co-simulation FMU must export for savme to run it.
const REQUIRED_FMI2: [&str; 14] = [
    "fmi2Instantiate",
    "fmi2FreeInstance",
    "fmi2SetupExperiment",
    "fmi2EnterInitializationMode",
    "fmi2ExitInitializationMode",
    "fmi2Terminate",
    "fmi2Reset",
    "fmi2GetReal",
    "fmi2GetInteger",
    "fmi2GetBoolean",
    "fmi2SetReal",
    "fmi2SetInteger",
    "fmi2SetBoolean",
    "fmi2DoStep",
];

/// An FMU's checked model description, read from the archive without unpacking it or loading
/// its library: enough to check a campaign's bindings against it.
#[derive(Debug, Clone)]
pub struct FmuDescription {
    /// The `.fmu` path, for error messages.
    pub path: PathBuf,
    /// The parsed model description.
    pub model: ModelDescription,
    /// The archive's file names (for `savme fmu info`).
    pub files: Vec<String>,
    by_name: HashMap<String, usize>,
}

impl FmuDescription {
    /// Reads and checks `path`: a zip archive holding a well-formed FMI 2.0 or 3.0
    /// `modelDescription.xml` with a `CoSimulation` element, and a binary for this platform.
    pub fn read(path: &Path) -> Result<FmuDescription, FmuError> {
        let d = FmuDescription::inspect(path)?;
        let shown = path.display().to_string();
        let model = &d.model;
        if model.fmi_version != "2.0" && !model.is_fmi3() {
            return Err(FmuError::UnsupportedVersion {
                fmu: shown,
                version: model.fmi_version.clone(),
            });
        }
        let Some(cs) = &model.co_simulation else {
            let kinds: Vec<&str> = [
                model.model_exchange.as_ref().map(|_| "model exchange"),
                model
                    .scheduled_execution
                    .as_ref()
                    .map(|_| "scheduled execution (clocked model partitions)"),
            ]
            .into_iter()
            .flatten()
            .collect();
            return Err(FmuError::NoCoSimulation {
                fmu: shown,
                kinds: if kinds.is_empty() {
                    "neither model exchange nor scheduled execution".into()
                } else {
                    kinds.join(" and ")
                },
            });
        };
        let binary = binary_path(&cs.model_identifier, model.is_fmi3());
        if !d.files.contains(&binary) {
            return Err(FmuError::NoBinary {
                fmu: shown,
                expected: binary,
            });
        }
        Ok(d)
    }

    /// Reads `path`'s archive and model description without checking that savme can run it
    /// (any FMI version, model exchange, other platforms): what `savme fmu info` shows.
    pub fn inspect(path: &Path) -> Result<FmuDescription, FmuError> {
        let shown = path.display().to_string();
        let (xml, files) = read_archive(path, &shown)?;
        let model =
            ModelDescription::parse(&xml).map_err(|message| FmuError::BadModelDescription {
                fmu: shown.clone(),
                message,
            })?;
        let by_name = model
            .variables
            .iter()
            .enumerate()
            .map(|(k, v)| (v.name.clone(), k))
            .collect();
        Ok(FmuDescription {
            path: path.to_path_buf(),
            model,
            files,
            by_name,
        })
    }

    /// The platforms the archive has binaries for (`binaries/<platform>/…`).
    pub fn platforms(&self) -> Vec<String> {
        let mut p: Vec<String> = self
            .files
            .iter()
            .filter_map(|f| f.strip_prefix("binaries/")?.split_once('/'))
            .filter(|(_, file)| !file.is_empty())
            .map(|(platform, _)| platform.to_string())
            .collect();
        p.sort();
        p.dedup();
        p
    }

    /// The variable called `name`, or an error naming the FMU and listing its variables.
    pub fn variable(&self, name: &str) -> Result<&VarInfo, FmuError> {
        match self.by_name.get(name) {
            Some(&k) => Ok(&self.model.variables[k]),
            None => {
                let mut known: Vec<&str> = self.by_name.keys().map(String::as_str).collect();
                known.sort_unstable();
                Err(FmuError::UnknownVariable {
                    fmu: self.path.display().to_string(),
                    variable: name.into(),
                    known: known.join(", "),
                })
            }
        }
    }

    /// `canBeInstantiatedOnlyOncePerProcess="true"`: savme runs it in worker processes only.
    pub fn only_once_per_process(&self) -> bool {
        self.model
            .co_simulation
            .as_ref()
            .is_some_and(|c| c.can_be_instantiated_only_once_per_process)
    }

    /// The co-simulation model identifier.
    pub fn model_identifier(&self) -> &str {
        self.model
            .co_simulation
            .as_ref()
            .map_or("", |c| c.model_identifier.as_str())
    }
}

/// The C API of a loaded library: FMI 2.0 (libfmi's bindings) or FMI 3.0 ([`fmi3`]'s).
pub enum Api {
    /// FMI 2.0 co-simulation.
    Fmi2(Box<Fmi2Dll>),
    /// FMI 3.0 co-simulation.
    Fmi3(Box<fmi3::Library>),
}

/// An opened FMU: its checked description, unpacked to a private directory, its library loaded
/// once and shared by every instance (one instance per run or worker thread). Dereferences to
/// its [`FmuDescription`].
pub struct FmuFile {
    description: FmuDescription,
    /// Where the unpacked `resources/` directory is, as the FMU's version wants it: FMI 2.0's
    /// `fmuResourceLocation` is its `file://` URI, FMI 3.0's `resourcePath` its absolute path
    /// with a trailing separator.
    pub resource_uri: CString,
    pub(crate) api: Api,
    _unpacked: tempfile::TempDir,
}

impl std::ops::Deref for FmuFile {
    type Target = FmuDescription;
    fn deref(&self) -> &FmuDescription {
        &self.description
    }
}

impl std::fmt::Debug for FmuFile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FmuFile")
            .field("path", &self.path)
            .field("model_name", &self.model.model_name)
            .field("variables", &self.model.variables.len())
            .finish()
    }
}

/// The text of `path`'s `modelDescription.xml` (the archive checked as [`FmuDescription::inspect`]
/// checks it).
pub(crate) fn model_xml(path: &Path) -> Result<String, FmuError> {
    read_archive(path, &path.display().to_string()).map(|(xml, _)| xml)
}

/// The archive check: `path` exists, is a zip and holds a readable `modelDescription.xml`,
/// returned as text with the archive's file names.
fn read_archive(path: &Path, shown: &str) -> Result<(String, Vec<String>), FmuError> {
    let file = std::fs::File::open(path).map_err(|e| FmuError::Missing {
        fmu: shown.into(),
        source: e,
    })?;
    let mut zip = zip::ZipArchive::new(file).map_err(|e| FmuError::NotAZip {
        fmu: shown.into(),
        message: e.to_string(),
    })?;
    let files = zip.file_names().map(String::from).collect();
    let mut xml = String::new();
    match zip.by_name("modelDescription.xml") {
        Ok(mut f) => {
            f.read_to_string(&mut xml)
                .map_err(|e| FmuError::BadModelDescription {
                    fmu: shown.into(),
                    message: e.to_string(),
                })?;
        }
        Err(_) => return Err(FmuError::NoModelDescription { fmu: shown.into() }),
    }
    Ok((xml, files))
}

/// The prefix of the directories FMUs are unpacked to, in the temporary directory:
/// `savme-fmu-<pid>-<random>`, the pid of the process that unpacked it.
const UNPACKED: &str = "savme-fmu-";

/// The pid in an unpacked directory's name, if it is one of savme's.
fn unpacked_by(name: &str) -> Option<u32> {
    let (pid, rest) = name.strip_prefix(UNPACKED)?.split_once('-')?;
    (!rest.is_empty()).then_some(())?;
    pid.parse().ok()
}

/// Whether process `pid` is alive (Linux: `/proc/<pid>/stat` exists and is not a zombie's —
/// an orphaned worker can stay a zombie where nothing reaps it; elsewhere every process
/// counts as alive, so that nothing is swept).
fn alive(pid: u32) -> bool {
    if !cfg!(target_os = "linux") {
        return true;
    }
    let Ok(stat) = std::fs::read_to_string(format!("/proc/{pid}/stat")) else {
        return false;
    };
    // `pid (comm) state …`: comm may hold spaces and parentheses, the state follows the last ')'.
    let state = stat
        .rsplit_once(')')
        .and_then(|(_, rest)| rest.split_whitespace().next());
    !matches!(state, Some("Z" | "X" | "x"))
}

/// Removes the unpacked FMUs of processes that are gone — a worker that crashed, hung and was
/// killed, a campaign killed with `kill -9` — from the temporary directory: done once per
/// process, before its first unpacking. Returns the directories removed.
pub fn sweep_stale_unpacked() -> Vec<PathBuf> {
    remove_unpacked(|pid| pid != std::process::id() && !alive(pid))
}

/// Removes what process `pid` unpacked (called once that worker process has ended).
pub fn remove_unpacked_of(pid: u32) -> Vec<PathBuf> {
    remove_unpacked(|p| p == pid)
}

fn remove_unpacked(stale: impl Fn(u32) -> bool) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(std::env::temp_dir()) else {
        return Vec::new();
    };
    entries
        .flatten()
        .filter(|e| e.file_type().is_ok_and(|t| t.is_dir()))
        .filter(|e| {
            e.file_name()
                .to_str()
                .and_then(unpacked_by)
                .is_some_and(&stale)
        })
        .map(|e| e.path())
        .filter(|p| std::fs::remove_dir_all(p).is_ok())
        .collect()
}

/// Unpacks the archive at `path` into a fresh private directory (entries that would land
/// outside it are refused).
fn unpack(path: &Path, shown: &str) -> Result<tempfile::TempDir, FmuError> {
    static SWEPT: std::sync::Once = std::sync::Once::new();
    SWEPT.call_once(|| {
        sweep_stale_unpacked();
    });
    let dir = tempfile::Builder::new()
        .prefix(&format!("{UNPACKED}{}-", std::process::id()))
        .tempdir()
        .map_err(|e| FmuError::Io {
            what: "a temporary directory for the FMU".into(),
            source: e,
        })?;
    let bad = |message: String| FmuError::NotAZip {
        fmu: shown.into(),
        message,
    };
    let file = std::fs::File::open(path).map_err(|e| FmuError::Missing {
        fmu: shown.into(),
        source: e,
    })?;
    let mut zip = zip::ZipArchive::new(file).map_err(|e| bad(e.to_string()))?;
    for k in 0..zip.len() {
        let mut entry = zip.by_index(k).map_err(|e| bad(e.to_string()))?;
        let Some(rel) = entry.enclosed_name().map(Path::to_path_buf) else {
            return Err(bad(format!(
                "entry `{}` would unpack outside its directory",
                entry.name()
            )));
        };
        let target = dir.path().join(rel);
        let io = |e: std::io::Error| FmuError::Io {
            what: format!("unpacking {shown} to {}", target.display()),
            source: e,
        };
        if entry.is_dir() {
            std::fs::create_dir_all(&target).map_err(io)?;
            continue;
        }
        if let Some(parent) = target.parent() {
            std::fs::create_dir_all(parent).map_err(io)?;
        }
        let mut out = std::fs::File::create(&target).map_err(io)?;
        std::io::copy(&mut entry, &mut out).map_err(io)?;
    }
    Ok(dir)
}

/// `binaries/<platform>/<modelIdentifier>.<dll extension>` (the platform folder of FMI 2.0,
/// or FMI 3.0's platform tuple).
fn binary_path(model_identifier: &str, fmi3: bool) -> String {
    let version = if fmi3 {
        savme_fmi_export::FmiVersion::V3
    } else {
        savme_fmi_export::FmiVersion::V2
    };
    format!(
        "binaries/{}/{}.{}",
        version.platform(),
        model_identifier,
        std::env::consts::DLL_EXTENSION
    )
}

/// Loads the shared library at `lib_path`, checks that it exports the functions savme calls
/// for its FMI version and binds them.
fn load_library(lib_path: &Path, shown: &str, fmi3: bool) -> Result<Api, FmuError> {
    // SAFETY: loading a shared library runs its initialisers; that is what an FMU is for.
    let lib = unsafe { libloading::Library::new(lib_path) }.map_err(|e| FmuError::Load {
        fmu: shown.into(),
        message: e.to_string(),
    })?;
    let required: &[&str] = if fmi3 {
        &fmi3::REQUIRED
    } else {
        &REQUIRED_FMI2
    };
    for name in required {
        let symbol = format!("{name}\0");
        // SAFETY: only checks that the symbol exists.
        if unsafe { lib.get::<*const ()>(symbol.as_bytes()) }.is_err() {
            return Err(FmuError::MissingFunction {
                fmu: shown.into(),
                function: (*name).into(),
            });
        }
    }
    let load = |e: libloading::Error| FmuError::Load {
        fmu: shown.into(),
        message: e.to_string(),
    };
    if fmi3 {
        // SAFETY: the library declares FMI 3.0 and exports the functions checked above.
        let api = unsafe { fmi3::Library::bind(lib) }.map_err(load)?;
        return Ok(Api::Fmi3(Box::new(api)));
    }
    // SAFETY: the library exports the FMI 2.0 functions checked above.
    let dll = unsafe { Fmi2Dll::from_library(lib) }.map_err(load)?;
    Ok(Api::Fmi2(Box::new(dll)))
}

/// The `file://` URI of `dir` (RFC 3986: every byte but the unreserved ones and `/`
/// percent-encoded), as FMI 2.0 wants `fmuResourceLocation`.
///
/// ```
/// assert_eq!(
///     savme_fmu::file::file_uri(std::path::Path::new("/tmp/a b/resources")),
///     "file:///tmp/a%20b/resources"
/// );
/// ```
pub fn file_uri(dir: &Path) -> String {
    let mut uri = String::from("file://");
    for b in dir.to_string_lossy().bytes() {
        if b.is_ascii_alphanumeric() || b"-._~/".contains(&b) {
            uri.push(char::from(b));
        } else {
            uri.push_str(&format!("%{b:02X}"));
        }
    }
    uri
}

impl FmuFile {
    /// Reads, checks, unpacks and loads `path`.
    pub fn open(path: &Path) -> Result<FmuFile, FmuError> {
        let description = FmuDescription::read(path)?;
        let shown = path.display().to_string();
        let dir = unpack(path, &shown)?;
        let fmi3 = description.model.is_fmi3();
        let lib_path = dir
            .path()
            .join(binary_path(description.model_identifier(), fmi3));
        let api = load_library(&lib_path, &shown, fmi3)?;
        let resources = dir.path().join("resources");
        let location = if fmi3 {
            // FMI 3.0 §2.3.1: an absolute path with a trailing file separator.
            format!("{}{}", resources.display(), std::path::MAIN_SEPARATOR)
        } else {
            file_uri(&resources)
        };
        let resource_uri = CString::new(location)
            .map_err(|e| FmuError::Spec(format!("the FMU's resource path: {e}")))?;
        Ok(FmuFile {
            description,
            resource_uri,
            api,
            _unpacked: dir,
        })
    }

    /// The checked description.
    pub fn description(&self) -> &FmuDescription {
        &self.description
    }
}
