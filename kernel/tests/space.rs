//! Binning, drawing and validation of spaces.
use rand::SeedableRng;
use rand_pcg::Pcg64;
use savme_kernel::{Assignment, Scale, Space, SpaceError, Value, Variable};

fn real(x: f64) -> Value {
    Value::Real(x)
}

#[test]
fn linear_bins_edges_lo_and_hi() {
    let v = Variable::continuous("x", 0.0, 1.0, 4, Scale::Linear);
    assert_eq!(v.bin(0), Some((0.0, 0.25)));
    assert_eq!(v.bin(3), Some((0.75, 1.0)));
    assert_eq!(v.bin(4), None);
    assert_eq!(v.arm_of(&real(0.0)), Some(0), "lo is in the first bin");
    assert_eq!(
        v.arm_of(&real(0.25)),
        Some(1),
        "an inner edge is in the upper bin"
    );
    assert_eq!(v.arm_of(&real(0.2499999)), Some(0));
    assert_eq!(v.arm_of(&real(0.5)), Some(2));
    assert_eq!(v.arm_of(&real(0.75)), Some(3));
    assert_eq!(v.arm_of(&real(1.0)), Some(3), "hi is in the last bin");
    assert_eq!(v.arm_of(&real(-1e-12)), None);
    assert_eq!(v.arm_of(&real(1.0 + 1e-12)), None);
    assert_eq!(v.arm_of(&real(f64::NAN)), None);
    assert_eq!(
        v.arm_of(&Value::Int(1)),
        Some(3),
        "integers are numbers too"
    );
    assert_eq!(v.arm_of(&Value::from("1")), None, "labels are not");
}

#[test]
fn log_bins_have_equal_ratios_and_log_midpoints() {
    let v = Variable::continuous("d", 10.0, 1000.0, 2, Scale::Log);
    let (a, b) = v.bin(0).unwrap();
    assert_eq!(a, 10.0);
    assert!((b - 100.0).abs() < 1e-9);
    assert_eq!(v.bin(1).unwrap().1, 1000.0);
    assert_eq!(v.arm_of(&real(99.0)), Some(0));
    assert_eq!(
        v.arm_of(&real(v.bin(1).unwrap().0)),
        Some(1),
        "edge value goes up"
    );
    assert_eq!(v.arm_of(&real(1000.0)), Some(1));
    // Expected value of a log-uniform variable on [10, 100]: 90 / ln 10.
    let Value::Real(m) = v.representative(0) else {
        panic!("continuous representative is real")
    };
    assert!((m - 90.0 / 10f64.ln()).abs() < 1e-9);
    let lin = Variable::continuous("x", 2.0, 4.0, 1, Scale::Linear);
    assert_eq!(lin.representative(0), real(3.0));
}

#[test]
fn every_edge_maps_to_the_bin_that_starts_there() {
    for scale in [Scale::Linear, Scale::Log] {
        let v = Variable::continuous("x", 0.2, 20.0, 10, scale);
        for k in 0..10 {
            let (lo, hi) = v.bin(k).unwrap();
            assert_eq!(v.arm_of(&real(lo)), Some(k), "{scale:?} edge {k}");
            assert!(lo < hi);
        }
    }
}

#[test]
fn draws_land_in_their_bin_and_log_draws_are_log_uniform() {
    let mut rng = Pcg64::seed_from_u64(3);
    let v = Variable::continuous("d", 1.0, 10_000.0, 1, Scale::Log);
    let n = 20_000;
    let mut below_100 = 0;
    for _ in 0..n {
        let Value::Real(x) = v.draw_in_arm(0, &mut rng) else {
            panic!()
        };
        assert!((1.0..=10_000.0).contains(&x));
        below_100 += usize::from(x < 100.0);
    }
    // Log-uniform on [1, 1e4]: P(x < 100) = 0.5 (uniform would give 0.0099).
    let share = below_100 as f64 / n as f64;
    assert!((share - 0.5).abs() < 0.02, "share {share}");
    let lin = Variable::continuous("x", 0.0, 10.0, 5, Scale::Linear);
    for arm in 0..5 {
        for _ in 0..200 {
            let x = lin.draw_in_arm(arm, &mut rng);
            assert_eq!(lin.arm_of(&x), Some(arm));
        }
    }
}

#[test]
fn validation_names_the_problem() {
    let cont =
        |lo, hi, bins, scale| Space::new(vec![Variable::continuous("v", lo, hi, bins, scale)]);
    use Scale::*;
    assert_eq!(Space::new(vec![]), Err(SpaceError::Empty));
    assert!(matches!(
        cont(1.0, 1.0, 3, Linear),
        Err(SpaceError::EmptyRange { .. })
    ));
    assert!(matches!(
        cont(2.0, 1.0, 3, Linear),
        Err(SpaceError::EmptyRange { .. })
    ));
    assert!(matches!(
        cont(f64::NAN, 1.0, 3, Linear),
        Err(SpaceError::NonFiniteBound { .. })
    ));
    assert!(matches!(
        cont(0.0, f64::INFINITY, 3, Linear),
        Err(SpaceError::NonFiniteBound { .. })
    ));
    assert!(matches!(
        cont(0.0, 1.0, 0, Linear),
        Err(SpaceError::ZeroBins { .. })
    ));
    assert!(matches!(
        cont(0.0, 1.0, 3, Log),
        Err(SpaceError::LogRangeNotPositive { .. })
    ));
    assert!(matches!(
        cont(-1.0, 1.0, 3, Log),
        Err(SpaceError::LogRangeNotPositive { .. })
    ));
    assert!(matches!(
        cont(0.0, 1.0, 70_000, Linear),
        Err(SpaceError::TooManyArms { .. })
    ));
    assert!(cont(1e-9, 1.0, 3, Log).is_ok());
    // Extreme but finite ranges: refused naming the variable, not a panic at the first draw.
    for (lo, hi, scale) in [
        (-1e308, 1e308, Linear),
        (-f64::MAX, f64::MAX, Linear),
        (0.0, 1e-320, Linear),
        (1e-308, 1e308, Log),
    ] {
        let e = cont(lo, hi, 3, scale).unwrap_err();
        assert!(
            matches!(&e, SpaceError::RangeNotRepresentable { variable, .. } if variable == "v"),
            "[{lo}, {hi}] {scale:?}: {e}"
        );
        assert!(e.to_string().contains("`v`") && e.to_string().contains("too wide"));
    }
    // The widest ranges accepted draw inside their bins.
    let mut rng = Pcg64::seed_from_u64(7);
    for v in [
        Variable::continuous("w", -8e307, 8e307, 65_535, Linear),
        Variable::continuous("w", 1e-150, 1e150, 65_535, Log),
    ] {
        Space::new(vec![v.clone()]).unwrap();
        for arm in [0, 1, 32_767, 65_534] {
            let x = v.draw_in_arm(arm, &mut rng).as_f64().unwrap();
            let (a, b) = v.bin(arm).unwrap();
            assert!(x.is_finite() && a <= x && x <= b, "{x} in [{a}, {b}]");
        }
    }
    let dup = Space::new(vec![Variable::boolean("a"), Variable::boolean("a")]);
    assert_eq!(dup, Err(SpaceError::DuplicateName("a".into())));
    let empty_vals = Space::new(vec![Variable::discrete::<i64>("a", [])]);
    assert!(matches!(empty_vals, Err(SpaceError::NoValues { .. })));
    let dup_val = Space::new(vec![Variable::discrete(
        "a",
        [Value::Int(2), Value::Real(2.0)],
    )]);
    assert!(matches!(dup_val, Err(SpaceError::DuplicateValue { .. })));
    let nan_val = Space::new(vec![Variable::discrete("a", [f64::NAN])]);
    assert!(matches!(nan_val, Err(SpaceError::NonFiniteValue { .. })));
    assert_eq!(
        Space::new(vec![Variable::boolean(" ")]),
        Err(SpaceError::EmptyName)
    );
    let msg = cont(0.0, 1.0, 3, Log).unwrap_err().to_string();
    assert!(msg.contains("`v`") && msg.contains("0 < lo"), "{msg}");
}

#[test]
fn assignments_are_checked_against_the_space() {
    let s = Space::new(vec![
        Variable::discrete("rate", [2, 10]),
        Variable::continuous("d", 0.2, 20.0, 10, Scale::Log),
    ])
    .unwrap();
    let ok = Assignment::new().with("rate", 10).with("d", 0.2);
    assert_eq!(s.arms_of(&ok), Ok(vec![1, 0]));
    let missing = Assignment::new().with("rate", 10);
    assert!(
        matches!(s.arms_of(&missing), Err(SpaceError::MissingValue { variable }) if variable == "d")
    );
    let extra = ok.clone().with("zzz", 1);
    assert!(
        matches!(s.arms_of(&extra), Err(SpaceError::UnknownVariable { variable }) if variable == "zzz")
    );
    let outside = ok.clone().with("d", 20.5);
    let err = s.arms_of(&outside).unwrap_err();
    assert!(matches!(&err, SpaceError::OutOfSpace { variable, .. } if variable == "d"));
    assert!(err.to_string().contains("[0.2, 20]"), "{err}");
    let wrong_kind = ok.with("rate", "ten");
    assert!(matches!(
        s.arms_of(&wrong_kind),
        Err(SpaceError::OutOfSpace { .. })
    ));
}

/// A space of every kind of variable: integers, labels, booleans, log-binned reals (16 variables,
/// the shape of a realistic fidelity space).
fn mixed_space(bins: u32) -> Space {
    let mut vars = vec![
        Variable::discrete("rate", [2, 4, 6, 8, 10]),
        Variable::discrete("level", ["high", "low"]),
    ];
    vars.extend((0..6).map(|i| Variable::boolean(&format!("switch_{i}"))));
    vars.push(Variable::continuous("far", 10.0, 5000.0, bins, Scale::Log));
    vars.push(Variable::continuous("near", 0.2, 20.0, bins, Scale::Log));
    vars.extend((6..9).map(|i| Variable::boolean(&format!("switch_{i}"))));
    vars.push(Variable::discrete("count", [1, 2, 3, 4, 5]));
    vars.push(Variable::discrete("depth", [0, 1, 2, 3, 4]));
    vars.push(Variable::continuous("clip", 0.2, 20.0, bins, Scale::Log));
    Space::new(vars).expect("a valid space")
}

#[test]
fn spaces_round_trip_through_json_and_are_validated_on_read() {
    let s = mixed_space(10);
    assert_eq!(s.len(), 16);
    let json = serde_json::to_string(&s).unwrap();
    let back: Space = serde_json::from_str(&json).unwrap();
    assert_eq!(back, s);
    let bad = r#"[{"name":"v","type":"continuous","lo":5,"hi":1,"bins":3,"scale":"linear"}]"#;
    let err = serde_json::from_str::<Space>(bad).unwrap_err().to_string();
    assert!(err.contains("lo < hi"), "{err}");
}

#[test]
fn a_value_that_is_no_number_for_a_continuous_variable_is_named_as_such() {
    let s = Space::new(vec![Variable::continuous(
        "speed",
        5.0,
        35.0,
        6,
        Scale::Linear,
    )])
    .unwrap();
    for given in [Value::from("abc"), Value::Bool(true)] {
        let e = s
            .arms_of(&Assignment::new().with("speed", given.clone()))
            .unwrap_err();
        assert!(
            matches!(&e, SpaceError::NotANumber { variable, .. } if variable == "speed"),
            "{e}"
        );
        assert!(e.to_string().contains("is not a number"), "{e}");
    }
    let e = s
        .arms_of(&Assignment::new().with("speed", 99.0))
        .unwrap_err();
    assert!(matches!(e, SpaceError::OutOfSpace { .. }), "{e}");
}

/// The authors' SAVME code's log bins (`Variable(bin_edge_type="log")`): edges
/// `lo − 1 + (hi − lo + 1)^(k/n)`, inside a bin `[a, b]` the value `a − 1 + y` with `y`
/// log-uniform on `[1, 1 + b − a]`, and its mean as the MAP value. The expected numbers are the
/// authors' formulas evaluated in Python (numpy's `10 ** linspace(...) − 1 + lo`).
#[test]
fn shifted_log_bins_are_the_authors_code_s() {
    let v = Variable::continuous("near_clipping_m", 0.2, 20.0, 5, Scale::ShiftedLog);
    let authors = [
        0.2,
        1.034901125220996,
        2.566862139337278,
        5.377859127933941,
        10.53576066530279,
        20.0,
    ];
    for arm in 0..5 {
        let (a, b) = v.bin(arm).unwrap();
        assert!((a - authors[arm]).abs() < 1e-12, "edge {arm}: {a}");
        assert!(
            (b - authors[arm + 1]).abs() < 1e-12,
            "edge {}: {b}",
            arm + 1
        );
        assert_eq!(v.arm_of(&real(a)), Some(arm), "edge {arm} opens its bin");
    }
    // The authors' get_map() value of bin 2.
    let Value::Real(m) = v.representative(2) else {
        panic!()
    };
    assert!((m - 3.667928177001919).abs() < 1e-12, "representative {m}");
    // Draws: in their bin, x − a + 1 log-uniform on [1, 1 + b − a] (median √(1 + b − a)).
    let mut rng = Pcg64::seed_from_u64(11);
    let (a, b) = v.bin(4).unwrap();
    let median = a - 1.0 + (1.0 + b - a).sqrt();
    let n = 20_000;
    let mut below = 0;
    for _ in 0..n {
        let x = v.draw_in_arm(4, &mut rng);
        assert_eq!(v.arm_of(&x), Some(4));
        below += usize::from(x.as_f64().unwrap() < median);
    }
    let share = below as f64 / n as f64;
    assert!((share - 0.5).abs() < 0.02, "share below the median {share}");
    // The in-bin density integrates to 1 (midpoint rule).
    let steps = 100_000;
    let h = (b - a) / steps as f64;
    let mass: f64 = (0..steps)
        .map(|i| v.in_bin_density(4, &real(a + (i as f64 + 0.5) * h)) * h)
        .sum();
    assert!((mass - 1.0).abs() < 1e-6, "mass {mass}");
}

/// A shifted-log variable may touch or cross 0 (a log-scaled one may not), serialises as
/// "shifted-log", and an unrepresentable range is refused as for the other scales.
#[test]
fn shifted_log_takes_any_range_and_round_trips() {
    let v = Variable::continuous("offset", -5.0, 100.0, 4, Scale::ShiftedLog);
    let space = Space::new(vec![v.clone()]).unwrap();
    let json = serde_json::to_string(&space).unwrap();
    assert!(json.contains("\"scale\":\"shifted-log\""), "{json}");
    let back: Space = serde_json::from_str(&json).unwrap();
    assert_eq!(back, space);
    assert!(Space::new(vec![Variable::continuous("z", 0.0, 1.0, 3, Scale::Log)]).is_err());
    let huge = Variable::continuous("h", -1e308, 1e308, 3, Scale::ShiftedLog);
    assert!(matches!(
        Space::new(vec![huge]),
        Err(SpaceError::RangeNotRepresentable { .. })
    ));
    assert_eq!(Scale::from_name("shifted-log"), Some(Scale::ShiftedLog));
}
