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
