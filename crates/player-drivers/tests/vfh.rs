//! `vfh` on the stage driver, over TCP: a client sends a goal behind an obstacle to the vfh
//! position2d and reads it until the robot is there, checking that the base never stalled (the
//! obstacles are solid, so touching one would stall it) and that it went round; then a velocity
//! command through vfh moves the base. On a room with a screen written here, and on Stage
//! 4.1.1's own vfh.cfg and simple.world (from ../shared, skipped when absent) with its laser and
//! with its sonar ring.

mod common;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use player_client::{DataMode, PlayerClient, Position2dProxy};
use player_proto::Pose2d;
use player_server::Pace;

/// The driver block of Stage 4.1.1's vfh.cfg (its options, and its devices on port 0 so the
/// OS picks one).
const VFH_BLOCK: &str = r#"
driver
(
  name "vfh"
  provides ["0:position2d:1"]
  requires ["0:position2d:0" "0:laser:0"]

  max_speed 0.3
  max_turnrate_0ms 90
  max_turnrate_1ms 35
)
"#;

fn cfg(worldfile: &str, model: &str) -> String {
    format!(
        "driver( name \"stage\" provides [\"0:simulation:0\"] plugin \"stageplugin\" \
         worldfile \"{worldfile}\" )\n\
         driver( name \"stage\" provides [\"0:position2d:0\" \"0:laser:0\"] model \"{model}\" )\n\
         {VFH_BLOCK}"
    )
}

/// A 12 x 8 m room with a 3.5 m screen across the middle; a Pioneer-sized robot with a
/// 181-beam 180° laser starts 3 m in front of the screen, facing it.
const SCREEN_WORLD: &str = r#"
resolution 0.02
interval_sim 100

define wall model ( color "gray30" obstacle_return 1 gui_move 0 )
wall( name "north" size [12.2 0.2 0.5] pose [0 4 0 0] )
wall( name "south" size [12.2 0.2 0.5] pose [0 -4 0 0] )
wall( name "east" size [0.2 8 0.5] pose [6 0 0 0] )
wall( name "west" size [0.2 8 0.5] pose [-6 0 0 0] )
wall( name "screen" size [0.3 3.5 0.5] pose [0 0 0 0] )

define laser180 sensor ( range [0 8] fov 180 samples 181 )
define sick ranger ( size [0.156 0.155 0.19] laser180( pose [0 0 0.1 0] ) )

position
(
  name "r0"
  size [0.44 0.38 0.22]
  drive "diff"
  localization "gps"
  localization_origin [0 0 0 0]
  pose [-3 0 0 0]
  sick( pose [0 0 0 0] )
)
"#;

/// A fresh folder for one test's files.
fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("playerstage-vfh-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// What a drive to a goal looked like.
#[derive(Debug)]
struct Trip {
    /// Where the robot stopped.
    end: Pose2d,
    /// Simulated seconds from the goal to the stop.
    sim_seconds: f64,
    /// Every pose read, for the checks on the path.
    path: Vec<Pose2d>,
}

/// Sends `goal` to the vfh device (position2d:1) and reads it in PUSH mode (every sample)
/// until the robot has stopped within `tolerance` of the goal, asserting that the base never
/// stalls. Gives up after `sim_limit` simulated or 60 wall-clock seconds.
fn drive_to(port: u16, goal: Pose2d, tolerance: f64, sim_limit: f64) -> Trip {
    let client = PlayerClient::connect("localhost", port).unwrap();
    let vfh = Position2dProxy::new(&client, 1).unwrap();
    let trip = drive(&client, &vfh, goal, tolerance, sim_limit);
    // After the goal, a velocity command goes straight to the base.
    let at = trip.end;
    vfh.set_speed(0.2, 0.0, 0.0).unwrap();
    let wall = Instant::now();
    loop {
        client.read().unwrap();
        let p = vfh.pose();
        if (p.px - at.px).hypot(p.py - at.py) > 0.05 {
            break;
        }
        assert!(
            wall.elapsed() < Duration::from_secs(10),
            "velocity command ignored"
        );
    }
    vfh.set_speed(0.0, 0.0, 0.0).unwrap();
    trip
}

fn drive(
    client: &PlayerClient,
    vfh: &Position2dProxy,
    goal: Pose2d,
    tolerance: f64,
    sim_limit: f64,
) -> Trip {
    assert_eq!(vfh.driver_name(), "vfh");
    // Requests are answered by the base below.
    let geom = vfh.request_geom().unwrap();
    assert_eq!((geom.size.sl, geom.size.sw), (0.44, 0.38));
    client.set_datamode(DataMode::Push).unwrap();
    let wall = Instant::now();
    while vfh.state().is_none() {
        assert!(wall.elapsed() < Duration::from_secs(10), "no odometry");
        client.read().unwrap();
    }
    vfh.go_to(goal.px, goal.py, goal.pa).unwrap();
    let start = vfh.datatime();
    let mut path = Vec::new();
    let mut still = 0;
    loop {
        client.read().unwrap();
        if !vfh.is_fresh() {
            continue;
        }
        vfh.not_fresh();
        let s = vfh.state().unwrap();
        assert_eq!(s.stall, 0, "the robot hit something at {:?}", s.pos);
        path.push(s.pos);
        let t = vfh.datatime() - start;
        let off = (s.pos.px - goal.px).hypot(s.pos.py - goal.py);
        // Stopped at the goal: a few samples without motion there (vfh stops commanding).
        if off < tolerance && s.vel.px == 0.0 && s.vel.pa == 0.0 {
            still += 1;
            if still >= 5 {
                return Trip {
                    end: s.pos,
                    sim_seconds: t,
                    path,
                };
            }
        } else {
            still = 0;
        }
        assert!(
            t < sim_limit && wall.elapsed() < Duration::from_secs(60),
            "no arrival after {t:.1} simulated s; at {:?}, {off:.2} m from the goal",
            s.pos
        );
    }
}

#[test]
fn vfh_drives_round_a_screen_to_a_goal_behind_it() {
    let dir = scratch("screen");
    std::fs::write(dir.join("screen.world"), SCREEN_WORLD).unwrap();
    let handle = common::serve_cfg(
        &dir,
        "screen.cfg",
        &cfg("screen.world", "r0"),
        Pace::RealTime { speedup: 20.0 },
    );
    let goal = Pose2d {
        px: 3.0,
        py: 0.0,
        pa: 0.0,
    };
    let trip = drive_to(handle.ports()[0], goal, 0.5, 120.0);
    eprintln!(
        "screen world: arrived at {:?} after {:.1} simulated s",
        trip.end, trip.sim_seconds
    );
    // It went round the screen (whose ends are at y = ±1.75), not through it.
    let widest = trip.path.iter().map(|p| p.py.abs()).fold(0.0, f64::max);
    assert!(widest > 1.75, "never got round the screen: {widest:.2} m");
    assert!(
        trip.path
            .iter()
            .all(|p| p.px.abs() > 0.4 || p.py.abs() > 1.9),
        "crossed the screen"
    );
    handle.shutdown();
    let _ = std::fs::remove_dir_all(&dir);
}

/// Stage's own vfh.cfg, its devices moved to OS-chosen ports.
fn stage_vfh_cfg(src: &Path) -> String {
    std::fs::read_to_string(src.join("vfh.cfg"))
        .unwrap()
        .replace("\"simulation:", "\"0:simulation:")
        .replace("\"position2d:", "\"0:position2d:")
        .replace("\"laser:", "\"0:laser:")
}

/// The block r0 has to go round on its way to (-3, 0) in the cave.
fn assert_clear_of_the_block(trip: &Trip) {
    let in_block = |p: &Pose2d| (-5.6..-3.9).contains(&p.px) && (-3.4..-0.7).contains(&p.py);
    assert!(!trip.path.iter().any(in_block), "drove through the block");
}

#[test]
fn stages_vfh_cfg_drives_r0_round_a_block_of_the_cave() {
    let Some(src) = common::stage_worlds() else {
        eprintln!("skipping: Stage's worlds are not in ../shared/stage-worlds");
        return;
    };
    let dir = scratch("simple");
    common::simple_world_for_vfh(&src, &dir);
    let handle = common::serve_cfg(
        &dir,
        "vfh.cfg",
        &stage_vfh_cfg(&src),
        Pace::RealTime { speedup: 20.0 },
    );
    // r0 starts at (-6.95, -6.95) facing 45°; the straight line to (-3, 0) runs into the
    // block at x -5.6..-3.9, y -3.4..-0.7.
    let goal = Pose2d {
        px: -3.0,
        py: 0.0,
        pa: 90f64.to_radians(),
    };
    let trip = drive_to(handle.ports()[0], goal, 0.5, 200.0);
    eprintln!(
        "simple.world: arrived at {:?} after {:.1} simulated s",
        trip.end, trip.sim_seconds
    );
    assert_clear_of_the_block(&trip);
    handle.shutdown();
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn with_the_sonar_ring_instead_of_the_laser_r0_goes_round_too() {
    let Some(src) = common::stage_worlds() else {
        eprintln!("skipping: Stage's worlds are not in ../shared/stage-worlds");
        return;
    };
    let dir = scratch("sonar");
    common::simple_world_for_vfh(&src, &dir);
    let cfg = stage_vfh_cfg(&src).replace("\"0:laser:0\"", "\"0:sonar:0\"");
    assert_eq!(cfg.matches("\"0:sonar:0\"").count(), 2);
    let handle = common::serve_cfg(&dir, "vfh.cfg", &cfg, Pace::RealTime { speedup: 20.0 });
    let goal = Pose2d {
        px: -3.0,
        py: 0.0,
        pa: 90f64.to_radians(),
    };
    let trip = drive_to(handle.ports()[0], goal, 0.5, 200.0);
    eprintln!(
        "simple.world, sonar: arrived at {:?} after {:.1} simulated s",
        trip.end, trip.sim_seconds
    );
    assert_clear_of_the_block(&trip);
    handle.shutdown();
    let _ = std::fs::remove_dir_all(&dir);
}
