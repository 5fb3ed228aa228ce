//! The `savme` command line: parses the flags (clap) and hands each subcommand to its module
//! under `commands/`.
mod commands;
mod help;

use clap::{ColorChoice, FromArgMatches, Parser, Subcommand};
use commands::Failure;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "savme",
    version = help::VERSION,
    about = "Find the failures of an autonomous system in simulation, fast (SAVME).",
    after_help = "Exit status: 0 on success; 1 when running failed (a file, a simulator, the trial store, \
                  the output); 2 when the command line is wrong (an unknown flag, or a value savme \
                  refuses before running anything)."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// When to colour the output (help, errors, progress): auto (on a terminal, unless
    /// NO_COLOR is set), always or never.
    #[arg(long, global = true, value_name = "WHEN", value_enum, default_value_t = ColorChoice::Auto)]
    color: ColorChoice,
}

#[derive(Subcommand)]
enum Command {
    /// Serve the ask/tell kernel as JSON lines on stdin/stdout, for a harness in any language.
    Serve(commands::serve::Args),
    /// Print a kernel configuration (the toy simulator's) to start editing from: savme's
    /// search by cost (elite search, cost-rate allocation, adaptive deployment), or with
    /// `--method paper` the paper's SAVME.
    ExampleConfig(commands::serve::ExampleArgs),
    /// List the bundled driving simulator's scenarios with their parameter spaces.
    Scenarios(commands::scenarios::Args),
    /// List the 16 fidelity settings (the paper's Table II) with their high-fidelity values.
    Fidelity(commands::fidelity::Args),
    /// Reproduce the paper's protocol on the bundled simulator: baseline, meta-training per
    /// budget, evaluation, meta-testing. Writes table.md, fidelity.md, summary.json,
    /// trials.jsonl, breakeven.png and meta_testing.png.
    #[command(after_help = commands::reproduce::defaults_help())]
    Reproduce(commands::reproduce::Args),
    /// Run the paper's stages on the FMUs a campaign file (TOML) names, searched with savme's
    /// tuned method by default (`--method paper`: the paper's SAVME).
    Run(commands::run::Args),
    /// Estimate P(failure) under the nominal distribution of φ by importance sampling from a
    /// finished campaign's learned posterior (defensive mixture; HF runs only). Writes
    /// summary.json, table.md and trials.jsonl (q, p, weight per run).
    Estimate(commands::estimate::Args),
    /// List every HF failure a campaign found (stage, trial, scenario, φ, what the LF run
    /// said), with the `savme simulate` command that replays it; `--json` for one object per
    /// line.
    Failures(commands::failures::Args),
    /// FMU tools.
    #[command(subcommand)]
    Fmu(commands::fmu::Command),
    /// Serve FMU evaluations on stdin/stdout (started by `savme run` with `isolate = true`).
    #[command(hide = true)]
    FmuWorker,
    /// Run one simulation on the bundled driving simulator.
    Simulate(commands::simulate::Args),
    /// Run the quick preset of the paper's protocol (one budget, fewer iterations) on the toy
    /// simulator, a 1-D braking model that runs in microseconds (`--sleep-ms` or `--null` to
    /// try and benchmark distribution).
    #[command(after_help = commands::toy::defaults_help())]
    Toy(commands::toy::Args),
    /// Run the HF and LF runs of a campaign kept in PostgreSQL whose coordinator was started
    /// with --remote, on this host, until the campaign is finished (a build with the
    /// `postgres` feature).
    Worker(commands::worker::Args),
    /// Print a shell completion script (bash, zsh, fish, elvish, powershell).
    Completions(commands::completions::CompletionArgs),
    /// Print the man page savme(1), or write every subcommand's page with --out DIR.
    Man(commands::completions::ManArgs),
}

fn main() -> ExitCode {
    // Each command fails with a message (a runtime failure) or a `Failure` that says which.
    // The command line with its Examples and defaults (help.rs); parsed into `Cli`.
    // `--color` is read before parsing, so that clap's own help and errors honour it too.
    let color = help::color_choice(std::env::args_os().skip(1));
    help::color_progress(color);
    let matches = help::command().color(color).get_matches();
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    // An FMU loaded in this process is loaded and instantiated in a child first: a library
    // that crashes is reported, not the silent end of savme.
    if let Ok(probe) = commands::fmu::probe_command() {
        savme_fmu::inspect::set_load_probe(probe);
    }
    let result = match cli.command {
        Command::Serve(a) => commands::serve::run(a),
        Command::ExampleConfig(a) => commands::serve::example_config(a).map_err(Failure::from),
        Command::Scenarios(a) => commands::scenarios::run(a).map_err(Failure::from),
        Command::Fidelity(a) => commands::fidelity::run(a).map_err(Failure::from),
        Command::Reproduce(a) => commands::reproduce::run(a),
        Command::Run(a) => commands::run::run(a),
        Command::Estimate(a) => commands::estimate::run(a),
        Command::Failures(a) => commands::failures::run(a),
        Command::Fmu(c) => commands::fmu::run(c).map_err(Failure::from),
        Command::FmuWorker => commands::fmu::worker().map_err(Failure::from),
        Command::Simulate(a) => commands::simulate::run(a),
        Command::Toy(a) => commands::toy::run(a),
        Command::Worker(a) => commands::worker::run(a),
        Command::Completions(a) => {
            commands::completions::completions(a, help::command()).map_err(Failure::from)
        }
        Command::Man(a) => commands::completions::man(a, help::command()).map_err(Failure::from),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // The prefix clap gives the command line's errors: one for every error.
            eprintln!("error: {}", e.message());
            ExitCode::from(e.code())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Cli;
    use clap::Parser;

    fn parse(args: &str) -> Result<Cli, clap::Error> {
        Cli::try_parse_from(std::iter::once("savme").chain(args.split_whitespace()))
    }

    /// clap's own consistency checks on every subcommand (a flag defined twice, a clash
    /// between a positional argument and a flag of the same name): they otherwise fire only
    /// when that subcommand is parsed.
    #[test]
    fn every_subcommand_passes_claps_checks() {
        use clap::CommandFactory;
        Cli::command().debug_assert();
    }

    #[test]
    fn reproduce_help_states_the_protocol_it_runs_without_flags() {
        use clap::CommandFactory;
        let mut cli = Cli::command();
        let help = cli
            .find_subcommand_mut("reproduce")
            .expect("reproduce")
            .render_long_help()
            .to_string();
        // The paper's protocol (docs/RESULTS.md: 4,000 trials) and --quick's (README: 860).
        for text in [
            "seed 1, cost wall, 8 meta-training and 2 meta-testing scenarios",
            "budgets 0.2,0.3,0.4; per budget 500 meta-training iterations",
            "baselines of 700 and 300 trials (4000 trials in all)",
            "--quick: budgets 0.3; per budget 200 meta-training iterations",
            "(860 trials in all)",
            "default savme-results",
        ] {
            assert!(help.contains(text), "{text:?} not in:\n{help}");
        }
    }

    #[test]
    fn serve_without_a_configuration_or_journal_is_a_usage_error() {
        let Ok(Cli {
            command: super::Command::Serve(args),
            ..
        }) = parse("serve")
        else {
            panic!("savme serve did not parse");
        };
        // Refused before reading standard input, with exit status 2 (the command line is wrong).
        let e = crate::commands::serve::run(args).expect_err("serve ran without --config");
        assert_eq!(e.code(), 2, "{}", e.message());
        assert!(
            e.message().contains("give --config FILE"),
            "{}",
            e.message()
        );
    }

    #[test]
    fn toy_null_counts_work_units_and_refuses_wall_clock_cost() {
        let run = |args: &str| match parse(args) {
            Ok(Cli {
                command: super::Command::Toy(a),
                ..
            }) => crate::commands::toy::run(a),
            _ => panic!("{args} did not parse"),
        };
        let out = std::env::temp_dir().join(format!("savme-toy-null-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&out);
        // Its runs take no time: wall-clock cost is refused before anything is created ...
        let e = run(&format!(
            "toy --null --cost wall --quiet --out {}",
            out.display()
        ))
        .expect_err("--null --cost wall ran");
        assert_eq!(e.code(), 2, "{}", e.message());
        assert!(e.message().contains("--cost work"), "{}", e.message());
        assert!(!out.exists());
        // ... and without --cost the campaign runs with work units.
        let done = run(&format!(
            "toy --null --quiet --jobs 1 --out {}",
            out.display()
        ));
        let protocol = std::fs::read_to_string(out.join("protocol.json"));
        let _ = std::fs::remove_dir_all(&out);
        if let Err(e) = done {
            panic!("toy --null failed: {}", e.message());
        }
        assert!(protocol.is_ok_and(|p| p.contains(r#""cost": "work""#)));
        // A resumed campaign keeps its simulator: asking for another one is refused, not ignored.
        for flag in ["--null", "--sleep-ms 5"] {
            let e = run(&format!("toy --resume {} {flag}", out.display()))
                .expect_err("a simulator flag was accepted with --resume");
            assert_eq!(e.code(), 2, "{flag}: {}", e.message());
            assert!(
                e.message().contains("keeps its simulator"),
                "{}",
                e.message()
            );
        }
    }

    #[test]
    fn coordinator_flags_are_refused_where_they_would_be_ignored() {
        let db = "--storage postgresql://u@h/d --campaign c";
        // The coordinators take them ...
        for command in ["reproduce", "toy", "run --config c.toml"] {
            let args = format!("{command} {db} --remote --worker-wait 5");
            assert!(parse(&args).is_ok(), "{args}");
        }
        // ... a worker or a server has nothing to do with them: an unknown flag (exit 2),
        // not silently dropped.
        for command in ["worker", "serve"] {
            for flag in ["--remote", "--worker-wait 5"] {
                let args = format!("{command} {db} {flag}");
                let e = parse(&args)
                    .err()
                    .unwrap_or_else(|| panic!("{args} was accepted"));
                assert_eq!(e.kind(), clap::error::ErrorKind::UnknownArgument, "{args}");
                assert_eq!(e.exit_code(), 2, "{args}");
            }
            assert!(parse(&format!("{command} {db}")).is_ok(), "{command}");
        }
    }

    /// `-j N` is `--jobs N` wherever there is a `--jobs` (as cargo's).
    #[test]
    fn every_jobs_flag_has_short_j() {
        fn walk(c: &clap::Command, path: &str, found: &mut Vec<String>) {
            for a in c.get_arguments().filter(|a| a.get_long() == Some("jobs")) {
                assert_eq!(a.get_short(), Some('j'), "{path} --jobs has no -j");
                found.push(path.to_owned());
            }
            for s in c.get_subcommands() {
                walk(s, &format!("{path} {}", s.get_name()), found);
            }
        }
        let mut found = Vec::new();
        walk(&crate::help::command(), "savme", &mut found);
        assert!(found.len() >= 5, "{found:?}");
        for args in [
            "toy -j 3",
            "reproduce -j 2",
            "run --config c.toml -j 2",
            "estimate results -j 2",
            "worker --storage postgresql://u@h/d --campaign c -j 2",
        ] {
            assert!(parse(args).is_ok(), "{args}");
        }
    }
}
