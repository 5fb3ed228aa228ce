//! The paper's space and the kernels the ask+tell benchmarks time (`ask_tell`, `guard`).
#![allow(dead_code)]

use savme_kernel::{
    Allocation, Assignment, CostRate, EliteMixture, Kernel, KernelConfig, Observation, Run, Scale,
    SearchModel, Space, Trial, Variable,
};

/// The shape (and names, so that name lookups cost the same) of the driving simulator's Table II
/// space, `savme_sim::fidelity::space(10)`, written out here: the kernel depends on no simulator.
pub fn fidelity_space() -> Space {
    let b = Variable::boolean;
    let log = |name: &str, lo: f64, hi: f64| Variable::continuous(name, lo, hi, 10, Scale::Log);
    Space::new(vec![
        Variable::discrete("simulation_rate_hz", [2, 4, 6, 8, 10]),
        Variable::discrete("camera_bloom_level", ["high", "low"]),
        b("camera_disable_bloom"),
        b("camera_disable_lighting"),
        b("camera_disable_shadows"),
        b("camera_disable_lens_model"),
        b("camera_disable_depth_of_field"),
        b("camera_disable_shot_noise"),
        log("camera_view_distance_m", 10.0, 5000.0),
        log("camera_near_clipping_m", 0.2, 20.0),
        b("lidar_disable_shot_noise"),
        b("lidar_disable_ambient_effects"),
        b("lidar_disable_translucency"),
        Variable::discrete("lidar_subsample_count", [1, 2, 3, 4, 5]),
        Variable::discrete("lidar_raytracing_bounces", [0, 1, 2, 3, 4]),
        log("lidar_near_clipping_m", 0.2, 20.0),
    ])
    .expect("valid fidelity space")
}

/// θ_HF of [`fidelity_space`]: every setting at its most faithful value.
pub fn theta_hf() -> Assignment {
    Assignment::new()
        .with("simulation_rate_hz", 10)
        .with("camera_bloom_level", "high")
        .with("camera_disable_bloom", false)
        .with("camera_disable_lighting", false)
        .with("camera_disable_shadows", false)
        .with("camera_disable_lens_model", false)
        .with("camera_disable_depth_of_field", false)
        .with("camera_disable_shot_noise", false)
        .with("camera_view_distance_m", 5000.0)
        .with("camera_near_clipping_m", 0.2)
        .with("lidar_disable_shot_noise", false)
        .with("lidar_disable_ambient_effects", false)
        .with("lidar_disable_translucency", false)
        .with("lidar_subsample_count", 5)
        .with("lidar_raytracing_bounces", 4)
        .with("lidar_near_clipping_m", 0.2)
}

pub fn config() -> KernelConfig {
    let phi = Space::new(
        ["ego_speed", "intruder_speed", "gap", "intruder_decel"]
            .iter()
            .map(|n| Variable::continuous(n, 1.0, 30.0, 10, Scale::Linear))
            .collect(),
    )
    .expect("valid φ-space");
    Kernel::builder(fidelity_space(), theta_hf())
        .scenario("lead_vehicle", phi, 1.0)
        .budget(0.3)
        .seed(1)
        .build()
        .expect("valid config")
        .config()
        .clone()
}

/// A cheap synthetic outcome so that only the kernel is measured.
pub fn observe(t: &Trial) -> Observation {
    let hf = t.phi.get_f64("gap").unwrap_or(0.0) < 8.0;
    let theta = t.theta_lf.as_ref().expect("paired trial");
    let rate = theta.get_f64("simulation_rate_hz").unwrap_or(10.0);
    let lf = hf ^ (rate < 4.0);
    Observation::Paired {
        hf: Run::new(hf, 1.0),
        lf: Run::new(lf, rate / 10.0),
    }
}

/// The tuned kernel (`savme run`'s default): the elite search with candidates ranked per
/// expected cost (`per_cost`; false: by odds alone, as before) and the cost-rate allocation,
/// on eight scenarios like the bundled simulator's meta-training set.
pub fn tuned_config(per_cost: bool) -> KernelConfig {
    let phi = |_| {
        Space::new(
            ["ego_speed", "intruder_speed", "gap", "intruder_decel"]
                .iter()
                .map(|n| Variable::continuous(n, 1.0, 30.0, 10, Scale::Linear))
                .collect(),
        )
        .expect("valid φ-space")
    };
    let mut b = Kernel::builder(fidelity_space(), theta_hf())
        .budget(0.3)
        .seed(1)
        .search(SearchModel::EliteMixture(EliteMixture {
            per_cost,
            ..EliteMixture::default()
        }))
        .allocation(Allocation::CostRate(CostRate::default()));
    for s in 0..8 {
        b = b.scenario(&format!("scenario_{s}"), phi(s), 1.0);
    }
    b.build().expect("valid config").config().clone()
}

pub fn warmed(told: usize) -> Kernel {
    warmed_with(config(), told)
}

pub fn warmed_with(config: KernelConfig, told: usize) -> Kernel {
    let mut k = Kernel::new(config).expect("valid config");
    for _ in 0..told {
        let t = k.ask();
        let o = observe(&t);
        k.tell(t.id, o).expect("valid tell");
    }
    k
}
