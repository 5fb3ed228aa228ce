//! Property tests: draws stay in their spaces, snapshots restore exactly, no tell sequence panics.
mod common;
use proptest::prelude::*;
use savme_kernel::{Kernel, Observation, Phase, Run, Scale, Space, Value, Variable};

fn variable(i: usize) -> impl Strategy<Value = Variable> {
    let name = format!("v{i}");
    let n2 = name.clone();
    prop_oneof![
        (-1e3f64..1e3, 1e-3f64..1e3, 1u32..12, any::<bool>()).prop_map(
            move |(lo, w, bins, log)| {
                let (lo, scale) = if log {
                    (lo.abs() + 1e-3, Scale::Log)
                } else {
                    (lo, Scale::Linear)
                };
                Variable::continuous(&name, lo, lo + w, bins, scale)
            }
        ),
        (1usize..6).prop_map(move |n| Variable::discrete(&n2, (0..n as i64).map(|x| x * 3))),
    ]
}

fn space() -> impl Strategy<Value = Space> {
    (1usize..5)
        .prop_flat_map(|n| (0..n).map(variable).collect::<Vec<_>>())
        .prop_map(|vars| Space::new(vars).unwrap())
}

fn in_space(space: &Space, a: &savme_kernel::Assignment) -> bool {
    space.arms_of(a).is_ok()
        && space
            .variables()
            .iter()
            .all(|v| match (&v.domain, a.get(&v.name)) {
                (savme_kernel::Domain::Continuous { lo, hi, .. }, Some(Value::Real(x))) => {
                    lo <= x && x <= hi
                }
                (savme_kernel::Domain::Discrete { .. }, Some(_)) => true,
                _ => false,
            })
}

fn kernel_for(phi: Space, fidelity: Space, seed: u64) -> Kernel {
    // θ_HF: the first arm's representative of every fidelity variable.
    let mut hf = savme_kernel::Assignment::new();
    for v in fidelity.variables() {
        hf.set(&v.name, v.representative(0));
    }
    Kernel::builder(fidelity, hf)
        .scenario("s", phi, 1.0)
        .seed(seed)
        .build()
        .unwrap()
}

/// One step of an arbitrary driver: ask, tell (well or badly), cancel, switch phase.
#[derive(Debug, Clone)]
enum Step {
    Ask,
    Tell {
        pick: usize,
        hf: bool,
        lf: bool,
        t_hf: f64,
        t_lf: f64,
        hf_only: bool,
    },
    TellUnknown(u64),
    Cancel(usize),
    Phase(u8),
}

fn step() -> impl Strategy<Value = Step> {
    let runtime = prop_oneof![
        0.001f64..10.0,
        Just(0.0),
        Just(-1.0),
        Just(f64::NAN),
        Just(f64::INFINITY)
    ];
    prop_oneof![
        3 => Just(Step::Ask),
        3 => (any::<usize>(), any::<bool>(), any::<bool>(), runtime.clone(), runtime, any::<bool>())
            .prop_map(|(pick, hf, lf, t_hf, t_lf, hf_only)| Step::Tell { pick, hf, lf, t_hf, t_lf, hf_only }),
        1 => any::<u64>().prop_map(Step::TellUnknown),
        1 => any::<usize>().prop_map(Step::Cancel),
        1 => (0u8..4).prop_map(Step::Phase),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 64,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x5A7E),
        ..ProptestConfig::default()
    })]

    #[test]
    fn every_draw_lies_in_its_space(phi in space(), fid in space(), seed in any::<u64>(), phase in 0u8..4) {
        let mut k = kernel_for(phi.clone(), fid.clone(), seed);
        k.set_phase([Phase::Train, Phase::Evaluate, Phase::Baseline, Phase::Test][phase as usize]);
        for _ in 0..20 {
            let t = k.ask();
            prop_assert!(in_space(&phi, &t.phi), "{}", t.phi);
            if let Some(theta) = &t.theta_lf {
                prop_assert!(in_space(&fid, theta), "{}", theta);
            }
        }
    }

    #[test]
    fn snapshot_then_restore_gives_identical_next_asks(phi in space(), fid in space(), seed in any::<u64>(), told in proptest::collection::vec(any::<bool>(), 0..30)) {
        let mut k = kernel_for(phi, fid, seed);
        for (i, &f) in told.iter().enumerate() {
            let t = k.ask();
            if i % 5 != 4 {
                k.tell(t.id, Observation::Paired { hf: Run::new(f, 1.0), lf: Run::new(f ^ (i % 3 == 0), 0.05 * (i % 9 + 1) as f64) }).unwrap();
            }
        }
        let restored = Kernel::from_json(&k.to_json()).unwrap();
        let mut a = k;
        let mut b = restored;
        for _ in 0..10 {
            prop_assert_eq!(a.ask(), b.ask());
        }
    }

    #[test]
    fn no_sequence_of_calls_panics_and_stats_stay_consistent(steps in proptest::collection::vec(step(), 0..80), seed in any::<u64>()) {
        let mut k = common::builder().seed(seed).build().unwrap();
        let mut told = 0u64;
        for s in steps {
            let pending: Vec<u64> = k.pending().map(|t| t.id).collect();
            match s {
                Step::Ask => { k.ask(); }
                Step::Tell { pick, hf, lf, t_hf, t_lf, hf_only } => {
                    let id = if pending.is_empty() { pick as u64 } else { pending[pick % pending.len()] };
                    let obs = if hf_only { Observation::HfOnly(Run::new(hf, t_hf)) } else { Observation::Paired { hf: Run::new(hf, t_hf), lf: Run::new(lf, t_lf) } };
                    let before = k.to_json();
                    match k.tell(id, obs) {
                        Ok(_) => told += 1,
                        Err(_) => prop_assert_eq!(k.to_json(), before),
                    }
                }
                Step::TellUnknown(id) => { let _ = k.tell(id, Observation::HfOnly(Run::new(true, 1.0))); }
                Step::Cancel(pick) => if !pending.is_empty() { k.cancel(pending[pick % pending.len()]).unwrap(); },
                Step::Phase(p) => k.set_phase([Phase::Train, Phase::Evaluate, Phase::Baseline, Phase::Test][p as usize]),
            }
        }
        let st = k.stats();
        prop_assert_eq!(st.told, told);
        prop_assert_eq!(st.asked, st.told + st.cancelled + k.pending().count() as u64);
    }
}
