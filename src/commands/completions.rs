//! `savme completions SHELL` (clap_complete) and `savme man` (clap_mangen): shell completion
//! scripts and man pages generated from the same command line the parser uses.

use clap::builder::{PossibleValue, PossibleValuesParser};
use clap::{Arg, Command, ValueHint};
use clap_complete::Shell;
use savme::store::safe_file;
use savme_sim::scenario::SCENARIOS;
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
    let mut cli = completable(&cli);
    let mut script = Vec::new();
    clap_complete::generate(a.shell, &mut cli, "savme", &mut script);
    super::print(&String::from_utf8_lossy(&script))
}

/// The command line the completion scripts offer: `cli` without its hidden subcommands and
/// flags (clap_complete's scripts offer whatever a command holds, hidden or not), and with the
/// bundled simulator's scenarios (names and numbers) as the values of the flags that name them
/// (`simulate --scenario`, `reproduce --train-scenarios/--test-scenarios`) instead of file
/// names (a campaign's scenario flags elsewhere: no file names). Only the scripts read it: parsing keeps `cli`, so the flags accept what they did.
fn completable(cli: &Command) -> Command {
    let scenarios: Vec<PossibleValue> = SCENARIOS
        .iter()
        .map(|s| PossibleValue::new(s.name).help(format!("scenario {}", s.id)))
        .chain(
            SCENARIOS
                .iter()
                .map(|s| PossibleValue::new(s.id.to_string()).help(s.name)),
        )
        .collect();
    let hint = |a: Arg| a.value_parser(PossibleValuesParser::new(scenarios.clone()));
    // A campaign's scenarios (any simulator's, named in its file or trial lines): no hint
    // but not a file name either.
    let names = |a: Arg| a.value_hint(ValueHint::Other);
    visible(cli)
        .mut_subcommand("simulate", |c| c.mut_arg("scenario", hint))
        .mut_subcommand("reproduce", |c| {
            c.mut_arg("train_scenarios", hint)
                .mut_arg("test_scenarios", hint)
        })
        .mut_subcommand("estimate", |c| c.mut_arg("scenarios", names))
        .mut_subcommand("failures", |c| c.mut_arg("scenarios", names))
        .mut_subcommand("run", |c| {
            c.mut_arg("train_scenarios", names)
                .mut_arg("test_scenarios", names)
        })
        .mut_subcommand("toy", |c| {
            c.mut_arg("train_scenarios", names)
                .mut_arg("test_scenarios", names)
        })
}

/// A copy of `c` (what the completion scripts read of it: names, about, aliases, version,
/// arguments, subcommands) without the hidden subcommands and arguments, at every depth.
fn visible(c: &Command) -> Command {
    let mut copy = Command::new(c.get_name().to_owned())
        .visible_aliases(c.get_visible_aliases().map(str::to_owned))
        .args(c.get_arguments().filter(|a| !a.is_hide_set()).cloned())
        .subcommands(
            c.get_subcommands()
                .filter(|s| !s.is_hide_set())
                .map(visible),
        );
    if let Some(about) = c.get_about() {
        copy = copy.about(about.clone());
    }
    if let Some(about) = c.get_long_about() {
        copy = copy.long_about(about.clone());
    }
    if let Some(v) = c.get_version() {
        copy = copy.version(v.to_owned());
    }
    copy
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The hidden subcommands and long flags of `c`, at every depth.
    fn hidden(c: &Command, subcommands: &mut Vec<String>, flags: &mut Vec<String>) {
        for a in c.get_arguments().filter(|a| a.is_hide_set()) {
            flags.extend(a.get_long().map(str::to_owned));
        }
        for s in c.get_subcommands() {
            if s.is_hide_set() {
                subcommands.push(s.get_name().to_owned());
            }
            hidden(s, subcommands, flags);
        }
    }

    fn script(shell: Shell) -> String {
        let mut script = Vec::new();
        let cli = completable(&crate::help::command());
        clap_complete::generate(shell, &mut { cli }, "savme", &mut script);
        String::from_utf8_lossy(&script).into_owned()
    }

    #[test]
    fn completions_offer_no_hidden_command_or_flag() {
        let (mut subcommands, mut flags) = (Vec::new(), Vec::new());
        hidden(&crate::help::command(), &mut subcommands, &mut flags);
        assert!(
            subcommands.contains(&"fmu-worker".to_owned()),
            "{subcommands:?}"
        );
        assert!(
            subcommands.contains(&"validate-library".to_owned()),
            "{subcommands:?}"
        );
        for shell in [Shell::Bash, Shell::Zsh, Shell::Fish] {
            let text = script(shell);
            for name in &subcommands {
                // As a word, and as the scripts name its functions (fmu__worker).
                for form in [name.clone(), name.replace('-', "__")] {
                    assert!(!text.contains(&form), "{shell}: hidden `{form}` offered");
                }
            }
            for long in &flags {
                for form in [
                    format!("--{long}'"),
                    format!("--{long}="),
                    format!("--{long} "),
                    format!("--{long})"),
                    format!("-l {long} "),
                ] {
                    assert!(!text.contains(&form), "{shell}: hidden `{form}` offered");
                }
            }
        }
    }

    /// The bash script's words after `--flag` of `command`.
    fn bash_words<'a>(bash: &'a str, command: &str, flag: &str) -> &'a str {
        let (_, section) = bash
            .split_once(&format!("savme__subcmd__{command})"))
            .unwrap_or_else(|| panic!("bash: no {command}"));
        let section = section
            .split("\n        savme__")
            .next()
            .unwrap_or_default();
        let (_, after) = section
            .split_once(&format!("--{flag})"))
            .unwrap_or_else(|| panic!("bash: no {command} --{flag}"));
        after.lines().nth(1).unwrap_or_default()
    }

    #[test]
    fn scenario_flags_complete_scenario_names_not_file_names() {
        let names = SCENARIOS.map(|s| s.name);
        let bash = script(Shell::Bash);
        let fish = script(Shell::Fish);
        let bundled = [
            ("simulate", "scenario"),
            ("reproduce", "train-scenarios"),
            ("reproduce", "test-scenarios"),
        ];
        for (command, flag) in bundled {
            let offered = bash_words(&bash, command, flag);
            for name in names.iter().chain(&["1", "10"]) {
                assert!(
                    offered.contains(name),
                    "{command} --{flag}: no {name}: {offered}"
                );
            }
            let line = fish
                .split("\ncomplete ")
                .find(|l| {
                    l.contains(&format!("using_subcommand {command}\""))
                        && l.contains(&format!("-l {flag} "))
                })
                .unwrap_or_else(|| panic!("fish: no line for {command} --{flag}"));
            assert!(names.iter().all(|n| line.contains(n)), "{line}");
        }
        // A campaign's scenarios (any simulator's): no file names either.
        for (command, flag) in [
            ("estimate", "scenario"),
            ("failures", "scenario"),
            ("run", "train-scenarios"),
            ("toy", "test-scenarios"),
        ] {
            let offered = bash_words(&bash, command, flag);
            assert!(
                !offered.contains("compgen -f"),
                "{command} --{flag}: {offered}"
            );
        }
    }
}
