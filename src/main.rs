//! The `mapvlm` binary: parses the command line and reports failures in one line.

use std::process::ExitCode;

fn main() -> ExitCode {
    match mapvlm::cli::run() {
        Ok(code) => code,
        Err(err) => {
            eprintln!("mapvlm: {err:#}");
            ExitCode::FAILURE
        }
    }
}
