//! What the `player`, `stage` and `playerv` binaries share.

use std::io::{ErrorKind, Write};

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
