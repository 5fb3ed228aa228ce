//! `savme serve` (the kernel behind JSON lines on stdin/stdout, optionally journaled to a trial
//! store) and `savme example-config`.

use super::{usage, Failure};
use savme::campaign::store::{journal, JsonlStore, TrialStore};
use savme::kernel::{Kernel, KernelConfig};
use savme::serve::Session;
use std::io;
use std::path::{Path, PathBuf};

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
    let database = a.storage.open()?;
    let store: Option<Box<dyn TrialStore>> = match (a.journal.as_deref(), database) {
        (Some(path), _) => Some(Box::new(
            JsonlStore::open(path).map_err(|e| Failure::from(e.to_string()))?,
        )),
        (None, Some(db)) => Some(Box::new(db)),
        (None, None) => None,
    };
    serve(a.config.as_deref(), store).map_err(Failure::from)
}

pub fn example_config() -> Result<(), String> {
    let kernel = savme::toy::kernel_builder()
        .seed(1)
        .build()
        .map_err(|e| e.to_string())?;
    let json = serde_json::to_string_pretty(kernel.config()).map_err(|e| e.to_string())?;
    super::print(&format!("{json}\n"))
}

fn read_config(path: &Path) -> Result<KernelConfig, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let config: KernelConfig =
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    // Validate now, so that the error names the file.
    Kernel::new(config.clone()).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(config)
}

fn serve(config: Option<&Path>, journal: Option<Box<dyn TrialStore>>) -> Result<(), String> {
    let config = config.map(read_config).transpose()?;
    let stdin = io::stdin().lock();
    let stdout = io::stdout().lock();
    let io_err = |e: io::Error| format!("stdin/stdout: {e}");
    let session = match journal {
        None => {
            let config = config.ok_or("give --config (or --journal to resume)")?;
            Session::Plain(Kernel::new(config).map_err(|e| e.to_string())?)
        }
        Some(store) => {
            let shown = store.location();
            let opened = journal::open(store, config).map_err(|e| e.to_string())?;
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
            Session::Journaled(opened.kernel)
        }
    };
    let mut session = session;
    session.serve(stdin, stdout).map_err(io_err)
}
