//! # savme-store
//!
//! Where a campaign's trial lines (and `savme serve`'s journal events) live: the
//! [`TrialStore`] trait, and [`JsonlStore`], the embedded default — a JSON-lines file with an
//! exclusive advisory lock.
//!
//! A store is an append-only sequence of JSON objects ("lines"). It promises:
//! - **one writer**: opening a store takes an exclusive lock for as long as the store lives; a
//!   second process opening the same store is refused at once, naming the store and the
//!   holder's process id, and changes nothing;
//! - **crash safety**: [`TrialStore::append`] returns only once the line is handed to the
//!   operating system whole; a process killed mid-write leaves at most one incomplete last line,
//!   which [`TrialStore::load`] reports ([`Loaded::torn`]) and drops, and later appends go after
//!   the last complete line;
//! - **versioned lines**: every line carries the store format version (`"v"`), checked on load;
//! - **edits are found** ([`JsonlStore`]): every line ends with a digest chained over the lines
//!   before it ([`chain`]); a complete line changed after it was written is refused on load,
//!   naming the line.
//!
//! ```
//! use savme_store::{JsonlStore, TrialStore};
//! let dir = std::env::temp_dir().join(format!("savme-store-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir)?;
//! let path = dir.join("trials.jsonl");
//! # let _ = std::fs::remove_file(&path);
//! let mut store = JsonlStore::open(&path)?;
//! store.append(&serde_json::json!({"stage": "train@0.3", "index": 0}))?;
//! // A second opener (here in the same process; normally another one) is refused.
//! assert!(JsonlStore::open(&path).is_err());
//! let loaded = store.load()?;
//! assert_eq!(loaded.lines[0].value["stage"], "train@0.3");
//! # drop(store); std::fs::remove_dir_all(&dir)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod chain;
pub mod journal;
mod jsonl;
mod lock;
pub mod safe_file;

pub use jsonl::JsonlStore;
pub use lock::StoreLock;

use serde_json::Value;

/// The store format version every line carries (key `"v"`). Lines written before versions
/// existed (no `"v"`) are read as version 1, the format they have.
pub const FORMAT: u64 = 1;

/// What a store appends: any serialisable value whose JSON is an object (a campaign's trial
/// line, an estimate's line, a kernel's journal event). The store serialises it once, when it
/// writes it; a store that files records of types it knows in columns (a database) sees the
/// record's type through [`Record::as_any`] and reads its fields, never its text.
///
/// ```
/// use savme_store::Record;
/// #[derive(serde::Serialize)]
/// struct Seen { stage: &'static str, index: u64 }
/// let record: &dyn Record = &Seen { stage: "train@0.3", index: 0 };
/// assert_eq!(record.object()?, br#""stage":"train@0.3","index":0"#);
/// assert!(record.as_any().downcast_ref::<Seen>().is_some());
/// # Ok::<(), String>(())
/// ```
pub trait Record: std::any::Any {
    /// The record's keys and values: its JSON object without the braces (empty for `{}`).
    /// The error says why it is no store line (not an object, a `v` key of its own, not
    /// serialisable).
    fn object(&self) -> Result<Vec<u8>, String>;

    /// The record itself, for a store that reads the fields of the types it knows.
    fn as_any(&self) -> &dyn std::any::Any;
}

impl<T: serde::Serialize + std::any::Any> Record for T {
    fn object(&self) -> Result<Vec<u8>, String> {
        if let Some(Value::Object(map)) = (self as &dyn std::any::Any).downcast_ref::<Value>() {
            if map.contains_key("v") {
                return Err("a store line must be a JSON object without a `v` key".into());
            }
        }
        let text =
            serde_json::to_vec(self).map_err(|e| format!("not serialisable as JSON: {e}"))?;
        match text.strip_prefix(b"{").and_then(|t| t.strip_suffix(b"}")) {
            Some(inner) => Ok(inner.to_vec()),
            None => Err("a store line must be a JSON object".into()),
        }
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}

/// `items` as records, for [`TrialStore::append_all`].
///
/// ```
/// use savme_store::{records, JsonlStore, TrialStore};
/// # let dir = std::env::temp_dir().join(format!("savme-records-doc-{}", std::process::id()));
/// # std::fs::create_dir_all(&dir)?;
/// # let _ = std::fs::remove_file(dir.join("t.jsonl"));
/// let mut store = JsonlStore::open(&dir.join("t.jsonl"))?;
/// let lines = [serde_json::json!({"i": 0}), serde_json::json!({"i": 1})];
/// store.append_all(&records(&lines))?;
/// assert_eq!(store.load()?.lines.len(), 2);
/// # drop(store); std::fs::remove_dir_all(&dir)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn records<T: Record>(items: &[T]) -> Vec<&dyn Record> {
    items.iter().map(|r| r as &dyn Record).collect()
}

/// One complete line read back.
#[derive(Debug, Clone, PartialEq)]
pub struct StoredLine {
    /// Its 1-based position in the store (the file's line number).
    pub line: u64,
    /// The object, without the `"v"` key.
    pub value: Value,
}

/// An incomplete last line left by a process killed mid-write; dropped by [`TrialStore::load`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TornTail {
    /// Its 1-based line number.
    pub line: u64,
    /// Its length in bytes.
    pub bytes: u64,
}

/// What [`TrialStore::load`] found.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Loaded {
    /// The complete lines, in order.
    pub lines: Vec<StoredLine>,
    /// The incomplete last line that was dropped, if any.
    pub torn: Option<TornTail>,
    /// The first complete line changed after it was written (its checksum does not match, or
    /// it lost its checksum: [`chain`]), if any. Its line is in [`Loaded::lines`] as it reads
    /// now, so that a reader that can say which field is wrong (a campaign's replay) says so
    /// first; every reader then calls [`Loaded::refuse_edits`].
    pub edited: Option<EditedLine>,
}

/// A line changed after savme wrote it ([`Loaded::edited`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EditedLine {
    /// 1-based line.
    pub line: u64,
    /// What is wrong and what to do.
    pub message: String,
}

impl Loaded {
    /// An error naming `store` and the first edited line, if a line was edited.
    ///
    /// ```
    /// use savme_store::{EditedLine, Loaded};
    /// let mut loaded = Loaded::default();
    /// assert!(loaded.refuse_edits("t.jsonl").is_ok());
    /// loaded.edited = Some(EditedLine { line: 3, message: "changed".into() });
    /// assert_eq!(loaded.refuse_edits("t.jsonl").unwrap_err().to_string(), "t.jsonl, line 3: changed");
    /// ```
    pub fn refuse_edits(&self, store: &str) -> Result<(), StoreError> {
        match &self.edited {
            Some(e) => Err(StoreError::BadLine {
                store: store.to_string(),
                line: e.line,
                message: e.message.clone(),
            }),
            None => Ok(()),
        }
    }
}

/// Why a store could not be opened, read or written. Every variant names the store.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StoreError {
    /// Reading or writing failed.
    #[error("{store}: {source}")]
    Io {
        /// The store.
        store: String,
        /// The error.
        source: std::io::Error,
    },
    /// Another process holds the store.
    #[error("{store} is {}; it was left unchanged — {}", held_by(*holder), if *holder == Some(std::process::id()) { "close() or drop the one that holds it first" } else { "wait for that process, or stop it" })]
    Locked {
        /// The store.
        store: String,
        /// The holder's process id, when it could be read.
        holder: Option<u32>,
    },
    /// Another process holds the campaign in a shared database.
    #[error("{store} is in use by another savme coordinator ({holder}); it was left unchanged — wait for that process, or stop it")]
    Held {
        /// The store.
        store: String,
        /// Who holds it, as the database shows it.
        holder: String,
    },
    /// The database refused a connection or a statement (the text never holds a password).
    #[error("{store}: {message}")]
    Database {
        /// The store (or the flag that named it).
        store: String,
        /// What the database said.
        message: String,
    },
    /// A complete line that is not a JSON object of a supported format.
    #[error("{store}, line {line}: {message}")]
    BadLine {
        /// The store.
        store: String,
        /// 1-based line.
        line: u64,
        /// What is wrong.
        message: String,
    },
    /// A write failed and the store could not be cut back to its last complete line: it
    /// needs attention before it is used again.
    #[error("{store}: writing failed ({write}) and the partial line could not be removed ({repair}); remove the bytes after the last newline before resuming")]
    Damaged {
        /// The store.
        store: String,
        /// The write error.
        write: std::io::Error,
        /// The repair error.
        repair: std::io::Error,
    },
}

/// Who holds a locked store, for [`StoreError::Locked`]: this very process (a second opener in
/// it, e.g. a second Python `Kernel` on one journal), another process, or one not known.
fn held_by(holder: Option<u32>) -> String {
    match holder {
        Some(p) if p == std::process::id() => {
            format!("already open in this process (pid {p}): a store has one writer")
        }
        Some(p) => format!("in use by another savme process (pid {p})"),
        None => "in use by another savme process (pid unknown)".into(),
    }
}

impl StoreError {
    /// The I/O error of `store`.
    pub fn io(store: impl Into<String>, source: std::io::Error) -> Self {
        StoreError::Io {
            store: store.into(),
            source,
        }
    }
}

/// An append-only, exclusively held sequence of JSON objects: a campaign's trials or a served
/// kernel's journal. Implementations take their exclusive lock when opened and release it when
/// dropped (see the module docs for what every store promises).
pub trait TrialStore: Send {
    /// Where the store is, for messages (a path; never a credential).
    fn location(&self) -> String;

    /// Reads every complete line back, in order. An incomplete last line is dropped (and
    /// reported); later appends go after the last complete line.
    fn load(&mut self) -> Result<Loaded, StoreError>;

    /// Appends records as lines, all or none, durably (handed whole to the operating system)
    /// before returning. The store serialises each record once ([`Record`]), adding the
    /// format version (`"v"`, first) and, in a JSON-lines file, the chained digest (`"c"`,
    /// last). On an error nothing was appended. (One exception, documented where it is made: a
    /// PostgreSQL store whose campaign runs through its work queue commits the lines with the
    /// queue's next batch, in one transaction.)
    fn append_all(&mut self, records: &[&dyn Record]) -> Result<(), StoreError>;

    /// Appends one record as a line ([`TrialStore::append_all`] of one).
    fn append(&mut self, record: &dyn Record) -> Result<(), StoreError> {
        self.append_all(&[record])
    }

    /// The store's [`ProtocolKeeper`] capability, if it keeps a campaign's protocol apart from
    /// its lines (a database does, in its campaign row). Default: none — a campaign then
    /// stores its protocol as the store's first record.
    fn protocol_keeper(&mut self) -> Option<&mut dyn ProtocolKeeper> {
        None
    }
}

/// An optional capability of a [`TrialStore`] ([`TrialStore::protocol_keeper`]): it keeps the
/// campaign's protocol apart from its lines.
pub trait ProtocolKeeper {
    /// The protocol kept, if the store has been given one.
    fn load_protocol(&mut self) -> Result<Option<Value>, StoreError>;

    /// Keeps `protocol`.
    fn save_protocol(&mut self, protocol: &Value) -> Result<(), StoreError>;
}

impl<T: TrialStore + ?Sized> TrialStore for Box<T> {
    fn location(&self) -> String {
        (**self).location()
    }

    fn load(&mut self) -> Result<Loaded, StoreError> {
        (**self).load()
    }

    fn append_all(&mut self, records: &[&dyn Record]) -> Result<(), StoreError> {
        (**self).append_all(records)
    }

    fn protocol_keeper(&mut self) -> Option<&mut dyn ProtocolKeeper> {
        (**self).protocol_keeper()
    }
}

/// A record as a line: `{"v":FORMAT,` followed by the record's own keys, then the digest
/// `"c"` that `chain` gives it, appended to `out`.
pub(crate) fn encode_sealed(
    record: &dyn Record,
    chain: &mut chain::Chain,
    out: &mut Vec<u8>,
) -> Result<(), String> {
    let mut line = Vec::new();
    encode(record, &mut line)?;
    line.truncate(line.len() - 2); // `}\n`
    chain.seal(&mut line);
    out.extend_from_slice(&line);
    out.push(b'\n');
    Ok(())
}

/// Reads a store's complete lines in order, checking the digest chain ([`chain`]).
#[derive(Debug, Default)]
pub(crate) struct LineReader {
    pub(crate) chain: chain::Chain,
    /// The last line with a digest, and whether the previous non-blank line had one.
    last_sealed: Option<u64>,
    previous_sealed: bool,
    previous: Option<u64>,
    /// The previous non-blank line's text (a repeated line is named as a copy).
    previous_text: Vec<u8>,
    /// The first line whose checksum failed.
    pub(crate) edited: Option<EditedLine>,
}

impl LineReader {
    /// Line `line` (1-based; its text without the newline) as its object; the error says
    /// what is wrong (the caller names the store and line). A line whose checksum fails is
    /// read all the same and kept in [`LineReader::edited`] (the first one).
    pub(crate) fn read(&mut self, line: u64, text: &[u8]) -> Result<Value, String> {
        let checked = self.chain.check(text);
        let body = match checked {
            chain::ChainCheck::Sealed { body } | chain::ChainCheck::Mismatch { body } => body,
            _ => text.len(),
        };
        let mut value = if body == text.len() {
            decode(text)?
        } else {
            let mut object = text[..body].to_vec();
            object.push(b'}');
            decode(&object)?
        };
        // A line that still has its digest, but not where and as savme writes it: another
        // JSON writer re-serialised it (keys reordered, spacing or numbers changed).
        let rewritten = matches!(
            checked,
            chain::ChainCheck::Missing | chain::ChainCheck::Unsealed
        ) && value
            .as_object_mut()
            .is_some_and(|m| m.get("c").is_some_and(is_digest) && m.remove("c").is_some());
        let verdict = if rewritten {
            self.previous = Some(line);
            self.previous_sealed = true;
            Err(format!(
                "this line was rewritten after savme wrote it: it keeps its checksum (`\"c\"`), but not the bytes savme wrote (keys reordered, spacing or number format changed, e.g. by another JSON writer), so its checksum no longer matches. savme checks the line as it wrote it, not its values as another tool re-serialised them; restore the line (from a copy), or cut the store back to line {} and resume to run the rest again",
                line - 1
            ))
        } else {
            self.checked(line, checked, text)
        };
        if let Err(message) = verdict {
            self.edited.get_or_insert(EditedLine { line, message });
        }
        self.previous_text.clear();
        self.previous_text.extend_from_slice(text);
        Ok(value)
    }

    /// What the chain says of line `line`.
    fn checked(
        &mut self,
        line: u64,
        checked: chain::ChainCheck,
        text: &[u8],
    ) -> Result<(), String> {
        use chain::ChainCheck;
        let previous = self.previous.replace(line);
        let previous_sealed = std::mem::replace(
            &mut self.previous_sealed,
            matches!(
                checked,
                ChainCheck::Sealed { .. } | ChainCheck::Mismatch { .. }
            ),
        );
        match checked {
            ChainCheck::Sealed { .. } => {
                self.last_sealed = Some(line);
                Ok(())
            }
            ChainCheck::Unsealed => Ok(()),
            ChainCheck::Missing => Err(format!(
                "this line has no checksum (`\"c\"`), but line {} before it has one: savme ends every line it writes with one, so this line was changed or added after savme wrote the file; restore it (or cut the store back to line {})",
                self.last_sealed.unwrap_or(0),
                line - 1
            )),
            ChainCheck::Mismatch { .. } => {
                let what = match (previous_sealed, previous) {
                    (true, Some(p)) if text == self.previous_text.as_slice() => format!(
                        "this line repeats line {p} (a copy of it was added after savme wrote the file); remove it"
                    ),
                    (true, _) | (false, None) => "this line was changed after savme wrote it, or a line just before it was deleted (the chain links each line to the one before it)".to_string(),
                    (false, Some(p)) => format!(
                        "this line, or one of lines 1–{p} before it (written without checksums by an earlier savme), was changed after savme wrote it"
                    ),
                };
                Err(format!(
                    "its checksum (`\"c\"`) does not match: {what}. A told trial cannot be recomputed, so savme refuses to resume from an edited store; restore the line (from a copy), or cut the store back to line {} and resume to run the rest again",
                    line - 1
                ))
            }
        }
    }
}

/// True for a digest as savme writes it: a string of 16 hex digits.
fn is_digest(c: &Value) -> bool {
    c.as_str()
        .is_some_and(|s| s.len() == 16 && s.bytes().all(|b| b.is_ascii_hexdigit()))
}

/// A record as a line: `{"v":FORMAT,` followed by the record's own keys, appended to `out`.
pub(crate) fn encode(record: &dyn Record, out: &mut Vec<u8>) -> Result<(), String> {
    let object = record.object()?;
    out.extend_from_slice(format!("{{\"v\":{FORMAT}").as_bytes());
    if !object.is_empty() {
        out.push(b',');
    }
    out.extend_from_slice(&object);
    out.extend_from_slice(b"}\n");
    Ok(())
}

/// A complete line (without its newline) back to its object; the error says what is wrong.
pub(crate) fn decode(bytes: &[u8]) -> Result<Value, String> {
    let text = std::str::from_utf8(bytes)
        .map_err(|e| format!("not UTF-8 text (byte {})", e.valid_up_to() + 1))?;
    let mut value: Value = serde_json::from_str(text).map_err(|e| format!("not JSON: {e}"))?;
    let Value::Object(map) = &mut value else {
        return Err("not a JSON object".into());
    };
    match map.remove("v") {
        None => {}
        Some(Value::Number(n)) if n.as_u64() == Some(FORMAT) => {}
        Some(other) => {
            return Err(format!(
                "store format version {other} is not supported (this savme reads version {FORMAT})"
            ))
        }
    }
    Ok(value)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn lines_carry_the_format_version_first_and_round_trip() {
        let v = json!({"stage": "train@0.3", "x": [1.5, null]});
        let mut line = Vec::new();
        encode(&v, &mut line).unwrap();
        assert!(line.starts_with(b"{\"v\":1,\"stage\""));
        assert_eq!(decode(&line[..line.len() - 1]).unwrap(), v);
        let mut empty = Vec::new();
        encode(&json!({}), &mut empty).unwrap();
        assert_eq!(empty, b"{\"v\":1}\n");
        assert_eq!(decode(b"{\"a\":1}").unwrap(), json!({"a": 1}));
    }

    #[test]
    fn bad_lines_say_what_is_wrong() {
        assert!(encode(&json!([1]), &mut Vec::new()).is_err());
        assert!(encode(&json!({"v": 2}), &mut Vec::new()).is_err());
        // A string with a newline is escaped: the line stays one line.
        let mut line = Vec::new();
        encode(&json!({"a": "x\ny"}), &mut line).unwrap();
        assert_eq!(line, b"{\"v\":1,\"a\":\"x\\ny\"}\n");
        let cases: [(&[u8], &str); 4] = [
            (b"{\"v\":2,\"a\":1}", "version 2 is not supported"),
            (b"[1,2]", "not a JSON object"),
            (b"{\"a\":", "not JSON"),
            (b"{\"a\":\"\xff\"}", "not UTF-8 text (byte 7)"),
        ];
        for (bytes, message) in cases {
            let e = decode(bytes).unwrap_err();
            assert!(e.contains(message), "{e}");
        }
    }
}
