//! What `--help` says beyond the flags' doc comments: an Examples section for every
//! subcommand, the default of every protocol flag (read from the presets, so it cannot drift),
//! and `--storage` help that fits each command. [`command`] is the one `clap::Command` that
//! parsing, the shell completions and the man pages all use.

use clap::{ColorChoice, Command, CommandFactory};
use savme::campaign::config::{self as campaign_config, TOY};
use savme::campaign::values::VALUES;
use savme::campaign::{Method, Protocol};
use savme::compose;

/// The command line with the additions of this module.
pub fn command() -> Command {
    let mut cli = crate::Cli::command();
    for (name, text) in EXAMPLES {
        cli = with_examples(cli, name, text);
    }
    cli = protocol_defaults(cli);
    storage_help(cli)
}

/// The `--color` of `args` (the command line after the program's name), read before clap
/// parses it so that clap's own help and errors honour it: the last one given (`--color WHEN`
/// or `--color=WHEN`, before a `--`); `auto` when there is none or its value is not one clap
/// takes (clap then refuses it).
pub fn color_choice(args: impl IntoIterator<Item = std::ffi::OsString>) -> ColorChoice {
    let mut choice = ColorChoice::Auto;
    let mut args = args.into_iter();
    while let Some(arg) = args.next() {
        let value = match arg.to_str() {
            Some("--") => break,
            Some("--color") => args.next(),
            Some(a) => a.strip_prefix("--color=").map(Into::into),
            None => None,
        };
        if let Some(v) = value {
            choice = match v.to_str() {
                Some("always") => ColorChoice::Always,
                Some("never") => ColorChoice::Never,
                _ => ColorChoice::Auto,
            };
        }
    }
    choice
}

/// Makes the progress bars (indicatif, through console) follow `--color`; with `auto`, a set
/// NO_COLOR turns colour off (as clap does, and before console's CLICOLOR_FORCE).
pub fn color_progress(choice: ColorChoice) {
    match choice {
        ColorChoice::Always => console::set_colors_enabled_stderr(true),
        ColorChoice::Never => console::set_colors_enabled_stderr(false),
        ColorChoice::Auto => {
            if std::env::var_os("NO_COLOR").is_some_and(|v| !v.is_empty()) {
                console::set_colors_enabled_stderr(false);
            }
        }
    }
}

/// `savme --version`: the package version, the commit it was built from and the features.
pub const VERSION: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    " (commit ",
    env!("SAVME_COMMIT"),
    "; features: ",
    env!("SAVME_FEATURES"),
    ")"
);

/// Examples per subcommand path (`fmu pack` is subcommand `pack` of `fmu`); each line that
/// starts with `savme ` is parsed by a test, and tests/it/help_examples.rs runs them as printed, in
/// order, from an empty directory (so a command that reads a campaign or an FMU makes it first).
pub const EXAMPLES: &[(&str, &str)] = &[
    ("serve", "savme example-config > kernel.json\n  savme serve --config kernel.json --journal campaign.journal"),
    ("example-config", "savme example-config > kernel.json"),
    ("scenarios", "savme scenarios\n  savme scenarios --json"),
    ("fidelity", "savme fidelity\n  savme fidelity --json"),
    ("reproduce", "savme reproduce --quick --out results\n  savme reproduce --quick --perception ideal --cost work --seed 3\n  savme reproduce --repeat 5 --out results-5\n  savme reproduce --resume results"),
    ("run", "savme run --config examples/fmu/campaign.toml --out fmu-results\n  savme run --config examples/fmu/campaign.toml --resume fmu-results"),
    ("estimate", "savme reproduce --quick --perception ideal --cost work --out results\n  savme estimate results --target-width 0.1\n  savme estimate results --max-runs 2000 --no-target --out estimate-2000 --json\n  savme estimate results --nominal lead_vehicle_brakes.ego_speed=normal:20,3 --out estimate-nominal\n  savme estimate results --refine-rounds 2 --refine-runs 500 --pilot-fidelity lf --out estimate-mf\n  savme estimate results --refine-rounds 2 --refine-runs 500 --control-calibration 500 --out estimate-cv"),
    ("failures", "savme reproduce --quick --perception ideal --cost work --out results\n  savme failures results\n  savme failures results --stage train@0.3 --json"),
    ("fmu pack", "savme fmu pack --out savme-sim.fmu\n  savme fmu pack --fmi 3 --out savme-sim3.fmu"),
    ("fmu info", "savme fmu pack --out model.fmu\n  savme fmu info model.fmu\n  savme fmu info model.fmu --json"),
    ("fmu validate", "savme fmu pack --out model.fmu\n  savme fmu validate model.fmu\n  savme fmu validate model.fmu --json"),
    ("simulate", "savme simulate --scenario 7 --phi ego_speed=20,lead_speed=10,gap=8,lead_decel=9,brake_time=0.5\n  savme simulate --scenario 7 --phi ego_speed=20,lead_speed=10,gap=8,lead_decel=9,brake_time=0.5 --fidelity simulation_rate_hz=2 --json\n  savme simulate --scenario 7 --phi ego_speed=20,lead_speed=10,gap=8,lead_decel=9,brake_time=0.5 --perception ideal"),
    ("toy", "savme toy --out toy-results\n  savme toy --sleep-ms 20 --jobs 4 --quiet"),
    ("worker", "savme worker --storage-file db.url --campaign c1 --jobs 4"),
    ("completions", "savme completions bash > ~/.local/share/bash-completion/completions/savme\n  savme completions zsh > ~/.zfunc/_savme\n  savme completions fish > ~/.config/fish/completions/savme.fish"),
    ("man", "savme man > savme.1\n  savme man --out man/"),
];

/// Finds the subcommand at `path` (space-separated) and appends `text` as its Examples.
fn with_examples(cli: Command, path: &str, text: &'static str) -> Command {
    let mut names = path.split(' ');
    let first = names.next().unwrap_or_default();
    let rest: Vec<&str> = names.collect();
    cli.mut_subcommand(first, |c| {
        let mut c = c;
        for name in &rest {
            c = c.mut_subcommand(*name, |s| append_examples(s, text));
        }
        if rest.is_empty() {
            append_examples(c, text)
        } else {
            c
        }
    })
}

fn append_examples(c: Command, text: &str) -> Command {
    let before = c
        .get_after_help()
        .map(|h| format!("{h}\n\n"))
        .unwrap_or_default();
    c.after_help(format!("{before}Examples:\n  {text}"))
}

/// A protocol value of `p` as a flag takes it (lists comma-separated).
fn shown(v: &serde_json::Value) -> String {
    match v {
        serde_json::Value::String(s) => s.clone(),
        serde_json::Value::Array(items) if items.is_empty() => "none".into(),
        serde_json::Value::Array(items) => items.iter().map(shown).collect::<Vec<_>>().join(","),
        serde_json::Value::Null => "none".into(),
        other => other.to_string(),
    }
}

/// The value of protocol field `name` in `p` (None for a value that is no protocol field).
fn default_of(p: &Protocol, name: &str) -> Option<String> {
    let v = serde_json::to_value(p).ok()?;
    match (name, v.get(name)) {
        ("search", None) => Some("bins".into()),
        ("screen_iterations", None) => Some("0".into()),
        ("prior_strengths", None) => Some("none".into()),
        ("ladder", None) => Some("none (two-level screening at each budget)".into()),
        ("pair_fraction", None) => Some(p.pair_fraction.to_string()),
        ("pair_settle", None) => Some(p.pair_settle.to_string()),
        ("deployment", None) => Some(p.deployment.name().into()),
        ("screen_lf", None) => Some("always".into()),
        ("log_bins", None) => Some("savme".into()),
        ("elite", None) => Some(elite_defaults()),
        ("allocation", None) => Some("weights".into()),
        ("theta_lf_choice", None) => Some("map".into()),
        ("transfer", None) => Some("fixed".into()),
        ("ladder_training", None) => Some("separate".into()),
        ("coverage_floor", None) => Some(p.coverage_floor.to_string()),
        ("search_budget" | "deploy_budget", None) => Some("none (the iterations)".into()),
        (_, Some(x)) => Some(shown(x)),
        (_, None) => None,
    }
}

/// The elite search's default parameters as `--elite` takes them (`key=value,…`).
fn elite_defaults() -> String {
    let v = serde_json::to_value(savme::kernel::EliteMixture::default()).unwrap_or_default();
    let pairs: Vec<String> = v
        .as_object()
        .map(|m| m.iter().map(|(k, x)| format!("{k}={}", shown(x))).collect())
        .unwrap_or_default();
    pairs.join(",")
}

/// Adds `[default: …]` to every protocol flag of `reproduce` (the paper's protocol, and
/// `--quick`'s), `toy` (the quick preset on the toy scenarios) and `run` (the campaign
/// file's value, else the paper's).
fn protocol_defaults(cli: Command) -> Command {
    let (train, test) = savme_sim::scenario::train_test_names();
    let paper = Protocol::paper(compose::SENSORS, train.clone(), test.clone());
    let quick = Protocol::quick(compose::SENSORS, train, test);
    let toy = campaign_config::toy(TOY, &Default::default()).map(|(p, _)| p);
    // `savme run` searches with the tuned method unless told otherwise.
    let tuned = paper.clone().with_method(Method::Tuned);
    let mut cli = cli;
    for v in VALUES {
        let id = v.name;
        let note = |p: &Protocol| default_of(p, id);
        let (reproduce, run, toy_note) = match id {
            "repeat" => {
                let one = "[default: none — one campaign, written to OUT itself]".to_string();
                (one.clone(), one.clone(), one)
            }
            "method" => {
                let paper = "[default: paper]".to_string();
                let run = "[default: the campaign file's `method`, else tuned]".to_string();
                (paper.clone(), run, paper)
            }
            _ => {
                let (Some(p), Some(q)) = (note(&paper), note(&quick)) else {
                    continue;
                };
                let t = toy.as_ref().ok().and_then(note).unwrap_or_default();
                let reproduce = if p == q {
                    format!("[default: {p}]")
                } else {
                    format!("[default: {p}; with --quick: {q}]")
                };
                let r = note(&tuned).unwrap_or(p);
                (
                    reproduce,
                    format!("[default: the campaign file's `{id}`, else {r}]"),
                    format!("[default: {t}]"),
                )
            }
        };
        for (command, text) in [("reproduce", reproduce), ("run", run), ("toy", toy_note)] {
            cli = cli.mut_subcommand(command, |c| {
                c.mut_arg(id, |a| {
                    let help = a.get_help().map(|h| h.to_string()).unwrap_or_default();
                    a.help(format!("{} {text}", help.trim_end()))
                })
            });
        }
    }
    cli
}

/// `--storage` reads a campaign in `failures` and `estimate`, keeps one in the coordinators,
/// and names the queue a `worker` works for: say so in each.
fn storage_help(cli: Command) -> Command {
    const URL: &str = "postgresql://USER@HOST[:PORT]/DB; the password comes from the URL, \
                       PGPASSWORD or ~/.pgpass and is never printed. Needs a build with the \
                       `postgres` feature (cargo install --path . --features postgres)";
    let read = format!(
        "Read the campaign from this PostgreSQL database instead of a directory (without the \
         coordinator's lock: a running campaign can be read; nothing in the database changes): {URL}"
    );
    let estimate = format!(
        "Read the campaign from this PostgreSQL database instead of a directory (without the \
         coordinator's lock); the estimate's own runs go to --out DIR: {URL}"
    );
    let worker = format!(
        "The PostgreSQL database whose campaign (--campaign) this worker runs trials for; its \
         coordinator was started with --remote: {URL}"
    );
    let name_read = "The campaign's name in the database (with --storage)";
    let name_worker = "The name of the campaign to work for (as its coordinator's --campaign)";
    cli.mut_subcommand("failures", |c| {
        c.mut_arg("storage", |a| a.help(read.clone()))
            .mut_arg("campaign", |a| a.help(name_read))
    })
    .mut_subcommand("estimate", |c| {
        c.mut_arg("storage", |a| a.help(estimate.clone()))
            .mut_arg("campaign", |a| a.help(name_read))
    })
    .mut_subcommand("worker", |c| {
        c.mut_arg("storage", |a| a.help(worker.clone()))
            .mut_arg("campaign", |a| a.help(name_worker))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every subcommand, with its path (`fmu pack`), hidden ones left out.
    fn subcommands(c: &Command, prefix: &str, out: &mut Vec<(String, Command)>) {
        for s in c.get_subcommands().filter(|s| !s.is_hide_set()) {
            let path = format!("{prefix}{}", s.get_name());
            if s.has_subcommands() {
                subcommands(s, &format!("{path} "), out);
            } else {
                out.push((path, s.clone()));
            }
        }
    }

    #[test]
    fn every_subcommand_has_examples_and_each_example_parses() {
        let mut all = Vec::new();
        subcommands(&command(), "", &mut all);
        assert!(all.len() >= 15, "{}", all.len());
        for (path, mut c) in all {
            let help = c.render_help().to_string();
            let (_, examples) = help
                .split_once("Examples:\n")
                .unwrap_or_else(|| panic!("`savme {path} --help` has no Examples:\n{help}"));
            let lines: Vec<&str> = examples
                .lines()
                .map(str::trim)
                .filter(|l| l.starts_with("savme "))
                .collect();
            assert!(!lines.is_empty(), "{path}: {examples}");
            for line in lines {
                // What a shell would pass (no quoting in the examples); a redirection ends it.
                let args = line.split(" > ").next().unwrap_or(line);
                command()
                    .try_get_matches_from(args.split_whitespace())
                    .unwrap_or_else(|e| panic!("example `{line}` does not parse: {e}"));
            }
        }
    }

    /// Help is read in a terminal: no rustdoc link syntax (`[`X`](path)`) leaks into any
    /// command's `--help`, at any depth of subcommands.
    #[test]
    fn no_help_shows_rustdoc_link_syntax() {
        fn walk(c: &mut Command, path: &str, bad: &mut Vec<String>) {
            let text = c.render_long_help().to_string();
            for line in text
                .lines()
                .filter(|l| l.contains("](") || l.contains("[`"))
            {
                bad.push(format!("{path}: {}", line.trim()));
            }
            let names: Vec<String> = c
                .get_subcommands()
                .map(|s| s.get_name().to_string())
                .collect();
            for name in names {
                if let Some(s) = c.find_subcommand_mut(&name) {
                    walk(s, &format!("{path} {name}"), bad);
                }
            }
        }
        let mut bad = Vec::new();
        walk(&mut command(), "savme", &mut bad);
        assert!(
            bad.is_empty(),
            "rustdoc syntax in help:\n{}",
            bad.join("\n")
        );
    }

    #[test]
    fn every_protocol_flag_shows_its_default_in_each_campaign_command() {
        let mut cli = command();
        for command in ["reproduce", "run", "toy"] {
            let c = cli.find_subcommand_mut(command).expect(command);
            for v in VALUES {
                let arg = c
                    .get_arguments()
                    .find(|a| a.get_id() == v.name)
                    .unwrap_or_else(|| panic!("{command} --{}", v.flag));
                let help = arg.get_help().map(|h| h.to_string()).unwrap_or_default();
                assert!(
                    help.contains("[default: "),
                    "{command} --{}: {help}",
                    v.flag
                );
            }
        }
        let help = cli
            .find_subcommand_mut("reproduce")
            .expect("reproduce")
            .render_help()
            .to_string();
        for text in [
            "[default: 1]",
            "[default: wall]",
            "[default: 0.2,0.3,0.4; with --quick: 0.3]",
        ] {
            assert!(help.contains(text), "{text} not in {help}");
        }
        let toy = cli
            .find_subcommand_mut("toy")
            .expect("toy")
            .render_help()
            .to_string();
        assert!(toy.contains("[default: stopped_obstacle]"), "{toy}");
    }

    #[test]
    fn storage_help_fits_each_command() {
        let mut cli = command();
        let mut help = |c: &str| {
            cli.find_subcommand_mut(c)
                .expect(c)
                .render_help()
                .to_string()
        };
        assert!(help("failures").contains("Read the campaign from this PostgreSQL database"));
        assert!(help("estimate").contains("Read the campaign from this PostgreSQL database"));
        assert!(help("worker").contains("whose campaign (--campaign) this worker runs trials"));
        assert!(help("reproduce").contains("Keep the campaign"));
        for c in [
            "failures",
            "estimate",
            "worker",
            "reproduce",
            "run",
            "toy",
            "serve",
        ] {
            assert!(
                help(c).contains("--features postgres"),
                "{c}: --storage names the feature it needs"
            );
        }
    }

    #[test]
    fn color_is_read_before_parsing_wherever_it_stands() {
        let choice = |line: &str| color_choice(line.split_whitespace().map(Into::into));
        assert_eq!(choice("scenarios"), ColorChoice::Auto);
        assert_eq!(choice("--color never scenarios"), ColorChoice::Never);
        assert_eq!(choice("estimate r --color=always"), ColorChoice::Always);
        assert_eq!(
            choice("--color never toy --color always"),
            ColorChoice::Always
        );
        assert_eq!(choice("--color sometimes toy"), ColorChoice::Auto);
        assert_eq!(choice("toy --color"), ColorChoice::Auto);
        assert_eq!(choice("toy -- --color never"), ColorChoice::Auto);
    }

    #[test]
    fn version_names_the_commit_and_the_features() {
        assert!(VERSION.starts_with(env!("CARGO_PKG_VERSION")), "{VERSION}");
        assert!(VERSION.contains("(commit "), "{VERSION}");
        assert!(VERSION.contains("features: "), "{VERSION}");
        assert_eq!(
            VERSION.contains("postgres"),
            cfg!(feature = "postgres"),
            "{VERSION}"
        );
        assert_eq!(
            VERSION.contains("rerun"),
            cfg!(feature = "rerun"),
            "{VERSION}"
        );
    }
}
