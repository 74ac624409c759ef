//! A tour of goals through Stage 4.1.1's simple.world (from ../shared, skipped when absent)
//! for each local navigation driver: `vfh` (Stage's vfh.cfg), `nd` (Stage's nd.cfg, laser and
//! sonar) and `snd`. A client sends each goal to the driver's position2d in turn, the next once
//! the robot has stopped at the last within the driver's own tolerances (distance and
//! heading); the legs go round the cave's blocks, never touch a wall (the walls are made solid,
//! so touching one stalls the base) and each must end within a limit in simulated seconds.

mod common;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use player_client::{DataMode, PlayerClient, Position2dProxy, SimulationProxy};
use player_server::Pace;

/// A goal and what counts as arriving there.
#[derive(Clone, Copy, Debug)]
struct Goal {
    x: f64,
    y: f64,
    /// Heading, degrees.
    a: f64,
}

/// The tour, from r0's start at (-6.95, -6.95) facing 45°, on the 16 m cave: round the
/// block (x -6..-3.5, y -3.5..-0.5) to its north-east, west along its north side, back south
/// past its west side to the open floor, and up the corridor between the block and the
/// U-shaped wall (x -1..2.5, y -4.5..-2) to its north.
const TOUR: [Goal; 4] = [
    Goal {
        x: -3.0,
        y: 0.0,
        a: 90.0,
    },
    Goal {
        x: -6.0,
        y: 1.0,
        a: 180.0,
    },
    Goal {
        x: -2.0,
        y: -6.0,
        a: 0.0,
    },
    Goal {
        x: -2.5,
        y: -1.5,
        a: 90.0,
    },
];

/// Simulated seconds allowed per leg: the longest leg is about 9 m, driven at 0.3 m/s or more
/// with detours and turns.
const LEG_LIMIT: f64 = 90.0;

/// A driver's goal tolerances: metres and radians.
#[derive(Clone, Copy, Debug)]
struct Tolerance {
    distance: f64,
    heading: f64,
}

/// One leg as driven.
#[derive(Debug)]
struct Leg {
    sim_seconds: f64,
    length: f64,
}

fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("playerstage-goals-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A Stage cfg with its devices moved to OS-chosen ports.
fn on_any_port(cfg: &str) -> String {
    cfg.replace("\"simulation:", "\"0:simulation:")
        .replace("\"position2d:", "\"0:position2d:")
        .replace(":::position2d:", "::0:position2d:")
        .replace("\"laser:", "\"0:laser:")
        .replace("\"sonar:", "\"0:sonar:")
}

/// Drives the tour through the driver on `position2d:1` of the server at `port`, asserting at
/// every sample that neither the base nor the driver reports a stall, and at every arrival
/// that the simulator's true pose agrees with the odometry (r0 reports gps odometry).
fn tour(port: u16, tolerance: Tolerance) -> Vec<Leg> {
    let client = PlayerClient::connect("localhost", port).unwrap();
    let nav = Position2dProxy::new(&client, 1).unwrap();
    let base = Position2dProxy::new(&client, 0).unwrap();
    let sim = SimulationProxy::new(&client, 0).unwrap();
    client.set_datamode(DataMode::Push).unwrap();
    let wall = Instant::now();
    while nav.state().is_none() || base.state().is_none() {
        assert!(wall.elapsed() < Duration::from_secs(10), "no odometry");
        client.read().unwrap();
    }
    let mut legs = Vec::new();
    for goal in TOUR {
        let heading = goal.a.to_radians();
        nav.go_to(goal.x, goal.y, heading).unwrap();
        let start = base.datatime();
        let wall = Instant::now();
        let mut last = base.pose();
        let mut length = 0.0;
        let mut still = 0;
        loop {
            client.read().unwrap();
            if !base.is_fresh() {
                continue;
            }
            base.not_fresh();
            let s = base.state().unwrap();
            let here = s.pos;
            assert_eq!(
                s.stall, 0,
                "r0 hit something at {here:?} on the way to {goal:?}"
            );
            assert!(
                !nav.stall(),
                "the driver gave up at {here:?} on the way to {goal:?}"
            );
            length += (here.px - last.px).hypot(here.py - last.py);
            last = here;
            let off = (here.px - goal.x).hypot(here.py - goal.y);
            let turn = (here.pa - heading).sin().atan2((here.pa - heading).cos());
            let t = base.datatime() - start;
            if off < tolerance.distance
                && turn.abs() < tolerance.heading
                && s.vel.px == 0.0
                && s.vel.pa == 0.0
            {
                still += 1;
                if still >= 5 {
                    let truth = sim.get_pose2d("r0").unwrap();
                    let true_off = (truth.px - goal.x).hypot(truth.py - goal.y);
                    assert!(
                        true_off < tolerance.distance + 0.05,
                        "odometry says arrived, the simulator says {truth:?}"
                    );
                    legs.push(Leg {
                        sim_seconds: t,
                        length,
                    });
                    break;
                }
            } else {
                still = 0;
            }
            assert!(
                t < LEG_LIMIT && wall.elapsed() < Duration::from_secs(90),
                "no arrival at {goal:?} after {t:.1} simulated s; at {here:?}, {off:.2} m off"
            );
        }
    }
    drop((nav, base, sim));
    legs
}

fn report(driver: &str, legs: &[Leg]) {
    for (goal, leg) in TOUR.iter().zip(legs) {
        eprintln!(
            "{driver}: to ({}, {}, {}°): {:.1} simulated s, {:.2} m",
            goal.x, goal.y, goal.a, leg.sim_seconds, leg.length
        );
    }
    assert_eq!(legs.len(), TOUR.len());
}

fn run(tag: &str, src: &Path, cfg: &str, tolerance: Tolerance) -> Vec<Leg> {
    let dir = scratch(tag);
    common::simple_world_for_vfh(src, &dir);
    let handle = common::serve_cfg(&dir, "nav.cfg", cfg, Pace::RealTime { speedup: 20.0 });
    let legs = tour(handle.ports()[0], tolerance);
    handle.shutdown();
    let _ = std::fs::remove_dir_all(&dir);
    legs
}

#[test]
fn vfh_tours_simple_world() {
    let Some(src) = common::stage_worlds() else {
        eprintln!("skipping: Stage's worlds are not in ../shared/stage-worlds");
        return;
    };
    // Stage's vfh.cfg sets no epsilons: vfh's defaults, 0.5 m and 10°.
    let cfg = on_any_port(&std::fs::read_to_string(src.join("vfh.cfg")).unwrap());
    let legs = run(
        "vfh",
        &src,
        &cfg,
        Tolerance {
            distance: 0.5,
            heading: 10f64.to_radians(),
        },
    );
    report("vfh", &legs);
}

#[test]
fn nd_tours_simple_world() {
    let Some(src) = common::stage_worlds() else {
        eprintln!("skipping: Stage's worlds are not in ../shared/stage-worlds");
        return;
    };
    // Stage's nd.cfg as written: laser and sonar, goal_tol [0.3 15].
    let cfg = on_any_port(&std::fs::read_to_string(src.join("nd.cfg")).unwrap());
    let legs = run(
        "nd",
        &src,
        &cfg,
        Tolerance {
            distance: 0.3,
            heading: 15f64.to_radians(),
        },
    );
    report("nd", &legs);
}

#[test]
fn snd_tours_simple_world() {
    let Some(src) = common::stage_worlds() else {
        eprintln!("skipping: Stage's worlds are not in ../shared/stage-worlds");
        return;
    };
    // Stage ships no snd cfg: its nd.cfg with snd in nd's place, on the laser alone, with
    // snd's own defaults but the radius of a Pioneer (goal_tol: half of it, and 30°).
    let cfg = r#"
driver ( name "stage" provides ["0:simulation:0"] plugin "stageplugin" worldfile "simple.world" )
driver ( name "stage" provides ["0:position2d:0" "0:laser:0"] model "r0" )
driver
(
  name "snd"
  provides ["0:position2d:1"]
  requires ["input::0:position2d:0" "output::0:position2d:0" "0:laser:0"]
  robot_radius 0.3
)
"#;
    let legs = run(
        "snd",
        &src,
        cfg,
        Tolerance {
            distance: 0.15,
            heading: 30f64.to_radians(),
        },
    );
    report("snd", &legs);
}
