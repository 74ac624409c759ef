//! `mbicp` end to end: a Stage room with a few boxes, a robot whose odometry is biased
//! (`odom_error`), its laser stamped with odometric poses by `laserposeinterpolator` (as in
//! Stage 4.1.1's mbicp.cfg), and `mbicp` on top. The robot drives a few metres along an
//! arc; the pose mbicp publishes must stay much closer to the true pose (the simulation's
//! ground truth, in the odometry's frame) than the raw odometry does. Requests and commands
//! to mbicp's device reach the base.

mod common;

use std::time::{Duration, Instant};

use player_client::{PlayerClient, Position2dProxy, SimulationProxy};
use player_proto::Pose2d;
use player_server::Pace;

const WORLD: &str = r#"
interval_sim 100
resolution 0.02
define wall model ( color "gray30" )
wall ( name "north" size [8.2 0.2 1] pose [0 3 0 0] )
wall ( name "south" size [8.2 0.2 1] pose [0 -3 0 0] )
wall ( name "east" size [0.2 6 1] pose [4 0 0 0] )
wall ( name "west" size [0.2 6 1] pose [-4 0 0 0] )
wall ( name "box1" size [0.6 0.6 1] pose [2.5 1.5 0 0] )
wall ( name "box2" size [1.0 0.4 1] pose [-1 2 0 30] )
wall ( name "box3" size [0.5 0.8 1] pose [2.9 -2 0 0] )
position
(
  name "r0"
  size [0.44 0.38 0.25]
  pose [-2.5 -1.5 0 0]
  drive "diff"
  localization "odom"
  # the heading factor is read as an angle (degrees): 5.73 is a 10% bias
  odom_error [0.08 0.08 0 5.73]
  ranger ( sensor ( pose [0.15 0 0 0] size [0.1 0.1 0.1] range [0 8] fov 180 samples 361 ) )
)
"#;

const CFG: &str = r#"
driver ( name "stage" provides ["0:simulation:0"] worldfile "mbicp.world" )
driver ( name "stage" provides ["0:position2d:0" "0:laser:0"] model "r0" )
driver
(
  name "laserposeinterpolator"
  provides ["0:laser:1"]
  requires ["0:laser:0" "0:position2d:0"]
)
driver
(
  name "mbicp"
  provides ["0:position2d:1"]
  requires ["0:position2d:0" "0:laser:1"]
  laserPose_x 0.15
)
"#;

/// `b` seen from `a`.
fn relative(a: Pose2d, b: Pose2d) -> Pose2d {
    let (s, c) = a.pa.sin_cos();
    let (dx, dy) = (b.px - a.px, b.py - a.py);
    let da = b.pa - a.pa;
    Pose2d {
        px: c * dx + s * dy,
        py: -s * dx + c * dy,
        pa: da.sin().atan2(da.cos()),
    }
}

fn error(a: Pose2d, b: Pose2d) -> (f64, f64) {
    let da = a.pa - b.pa;
    (
        (a.px - b.px).hypot(a.py - b.py),
        da.sin().atan2(da.cos()).abs(),
    )
}

#[test]
fn mbicp_stays_closer_to_the_truth_than_biased_odometry() {
    let dir = std::env::temp_dir().join(format!("mbicp-e2e-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("mbicp.world"), WORLD).unwrap();
    let handle = common::serve_cfg(&dir, "mbicp.cfg", CFG, Pace::RealTime { speedup: 5.0 });
    let port = handle.ports()[0];
    let client = PlayerClient::connect("localhost", port).unwrap();
    let corrected = Position2dProxy::new(&client, 1).unwrap();
    let base = Position2dProxy::new(&client, 0).unwrap();
    let sim = SimulationProxy::new(&client, 0).unwrap();

    // Requests to mbicp's device are answered by the base.
    assert_eq!(
        corrected.request_geom().unwrap(),
        base.request_geom().unwrap()
    );
    let deadline = Instant::now() + Duration::from_secs(10);
    while corrected.state().is_none() || base.state().is_none() {
        assert!(Instant::now() < deadline, "mbicp published no pose");
        client.read().unwrap();
    }
    let start = sim.get_pose2d("r0").unwrap();

    // A velocity command to mbicp drives the base along an arc.
    corrected.set_speed(0.3, 0.0, 0.08).unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut worst_mbicp: f64 = 0.0;
    let (odo, fixed, truth) = loop {
        assert!(Instant::now() < deadline, "the robot did not drive 3.5 m");
        client.read().unwrap();
        let truth = relative(start, sim.get_pose2d("r0").unwrap());
        let (odo, fixed) = (base.pose(), corrected.pose());
        assert!(!base.stall(), "the robot hit something at {truth:?}");
        worst_mbicp = worst_mbicp.max(error(fixed, truth).0);
        if truth.px.hypot(truth.py) > 3.5 {
            break (odo, fixed, truth);
        }
    };
    corrected.set_speed(0.0, 0.0, 0.0).unwrap();
    let (odo_d, odo_a) = error(odo, truth);
    let (fix_d, fix_a) = error(fixed, truth);
    eprintln!(
        "truth {truth:?}\nodometry {odo:?} off {odo_d:.3} m {odo_a:.4} rad\n\
         mbicp {fixed:?} off {fix_d:.3} m {fix_a:.4} rad (worst {worst_mbicp:.3} m)"
    );
    // The bias makes odometry drift by decimetres; matching keeps within a few centimetres.
    assert!(odo_d > 0.2, "odometry barely drifted: {odo_d}");
    assert!(fix_d < odo_d / 3.0, "mbicp {fix_d} m vs odometry {odo_d} m");
    assert!(
        fix_a < odo_a / 3.0,
        "mbicp {fix_a} rad vs odometry {odo_a} rad"
    );
    assert!(fix_d < 0.1 && worst_mbicp < 0.15, "{fix_d} {worst_mbicp}");
    drop((corrected, base, sim));
    drop(client);
    handle.shutdown();
}

#[test]
fn mbicp_refuses_a_cfg_without_a_laser() {
    let dir = std::env::temp_dir().join(format!("mbicp-refused-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("mbicp.world"), WORLD).unwrap();
    let no_laser = CFG.replace(r#"["0:position2d:0" "0:laser:1"]"#, r#"["0:position2d:0"]"#);
    let err = common::build_cfg(&dir, "mbicp.cfg", &no_laser, Pace::AsFastAsPossible)
        .err()
        .unwrap();
    assert!(err.contains("laser"), "{err}");
}
