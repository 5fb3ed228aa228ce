//! Packing an `.fmu`: the model description and the shared library in a zip archive.

use std::io::{Seek, Write};
use std::path::Path;

/// The `binaries/` folder of this platform (`linux64`, `darwin64`, `win64`).
pub fn platform_folder() -> String {
    let os = match std::env::consts::OS {
        "macos" => "darwin",
        "windows" => "win",
        other => other,
    };
    let bits = if cfg!(target_pointer_width = "64") {
        "64"
    } else {
        "32"
    };
    format!("{os}{bits}")
}

/// The `binaries/` folder of this platform in FMI 3.0: the platform tuple `<arch>-<os>`
/// (`x86_64-linux`, `aarch64-darwin`, `x86_64-windows`, …; FMI 3.0 §2.5.1.1).
///
/// ```
/// let t = savme_fmi_export::platform_tuple();
/// assert!(t.ends_with(&format!("-{}", if cfg!(target_os = "macos") { "darwin" } else { std::env::consts::OS })));
/// ```
pub fn platform_tuple() -> String {
    let os = match std::env::consts::OS {
        "macos" => "darwin",
        other => other,
    };
    format!("{}-{os}", std::env::consts::ARCH)
}

/// The FMI version an FMU is packed for: where its library goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FmiVersion {
    /// FMI 2.0: `binaries/<os><bits>/` ([`platform_folder`]).
    V2,
    /// FMI 3.0: `binaries/<arch>-<os>/` ([`platform_tuple`]).
    V3,
}

impl FmiVersion {
    /// The `binaries/` folder of this platform.
    pub fn platform(self) -> String {
        match self {
            FmiVersion::V2 => platform_folder(),
            FmiVersion::V3 => platform_tuple(),
        }
    }
}

/// Why packing failed.
#[derive(Debug, thiserror::Error)]
pub enum PackError {
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The error.
        source: std::io::Error,
    },
    /// The zip archive could not be written.
    #[error("{path}: {source}")]
    Zip {
        /// The archive.
        path: String,
        /// The error.
        source: zip::result::ZipError,
    },
}

/// Writes `out` (an `.fmu`): `modelDescription.xml` (the given text) and `library` as
/// `binaries/<platform>/<identifier>.<so|dylib|dll>` — the FMI version read from the model
/// description decides the platform folder.
pub fn pack(
    model_description: &str,
    identifier: &str,
    library: &Path,
    out: &Path,
) -> Result<(), PackError> {
    pack_with(model_description, identifier, library, &[], out)
}

/// [`pack`] with more files in the archive, e.g. `("resources/table.txt", bytes)`.
///
/// `out` is created (or truncated) as [`std::fs::File::create`] does; a program that must not
/// write through a link at `out` packs with [`pack_bytes`] and writes the bytes itself.
pub fn pack_with(
    model_description: &str,
    identifier: &str,
    library: &Path,
    files: &[(&str, &[u8])],
    out: &Path,
) -> Result<(), PackError> {
    let lib = std::fs::read(library).map_err(io_error(library))?;
    let file = std::fs::File::create(out).map_err(io_error(out))?;
    let shown = out.display().to_string();
    write_archive(file, model_description, identifier, &lib, files, &shown)?;
    Ok(())
}

/// The `.fmu` archive [`pack_with`] writes, as bytes (for a caller that writes the file by its
/// own means, e.g. refusing a link at the path).
///
/// ```no_run
/// let bytes = savme_fmi_export::pack_bytes("<fmiModelDescription …/>", "model",
///     std::path::Path::new("libmodel.so"), &[])?;
/// assert!(bytes.starts_with(b"PK"));
/// # Ok::<(), savme_fmi_export::PackError>(())
/// ```
pub fn pack_bytes(
    model_description: &str,
    identifier: &str,
    library: &Path,
    files: &[(&str, &[u8])],
) -> Result<Vec<u8>, PackError> {
    let lib = std::fs::read(library).map_err(io_error(library))?;
    pack_library_bytes(model_description, identifier, &lib, files)
}

/// [`pack_bytes`] with the library given as bytes (e.g. embedded in the program that packs).
///
/// ```
/// let bytes = savme_fmi_export::pack_library_bytes("<fmiModelDescription …/>", "model",
///     b"\x7fELF (a shared library)", &[])?;
/// assert!(bytes.starts_with(b"PK"));
/// # Ok::<(), savme_fmi_export::PackError>(())
/// ```
pub fn pack_library_bytes(
    model_description: &str,
    identifier: &str,
    library: &[u8],
    files: &[(&str, &[u8])],
) -> Result<Vec<u8>, PackError> {
    let cursor = std::io::Cursor::new(Vec::new());
    let written = write_archive(
        cursor,
        model_description,
        identifier,
        library,
        files,
        "the .fmu archive",
    )?;
    Ok(written.into_inner())
}

fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> PackError {
    let path = path.display().to_string();
    move |source| PackError::Io { path, source }
}

/// Writes the archive into `w` (`shown`: what errors name); gives `w` back.
fn write_archive<W: Write + Seek>(
    w: W,
    model_description: &str,
    identifier: &str,
    lib: &[u8],
    files: &[(&str, &[u8])],
    shown: &str,
) -> Result<W, PackError> {
    let io = |source| PackError::Io {
        path: shown.to_string(),
        source,
    };
    let zip_err = |source| PackError::Zip {
        path: shown.to_string(),
        source,
    };
    let mut z = zip::ZipWriter::new(w);
    let opts = zip::write::FileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated)
        .unix_permissions(0o755);
    z.start_file("modelDescription.xml", opts)
        .map_err(zip_err)?;
    z.write_all(model_description.as_bytes()).map_err(io)?;
    let ext = std::env::consts::DLL_EXTENSION;
    let version = if model_description.contains("fmiVersion=\"3.") {
        FmiVersion::V3
    } else {
        FmiVersion::V2
    };
    z.start_file(
        format!("binaries/{}/{identifier}.{ext}", version.platform()),
        opts,
    )
    .map_err(zip_err)?;
    z.write_all(lib).map_err(io)?;
    for (name, bytes) in files {
        z.start_file(*name, opts).map_err(zip_err)?;
        z.write_all(bytes).map_err(io)?;
    }
    z.finish().map_err(zip_err)
}
