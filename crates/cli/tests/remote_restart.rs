//! Fault test of issue 41: the remote server of a `requires` chain killed mid-stream and
//! restarted. A local `player` serves a `passthrough` of a position2d device of a remote
//! `player` (`requires ["127.0.0.1:PORT:position2d:0"]`) beside a local ranger; a client
//! streams both. The remote is killed with SIGKILL, as a crash would end it. The client must
//! get a clear error on the chained device (its next request NACKed at once, its data stops,
//! the local server's log names the remote device and where the cfg requires it), the local
//! ranger must serve on to it and to a new client, and when the remote server comes back on
//! the same port the chain must recover by itself (the client still subscribed gets data
//! again), as well as for a client that subscribes again, as upstream's passthrough recovers.
//! The recovery time, from the restart to the first datum through the chain, is printed.

mod common;

use std::net::TcpListener;
use std::time::{Duration, Instant};

use common::{PATIENCE, PlayerProcess, player_command, read_until};
use player_client::{ClientError, PlayerClient, Position2dProxy, RangerProxy};

/// Reads until `count` fresh rounds of `ranger`.
fn ranger_rounds(client: &PlayerClient, ranger: &RangerProxy, count: u32) {
    let mut rounds = 0;
    ranger.not_fresh();
    read_until(client, "the local ranger's data", || {
        if ranger.is_fresh() {
            rounds += 1;
            ranger.not_fresh();
        }
        rounds >= count
    });
}

/// The remote server: a test driver's position2d on `port`.
fn remote(cfg: &std::path::Path, port: u16) -> PlayerProcess {
    PlayerProcess::spawn(player_command(&[
        "-p",
        &port.to_string(),
        "-q",
        cfg.to_str().unwrap(),
    ]))
}

#[test]
fn a_killed_remote_is_reported_and_the_chain_recovers_when_it_restarts() {
    let dir = std::env::temp_dir().join(format!("cli-remote-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let remote_cfg = dir.join("remote.cfg");
    std::fs::write(
        &remote_cfg,
        "driver( name \"testdriver\" provides [\"position2d:0\"] step_ms 20 )\n",
    )
    .unwrap();
    // A port for the remote server that is free now; it keeps it across the restart.
    let remote_port = TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let local_cfg = dir.join("local.cfg");
    std::fs::write(
        &local_cfg,
        format!(
            "driver( name \"passthrough\" provides [\"position2d:0\"] \
             requires [\"127.0.0.1:{remote_port}:position2d:0\"] )\n\
             driver( name \"testdriver\" provides [\"ranger:0\"] step_ms 20 )\n"
        ),
    )
    .unwrap();

    let mut far = remote(&remote_cfg, remote_port);
    let mut local = PlayerProcess::spawn(player_command(&[
        "-p",
        "0",
        "-q",
        local_cfg.to_str().unwrap(),
    ]));
    let client = PlayerClient::connect("localhost", local.port).unwrap();
    client.set_request_timeout(Duration::from_secs(5));
    client.set_read_timeout(Some(Duration::from_secs(5)));
    let base = Position2dProxy::new(&client, 0).unwrap();
    let ranger = RangerProxy::new(&client, 0).unwrap();
    read_until(&client, "data through the chain", || base.is_fresh());
    base.request_geom().expect("a request through the chain");
    ranger_rounds(&client, &ranger, 5);
    let (fds_before, rss_before) = local.fds_and_rss();

    // The remote server dies mid-stream.
    far.kill();
    let killed = Instant::now();
    // The chained device: its next request is refused at once (no 5 s timeout).
    let refused = loop {
        let asked = Instant::now();
        match base.request_geom() {
            Err(ClientError::Nack { .. }) => break asked.elapsed(),
            // Sent before the local server saw the connection go: answered, or refused.
            Ok(_) => {}
            Err(e) => panic!("a request to the chained device: {e}"),
        }
        assert!(killed.elapsed() < PATIENCE, "requests were never refused");
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(
        refused < Duration::from_millis(2500),
        "NACK after {refused:?}"
    );
    // The log names the remote device and where the cfg requires it.
    let log = local.wait_for_log("requests to it are refused", PATIENCE);
    let warning = log
        .lines()
        .find(|l| l.contains("WARN") && l.contains("requests to it are refused"))
        .unwrap_or_else(|| panic!("no warning about the remote:\n{log}"))
        .to_string();
    assert!(
        warning.contains(&format!("position2d:0 at 127.0.0.1:{remote_port}"))
            && warning.contains("required at")
            && warning.contains("local.cfg:1"),
        "{warning}"
    );
    // Its data stops; the local ranger serves on, to this client and a new one. (Data sent
    // before the kill may still be on its way, or kept from the wait for the NACK: let it
    // through first.)
    ranger_rounds(&client, &ranger, 5);
    base.not_fresh();
    ranger_rounds(&client, &ranger, 25);
    assert!(!base.is_fresh(), "chained data while the remote is down");
    let other = PlayerClient::connect("localhost", local.port).unwrap();
    other.set_read_timeout(Some(Duration::from_secs(5)));
    let other_ranger = RangerProxy::new(&other, 0).unwrap();
    read_until(&other, "a new client's ranges", || {
        !other_ranger.ranges().is_empty()
    });
    // Down long enough for the local server's attempts to reach their longest pause, so the
    // recovery time below is what a restart after a real outage gets.
    while killed.elapsed() < Duration::from_secs(4) {
        ranger_rounds(&client, &ranger, 5);
        ranger_rounds(&other, &other_ranger, 1);
    }
    assert!(!base.is_fresh(), "chained data while the remote is down");
    assert!(local.alive(), "the local server died with the remote");

    // The remote server comes back on the same port: the chain recovers by itself.
    let restarted = Instant::now();
    let far = remote(&remote_cfg, remote_port);
    let listening = Instant::now();
    base.not_fresh();
    read_until(&client, "data through the chain again", || base.is_fresh());
    let recovery = restarted.elapsed();
    let after_listening = listening.elapsed();
    assert!(
        recovery < Duration::from_secs(10),
        "recovered after {recovery:?}"
    );
    base.request_geom()
        .expect("a request through the recovered chain");
    local.wait_for_log("is back", PATIENCE);

    // A client subscribing again (upstream's way to recover) gets data too.
    drop(base);
    let again = Position2dProxy::new(&client, 0).unwrap();
    read_until(&client, "data after subscribing again", || again.is_fresh());
    let late = Position2dProxy::new(&other, 0).unwrap();
    read_until(&other, "a new subscriber's chained data", || {
        late.is_fresh()
    });
    let (fds_after, rss_after) = local.fds_and_rss();
    assert!(
        fds_after <= fds_before + 3,
        "descriptors of the local server: {fds_before} before the kill, {fds_after} after"
    );
    println!(
        "remote restart: request NACKed {refused:?} after the kill; chain recovered \
         {recovery:?} after the restart ({after_listening:?} after the remote listened); \
         local server: {fds_before} -> {fds_after} fds, {rss_before} -> {rss_after} KiB RSS"
    );
    drop((again, ranger, late, other_ranger));
    drop((client, other));
    drop(far);
    drop(local);
    let _ = std::fs::remove_dir_all(&dir);
}
