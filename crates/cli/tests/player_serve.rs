//! `player FILE.cfg` end to end: start-up output, serving a client, clear errors, SIGTERM.

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Command, Stdio};

use player_client::{BlobfinderProxy, PlayerClient, Position2dProxy, RangerProxy, SimulationProxy};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cli-serve-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn player_serves_a_cfg_until_sigterm() {
    let dir = scratch("serve");
    let cfg = dir.join("t.cfg");
    // -p 0: every device without a port gets one port chosen by the OS.
    std::fs::write(
        &cfg,
        "driver( name \"testdriver\" provides [\"ranger:0\" \"position2d:0\"] step_ms 20 )\n",
    )
    .unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_player"))
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .args(["-p", "0", "-q"])
        .arg(&cfg)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdout = BufReader::new(child.stdout.take().unwrap());
    let mut line = String::new();
    stdout.read_line(&mut line).unwrap();
    let port: u16 = line
        .trim()
        .strip_prefix("Listening on ports: ")
        .unwrap_or_else(|| panic!("start-up line: {line:?}"))
        .parse()
        .unwrap();
    let client = PlayerClient::connect("localhost", port).unwrap();
    let ranger = RangerProxy::new(&client, 0).unwrap();
    for _ in 0..3 {
        client.read().unwrap();
    }
    assert_eq!(ranger.ranges().len(), 4);
    drop(ranger);
    drop(client);

    let pid = child.id().to_string();
    assert!(
        Command::new("kill")
            .args(["-TERM", &pid])
            .status()
            .unwrap()
            .success()
    );
    let mut rest = String::new();
    stdout.read_line(&mut rest).unwrap();
    assert_eq!(rest.trim(), "Quitting.");
    let status = child.wait().unwrap();
    assert!(status.success(), "{status:?}");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn unknown_drivers_are_a_clear_start_up_error() {
    let dir = scratch("unknown");
    let cfg = dir.join("bad.cfg");
    std::fs::write(
        &cfg,
        "# comment\ndriver( name \"nosuch\" provides [\"ranger:0\"] )\n",
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_player"))
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .args(["-p", "0"])
        .arg(&cfg)
        .env("RUST_BACKTRACE", "0")
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.cfg:2:1: couldn't find driver \"nosuch\""),
        "{err}"
    );
    assert!(err.contains("driver blocks"), "{err}");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn player_without_a_cfg_serves_the_builtin_bigbob_world() {
    let mut child = Command::new(env!("CARGO_BIN_EXE_player"))
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .args(["-p", "0", "--speedup", "5"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdout = BufReader::new(child.stdout.take().unwrap());
    let mut line = String::new();
    stdout.read_line(&mut line).unwrap();
    let port: u16 = line
        .trim()
        .strip_prefix("Listening on ports: ")
        .unwrap_or_else(|| panic!("start-up line: {line:?}"))
        .parse()
        .unwrap();
    let client = PlayerClient::connect("localhost", port).unwrap();
    let base = Position2dProxy::new(&client, 0).unwrap();
    let sonar = RangerProxy::new(&client, 0).unwrap();
    let eyes = BlobfinderProxy::new(&client, 0).unwrap();
    let laser = RangerProxy::new(&client, 1).unwrap();
    let sim = SimulationProxy::new(&client, 0).unwrap();
    assert_eq!(base.driver_name(), "stage");
    for _ in 0..5 {
        client.read().unwrap();
    }
    assert_eq!(sonar.ranges().len(), 4);
    assert_eq!(laser.ranges().len(), 180);
    assert!(eyes.data().is_some());
    let p = sim.get_pose2d("bob1").unwrap();
    assert_eq!((p.px, p.py), (-5.0, -5.0));
    drop((base, sonar, eyes, laser, sim, client));

    let pid = child.id().to_string();
    assert!(
        Command::new("kill")
            .args(["-TERM", &pid])
            .status()
            .unwrap()
            .success()
    );
    let mut rest = String::new();
    stdout.read_line(&mut rest).unwrap();
    assert_eq!(rest.trim(), "Quitting.");
    assert!(child.wait().unwrap().success());
    let mut err = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
    assert!(err.contains("built-in Bigbob world"), "{err}");
}

/// Headless, Player/Stage (`usegui 0`) does not pace its simulation and we do: `--help` says
/// so and names the flag that runs batch clients as fast as there.
#[test]
fn help_says_the_headless_simulation_keeps_real_time_and_points_to_fast() {
    let out = Command::new(env!("CARGO_BIN_EXE_player"))
        .arg("--help")
        .output()
        .unwrap();
    assert!(out.status.success(), "{out:?}");
    let text = String::from_utf8_lossy(&out.stdout);
    // clap wraps lines to the terminal: compare words
    let words = text.split_whitespace().collect::<Vec<_>>().join(" ");
    for said in [
        "keeps real time (times `--speedup`) whether Stage's window is open or not",
        "with `usegui 0` it steps the world once per pass of Player's main loop",
        "Give `--fast` for that.",
    ] {
        assert!(
            words.contains(said),
            "`player --help` lacks {said:?}:\n{text}"
        );
    }
}
