//! `savme completions SHELL` (clap_complete) and `savme man` (clap_mangen): shell completion
//! scripts and man pages generated from the same command line the parser uses.

use clap::Command;
use clap_complete::Shell;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct CompletionArgs {
    /// The shell to complete in.
    #[arg(value_enum)]
    shell: Shell,
}

#[derive(clap::Args)]
pub struct ManArgs {
    /// Write savme.1 and one page per subcommand (savme-reproduce.1, savme-fmu-pack.1, …) into
    /// DIR instead of printing savme.1 to standard output.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

/// Prints the completion script of `a.shell` for `cli`.
pub fn completions(a: CompletionArgs, cli: Command) -> Result<(), String> {
    let mut cli = cli;
    let mut script = Vec::new();
    clap_complete::generate(a.shell, &mut cli, "savme", &mut script);
    super::print(&String::from_utf8_lossy(&script))
}

/// Prints savme(1), or writes every page into `--out DIR`.
pub fn man(a: ManArgs, cli: Command) -> Result<(), String> {
    let cli = cli.version(crate::help::VERSION);
    match a.out {
        Some(dir) => {
            std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
            clap_mangen::generate_to(cli, &dir).map_err(|e| format!("{}: {e}", dir.display()))?;
            super::print(&format!("wrote the man pages into {}\n", dir.display()))
        }
        None => {
            let mut page = Vec::new();
            clap_mangen::Man::new(cli)
                .render(&mut page)
                .map_err(|e| format!("man page: {e}"))?;
            super::print(&String::from_utf8_lossy(&page))
        }
    }
}
