//! The Rust client library (`player-client`) against the server with the test driver.

mod common;

use std::time::Duration;

use common::{bigbob, block, start};
use player_client::{
    BlobfinderProxy, ClientError, DataMode, GripperProxy, PlayerClient, Position2dProxy,
    RangerProxy, SimulationProxy,
};
use player_proto::constants::LOCALHOST_ADDR;
use player_proto::{InterfaceCode, MsgType, Pose2d, SimulationReq};
use player_server::Pace;

#[test]
fn connect_devices_and_read_rounds() {
    let (_server, p1, p2) = bigbob(true);
    let client = PlayerClient::connect("localhost", p1 as u16).unwrap();
    assert_eq!(client.banner(), "Player v.3.0.2");
    assert_eq!(client.datamode(), DataMode::Pull);
    let devices = client.device_list().unwrap();
    let listed: Vec<_> = devices
        .iter()
        .map(|d| (d.addr.interf, d.addr.index))
        .collect();
    assert_eq!(
        listed,
        [
            (InterfaceCode::SIMULATION, 0),
            (InterfaceCode::POSITION2D, 0),
            (InterfaceCode::RANGER, 0),
            (InterfaceCode::BLOBFINDER, 0),
            (InterfaceCode::RANGER, 1)
        ]
    );
    assert!(
        devices.iter().all(|d| d.driver_name == "stage"
            && d.addr.robot == p1
            && d.addr.host == LOCALHOST_ADDR)
    );

    let base = Position2dProxy::new(&client, 0).unwrap();
    let sonar = RangerProxy::new(&client, 0).unwrap();
    let blobs = BlobfinderProxy::new(&client, 0).unwrap();
    assert_eq!(base.driver_name(), "stage");
    let geom = base.request_geom().unwrap();
    assert_eq!((geom.size.sw, geom.size.sl), (0.4, 0.5));
    assert_eq!(sonar.request_geom().unwrap().element_poses.len(), 4);
    assert!(sonar.request_config().unwrap().max_range > 0.0);
    base.set_motor_enable(true).unwrap();

    // The first reads may only deliver data flushed ahead of the replies above (as libplayerc
    // does); within a few rounds every device has published.
    for _ in 0..20 {
        client.read().unwrap();
        if !sonar.ranges().is_empty() && !blobs.blobs().is_empty() && base.state().is_some() {
            break;
        }
    }
    assert_eq!(sonar.ranges().len(), 4);
    assert_eq!(sonar.intensities(), [0.5; 4]);
    assert_eq!(blobs.blobs().len(), 1);
    assert!(base.is_fresh());
    base.not_fresh();
    let t0 = base.datatime();
    base.set_speed(1.0, 0.0, 0.0).unwrap();
    for _ in 0..5 {
        client.read().unwrap();
    }
    assert!(base.datatime() > t0, "simulated time advances");
    assert!(base.pose().px > 0.0, "the base moved: {:?}", base.pose());
    assert_eq!(base.velocity().px, 1.0);
    assert!(base.is_fresh());
    base.reset_odometry().unwrap();
    base.set_odometry(1.0, 2.0, 0.5).unwrap();

    // A device of the other port, and an absent index: subscription errors.
    assert!(matches!(
        GripperProxy::new(&client, 0),
        Err(ClientError::Subscribe { .. })
    ));
    assert!(matches!(
        RangerProxy::new(&client, 5),
        Err(ClientError::Subscribe { .. })
    ));
    let other = PlayerClient::connect("127.0.0.1", p2 as u16).unwrap();
    let gripper = GripperProxy::new(&other, 0).unwrap();
    assert_eq!(gripper.request_geometry().unwrap().num_beams, 2);
    other.read().unwrap();
    assert_eq!(
        gripper.state(),
        player_proto::constants::PLAYER_GRIPPER_STATE_OPEN
    );
}

#[test]
fn simulation_proxy_poses_colours_and_errors() {
    let (_server, p1, _) = bigbob(true);
    let client = PlayerClient::connect("localhost", p1 as u16).unwrap();
    let sim = SimulationProxy::new(&client, 0).unwrap();
    let start = sim.get_pose2d("orange1").unwrap();
    assert_eq!((start.px, start.py), (2.0, -2.0));
    sim.set_pose2d("orange1", 1.5, 2.5, 0.3).unwrap();
    let moved = sim.get_pose2d("orange1").unwrap();
    assert_eq!(
        moved,
        Pose2d {
            px: 1.5,
            py: 2.5,
            pa: 0.3
        }
    );
    let (pose, simtime) = sim.get_pose3d("orange1").unwrap();
    assert_eq!((pose.px, pose.pyaw), (1.5, 0.3));
    assert!(simtime >= 0.0);
    assert!(matches!(
        sim.get_pose2d("nobody"),
        Err(ClientError::Nack { .. })
    ));
    // The test driver has no properties: NACK.
    assert!(matches!(
        sim.get_color("bob1"),
        Err(ClientError::Nack { .. })
    ));
    assert!(
        sim.has_capability(MsgType::Req, SimulationReq::GET_POSE2D)
            .unwrap()
    );
    assert!(
        !sim.has_capability(MsgType::Req, SimulationReq::SET_PROPERTY)
            .unwrap()
    );
    assert!(matches!(
        sim.get_int_prop("anything"),
        Err(ClientError::Nack { .. })
    ));
}

#[test]
fn push_mode_reads_one_message_at_a_time() {
    let b = block(
        "test",
        0,
        &[(InterfaceCode::RANGER, 0)],
        &[("step_ms", "20")],
    );
    let server = start(&[b], Pace::RealTime { speedup: 1.0 }, Vec::new());
    let client = PlayerClient::connect("localhost", server.ports()[0]).unwrap();
    client.set_datamode(DataMode::Push).unwrap();
    let ranger = RangerProxy::new(&client, 0).unwrap();
    for _ in 0..6 {
        client.read().unwrap();
    }
    assert_eq!(ranger.ranges().len(), 4);
}

#[test]
fn request_timeout_on_a_device_that_is_not_there() {
    let b = block("test", 0, &[(InterfaceCode::POSITION2D, 0)], &[]);
    let server = start(&[b], Pace::RealTime { speedup: 1.0 }, Vec::new());
    let client = PlayerClient::connect("localhost", server.ports()[0]).unwrap();
    client.set_request_timeout(Duration::from_millis(300));
    let r = client.request(
        InterfaceCode::POSITION2D,
        7,
        player_proto::Position2dReq::GetGeom(None),
    );
    assert!(matches!(r, Err(ClientError::Timeout { .. })), "{r:?}");
    // The connection is still usable.
    let base = Position2dProxy::new(&client, 0).unwrap();
    assert!(base.request_geom().is_ok());
}

#[test]
fn replace_rule_and_overflow_through_the_client() {
    let b = block(
        "test",
        0,
        &[(InterfaceCode::RANGER, 0)],
        &[("step_ms", "1")],
    );
    let server = start(&[b], Pace::AsFastAsPossible, Vec::new());
    let client = PlayerClient::connect("localhost", server.ports()[0]).unwrap();
    let ranger = RangerProxy::new(&client, 0).unwrap();
    std::thread::sleep(Duration::from_millis(800));
    match client.read() {
        Err(ClientError::Overflow { dropped }) => assert!(dropped > 0),
        other => panic!("expected an overflow, got {other:?}"),
    }
    assert_eq!(ranger.ranges().len(), 4, "the data still arrived");
    client.set_replace_rule(true, 1, -1, -1).unwrap();
    // Drain what was queued (and dropped) before the rule took effect: the data flushed ahead
    // of the rule's ACK, then a round whose SYNCH may still report drops from before.
    for _ in 0..3 {
        match client.read() {
            Ok(()) | Err(ClientError::Overflow { .. }) => {}
            Err(e) => panic!("{e}"),
        }
    }
    // From now on at most one DATA per subtype waits: no more overflow.
    for _ in 0..3 {
        std::thread::sleep(Duration::from_millis(200));
        client.read().unwrap();
    }
}

#[test]
fn connection_refused_is_a_clear_error() {
    let (port, listener) = common::free_listener();
    drop(listener);
    let err = PlayerClient::connect("127.0.0.1", port as u16).unwrap_err();
    assert!(
        err.to_string().starts_with("connect call on [127.0.0.1:"),
        "{err}"
    );
}
