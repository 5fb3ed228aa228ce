//! The exclusive advisory lock a store holds for its lifetime: `flock` on a `.lock` file next to
//! the store (released by the operating system when the holder exits, even after `kill -9`),
//! holding the holder's process id so that a refused second process can name it.
//!
//! The lock is released explicitly when the store is dropped, not only by closing the file: a
//! child process forked by another thread at that instant shares the open file (until its exec
//! closes it), and a lock left to the close would outlive the store there — the store's next
//! opener in this process was then refused as "already open in this process".

use super::StoreError;
use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// An exclusive lock, held until dropped.
#[derive(Debug)]
pub struct StoreLock {
    _file: File,
    path: PathBuf,
}

impl StoreLock {
    /// Takes the lock file at `path` for `store` (named in errors), or fails at once with
    /// [`StoreError::Locked`] naming the holder's pid.
    ///
    /// ```
    /// use savme_store::StoreLock;
    /// let path = std::env::temp_dir().join(format!("savme-lock-doc-{}.lock", std::process::id()));
    /// let held = StoreLock::acquire(&path, "demo")?;
    /// let refused = StoreLock::acquire(&path, "demo").unwrap_err();
    /// assert!(refused.to_string().contains(&format!("pid {}", std::process::id())));
    /// drop(held);
    /// assert!(StoreLock::acquire(&path, "demo").is_ok());
    /// # std::fs::remove_file(&path)?;
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn acquire(path: &Path, store: &str) -> Result<StoreLock, StoreError> {
        let io = |e| StoreError::io(path.display().to_string(), e);
        let options = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .clone();
        let mut file = super::safe_file::open_no_follow(&options, path).map_err(io)?;
        match file.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                return Err(StoreError::Locked {
                    store: store.to_string(),
                    holder: holder_pid(&mut file),
                });
            }
            Err(TryLockError::Error(e)) => return Err(io(e)),
        }
        only_a_pid(&mut file).map_err(io)?;
        file.set_len(0).map_err(io)?;
        file.write_all(format!("{}\n", std::process::id()).as_bytes())
            .map_err(io)?;
        Ok(StoreLock {
            _file: file,
            path: path.to_path_buf(),
        })
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for StoreLock {
    fn drop(&mut self) {
        // `flock` belongs to the open file, which a child forked at this moment shares until
        // its exec: unlock it for all of them (the module docs). An error leaves it to close.
        let _ = self._file.unlock();
    }
}

/// The pid in a held lock file. The holder writes it just after taking the lock: a second
/// process racing it (two `--resume` at once) waits up to 200 ms for it rather than say "pid
/// unknown".
fn holder_pid(file: &mut File) -> Option<u32> {
    for _ in 0..20 {
        let mut text = String::new();
        let read = file
            .seek(SeekFrom::Start(0))
            .and_then(|_| file.read_to_string(&mut text));
        if let Some(pid) = read.ok().and_then(|_| text.trim().parse().ok()) {
            return Some(pid);
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    None
}

/// Refuses a lock file holding anything but a process id (what savme writes there): savme
/// truncates only a lock file it wrote.
fn only_a_pid(file: &mut File) -> std::io::Result<()> {
    let mut bytes = Vec::new();
    Read::by_ref(file).take(64).read_to_end(&mut bytes)?;
    let text = String::from_utf8_lossy(&bytes);
    let pid = text.trim();
    if bytes.len() < 64 && (pid.is_empty() || pid.parse::<u32>().is_ok()) {
        file.seek(SeekFrom::Start(0))?;
        return Ok(());
    }
    Err(super::safe_file::UnsafeFile::NotOurs {
        what: "a lock file holds only the pid of the savme process that holds it",
    }
    .into())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two `--resume` at once: the loser reads the lock file before the winner wrote its pid.
    #[test]
    fn a_racing_second_opener_waits_for_the_holders_pid() {
        let path =
            std::env::temp_dir().join(format!("savme-lock-race-{}.lock", std::process::id()));
        let _ = std::fs::remove_file(&path);
        let holder = File::create(&path).unwrap();
        holder.try_lock().unwrap();
        let writer = {
            let mut f = holder.try_clone().unwrap();
            std::thread::spawn(move || {
                std::thread::sleep(std::time::Duration::from_millis(50));
                f.write_all(b"4242\n").unwrap();
            })
        };
        let e = StoreLock::acquire(&path, "demo").unwrap_err();
        writer.join().unwrap();
        assert!(e.to_string().contains("pid 4242"), "{e}");
        drop(holder);
        let _ = std::fs::remove_file(&path);
    }

    /// A child process forked (by another thread) while a store is open keeps a copy of the
    /// lock's file until its exec: the store dropped in that window must still be free to
    /// open again at once (it was refused as "already open in this process").
    #[cfg(unix)]
    #[test]
    fn a_dropped_lock_is_free_while_a_forked_child_still_holds_its_file() {
        use std::os::unix::process::CommandExt;
        let path =
            std::env::temp_dir().join(format!("savme-lock-fork-{}.lock", std::process::id()));
        let _ = std::fs::remove_file(&path);
        let held = StoreLock::acquire(&path, "demo").unwrap();
        let (mut ready, forked) = std::io::pipe().unwrap();
        let spawner = std::thread::spawn(move || {
            let mut child = std::process::Command::new("true");
            // SAFETY: write(2) and nanosleep(2) only, async-signal-safe, between fork and exec.
            unsafe {
                child.pre_exec(move || {
                    use std::os::fd::AsRawFd;
                    libc::write(forked.as_raw_fd(), b"f".as_ptr().cast(), 1);
                    let pause = libc::timespec {
                        tv_sec: 1,
                        tv_nsec: 0,
                    };
                    libc::nanosleep(&pause, std::ptr::null_mut());
                    Ok(())
                });
            }
            child.status().unwrap()
        });
        // The child exists (forked, holding every open file) and has not exec'd yet.
        let mut byte = [0u8; 1];
        ready.read_exact(&mut byte).unwrap();
        drop(held);
        let again = StoreLock::acquire(&path, "demo");
        assert!(again.is_ok(), "{:?}", again.err().map(|e| e.to_string()));
        drop(again);
        assert!(spawner.join().unwrap().success());
        let _ = std::fs::remove_file(&path);
    }
}
