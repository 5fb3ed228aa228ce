//! Compiles the C logger savme hands to FMUs (`csrc/logger.c`): FMI's logger is C-variadic.
fn main() {
    println!("cargo:rerun-if-changed=csrc/logger.c");
    cc::Build::new()
        .file("csrc/logger.c")
        .warnings(true)
        .compile("savme_fmu_logger");
}
