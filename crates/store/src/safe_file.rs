//! Opening the files savme writes into a user's directory (lock files, stores, `protocol.json`,
//! reports, figures) so that it never writes through a symbolic link onto another file, never
//! writes into a FIFO or device, and never writes a file other names share (a hard link): such a
//! path is refused, naming it, before a byte changes. A path whose last component is a symbolic
//! link is refused by the operating system (`O_NOFOLLOW`), not by a check that could race.
//!
//! ```
//! use savme_store::safe_file;
//! let dir = std::env::temp_dir().join(format!("savme-safe-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir)?;
//! let decoy = dir.join("decoy.txt");
//! std::fs::write(&decoy, "precious")?;
//! # #[cfg(unix)] {
//! std::os::unix::fs::symlink(&decoy, dir.join("table.md"))?;
//! let e = safe_file::write_file(&dir.join("table.md"), b"report").unwrap_err();
//! assert!(e.to_string().contains("symbolic link"));
//! assert_eq!(std::fs::read_to_string(&decoy)?, "precious");
//! # }
//! # std::fs::remove_dir_all(&dir)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::fs::{File, OpenOptions};
use std::io::{self, Write};
use std::path::Path;

/// Why savme refuses to write a path. Carried inside an [`io::Error`] (kind `Other`), so that
/// every caller's error names the path as it does for any I/O error.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum UnsafeFile {
    /// The path is a symbolic link.
    #[error("is a symbolic link; savme does not write through a link (it may point at another file): remove the link, or choose another path")]
    Symlink,
    /// The path is a directory, FIFO, socket or device.
    #[error("is not a regular file ({kind}); savme writes only regular files: remove it, or choose another path")]
    NotRegular {
        /// What it is.
        kind: &'static str,
    },
    /// The file has other names (hard links).
    #[error("has {links} names (hard links); savme does not write a file other names share: remove the other names, or choose another path")]
    HardLinked {
        /// Its number of names.
        links: u64,
    },
    /// A directory savme would create is a symbolic link to a path that does not exist.
    #[error("is a symbolic link to {target}, which does not exist; savme does not create a directory through a link: create {target}, remove the link, or choose another directory")]
    DanglingLink {
        /// Where the link points.
        target: String,
    },
    /// The file holds data savme did not write there.
    #[error("holds data savme did not write ({what}); it was left unchanged: move it away, or choose another path")]
    NotOurs {
        /// What savme expected.
        what: &'static str,
    },
}

impl From<UnsafeFile> for io::Error {
    fn from(e: UnsafeFile) -> io::Error {
        io::Error::other(e)
    }
}

/// Opens `path` with `options`, never following a symbolic link in its last component, and
/// checks that what was opened is a regular file with no other name. `options` should not
/// truncate: a refused file must stay unchanged (use [`write_file`] to replace a file).
pub fn open_no_follow(options: &OpenOptions, path: &Path) -> io::Result<File> {
    let mut options = options.clone();
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        // O_NONBLOCK: opening a FIFO must not hang (it is refused below); no effect on files.
        options.custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK);
    }
    let file = match options.open(path) {
        Ok(file) => file,
        Err(e) => return Err(refusal(path).map_or(e, io::Error::from)),
    };
    check_opened(&file)?;
    Ok(file)
}

/// Why `path` would be refused as it stands now, if it would.
fn refusal(path: &Path) -> Option<UnsafeFile> {
    let meta = std::fs::symlink_metadata(path).ok()?;
    if meta.file_type().is_symlink() {
        return Some(UnsafeFile::Symlink);
    }
    check_metadata(&meta).err()
}

fn check_opened(file: &File) -> io::Result<()> {
    let meta = file.metadata()?;
    check_metadata(&meta).map_err(io::Error::from)
}

fn check_metadata(meta: &std::fs::Metadata) -> Result<(), UnsafeFile> {
    let kind = meta.file_type();
    if !kind.is_file() {
        let kind = if kind.is_dir() {
            "a directory"
        } else {
            "a FIFO, socket or device"
        };
        return Err(UnsafeFile::NotRegular { kind });
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if meta.nlink() > 1 {
            return Err(UnsafeFile::HardLinked {
                links: meta.nlink(),
            });
        }
    }
    Ok(())
}

/// Refuses a directory path that is a dangling symbolic link (creating the directory would fail
/// with "File exists" and name nothing), naming where it points.
pub fn dangling_link(dir: &Path) -> io::Result<()> {
    let meta = match std::fs::symlink_metadata(dir) {
        Ok(meta) => meta,
        Err(_) => return Ok(()),
    };
    if meta.file_type().is_symlink() && !dir.exists() {
        let target = std::fs::read_link(dir).map(|t| t.display().to_string());
        return Err(UnsafeFile::DanglingLink {
            target: target.unwrap_or_else(|_| "a missing path".into()),
        }
        .into());
    }
    Ok(())
}

/// Writes `bytes` as the whole content of `path` (created if missing), through
/// [`open_no_follow`]: a symbolic link, a non-regular file or a hard-linked file at `path` is
/// refused and left unchanged.
pub fn write_file(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let mut file = open_no_follow(OpenOptions::new().write(true).create(true), path)?;
    file.set_len(0)?;
    file.write_all(bytes)
}

/// Lets `write` create the file at `path` by its own means (a library that opens the path
/// itself, e.g. the figures' PNG encoder) without following a link: `write` is handed a fresh
/// file name beside `path` that savme created exclusively, and the result is renamed onto
/// `path` (replacing the name, never writing into what it points at). An unsafe `path` is
/// refused first, as [`open_no_follow`] would.
pub fn write_via_fresh_file<E>(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), E>,
    io_error: impl Fn(io::Error) -> E,
) -> Result<(), E> {
    if let Some(e) = refusal(path) {
        return Err(io_error(e.into()));
    }
    let fresh = fresh_name(path);
    let created = open_no_follow(OpenOptions::new().write(true).create_new(true), &fresh);
    drop(created.map_err(&io_error)?);
    let written = write(&fresh).and_then(|()| std::fs::rename(&fresh, path).map_err(&io_error));
    if written.is_err() {
        let _ = std::fs::remove_file(&fresh);
    }
    written
}

/// `DIR/.NAME.savme-PID-N.EXT` beside `path` (the same extension: encoders choose by it).
fn fresh_name(path: &Path) -> std::path::PathBuf {
    use std::sync::atomic::{AtomicU64, Ordering};
    static COUNT: AtomicU64 = AtomicU64::new(0);
    let n = COUNT.fetch_add(1, Ordering::Relaxed);
    let name = path.file_name().map(|s| s.to_string_lossy().into_owned());
    let ext = path.extension().map(|s| s.to_string_lossy().into_owned());
    let fresh = format!(
        ".{}.savme-{}-{n}.{}",
        name.unwrap_or_default(),
        std::process::id(),
        ext.unwrap_or_else(|| "tmp".into())
    );
    path.with_file_name(fresh)
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;
    use std::os::unix::fs::symlink;

    fn dir(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("savme-safe-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn links_fifos_and_shared_files_are_refused_and_left_unchanged() {
        let d = dir("refuse");
        let decoy = d.join("decoy.txt");
        std::fs::write(&decoy, "precious").unwrap();
        symlink(&decoy, d.join("link")).unwrap();
        symlink(d.join("nowhere"), d.join("dangling")).unwrap();
        std::fs::hard_link(&decoy, d.join("hard")).unwrap();
        let rw = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .clone();
        for (name, needle) in [
            ("link", "symbolic link"),
            ("dangling", "symbolic link"),
            ("hard", "2 names"),
        ] {
            let path = d.join(name);
            let e = open_no_follow(&rw, &path).unwrap_err();
            assert!(e.to_string().contains(needle), "{name}: {e}");
            let e = write_file(&path, b"x").unwrap_err();
            assert!(e.to_string().contains(needle), "{name}: {e}");
            let e = write_via_fresh_file(&path, |p| std::fs::write(p, "x"), |e| e).unwrap_err();
            assert!(e.to_string().contains(needle), "{name}: {e}");
        }
        let e = write_file(&d, b"x").unwrap_err();
        assert!(e.to_string().contains("a directory"), "{e}");
        assert_eq!(std::fs::read_to_string(&decoy).unwrap(), "precious");
        assert!(!d.join("nowhere").exists());
        // A FIFO is refused at once (the open does not wait for a writer).
        let fifo = d.join("fifo");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if made.is_ok_and(|s| s.success()) {
            let e = write_file(&fifo, b"x").unwrap_err();
            assert!(e.to_string().contains("FIFO"), "{e}");
        }
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn regular_files_are_written_and_replaced_whole() {
        let d = dir("write");
        let path = d.join("table.md");
        write_file(&path, b"a long first text").unwrap();
        write_file(&path, b"short").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "short");
        let png = d.join("figure.png");
        write_via_fresh_file(&png, |p| std::fs::write(p, "png"), |e| e).unwrap();
        write_via_fresh_file(&png, |p| std::fs::write(p, "png2"), |e| e).unwrap();
        assert_eq!(std::fs::read_to_string(&png).unwrap(), "png2");
        let failed: Result<(), io::Error> =
            write_via_fresh_file(&png, |_| Err(io::Error::other("no")), |e| e);
        assert!(failed.is_err());
        let names: Vec<_> = std::fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 2, "no fresh file left behind: {names:?}");
        let _ = std::fs::remove_dir_all(&d);
    }
}
