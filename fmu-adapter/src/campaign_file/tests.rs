use super::*;
use savme_kernel::Scale;
use savme_kernel::Variable;
use std::path::PathBuf;

/// Issue 40 item 3: a label written before labels were canonical (the paths as given,
/// relative to the directory savme ran in) still names its FMUs: it matches the canonical
/// label of the same files, not of another file of the same name.
#[test]
fn an_old_relative_label_matches_the_same_files_only() {
    let dir = std::env::temp_dir().join(format!("savme-label-{}", std::process::id()));
    let sub = dir.join("campaigns").join("ref");
    std::fs::create_dir_all(&sub).unwrap();
    std::fs::create_dir_all(dir.join("other")).unwrap();
    for f in [sub.join("a.fmu"), dir.join("other").join("a.fmu")] {
        std::fs::write(f, b"PK").unwrap();
    }
    let given = label(&sub.join("./a.fmu"), &sub.join("a.fmu"));
    assert!(!given.contains("./"), "{given}");
    assert_eq!(given, label(&sub.join("../ref/a.fmu"), &sub.join("a.fmu")));
    // Run from `campaigns/` with `--config ref/campaign.toml`, from `ref/` with
    // `--config ./campaign.toml`, from elsewhere with an absolute path.
    for old in [
        "fmu:ref/a.fmu|ref/a.fmu",
        "fmu:./a.fmu|a.fmu",
        "fmu:campaigns/ref/../ref/a.fmu|campaigns/ref/a.fmu",
        &format!(
            "fmu:{}|{}",
            sub.join("a.fmu").display(),
            sub.join("a.fmu").display()
        ),
    ] {
        assert!(same_label(old, &given), "{old}");
    }
    let other = label(&dir.join("other/a.fmu"), &dir.join("other/a.fmu"));
    for old in [
        "fmu:ref/a.fmu|ref/a.fmu",
        "fmu:b.fmu|b.fmu",
        "fmu:a.fmu|b.fmu",
    ] {
        assert!(!same_label(old, &other), "{old}");
    }
    assert!(!same_label("savme-sim", &given));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A file every check before the FMUs accepts; its FMU does not exist, so a load that gets
/// that far fails at line 3 (`fmu.hf`).
const BASE: &str = r#"
[fmu]
hf = "nowhere.fmu"
stop_time = 1.0
step = { rate_of = "rate" }

[failure]
boolean = "failed"

[campaign]
budgets = [0.5]
out = "results"

[fidelity]
[[fidelity.variable]]
name = "rate"
values = [1.0, 2.0]
hf = 2.0

[[scenario]]
name = "grow"
role = "train"
fixed = { threshold = 0.5 }
[[scenario.phi]]
name = "start"
fmu = "x0"
range = [0.0, 1.0]

[[scenario]]
name = "other"
role = "test"
[[scenario.phi]]
name = "start"
range = [0.0, 1.0]
"#;

/// A fresh temporary directory for one test's campaign file, removed when it is dropped.
fn dir(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix(&format!("savme-campaign-file-{name}-"))
        .tempdir()
        .unwrap()
}

fn no_paper(_: u32) -> (Space, Assignment) {
    panic!("the paper's space was asked for")
}

fn paper(bins: u32) -> (Space, Assignment) {
    let space = Space::new(vec![Variable::continuous(
        "rate",
        1.0,
        10.0,
        bins,
        Scale::Linear,
    )])
    .unwrap();
    (space, Assignment::new().with("rate", 10.0))
}

/// Loads `body` (BASE with replacements) and returns the error.
fn error(name: &str, replace: &[(&str, &str)]) -> ConfigError {
    let mut body = BASE.to_string();
    for (from, to) in replace {
        assert!(body.contains(from), "{from}");
        body = body.replacen(from, to, 1);
    }
    let scratch = dir(name);
    let path = scratch.path().join("campaign.toml");
    std::fs::write(&path, body).unwrap();
    let e = FmuCampaignFile::load(&path, &no_paper).unwrap_err();
    assert_eq!(e.file, path.display().to_string());
    e
}

fn at(e: &ConfigError) -> (Option<usize>, Option<&str>) {
    (e.line, e.key.as_deref())
}

#[test]
fn an_empty_fmu_path_and_an_infinite_timeout_are_named_at_their_key() {
    let e = error("empty-hf", &[("hf = \"nowhere.fmu\"", "hf = \"\"")]);
    assert_eq!(e.key.as_deref(), Some("fmu.hf"), "{e}");
    assert!(
        e.to_string().contains("is empty: give the path of an FMU"),
        "{e}"
    );
    let e = error(
        "inf-timeout",
        &[(
            "hf = \"nowhere.fmu\"",
            "hf = \"nowhere.fmu\"\ntimeout_s = inf",
        )],
    );
    assert_eq!(e.key.as_deref(), Some("fmu.timeout_s"), "{e}");
    assert!(
        e.to_string()
            .contains("must be a finite number of seconds > 0, got inf"),
        "{e}"
    );
}

#[test]
fn the_base_file_gets_as_far_as_its_fmu() {
    let e = error("base", &[]);
    assert_eq!(at(&e), (Some(3), Some("fmu.hf / fmu.lf")));
    assert!(e.message.contains("nowhere.fmu"), "{e}");
}

#[test]
fn openscenario_keys_are_checked_naming_their_key() {
    // The file and phi tables both.
    let e = error(
        "osc-and-phi",
        &[("fixed = { threshold = 0.5 }", "openscenario = \"v.xosc\"")],
    );
    assert_eq!(at(&e), (Some(24), Some("scenario[0].phi")));
    assert!(e.message.contains("either it or [[scenario.phi]]"), "{e}");
    // A file that is not there: named with the key's line.
    let e = error(
        "osc-missing",
        &[(
            "fixed = { threshold = 0.5 }\n[[scenario.phi]]\nname = \"start\"\nfmu = \"x0\"\nrange = [0.0, 1.0]",
            "openscenario = \"missing.xosc\"",
        )],
    );
    assert_eq!(at(&e), (Some(23), Some("scenario[0].openscenario")));
    assert!(e.message.contains("missing.xosc: "), "{e}");
    // `bind` without a file.
    let e = error(
        "bind-alone",
        &[(
            "role = \"test\"",
            "role = \"test\"\nbind = { start = \"x0\" }",
        )],
    );
    assert_eq!(at(&e), (Some(32), Some("scenario[1].bind.start")));
    assert!(
        e.message
            .contains("renames the parameters of an `openscenario` file"),
        "{e}"
    );
}

#[test]
fn a_toml_syntax_error_names_its_line() {
    let e = error("syntax", &[("stop_time = 1.0", "stop_time = = 1.0")]);
    assert_eq!(at(&e), (Some(4), None));
    assert!(e.to_string().contains("campaign.toml, line 4: "), "{e}");
}

#[test]
fn an_unknown_key_names_its_line() {
    let e = error(
        "unknown",
        &[("stop_time = 1.0", "stop_time = 1.0\nstop_tme = 3")],
    );
    assert_eq!(at(&e), (Some(5), None));
    assert!(e.message.starts_with("unknown field `stop_tme`"), "{e}");
    // (An unknown `[campaign]` key is refused by the campaign layer, which reads the
    // protocol's values by name: savme_campaign::config's tests.)
}

#[test]
fn a_variable_with_values_and_range_is_refused() {
    let e = error(
        "both",
        &[("range = [0.0, 1.0]", "range = [0.0, 1.0]\nvalues = [1, 2]")],
    );
    assert_eq!(at(&e), (Some(24), Some("scenario[0].phi[0]")));
    assert_eq!(
        e.message,
        "give either `values` (discrete) or `range` (continuous)"
    );
}

#[test]
fn bad_variables_name_their_part() {
    for (from, to, line, key, message) in [
        (
            "range = [0.0, 1.0]",
            "range = [1.0, 0.0]",
            27,
            "range",
            "`range` = [1, 0] is empty",
        ),
        (
            "range = [0.0, 1.0]",
            "range = [0.0, 1.0]\nbins = 0",
            28,
            "bins",
            "`bins` must be at least 1",
        ),
        (
            "range = [0.0, 1.0]",
            "range = [0.0, 1.0]\nscale = \"log\"",
            28,
            "scale",
            "a log scale needs 0 < lo (range [0, 1])",
        ),
        (
            "range = [0.0, 1.0]",
            "values = []",
            27,
            "values",
            "`values` is empty",
        ),
        (
            "range = [0.0, 1.0]",
            "values = [[1]]",
            27,
            "values",
            "`values` must be numbers, booleans or strings",
        ),
    ] {
        let e = error("variable", &[(from, to)]);
        let key = format!("scenario[0].phi[0].{key}");
        assert_eq!(at(&e), (Some(line), Some(key.as_str())), "{e}");
        assert_eq!(e.message, message);
    }
}

/// A replacement in BASE, and where the error is: line, key and part of the message.
type Case<'a> = (&'a [(&'a str, &'a str)], usize, &'a str, &'a str);

/// Checks (in the directory `name`) that each case's error names its line and key: every error before the FMU check
/// that names a key also names the line of the part of the file it is about.
fn expect_lines(name: &str, cases: &[Case]) {
    let mut wrong = Vec::new();
    for &(replace, line, key, message) in cases {
        let e = error(name, replace);
        if at(&e) != (Some(line), Some(key)) || !e.message.contains(message) {
            wrong.push(format!(
                "{replace:?}\n  expected line {line}, key `{key}`, `{message}`\n  got {e}"
            ));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

const SIDES: &str = "`above` / `below`";

#[test]
fn a_bad_failure_section_names_the_key_that_does_not_fit() {
    let b = "boolean = \"failed\"";
    expect_lines(
        "failure-keys",
        &[
            (&[(b, "threshold = \"x\"")], 8, "failure.threshold", SIDES),
            (
                &[(b, "threshold = \"x\"\nabove = 1.0\nbelow = 0.0")],
                10,
                "failure.below",
                SIDES,
            ),
            (
                &[(b, "boolean = \"failed\"\nthreshold = \"x\"\nabove = 1.0")],
                9,
                "failure.threshold",
                SIDES,
            ),
            (
                &[(b, "boolean = \"failed\"\nabove = 1.0")],
                9,
                "failure.above",
                SIDES,
            ),
            (&[(b, "")], 7, "failure", SIDES),
            // A robustness output goes with a Boolean only (a threshold's is its margin).
            (
                &[(b, "threshold = \"x\"\nbelow = 0.0\nrobustness = \"d\"")],
                10,
                "failure.robustness",
                "`robustness = \"output\"`",
            ),
            (&[(b, "robustness = \"d\"")], 8, "failure.robustness", SIDES),
            // A threshold no value crosses (NaN), or every value does, is refused.
            (
                &[(b, "threshold = \"x\"\nbelow = nan")],
                9,
                "failure.below",
                "NaN is not a finite number",
            ),
            (
                &[(b, "threshold = \"x\"\nabove = -inf")],
                9,
                "failure.above",
                "-inf is not a finite number",
            ),
        ],
    );
}

#[test]
fn a_bad_fidelity_space_names_the_part_at_fault() {
    let values = "values = [1.0, 2.0]";
    let second = "hf = 2.0\n[[fidelity.variable]]\nname = \"rate\"\nvalues = [3.0]\nhf = 3.0";
    let all = "[[fidelity.variable]]\nname = \"rate\"\nvalues = [1.0, 2.0]\nhf = 2.0";
    let k = "fidelity.variable[0]";
    expect_lines(
        "fidelity-keys",
        &[
            (
                &[(values, "values = [1.0, 1.0]")],
                17,
                &format!("{k}.values"),
                "lists the value 1 twice",
            ),
            (
                &[(values, "values = [1.0, nan]")],
                17,
                &format!("{k}.values"),
                "NaN",
            ),
            (
                &[("name = \"rate\"", "name = \" \"")],
                16,
                &format!("{k}.name"),
                "empty name",
            ),
            (
                &[("hf = 2.0", second)],
                20,
                "fidelity.variable[1].name",
                "`rate` is defined twice",
            ),
            (
                &[(values, "range = [1.0, 2.0]\nbins = 100000")],
                18,
                &format!("{k}.bins"),
                "arms",
            ),
            (
                &[(values, "range = [1.0, inf]")],
                17,
                &format!("{k}.range"),
                "non-finite",
            ),
            // Finite but too wide to compute with: refused, not a panic at the first draw.
            (
                &[(values, "range = [-1e308, 1e308]")],
                17,
                &format!("{k}.range"),
                "`rate` has a range too wide",
            ),
            // A third number is not dropped silently; one number names the key too.
            (
                &[(values, "range = [1.0, 2.0, 3.0]")],
                17,
                &format!("{k}.range"),
                "`range` must be [lo, hi], got 3 numbers",
            ),
            (
                &[(values, "range = [1.0]")],
                17,
                &format!("{k}.range"),
                "`range` must be [lo, hi], got 1 numbers",
            ),
            (
                &[("hf = 2.0", "hf = 3.0")],
                18,
                &format!("{k}.hf"),
                "θ_HF: value 3 is outside",
            ),
            (
                &[("hf = 2.0", "hf = [2.0]")],
                18,
                &format!("{k}.hf"),
                "θ_HF value",
            ),
            (&[(all, "")], 14, "fidelity", "no variables"),
        ],
    );
}

#[test]
fn a_bad_phi_space_or_run_setting_names_its_line() {
    let start = "name = \"start\"\nrange = [0.0, 1.0]";
    let twice = "name = \"start\"\nrange = [0.0, 1.0]\n[[scenario.phi]]\nname = \"start\"\nfmu = \"y\"\nrange = [0.0, 1.0]";
    let role = "role = \"test\"\n[[scenario.phi]]\nname = \"start\"\nrange = [0.0, 1.0]";
    expect_lines(
        "phi-keys",
        &[
            (
                &[("range = [0.0, 1.0]", "range = [0.0, inf]")],
                27,
                "scenario[0].phi[0].range",
                "non-finite",
            ),
            (
                &[("range = [0.0, 1.0]", "range = [-1e308, 1e308]")],
                27,
                "scenario[0].phi[0].range",
                "range too wide",
            ),
            (
                &[(start, twice)],
                36,
                "scenario[1].phi[1].name",
                "`start` is defined twice",
            ),
            (
                &[(role, "role = \"test\"\nphi = []")],
                29,
                "scenario[1].phi",
                "no variables",
            ),
            // Named here, not later by the kernel without the file and line.
            (
                &[("name = \"other\"", "name = \" \"")],
                30,
                "scenario[1].name",
                "a scenario has an empty name",
            ),
            (
                &[("stop_time = 1.0", "stop_time = 0.0")],
                4,
                "fmu.stop_time",
                "stop time 0 is not a positive",
            ),
            (
                &[("step = { rate_of = \"rate\" }", "step = -0.5")],
                5,
                "fmu.step",
                "step size -0.5 is not a positive",
            ),
            // A run that cannot finish: more steps than a run may take.
            (
                &[("step = { rate_of = \"rate\" }", "step = 1e-300")],
                5,
                "fmu.step",
                "more than the maximum of 1e9 steps",
            ),
            (
                &[(
                    "values = [1.0, 2.0]\nhf = 2.0",
                    "values = [1.0, 2e12]\nhf = 1.0",
                )],
                5,
                "fmu.step.rate_of",
                "step size 5e-13 s makes 2.000e12 steps",
            ),
        ],
    );
}

/// Two bindings that would set one FMU variable in the same run are refused at the later
/// one, naming the other with its line.
#[test]
fn conflicting_bindings_are_refused_naming_both() {
    let phi_start = "name = \"start\"\nrange = [0.0, 1.0]\n";
    for (name, replace, line, key, message) in [
        (
            "fixed-and-phi",
            vec![("threshold = 0.5", "threshold = 0.5, x0 = 1.0")],
            26,
            "scenario[0].phi[0].fmu",
            "FMU variable `x0` is already bound by `scenario[0].fixed.x0` (line 23)",
        ),
        (
            "two-phi-by-name",
            vec![(phi_start, "name = \"start\"\nrange = [0.0, 1.0]\n[[scenario.phi]]\nname = \"end\"\nfmu = \"start\"\nrange = [0.0, 1.0]\n")],
            37,
            "scenario[1].phi[1].fmu",
            "FMU variable `start` is already bound by `scenario[1].phi[0].name` (line 33)",
        ),
        (
            "two-phi-by-fmu",
            vec![("range = [0.0, 1.0]\n\n", "range = [0.0, 1.0]\n[[scenario.phi]]\nname = \"end\"\nfmu = \"x0\"\nrange = [0.0, 1.0]\n\n")],
            30,
            "scenario[0].phi[1].fmu",
            "FMU variable `x0` is already bound by `scenario[0].phi[0].fmu` (line 26)",
        ),
        (
            "phi-and-fidelity",
            vec![(phi_start, "name = \"start\"\nfmu = \"rate\"\nrange = [0.0, 1.0]\n")],
            34,
            "scenario[1].phi[0].fmu",
            "FMU variable `rate` is already bound by `fidelity.variable[0].name` (line 16)",
        ),
        (
            "fixed-and-fidelity",
            vec![("threshold = 0.5", "threshold = 0.5, rate = 1.0")],
            23,
            "scenario[0].fixed.rate",
            "FMU variable `rate` is already bound by `fidelity.variable[0].name` (line 16)",
        ),
        (
            "two-fidelity",
            vec![("hf = 2.0", "hf = 2.0\n[[fidelity.variable]]\nname = \"fps\"\nfmu = \"rate\"\nvalues = [1]\nhf = 1")],
            21,
            "fidelity.variable[1].fmu",
            "FMU variable `rate` is already bound by `fidelity.variable[0].name` (line 16)",
        ),
    ] {
        let e = error(name, &replace);
        assert_eq!(at(&e), (Some(line), Some(key)), "{name}: {e}");
        assert_eq!(e.message, message, "{name}");
    }
    // The later binding is blamed whichever is read first: here the fidelity comes last.
    let body = BASE.replacen("threshold = 0.5", "threshold = 0.5, rate = 1.0", 1);
    let (head, fidelity) = body.split_at(body.find("[fidelity]").unwrap());
    let (fidelity, scenarios) = fidelity.split_at(fidelity.find("[[scenario]]").unwrap());
    let scratch = dir("fidelity-last");
    let path = scratch.path().join("campaign.toml");
    std::fs::write(&path, format!("{head}{scenarios}\n{fidelity}")).unwrap();
    let e = FmuCampaignFile::load(&path, &no_paper).unwrap_err();
    assert_eq!(at(&e), (Some(32), Some("fidelity.variable[0].name")), "{e}");
    assert_eq!(
        e.message,
        "FMU variable `rate` is already bound by `scenario[0].fixed.rate` (line 17)"
    );
}

#[test]
fn a_paper_setting_cannot_be_bound_again() {
    let body = BASE
        .replacen(
            "[[fidelity.variable]]\nname = \"rate\"\nvalues = [1.0, 2.0]\nhf = 2.0",
            "",
            1,
        )
        .replacen("[fidelity]", "[fidelity]\npaper = true", 1)
        .replacen("threshold = 0.5", "threshold = 0.5, rate = 1.0", 1);
    let scratch = dir("paper-bound");
    let path = scratch.path().join("campaign.toml");
    std::fs::write(&path, body).unwrap();
    let e = FmuCampaignFile::load(&path, &paper).unwrap_err();
    assert_eq!(at(&e), (Some(21), Some("scenario[0].fixed.rate")), "{e}");
    assert_eq!(
        e.message,
        "FMU variable `rate` is already bound by `fidelity.paper` (line 15)"
    );
}

#[test]
fn scenarios_may_share_fmu_variables() {
    // Scenario 1 sets `x0` by φ, scenario 0 by φ and scenario 1 fixes `threshold` too: they
    // are set in different runs, so the file gets as far as its FMU.
    let e = error(
        "shared",
        &[
            (
                "role = \"test\"\n",
                "role = \"test\"\nfixed = { threshold = 0.1 }\n",
            ),
            (
                "name = \"start\"\nrange = [0.0, 1.0]\n",
                "name = \"start\"\nfmu = \"x0\"\nrange = [0.0, 1.0]\n",
            ),
        ],
    );
    assert_eq!(at(&e), (Some(3), Some("fmu.hf / fmu.lf")), "{e}");
}

#[test]
fn a_file_without_scenarios_is_refused_at_its_line() {
    let body = BASE.replacen("\n[fmu]", "\nscenario = []\n[fmu]", 1);
    let body = &body[..body.find("[[scenario]]").unwrap()];
    let scratch = dir("no-scenarios");
    let path = scratch.path().join("campaign.toml");
    std::fs::write(&path, body).unwrap();
    let e = FmuCampaignFile::load(&path, &no_paper).unwrap_err();
    assert_eq!(at(&e), (Some(2), Some("scenario")), "{e}");
    assert_eq!(e.message, "no scenarios: give [[scenario]] tables");
}

#[test]
fn rate_of_must_name_a_fidelity_variable() {
    let e = error("rate-of", &[("rate_of = \"rate\"", "rate_of = \"fps\"")]);
    assert_eq!(at(&e), (Some(5), Some("fmu.step.rate_of")));
    assert_eq!(e.message, "`fps` is not a fidelity variable");
}

#[test]
fn a_scenario_defined_twice_is_refused() {
    let e = error("twice", &[("name = \"other\"", "name = \"grow\"")]);
    assert_eq!(at(&e), (Some(30), Some("scenario[1].name")));
    assert_eq!(e.message, "scenario `grow` is defined twice");
}

#[test]
fn a_role_is_train_or_test() {
    let e = error("role", &[("role = \"test\"", "role = \"tset\"")]);
    assert_eq!(at(&e), (Some(31), Some("scenario[1].role")));
    assert_eq!(e.message, "`tset`: expected \"train\" or \"test\"");
}

#[test]
fn fixed_parameters_are_scalars() {
    let e = error("fixed", &[("threshold = 0.5", "threshold = [0.5]")]);
    assert_eq!(at(&e), (Some(23), Some("scenario[0].fixed.threshold")));
    assert_eq!(e.message, "expected a number, boolean or string");
}

#[test]
fn fidelity_variables_need_a_theta_hf_inside_their_space() {
    let e = error("no-hf", &[("hf = 2.0", "")]);
    assert_eq!(at(&e), (Some(15), Some("fidelity.variable[0].hf")));
    let e = error("hf-out", &[("hf = 2.0", "hf = 3.0")]);
    assert_eq!(at(&e), (Some(18), Some("fidelity.variable[0].hf")));
    assert!(e.message.starts_with("θ_HF: "), "{e}");
}

#[test]
fn paper_excludes_variables_and_needs_bins() {
    let e = error("paper-and", &[("[fidelity]", "[fidelity]\npaper = true")]);
    assert_eq!(at(&e), (Some(16), Some("fidelity.variable")));
    assert_eq!(
        e.message,
        "give either `paper = true` or variables, not both"
    );
    // Zero bins are refused before the paper's space is built (it could not be).
    let e = error(
        "paper-zero",
        &[
            ("budgets = [0.5]", "fidelity_bins = 0"),
            (
                "[[fidelity.variable]]\nname = \"rate\"\nvalues = [1.0, 2.0]\nhf = 2.0",
                "",
            ),
            ("[fidelity]", "[fidelity]\npaper = true"),
        ],
    );
    assert_eq!(at(&e), (Some(11), Some("campaign.fidelity_bins")));
    assert_eq!(e.message, "must be at least 1");
    // So are more bins than an arm index holds (the paper's space would panic).
    let e = error(
        "paper-huge",
        &[
            ("budgets = [0.5]", "fidelity_bins = 4294967295"),
            (
                "[[fidelity.variable]]\nname = \"rate\"\nvalues = [1.0, 2.0]\nhf = 2.0",
                "",
            ),
            ("[fidelity]", "[fidelity]\npaper = true"),
        ],
    );
    assert_eq!(at(&e), (Some(11), Some("campaign.fidelity_bins")));
    assert_eq!(e.message, "4294967295 bins: at most 65535 are supported");
}

#[test]
fn an_empty_out_is_refused() {
    // "" resolved to the file's own directory: the campaign was written beside its FMUs.
    let e = error("out-empty", &[("out = \"results\"", "out = \"\"")]);
    assert_eq!(at(&e), (Some(12), Some("campaign.out")));
    assert!(e.message.starts_with("is empty"), "{e}");
}

#[test]
fn the_paper_space_comes_from_the_caller() {
    let body = BASE
        .replacen("budgets = [0.5]", "fidelity_bins = 4", 1)
        .replacen(
            "[[fidelity.variable]]\nname = \"rate\"\nvalues = [1.0, 2.0]\nhf = 2.0",
            "",
            1,
        )
        .replacen("[fidelity]", "[fidelity]\npaper = true", 1);
    let scratch = dir("paper");
    let path = scratch.path().join("campaign.toml");
    std::fs::write(&path, body).unwrap();
    let asked = std::cell::Cell::new(None);
    let e = FmuCampaignFile::load(&path, &|bins| {
        asked.set(Some(bins));
        paper(bins)
    })
    .unwrap_err();
    assert_eq!(asked.get(), Some(4));
    // `rate` is the paper's: the file gets as far as its FMU.
    assert_eq!(e.key.as_deref(), Some("fmu.hf / fmu.lf"), "{e}");
}

#[test]
fn the_failure_signal_is_boolean_or_a_threshold_with_one_side() {
    for (to, name, line, key) in [
        ("threshold = \"x\"", "no-side", 8, "failure.threshold"),
        (
            "threshold = \"x\"\nabove = 1.0\nbelow = 0.0",
            "two-sides",
            10,
            "failure.below",
        ),
        (
            "boolean = \"failed\"\nthreshold = \"x\"\nabove = 1.0",
            "both",
            9,
            "failure.threshold",
        ),
    ] {
        let e = error(name, &[("boolean = \"failed\"", to)]);
        assert_eq!(at(&e), (Some(line), Some(key)), "{name}");
        assert!(e.message.contains("`above` / `below`"), "{e}");
    }
}

#[test]
fn a_missing_file_is_named() {
    let scratch = dir("missing");
    let path = scratch.path().join("campaign.toml");
    let e = FmuCampaignFile::load(&path, &no_paper).unwrap_err();
    assert_eq!(at(&e), (None, None));
    assert!(
        e.to_string().starts_with(&path.display().to_string()),
        "{e}"
    );
}

#[test]
fn the_campaign_section_keeps_its_values_and_lines() {
    let text = BASE.replacen(
        "budgets = [0.5]",
        "budgets = [0.5]\nseed = 7\ncost = \"work\"\nprior_strength = 0.5\nrepeat = 3\nprior_strengths = [0, 0.5]",
        1,
    );
    let src = Source::new("campaign.toml", text);
    let path = Path::new("/runs/campaign.toml");
    let c = CampaignFile::parse(&src, path, &SECTIONS, &no_paper)
        .unwrap()
        .campaign;
    let value = |k: &str| c.values.get(k).cloned();
    assert_eq!(value("budgets"), Some(toml::Value::Array(vec![0.5.into()])));
    assert_eq!(value("seed"), Some(toml::Value::Integer(7)));
    assert_eq!(value("cost"), Some(toml::Value::String("work".into())));
    assert_eq!(value("prior_strength"), Some(toml::Value::Float(0.5)));
    assert_eq!(value("repeat"), Some(toml::Value::Integer(3)));
    assert_eq!(value("train_iterations"), None);
    assert_eq!(c.fidelity_bins(), None);
    assert_eq!(c.out, Some(PathBuf::from("/runs/results")));
    let lines: Vec<(&str, usize)> = c.lines.iter().map(|(k, l)| (k.as_str(), *l)).collect();
    assert_eq!(
        lines,
        [
            ("budgets", 11),
            ("cost", 13),
            ("out", 17),
            ("prior_strength", 14),
            ("prior_strengths", 16),
            ("repeat", 15),
            ("seed", 12)
        ]
    );
    // No [campaign] table: nothing given.
    let text = BASE.replacen("[campaign]\nbudgets = [0.5]\nout = \"results\"\n", "", 1);
    let src = Source::new("campaign.toml", text);
    let path = Path::new("campaign.toml");
    let c = CampaignFile::parse(&src, path, &SECTIONS, &no_paper)
        .unwrap()
        .campaign;
    assert_eq!(c, CampaignSection::default());
}

#[test]
fn a_wrong_on_error_names_its_line() {
    // (A wrong `[campaign] cost` is refused by the campaign layer, which reads the
    // protocol's values: savme_campaign::config's tests.)
    let e = error(
        "on-error",
        &[("stop_time = 1.0", "stop_time = 1.0\non_error = \"ignore\"")],
    );
    assert_eq!(at(&e), (Some(5), None));
    assert_eq!(
        e.message,
        "unknown variant `ignore`, expected `abort` or `skip`"
    );
}

#[test]
fn lines_and_errors_display_as_before() {
    let line_of = savme_campaign_file::line_of;
    assert_eq!(line_of("a\nb\nc", 0), 1);
    assert_eq!(line_of("a\nb\nc", 2), 2);
    assert_eq!(line_of("a\nb\nc", 99), 3);
    let e = ConfigError {
        file: "f.toml".into(),
        line: None,
        key: Some("failure".into()),
        message: "m".into(),
    };
    assert_eq!(e.to_string(), "f.toml, key `failure`: m");
    let e = ConfigError { key: None, ..e };
    assert_eq!(e.to_string(), "f.toml: m");
}
