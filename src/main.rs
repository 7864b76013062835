//! The `mapvlm` binary: parses the command line and reports failures in one line.

use std::process::ExitCode;

fn main() -> ExitCode {
    match mapvlm::cli::run() {
        Ok(code) => code,
        Err(err) => {
            // The error may quote a server, a model, a file or a path.
            let line = mapvlm::sanitize::redact_url_credentials(&format!("{err:#}"));
            eprintln!("mapvlm: {}", mapvlm::sanitize::for_terminal(&line));
            ExitCode::FAILURE
        }
    }
}
