//! `savme-fmu-worker`: serves FMU evaluations over stdin/stdout for
//! [`savme_fmu::worker::IsolatedSimulator`] (the `savme` CLI offers the same as
//! `savme fmu-worker`).
fn main() -> std::process::ExitCode {
    match savme_fmu::worker::serve(std::io::stdin().lock(), std::io::stdout().lock()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("savme-fmu-worker: {e}");
            std::process::ExitCode::FAILURE
        }
    }
}
