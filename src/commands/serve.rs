//! `savme serve` (the kernel behind JSON lines on stdin/stdout, optionally journaled to a trial
//! store) and `savme example-config`.

use super::{usage, Failure};
use savme::campaign::store::{JsonlStore, TrialStore};
use savme::campaign::Stop;
use savme::kernel::KernelConfig;
use savme::serve::{OpenError, Session};
use std::io::{self, BufRead, Read};
use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::time::Duration;

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

/// Standard input's lines, read by a thread of their own so that a stop (SIGINT, SIGTERM) is
/// seen while no request comes: the input ends at the first line boundary after the stop.
struct LinesUntilStop {
    lines: Receiver<io::Result<Vec<u8>>>,
    line: Vec<u8>,
    at: usize,
    stop: Stop,
}

impl LinesUntilStop {
    fn stdin(stop: &Stop) -> LinesUntilStop {
        let (send, lines) = mpsc::sync_channel(16);
        std::thread::spawn(move || {
            let mut input = io::stdin().lock();
            loop {
                let mut line = Vec::new();
                match input.read_until(b'\n', &mut line) {
                    Ok(0) => return,
                    Ok(_) => {
                        if send.send(Ok(line)).is_err() {
                            return;
                        }
                    }
                    Err(e) => {
                        let _ = send.send(Err(e));
                        return;
                    }
                }
            }
        });
        LinesUntilStop {
            lines,
            line: Vec::new(),
            at: 0,
            stop: stop.clone(),
        }
    }
}

impl Read for LinesUntilStop {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        while self.at == self.line.len() {
            if self.stop.is_requested() {
                return Ok(0);
            }
            match self.lines.recv_timeout(Duration::from_millis(100)) {
                Ok(line) => (self.line, self.at) = (line?, 0),
                Err(RecvTimeoutError::Timeout) => continue,
                Err(RecvTimeoutError::Disconnected) => return Ok(0),
            }
        }
        let n = buf.len().min(self.line.len() - self.at);
        buf[..n].copy_from_slice(&self.line[self.at..self.at + n]);
        self.at += n;
        Ok(n)
    }
}

/// `savme example-config`'s flags.
#[derive(clap::Args)]
pub struct ExampleArgs {
    /// tuned (savme's search by cost, the default) or paper (the paper's SAVME).
    #[arg(long, value_enum, default_value = "tuned")]
    method: savme::campaign::Method,
}

pub fn example_config(a: ExampleArgs) -> Result<(), String> {
    let builder = savme::toy::kernel_builder().seed(1);
    let builder = match a.method {
        savme::campaign::Method::Paper => builder,
        savme::campaign::Method::Tuned => builder
            .search(savme::kernel::SearchModel::EliteMixture(Default::default()))
            .deployment(savme::kernel::Deployment::ADAPTIVE)
            .allocation(savme::kernel::Allocation::CostRate(Default::default())),
    };
    let kernel = builder.build().map_err(|e| e.to_string())?;
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
