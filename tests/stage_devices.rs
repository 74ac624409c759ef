//! End-to-end through the Rust client, on the findings of Player's own client programs
//! (playerprint, libplayerc's and libplayerc++'s device tests): the odometry's start under
//! `localization "odom"`, the actuator's limits, and the laser interface on a Stage ranger
//! configured like a SICK LMS200.

mod common;

use std::time::{Duration, Instant};

use common::{pioneer_odom_cfg, serve_cfg};
use player_client::{ActArrayProxy, ClientError, LaserProxy, PlayerClient, Position2dProxy};
use player_proto::LaserConfig;
use player_proto::constants::PLAYER_ACTARRAY_ACTSTATE_MOVING;
use player_server::Pace;

/// Reads data rounds until `done` holds; fails after 10 s of wall time (the world runs as
/// fast as it computes, so a round may find the queue overflowed or empty: both are fine).
fn read_until(client: &PlayerClient, what: &str, mut done: impl FnMut() -> bool) {
    let start = Instant::now();
    loop {
        match client.read() {
            Ok(()) | Err(ClientError::Overflow { .. } | ClientError::NoData) => {}
            Err(e) => panic!("reading while waiting for {what}: {e}"),
        }
        if done() {
            return;
        }
        assert!(
            start.elapsed() < Duration::from_secs(10),
            "timed out waiting for {what}"
        );
    }
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-6
}

#[test]
fn odometry_starts_at_the_start_pose_in_the_localization_origin_frame() {
    let (cfg, dir) = pioneer_odom_cfg("odom-start");
    let server = serve_cfg(&cfg, Pace::AsFastAsPossible);
    let c = PlayerClient::connect("localhost", server.port(6665)).unwrap();
    let r0 = Position2dProxy::new(&c, 0).unwrap();
    let r1 = Position2dProxy::new(&c, 1).unwrap();
    read_until(&c, "both robots' odometry", || {
        r0.state().is_some() && r1.state().is_some()
    });
    // What the original prints for simple.world's robot on odometry: -6.946 -6.947 0.785398
    let p = r0.pose();
    assert!(
        close(p.px, -6.946) && close(p.py, -6.947) && close(p.pa, 45f64.to_radians()),
        "{p:?}"
    );
    // Without localization_origin the origin is the start pose.
    let q = r1.pose();
    assert!(
        close(q.px, 0.0) && close(q.py, 0.0) && close(q.pa, 0.0),
        "{q:?}"
    );

    // In odom mode SET_ODOM and RESET_ODOM last (the robot stands still).
    r0.set_odometry(1.0, 2.0, 0.5).unwrap();
    read_until(&c, "the odometry set", || {
        let p = r0.pose();
        close(p.px, 1.0) && close(p.py, 2.0) && close(p.pa, 0.5)
    });
    for _ in 0..5 {
        let _ = c.read();
    }
    let p = r0.pose();
    assert!(
        close(p.px, 1.0) && close(p.py, 2.0) && close(p.pa, 0.5),
        "{p:?}"
    );
    r0.reset_odometry().unwrap();
    read_until(&c, "the odometry reset", || {
        let p = r0.pose();
        close(p.px, 0.0) && close(p.py, 0.0) && close(p.pa, 0.0)
    });
    drop(server);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_actuator_reports_a_goal_beyond_its_limit_clamped() {
    let (cfg, dir) = pioneer_odom_cfg("act-limits");
    let server = serve_cfg(&cfg, Pace::AsFastAsPossible);
    let c = PlayerClient::connect("localhost", server.port(6665)).unwrap();
    let lift = ActArrayProxy::new(&c, 0).unwrap();
    let geom = lift.request_geometry().unwrap();
    assert_eq!((geom.actuators[0].min, geom.actuators[0].max), (0.0, 0.5));
    let speed = || lift.data().map_or(0.0, |d| d.actuators[0].speed);
    lift.move_to(0, 1.0).unwrap();
    read_until(&c, "the lift's goal", || speed() != 0.0);
    let joint = lift.data().unwrap().actuators[0].clone();
    assert_eq!(joint.speed, 0.5, "MoveTo(0, 1.0) with max_position 0.5");
    assert_eq!(joint.state, PLAYER_ACTARRAY_ACTSTATE_MOVING);
    // Stage 4.1.1's joints do not move; the position stays at the start.
    assert_eq!(joint.position, 0.0);
    // max_speed (0.2) bounds the motion Stage computes; the speed goal is reported as sent.
    lift.move_at_speed(0, 3.0).unwrap();
    read_until(&c, "the speed goal", || speed() == 3.0);
    assert_eq!(lift.data().unwrap().actuators[0].acceleration, 0.0);
    drop(server);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_laser_on_a_sick_ranger_configures_like_an_lms200() {
    let (cfg, dir) = pioneer_odom_cfg("laser-config");
    let server = serve_cfg(&cfg, Pace::AsFastAsPossible);
    let c = PlayerClient::connect("localhost", server.port(6665)).unwrap();
    let laser = LaserProxy::new(&c, 0).unwrap();
    let geom = laser.request_geom().unwrap();
    assert_eq!(
        (geom.size.sl, geom.size.sw),
        (0.156, 0.155),
        "the ranger's size"
    );
    read_until(&c, "a first scan", || laser.scan().is_some());
    assert_eq!(laser.ranges().len(), 180);

    // libplayerc++'s laser test: ±90°, "100" and "1" (Player 2's hundredths of a degree and
    // millimetres): refused, as the LMS200 driver refuses it (Player 3 reads radians, metres).
    let as_cpp_test = common::player_2_units_laser_request();
    let default = laser.request_config().unwrap();
    let err = laser.configure(as_cpp_test.clone()).unwrap_err();
    assert!(matches!(err, ClientError::Nack { .. }), "{err:?}");
    assert_eq!(laser.request_config().unwrap(), default);
    // The same in Player 3's units: 1°, ranges in centimetres.
    laser
        .configure(LaserConfig {
            resolution: 1f32.to_radians(),
            range_res: 0.01,
            ..as_cpp_test
        })
        .unwrap();
    let got = laser.request_config().unwrap();
    assert_eq!(f64::from(got.min_angle).to_degrees().round(), -90.0);
    assert_eq!(f64::from(got.max_angle).to_degrees().round(), 90.0);
    assert_eq!((got.range_res, got.intensity), (0.01, 1));
    // 1° served by every ray of the 180: they are 180/179° apart
    let spacing = 180f64.to_radians() / 179.0;
    assert!(
        (f64::from(got.resolution) - spacing).abs() < 1e-6,
        "{got:?}"
    );

    // Every second ray of ±45°, in 10 cm units, no intensities.
    let narrow = LaserConfig {
        min_angle: (-45f32).to_radians(),
        max_angle: 45f32.to_radians(),
        resolution: (2.0 * spacing) as f32,
        max_range: 0.0,
        range_res: 0.1,
        intensity: 0,
        scanning_frequency: 10.0,
    };
    let applied = laser.configure(narrow.clone()).unwrap();
    assert_eq!(applied, laser.request_config().unwrap());
    // -45° is ray 44.75 → 45; 45° is ray 134.25 → 134; every second from 45: 45..=133
    let first = -90f64.to_radians() + 45.0 * spacing;
    assert!(
        (f64::from(applied.min_angle) - first).abs() < 1e-6,
        "{applied:?}"
    );
    read_until(&c, "a narrowed scan", || {
        laser.scan().is_some_and(|s| s.ranges.len() != 180)
    });
    let scan = laser.scan().unwrap();
    assert_eq!(scan.ranges.len(), 45);
    assert_eq!(
        (scan.min_angle, scan.resolution),
        (applied.min_angle, applied.resolution)
    );
    assert!(scan.intensity.iter().all(|&i| i == 0));
    assert!(
        scan.ranges
            .iter()
            .all(|&r| ((r / 0.1).round() - r / 0.1).abs() < 1e-3),
        "{:?}",
        scan.ranges
    );

    // What the ranger cannot do is refused, and the configuration stays.
    for bad in [
        LaserConfig {
            resolution: 0.25f32.to_radians(),
            ..narrow.clone()
        },
        LaserConfig {
            min_angle: (-100f32).to_radians(),
            ..narrow.clone()
        },
        LaserConfig {
            range_res: 0.0,
            ..narrow.clone()
        },
    ] {
        let err = laser.configure(bad).unwrap_err();
        assert!(matches!(err, ClientError::Nack { .. }), "{err:?}");
    }
    assert_eq!(laser.request_config().unwrap(), applied);
    drop(server);
    let _ = std::fs::remove_dir_all(&dir);
}
