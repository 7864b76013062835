//! The `mapvlm` binary: parses the command line and reports failures in one
//! line; a closed standard output (`mapvlm score … | head -1`) ends it
//! quietly with status 0, as ripgrep does.

use std::process::ExitCode;

fn main() -> ExitCode {
    match mapvlm::cli::run() {
        Ok(code) => code,
        Err(err) if is_broken_pipe(&err) => ExitCode::SUCCESS,
        Err(err) => {
            // The error may quote a server, a model, a file or a path.
            let line = mapvlm::sanitize::redact_url_credentials(&format!("{err:#}"));
            eprintln!("mapvlm: {}", mapvlm::sanitize::one_line(&line));
            ExitCode::FAILURE
        }
    }
}

/// Whether the failure is, anywhere in its chain, a write to a pipe whose
/// reader has gone: the reader had what it wanted, so it is no error.
fn is_broken_pipe(err: &anyhow::Error) -> bool {
    err.chain().any(|cause| {
        cause
            .downcast_ref::<std::io::Error>()
            .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
    })
}
