//! [`JsonlStore`]: a JSON-lines file, one store line per text line, with a `.lock` file beside
//! it.

use super::chain::Chain;
use super::{
    encode_sealed, EditedLine, LineReader, Loaded, Record, StoreError, StoreLock, StoredLine,
    TornTail, TrialStore,
};
use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

/// The embedded default store: `PATH` holds the lines, `PATH.lock` the lock (see
/// [`super::StoreLock`]). Lines are written with one `write` of the whole line each (no
/// `fsync`: a killed process loses nothing it was told was stored; a power cut may lose the
/// last lines, never corrupt an earlier one).
#[derive(Debug)]
pub struct JsonlStore {
    path: PathBuf,
    file: File,
    /// Bytes of complete lines: appends go here.
    end: u64,
    /// The file holds bytes after `end` (a torn tail) still to be cut off.
    torn_bytes: u64,
    /// The digest chain after the last complete line (None: not read yet).
    chain: Option<Chain>,
    /// The first line changed after it was written: nothing is appended to such a store.
    edited: Option<EditedLine>,
    _lock: StoreLock,
}

impl JsonlStore {
    /// Locks and opens `path`, creating it if missing.
    pub fn open(path: &Path) -> Result<JsonlStore, StoreError> {
        let shown = path.display().to_string();
        missing_directory(path).map_err(|e| StoreError::io(shown.clone(), e))?;
        let mut lock_name = path.as_os_str().to_owned();
        lock_name.push(".lock");
        let lock = StoreLock::acquire(Path::new(&lock_name), &shown)?;
        let io = |e| StoreError::io(shown.clone(), e);
        let options = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .clone();
        let mut file = super::safe_file::open_no_follow(&options, path).map_err(io)?;
        let len = file.metadata().map_err(io)?.len();
        let end = end_of_last_line(&mut file, len).map_err(io)?;
        if end == 0 && len > 0 {
            not_a_store_to_cut(&mut file).map_err(io)?;
        }
        Ok(JsonlStore {
            path: path.to_path_buf(),
            file,
            end,
            torn_bytes: len - end,
            chain: None,
            edited: None,
            _lock: lock,
        })
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// True when the file holds no complete line.
    pub fn is_empty(&self) -> bool {
        self.end == 0
    }

    fn io(&self, e: std::io::Error) -> StoreError {
        StoreError::io(self.location(), e)
    }

    /// Reads the complete lines of the store at `path` without taking its lock or changing
    /// it (several readers of a finished campaign at once, e.g. `savme estimate`). A torn
    /// last line is reported in [`Loaded::torn`], not cut.
    pub fn read(path: &Path) -> Result<Loaded, StoreError> {
        let location = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|e| StoreError::io(location.clone(), e))?;
        let end = bytes.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        let mut loaded = Loaded::default();
        let mut line = 0u64;
        let mut reader = LineReader::default();
        for text in bytes[..end].split(|&b| b == b'\n') {
            line += 1;
            if text.iter().all(u8::is_ascii_whitespace) {
                continue;
            }
            let value = reader
                .read(line, text)
                .map_err(|message| StoreError::BadLine {
                    store: location.clone(),
                    line,
                    message,
                })?;
            loaded.lines.push(StoredLine { line, value });
        }
        loaded.edited = reader.edited;
        if end < bytes.len() {
            loaded.torn = Some(TornTail {
                line,
                bytes: (bytes.len() - end) as u64,
            });
        }
        Ok(loaded)
    }

    /// The first complete line of the store at `path` (None: the file has none, or does not
    /// exist), read without its lock and checked as [`JsonlStore::read`] checks it (a
    /// changed line is refused, naming it). What a campaign keeps there: its protocol.
    pub fn read_first(path: &Path) -> Result<Option<StoredLine>, StoreError> {
        let location = path.display().to_string();
        let file = match File::open(path) {
            Ok(f) => f,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(StoreError::io(location, e)),
        };
        let mut reader = BufReader::new(file);
        let mut lines = LineReader::default();
        let mut buf = Vec::new();
        let mut line = 0u64;
        loop {
            buf.clear();
            let n = reader
                .read_until(b'\n', &mut buf)
                .map_err(|e| StoreError::io(location.clone(), e))?;
            line += 1;
            let Some(text) = buf.strip_suffix(b"\n") else {
                return Ok(None); // no complete line (n == 0: the end)
            };
            if n == 0 || text.iter().all(u8::is_ascii_whitespace) {
                continue;
            }
            let bad = |message| StoreError::BadLine {
                store: location.clone(),
                line,
                message,
            };
            let value = lines.read(line, text).map_err(bad)?;
            if let Some(e) = lines.edited {
                return Err(bad(e.message));
            }
            return Ok(Some(StoredLine { line, value }));
        }
    }

    /// Cuts a torn tail off, so that the next line starts after the last complete one.
    fn cut_torn_tail(&mut self) -> Result<(), StoreError> {
        if self.torn_bytes > 0 {
            self.file.set_len(self.end).map_err(|e| self.io(e))?;
            self.torn_bytes = 0;
        }
        Ok(())
    }
}

/// Writes `bytes` at `offset` (one `pwrite` on Unix: no seek, no buffering).
fn write_at(file: &File, bytes: &[u8], offset: u64) -> std::io::Result<()> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileExt;
        file.write_all_at(bytes, offset)
    }
    #[cfg(not(unix))]
    {
        use std::io::Write;
        let mut f = file;
        f.seek(SeekFrom::Start(offset))?;
        f.write_all(bytes)
    }
}

/// Refuses a store whose directory does not exist, naming the directory (not the lock file
/// beside the store, the first file opened there).
fn missing_directory(path: &Path) -> std::io::Result<()> {
    match path.parent().filter(|p| !p.as_os_str().is_empty()) {
        Some(dir) if !dir.is_dir() => Err(std::io::Error::new(
            std::io::ErrorKind::NotFound,
            format!("its directory {} does not exist", dir.display()),
        )),
        _ => Ok(()),
    }
}

/// Refuses a file without a complete line whose bytes do not begin a store line (`{`): loading
/// would cut all of it as a torn tail, and savme cuts only what it wrote.
fn not_a_store_to_cut(file: &mut File) -> std::io::Result<()> {
    let mut head = Vec::new();
    file.seek(SeekFrom::Start(0))?;
    file.take(4096).read_to_end(&mut head)?;
    match head.iter().find(|b| !b.is_ascii_whitespace()) {
        Some(b'{') | None => Ok(()),
        Some(_) => Err(super::safe_file::UnsafeFile::NotOurs {
            what: "a store's lines are JSON objects",
        }
        .into()),
    }
}

/// The length of the file's complete lines: the position after its last newline.
fn end_of_last_line(file: &mut File, len: u64) -> std::io::Result<u64> {
    let mut pos = len;
    let mut buf = vec![0u8; 64 * 1024];
    while pos > 0 {
        let n = (buf.len() as u64).min(pos);
        pos -= n;
        file.seek(SeekFrom::Start(pos))?;
        let chunk = &mut buf[..n as usize];
        file.read_exact(chunk)?;
        if let Some(i) = chunk.iter().rposition(|&b| b == b'\n') {
            return Ok(pos + i as u64 + 1);
        }
    }
    Ok(0)
}

impl TrialStore for JsonlStore {
    fn location(&self) -> String {
        self.path.display().to_string()
    }

    fn load(&mut self) -> Result<Loaded, StoreError> {
        self.file.seek(SeekFrom::Start(0)).map_err(|e| self.io(e))?;
        let mut reader = BufReader::new((&self.file).take(self.end));
        let mut loaded = Loaded::default();
        let mut buf = Vec::new();
        let mut line = 0u64;
        let mut lines = LineReader::default();
        loop {
            buf.clear();
            let n = reader
                .read_until(b'\n', &mut buf)
                .map_err(|e| StoreError::io(self.location(), e))?;
            if n == 0 {
                break;
            }
            line += 1;
            let text = buf.strip_suffix(b"\n").unwrap_or(&buf);
            if text.iter().all(u8::is_ascii_whitespace) {
                continue;
            }
            let value = lines
                .read(line, text)
                .map_err(|message| StoreError::BadLine {
                    store: self.location(),
                    line,
                    message,
                })?;
            loaded.lines.push(StoredLine { line, value });
        }
        self.chain = Some(lines.chain);
        self.edited.clone_from(&lines.edited);
        loaded.edited = lines.edited;
        if self.torn_bytes > 0 {
            loaded.torn = Some(TornTail {
                line: line + 1,
                bytes: self.torn_bytes,
            });
            self.cut_torn_tail()?;
        }
        Ok(loaded)
    }

    fn append_all(&mut self, records: &[&dyn Record]) -> Result<(), StoreError> {
        if self.chain.is_none() {
            // The chain continues after the stored lines (read, and checked, once).
            self.load()?;
        }
        if let Some(e) = &self.edited {
            return Err(StoreError::BadLine {
                store: self.location(),
                line: e.line,
                message: e.message.clone(),
            });
        }
        let mut chain = self.chain.unwrap_or_default();
        let mut bytes = Vec::new();
        for record in records {
            encode_sealed(*record, &mut chain, &mut bytes).map_err(|message| {
                StoreError::BadLine {
                    store: self.location(),
                    line: 0,
                    message,
                }
            })?;
        }
        self.cut_torn_tail()?;
        let written = write_at(&self.file, &bytes, self.end);
        match written {
            Ok(()) => {
                self.end += bytes.len() as u64;
                self.chain = Some(chain);
                Ok(())
            }
            // A partial write (e.g. a full disk) must not stay: cut back to where it began.
            Err(write) => match self.file.set_len(self.end) {
                Ok(()) => Err(self.io(write)),
                Err(repair) => Err(StoreError::Damaged {
                    store: self.location(),
                    write,
                    repair,
                }),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;
    use std::io::Write;

    fn temp(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("savme-jsonl-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir.join("store.jsonl")
    }

    #[test]
    fn lines_come_back_in_order_after_reopening() {
        let path = temp("order");
        let mut s = JsonlStore::open(&path).unwrap();
        assert!(s.is_empty());
        for i in 0..5 {
            s.append(&json!({"i": i})).unwrap();
        }
        drop(s);
        let mut s = JsonlStore::open(&path).unwrap();
        let loaded = s.load().unwrap();
        assert_eq!(loaded.torn, None);
        let got: Vec<(u64, i64)> = loaded
            .lines
            .iter()
            .map(|l| (l.line, l.value["i"].as_i64().unwrap()))
            .collect();
        assert_eq!(got, [(1, 0), (2, 1), (3, 2), (4, 3), (5, 4)]);
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.starts_with("{\"v\":1,\"i\":0,\"c\":\""), "{text}");
    }

    #[test]
    fn a_torn_tail_is_reported_dropped_and_overwritten() {
        let path = temp("torn");
        let mut s = JsonlStore::open(&path).unwrap();
        s.append(&json!({"i": 0})).unwrap();
        s.append(&json!({"i": 1})).unwrap();
        drop(s);
        let mut f = OpenOptions::new().append(true).open(&path).unwrap();
        f.write_all(b"{\"v\":1,\"i\":2,\"hal").unwrap(); // 17 bytes
        drop(f);
        // Appending before loading also cuts the tail first.
        let mut s = JsonlStore::open(&path).unwrap();
        let loaded = s.load().unwrap();
        assert_eq!(loaded.lines.len(), 2);
        assert_eq!(loaded.torn, Some(TornTail { line: 3, bytes: 17 }));
        s.append(&json!({"i": 2})).unwrap();
        drop(s);
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text.lines().count(), 3);
        assert!(
            text.lines()
                .last()
                .unwrap()
                .starts_with("{\"v\":1,\"i\":2,\"c\":"),
            "{text}"
        );
    }

    #[test]
    fn a_bad_middle_line_names_the_file_and_line() {
        let path = temp("bad");
        std::fs::write(&path, "{\"a\":1}\n\n{\"a\":\n{\"a\":3}\n").unwrap();
        let mut s = JsonlStore::open(&path).unwrap();
        let e = s.load().unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("{}, line 3: not JSON", path.display())),
            "{e}"
        );
        let mut raw = b"{\"a\":1}\n{\"a\":\"".to_vec();
        raw.extend_from_slice(&[0xff, b'"', b'}', b'\n']);
        drop(s);
        std::fs::write(&path, raw).unwrap();
        let e = JsonlStore::open(&path).unwrap().load().unwrap_err();
        assert!(e.to_string().contains("line 2: not UTF-8"), "{e}");
    }

    #[test]
    fn an_edited_line_is_refused_naming_it_and_a_torn_tail_still_recovers() {
        let path = temp("edited");
        let mut s = JsonlStore::open(&path).unwrap();
        for i in 0..4 {
            s.append(&json!({"i": i, "hf": {"failure": i == 2}}))
                .unwrap();
        }
        drop(s);
        let good = std::fs::read_to_string(&path).unwrap();
        // The failure flag of line 2 edited (false → true on lines 1 and 2, then line 1 put
        // back).
        let edited = good.replacen("\"failure\":false", "\"failure\":true", 2);
        let edited = edited.replacen("\"failure\":true", "\"failure\":false", 1);
        std::fs::write(&path, &edited).unwrap();
        let loaded = JsonlStore::open(&path).unwrap().load().unwrap();
        // Read as it is now (a reader may say what is wrong with it), and refused.
        assert_eq!(
            loaded.lines[1].value,
            json!({"i": 1, "hf": {"failure": true}})
        );
        let shown = path.display().to_string();
        let e = loaded.refuse_edits(&shown).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("{shown}, line 2: its checksum")),
            "{e}"
        );
        // Appending to an edited store is refused, and changes nothing.
        let mut s = JsonlStore::open(&path).unwrap();
        assert!(s.append(&json!({"i": 9})).is_err());
        assert_eq!(std::fs::read_to_string(&path).unwrap(), edited);
        drop(s);
        // A digest removed from an edited line: refused too.
        let mut lines: Vec<String> = good.lines().map(String::from).collect();
        let cut = lines[2].find(",\"c\":").unwrap();
        lines[2] = format!("{}}}", &lines[2][..cut]).replace("true", "false");
        std::fs::write(&path, lines.join("\n") + "\n").unwrap();
        let loaded = JsonlStore::open(&path).unwrap().load().unwrap();
        let e = loaded.refuse_edits("s").unwrap_err().to_string();
        assert!(e.contains("line 3: this line has no checksum"), "{e}");
        // Unchanged lines and a torn tail: the tail dropped, the chain continues.
        std::fs::write(&path, good.clone() + "{\"v\":1,\"i\":4,\"h").unwrap();
        let mut s = JsonlStore::open(&path).unwrap();
        let loaded = s.load().unwrap();
        assert_eq!((loaded.lines.len(), loaded.torn.is_some()), (4, true));
        assert_eq!(
            loaded.lines[2].value,
            json!({"i": 2, "hf": {"failure": true}})
        );
        s.append(&json!({"i": 4})).unwrap();
        drop(s);
        let loaded = JsonlStore::read(&path).unwrap();
        assert_eq!(loaded.lines.len(), 5);
    }

    #[test]
    fn a_store_without_checksums_still_loads_and_continues_with_them() {
        let path = temp("old");
        std::fs::write(&path, "{\"v\":1,\"i\":0}\n{\"i\":1}\n").unwrap();
        let mut s = JsonlStore::open(&path).unwrap();
        assert_eq!(s.load().unwrap().lines.len(), 2);
        s.append(&json!({"i": 2})).unwrap();
        drop(s);
        let loaded = JsonlStore::read(&path).unwrap();
        let got: Vec<i64> = loaded
            .lines
            .iter()
            .map(|l| l.value["i"].as_i64().unwrap())
            .collect();
        assert_eq!(got, [0, 1, 2]);
        // An old line edited after the chain began: found at the first line with a digest.
        let text = std::fs::read_to_string(&path)
            .unwrap()
            .replace("\"i\":1}", "\"i\":7}");
        std::fs::write(&path, text).unwrap();
        let loaded = JsonlStore::read(&path).unwrap();
        let e = loaded.refuse_edits("s").unwrap_err().to_string();
        assert!(
            e.contains("line 3: its checksum") && e.contains("one of lines 1–2"),
            "{e}"
        );
    }

    #[test]
    fn the_first_line_is_read_alone_and_checked() {
        let path = temp("first");
        assert_eq!(JsonlStore::read_first(&path).unwrap(), None);
        std::fs::write(&path, "{\"v\":1,\"a\":").unwrap();
        assert_eq!(JsonlStore::read_first(&path).unwrap(), None); // torn: no complete line
        std::fs::write(&path, "").unwrap();
        let mut s = JsonlStore::open(&path).unwrap();
        s.append(&json!({"protocol": {"seed": 7}})).unwrap();
        s.append(&json!({"i": 1})).unwrap();
        drop(s);
        let first = JsonlStore::read_first(&path).unwrap().unwrap();
        assert_eq!(
            (first.line, first.value),
            (1, json!({"protocol": {"seed": 7}}))
        );
        let text = std::fs::read_to_string(&path).unwrap();
        std::fs::write(&path, text.replacen("7", "8", 1)).unwrap();
        let e = JsonlStore::read_first(&path).unwrap_err().to_string();
        assert!(e.contains("line 1: its checksum"), "{e}");
        std::fs::write(&path, "\n{\"a\":1}\n").unwrap();
        assert_eq!(JsonlStore::read_first(&path).unwrap().unwrap().line, 2);
    }

    #[test]
    fn a_second_opener_is_refused_and_changes_nothing() {
        let path = temp("second");
        let mut s = JsonlStore::open(&path).unwrap();
        s.append(&json!({"i": 0})).unwrap();
        let before = std::fs::read(&path).unwrap();
        let e = JsonlStore::open(&path).unwrap_err();
        match &e {
            StoreError::Locked { store, holder } => {
                assert_eq!(store, &path.display().to_string());
                assert_eq!(*holder, Some(std::process::id()));
            }
            other => panic!("expected Locked, got {other:?}"),
        }
        assert_eq!(std::fs::read(&path).unwrap(), before);
        drop(s);
        assert!(JsonlStore::open(&path).is_ok());
    }
}
