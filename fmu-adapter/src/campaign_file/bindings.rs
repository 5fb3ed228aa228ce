//! Where each FMU variable of a campaign file is bound, and for what: conflicting bindings are
//! refused as they are read, and the FMU check runs one use at a time so that an error about an
//! FMU variable lands on the binding it is about.

use super::raw::FmuSection;
use super::{ConfigError, Source};
use crate::worker::WorkerInit;
use crate::{CostSource, Failure, FmuDescription, FmuError, FmuSimulator, RunSpec};
use toml::Spanned;

/// What a campaign file does with an FMU variable: reads it as the failure signal or the cost,
/// or sets it as a fidelity setting or for one scenario (φ or `fixed`, by file position).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Use {
    /// `[failure]`: read.
    Failure,
    /// `[failure] robustness`: read.
    Robustness,
    /// `[fmu] cost`: read.
    Cost,
    /// The fidelity settings: set in every run.
    Fidelity,
    /// `scenario[k]`'s φ and fixed parameters: set in its runs.
    Scenario(usize),
}

impl Use {
    /// True when a binding of `self` and one of `other` are set in the same run: the fidelity
    /// settings with each other and with every scenario, a scenario with itself.
    fn set_with(self, other: Use) -> bool {
        match (self, other) {
            (Use::Fidelity, Use::Fidelity | Use::Scenario(_))
            | (Use::Scenario(_), Use::Fidelity) => true,
            (Use::Scenario(a), Use::Scenario(b)) => a == b,
            _ => false,
        }
    }
}

/// One binding: the FMU variable, the line and key that name it, and its use.
#[derive(Debug)]
struct Origin {
    line: usize,
    key: String,
    used: Use,
}

/// Every binding of the file, by FMU variable in the order read (a map: a search of every
/// earlier binding for each one took time quadratic in their number, which an OpenSCENARIO file
/// of many parameters makes large).
#[derive(Debug, Default)]
pub(super) struct Origins(std::collections::HashMap<String, Vec<Origin>>);

impl Origins {
    /// Remembers an output the runs read (`used` is [`Use::Failure`], [`Use::Robustness`] or
    /// [`Use::Cost`]).
    pub(super) fn read(&mut self, fmu_variable: &str, line: usize, key: &str, used: Use) {
        self.0
            .entry(fmu_variable.to_string())
            .or_default()
            .push(Origin {
                line,
                key: key.into(),
                used,
            });
    }

    /// The bindings of `fmu_variable`, in the order read.
    fn named(&self, fmu_variable: &str) -> impl Iterator<Item = &Origin> {
        self.0.get(fmu_variable).into_iter().flatten()
    }

    /// Remembers an input the runs set, refusing an FMU variable another binding already sets
    /// in the same runs (one value would silently overwrite the other). The error is at the
    /// later of the two lines and names the other binding with its line.
    pub(super) fn set(
        &mut self,
        src: &Source,
        fmu_variable: &str,
        line: usize,
        key: &str,
        used: Use,
    ) -> Result<(), ConfigError> {
        let clash = self.named(fmu_variable).find(|o| o.used.set_with(used));
        if let Some(o) = clash {
            let ((at, here), (there, other)) = if line >= o.line {
                ((line, key), (o.line, o.key.as_str()))
            } else {
                ((o.line, o.key.as_str()), (line, key))
            };
            return Err(src.err(
                Some(at),
                Some(here),
                format!(
                    "FMU variable `{fmu_variable}` is already bound by `{other}` (line {there})"
                ),
            ));
        }
        self.read(fmu_variable, line, key, used);
        Ok(())
    }

    /// The line and key of the binding of `fmu_variable` for `used`.
    fn of(&self, fmu_variable: &str, used: Use) -> Option<(usize, &str)> {
        self.named(fmu_variable)
            .find(|o| o.used == used)
            .map(|o| (o.line, o.key.as_str()))
    }
}

/// Reads both FMUs' descriptions (nothing loaded: with isolation the libraries are loaded in
/// the workers only) and checks every binding and signal against them (types, causalities,
/// declared bounds and items), one use at a time — the failure signal, its robustness, the cost, the fidelity
/// settings, each scenario, then the whole run specification — so that an error about an FMU
/// variable is put on the binding of the use that failed: `cost = "collision"` is blamed, not
/// `failure.boolean = "collision"`. Returns the descriptions (HF, LF).
pub(super) fn check_fmus(
    src: &Source,
    init: &WorkerInit,
    fmu: &Spanned<FmuSection>,
    origins: &Origins,
) -> Result<(FmuDescription, FmuDescription), ConfigError> {
    let read = |path: &std::path::Path| {
        FmuDescription::read(path).map_err(|e| fmu_file_error(src, &e, fmu))
    };
    let hf = read(&init.hf)?;
    let lf = if init.lf == init.hf {
        hf.clone()
    } else {
        read(&init.lf)?
    };
    for (used, spec) in stages(&init.spec) {
        FmuSimulator::check(&hf, &lf, &spec, init.fidelity.as_ref(), &|name| {
            init.phi.get(name).cloned()
        })
        .map_err(|e| {
            let (line, key) = locate(src, &e, used, fmu, origins);
            src.err(Some(line), Some(key), e.to_string())
        })?;
    }
    Ok((hf, lf))
}

/// The `[fmu] record` list checked against both FMUs: each name an output of both (Real,
/// Integer, Boolean or enumeration), listed once; an error names the line of the name, the key
/// and the variable.
pub(super) fn check_record(
    src: &Source,
    hf: &FmuDescription,
    lf: &FmuDescription,
    record: Option<&Spanned<Vec<Spanned<String>>>>,
) -> Result<Vec<String>, ConfigError> {
    let mut names: Vec<String> = Vec::new();
    for name in record.map(|r| r.get_ref().as_slice()).unwrap_or_default() {
        let line = Some(src.line(name.span()));
        let n = name.get_ref();
        if names.contains(n) {
            return Err(src.err(line, Some("fmu.record"), format!("`{n}` is listed twice")));
        }
        for d in [hf, lf] {
            crate::simulator::recordable(d, n)
                .map_err(|e| src.err(line, Some("fmu.record"), e.to_string()))?;
        }
        names.push(n.clone());
    }
    Ok(names)
}

/// Loads both FMUs in this process (for a campaign without isolation): a library that cannot
/// be loaded, or lacks an FMI function, is named at the line of its FMU. Each is first loaded
/// and instantiated in a child process ([`crate::inspect::probe_load`]): a library that
/// crashes is named there, with what contains it, instead of ending this process.
pub(super) fn load_fmus(
    src: &Source,
    init: &WorkerInit,
    fmu: &Spanned<FmuSection>,
) -> Result<(), ConfigError> {
    let paths = if init.hf == init.lf {
        vec![&init.hf]
    } else {
        vec![&init.hf, &init.lf]
    };
    for path in paths {
        crate::inspect::probe_load(path).map_err(|e| fmu_file_error(src, &e, fmu))?;
    }
    init.open()
        .map(|_| ())
        .map_err(|e| fmu_file_error(src, &e, fmu))
}

/// The run specifications the FMU check builds in turn, each adding one use to the last (and
/// the whole specification, with no use of its own, at the end).
fn stages(spec: &RunSpec) -> Vec<(Option<Use>, RunSpec)> {
    let robustness = RunSpec {
        cost: CostSource::Wall,
        fidelity: Vec::new(),
        scenarios: Vec::new(),
        ..spec.clone()
    };
    let failure = RunSpec {
        failure: match &spec.failure {
            Failure::Boolean { variable, .. } => Failure::Boolean {
                variable: variable.clone(),
                robustness: None,
            },
            other => other.clone(),
        },
        ..robustness.clone()
    };
    let cost = RunSpec {
        cost: spec.cost.clone(),
        ..robustness.clone()
    };
    let fidelity = RunSpec {
        fidelity: spec.fidelity.clone(),
        ..cost.clone()
    };
    let mut stages = vec![
        (Some(Use::Failure), failure),
        (Some(Use::Robustness), robustness),
        (Some(Use::Cost), cost),
        (Some(Use::Fidelity), fidelity.clone()),
    ];
    for (k, s) in spec.scenarios.iter().enumerate() {
        let one = RunSpec {
            scenarios: vec![s.clone()],
            ..fidelity.clone()
        };
        stages.push((Some(Use::Scenario(k)), one));
    }
    stages.push((None, spec.clone()));
    stages
}

/// The line and key of an error of the FMU check in the stage of `used`: the binding of the
/// variable it names, else the `[fmu]` section.
fn locate<'a>(
    src: &Source,
    e: &FmuError,
    used: Option<Use>,
    fmu: &Spanned<FmuSection>,
    origins: &'a Origins,
) -> (usize, &'a str) {
    let variable = match e {
        FmuError::UnknownVariable { variable, .. }
        | FmuError::WrongType { variable, .. }
        | FmuError::WrongCausality { variable, .. }
        | FmuError::OutOfRange { variable, .. } => Some(variable),
        _ => None,
    };
    variable
        .zip(used)
        .and_then(|(v, u)| origins.of(v, u))
        .unwrap_or((src.line(fmu.span()), "fmu"))
}

/// An error opening an FMU: at the line of the one it names (`fmu.lf` when the message names
/// that path, else `fmu.hf`).
fn fmu_file_error(src: &Source, e: &FmuError, fmu: &Spanned<FmuSection>) -> ConfigError {
    let message = e.to_string();
    let f = fmu.get_ref();
    let span = match &f.lf {
        Some(lf) if message.contains(lf.get_ref().as_str()) => lf.span(),
        _ => f.hf.span(),
    };
    src.err(Some(src.line(span)), Some("fmu.hf / fmu.lf"), message)
}
