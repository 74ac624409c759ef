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

mod common;

use std::time::{Duration, Instant};

use player_client::{MapProxy, PlannerProxy, PlayerClient, Position2dProxy};
use player_server::Pace;

const ROBOT_AND_MAP: &str = r#"
driver( name "stage" provides ["0:simulation:0"] plugin "stageplugin" worldfile "simple.world" )
driver( name "stage" provides ["0:position2d:0" "0:laser:0"] model "r0" )
driver( name "mapfile" provides ["0:map:0"] filename "bitmaps/cave.png" resolution 0.032 )
"#;

#[test]
fn wavefront_remote_cfg_reaches_a_goal_across_the_cave() {
    let Some(src) = common::stage_worlds() else {
        eprintln!("SKIP: ../shared/stage-worlds not found");
        return;
    };
    let dir = std::env::temp_dir().join(format!("playerstage-navchain-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    common::simple_world_for_vfh(&src, &dir);
    let a = common::serve_cfg(
        &dir,
        "robot.cfg",
        ROBOT_AND_MAP,
        Pace::RealTime { speedup: 5.0 },
    );
    let pa = a.ports()[0];
    let stack = std::fs::read_to_string(src.join("wavefront-remote.cfg"))
        .unwrap()
        .replace("6665:", &format!("{pa}:"))
        .replace("7000:", "0:")
        .replace(
            "name \"amcl\"",
            "name \"amcl\"\n  init_pose [-6.946 -6.947 45]\n  init_pose_var [0.2 0.2 10]",
        );
    let b = common::serve_cfg(&dir, "wavefront-remote.cfg", &stack, Pace::default());
    let pb = b.ports()[0];

    let client = PlayerClient::connect("localhost", pb).unwrap();
    let planner = PlannerProxy::new(&client, 0).unwrap();
    let map = MapProxy::new(&client, 0).unwrap().get_map().unwrap();
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
            break;
        }
        assert!(
            Instant::now() < deadline,
            "not there in time: at {p:?}, {off:.2} m from the goal, valid {} done {}",
            planner.path_valid(),
            planner.path_done()
        );
    }
    drop((planner, truth));
    drop((client, truth_client));
    b.shutdown();
    a.shutdown();
    let _ = std::fs::remove_dir_all(&dir);
}
