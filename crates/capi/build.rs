//! The shared library's SONAME is `libsavme.so` (the name scripts/install gives it), so that a
//! program linked against it finds it by that name at run time.
fn main() {
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("linux") {
        println!("cargo:rustc-cdylib-link-arg=-Wl,-soname,libsavme.so");
    }
}
