//! What the `player`, `stage` and `playerv` binaries share.

use std::io::{ErrorKind, Write};
use std::process::ExitCode;

/// Writes `text` and a newline to standard output. A closed pipe (`stage --dump W | head`) is
/// the reader's choice, not an error: it ends the output quietly instead of panicking as
/// `println!` does. Other write errors are returned.
pub fn print_out(text: &str) -> std::io::Result<()> {
    let mut out = std::io::stdout().lock();
    match writeln!(out, "{text}").and_then(|()| out.flush()) {
        Err(e) if e.kind() == ErrorKind::BrokenPipe => Ok(()),
        r => r,
    }
}

/// The exit status of a binary whose body returned `result`. An error is a user's mistake or
/// the world's (a bad file, a port in use): it is printed as its message and its causes on one
/// line (`error: a: b`) and the status is 1. Never a backtrace, whatever `RUST_BACKTRACE` says:
/// returning the error from `main` would print anyhow's `{:?}`, which adds one when
/// `RUST_BACKTRACE=1`. Panics, which are our bugs, still get theirs from the panic hook.
pub fn exit_status(result: anyhow::Result<()>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
