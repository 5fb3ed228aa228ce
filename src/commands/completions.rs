//! `savme completions SHELL` (clap_complete) and `savme man` (clap_mangen): shell completion
//! scripts and man pages generated from the same command line the parser uses.

use clap::Command;
use clap_complete::Shell;
use savme::store::safe_file;
use std::path::{Path, PathBuf};

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
            let at = |e: std::io::Error| format!("{}: {e}", dir.display());
            safe_file::dangling_link(&dir).map_err(at)?;
            std::fs::create_dir_all(&dir).map_err(at)?;
            write_pages(cli, &dir)?;
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

/// Writes the page of `cli` and of each subcommand (not the hidden ones) into `dir`, as
/// `clap_mangen::generate_to` names them, each through [`safe_file::write_file`]: a page that
/// is a link (symbolic, or a file other names share) is refused, naming it, and left unchanged.
fn write_pages(cli: Command, dir: &Path) -> Result<(), String> {
    fn pages(cmd: Command, dir: &Path) -> Result<(), String> {
        for sub in cmd.get_subcommands().filter(|s| !s.is_hide_set()).cloned() {
            pages(sub, dir)?;
        }
        let man = clap_mangen::Man::new(cmd);
        let path = dir.join(man.get_filename());
        let mut page = Vec::new();
        man.render(&mut page)
            .and_then(|()| safe_file::write_file(&path, &page))
            .map_err(|e| format!("{}: {e}", path.display()))
    }
    let mut cli = cli.disable_help_subcommand(true);
    cli.build();
    pages(cli, dir)
}
