//! Helpers of the tests that run `player` as a process: start it, learn its port from its
//! first line, collect its log (standard error) while it runs, and stop it.

#![allow(dead_code)] // each test binary uses a different subset

use std::io::{BufRead, BufReader, Read};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// `player` with `args`, headless, its output piped: ready for [`PlayerProcess::spawn`] (or
/// for more settings first).
pub fn player_command(args: &[&str]) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_player"));
    cmd.env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    cmd
}

/// A running `player`, killed on drop; its standard error is collected by a thread.
pub struct PlayerProcess {
    pub child: Child,
    /// The first port of its "Listening on ports:" line.
    pub port: u16,
    stderr: Arc<Mutex<String>>,
}

impl PlayerProcess {
    /// Starts `cmd` (from [`player_command`]) and waits for its "Listening on ports:" line.
    pub fn spawn(mut cmd: Command) -> PlayerProcess {
        let mut child = cmd.spawn().expect("starting player");
        let stderr = Arc::new(Mutex::new(String::new()));
        let mut pipe = child.stderr.take().unwrap();
        let sink = stderr.clone();
        std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            while let Ok(n) = pipe.read(&mut buf) {
                if n == 0 {
                    break;
                }
                sink.lock()
                    .unwrap()
                    .push_str(&String::from_utf8_lossy(&buf[..n]));
            }
        });
        let mut stdout = BufReader::new(child.stdout.take().unwrap());
        let mut line = String::new();
        stdout.read_line(&mut line).unwrap();
        let port = line
            .trim()
            .strip_prefix("Listening on ports: ")
            .and_then(|ports| ports.split_whitespace().next())
            .and_then(|p| p.trim_end_matches(',').parse().ok())
            .unwrap_or_else(|| panic!("start-up line: {line:?}; log:\n{}", stderr.lock().unwrap()));
        // Keep reading standard output so that the server never blocks on it.
        std::thread::spawn(move || {
            let mut rest = String::new();
            let _ = stdout.read_to_string(&mut rest);
        });
        PlayerProcess {
            child,
            port,
            stderr,
        }
    }

    /// What it logged so far.
    pub fn log(&self) -> String {
        self.stderr.lock().unwrap().clone()
    }

    /// Waits (at most `limit`) until its log contains `text`; returns the log.
    pub fn wait_for_log(&self, text: &str, limit: Duration) -> String {
        let start = Instant::now();
        loop {
            let log = self.log();
            if log.contains(text) {
                return log;
            }
            assert!(start.elapsed() < limit, "no {text:?} in the log:\n{log}");
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// Whether it still runs.
    pub fn alive(&mut self) -> bool {
        self.child.try_wait().unwrap().is_none()
    }

    /// Its open file descriptors and resident memory (KiB), from /proc.
    pub fn fds_and_rss(&self) -> (usize, u64) {
        let pid = self.child.id();
        let fds = std::fs::read_dir(format!("/proc/{pid}/fd"))
            .map(|d| d.count())
            .unwrap_or(0);
        let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
        let rss = status
            .lines()
            .find_map(|l| l.strip_prefix("VmRSS:"))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
            .unwrap_or(0);
        (fds, rss)
    }

    /// Kills it at once (SIGKILL, as a crash would end it) and reaps it.
    pub fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for PlayerProcess {
    fn drop(&mut self) {
        self.kill();
    }
}

/// Longest anything may take on a busy machine.
pub const PATIENCE: Duration = Duration::from_secs(30);

/// Reads until `done` holds, failing after [`PATIENCE`]. A read with nothing waiting, or a
/// queue overflow, is not an error here: the condition decides.
pub fn read_until(
    client: &player_client::PlayerClient,
    what: &str,
    mut done: impl FnMut() -> bool,
) {
    use player_client::ClientError;
    let start = Instant::now();
    while !done() {
        assert!(start.elapsed() < PATIENCE, "timed out waiting for {what}");
        match client.read() {
            Ok(()) | Err(ClientError::NoData | ClientError::Overflow { .. }) => {}
            Err(e) => panic!("reading while waiting for {what}: {e}"),
        }
    }
}
