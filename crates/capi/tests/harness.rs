//! The C and C++ example harnesses, built with CMake against the library as
//! `scripts/install` installs it (the CMake package, the headers, libsavme.so and libsavme.a),
//! run under AddressSanitizer and UndefinedBehaviorSanitizer with zero reports, and compared:
//! C and C++ give the same lines, the same campaign through the Rust kernel API gives the same
//! trials, and a journaled campaign killed with SIGKILL resumes to the same end.
//!
//! Needs cmake and a C/C++ compiler with the sanitizers (gcc): without cmake the tests say so
//! loudly and pass, unless SAVME_REQUIRE_CMAKE is set (scripts/test sets it).

use savme_kernel::estimation::EstimationConfig;
use savme_kernel::{Assignment, Estimator, Kernel, Observation, Phase, Run, Trial, Value};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

fn capi() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn config_path() -> PathBuf {
    capi().join("examples/config.json")
}

/// The built harnesses (built once per test process), or None when cmake is missing.
fn built() -> Option<&'static Path> {
    static BUILT: OnceLock<Option<PathBuf>> = OnceLock::new();
    BUILT.get_or_init(build).as_deref()
}

fn build() -> Option<PathBuf> {
    if Command::new("cmake").arg("--version").output().is_err() {
        assert!(
            std::env::var_os("SAVME_REQUIRE_CMAKE").is_none(),
            "SAVME_REQUIRE_CMAKE is set but cmake is not installed"
        );
        eprintln!("\n*** SKIPPED: cmake not found: the C and C++ harnesses were NOT built or run (apt-get install cmake) ***\n");
        return None;
    }
    // target/debug/deps, where cargo built libsavme_capi.so and .a for this test (it copies
    // them up to target/debug only for `cargo build`).
    let exe = std::env::current_exe().unwrap();
    let lib_dir = exe.parent().unwrap().to_path_buf();
    let work = lib_dir.join("capi-harness");
    let _ = std::fs::remove_dir_all(&work);
    let prefix = work.join("prefix");
    let build = work.join("build");
    run_ok(
        Command::new(capi().join("scripts/install"))
            .arg(&prefix)
            .arg("--lib-dir")
            .arg(&lib_dir),
    );
    run_ok(
        Command::new("cmake")
            .arg("-S")
            .arg(capi().join("examples"))
            .arg("-B")
            .arg(&build)
            .arg(format!("-DCMAKE_PREFIX_PATH={}", prefix.display()))
            .arg("-DSAVME_SANITIZE=ON"),
    );
    run_ok(Command::new("cmake").arg("--build").arg(&build));
    pkg_config(&prefix, &build);
    Some(build)
}

/// The pkg-config file: the C harness compiled with `pkg-config --cflags --libs savme` alone
/// (against libsavme.so, found at run time through an rpath to the prefix).
fn pkg_config(prefix: &Path, build: &Path) {
    let pc = prefix.join("lib/pkgconfig");
    let flags = Command::new("pkg-config")
        .args(["--cflags", "--libs", "savme"])
        .env("PKG_CONFIG_PATH", &pc)
        .output();
    let flags = match flags {
        Ok(out) if out.status.success() => String::from_utf8(out.stdout).unwrap(),
        Ok(out) => panic!("pkg-config savme: {}", String::from_utf8_lossy(&out.stderr)),
        Err(_) => {
            assert!(
                std::env::var_os("SAVME_REQUIRE_CMAKE").is_none(),
                "SAVME_REQUIRE_CMAKE is set but pkg-config is not installed"
            );
            eprintln!("\n*** SKIPPED: pkg-config not found: savme.pc was NOT checked ***\n");
            return;
        }
    };
    let examples = capi().join("examples");
    let exe = build.join("harness_pkg_config");
    run_ok(
        Command::new("cc")
            .arg(examples.join("c/harness.c"))
            .arg(examples.join("sim.c"))
            .arg("-o")
            .arg(&exe)
            .args(flags.split_whitespace())
            .arg(format!("-Wl,-rpath,{}", prefix.join("lib").display())),
    );
    let out = run_ok(
        Command::new(&exe)
            .arg("--config")
            .arg(config_path())
            .args(["--train", "5", "--evaluate", "2", "--baseline", "2"])
            .env_remove("LD_LIBRARY_PATH"),
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        text.lines().filter(|l| l.starts_with("trial ")).count(),
        9,
        "{text}"
    );
}

fn run_ok(c: &mut Command) -> Output {
    let out = c.output().unwrap_or_else(|e| panic!("{c:?}: {e}"));
    assert!(
        out.status.success(),
        "{c:?} failed: {}\n{}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Runs a harness under the sanitizers: any report fails the run (and the test).
fn harness(exe: &str, args: &[&str]) -> Output {
    let dir = built().expect("built");
    let mut c = Command::new(dir.join(exe));
    c.arg("--config")
        .arg(config_path())
        .args(args)
        .env(
            "ASAN_OPTIONS",
            "detect_leaks=1:halt_on_error=1:abort_on_error=0",
        )
        .env("UBSAN_OPTIONS", "halt_on_error=1:print_stacktrace=1")
        // cargo's test library path would come before the harness's RUNPATH (the installed
        // library): the harness must load what it was linked against.
        .env_remove("LD_LIBRARY_PATH");
    let out = c.output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    for report in [
        "AddressSanitizer",
        "LeakSanitizer",
        "runtime error:",
        "UndefinedBehaviorSanitizer",
    ] {
        assert!(
            !stderr.contains(report),
            "{exe} {args:?}: sanitizer report:\n{stderr}"
        );
    }
    let killed = {
        use std::os::unix::process::ExitStatusExt;
        out.status.signal() == Some(9)
    };
    assert!(
        out.status.success() || killed,
        "{exe} {args:?}: {}\n{stderr}",
        out.status
    );
    out
}

/// Asserts `a` and `b` have the same lines, naming the first that differs.
fn same_lines(a: &str, b: &str, what: &str) {
    for (i, (x, y)) in a.lines().zip(b.lines()).enumerate() {
        assert_eq!(x, y, "{what}: line {} differs", i + 1);
    }
    assert_eq!(
        a.lines().count(),
        b.lines().count(),
        "{what}: line counts differ"
    );
}

const REFUSED: &str = "refused (6): savme_tell_hf_only: trial 0 was already told or cancelled\n";

fn stdout(o: &Output) -> String {
    String::from_utf8(o.stdout.clone()).unwrap()
}

fn hex(x: f64) -> String {
    format!("{:016x}", x.to_bits())
}

fn value(name: &str, v: &Value) -> String {
    match v {
        Value::Bool(b) => format!("{name}=b:{}", u8::from(*b)),
        Value::Int(i) => format!("{name}=i:{i}"),
        Value::Real(x) => format!("{name}=r:{}", hex(*x)),
        Value::Label(s) => format!("{name}=s:{s}"),
    }
}

fn part(a: &Assignment) -> String {
    let values: Vec<String> = a.iter().map(|(n, v)| value(n, v)).collect();
    format!("[{}]", values.join(","))
}

/// One run as a harness line prints it (`1/<runtime bits>/<robustness bits>`).
fn parse_run(s: &str) -> Run {
    let mut f = s.split('/');
    let failure = f.next().unwrap() == "1";
    let bits = |t: &str| f64::from_bits(u64::from_str_radix(t, 16).unwrap());
    let runtime = bits(f.next().unwrap());
    let robustness = bits(f.next().unwrap());
    Run::new(failure, runtime).with_robustness(robustness)
}

/// The campaign of a harness's output replayed through the Rust kernel API: the same phases
/// and batches, each ask compared with the harness's line, the harness's runs told. Returns
/// the lines the Rust API prints for them.
fn replay(output: &str, counts: [u64; 3], batch: u64) -> Vec<String> {
    let text = std::fs::read_to_string(config_path()).unwrap();
    let mut k = Kernel::new(savme_serve::parse_config(&text).unwrap()).unwrap();
    let lines: Vec<&str> = output.lines().collect();
    let mut out = Vec::new();
    let (mut end, mut next) = (0, 0);
    for (phase, count) in [Phase::Train, Phase::Evaluate, Phase::Baseline]
        .into_iter()
        .zip(counts)
    {
        end += count;
        k.set_phase(phase);
        while k.stats().told < end {
            let n = (end - k.stats().told).min(batch);
            let asked: Vec<Trial> = (0..n).map(|_| k.ask()).collect();
            for t in asked {
                let line = lines[next];
                next += 1;
                let mut mine = format!(
                    "trial {} {} {} phi{}",
                    t.id,
                    t.phase,
                    t.scenario,
                    part(&t.phi)
                );
                let field = |key: &str| {
                    line.split(' ')
                        .find_map(|w| w.strip_prefix(key))
                        .unwrap_or_else(|| panic!("no {key} in {line}"))
                };
                let hf = parse_run(field("hf="));
                mine += &format!(" hf={}", field("hf="));
                let observation = match &t.theta_lf {
                    Some(theta) => {
                        let lf = field("lf[").rsplit('=').next().unwrap();
                        mine += &format!(" lf{}={lf}", part(theta));
                        Observation::Paired {
                            hf,
                            lf: parse_run(lf),
                        }
                    }
                    None => Observation::HfOnly(hf),
                };
                assert_eq!(
                    mine, line,
                    "the Rust API asked another trial than the harness"
                );
                k.tell(t.id, observation).unwrap();
                out.push(mine);
            }
        }
    }
    // The configuration's estimator (examples/config.json: evidence, the tuned default).
    let estimator = k.config().estimator;
    assert_eq!(estimator, Estimator::Evidence);
    let best = k.fidelity_estimate(estimator);
    let evidence = savme_serve::evidence(k.fidelity_posterior());
    out.push(format!(
        "theta_lf* {} evidence={}",
        part(&best),
        hex(evidence)
    ));
    assert_eq!(lines[next], out.last().unwrap());
    let settings = savme_serve::chosen_settings(&k, estimator);
    assert!(settings.is_some(), "an evidence kernel keeps tallies");
    out.push(format!(
        "settings {}",
        serde_json::to_string(&settings).unwrap()
    ));
    assert_eq!(lines[next + 1], out.last().unwrap());
    // The estimation: the same trials from the same posteriors and configuration.
    let mut e = k.estimation(&EstimationConfig::new(0.2, 3)).unwrap();
    for line in lines
        .iter()
        .filter(|l| l.starts_with("estimation ") && !l.starts_with("estimation result"))
    {
        let t = e.ask().unwrap();
        let hf = line.rsplit("hf=").next().unwrap();
        let mine = format!(
            "estimation {} {} phi{} weight={} hf={hf}",
            t.id,
            t.scenario,
            part(&t.phi),
            hex(t.weight)
        );
        assert_eq!(&mine, line);
        let (failure, robustness) = hf.split_once('/').unwrap();
        let robustness = f64::from_bits(u64::from_str_radix(robustness, 16).unwrap());
        e.tell_run(t.id, failure == "1", Some(robustness)).unwrap();
        out.push(mine);
    }
    let result = lines
        .iter()
        .find(|l| l.starts_with("estimation result "))
        .unwrap();
    let expected =
        serde_json::json!({"estimate": e.estimate(), "told": e.told(), "round": e.round()});
    assert_eq!(
        result.strip_prefix("estimation result ").unwrap(),
        expected.to_string()
    );
    out
}

#[test]
fn the_c_and_cpp_harnesses_run_clean_under_the_sanitizers_and_ask_what_the_rust_api_asks() {
    if built().is_none() {
        return;
    }
    let c = stdout(&harness("harness", &[]));
    let cpp = stdout(&harness("harness_cpp", &[]));
    assert_eq!(
        cpp,
        format!("{c}{REFUSED}"),
        "the C++ harness printed other lines than the C one"
    );
    assert_eq!(c.lines().filter(|l| l.starts_with("trial ")).count(), 100);
    assert!(c.contains("snapshot restored twice: same next trial: yes"));
    assert!(
        c.contains("request {\"ok\":true,\"stats\":{\"asked\":100,\"told\":100,\"cancelled\":0}")
    );
    // The campaign found failures and learned: some HF failures, evidence behind θ_LF*.
    assert!(c.matches(" hf=1/").count() > 10, "{c}");
    let replayed = replay(&c, [60, 20, 20], 1);
    assert_eq!(replayed.len(), 100 + 2 + 30);
}

#[test]
fn batched_asks_give_the_same_trials_in_c_cpp_and_rust() {
    if built().is_none() {
        return;
    }
    let args = [
        "--batch",
        "4",
        "--train",
        "30",
        "--evaluate",
        "9",
        "--baseline",
        "6",
    ];
    let c = stdout(&harness("harness", &args));
    let cpp = stdout(&harness("harness_cpp", &args));
    // The C++ harness's kernel put together with savme::builder: the same trials.
    let mut built = args.to_vec();
    built.extend(["--builder", "1"]);
    same_lines(
        &stdout(&harness("harness_cpp", &built)),
        &cpp,
        "builder against JSON",
    );
    same_lines(
        &cpp,
        &format!("{c}{REFUSED}"),
        "the C++ harness against the C one",
    );
    replay(&c, [30, 9, 6], 4);
    // Batches learn later than single asks: another campaign than the default's.
    let single = stdout(&harness(
        "harness",
        &["--train", "30", "--evaluate", "9", "--baseline", "6"],
    ));
    assert!(c != single, "batched asks gave the campaign of single asks");
}

#[test]
fn a_journaled_campaign_killed_with_sigkill_resumes_to_the_same_end() {
    if built().is_none() {
        return;
    }
    let dir = built()
        .unwrap()
        .join(format!("journal-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for batch in ["1", "3"] {
        let whole = dir.join(format!("whole-{batch}.jsonl"));
        let killed = dir.join(format!("killed-{batch}.jsonl"));
        let (snap_whole, snap_killed) = (
            dir.join(format!("whole-{batch}.snap")),
            dir.join(format!("killed-{batch}.snap")),
        );
        let s = |p: &Path| p.to_str().unwrap().to_string();
        let uninterrupted = stdout(&harness(
            "harness",
            &[
                "--batch",
                batch,
                "--journal",
                &s(&whole),
                "--snapshot-out",
                &s(&snap_whole),
            ],
        ));
        // The same campaign without a journal gives the same lines.
        assert_eq!(
            uninterrupted,
            stdout(&harness("harness", &["--batch", batch]))
        );
        // Killed by SIGKILL right after an ask (in the evaluation phase), before its tell.
        let first = harness(
            "harness",
            &[
                "--batch",
                batch,
                "--journal",
                &s(&killed),
                "--die-after-ask",
                "65",
            ],
        );
        use std::os::unix::process::ExitStatusExt;
        assert_eq!(first.status.signal(), Some(9), "{first:?}");
        let resumed = harness(
            "harness",
            &[
                "--batch",
                batch,
                "--journal",
                &s(&killed),
                "--snapshot-out",
                &s(&snap_killed),
            ],
        );
        assert!(resumed.status.success(), "{resumed:?}");
        let stderr = String::from_utf8_lossy(&resumed.stderr);
        assert!(
            stderr.contains("harness: resumed") && stderr.contains("pending"),
            "{stderr}"
        );
        assert_eq!(
            format!("{}{}", stdout(&first), stdout(&resumed)),
            uninterrupted
        );
        assert_eq!(
            std::fs::read(&snap_whole).unwrap(),
            std::fs::read(&snap_killed).unwrap()
        );
        // The journal the C ABI wrote is `savme serve --journal`'s: its session code resumes it.
        let store = savme_store::JsonlStore::open(&killed).unwrap();
        let mut opened = savme_serve::Session::open(None, Some(Box::new(store))).unwrap();
        let stats = opened.session.handle("{\"op\":\"stats\"}");
        assert_eq!(stats["stats"]["told"], 100, "{stats}");
        assert_eq!(stats["pending"], serde_json::json!([]));
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
