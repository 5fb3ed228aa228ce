//! The test kit's FMU and the adapter's simulator on it, shared by the benches.
use savme_fmu::{
    Binding, CostSource, Failure, FmuFile, FmuSimulator, RunSpec, ScenarioSpec, StepSize,
};
use savme_kernel::{Scale, Space, Variable};
use std::path::PathBuf;
use std::sync::Arc;

/// The test kit's shared library, next to the bench executable.
pub fn testkit_library() -> PathBuf {
    let exe = std::env::current_exe().expect("bench executable");
    let deps = exe.parent().expect("deps dir");
    let name = format!(
        "{}savme_fmu_testkit{}",
        std::env::consts::DLL_PREFIX,
        std::env::consts::DLL_SUFFIX
    );
    [deps.join(&name), deps.join("..").join(&name)]
        .into_iter()
        .find(|p| p.exists())
        .expect("the test-kit library next to the bench")
}

/// The test kit's library packed as an FMU of FMI version `fmi` (2 or 3).
pub fn testkit_fmu(fmi: u8) -> PathBuf {
    let lib = testkit_library();
    let exe = std::env::current_exe().expect("bench executable");
    let deps = exe.parent().expect("deps dir");
    // target/savme-fmu-testkit.fmu and …testkit3.fmu, kept for the FMPy comparison.
    let (name, xml) = if fmi == 3 {
        (
            "savme-fmu-testkit3.fmu",
            savme_fmu_testkit::model_description3(),
        )
    } else {
        (
            "savme-fmu-testkit.fmu",
            savme_fmu_testkit::model_description(),
        )
    };
    let out = deps
        .parent()
        .and_then(|p| p.parent())
        .unwrap_or(deps)
        .join(name);
    savme_fmi_export::pack(&xml, "savme_fmu_testkit", &lib, &out).expect("pack");
    println!("trivial FMU (FMI {fmi}.0): {}", out.display());
    out
}

/// The adapter's simulator on the test kit's FMU of FMI version `fmi`: scenario `grow` (φ
/// `start` → `x0`), fidelity `rate`; 100 steps of 0.01 s, the Boolean `failed` read after each,
/// the cost the Integer `steps`.
pub fn simulator(fmi: u8) -> FmuSimulator {
    let fmu = testkit_fmu(fmi);
    let file = Arc::new(FmuFile::open(&fmu).expect("open"));
    let fidelity = Space::new(vec![Variable::continuous(
        "rate",
        0.5,
        4.0,
        4,
        Scale::Linear,
    )])
    .expect("space");
    let phi = Space::new(vec![Variable::continuous(
        "start",
        0.0,
        1.0,
        4,
        Scale::Linear,
    )])
    .expect("space");
    let spec = RunSpec {
        fmu_log: false,
        tolerance: None,
        stop_time: 1.0,
        step: StepSize::Fixed(0.01),
        failure: Failure::Boolean {
            variable: "failed".into(),
            robustness: None,
        },
        stop_on_failure: false,
        cost: CostSource::Output("steps".into()),
        fidelity: vec![Binding {
            variable: "rate".into(),
            fmu_variable: "rate".into(),
            labels: None,
        }],
        scenarios: vec![ScenarioSpec {
            name: "grow".into(),
            phi: vec![Binding {
                variable: "start".into(),
                fmu_variable: "x0".into(),
                labels: None,
            }],
            fixed: vec![],
        }],
    };
    FmuSimulator::new(file.clone(), file, spec, Some(&fidelity), &|_| {
        Some(phi.clone())
    })
    .expect("simulator")
}
