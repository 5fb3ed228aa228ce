//! The ten scenarios under θ_HF: failures exist, runs are deterministic, bad φ is named, and the
//! simulation rate changes both the work done and the outcome.
use savme_kernel::{Assignment, Kernel, Phase, Role, SimError, Simulator};
use savme_sim::fidelity;
use savme_sim::scenario::{phi_space, SCENARIOS};
use savme_sim::sim::DrivingSimulator;

/// Uniform φ samples of a scenario (the kernel's baseline phase, seeded).
fn samples(name: &str, space: savme_kernel::Space, n: usize) -> Vec<Assignment> {
    let mut k = Kernel::builder(fidelity::space(10), fidelity::theta_hf())
        .scenario(name, space, 1.0)
        .seed(5)
        .build()
        .unwrap();
    k.set_phase(Phase::Baseline);
    (0..n).map(|_| k.ask().phi).collect()
}

#[test]
fn every_scenario_has_a_colliding_and_a_safe_phi() {
    let sim = DrivingSimulator::ideal();
    for info in &SCENARIOS {
        let (mut crash, mut safe) = (None, None);
        for phi in samples(info.name, phi_space(info), 400) {
            let r = sim
                .run(info.name, &phi, &fidelity::theta_hf(), false)
                .unwrap();
            if r.failure {
                assert_eq!(r.min_distance, 0.0);
                assert!(r
                    .collision_time
                    .is_some_and(|t| t > 0.0 && t <= info.duration));
                crash.get_or_insert(phi);
            } else {
                assert!(r.min_distance > 0.0 && r.collision_time.is_none());
                safe.get_or_insert(phi);
            }
            if crash.is_some() && safe.is_some() {
                break;
            }
        }
        assert!(crash.is_some(), "scenario {} never collides", info.id);
        assert!(safe.is_some(), "scenario {} always collides", info.id);
    }
}

#[test]
fn runs_are_deterministic_and_trajectories_cost_nothing_unless_asked() {
    let sim = DrivingSimulator::ideal();
    for info in &SCENARIOS {
        for phi in samples(info.name, phi_space(info), 5) {
            let a = sim
                .run(info.name, &phi, &fidelity::theta_hf(), true)
                .unwrap();
            let b = sim
                .run(info.name, &phi, &fidelity::theta_hf(), false)
                .unwrap();
            assert_eq!(
                (a.failure, a.min_distance, a.work),
                (b.failure, b.min_distance, b.work)
            );
            assert!(b.trajectory.is_none());
            let tr = a.trajectory.unwrap();
            assert!(tr.len() as u64 >= a.steps, "one frame per step");
        }
    }
}

#[test]
fn the_simulation_rate_changes_work_and_outcomes() {
    let sim = DrivingSimulator::ideal();
    let low = fidelity::theta_hf().with("simulation_rate_hz", 2);
    let (mut work_less, mut differ, mut n) = (0, 0, 0);
    for info in &SCENARIOS {
        for phi in samples(info.name, phi_space(info), 60) {
            let hf = sim
                .run(info.name, &phi, &fidelity::theta_hf(), false)
                .unwrap();
            let lf = sim.run(info.name, &phi, &low, false).unwrap();
            n += 1;
            work_less += usize::from(lf.work < hf.work);
            differ += usize::from(lf.failure != hf.failure);
        }
    }
    assert!(
        work_less * 10 >= n * 9,
        "2 Hz is cheaper in {work_less} of {n} runs"
    );
    assert!(differ > 0, "2 Hz never changes an outcome");
}

#[test]
fn bad_phi_and_fidelity_are_named() {
    let mut sim = DrivingSimulator::ideal();
    let info = &SCENARIOS[6];
    let good = samples(info.name, phi_space(info), 1).remove(0);
    let hf = fidelity::theta_hf();
    let mut err = |phi: &Assignment, theta: &Assignment| {
        sim.simulate_as(Role::High, info.name, phi, theta)
            .unwrap_err()
            .to_string()
    };
    let e = err(&good.clone().with("bogus", 1.0), &hf);
    assert!(e.contains("bogus") && e.contains("lead_decel"), "{e}");
    let e = err(&good.clone().with("gap", 500.0), &hf);
    assert!(e.contains("gap") && e.contains("[8, 28]"), "{e}");
    let mut missing = Assignment::new();
    for (n, v) in good.iter().filter(|(n, _)| *n != "lead_speed") {
        missing.set(n, v.clone());
    }
    let e = err(&missing, &hf);
    assert!(e.contains("lead_speed"), "{e}");
    let e = err(&good, &hf.clone().with("simulation_rate_hz", 3));
    assert!(e.contains("simulation_rate_hz"), "{e}");
    let e = err(&good, &hf.clone().with("warp_drive", true));
    assert!(e.contains("warp_drive"), "{e}");
    assert!(matches!(
        sim.simulate_as(Role::High, "11", &good, &hf),
        Err(SimError::UnknownScenario(_))
    ));
}
