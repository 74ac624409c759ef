//! End-to-end: `wavefront` plans over a `mapfile` map of a Stage room and drives the Stage
//! robot (exact "gps" odometry) around an obstacle to a goal behind it, waypoint by waypoint
//! through position commands; a `PlannerProxy` client sets the goal and watches the state.
//! The robot's `localization_origin` is the world's origin, so its odometry is its map pose
//! (Stage's default origin is the robot's starting pose).

mod common;

use std::path::PathBuf;
use std::time::{Duration, Instant};

use image::{GrayImage, Luma};
use player_client::{PlannerProxy, PlayerClient, Position2dProxy};
use player_server::Pace;

/// The room, 10 m x 10 m at 0.1 m per pixel, centred on the origin: walls all round and a
/// wall from the bottom up to y = 2 m between x = -0.3 and 0.3 m.
fn room_png(path: &std::path::Path) {
    let (w, h) = (100u32, 100u32);
    GrayImage::from_fn(w, h, |x, y| {
        // Image row 0 is the top of the room (y = +5 m).
        let (mx, my) = (x as f64 * 0.1 - 5.0 + 0.05, 5.0 - y as f64 * 0.1 - 0.05);
        let border = x < 2 || y < 2 || x >= w - 2 || y >= h - 2;
        let obstacle = mx.abs() < 0.3 && my < 2.0;
        Luma([if border || obstacle { 0 } else { 255 }])
    })
    .save(path)
    .unwrap();
}

const WORLD: &str = r#"
resolution 0.02
interval_sim 100
model( name "room" size [10 10 1] pose [0 0 0 0] bitmap "room.png" )
position( name "robot" size [0.4 0.4 0.3] pose [-3 -3 0 0] localization "gps"
          localization_origin [0 0 0 0] drive "diff" )
"#;

/// Without vfh in between, the robot drives straight at each waypoint and switches to the
/// next within `distance_epsilon` of it, so a small epsilon and a wider margin keep it from
/// clipping the wall's corner (upstream's nav-test.cfg pairs wavefront with vfh instead).
const CFG: &str = r#"
driver( name "stage" provides ["0:simulation:0"] worldfile "wave.world" )
driver( name "stage" provides ["0:position2d:0"] model "robot" )
driver( name "mapfile" provides ["0:map:0"] filename "room.png" resolution 0.1 )
driver( name "wavefront" provides ["0:planner:0"]
        requires ["output::0:position2d:0" "input::0:position2d:0" "0:map:0"]
        safety_dist 0.3 distance_epsilon 0.2 angle_epsilon 10 )
"#;

/// The cfg's distance_epsilon.
const EPSILON: f64 = 0.2;

fn scratch() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("player-drivers-wavefront-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    room_png(&dir.join("room.png"));
    std::fs::write(dir.join("wave.world"), WORLD).unwrap();
    dir
}

/// Reads until `done` holds, failing after `secs` seconds of wall time.
fn read_until(client: &PlayerClient, secs: u64, what: &str, mut done: impl FnMut() -> bool) {
    let deadline = Instant::now() + Duration::from_secs(secs);
    while !done() {
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        client.read().unwrap();
    }
}

#[test]
fn drives_around_an_obstacle_to_the_goal() {
    let dir = scratch();
    let handle = common::serve_cfg(&dir, "wave.cfg", CFG, Pace::RealTime { speedup: 10.0 });
    let port = handle.ports()[0];
    let client = PlayerClient::connect("localhost", port).unwrap();
    let robot = Position2dProxy::new(&client, 0).unwrap();
    let planner = PlannerProxy::new(&client, 0).unwrap();
    assert_eq!(planner.driver_name(), "wavefront");

    // Behind the wall: the straight line from (-3, -3) to (3, -3) crosses it.
    let goal = (3.0, -3.0, 0.0);
    planner.set_goal(goal.0, goal.1, goal.2).unwrap();
    read_until(&client, 20, "a valid path", || planner.path_valid());
    let d = planner.data().unwrap();
    assert_eq!((d.goal.px, d.goal.py), (goal.0, goal.1));
    assert!(d.waypoints_count >= 3, "{d:?}");

    let waypoints = planner.request_waypoints().unwrap();
    // The original Player 3.0.2 (wavefront + mapfile + Stage 4.1.1 on this world and cfg)
    // answers GET_WAYPOINTS with exactly these.
    let upstream = [(-3.0, -3.0), (-0.4, 2.9), (1.9, 1.6), (3.0, -3.0)];
    assert_eq!(waypoints.len(), upstream.len(), "{waypoints:?}");
    for (w, (x, y)) in waypoints.iter().zip(upstream) {
        assert!(
            (w.px - x).abs() < 1e-3 && (w.py - y).abs() < 1e-3 && w.pa == 0.0,
            "{waypoints:?}"
        );
    }
    assert_eq!(waypoints.len(), d.waypoints_count as usize);
    let first = waypoints[0];
    let last = *waypoints.last().unwrap();
    assert!(
        (first.px + 3.0).abs() < 0.2 && (first.py + 3.0).abs() < 0.2,
        "{first:?}"
    );
    assert!(
        (last.px - 3.0).abs() < 0.2 && (last.py + 3.0).abs() < 0.2,
        "{last:?}"
    );
    // The path goes over the top of the wall, which ends at y = 2 m.
    assert!(waypoints.iter().any(|w| w.py > 2.0), "{waypoints:?}");

    let mut highest: f64 = f64::NEG_INFINITY;
    read_until(&client, 60, "arrival", || {
        highest = highest.max(robot.pose().py);
        planner.path_done()
    });
    let p = robot.pose();
    let dist = (p.px - goal.0).hypot(p.py - goal.1);
    assert!(
        dist < EPSILON,
        "stopped at {p:?}, {dist:.2} m from the goal"
    );
    assert!(
        highest > 2.0,
        "the robot went around the wall (highest y {highest})"
    );
    assert!(planner.waypoint_idx() <= 0);

    // A goal inside the wall has no path.
    planner.set_goal(0.0, -3.0, 0.0).unwrap();
    read_until(&client, 20, "the plan to be refused", || {
        planner
            .data()
            .is_some_and(|d| d.valid == 0 && d.goal.px == 0.0)
    });
    assert!(!planner.path_done());
    assert!(planner.request_waypoints().unwrap().is_empty());

    // Disabled, the planner stops the robot and keeps it still.
    planner.set_goal(-3.0, 3.0, 0.0).unwrap();
    read_until(&client, 20, "a path back", || {
        planner.path_valid() && planner.goal().px == -3.0
    });
    planner.enable(false).unwrap();
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_millis(500) {
        client.read().unwrap();
    }
    let held = robot.pose();
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_millis(500) {
        client.read().unwrap();
    }
    let now = robot.pose();
    assert!(
        (now.px - held.px).hypot(now.py - held.py) < 0.05,
        "the robot kept moving while disabled: {held:?} -> {now:?}"
    );
    planner.enable(true).unwrap();
    read_until(&client, 60, "arrival after re-enabling", || {
        planner.path_done()
    });
    let p = robot.pose();
    assert!((p.px + 3.0).hypot(p.py - 3.0) < EPSILON, "{p:?}");

    drop((planner, robot));
    drop(client);
    handle.shutdown();
}

/// A room whose map (`bare.png`: walls only) lacks the box that stands in the world between
/// the robot and its goal: only the laser shows it.
const UNMAPPED_WORLD: &str = r#"
resolution 0.02
interval_sim 100
model( name "room" size [10 10 1] pose [0 0 0 0] bitmap "bare.png" )
model( name "box" size [0.6 3.0 0.5] pose [0 -3 0 0] color "red" )
position( name "robot" size [0.4 0.4 0.3] pose [-3 -3 0 0] localization "gps"
          localization_origin [0 0 0 0] drive "diff"
          ranger( sensor( range [0 8] fov 180 samples 181 ) ) )
"#;

/// The robot's laser stamped with its (map-frame) odometry for wavefront, which takes only
/// pose-stamped scans, and vfh on the base; wavefront drives `{output}` (the base itself, or
/// vfh's position2d:1) with `{laser}` in its requires and `{options}`.
fn unmapped_cfg(output: &str, laser: &str, options: &str) -> String {
    format!(
        r#"
driver( name "stage" provides ["0:simulation:0"] worldfile "unmapped.world" )
driver( name "stage" provides ["0:position2d:0" "0:laser:0"] model "robot" )
driver( name "laserposeinterpolator" provides ["0:laser:1"] requires ["0:laser:0" "0:position2d:0"] )
driver( name "vfh" provides ["0:position2d:1"] requires ["0:position2d:0" "0:laser:0"]
        distance_epsilon 0.2 angle_epsilon 10 )
driver( name "mapfile" provides ["0:map:0"] filename "bare.png" resolution 0.1 )
driver( name "wavefront" provides ["0:planner:0"]
        requires ["output::0:position2d:{output}" "input::0:position2d:0" "0:map:0" {laser}]
        safety_dist 0.2 distance_epsilon 0.3 angle_epsilon 20 {options} )
"#
    )
}

/// How a drive to (3, -3), behind the box, went.
struct Drive {
    arrived: bool,
    stalled: bool,
    /// Poses seen.
    path: Vec<(f64, f64)>,
}

fn drive_past_the_unmapped_box(tag: &str, cfg: &str) -> Drive {
    let dir = std::env::temp_dir().join(format!(
        "player-drivers-wavefront-{tag}-{}",
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    let (w, h) = (100u32, 100u32);
    GrayImage::from_fn(w, h, |x, y| {
        let border = x < 2 || y < 2 || x >= w - 2 || y >= h - 2;
        Luma([if border { 0 } else { 255 }])
    })
    .save(dir.join("bare.png"))
    .unwrap();
    std::fs::write(dir.join("unmapped.world"), UNMAPPED_WORLD).unwrap();
    let handle = common::serve_cfg(&dir, "unmapped.cfg", cfg, Pace::RealTime { speedup: 10.0 });
    let client = PlayerClient::connect("localhost", handle.ports()[0]).unwrap();
    let robot = Position2dProxy::new(&client, 0).unwrap();
    let planner = PlannerProxy::new(&client, 0).unwrap();
    // Let the laser's first scans reach the planner before the goal.
    read_until(&client, 20, "the planner's state", || {
        planner.data().is_some()
    });
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_millis(300) {
        client.read().unwrap();
    }
    planner.set_goal(3.0, -3.0, 0.0).unwrap();
    let mut drive = Drive {
        arrived: false,
        stalled: false,
        path: Vec::new(),
    };
    let deadline = Instant::now() + Duration::from_secs(40);
    while Instant::now() < deadline {
        client.read().unwrap();
        let p = robot.pose();
        drive.path.push((p.px, p.py));
        if robot.stall() {
            drive.stalled = true;
            break;
        }
        if planner.path_done() && planner.goal().px == 3.0 {
            drive.arrived = (p.px - 3.0).hypot(p.py + 3.0) < 0.35;
            break;
        }
    }
    drop((planner, robot));
    drop(client);
    handle.shutdown();
    let _ = std::fs::remove_dir_all(&dir);
    drive
}

/// With the laser, velocity control steers the base round the box the map does not show,
/// for a carrot on a plan remade every cycle over the laser's obstacles; and the usual stack,
/// waypoints as position goals to vfh (replanned locally along the way), gets there too.
/// Upstream checks the straight lines between waypoints against the map alone, so there vfh
/// does the dodging. Without the laser, velocity control runs straight into the box.
#[test]
fn the_laser_shows_an_obstacle_the_map_lacks() {
    let clear_of_the_box = |d: &Drive| {
        d.path
            .iter()
            .all(|&(x, y)| x.abs() > 0.5 || !(-4.7..=-1.3).contains(&y))
    };
    for (tag, output) in [("velocity", "0"), ("waypoints", "1")] {
        let options = if output == "0" {
            "velocity_control 1"
        } else {
            ""
        };
        let cfg = unmapped_cfg(output, "\"0:laser:1\"", options);
        let d = drive_past_the_unmapped_box(tag, &cfg);
        assert!(
            d.arrived && !d.stalled,
            "{tag}: arrived {}, stalled {}, last at {:?}",
            d.arrived,
            d.stalled,
            d.path.last()
        );
        assert!(clear_of_the_box(&d), "{tag}: drove into the box");
        assert!(
            d.path.iter().any(|&(_, y)| !(-4.7..=-1.3).contains(&y)),
            "{tag}: never went round"
        );
    }
    let blind = drive_past_the_unmapped_box("blind", &unmapped_cfg("0", "", "velocity_control 1"));
    assert!(
        blind.stalled && !blind.arrived,
        "without the laser the robot should hit the box; last at {:?}",
        blind.path.last()
    );
}
