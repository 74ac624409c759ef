//! Fault test of issue 41: `writelog` on a full disk. `player` records a busy test driver to a
//! 64 KiB tmpfs (or, where mounting is not permitted, under a 64 KiB file-size limit with
//! SIGXFSZ ignored, so the write fails with EFBIG instead of killing the server). The server
//! must report the failure once, naming the log file and the cause, stop recording (its log
//! device says so), keep serving its devices to the clients it has and to new ones, and
//! leave a log that `readlog` reads to its last line without a bad line: no line cut short.

mod common;

use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{PlayerProcess, player_command, read_until};

use player_client::{ClientError, ClientProxy, PlayerClient, Position2dProxy, RangerProxy};
use player_drivers::shell::readlog::{LogReader, open_log};
use player_proto::{Body, InterfaceCode, LogMsg, LogReq};

/// The disk's size (tmpfs) or the file-size limit.
const DISK: u64 = 64 * 1024;
/// Where the log goes, and how the disk is made full.
enum Disk {
    /// A tmpfs of [`DISK`] bytes mounted here (unmounted on drop).
    Tmpfs(PathBuf),
    /// A plain folder; the server runs under a file-size limit of [`DISK`] bytes.
    SizeLimit(PathBuf),
}

impl Disk {
    fn make(dir: &Path) -> Disk {
        let mnt = dir.join("disk");
        std::fs::create_dir_all(&mnt).unwrap();
        let mounted = Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={DISK}"), "tmpfs"])
            .arg(&mnt)
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        if mounted {
            Disk::Tmpfs(mnt)
        } else {
            eprintln!("mounting a tmpfs is not permitted: using a file-size limit instead");
            Disk::SizeLimit(mnt)
        }
    }

    fn path(&self) -> &Path {
        match self {
            Disk::Tmpfs(p) | Disk::SizeLimit(p) => p,
        }
    }

    /// The cause the server must name.
    fn cause(&self) -> &'static str {
        match self {
            Disk::Tmpfs(_) => "No space left on device",
            Disk::SizeLimit(_) => "File too large",
        }
    }
}

impl Drop for Disk {
    fn drop(&mut self) {
        if let Disk::Tmpfs(mnt) = self {
            let _ = Command::new("umount").arg(mnt).status();
        }
    }
}

/// `player` on `cfg`, under the file-size limit when the disk is one.
fn start_server(cfg: &Path, disk: &Disk) -> PlayerProcess {
    let mut cmd = player_command(&["-p", "0", "-q", cfg.to_str().unwrap()]);
    if matches!(disk, Disk::SizeLimit(_)) {
        // SAFETY: only async-signal-safe calls (setrlimit, signal) between fork and exec.
        unsafe {
            cmd.pre_exec(|| {
                let limit = libc::rlimit {
                    rlim_cur: DISK as libc::rlim_t,
                    rlim_max: DISK as libc::rlim_t,
                };
                if libc::setrlimit(libc::RLIMIT_FSIZE, &limit) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                // An ignored signal stays ignored across exec: the write fails with EFBIG.
                libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
                Ok(())
            });
        }
    }
    PlayerProcess::spawn(cmd)
}

/// The log device's GET_STATE: whether it records.
fn recording(log: &ClientProxy) -> bool {
    match log.request(LogReq::GetState(None)).unwrap() {
        Some(Body::Log(LogMsg::Ack(LogReq::GetState(Some(s))))) => s.state != 0,
        other => panic!("GET_STATE answered {other:?}"),
    }
}

#[test]
fn writelog_on_a_full_disk_stops_with_one_clear_error_and_a_readable_log() {
    full_disk("full.log");
}

/// The same for a gzip'd log (a name ending in `.gz`): the file holds whole gzip members of
/// whole lines only, so `readlog` reads it to its last complete line, no stream cut short.
#[test]
fn gzip_writelog_on_a_full_disk_stops_with_one_clear_error_and_a_readable_log() {
    full_disk("full.log.gz");
}

/// Records to `name` on a full disk and checks the guarantees above.
fn full_disk(name: &str) {
    let dir = std::env::temp_dir().join(format!("cli-fulldisk-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let disk = Disk::make(&dir);
    let file = disk.path().join(name);
    let cfg = dir.join("record.cfg");
    // Ranger lines of 256 samples are about 2 KiB: the disk fills within a second.
    std::fs::write(
        &cfg,
        format!(
            "driver( name \"testdriver\" provides [\"position2d:0\" \"ranger:0\"] step_ms 10 samples 256 )\n\
             driver( name \"writelog\" requires [\"position2d:0\" \"ranger:0\"] provides [\"log:0\"] \
             log_directory \"{}\" filename \"{name}\" alwayson 1 )\n",
            disk.path().display()
        ),
    )
    .unwrap();
    let mut server = start_server(&cfg, &disk);

    // A client watches the base the whole time, and the log device.
    let client = PlayerClient::connect("localhost", server.port).unwrap();
    client.set_read_timeout(Some(Duration::from_secs(5)));
    let base = Position2dProxy::new(&client, 0).unwrap();
    let log = ClientProxy::subscribe(&client, InterfaceCode::LOG, 0).unwrap();
    // (Recording starts with the server and the disk fills within a fraction of a second:
    // whether it still records by now is a race, so only its state after the error is checked.)
    let path = file.display().to_string();
    let start = Instant::now();
    read_until(&client, "the write error in the server's log", || {
        server.log().contains(&format!("writing {path} failed"))
    });
    let filled_in = start.elapsed();

    // One error, naming the file and the cause; the recording stopped.
    let errors: Vec<String> = server
        .log()
        .lines()
        .filter(|l| l.contains(&path) && l.contains("ERROR"))
        .map(str::to_string)
        .collect();
    assert!(errors[0].contains(disk.cause()), "{errors:?}");
    assert!(errors[0].contains("recording stopped"), "{errors:?}");
    assert!(!recording(&log), "the log device still says it records");

    // The server serves on: the watching client's data keeps coming, a new client is served.
    let mut rounds = 0;
    base.not_fresh();
    read_until(&client, "50 more rounds of the base's data", || {
        if base.is_fresh() {
            rounds += 1;
            base.not_fresh();
        }
        rounds >= 50
    });
    let late = PlayerClient::connect("localhost", server.port).unwrap();
    late.set_read_timeout(Some(Duration::from_secs(5)));
    let ranger = RangerProxy::new(&late, 0).unwrap();
    read_until(&late, "a new client's ranges", || {
        ranger.ranges().len() == 256
    });
    // Recording cannot be switched back on into the failed file.
    match log.request(LogReq::SetWriteState(Some(
        player_proto::LogSetWriteState { state: 1 },
    ))) {
        Err(ClientError::Nack { .. }) => {}
        other => panic!("SET_WRITE_STATE 1 after the failure: {other:?}"),
    }
    assert!(server.alive(), "the server died");
    let errors_now = server
        .log()
        .lines()
        .filter(|l| l.contains(&path) && l.contains("ERROR"))
        .count();
    assert_eq!(
        errors_now,
        1,
        "one error, not one per message:\n{}",
        server.log()
    );
    drop((base, log, ranger));
    drop((client, late));
    drop(server);

    // The log: complete lines only, every one read back by readlog.
    let on_disk = std::fs::read(&file).unwrap();
    assert!(on_disk.len() as u64 <= DISK, "{} bytes", on_disk.len());
    // what readlog reads (gzip decoded); every member whole: a stream cut short is an error
    let mut bytes = Vec::new();
    std::io::Read::read_to_end(&mut open_log(&file).unwrap(), &mut bytes)
        .unwrap_or_else(|e| panic!("{name} does not read to its end: {e}"));
    assert!(
        bytes.ends_with(b"\n"),
        "the log ends in a line cut short: {:?}",
        String::from_utf8_lossy(&bytes[bytes.len().saturating_sub(80)..])
    );
    let (mut messages, mut bad) = (0, Vec::new());
    {
        let mut reader = LogReader::open(&file).unwrap();
        while let Some(next) = reader.next_message() {
            match next {
                Ok(_) => messages += 1,
                Err(e) => bad.push(e.to_string()),
            }
        }
    }
    assert!(bad.is_empty(), "readlog found bad lines: {bad:?}");
    assert!(messages > 10, "only {messages} messages in the log");
    assert!(
        errors[0].contains(&format!("recording stopped after {messages} message lines")),
        "the error counts the lines the log kept ({messages}): {}",
        errors[0]
    );
    println!(
        "full disk ({}, {name}): filled in {filled_in:?}, {} bytes and {messages} messages \
         kept; error: {}",
        match disk {
            Disk::Tmpfs(_) => "tmpfs",
            Disk::SizeLimit(_) => "file-size limit",
        },
        bytes.len(),
        errors[0]
    );
    drop(disk);
    let _ = std::fs::remove_dir_all(&dir);
}
