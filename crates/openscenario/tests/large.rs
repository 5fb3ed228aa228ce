//! Large files: read in time proportional to their size (the ratio of two sizes' times, both
//! measured here, rather than an absolute time), and files over the limits refused naming the
//! file and the limit.

use savme_openscenario::{Limits, ParameterDistribution, MAX_BYTES, MAX_ELEMENTS};
use std::path::PathBuf;
use std::time::{Duration, Instant};

const HEAD: &str = "<?xml version=\"1.0\"?>\n<OpenSCENARIO>\n  <FileHeader revMajor=\"1\" revMinor=\"2\" author=\"a\" description=\"d\" date=\"2024-01-01T00:00:00\"/>\n  <ParameterValueDistribution>\n    <ScenarioFile filepath=\"s.xosc\"/>\n";
const TAIL: &str = "  </ParameterValueDistribution>\n</OpenSCENARIO>\n";

/// `n` parameters, each a uniform distribution over a range (3 elements each, one a line).
fn parameters(n: usize) -> String {
    let mut s = String::from(HEAD);
    s += "    <Stochastic numberOfTestRuns=\"10\">\n";
    for i in 0..n {
        s += &format!("      <StochasticDistribution parameterName=\"p{i}\"><UniformDistribution><Range lowerLimit=\"0\" upperLimit=\"1\"/></UniformDistribution></StochasticDistribution>\n");
    }
    s + "    </Stochastic>\n" + TAIL
}

/// One parameter whose set lists `n` values, one a line.
fn set(n: usize) -> String {
    let mut s = String::from(HEAD);
    s += "    <Deterministic>\n      <DeterministicSingleParameterDistribution parameterName=\"v\">\n        <DistributionSet>\n";
    for i in 0..n {
        s += &format!("          <Element value=\"{}\"/>\n", i as f64 * 0.5);
    }
    s + "        </DistributionSet>\n      </DeterministicSingleParameterDistribution>\n    </Deterministic>\n"
        + TAIL
}

/// The shortest of three readings of `text`.
fn time(text: &str) -> Duration {
    (0..3)
        .map(|_| {
            let t = Instant::now();
            let d =
                ParameterDistribution::parse(text, "big.xosc").unwrap_or_else(|e| panic!("{e}"));
            let took = t.elapsed();
            assert!(!d.parameters.is_empty());
            took
        })
        .min()
        .unwrap_or_default()
}

/// Twice the elements take about twice the time (a quadratic reading took four times: 5k, 10k,
/// 20k and 40k elements took 0.3, 1.3, 5.2 and 19.9 s).
fn linear(make: fn(usize) -> String, n: usize) {
    let (small, large) = (make(n), make(2 * n));
    let (a, b) = (time(&small), time(&large));
    let ratio = b.as_secs_f64() / a.as_secs_f64().max(1e-6);
    eprintln!("{n}: {a:?}, {}: {b:?}, ratio {ratio:.2}", 2 * n);
    assert!(
        ratio < 3.0,
        "a file of {} took {b:?}, one of {n} took {a:?}: {ratio:.2} times as long (linear: about 2)",
        2 * n
    );
}

#[test]
fn many_parameters_are_read_in_linear_time() {
    // 40,000 and 80,000 parameters: 120,000 and 240,000 elements.
    linear(parameters, 40_000);
}

#[test]
fn a_set_of_many_values_is_read_in_linear_time() {
    // 30,000 and 60,000 values (a set holds at most 65,535).
    linear(set, 30_000);
}

fn temp(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("savme-openscenario-large-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn files_over_the_limits_are_refused_naming_the_file_and_the_limit() {
    assert_eq!(
        Limits::default(),
        Limits {
            bytes: MAX_BYTES,
            elements: MAX_ELEMENTS
        }
    );
    assert_eq!((MAX_BYTES, MAX_ELEMENTS), (32 << 20, 500_000));
    // More elements than the limit: refused at the first one too many.
    let path = temp("many.xosc", &parameters(1000));
    let few = Limits {
        bytes: MAX_BYTES,
        elements: 600,
    };
    let e = ParameterDistribution::read_with(&path, few, &|| false)
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        format!(
            "{}, line 205: the file holds more than the 600 elements savme reads (a parameter variation file holds a few dozen)",
            path.display()
        )
    );
    // The default element limit, through `read`.
    let path = temp("default.xosc", &parameters(MAX_ELEMENTS / 3 + 1));
    let e = ParameterDistribution::read(&path).unwrap_err().to_string();
    assert!(
        e.starts_with(&format!("{}, line ", path.display()))
            && e.ends_with(": the file holds more than the 500000 elements savme reads (a parameter variation file holds a few dozen)"),
        "{e}"
    );
    // More bytes than the limit: refused before it is read.
    let path = temp("bytes.xosc", &parameters(1000));
    let len = std::fs::metadata(&path).unwrap().len();
    let small = Limits {
        bytes: 10_000,
        elements: MAX_ELEMENTS,
    };
    let e = ParameterDistribution::read_with(&path, small, &|| false)
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        format!(
            "{}: the file has {len} bytes, more than the 10000 bytes savme reads (a parameter variation file is a few kB)",
            path.display()
        )
    );
    // The default byte limit, through `read`.
    let pad = " ".repeat(MAX_BYTES as usize);
    let path = temp("large.xosc", &format!("{HEAD}{pad}{TAIL}"));
    let e = ParameterDistribution::read(&path).unwrap_err().to_string();
    assert!(
        e.starts_with(&format!("{}: the file has ", path.display()))
            && e.contains("more than the 33554432 bytes savme reads"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(path.parent().unwrap());
}

#[test]
fn a_stop_ends_a_reading_promptly() {
    let path = temp("stopped.xosc", &parameters(20_000));
    let asked = std::cell::Cell::new(0);
    let stop = || {
        asked.set(asked.get() + 1);
        asked.get() > 3
    };
    let e = ParameterDistribution::read_with(&path, Limits::default(), &stop).unwrap_err();
    assert_eq!(e.message, savme_openscenario::STOPPED);
    assert_eq!(
        e.to_string(),
        format!("{}: {}", path.display(), savme_openscenario::STOPPED)
    );
    assert_eq!(asked.get(), 4, "stopped at the first stop that said so");
}
