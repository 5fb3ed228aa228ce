//! The FMU-run overhead guard (issue 39 item 6): one evaluation through the adapter (the test
//! kit's FMU as FMI 3.0, 100 steps of 0.01 s, the failure output read after each step, the cost
//! output at the end) timed as a ratio to the same FMI calls made by a native loop — the test
//! kit's library loaded directly, its `fmi3…` functions called through plain function pointers
//! with nothing around them — measured in interleaved batches of the same run (the fastest
//! batch of each kept), and compared
//! with the ratio recorded in `fmu-adapter/benches/guard.json`. Exits with status 1 when the
//! ratio is more than 10 % above its record; prints the overhead (adapter − native) too.
//!
//! `cargo bench -p savme-fmu --bench guard` checks; `… --bench guard -- --record` rewrites the
//! record (after a change meant to cost more or less).
mod testkit;

use libloading::{Library, Symbol};
use savme_kernel::{Assignment, Role};
use std::collections::BTreeMap;
use std::ffi::{c_char, c_void, CString};
use std::hint::black_box;
use std::time::Instant;

/// How far above its recorded ratio a measured one may be before it counts as a regression.
const TOLERANCE: f64 = 1.10;
/// Interleaved batches and evaluations per batch: short batches (~1 ms), many of them, and the
/// fastest kept for each side — on a shared machine the least disturbed batch is the one that
/// measures the code (a median still moved by ±50 % under a load average of 20).
const BATCHES: usize = 301;
const PER_BATCH: usize = 200;
/// The test kit's value references (see `savme_fmu_testkit::vr`).
const X0: u32 = 0;
const RATE: u32 = 1;
const FAILED: u32 = 7;
const STEPS: u32 = 8;

type Instantiate = unsafe extern "C" fn(
    *const c_char,
    *const c_char,
    *const c_char,
    bool,
    bool,
    bool,
    bool,
    *const u32,
    usize,
    *mut c_void,
    *const c_void,
    *const c_void,
) -> *mut c_void;
type Simple = unsafe extern "C" fn(*mut c_void) -> i32;
type EnterInit = unsafe extern "C" fn(*mut c_void, bool, f64, f64, bool, f64) -> i32;
type DoStep = unsafe extern "C" fn(
    *mut c_void,
    f64,
    f64,
    bool,
    *mut bool,
    *mut bool,
    *mut bool,
    *mut f64,
) -> i32;
type SetF64 = unsafe extern "C" fn(*mut c_void, *const u32, usize, *const f64, usize) -> i32;
type GetBool = unsafe extern "C" fn(*mut c_void, *const u32, usize, *mut bool, usize) -> i32;
type GetI32 = unsafe extern "C" fn(*mut c_void, *const u32, usize, *mut i32, usize) -> i32;

/// The native loop: the test kit's FMI 3.0 functions, one instance, reused.
struct Native<'a> {
    c: *mut c_void,
    reset: Symbol<'a, Simple>,
    enter: Symbol<'a, EnterInit>,
    exit: Symbol<'a, Simple>,
    step: Symbol<'a, DoStep>,
    set: Symbol<'a, SetF64>,
    get_bool: Symbol<'a, GetBool>,
    get_i32: Symbol<'a, GetI32>,
}

impl<'a> Native<'a> {
    fn new(lib: &'a Library) -> Native<'a> {
        // SAFETY: the symbols are the test kit's FMI 3.0 exports with these signatures
        // (fmi-export/src/macros3.rs); the instance lives as long as the library.
        unsafe {
            let instantiate: Symbol<Instantiate> =
                lib.get(b"fmi3InstantiateCoSimulation").expect("symbol");
            let name = CString::new("native").unwrap();
            let token = CString::new("{5a1e7e57-0000-4000-8000-7e57c0ffee01}").unwrap();
            let c = instantiate(
                name.as_ptr(),
                token.as_ptr(),
                std::ptr::null(),
                false,
                false,
                false,
                false,
                std::ptr::null(),
                0,
                std::ptr::null_mut(),
                std::ptr::null(),
                std::ptr::null(),
            );
            assert!(!c.is_null(), "the native instance");
            Native {
                c,
                reset: lib.get(b"fmi3Reset").expect("symbol"),
                enter: lib.get(b"fmi3EnterInitializationMode").expect("symbol"),
                exit: lib.get(b"fmi3ExitInitializationMode").expect("symbol"),
                step: lib.get(b"fmi3DoStep").expect("symbol"),
                set: lib.get(b"fmi3SetFloat64").expect("symbol"),
                get_bool: lib.get(b"fmi3GetBoolean").expect("symbol"),
                get_i32: lib.get(b"fmi3GetInt32").expect("symbol"),
            }
        }
    }

    /// One evaluation: the adapter's calls, nothing else; returns the steps output.
    fn run(&self, x0: f64, rate: f64) -> i32 {
        let (mut event, mut terminate, mut early, mut last) = (false, false, false, 0.0);
        let mut failed = false;
        let mut steps = 0;
        // SAFETY: `self.c` is a live instance of the library these symbols come from.
        unsafe {
            assert_eq!((self.reset)(self.c), 0);
            let vrs = [X0, RATE];
            assert_eq!(
                (self.set)(self.c, vrs.as_ptr(), 2, [x0, rate].as_ptr(), 2),
                0
            );
            assert_eq!((self.enter)(self.c, false, 0.0, 0.0, true, 1.0), 0);
            assert_eq!((self.exit)(self.c), 0);
            for k in 0..100 {
                let t = f64::from(k) * 0.01;
                let s = (self.step)(
                    self.c,
                    t,
                    0.01,
                    true,
                    &mut event,
                    &mut terminate,
                    &mut early,
                    &mut last,
                );
                assert_eq!(s, 0);
                assert_eq!((self.get_bool)(self.c, &FAILED, 1, &mut failed, 1), 0);
                black_box(failed);
            }
            assert_eq!((self.get_i32)(self.c, &STEPS, 1, &mut steps, 1), 0);
        }
        steps
    }
}

fn fastest(v: Vec<f64>) -> f64 {
    v.into_iter().fold(f64::INFINITY, f64::min)
}

fn record_path() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/guard.json")
}

fn main() {
    let record = std::env::args().any(|a| a == "--record");
    let mut sim = testkit::simulator(3);
    // SAFETY: the test kit's own library, built with this bench; loading runs no code of note.
    let lib = unsafe { Library::new(testkit::testkit_library()) }.expect("load the test kit");
    let native = Native::new(&lib);
    let (p, t) = (
        Assignment::new().with("start", 0.0),
        Assignment::new().with("rate", 0.1),
    );
    assert_eq!(
        sim.run(Role::High, "grow", &p, &t).expect("run").work,
        Some(100)
    );
    assert_eq!(native.run(0.0, 0.1), 100);
    let (mut a, mut n) = (Vec::new(), Vec::new());
    for _ in 0..BATCHES {
        let start = Instant::now();
        for _ in 0..PER_BATCH {
            black_box(native.run(0.0, 0.1));
        }
        n.push(start.elapsed().as_secs_f64() / PER_BATCH as f64);
        let start = Instant::now();
        for _ in 0..PER_BATCH {
            black_box(sim.run(Role::High, "grow", &p, &t).expect("run"));
        }
        a.push(start.elapsed().as_secs_f64() / PER_BATCH as f64);
    }
    let (adapter, native_s) = (fastest(a), fastest(n));
    let ratio = adapter / native_s;
    println!(
        "fmu_evaluation_100_steps_fmi3: {:.3} µs through the adapter, {:.3} µs native: overhead {:.3} µs, ratio {ratio:.3}",
        adapter * 1e6,
        native_s * 1e6,
        (adapter - native_s) * 1e6
    );
    let name = "fmu_evaluation_100_steps_fmi3";
    let path = record_path();
    if record {
        let ratios = BTreeMap::from([(name.to_string(), ratio)]);
        let text = serde_json::to_string_pretty(&ratios).expect("ratios as JSON") + "\n";
        std::fs::write(&path, text).expect("write the record");
        println!("recorded in {}", path.display());
        return;
    }
    let recorded: BTreeMap<String, f64> = match std::fs::read_to_string(&path) {
        Ok(text) => serde_json::from_str(&text).expect("a valid guard.json"),
        Err(e) => {
            eprintln!("{}: {e}; run with -- --record first", path.display());
            std::process::exit(2);
        }
    };
    let Some(&was) = recorded.get(name) else {
        eprintln!("{name}: not in {}; run with -- --record", path.display());
        std::process::exit(2);
    };
    let regressed = ratio > was * TOLERANCE;
    println!(
        "{name}: ratio {ratio:.3} against {was:.3} recorded: {}",
        if regressed { "REGRESSION" } else { "ok" }
    );
    if regressed {
        std::process::exit(1);
    }
}
