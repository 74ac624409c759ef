//! playerv (as playernav) on a live navigation stack: Stage's simple.world r0 with mapfile,
//! amcl, vfh and wavefront on one server, and playerv's client thread subscribed to the map,
//! the planner, the localiser and the base. The map arrives whole, amcl's hypotheses and the
//! planner's state come in, and a click at a map pixel, turned into a request by the function
//! the mouse handler calls, gives the planner the goal at that pixel's world point; a right
//! drag gives amcl the pose where it started. Skipped without `../shared`.

mod common;

use std::path::Path;
use std::time::{Duration, Instant};

use player_client::DataMode;
use player_server::stage::{self, StageOptions};
use player_server::{DriverRegistry, Pace, Server, ServerConfig, ServerHandle};
use viewer::View;
use viewer::playerv::state::{DeviceData, DeviceKey, PlayervState};
use viewer::playerv::worker::{Request, Worker};
use viewer::playerv::{NavAction, nav_request};
use worldfile::{CfgFile, LoadOptions};

const CFG: &str = r#"
driver( name "stage" provides ["0:simulation:0"] plugin "stageplugin" worldfile "simple.world" )
driver( name "stage" provides ["0:position2d:0" "0:laser:0"] model "r0" )
driver( name "mapfile" provides ["0:map:0"] filename "bitmaps/cave.png" resolution 0.032 )
driver( name "vfh" provides ["0:position2d:1"] requires ["0:position2d:0" "0:laser:0"] )
driver( name "amcl" provides ["0:localize:0" "0:position2d:2"]
        requires ["odometry::0:position2d:0" "0:laser:0" "laser::0:map:0"]
        init_pose [-6.946 -6.947 45] init_pose_var [0.2 0.2 10] )
driver( name "wavefront" provides ["0:planner:0"]
        requires ["output::0:position2d:1" "input::0:position2d:2" "0:map:0"]
        safety_dist 0.15 distance_epsilon 0.5 angle_epsilon 10 )
"#;

/// simple.world as Player users run it (no `wander` controller, solid walls).
fn simple_world(src: &Path, dir: &Path) {
    for f in ["pioneer.inc", "map.inc", "sick.inc"] {
        std::fs::copy(src.join(f), dir.join(f)).unwrap();
    }
    std::fs::create_dir_all(dir.join("bitmaps")).unwrap();
    std::fs::copy(src.join("bitmaps/cave.png"), dir.join("bitmaps/cave.png")).unwrap();
    let world: Vec<String> = std::fs::read_to_string(src.join("simple.world"))
        .unwrap()
        .lines()
        .filter(|l| !l.trim_start().starts_with("ctrl"))
        .map(str::to_string)
        .collect();
    let world = world.join("\n").replace(
        "bitmap \"bitmaps/cave.png\"",
        "bitmap \"bitmaps/cave.png\"\n  obstacle_return 1",
    );
    std::fs::write(dir.join("simple.world"), world).unwrap();
}

fn serve(dir: &Path) -> ServerHandle {
    let cfg = CfgFile::parse(&dir.join("nav.cfg"), CFG, &LoadOptions::default()).unwrap();
    let mut registry = DriverRegistry::new();
    stage::register(
        &mut registry,
        StageOptions {
            seed: 1,
            usegui: Some(false),
        },
    );
    player_drivers::register_all(&mut registry);
    let mut server = Server::new(ServerConfig {
        pace: Pace::RealTime { speedup: 5.0 },
        ..ServerConfig::default()
    });
    for block in player_server::cfg::driver_blocks(&cfg, 6665).unwrap() {
        server
            .add_block(&block, &mut registry)
            .unwrap_or_else(|e| panic!("{e}"));
    }
    server.resolve_requires().unwrap();
    server.start().unwrap()
}

/// Waits (at most 30 s) until the worker's state satisfies `ok`.
fn wait_for(worker: &Worker, what: &str, ok: impl Fn(&PlayervState) -> bool) -> PlayervState {
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let st = worker.state();
        if ok(&st) {
            return st;
        }
        assert!(
            Instant::now() < deadline,
            "no {what}; playerv's log: {:?}",
            st.log
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn playerv_shows_the_stack_and_its_clicks_reach_the_planner_and_amcl() {
    let Some(src) = common::shared("stage-worlds") else {
        return;
    };
    let dir = std::env::temp_dir().join(format!("playerv-nav-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    simple_world(&src, &dir);
    let server = serve(&dir);
    let key = |s: &str| DeviceKey::parse(s).unwrap();
    let worker = Worker::spawn(
        "localhost",
        server.ports()[0],
        DataMode::Push,
        10.0,
        vec![
            key("map:0"),
            key("planner:0"),
            key("localize:0"),
            key("position2d:0"),
        ],
        || {},
    );
    let st = wait_for(&worker, "map and hypotheses", |st| {
        let map = st
            .subscribed
            .get(&key("map:0"))
            .is_some_and(|s| matches!(s.data, DeviceData::Map(_)));
        let hyp = st.subscribed.get(&key("localize:0")).is_some_and(|s| {
            matches!(&s.data, DeviceData::Localize { hypotheses, .. } if !hypotheses.is_empty())
        });
        map && hyp
    });
    let DeviceData::Map(map) = &st.subscribed[&key("map:0")].data else {
        unreachable!()
    };
    assert_eq!((map.width, map.height), (500, 500));
    assert!(map.runs.len() > 100, "{} runs", map.runs.len());
    // The view the window would open with: the map fitted.
    let mut view = View {
        center: [0.0, 0.0],
        scale: 1.0,
        yaw: 0.0,
        size: [640.0, 640.0],
    };
    view.fit(map.origin, map.far_corner());
    let robot = st.robot_in_map().unwrap();
    assert!(
        (robot.x + 6.946).hypot(robot.y + 6.947) < 0.3,
        "amcl places r0 at {robot:?}"
    );

    // A left click at the pixel of (-3, 0): the planner's goal becomes that point.
    let px = view.to_screen([-3.0, 0.0]);
    let click = nav_request(&st, &view, NavAction::Goal, px, px).expect("a goal request");
    let Request::SetGoal(_, goal) = click else {
        panic!("{click:?}")
    };
    worker.send(click);
    let st = wait_for(&worker, "the goal at the planner", |st| {
        matches!(&st.subscribed[&key("planner:0")].data,
            DeviceData::Planner(p) if p.valid && (p.goal.x - goal.x).abs() < 1e-9
                && (p.goal.y - goal.y).abs() < 1e-9 && !p.waypoints.is_empty())
    });
    assert!(
        (goal.x + 3.0).abs() < 0.02 && goal.y.abs() < 0.02,
        "{goal:?}"
    );
    let DeviceData::Planner(plan) = &st.subscribed[&key("planner:0")].data else {
        unreachable!()
    };
    let last = plan.waypoints.last().unwrap();
    assert!((last[0] - goal.x).hypot(last[1] - goal.y) < 0.1, "{plan:?}");

    // Go/Stop reach the planner without an error in playerv's log.
    worker.send(Request::PlannerEnable(key("planner:0"), false));
    worker.send(Request::PlannerEnable(key("planner:0"), true));

    // A right drag from (-6, -6) towards +y: amcl restarts there, facing 90°.
    let from = view.to_screen([-6.0, -6.0]);
    let to = view.to_screen([-6.0, -5.0]);
    let drag = nav_request(&st, &view, NavAction::Pose, from, to).expect("a pose request");
    worker.send(drag);
    wait_for(&worker, "amcl at the pose given", |st| {
        matches!(&st.subscribed[&key("localize:0")].data,
            DeviceData::Localize { hypotheses, .. }
                if hypotheses.first().is_some_and(|h| (h.mean.x + 6.0).hypot(h.mean.y + 6.0) < 0.6))
    });
    let st = worker.state();
    assert!(!st.log.iter().any(|l| l.contains("failed")), "{:?}", st.log);
    drop(worker);
    server.shutdown();
    let _ = std::fs::remove_dir_all(&dir);
}
