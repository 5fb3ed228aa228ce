//! ask + tell through the C ABI (the `extern "C"` entry points C calls: registry lookups,
//! locks, `catch_unwind`, the reusable trial handle) against the same loop on the in-process
//! Rust kernel, in one run: the ratio is what docs/BENCHMARKS.md records.
//!
//!   cargo bench -p savme-capi --bench ffi
//!
//! Each iteration asks a trial, reads one φ value by name and tells a paired observation (the
//! failure a fixed function of the trial id). Both kernels start from the example
//! configuration (crates/capi/examples/config.json) with the paper's kernel settings, after
//! 1000 told trials; blocks of each
//! alternate, and the medians of the blocks are compared.

use ::savme_kernel::{Kernel, Observation, Run};
use savme_capi::*;
use std::ffi::CString;
use std::hint::black_box;
use std::time::Instant;

const BLOCK: u32 = 20_000;
const ROUNDS: usize = 15;

/// The example configuration with the paper's kernel settings (MAP, independent bins, frozen,
/// p(s)): the workload the recorded figures were measured on before the example became the
/// tuned one; the ratio measures the C ABI's overhead, not the search.
fn config() -> String {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/config.json"))
            .unwrap();
    let mut config: serde_json::Value = serde_json::from_str(&text).unwrap();
    let o = config.as_object_mut().unwrap();
    for key in ["search", "deployment", "allocation"] {
        o.remove(key);
    }
    o.insert("estimator".into(), "map".into());
    config.to_string()
}

fn rust_block(k: &mut Kernel, n: u32) -> f64 {
    let start = Instant::now();
    for _ in 0..n {
        let t = k.ask();
        let gap = t.phi.get_f64("gap").unwrap();
        let failure = t.id.is_multiple_of(3);
        let observation = Observation::Paired {
            hf: Run::new(failure, 1.0 + gap * 1e-3),
            lf: Run::new(failure, 0.2),
        };
        black_box(k.tell(t.id, observation).unwrap());
    }
    start.elapsed().as_secs_f64() / f64::from(n)
}

fn c_block(k: *mut savme_kernel, t: *mut savme_trial, n: u32) -> f64 {
    let gap_name = c"gap";
    let start = Instant::now();
    for _ in 0..n {
        // SAFETY: live handles and valid out-pointers.
        unsafe {
            assert_eq!(savme_ask(k, t), savme_status::SAVME_OK);
            let (mut id, mut gap) = (0u64, 0.0);
            savme_trial_id(t, &mut id);
            savme_trial_number(t, savme_part::SAVME_PHI as i32, gap_name.as_ptr(), &mut gap);
            let failure = id.is_multiple_of(3);
            let hf = savme_run {
                failure,
                runtime: 1.0 + gap * 1e-3,
                has_robustness: false,
                robustness: 0.0,
            };
            let lf = savme_run { runtime: 0.2, ..hf };
            let mut record = std::mem::MaybeUninit::<savme_record>::uninit();
            let s = savme_tell_paired(k, id, hf, lf, record.as_mut_ptr());
            assert_eq!(s, savme_status::SAVME_OK);
            black_box(record);
        }
    }
    start.elapsed().as_secs_f64() / f64::from(n)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let text = config();
    let mut rust = Kernel::new(savme_serve::parse_config(&text).unwrap()).unwrap();
    let (mut k, mut t) = (std::ptr::null_mut(), std::ptr::null_mut());
    let json = CString::new(text).unwrap();
    // SAFETY: valid pointers.
    unsafe {
        assert_eq!(
            savme_kernel_new(json.as_ptr(), &mut k),
            savme_status::SAVME_OK
        );
        assert_eq!(savme_trial_new(&mut t), savme_status::SAVME_OK);
    }
    rust_block(&mut rust, 1000);
    c_block(k, t, 1000);
    let (mut rs, mut cs) = (Vec::new(), Vec::new());
    for _ in 0..ROUNDS {
        rs.push(rust_block(&mut rust, BLOCK));
        cs.push(c_block(k, t, BLOCK));
    }
    let (r, c) = (median(rs), median(cs));
    println!("ask + read φ + tell, median of {ROUNDS} blocks of {BLOCK} (after 1000 told):");
    println!("  Rust kernel in process: {:.3} µs", r * 1e6);
    println!("  through the C ABI:      {:.3} µs", c * 1e6);
    println!("  ratio C ABI / Rust:     {:.2}", c / r);
    // SAFETY: live handles.
    unsafe {
        savme_trial_free(t);
        savme_kernel_free(k);
    }
}
