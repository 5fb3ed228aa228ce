//! Tests of the joint proposal ([`super::joint`], [`super::joint_fit`]).

use super::joint::Mixture;
use super::proposal::Proposal;
use super::*;
use crate::space::{Scale, Space, Variable};
use crate::PriorCounts;
use statrs::distribution::{Continuous, ContinuousCDF, Normal};

/// x, y on [0, 1] and z ∈ {0, 1, 2}, all uniform under the nominal. A run fails in two
/// opposite corners — x, y < 0.1 or x, y > 0.9 — when z = 1: P = 2 · 0.01 / 3. No product of
/// per-variable distributions holds the two corners without the two others as well.
fn corners(seed: u64, joint: Option<Joint>, rounds: u32) -> Estimation {
    let space = Space::new(vec![
        Variable::continuous("x", 0.0, 1.0, 10, Scale::Linear),
        Variable::continuous("y", 0.0, 1.0, 10, Scale::Linear),
        Variable::discrete("z", [0, 1, 2]),
    ])
    .unwrap();
    let posterior = Posterior::new(&space, PriorCounts::UNIFORM).unwrap();
    let s = Scenario {
        name: Arc::from("s"),
        space,
        weight: 1.0,
    };
    let mut c = EstimationConfig::new(0.1, seed);
    c.refine = Some(Refine {
        rounds,
        runs: 500,
        reuse: 0,
    });
    c.joint = joint;
    Estimation::new(&[(s, posterior)], &c).unwrap()
}

const CORNERS_P: f64 = 2.0 * 0.01 / 3.0;

/// The failure and the robustness: the distance (unit widths) to the nearer failing corner,
/// plus 1 when z ≠ 1; ≤ 0 inside.
fn corner_run(t: &EstimationTrial) -> (bool, f64) {
    let (x, y) = (t.phi.get_f64("x").unwrap(), t.phi.get_f64("y").unwrap());
    let z = t.phi.get("z").and_then(crate::Value::as_f64).unwrap();
    let low = (x - 0.1).max(y - 0.1).max(0.0);
    let high = (0.9 - x).max(0.9 - y).max(0.0);
    let inside = low == 0.0 || high == 0.0;
    let failure = inside && z == 1.0;
    let r = low.min(high) + if z == 1.0 { 0.0 } else { 1.0 };
    (failure, if failure { -0.01 } else { r.max(1e-6) })
}

/// Runs the pilot and `runs` estimate trials; returns the estimate and the share of the
/// estimate's draws that failed.
fn run_corners(seed: u64, joint: Option<Joint>, runs: u64) -> (Interval, f64) {
    let mut e = corners(seed, joint, 5);
    while e.round().is_some() {
        let t = e.ask().expect("told one by one");
        let (f, r) = corner_run(&t);
        e.tell_run(t.id, f, Some(r)).unwrap();
    }
    let mut failed = 0;
    for _ in 0..runs {
        let t = e.ask().expect("no waiting after the pilot");
        let (f, r) = corner_run(&t);
        failed += u64::from(f);
        e.tell_run(t.id, f, Some(r)).unwrap();
    }
    (e.estimate().total, failed as f64 / runs as f64)
}

/// A component's density is, per variable, its bin's probability times the nominal
/// restricted to the bin: here a normal nominal on a linear variable and a uniform one on a
/// log-scaled variable (log-uniform inside a bin), in closed form.
#[test]
fn a_component_density_is_the_bin_probability_times_the_nominal_in_the_bin() {
    let space = Space::new(vec![
        Variable::continuous("a", 2.0, 6.0, 4, Scale::Linear),
        Variable::continuous("b", 1.0, 100.0, 4, Scale::Log),
    ])
    .unwrap();
    let normal = Nominal::Normal { mean: 3.0, sd: 1.0 };
    let nominal = vec![
        super::nominal::NominalOf::new(&normal, "s", &space.variables()[0]).unwrap(),
        super::nominal::NominalOf::new(&Nominal::Uniform, "s", &space.variables()[1]).unwrap(),
    ];
    let posterior = Posterior::new(&space, PriorCounts::UNIFORM).unwrap();
    let base = Proposal::new(&space, &posterior, nominal, 0.1, Tilt::Posterior);
    let (pa, pb) = (vec![0.1, 0.2, 0.3, 0.4], vec![0.7, 0.1, 0.1, 0.1]);
    let m = Mixture {
        alpha: vec![1.0],
        components: vec![vec![pa.clone(), pb.clone()]],
    };
    let n = Normal::new(3.0, 1.0).unwrap();
    let mass = n.cdf(6.0) - n.cdf(2.0);
    for (a, b) in [(2.0, 1.0), (3.3, 10.0), (6.0, 77.0), (4.1, 2.5)] {
        let phi = Assignment::new().with("a", a).with("b", b);
        let ka = (((a - 2.0) / 1.0) as usize).min(3);
        let kb = ((f64::ln(b) / f64::ln(100.0) * 4.0) as usize).min(3);
        let bin_a = (n.cdf(2.0 + ka as f64 + 1.0) - n.cdf(2.0 + ka as f64)) / mass;
        let in_a = n.pdf(a) / mass / bin_a;
        let in_b = 1.0 / (b * f64::ln(100.0) / 4.0);
        let want = pa[ka] * in_a * pb[kb] * in_b;
        let got = m.density(&base, &phi);
        assert!(
            (got - want).abs() <= 1e-9 * want,
            "{a} {b}: {got} vs {want}"
        );
    }
    let outside = Assignment::new().with("a", 6.5).with("b", 2.0);
    assert_eq!(m.density(&base, &outside), 0.0);
}

/// q = (1 − ε)·mixture + ε·p of a fitted joint proposal integrates to 1 over x, y (a 400 × 400
/// grid) and the three values of z, and its weights are p/q of those densities, ≤ 1/ε.
#[test]
fn a_fitted_joint_proposal_is_a_normalised_density_with_exact_weights() {
    let mut e = corners(3, Some(Joint { components: 4 }), 1);
    for _ in 0..500 {
        let t = e.ask().unwrap();
        let (f, r) = corner_run(&t);
        e.tell_run(t.id, f, Some(r)).unwrap();
    }
    assert!(e.is_joint(0), "fitted after the round");
    let k = 400;
    let mut integral = 0.0;
    for z in 0..3 {
        for i in 0..k * k {
            let (x, y) = ((i % k) as f64 + 0.5, (i / k) as f64 + 0.5);
            let phi = Assignment::new()
                .with("x", x / k as f64)
                .with("y", y / k as f64)
                .with("z", z);
            integral += e.densities(0, &phi).unwrap().0 / (k * k) as f64;
        }
    }
    assert!((integral - 1.0).abs() < 1e-3, "{integral}");
    for _ in 0..200 {
        let t = e.ask().unwrap();
        let (q, p) = e.densities(0, &t.phi).unwrap();
        assert_eq!((t.q, t.p, t.weight), (q, p, p / q));
        assert!(t.weight <= 1.0 / 0.1 + 1e-9);
    }
}

/// Over 40 seeds (5 pilot rounds of 500 runs, then 2,000 runs) the joint proposal's interval
/// covers the known P at about its nominal rate, the estimates average to P, and — the point
/// of it — with the same pilot and estimate runs its intervals are far narrower than the
/// product proposal's: it draws the two failing corners without the two that never fail.
#[test]
fn the_joint_proposal_is_unbiased_and_beats_a_product_on_a_joint_corner() {
    let seeds = 40;
    let (mut covered, mut mean, mut width, mut width_product) = (0, 0.0, 0.0, 0.0);
    let (mut share, mut share_product) = (0.0, 0.0);
    for seed in 0..seeds {
        let (est, s) = run_corners(seed, Some(Joint { components: 4 }), 2000);
        covered += u32::from(est.lo <= CORNERS_P && CORNERS_P <= est.hi);
        mean += est.mean / seeds as f64;
        width += est.relative_half_width() / seeds as f64;
        share += s / seeds as f64;
        let (est, s) = run_corners(seed, None, 2000);
        width_product += est.relative_half_width() / seeds as f64;
        share_product += s / seeds as f64;
    }
    // Measured: 38 of 40 covered, mean 6.67e-3 against 6.67e-3; mean relative half-width
    // 0.057 against the product's 0.096; 38 % of the draws fail against 33 %.
    assert!((33..=40).contains(&covered), "covered {covered} of {seeds}");
    // 40 estimates of relative sd ≈ width / 1.96: their mean is within 4 of its sds.
    let sd_of_mean = CORNERS_P * width / 1.96 / f64::from(seeds as u32).sqrt();
    assert!(
        (mean - CORNERS_P).abs() < 4.0 * sd_of_mean,
        "{mean} vs {CORNERS_P}"
    );
    assert!(share > share_product, "{share} vs {share_product}");
    // (0.59)² : the product proposal needs about 2.9 times the runs for the same width.
    assert!(width < 0.7 * width_product, "{width} vs {width_product}");
}

/// The same seed gives the same trials; the order of the tells within a round does not
/// change the fit or any later draw.
#[test]
fn joint_draws_depend_on_the_seed_and_outcomes_not_the_tell_order() {
    let joint = Some(Joint { components: 3 });
    let (mut a, mut b) = (corners(9, joint, 2), corners(9, joint, 2));
    for _ in 0..2 {
        let ta: Vec<_> = (0..500).map(|_| a.ask().unwrap()).collect();
        let tb: Vec<_> = (0..500).map(|_| b.ask().unwrap()).collect();
        assert_eq!(ta, tb);
        for t in &ta {
            let (f, r) = corner_run(t);
            a.tell_run(t.id, f, Some(r)).unwrap();
        }
        for t in tb.iter().rev() {
            let (f, r) = corner_run(t);
            b.tell_run(t.id, f, Some(r)).unwrap();
        }
    }
    let ta: Vec<_> = (0..100).map(|_| a.ask().unwrap()).collect();
    let tb: Vec<_> = (0..100).map(|_| b.ask().unwrap()).collect();
    assert_eq!(ta, tb);
    assert!(a.is_joint(0));
    let mut c = corners(10, joint, 2);
    assert_ne!(
        c.ask().unwrap().phi,
        corners(9, joint, 2).ask().unwrap().phi
    );
}

#[test]
fn bad_joint_options_and_robustness_are_refused_naming_them() {
    let space = Space::new(vec![Variable::boolean("b")]).unwrap();
    let p = Posterior::new(&space, PriorCounts::UNIFORM).unwrap();
    let s = Scenario {
        name: Arc::from("s"),
        space,
        weight: 1.0,
    };
    let scenarios = [(s, p)];
    let err = |c: &EstimationConfig| Estimation::new(&scenarios, c).unwrap_err().to_string();
    let mut c = EstimationConfig::new(0.1, 0);
    c.joint = Some(Joint { components: 2 });
    assert_eq!(
        err(&c),
        "joint: the joint proposal is fitted by the cross-entropy pilot rounds: give `refine` (at least 1 round) too"
    );
    c.refine = Some(Refine {
        rounds: 1,
        runs: 10,
        reuse: 0,
    });
    for bad in [0, 65] {
        c.joint = Some(Joint { components: bad });
        assert_eq!(
            err(&c),
            format!("joint.components: must lie in 1..=64, got {bad}")
        );
    }
    c.joint = Some(Joint { components: 2 });
    let mut e = Estimation::new(&scenarios, &c).unwrap();
    let t = e.ask().unwrap();
    assert_eq!(
        e.tell_run(t.id, false, Some(f64::NAN))
            .unwrap_err()
            .to_string(),
        format!(
            "estimation trial {}: robustness must be a finite number, got NaN",
            t.id
        )
    );
    e.tell_run(t.id, false, Some(0.5))
        .expect("still pending after the refusal");
    let json = r#"{"epsilon":0.1,"seed":1,"refine":{"rounds":1,"runs":5},"joint":{"components":2,"kind":"x"}}"#;
    let e = serde_json::from_str::<EstimationConfig>(json).unwrap_err();
    assert!(e.to_string().contains("unknown field `kind`"), "{e}");
}

/// Draws follow the density they are weighted with: the share of 200,000 draws of a fitted
/// joint proposal in each of a few regions equals q's integral over the region.
#[test]
fn joint_draws_follow_the_joint_density() {
    let mut e = corners(4, Some(Joint { components: 4 }), 1);
    for _ in 0..500 {
        let t = e.ask().unwrap();
        let (f, r) = corner_run(&t);
        e.tell_run(t.id, f, Some(r)).unwrap();
    }
    // (x range, y range, z)
    let regions = [
        ((0.0, 0.1), (0.0, 0.1), 1),
        ((0.9, 1.0), (0.9, 1.0), 1),
        ((0.0, 0.1), (0.9, 1.0), 1),
        ((0.2, 0.7), (0.0, 1.0), 0),
    ];
    let n = 200_000;
    let mut counts = [0u32; 4];
    for _ in 0..n {
        let t = e.ask().unwrap();
        let (x, y) = (t.phi.get_f64("x").unwrap(), t.phi.get_f64("y").unwrap());
        let z = t.phi.get("z").and_then(crate::Value::as_f64).unwrap();
        for (c, ((x0, x1), (y0, y1), rz)) in counts.iter_mut().zip(&regions) {
            *c += u32::from(x0 <= &x && x < *x1 && y0 <= &y && y < *y1 && z == f64::from(*rz));
        }
    }
    let k = 200;
    for (c, ((x0, x1), (y0, y1), z)) in counts.iter().zip(&regions) {
        let mut integral = 0.0;
        for i in 0..k * k {
            let x = x0 + (x1 - x0) * ((i % k) as f64 + 0.5) / k as f64;
            let y = y0 + (y1 - y0) * ((i / k) as f64 + 0.5) / k as f64;
            let phi = Assignment::new().with("x", x).with("y", y).with("z", *z);
            integral += e.densities(0, &phi).unwrap().0 * (x1 - x0) * (y1 - y0) / (k * k) as f64;
        }
        let share = f64::from(*c) / n as f64;
        let sd = (integral * (1.0 - integral) / n as f64).sqrt();
        assert!(
            (share - integral).abs() < 4.0 * sd + 1e-4,
            "{share} vs {integral}"
        );
    }
}
