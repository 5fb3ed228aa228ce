#![allow(dead_code)]
use savme_kernel::{Assignment, Kernel, KernelBuilder, Scale, Space, Variable};

/// A small fidelity space: a rate (HF 10), a switch (HF false), a log distance (HF 5000).
pub fn fidelity() -> (Space, Assignment) {
    let space = Space::new(vec![
        Variable::discrete("rate_hz", [2, 5, 10]),
        Variable::boolean("disable_shadows"),
        Variable::continuous("view_m", 10.0, 5000.0, 4, Scale::Log),
    ])
    .unwrap();
    let hf = Assignment::new()
        .with("rate_hz", 10)
        .with("disable_shadows", false)
        .with("view_m", 5000.0);
    (space, hf)
}

pub fn phi_space() -> Space {
    Space::new(vec![
        Variable::continuous("speed", 5.0, 35.0, 6, Scale::Linear),
        Variable::discrete("weather", ["dry", "wet"]),
    ])
    .unwrap()
}

pub fn builder() -> KernelBuilder {
    let (f, hf) = fidelity();
    Kernel::builder(f, hf)
        .scenario("a", phi_space(), 1.0)
        .scenario("b", phi_space(), 3.0)
        .budget(0.3)
        .seed(42)
}

pub fn kernel() -> Kernel {
    builder().build().unwrap()
}

/// One scenario `name` on the unit square (variables `a` and `b` in [0, 1], 10 bins each), a
/// three-rate fidelity space (HF 10 Hz) and the elite search `m`: the toy problems of the
/// elite search's tests (tests/rho_model.rs, tests/cells.rs).
pub fn unit_square(
    m: savme_kernel::EliteMixture,
    name: &str,
    [a, b]: [&str; 2],
    seed: u64,
) -> savme_kernel::KernelConfig {
    let fidelity = Space::new(vec![Variable::discrete("rate_hz", [2, 5, 10])]).unwrap();
    let phi = Space::new(vec![
        Variable::continuous(a, 0.0, 1.0, 10, Scale::Linear),
        Variable::continuous(b, 0.0, 1.0, 10, Scale::Linear),
    ])
    .unwrap();
    Kernel::builder(fidelity, Assignment::new().with("rate_hz", 10))
        .scenario(name, phi, 1.0)
        .search(savme_kernel::SearchModel::EliteMixture(m))
        .seed(seed)
        .build()
        .unwrap()
        .config()
        .clone()
}
