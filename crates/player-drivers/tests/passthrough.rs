//! `passthrough` over TCP: a stage robot's devices relayed under other addresses of the same
//! server, and (with the remote devices) from a second server.

mod common;

use std::time::{Duration, Instant};

use player_client::{PlayerClient, Position2dProxy, RangerProxy};
use player_server::Pace;

const LOCAL: &str = r#"
driver( name "stage" provides ["0:simulation:0"] plugin "stageplugin" worldfile "bigbob.world" )
driver( name "passthrough" provides ["0:position2d:7" "0:ranger:7"] requires ["0:position2d:0" "0:ranger:0"] )
driver( name "stage" provides ["0:position2d:0" "0:ranger:0"] model "bob1" )
"#;

/// Reads until `done` holds.
fn read_until(client: &PlayerClient, what: &str, mut done: impl FnMut() -> bool) {
    let deadline = Instant::now() + Duration::from_secs(10);
    while !done() {
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        client.read().unwrap();
    }
}

#[test]
fn a_local_device_relayed_under_another_address() {
    let handle = common::serve_cfg(
        &common::worlds(),
        "pt-test.cfg",
        LOCAL,
        Pace::RealTime { speedup: 4.0 },
    );
    let port = handle.ports()[0];
    let client = PlayerClient::connect("localhost", port).unwrap();
    let relayed = Position2dProxy::new(&client, 7).unwrap();
    let sonar = RangerProxy::new(&client, 7).unwrap();
    let direct = Position2dProxy::new(&client, 0).unwrap();
    // Requests are answered by the stage device behind the relay.
    assert_eq!(
        relayed.request_geom().unwrap(),
        direct.request_geom().unwrap()
    );
    assert_eq!(
        sonar.request_geom().unwrap().element_poses.len(),
        RangerProxy::new(&client, 0)
            .unwrap()
            .request_geom()
            .unwrap()
            .element_poses
            .len()
    );
    // A command through the relay moves the robot; its odometry comes back through it.
    read_until(&client, "a first pose", || relayed.is_fresh());
    let start = relayed.pose();
    relayed.set_speed(0.5, 0.0, 0.0).unwrap();
    read_until(&client, "the robot to move", || {
        let p = relayed.pose();
        (p.px - start.px).hypot(p.py - start.py) > 0.1
    });
    read_until(&client, "sonar ranges", || !sonar.ranges().is_empty());
    let (a, b) = (relayed.pose(), direct.pose());
    assert!((a.px - b.px).abs() < 0.2, "relayed {a:?} vs direct {b:?}");
    relayed.set_speed(0.0, 0.0, 0.0).unwrap();
    drop((relayed, sonar, direct));
    drop(client);
    handle.shutdown();
}

#[test]
fn a_device_of_another_server_relayed_over_tcp() {
    // Server A: the robot. Server B: a passthrough to A's position2d and sonar, and a local
    // chain on top of the remote sonar (rangers of another server are devices like any other).
    let a = common::serve_cfg(
        &common::worlds(),
        "a.cfg",
        r#"
driver( name "stage" provides ["0:simulation:0"] plugin "stageplugin" worldfile "bigbob.world" )
driver( name "stage" provides ["0:position2d:0" "0:ranger:0"] model "bob1" )
"#,
        Pace::RealTime { speedup: 4.0 },
    );
    let pa = a.ports()[0];
    let b_cfg = format!(
        r#"
driver( name "passthrough" provides ["0:position2d:0" "0:ranger:0"] requires ["localhost:{pa}:position2d:0" "127.0.0.1:{pa}:ranger:0"] )
"#
    );
    let b = common::serve_cfg(&common::worlds(), "b.cfg", &b_cfg, Pace::default());
    let pb = b.ports()[0];
    assert_ne!(pa, pb);
    let remote_devices = b
        .table()
        .devices()
        .iter()
        .filter(|d| d.driver_name == "remote")
        .count();
    assert_eq!(remote_devices, 2);

    let client = PlayerClient::connect("localhost", pb).unwrap();
    let base = Position2dProxy::new(&client, 0).unwrap();
    let sonar = RangerProxy::new(&client, 0).unwrap();
    // Requests cross both servers.
    let direct_client = PlayerClient::connect("localhost", pa).unwrap();
    let direct = Position2dProxy::new(&direct_client, 0).unwrap();
    assert_eq!(base.request_geom().unwrap(), direct.request_geom().unwrap());
    read_until(&client, "remote sonar ranges", || {
        !sonar.ranges().is_empty()
    });
    read_until(&client, "a first remote pose", || base.is_fresh());
    let start = base.pose();
    base.set_speed(0.5, 0.0, 0.0).unwrap();
    read_until(&client, "the remote robot to move", || {
        let p = base.pose();
        (p.px - start.px).hypot(p.py - start.py) > 0.1
    });
    base.set_speed(0.0, 0.0, 0.0).unwrap();
    drop((base, sonar, direct));
    drop((client, direct_client));
    b.shutdown();
    a.shutdown();
}
