//! `savme serve` (the kernel behind JSON lines on stdin/stdout, optionally journaled to a trial
//! store) and `savme example-config`.

use super::{usage, Failure};
use savme::campaign::store::{JsonlStore, TrialStore};
use savme::campaign::Stop;
use savme::kernel::KernelConfig;
use savme::serve::{OpenError, Session};
use std::io::{self, Read};
use std::path::{Path, PathBuf};
#[cfg(not(unix))]
use std::{
    io::BufRead,
    sync::mpsc::{self, Receiver, RecvTimeoutError},
    time::Duration,
};

#[derive(clap::Args)]
pub struct Args {
    /// Kernel configuration (JSON, as printed by `savme example-config`). Optional when
    /// resuming from an existing journal.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Journal file: created if missing, resumed if it exists. Every ask and tell is logged
    /// to it before it takes effect; a second server on the same journal is refused.
    #[arg(long, conflicts_with_all = ["storage", "storage_file"])]
    journal: Option<PathBuf>,
    /// Journal into campaign NAME of a PostgreSQL database instead of a file (--storage URL
    /// --campaign NAME), with the same rules.
    #[command(flatten)]
    storage: super::StorageArgs,
}

pub fn run(a: Args) -> Result<(), Failure> {
    if a.config.is_none() && a.journal.is_none() && !a.storage.given() {
        return Err(usage(
            "give --config FILE (a kernel configuration, e.g. from `savme example-config`), or --journal FILE to resume",
        ));
    }
    let again = match (&a.journal, a.storage.database()?) {
        (Some(path), _) => format!(
            "its journal {} holds every answered request: continue with: savme serve --journal {}",
            path.display(),
            path.display()
        ),
        (None, Some((db, name))) => format!(
            "campaign {name:?} holds every answered request: continue with: savme serve {}",
            a.storage.flags(&db)
        ),
        (None, None) => {
            "nothing was journaled (no --journal): the kernel's state is gone".to_string()
        }
    };
    let stop = super::signals::stop_on_signals_saying(
        "stopping after the request being answered; a second signal quits at once (the journal keeps every answered request either way)",
        &again,
    );
    let database = a.storage.open()?;
    let store: Option<Box<dyn TrialStore>> = match (a.journal.as_deref(), database) {
        (Some(path), _) => Some(Box::new(
            JsonlStore::open(path).map_err(|e| Failure::from(e.to_string()))?,
        )),
        (None, Some(db)) => Some(Box::new(db)),
        (None, None) => None,
    };
    serve(a.config.as_deref(), store, &stop).map_err(Failure::from)?;
    if stop.is_requested() {
        return Err(Failure::Interrupted(format!(
            "serve stopped ({}) between requests; {again}",
            super::signals::received_name()
        )));
    }
    Ok(())
}

/// Standard input's lines, handed out whole, so that a stop (SIGINT, SIGTERM) is seen while no
/// request comes: the input ends at the first line boundary after the stop (a line cut off by
/// the stop is dropped, never answered half).
///
/// On Unix the serving thread waits for standard input itself (poll(2), 100 ms at a time), so a
/// request wakes one thread: with a reader thread handing lines over a channel, each request
/// woke two (a served trial took 67–68 µs against 57–58 µs now, pinned to one core;
/// docs/BENCHMARKS.md, "The riddle looked into").
struct LinesUntilStop {
    source: Source,
    /// Bytes read and not yet handed out: `buf[at..end]` is the rest of the line being handed
    /// out, whole lines and a partial one may follow.
    buf: Vec<u8>,
    at: usize,
    end: usize,
    ended: bool,
    stop: Stop,
}

impl LinesUntilStop {
    fn stdin(stop: &Stop) -> LinesUntilStop {
        LinesUntilStop {
            source: Source::stdin(),
            buf: Vec::new(),
            at: 0,
            end: 0,
            ended: false,
            stop: stop.clone(),
        }
    }

    /// At a line boundary: moves `end` past the next whole line (the last one unterminated at
    /// the end of the input); false when none is read yet.
    fn next_line(&mut self) -> bool {
        let rest = &self.buf[self.at..];
        match rest.iter().position(|&b| b == b'\n') {
            Some(i) => self.end = self.at + i + 1,
            None if self.ended => self.end = self.buf.len(),
            None => return false,
        }
        true
    }
}

impl Read for LinesUntilStop {
    /// One line at a time, so that a stop is seen at every line boundary.
    fn read(&mut self, out: &mut [u8]) -> io::Result<usize> {
        while self.at == self.end {
            if self.stop.is_requested() {
                return Ok(0);
            }
            if self.next_line() {
                if self.at == self.end {
                    return Ok(0); // the input ended at a line boundary
                }
                continue;
            }
            // Only a partial line left: keep it, read more (waiting at most Source::WAIT).
            self.buf.drain(..self.at);
            (self.at, self.end) = (0, 0);
            self.ended = self.source.read(&mut self.buf)? == Some(0);
        }
        let n = out.len().min(self.end - self.at);
        out[..n].copy_from_slice(&self.buf[self.at..self.at + n]);
        self.at += n;
        Ok(n)
    }
}

/// Where [`LinesUntilStop`] reads: file descriptor 0 polled by the serving thread (Unix), or a
/// thread of its own blocked on standard input (elsewhere).
#[cfg(unix)]
struct Source;

#[cfg(unix)]
impl Source {
    const WAIT: libc::c_int = 100;

    fn stdin() -> Source {
        Source
    }

    /// Appends what file descriptor 0 has (`Some(0)` at its end), or `None` when nothing came
    /// within [`Source::WAIT`] ms or a signal interrupted the wait.
    fn read(&mut self, buf: &mut Vec<u8>) -> io::Result<Option<usize>> {
        let mut fd = libc::pollfd {
            fd: 0,
            events: libc::POLLIN,
            revents: 0,
        };
        // SAFETY: one valid pollfd.
        match unsafe { libc::poll(&mut fd, 1, Self::WAIT) } {
            0 => return Ok(None),
            n if n < 0 => {
                let e = io::Error::last_os_error();
                return match e.kind() {
                    io::ErrorKind::Interrupted => Ok(None),
                    _ => Err(e),
                };
            }
            _ => {}
        }
        let old = buf.len();
        buf.resize(old + 64 * 1024, 0);
        // SAFETY: read(2) into the 64 KiB just reserved at the end of `buf`.
        let got = unsafe { libc::read(0, buf[old..].as_mut_ptr().cast(), 64 * 1024) };
        if got < 0 {
            buf.truncate(old);
            let e = io::Error::last_os_error();
            return match e.kind() {
                io::ErrorKind::Interrupted | io::ErrorKind::WouldBlock => Ok(None),
                _ => Err(e),
            };
        }
        buf.truncate(old + got as usize);
        Ok(Some(got as usize))
    }
}

#[cfg(not(unix))]
struct Source(Receiver<io::Result<Vec<u8>>>);

#[cfg(not(unix))]
impl Source {
    const WAIT: Duration = Duration::from_millis(100);

    fn stdin() -> Source {
        let (send, lines) = mpsc::sync_channel(16);
        std::thread::spawn(move || {
            let mut input = io::stdin().lock();
            loop {
                let mut line = Vec::new();
                let result = input.read_until(b'\n', &mut line).map(|_| line);
                let last = !matches!(&result, Ok(l) if !l.is_empty());
                if send.send(result).is_err() || last {
                    return;
                }
            }
        });
        Source(lines)
    }

    /// Appends the next line (`Some(0)` at the input's end), or `None` when none came within
    /// [`Source::WAIT`].
    fn read(&mut self, buf: &mut Vec<u8>) -> io::Result<Option<usize>> {
        match self.0.recv_timeout(Self::WAIT) {
            Ok(line) => {
                let line = line?;
                buf.extend_from_slice(&line);
                Ok(Some(line.len()))
            }
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Ok(Some(0)),
        }
    }
}

/// `savme example-config`'s flags.
#[derive(clap::Args)]
pub struct ExampleArgs {
    /// tuned (savme's search by cost, the default) or paper (the paper's SAVME).
    #[arg(long, value_enum, default_value = "tuned")]
    method: savme::campaign::Method,
}

/// The toy simulator's kernel configuration under `--method`: the method's
/// [`savme::kernel::Preset`] ([`savme::campaign::Method::preset`]): the tuned one reads θ_LF*
/// by evidence, as a tuned campaign does; the paper's by MAP.
pub fn example_config(a: ExampleArgs) -> Result<(), String> {
    let kernel = savme::toy::kernel_builder()
        .seed(1)
        .preset(a.method.preset())
        .build()
        .map_err(|e| e.to_string())?;
    let json = serde_json::to_string_pretty(kernel.config()).map_err(|e| e.to_string())?;
    super::print(&format!("{json}\n"))
}

fn read_config(path: &Path) -> Result<KernelConfig, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    savme::serve::parse_config(&text).map_err(|e| format!("{}: {e}", path.display()))
}

fn serve(
    config: Option<&Path>,
    journal: Option<Box<dyn TrialStore>>,
    stop: &Stop,
) -> Result<(), String> {
    let config = config.map(read_config).transpose()?;
    let stdin = io::BufReader::new(LinesUntilStop::stdin(stop));
    let stdout = io::stdout().lock();
    let io_err = |e: io::Error| format!("stdin/stdout: {e}");
    let shown = journal.as_ref().map(|s| s.location());
    let opened = Session::open(config, journal).map_err(|e| match e {
        OpenError::NoConfig => "give --config (or --journal to resume)".to_string(),
        e => e.to_string(),
    })?;
    let shown = shown.unwrap_or_default();
    if let Some(tail) = &opened.torn {
        eprintln!(
            "savme: {shown}: line {} was cut off mid-write ({} bytes); dropped it",
            tail.line, tail.bytes
        );
    }
    if let Some((told, pending)) = &opened.resumed {
        eprintln!(
            "savme: resumed {shown}: {told} told, {} pending",
            pending.len()
        );
    }
    let mut session = opened.session;
    session.serve(stdin, stdout).map_err(io_err)
}
