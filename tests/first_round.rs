//! The first data round after subscribing (issue 40): a client of a cfg serving both Bigbobs
//! on one port subscribes every robot's rangers, asks each for its geometry and reads once.
//! On the original every subscribed ranger holds data after that read; libplayerc clients
//! index the ranges without checking, so a ranger left empty crashes them.
//!
//! The same sequence runs as a real libplayerc program (`examples/c/first_round.c`) when
//! `pkg-config` finds `playerc` (skipped with a message otherwise).

mod common;

use std::path::PathBuf;
use std::time::Duration;

use common::{assert_example_ok, build_example, root, run_bounded, serve_cfg};
use player_client::{DataMode, PlayerClient, Position2dProxy, RangerProxy};
use player_server::Pace;

/// Both Bigbobs on one port: bob1's sonars and laser are ranger:0 and ranger:1, bob2's
/// ranger:2 and ranger:3, each robot in its own stage block (as the issue's cfg).
fn one_port_cfg(tag: &str) -> (PathBuf, PathBuf) {
    let dir = std::env::temp_dir().join(format!("playerstage-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let world = root().join("worlds/bigbob.world");
    let cfg = dir.join("bigbob_one_port.cfg");
    std::fs::write(
        &cfg,
        format!(
            "driver( name \"stage\" provides [\"6665:simulation:0\"] worldfile \"{}\" )\n\
             driver( name \"stage\" provides [\"6665:position2d:0\" \"6665:ranger:0\" \
             \"6665:ranger:1\"] model \"bob1\" )\n\
             driver( name \"stage\" provides [\"6665:position2d:1\" \"6665:ranger:2\" \
             \"6665:ranger:3\"] model \"bob2\" )\n",
            world.display()
        ),
    )
    .unwrap();
    (cfg, dir)
}

/// Ranges per ranger in bigbob.inc: four one-sample sonars, a 180-sample laser.
const RANGES: [usize; 4] = [4, 180, 4, 180];

/// Subscribes ranger:0..3, requests each one's geometry, reads once (one PULL round, or in
/// PUSH mode what arrives with the first ranger's data) and checks that every ranger holds
/// ranges of the right count.
///
/// The client first syncs with the server's steps (bob2's position2d, one round), then waits
/// 40 ms before subscribing, as a client on a network or printing to a terminal may: bob1's
/// block is then subscribed well apart from bob2's, and the world does not step during the
/// subscriptions (at the pace of real time a step is 100 ms).
fn first_round_has_every_ranger(mode: DataMode, pace: Pace, tag: &str) {
    let (cfg, dir) = one_port_cfg(tag);
    let server = serve_cfg(&cfg, pace);
    let client = PlayerClient::connect("localhost", server.port(6665)).unwrap();
    client.set_read_timeout(Some(Duration::from_secs(10)));
    let bob2 = Position2dProxy::new(&client, 1).unwrap();
    client.read().unwrap();
    assert!(bob2.state().is_some(), "bob2's odometry after a round");
    client.set_datamode(mode).unwrap();
    std::thread::sleep(Duration::from_millis(40));
    let rangers: Vec<RangerProxy> = (0..4)
        .map(|i| RangerProxy::new(&client, i).unwrap())
        .collect();
    for (i, r) in rangers.iter().enumerate() {
        let g = r.request_geom().unwrap();
        let sensors = if RANGES[i] == 4 { 4 } else { 1 };
        assert_eq!(g.element_poses.len(), sensors, "ranger:{i} geometry");
    }
    match mode {
        DataMode::Pull => client.read().unwrap(),
        // PUSH has no rounds: a pass's messages are written together, so what arrives within
        // 15 ms of the first ranger's data is that pass (the world steps every 100 ms; bob1's
        // block, subscribed 40 ms after bob2's, would publish 40 ms apart from it).
        DataMode::Push => {
            while rangers.iter().all(|r| r.ranges().is_empty()) {
                client.read().unwrap();
            }
            client.set_read_timeout(Some(Duration::from_millis(15)));
            while client.read().is_ok() {}
        }
    }
    drop(server);
    let _ = std::fs::remove_dir_all(&dir);
    for (i, r) in rangers.iter().enumerate() {
        let ranges = r.ranges();
        assert_eq!(
            ranges.len(),
            RANGES[i],
            "ranger:{i} after the first {mode:?} round: {ranges:?} (datatime {})",
            r.datatime()
        );
    }
}

#[test]
fn the_first_pull_round_holds_every_subscribed_ranger_in_real_time() {
    first_round_has_every_ranger(DataMode::Pull, Pace::RealTime { speedup: 1.0 }, "pull-rt");
}

#[test]
fn the_first_push_round_holds_every_subscribed_ranger_in_real_time() {
    first_round_has_every_ranger(DataMode::Push, Pace::RealTime { speedup: 1.0 }, "push-rt");
}

#[test]
fn the_first_pull_round_holds_every_subscribed_ranger_as_fast_as_possible() {
    first_round_has_every_ranger(DataMode::Pull, Pace::AsFastAsPossible, "pull-fast");
}

/// A robot whose ranger updates every 500 ms, in a world stepping every 100 ms.
const SLOW_RANGER_WORLD: &str = r#"
interval_sim 100
resolution 0.02
model ( name "wall" size [0.2 4 1] pose [2 0 0 0] )
position
(
  name "robot"
  size [0.5 0.5 0.5]
  drive "diff"
  ranger ( update_interval 500 sensor ( range [0 4] fov 20 samples 5 ) )
)
"#;

/// A second client subscribing to a device that is already running gets its current data in
/// its first round, though the model makes no new sample before the next 500 ms: upstream's
/// plugin publishes every subscribed device's current data, not only new samples.
#[test]
fn a_device_already_running_is_in_a_new_subscribers_first_round() {
    let dir = std::env::temp_dir().join(format!("playerstage-slow-ranger-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("slow.world"), SLOW_RANGER_WORLD).unwrap();
    let cfg = dir.join("slow.cfg");
    std::fs::write(
        &cfg,
        "driver( name \"stage\" provides [\"simulation:0\"] worldfile \"slow.world\" )\n\
         driver( name \"stage\" provides [\"position2d:0\" \"ranger:0\"] model \"robot\" )\n",
    )
    .unwrap();
    let server = serve_cfg(&cfg, Pace::RealTime { speedup: 1.0 });
    let first = PlayerClient::connect("localhost", server.port(6665)).unwrap();
    let second = PlayerClient::connect("localhost", server.port(6665)).unwrap();
    first.set_read_timeout(Some(Duration::from_secs(10)));
    second.set_read_timeout(Some(Duration::from_secs(10)));
    let running = RangerProxy::new(&first, 0).unwrap();
    // The first client's round with a sample: the model's next one is 500 ms away.
    while running.ranges().is_empty() {
        first.read().unwrap();
    }
    let base = Position2dProxy::new(&second, 0).unwrap();
    let ranger = RangerProxy::new(&second, 0).unwrap();
    second.read().unwrap();
    let odometry = base.state().is_some();
    let ranges = ranger.ranges();
    drop(server);
    let _ = std::fs::remove_dir_all(&dir);
    assert!(odometry, "the base's first sample");
    assert_eq!(
        ranges.len(),
        5,
        "the running ranger's current scan: {ranges:?}"
    );
    assert_eq!(ranger.datatime(), running.datatime(), "the same sample");
}

/// The libplayerc program `examples/c/first_round.c` does the same (in PULL mode, libplayerc's
/// default) and exits non-zero when a ranger holds no ranges after the first read.
#[test]
fn libplayerc_first_round_holds_every_subscribed_ranger() {
    if !test_support::pkg_config_finds(&["playerc"], "the libplayerc first-round test") {
        return;
    }
    let program = build_example("c", "first_round");
    let (cfg, dir) = one_port_cfg("first-round-c");
    let server = serve_cfg(&cfg, Pace::RealTime { speedup: 1.0 });
    let args = ["localhost".to_string(), server.port(6665).to_string()];
    let out = run_bounded(&program, &args, Duration::from_secs(30));
    drop(server);
    let _ = std::fs::remove_dir_all(program.parent().unwrap());
    let _ = std::fs::remove_dir_all(&dir);
    assert_example_ok("first_round", &out);
}
