//! Opening an `.fmu`: the checks a user needs named errors for (missing file, not a zip, no
//! `modelDescription.xml`, not FMI 2.0, no co-simulation), then unpacking and parsing it with
//! fmu-runner and loading its shared library once.

use crate::FmuError;
use fmu_runner::model_description::{
    Causality as MdCausality, FmiModelDescription as ModelDescription, SignalType,
};
use libfmi::Fmi2Dll;
use std::collections::HashMap;
use std::io::Read;
use std::path::{Path, PathBuf};

/// A variable's type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VarType {
    /// fmi2Real.
    Real,
    /// fmi2Integer.
    Integer,
    /// fmi2Boolean.
    Boolean,
    /// fmi2String (not supported by savme's bindings).
    String,
    /// An enumeration (not supported).
    Enumeration,
}

/// A variable's causality.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VarCausality {
    /// Parameter (or calculated parameter).
    Parameter,
    /// Input.
    Input,
    /// Output.
    Output,
    /// Anything else (local, independent).
    Other,
}

/// A variable of the FMU.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct VarInfo {
    /// Its name.
    pub name: String,
    /// Its value reference.
    pub vr: u32,
    /// Its type.
    pub kind: VarType,
    /// Its causality.
    pub causality: VarCausality,
}

/// Symbols a co-simulation FMU must export for savme to run it.
const REQUIRED: [&str; 14] = [
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

/// An opened FMU: parsed, unpacked to a private directory, its library loaded once and shared
/// by every instance (one instance per run or worker thread).
pub struct FmuFile {
    /// The `.fmu` path, for error messages.
    pub path: PathBuf,
    /// `modelName`.
    pub model_name: String,
    /// `guid`.
    pub guid: String,
    /// The variables by name.
    pub variables: HashMap<String, VarInfo>,
    /// `DefaultExperiment` stop time and step size, if given.
    pub default_experiment: (Option<f64>, Option<f64>),
    pub(crate) dll: Fmi2Dll,
    _unpacked: tempfile::TempDir,
}

impl std::fmt::Debug for FmuFile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FmuFile")
            .field("path", &self.path)
            .field("model_name", &self.model_name)
            .field("variables", &self.variables.len())
            .finish()
    }
}

/// Reads the model description from the archive and checks what fmu-runner would otherwise
/// reject with an unclear error (or accept wrongly): FMI version and co-simulation support.
fn precheck(path: &Path) -> Result<(), FmuError> {
    let shown = path.display().to_string();
    let xml = read_model_description(path, &shown)?;
    let (version, co_simulation) = scan_model_description(&xml, &shown)?;
    match version.as_deref() {
        Some("2.0") => {}
        Some(v) => {
            return Err(FmuError::UnsupportedVersion {
                fmu: shown,
                version: v.into(),
            })
        }
        None => {
            return Err(FmuError::BadModelDescription {
                fmu: shown,
                message: "no fmiModelDescription element with an fmiVersion attribute".into(),
            })
        }
    }
    if !co_simulation {
        return Err(FmuError::NoCoSimulation { fmu: shown });
    }
    Ok(())
}

/// The archive check: `path` exists, is a zip and holds a readable `modelDescription.xml`,
/// returned as text.
fn read_model_description(path: &Path, shown: &str) -> Result<String, FmuError> {
    let file = std::fs::File::open(path).map_err(|e| FmuError::Missing {
        fmu: shown.into(),
        source: e,
    })?;
    let mut zip = zip::ZipArchive::new(file).map_err(|e| FmuError::NotAZip {
        fmu: shown.into(),
        message: e.to_string(),
    })?;
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
    Ok(xml)
}

/// The model description check: well-formed XML; returns its `fmiVersion` (if any) and
/// whether it declares `CoSimulation`.
fn scan_model_description(xml: &str, shown: &str) -> Result<(Option<String>, bool), FmuError> {
    let mut reader = quick_xml::Reader::from_str(xml);
    let mut version = None;
    let mut co_simulation = false;
    loop {
        match reader.read_event() {
            Ok(quick_xml::events::Event::Start(e)) | Ok(quick_xml::events::Event::Empty(e)) => {
                match e.name().as_ref() {
                    b"fmiModelDescription" => {
                        for a in e.attributes().flatten() {
                            if a.key.as_ref() == b"fmiVersion" {
                                version = Some(String::from_utf8_lossy(&a.value).into_owned());
                            }
                        }
                    }
                    b"CoSimulation" => co_simulation = true,
                    _ => {}
                }
            }
            Ok(quick_xml::events::Event::Eof) => break,
            Ok(_) => {}
            Err(e) => {
                return Err(FmuError::BadModelDescription {
                    fmu: shown.into(),
                    message: format!("at byte {}: {e}", reader.buffer_position()),
                })
            }
        }
    }
    Ok((version, co_simulation))
}

/// Unpacks `path` into a fresh private directory and parses it with fmu-runner.
fn unpack(path: &Path, shown: &str) -> Result<(tempfile::TempDir, fmu_runner::Fmu), FmuError> {
    let dir = tempfile::Builder::new()
        .prefix("savme-fmu-")
        .tempdir()
        .map_err(|e| FmuError::Io {
            what: "a temporary directory for the FMU".into(),
            source: e,
        })?;
    let fmu = fmu_runner::Fmu::unpack_to(path, dir.path()).map_err(|e| {
        FmuError::BadModelDescription {
            fmu: shown.into(),
            message: format!("{e}{}", source_text(&e)),
        }
    })?;
    Ok((dir, fmu))
}

/// The platform binary check: the unpacked FMU holds
/// `binaries/<platform>/<modelIdentifier>.<dll extension>` for this platform.
fn platform_binary(dir: &Path, model_identifier: &str, shown: &str) -> Result<PathBuf, FmuError> {
    let lib_path = dir.join("binaries").join(savme_platform()).join(format!(
        "{}.{}",
        model_identifier,
        std::env::consts::DLL_EXTENSION
    ));
    if !lib_path.exists() {
        return Err(FmuError::NoBinary {
            fmu: shown.into(),
            expected: format!(
                "binaries/{}/{}.{}",
                savme_platform(),
                model_identifier,
                std::env::consts::DLL_EXTENSION
            ),
        });
    }
    Ok(lib_path)
}

/// Loads the shared library at `lib_path`, checks that it exports the [`REQUIRED`] functions
/// and binds them.
fn load_library(lib_path: &Path, shown: &str) -> Result<Fmi2Dll, FmuError> {
    // SAFETY: loading a shared library runs its initialisers; that is what an FMU is for.
    let lib = unsafe { libloading::Library::new(lib_path) }.map_err(|e| FmuError::Load {
        fmu: shown.into(),
        message: e.to_string(),
    })?;
    for name in REQUIRED {
        let symbol = format!("{name}\0");
        // SAFETY: only checks that the symbol exists.
        if unsafe { lib.get::<*const ()>(symbol.as_bytes()) }.is_err() {
            return Err(FmuError::MissingFunction {
                fmu: shown.into(),
                function: name.into(),
            });
        }
    }
    // SAFETY: the library exports the FMI 2.0 functions checked above.
    unsafe { Fmi2Dll::from_library(lib) }.map_err(|e| FmuError::Load {
        fmu: shown.into(),
        message: e.to_string(),
    })
}

/// The model description's scalar variables by name, with savme's type and causality.
fn variables(md: &ModelDescription) -> HashMap<String, VarInfo> {
    md.model_variables
        .scalar_variable
        .values()
        .map(|v| {
            let kind = match v.signal_type {
                SignalType::Real(_) => VarType::Real,
                SignalType::Integer(_) => VarType::Integer,
                SignalType::Boolean(_) => VarType::Boolean,
                SignalType::String => VarType::String,
                SignalType::Enumeration => VarType::Enumeration,
            };
            let causality = match v.causality {
                MdCausality::Parameter | MdCausality::CalculatedParameter => {
                    VarCausality::Parameter
                }
                MdCausality::Input => VarCausality::Input,
                MdCausality::Output => VarCausality::Output,
                _ => VarCausality::Other,
            };
            (
                v.name.clone(),
                VarInfo {
                    name: v.name.clone(),
                    vr: v.value_reference,
                    kind,
                    causality,
                },
            )
        })
        .collect()
}

impl FmuFile {
    /// Opens, checks, unpacks and loads `path`.
    pub fn open(path: &Path) -> Result<FmuFile, FmuError> {
        precheck(path)?;
        let shown = path.display().to_string();
        let (dir, fmu) = unpack(path, &shown)?;
        let md = &fmu.model_description;
        let cs = md
            .co_simulation
            .as_ref()
            .ok_or_else(|| FmuError::NoCoSimulation { fmu: shown.clone() })?;
        let lib_path = platform_binary(dir.path(), &cs.model_identifier, &shown)?;
        let dll = load_library(&lib_path, &shown)?;
        let default_experiment = md.default_experiment.as_ref().map_or((None, None), |d| {
            ((d.stop_time > 0.0).then_some(d.stop_time), d.step_size)
        });
        Ok(FmuFile {
            path: path.to_path_buf(),
            model_name: md.model_name.clone(),
            guid: md.guid.clone(),
            variables: variables(md),
            default_experiment,
            dll,
            _unpacked: dir,
        })
    }

    /// The variable called `name`, or an error naming the FMU and listing close names.
    pub fn variable(&self, name: &str) -> Result<&VarInfo, FmuError> {
        self.variables.get(name).ok_or_else(|| {
            let mut known: Vec<&str> = self.variables.keys().map(String::as_str).collect();
            known.sort_unstable();
            FmuError::UnknownVariable {
                fmu: self.path.display().to_string(),
                variable: name.into(),
                known: known.join(", "),
            }
        })
    }
}

/// The platform folder under `binaries/` (`linux64`, …).
pub fn savme_platform() -> String {
    savme_fmi_export::platform_folder()
}

fn source_text(e: &dyn std::error::Error) -> String {
    e.source().map_or(String::new(), |s| format!(": {s}"))
}
