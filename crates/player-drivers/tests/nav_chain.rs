//! Stage 4.1.1's `wavefront-remote.cfg` chain end to end: a planner goal across the cave
//! reached by wavefront driving vfh, localised by amcl, every device of the robot and its map
//! living on another Player server reached over TCP (as the cfg has it: its robot on 6665,
//! its navigation stack on 7000).
//!
//! Server A serves simple.world's r0 (laser, odometry; the world as Player users run it, see
//! `common::simple_world_for_vfh`) and the cave's map. Server B is wavefront-remote.cfg
//! verbatim but for its ports (A's and an OS-chosen one) and amcl's `init_pose`: the cfg was
//! written for a world (`wavefront.world`) that is not in Stage's tree, so it does not know
//! where r0 starts. Skipped without `../shared`.
//!
//! Along the way the Rust client's `LocalizeProxy` follows amcl's hypotheses, and a real
//! libplayerc program (`examples/c/nav.c`, built when `pkg-config` finds `playerc`) drives the
//! same chain through libplayerc's planner, localize and map proxies.

mod common;

use std::time::{Duration, Instant};

use std::process::Command;

use player_client::{LocalizeProxy, MapProxy, PlannerProxy, PlayerClient, Position2dProxy};
use player_server::Pace;

const ROBOT_AND_MAP: &str = r#"
driver( name "stage" provides ["0:simulation:0"] plugin "stageplugin" worldfile "simple.world" )
driver( name "stage" provides ["0:position2d:0" "0:laser:0"] model "r0" )
driver( name "mapfile" provides ["0:map:0"] filename "bitmaps/cave.png" resolution 0.032 )
"#;

/// wavefront-remote.cfg with its robot's devices on `robot_port`, its own on an OS-chosen port,
/// and amcl told where r0 starts.
fn stack_cfg(src: &std::path::Path, robot_port: &str) -> String {
    std::fs::read_to_string(src.join("wavefront-remote.cfg"))
        .unwrap()
        .replace("6665:", &format!("{robot_port}:"))
        .replace("7000:", "0:")
        .replace(
            "name \"amcl\"",
            "name \"amcl\"\n  init_pose [-6.946 -6.947 45]\n  init_pose_var [0.2 0.2 10]",
        )
}

/// The robot, its map and the stack in one cfg on one port. One port holds one map:0: the
/// mapfile moves to map:5 and the passthrough relays it, so the rest of the stack reads the map
/// exactly as it does from the other server.
fn one_port_cfg(src: &std::path::Path) -> String {
    let robot = ROBOT_AND_MAP.replace("\"0:map:0\"", "\"0:map:5\"");
    let stack = stack_cfg(src, "0").replace("requires [\"0:map:0\"]", "requires [\"0:map:5\"]");
    assert!(stack.contains("\"0:map:5\""));
    format!("{robot}\n{stack}")
}

/// A folder with simple.world ready for Player, or `None` (skip) without `../shared`.
fn world_dir(tag: &str) -> Option<(std::path::PathBuf, std::path::PathBuf)> {
    let Some(src) = common::stage_worlds() else {
        eprintln!("SKIP: ../shared/stage-worlds not found");
        return None;
    };
    let dir =
        std::env::temp_dir().join(format!("playerstage-navchain-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    common::simple_world_for_vfh(&src, &dir);
    Some((src, dir))
}

#[test]
fn wavefront_remote_cfg_reaches_a_goal_across_the_cave() {
    let Some((src, dir)) = world_dir("two") else {
        return;
    };
    let a = common::serve_cfg(
        &dir,
        "robot.cfg",
        ROBOT_AND_MAP,
        Pace::RealTime { speedup: 5.0 },
    );
    let pa = a.ports()[0];
    let stack = stack_cfg(&src, &pa.to_string());
    let b = common::serve_cfg(&dir, "wavefront-remote.cfg", &stack, Pace::default());
    drive_across_the_cave(b.ports()[0], pa);
    b.shutdown();
    a.shutdown();
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_same_chain_on_one_server_and_port() {
    let Some((src, dir)) = world_dir("one") else {
        return;
    };
    let server = common::serve_cfg(
        &dir,
        "one.cfg",
        &one_port_cfg(&src),
        Pace::RealTime { speedup: 5.0 },
    );
    assert_eq!(server.ports().len(), 1);
    let remote = server
        .table()
        .devices()
        .iter()
        .filter(|d| d.driver_name == "remote")
        .count();
    assert_eq!(remote, 0, "every device is local");
    drive_across_the_cave(server.ports()[0], server.ports()[0]);
    server.shutdown();
    let _ = std::fs::remove_dir_all(&dir);
}

/// Sends the planner on `stack_port` a goal across the cave's block and reads until it is done,
/// checking the waypoints against the map and the arrival against the robot's true pose (r0's
/// gps position2d:0 on `robot_port`).
fn drive_across_the_cave(stack_port: u16, robot_port: u16) {
    let pb = stack_port;
    let pa = robot_port;
    let client = PlayerClient::connect("localhost", pb).unwrap();
    let planner = PlannerProxy::new(&client, 0).unwrap();
    let map = MapProxy::new(&client, 0).unwrap().get_map().unwrap();
    let localize = LocalizeProxy::new(&client, 0).unwrap();
    assert_eq!(localize.driver_name(), "amcl");
    let truth_client = PlayerClient::connect("localhost", pa).unwrap();
    let truth = Position2dProxy::new(&truth_client, 0).unwrap();

    // Across the cave's block, as vfh's own test drives it.
    let goal = (-3.0, 0.0, std::f64::consts::FRAC_PI_2);
    planner.set_goal(goal.0, goal.1, goal.2).unwrap();
    let deadline = Instant::now() + Duration::from_secs(90);
    let mut checked_waypoints = false;
    loop {
        client.read().unwrap();
        truth_client.read().unwrap();
        if planner.path_valid() && !checked_waypoints {
            // Every waypoint is a free cell of the map the planner was given.
            let waypoints = planner.request_waypoints().unwrap();
            assert!(waypoints.len() >= 2, "{waypoints:?}");
            for w in &waypoints {
                let i = ((w.px - map.info.origin.px) / f64::from(map.info.scale)).floor();
                let j = ((w.py - map.info.origin.py) / f64::from(map.info.scale)).floor();
                let cell = map.cells[j as usize * map.info.width as usize + i as usize];
                assert_eq!(cell, -1, "waypoint {w:?} is not a free cell");
            }
            checked_waypoints = true;
        }
        let p = truth.pose();
        let off = (p.px - goal.0).hypot(p.py - goal.1);
        if planner.path_done() && checked_waypoints {
            // wavefront-remote.cfg's distance_epsilon is 0.5 m.
            assert!(off < 0.6, "done {off:.2} m from the goal, at {p:?}");
            // amcl's best hypothesis is where the robot truly is.
            let best = localize.best().expect("amcl published no hypotheses");
            let miss = (best.mean.px - p.px).hypot(best.mean.py - p.py);
            assert!(miss < 0.3, "amcl's best {best:?} is {miss:.2} m from {p:?}");
            let particles = localize.request_particles().unwrap();
            let weight: f64 = particles.particles.iter().map(|q| q.alpha).sum();
            assert!(!particles.particles.is_empty() && (weight - 1.0).abs() < 1e-6);
            break;
        }
        assert!(
            Instant::now() < deadline,
            "not there in time: at {p:?}, {off:.2} m from the goal, valid {} done {}",
            planner.path_valid(),
            planner.path_done()
        );
    }
    drop((planner, localize, truth));
    drop((client, truth_client));
}

/// libplayerc's planner, localize and map proxies on the one-port chain: `examples/c/nav.c`
/// reads amcl's hypotheses and particles, sends wavefront the goal across the cave, checks
/// the waypoints against the map, pauses the robot through the planner, waits for "done" and
/// gives amcl a pose.
#[test]
fn libplayerc_drives_the_chain_through_its_planner_and_localize_proxies() {
    if !test_support::pkg_config_finds(&["playerc"], "the libplayerc navigation test") {
        return;
    }
    let Some((src, dir)) = world_dir("libplayerc") else {
        return;
    };
    let examples = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/c");
    let status = Command::new("make")
        .args(["-s", "-C"])
        .arg(&examples)
        .arg(format!("OUT={}", dir.display()))
        .arg(dir.join("nav"))
        .status()
        .expect("running make");
    assert!(status.success(), "building examples/c/nav.c");
    let server = common::serve_cfg(
        &dir,
        "one.cfg",
        &one_port_cfg(&src),
        Pace::RealTime { speedup: 5.0 },
    );
    let mut child = Command::new(dir.join("nav"))
        .args(["localhost", &server.ports()[0].to_string(), "-3", "0", "90"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            break;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let out = child.wait_with_output().unwrap();
    server.shutdown();
    let _ = std::fs::remove_dir_all(&dir);
    let stdout = String::from_utf8_lossy(&out.stdout);
    eprintln!("{stdout}");
    assert!(
        out.status.success(),
        "nav failed: {stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("nav: map 500x500 at 0.032 m"), "{stdout}");
    assert!(stdout.contains("all free cells"), "{stdout}");
    assert!(stdout.contains("nav: ok"), "{stdout}");
}
