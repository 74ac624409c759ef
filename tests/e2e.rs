//! End-to-end: the Rust client against the `player` server running the `stage` driver on our
//! Bigbob world (`worlds/bigbob2.cfg`: bob1 on one port, bob2 with gripper and fiducial finder
//! on another), stepped as fast as possible on free ports.

mod common;

use std::io::Write;
use std::net::TcpStream;
use std::time::{Duration, Instant};

use common::{Running, bigbob2, serve_cfg};
use player_client::{
    BlobfinderProxy, ClientError, DataMode, FiducialProxy, GripperProxy, LaserProxy, PlayerClient,
    Position2dProxy, RangerProxy, SimulationProxy, SonarProxy,
};
use player_proto::InterfaceCode;
use player_proto::constants::PLAYER_GRIPPER_STATE_CLOSED;
use player_server::Pace;

/// One read; a queue overflow (a PUSH client that was not read for a while, the server running
/// as fast as it can) and a read with no data are not failures.
fn read_once(client: &PlayerClient, what: &str) {
    match client.read() {
        Ok(()) | Err(ClientError::Overflow { .. } | ClientError::NoData) => {}
        Err(e) => panic!("reading while waiting for {what}: {e}"),
    }
}

/// Reads data rounds until `done` holds; fails after 10 s of wall time. The world runs as fast
/// as it computes, so PULL rounds can find the server's queue overflowed (the data is still
/// there) or empty: both are fine here.
fn read_until(client: &PlayerClient, what: &str, mut done: impl FnMut() -> bool) {
    let start = Instant::now();
    loop {
        read_once(client, what);
        if done() {
            return;
        }
        assert!(
            start.elapsed() < Duration::from_secs(10),
            "timed out waiting for {what}"
        );
    }
}

fn fast() -> Running {
    bigbob2(Pace::AsFastAsPossible)
}

fn connect(server: &Running, cfg_port: u32) -> PlayerClient {
    PlayerClient::connect("localhost", server.port(cfg_port)).unwrap()
}

#[test]
fn every_device_of_both_bigbobs_publishes_in_pull_mode() {
    let server = fast();
    let c = connect(&server, 6666);
    let pos = Position2dProxy::new(&c, 0).unwrap();
    let sonar = RangerProxy::new(&c, 0).unwrap();
    let eyes = BlobfinderProxy::new(&c, 0).unwrap();
    let laser = RangerProxy::new(&c, 1).unwrap();
    let gripper = GripperProxy::new(&c, 0).unwrap();
    let fid = FiducialProxy::new(&c, 0).unwrap();
    assert_eq!(pos.driver_name(), "stage");
    read_until(&c, "data from every device", || {
        pos.state().is_some()
            && sonar.ranges().len() == 4
            && eyes.data().is_some()
            && laser.ranges().len() == 180
            && gripper.data().is_some()
            && fid.is_fresh()
    });
    assert!(fid.fiducials().is_empty(), "nothing tall enough in view");
    // bob2 starts at (5, -5) facing north (gps localisation: world pose).
    let p = pos.pose();
    assert!(
        (p.px - 5.0).abs() < 0.01 && (p.py + 5.0).abs() < 0.01,
        "{p:?}"
    );
    assert!(c.datatime() > 0.0, "data is stamped with simulated time");
}

#[test]
fn push_mode_streams_data_without_requests() {
    let server = fast();
    let c = connect(&server, 6665);
    let pos = Position2dProxy::new(&c, 0).unwrap();
    c.set_datamode(DataMode::Push).unwrap();
    let mut stamps = Vec::new();
    read_until(&c, "several position samples", || {
        if pos.is_fresh() {
            stamps.push(pos.datatime());
            pos.not_fresh();
        }
        stamps.len() >= 5
    });
    assert!(
        stamps.windows(2).all(|w| w[1] > w[0]),
        "fresh samples, increasing sim time: {stamps:?}"
    );
}

#[test]
fn geometry_and_config_requests_are_answered() {
    let server = fast();
    let c = connect(&server, 6666);
    let pos = Position2dProxy::new(&c, 0).unwrap();
    let g = pos.request_geom().unwrap();
    assert_eq!((g.size.sl, g.size.sw), (1.25, 1.0));
    assert_eq!(
        (g.pose.px, g.pose.py),
        (0.125, 0.0),
        "Bigbob's origin offset"
    );
    let sonar = RangerProxy::new(&c, 0).unwrap();
    let rg = sonar.request_geom().unwrap();
    assert_eq!(rg.element_poses.len(), 4);
    assert_eq!(rg.element_poses[2].py, 0.5);
    assert!((rg.element_poses[2].pyaw - 30f64.to_radians()).abs() < 1e-9);
    let cfg = RangerProxy::new(&c, 1).unwrap().request_config().unwrap();
    assert!((cfg.max_range - 0.25).abs() < 1e-9);
    assert!((cfg.max_angle - 10f64.to_radians()).abs() < 1e-9);
    assert!(
        (cfg.frequency - 10.0).abs() < 1e-6,
        "100 ms update interval"
    );
    let gg = GripperProxy::new(&c, 0)
        .unwrap()
        .request_geometry()
        .unwrap();
    assert_eq!(gg.num_beams, 2);
    assert!((gg.pose.px - 0.85).abs() < 1e-9);
    FiducialProxy::new(&c, 0)
        .unwrap()
        .request_geometry()
        .unwrap();
    // Stage refuses velocity mode but accepts motor power.
    pos.set_motor_enable(true).unwrap();
    assert!(
        pos.request(player_proto::Position2dReq::VelocityMode(Some(
            player_proto::Position2dVelocityModeConfig { value: 0 }
        )))
        .is_err()
    );
}

#[test]
fn driving_changes_the_pose() {
    let server = fast();
    let c = connect(&server, 6666);
    let pos = Position2dProxy::new(&c, 0).unwrap();
    read_until(&c, "a first pose", || pos.state().is_some());
    let start = pos.pose();
    // Turn on the spot first: driving ahead ends against orange3 (4 m north), where a
    // stalled robot cannot turn any more.
    pos.set_speed(0.0, 0.0, 1.0).unwrap();
    read_until(&c, "bob2 to turn", || {
        (pos.pose().pa - start.pa).abs() > 0.3
    });
    assert!((pos.pose().px - start.px).abs() < 0.05, "on the spot");
    pos.set_speed(0.4, 0.0, 0.0).unwrap();
    read_until(&c, "bob2 to drive", || {
        let p = pos.pose();
        (p.px - start.px).hypot(p.py - start.py) > 0.3
    });
    assert!(
        pos.velocity().px > 0.3 || pos.stall(),
        "{:?}",
        pos.velocity()
    );
}

#[test]
fn odometry_requests_are_acknowledged_and_gps_overrides_them() {
    let server = fast();
    let c = connect(&server, 6665);
    let pos = Position2dProxy::new(&c, 0).unwrap();
    read_until(&c, "a first pose", || pos.state().is_some());
    pos.set_odometry(1.0, 2.0, 0.5).unwrap();
    pos.reset_odometry().unwrap();
    // Bigbob localises by "gps": Stage recomputes the estimate from the true pose every update,
    // so the odometry requests have no lasting effect (stage-models.md §7.8).
    read_until(&c, "the true pose again", || {
        let p = pos.pose();
        (p.px + 5.0).abs() < 1e-6 && (p.py + 5.0).abs() < 1e-6
    });
}

#[test]
fn ranges_change_when_the_robot_is_moved() {
    let server = fast();
    let c = connect(&server, 6665);
    let sim = SimulationProxy::new(&c, 0).unwrap();
    let sonar = RangerProxy::new(&c, 0).unwrap();
    read_until(&c, "sonar ranges", || sonar.ranges().len() == 4);
    // Nose against the cave's west border wall (rock at x < -7.75).
    sim.set_pose2d("bob1", -6.6, -5.0, std::f64::consts::PI)
        .unwrap();
    read_until(&c, "a short front sonar range", || {
        sonar.ranges().first().is_some_and(|&r| r < 1.0)
    });
    let near = sonar.ranges()[0];
    // Back in the open room, facing east.
    sim.set_pose2d("bob1", -5.0, -5.0, 0.0).unwrap();
    read_until(&c, "a long front sonar range", || {
        sonar.ranges().first().is_some_and(|&r| r > near + 0.5)
    });
}

#[test]
fn blobs_appear_when_an_orange_is_in_view() {
    let server = fast();
    let c = connect(&server, 6665);
    let eyes = BlobfinderProxy::new(&c, 0).unwrap();
    // bob1 starts facing orange1, 2.5 m away.
    read_until(&c, "an orange blob", || {
        eyes.blobs().iter().any(|b| b.color == 0xffa500)
    });
    let d = eyes.data().unwrap();
    assert_eq!((d.width, d.height), (160, 120));
    let b = eyes
        .blobs()
        .into_iter()
        .find(|b| b.color == 0xffa500)
        .unwrap();
    assert!(b.left <= b.x && b.x <= b.right, "{b:?}");
    assert!((b.range - 2.5).abs() < 0.5, "range {}", b.range);
    // Turned away: no blob.
    let sim = SimulationProxy::new(&c, 0).unwrap();
    sim.set_pose2d("bob1", -5.0, -5.0, -2.5).unwrap();
    read_until(&c, "no orange blob", || {
        eyes.data().is_some() && !eyes.blobs().iter().any(|b| b.color == 0xffa500)
    });
}

#[test]
fn gripper_closes_on_an_orange() {
    let server = fast();
    let c = connect(&server, 6666);
    let s = connect(&server, 6665);
    let sim = SimulationProxy::new(&s, 0).unwrap();
    let gripper = GripperProxy::new(&c, 0).unwrap();
    read_until(&c, "gripper data", || gripper.data().is_some());
    assert!(!gripper.is_closed());
    // An orange between the paddles: bob2 faces north, the gripper is ~0.85 m ahead.
    sim.set_pose2d("orange2", 5.0, -4.05, 0.0).unwrap();
    read_until(&c, "a break beam", || gripper.beams() != 0);
    gripper.close().unwrap();
    read_until(&c, "closed paddles", || {
        gripper.state() == PLAYER_GRIPPER_STATE_CLOSED
    });
}

#[test]
fn fiducial_finder_sees_the_other_robot() {
    let server = fast();
    let c = connect(&server, 6666);
    let s = connect(&server, 6665);
    let sim = SimulationProxy::new(&s, 0).unwrap();
    let fid = FiducialProxy::new(&c, 0).unwrap();
    // bob1 (fiducial_return 1) 3 m straight ahead of bob2, facing east. The oranges are
    // below the finder's beam (Stage's fiducial rays are cast at the finder's height).
    sim.set_pose2d("bob1", 5.0, -2.0, 0.0).unwrap();
    read_until(&c, "bob1's fiducial", || {
        fid.fiducials().iter().any(|f| f.id == 1)
    });
    let f = fid.fiducials().into_iter().find(|f| f.id == 1).unwrap();
    assert!(
        (f.pose.px - 3.0).abs() < 0.01 && f.pose.py.abs() < 0.01,
        "{f:?}"
    );
    assert!(
        (f.pose.pyaw + std::f64::consts::FRAC_PI_2).abs() < 1e-6,
        "{f:?}"
    );
}

#[test]
fn set_pose2d_then_get_pose2d_round_trips() {
    let server = fast();
    let c = connect(&server, 6665);
    let sim = SimulationProxy::new(&c, 0).unwrap();
    sim.set_pose2d("carton3", -2.5, 2.0, 0.75).unwrap();
    let p = sim.get_pose2d("carton3").unwrap();
    assert_eq!((p.px, p.py, p.pa), (-2.5, 2.0, 0.75));
    let (p3, _simtime) = sim.get_pose3d("carton3").unwrap();
    assert_eq!((p3.px, p3.py, p3.pyaw), (-2.5, 2.0, 0.75));
    assert!(
        sim.get_pose2d("no_such_model").is_err(),
        "unknown name NACKed"
    );
    sim.set_color("carton3", [1.0, 0.0, 0.0, 1.0]).unwrap();
    assert_eq!(sim.get_color("carton3").unwrap(), [1.0, 0.0, 0.0, 1.0]);
}

#[test]
fn a_missing_device_is_nacked() {
    let server = fast();
    let c = connect(&server, 6665);
    let err = Position2dProxy::new(&c, 5).unwrap_err();
    assert!(
        matches!(err, ClientError::Subscribe { index: 5, .. }),
        "{err:?}"
    );
    // bob1 has no gripper: that one is on bob2's port only.
    assert!(GripperProxy::new(&c, 0).is_err());
    // The session goes on.
    Position2dProxy::new(&c, 0).unwrap();
}

#[test]
fn two_clients_on_two_ports_drive_two_robots() {
    let server = fast();
    let c1 = connect(&server, 6665);
    let c2 = connect(&server, 6666);
    let p1 = Position2dProxy::new(&c1, 0).unwrap();
    let p2 = Position2dProxy::new(&c2, 0).unwrap();
    read_until(&c1, "bob1's pose", || p1.state().is_some());
    read_until(&c2, "bob2's pose", || p2.state().is_some());
    assert!(
        p1.pose().px < 0.0 && p2.pose().px > 0.0,
        "two different robots: {:?} {:?}",
        p1.pose(),
        p2.pose()
    );
    let start2 = p2.pose();
    p2.set_speed(0.0, 0.0, 0.8).unwrap();
    read_until(&c2, "bob2 turning", || {
        (p2.pose().pa - start2.pa).abs() > 0.2
    });
    // bob1 was not commanded: it stays where it is.
    // c1 was not read while bob2 turned: its queue may have overflowed meanwhile
    let start1 = p1.pose();
    read_once(&c1, "bob1's pose");
    read_once(&c1, "bob1's pose");
    assert!((p1.pose().px - start1.px).abs() < 1e-9);
}

#[test]
fn a_client_vanishing_mid_message_hurts_nobody() {
    let server = fast();
    let port = server.port(6665);
    let c = PlayerClient::connect("localhost", port).unwrap();
    let pos = Position2dProxy::new(&c, 0).unwrap();
    {
        let mut rude = TcpStream::connect(("127.0.0.1", port)).unwrap();
        // Half a header, then gone.
        rude.write_all(&[0, 0, 0, 0, 0, 0, 0x1a, 0x0a, 0, 4, 0])
            .unwrap();
    }
    std::thread::sleep(Duration::from_millis(100));
    read_until(&c, "data after the rude client left", || {
        pos.state().is_some()
    });
    let again = PlayerClient::connect("localhost", port).unwrap();
    RangerProxy::new(&again, 0).unwrap();
}

#[test]
fn legacy_laser_and_sonar_serve_the_rangers() {
    let (cfg, dir) = extra_cfg("legacy", "\"position2d:0\" \"sonar:0\" \"laser:0\"");
    let server = serve_cfg(&cfg, Pace::AsFastAsPossible);
    let c = connect(&server, 6665);
    let sonar = SonarProxy::new(&c, 0).unwrap();
    let laser = LaserProxy::new(&c, 0).unwrap();
    read_until(&c, "sonar and laser data", || {
        sonar.ranges().len() == 4 && laser.scan().is_some()
    });
    let scan = laser.scan().unwrap();
    assert_eq!(scan.ranges.len(), 180);
    assert!((scan.max_range - 0.25).abs() < 1e-6);
    assert_eq!(sonar.request_geom().unwrap().poses.len(), 4);
    let lg = laser.request_geom().unwrap();
    assert!((lg.pose.px - 0.625).abs() < 1e-6, "{lg:?}");
    drop(server);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A cfg for bob1 with extra devices, written next to nothing (the world path is absolute).
fn extra_cfg(tag: &str, devices: &str) -> (std::path::PathBuf, std::path::PathBuf) {
    let dir = std::env::temp_dir().join(format!("playerstage-e2e-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cfg = dir.join("extra.cfg");
    let world = common::root().join("worlds/bigbob.world");
    std::fs::write(
        &cfg,
        format!(
            "driver( name \"stage\" provides [\"simulation:0\"] worldfile \"{}\" )\n\
             driver( name \"stage\" provides [{devices}] model \"bob1\" )\n",
            world.display()
        ),
    )
    .unwrap();
    (cfg, dir)
}

#[test]
fn graphics_and_speech_from_a_client_reach_the_world_window() {
    use player_client::{Graphics2dProxy, SpeechProxy};
    use player_proto::{Color, Point2d};
    let (cfg, dir) = extra_cfg("graphics", "\"graphics2d:0\" \"speech:0\"");
    let server = serve_cfg(&cfg, Pace::AsFastAsPossible);
    let c = connect(&server, 6665);
    let g = Graphics2dProxy::new(&c, 0).unwrap();
    let speech = SpeechProxy::new(&c, 0).unwrap();
    let red = Color {
        alpha: 0,
        red: 255,
        green: 0,
        blue: 0,
    };
    g.draw_points(
        vec![Point2d { px: 0.5, py: 0.0 }, Point2d { px: 1.0, py: 0.0 }],
        red,
    )
    .unwrap();
    speech.say("orange ahead").unwrap();
    let drawings = server.stage.drawings();
    let world = server.stage.world().unwrap();
    let bob1 = world.read().unwrap().model_by_name("bob1").unwrap();
    // Commands are asynchronous: wait until the server has applied them.
    let start = Instant::now();
    while drawings.lock().unwrap().on_model(bob1).count() == 0
        || world.read().unwrap().said(bob1).unwrap() != "orange ahead"
    {
        assert!(
            start.elapsed() < Duration::from_secs(5),
            "commands not applied"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    // Unsubscribing takes this client's figures away.
    drop(g);
    let start = Instant::now();
    while !drawings.lock().unwrap().is_empty() {
        assert!(start.elapsed() < Duration::from_secs(5), "figures kept");
        std::thread::sleep(Duration::from_millis(5));
    }
    drop(server);
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn pausing_the_world_stops_simulated_time() {
    let server = fast();
    let paused = server.stage.paused();
    paused.store(true, std::sync::atomic::Ordering::SeqCst);
    let c = connect(&server, 6665);
    let sim = SimulationProxy::new(&c, 0).unwrap();
    let (_, t0) = sim.get_pose3d("bob1").unwrap();
    std::thread::sleep(Duration::from_millis(50));
    let (_, t1) = sim.get_pose3d("bob1").unwrap();
    assert_eq!(t0, t1, "no step while paused");
    paused.store(false, std::sync::atomic::Ordering::SeqCst);
    std::thread::sleep(Duration::from_millis(50));
    let (_, t2) = sim.get_pose3d("bob1").unwrap();
    assert!(t2 > t1);
    let world = server.stage.world().expect("the world is shared");
    assert!(world.read().unwrap().model_by_name("bob1").is_some());
    let _ = InterfaceCode::SIMULATION;
}
