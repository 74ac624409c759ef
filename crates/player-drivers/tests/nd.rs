//! `nd` and `snd` end to end: a Stage room with a wall segment between the robot and its
//! goal, the robot's laser served as `laser:0` on its ranger, the navigation driver on top of
//! the robot's position2d. A client sends a goal behind the obstacle to `position2d:1` and
//! watches it: the robot must get there (within the goal tolerance) round the obstacle,
//! without touching anything and without the driver giving up; a velocity command then passes
//! through to the base.

mod common;

use std::time::{Duration, Instant};

use player_client::{PlayerClient, Position2dProxy, SimulationProxy};
use player_server::Pace;

const WORLD: &str = r#"
interval_sim 100
resolution 0.02
define wall model ( color "gray30" )
define sonar sensor ( range [0 5] fov 15 samples 1 )
wall ( name "north" size [8.2 0.2 1] pose [0 3 0 0] )
wall ( name "south" size [8.2 0.2 1] pose [0 -3 0 0] )
wall ( name "east" size [0.2 6 1] pose [4 0 0 0] )
wall ( name "west" size [0.2 6 1] pose [-4 0 0 0] )
wall ( name "block" size [0.4 2.0 1] pose [0 0.3 0 0] )
position
(
  name "r0"
  size [0.44 0.38 0.25]
  pose [-2.5 0 0 0]
  drive "diff"
  ranger ( sensor ( pose [0.15 0 0 0] size [0.1 0.1 0.1] range [0 8] fov 180 samples 181 ) )
  ranger
  (
    sonar ( pose [0.2 0 0 0] ) sonar ( pose [0.15 0.15 0 45] ) sonar ( pose [0 0.19 0 90] )
    sonar ( pose [-0.15 0.15 0 135] ) sonar ( pose [-0.2 0 0 180] )
    sonar ( pose [-0.15 -0.15 0 -135] ) sonar ( pose [0 -0.19 0 -90] )
    sonar ( pose [0.15 -0.15 0 -45] )
  )
)
"#;

const CFG: &str = r#"
driver ( name "stage" provides ["0:simulation:0"] worldfile "nd.world" )
driver ( name "stage" provides ["0:position2d:0" "0:laser:0"] model "r0" )
driver
(
  name "nd"
  provides ["0:position2d:1"]
  requires ["output::0:position2d:0" "input::0:position2d:0" "0:laser:0"]
  goal_tol [0.3 15]
  max_speed [0.4 60]
  avoid_dist 0.4
  laser_buffer 1
)
"#;

const SND_CFG: &str = r#"
driver ( name "stage" provides ["0:simulation:0"] worldfile "nd.world" )
driver ( name "stage" provides ["0:position2d:0" "0:laser:0"] model "r0" )
driver
(
  name "snd"
  provides ["0:position2d:1"]
  requires ["input::0:position2d:0" "output::0:position2d:0" "0:laser:0"]
  robot_radius 0.3
  goal_tol [0.3 0.26]  # radians: snd reads this angle as a length
)
"#;

/// Stage's own nd.cfg shape: laser and sonar, the sonar's rear transducers ignored.
const ND_SONAR_CFG: &str = r#"
driver ( name "stage" provides ["0:simulation:0"] worldfile "nd.world" )
driver ( name "stage" provides ["0:position2d:0" "0:laser:0" "0:sonar:0"] model "r0" )
driver
(
  name "nd"
  provides ["0:position2d:1"]
  requires ["output::0:position2d:0" "input::0:position2d:0" "0:laser:0" "0:sonar:0"]
  sonar_bad_transducers [3 4 5]
  goal_tol [0.3 15]
  max_speed [0.4 60]
  avoid_dist 0.4
  laser_buffer 1
  sonar_buffer 1
)
"#;

fn folder(tag: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("nd-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("nd.world"), WORLD).unwrap();
    dir
}

#[test]
fn nd_drives_round_the_obstacle_to_the_goal() {
    drive_round_the_block("goto", CFG);
}

#[test]
fn nd_with_laser_and_sonar_drives_round_the_obstacle_to_the_goal() {
    drive_round_the_block("sonar", ND_SONAR_CFG);
}

#[test]
fn snd_drives_round_the_obstacle_to_the_goal() {
    drive_round_the_block("snd", SND_CFG);
}

/// Both drivers' goal tolerances are 0.3 m and 15° in these cfgs.
fn drive_round_the_block(tag: &str, cfg: &str) {
    let dir = folder(tag);
    let handle = common::serve_cfg(&dir, "nd.cfg", cfg, Pace::RealTime { speedup: 10.0 });
    let port = handle.ports()[0];
    let client = PlayerClient::connect("localhost", port).unwrap();
    let nav = Position2dProxy::new(&client, 1).unwrap();
    let base = Position2dProxy::new(&client, 0).unwrap();
    let sim = SimulationProxy::new(&client, 0).unwrap();

    // Requests to nd's device are answered by the base.
    assert_eq!(nav.request_geom().unwrap(), base.request_geom().unwrap());

    // Wait for odometry through nd, then aim 5 m ahead: (2.5, 0) in the world, behind the
    // block that spans y -0.7..1.3 at x = 0.
    let deadline = Instant::now() + Duration::from_secs(10);
    while nav.state().is_none() {
        assert!(Instant::now() < deadline, "nd published no odometry");
        client.read().unwrap();
    }
    let start = nav.pose();
    let goal = (start.px + 5.0, start.py, start.pa);
    let world_goal = (2.5, 0.0);
    nav.go_to(goal.0, goal.1, goal.2).unwrap();

    let deadline = Instant::now() + Duration::from_secs(90);
    let mut passed_block = false;
    let mut widest: f64 = 0.0;
    loop {
        assert!(
            Instant::now() < deadline,
            "the robot did not arrive: at {:?}, goal {goal:?}",
            nav.pose()
        );
        client.read().unwrap();
        let here = nav.pose();
        assert!(!nav.stall(), "nd gave up at {here:?}");
        assert!(!base.stall(), "the robot hit something at {here:?}");
        let truth = sim.get_pose2d("r0").unwrap();
        widest = widest.max(truth.py.abs());
        if truth.px > 0.3 {
            passed_block = true;
        }
        let dist = (here.px - goal.0).hypot(here.py - goal.1);
        let speed = base.velocity();
        if dist < 0.3 && speed.px == 0.0 && speed.pa == 0.0 && passed_block {
            let world = (truth.px - world_goal.0).hypot(truth.py - world_goal.1);
            assert!(world < 0.35, "stopped at {truth:?}, not at the goal");
            let heading = (here.pa - goal.2).sin().atan2((here.pa - goal.2).cos());
            assert!(
                heading.abs() < 15f64.to_radians(),
                "heading off by {heading}"
            );
            break;
        }
    }
    // A velocity command to nd passes through to the base.
    nav.set_speed(0.1, 0.0, 0.2).unwrap();
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        assert!(
            Instant::now() < deadline,
            "the velocity command did not reach the base"
        );
        client.read().unwrap();
        let v = base.velocity();
        if (v.px - 0.1).abs() < 1e-6 && (v.pa - 0.2).abs() < 1e-6 {
            break;
        }
    }
    drop((nav, base, sim));
    drop(client);
    handle.shutdown();
}

#[test]
fn nd_refuses_a_cfg_without_its_keyed_position_devices_or_a_range_sensor() {
    let dir = folder("refused");
    let no_keys = CFG.replace(
        r#"["output::0:position2d:0" "input::0:position2d:0" "0:laser:0"]"#,
        r#"["0:position2d:0" "0:laser:0"]"#,
    );
    let err = common::build_cfg(&dir, "nd.cfg", &no_keys, Pace::AsFastAsPossible).unwrap_err();
    assert!(err.contains("output"), "{err}");
    let no_sensor = CFG.replace(r#" "0:laser:0"]"#, "]");
    let err = common::build_cfg(&dir, "nd.cfg", &no_sensor, Pace::AsFastAsPossible).unwrap_err();
    assert!(err.contains("sonar or one laser"), "{err}");
}

#[test]
fn stages_nd_cfg_drives_r0_round_a_block_of_the_cave() {
    let Some(src) = common::stage_worlds() else {
        eprintln!("skipping: Stage's worlds are not in ../shared/stage-worlds");
        return;
    };
    let dir = std::env::temp_dir().join(format!("nd-stage-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    common::simple_world_for_vfh(&src, &dir);
    // Stage's nd.cfg as written (laser and sonar, wait_on_stall 1, its stuck times), its
    // devices moved to OS-chosen ports.
    let cfg = std::fs::read_to_string(src.join("nd.cfg"))
        .unwrap()
        .replace("\"simulation:", "\"0:simulation:")
        .replace("\"position2d:", "\"0:position2d:")
        .replace(":::position2d:", "::0:position2d:")
        .replace("\"laser:", "\"0:laser:")
        .replace("\"sonar:", "\"0:sonar:");
    let handle = common::serve_cfg(&dir, "nd.cfg", &cfg, Pace::RealTime { speedup: 20.0 });
    let client = PlayerClient::connect("localhost", handle.ports()[0]).unwrap();
    let nav = Position2dProxy::new(&client, 1).unwrap();
    let base = Position2dProxy::new(&client, 0).unwrap();
    let wall = Instant::now();
    while nav.state().is_none() {
        assert!(wall.elapsed() < Duration::from_secs(10), "no odometry");
        client.read().unwrap();
    }
    // r0 starts at (-6.95, -6.95) facing 45°; the straight line to (-3, 0) runs into the
    // block at x -5.6..-3.9, y -3.4..-0.7.
    let goal = (-3.0, 0.0, 90f64.to_radians());
    nav.go_to(goal.0, goal.1, goal.2).unwrap();
    loop {
        client.read().unwrap();
        let here = nav.pose();
        assert!(!nav.stall(), "nd gave up at {here:?}");
        assert!(!base.stall(), "r0 hit something at {here:?}");
        assert!(
            !((-5.6..-3.9).contains(&here.px) && (-3.4..-0.7).contains(&here.py)),
            "drove through the block"
        );
        let off = (here.px - goal.0).hypot(here.py - goal.1);
        let v = base.velocity();
        if off < 0.3 && v.px == 0.0 && v.pa == 0.0 {
            let heading = (here.pa - goal.2).sin().atan2((here.pa - goal.2).cos());
            assert!(
                heading.abs() < 15f64.to_radians(),
                "heading off by {heading}"
            );
            break;
        }
        assert!(
            wall.elapsed() < Duration::from_secs(60),
            "no arrival; at {here:?}, {off:.2} m from the goal"
        );
    }
    drop((nav, base));
    drop(client);
    handle.shutdown();
    let _ = std::fs::remove_dir_all(&dir);
}
