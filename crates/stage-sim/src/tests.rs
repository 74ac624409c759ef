//! Analytic tests of the whole engine: known geometry, known answers.

use crate::desc::*;
use crate::models::gripper::{GripperCmd, PaddleState};
use crate::pool::pool_of;
use crate::pose::Pose;
use crate::world::{ModelId, World};
use std::f64::consts::PI;

fn wall(name: &str, x: f64, y: f64, sx: f64, sy: f64, sz: f64) -> ModelDesc {
    let mut m = ModelDesc::new(name, KindDesc::Model);
    m.pose = Pose::new(x, y, 0.0, 0.0);
    m.size = [sx, sy, sz];
    m
}

fn robot(name: &str, x: f64, y: f64, a: f64, drive: Drive) -> ModelDesc {
    let mut m = ModelDesc::new(
        name,
        KindDesc::Position(PositionDesc {
            drive,
            localization_origin: Some(Pose::ZERO),
            ..PositionDesc::default()
        }),
    );
    m.pose = Pose::new(x, y, 0.0, a);
    m.size = [0.4, 0.4, 0.5];
    m
}

fn laser(samples: u32, fov: f64, max: f64) -> ModelDesc {
    let mut m = ModelDesc::new(
        "laser",
        KindDesc::Ranger(vec![SensorDesc {
            samples,
            fov,
            range: [0.0, max],
            ..SensorDesc::default()
        }]),
    );
    m.size = [0.1, 0.1, 0.1];
    m
}

fn run(w: &mut World, steps: usize) {
    for _ in 0..steps {
        w.step();
    }
}

#[test]
fn laser_facing_wall_reads_exact_ranges_on_every_sample() {
    let mut d = WorldDesc::default();
    let r = d.add(robot("r", 0.0, 0.0, 0.0, Drive::Diff), None);
    let l = d.add(laser(181, PI, 8.0), Some(r));
    // near face at x = 2.0, 100 m long, 1 m high
    d.add(wall("wall", 2.05, 0.0, 0.1, 100.0, 1.0), None);
    let mut w = World::from_desc(&d, 1).unwrap();
    let lid = ModelId(l as u32);
    assert!(
        w.ranger_scans(lid).unwrap().scans().len() == 0,
        "no data before subscription"
    );
    w.subscribe(lid).unwrap();
    run(&mut w, 1);
    let data = w.ranger_scans(lid).unwrap();
    assert_eq!(data.time_us, 100_000);
    let scan = data.scan(0).unwrap();
    assert_eq!(scan.ranges.len(), 181);
    for (i, (&r, &b)) in scan.ranges.iter().zip(scan.bearings).enumerate() {
        let expect_b = -PI / 2.0 + i as f64 * PI / 180.0;
        assert!((b - expect_b).abs() < 1e-9);
        let c = expect_b.cos();
        let expect = if c > 1e-9 && 2.0 / c <= 8.0 {
            2.0 / c
        } else {
            8.0
        };
        assert!((r - expect).abs() < 1e-6, "sample {i}: {r} vs {expect}");
        let expect_i = if expect < 8.0 { 1.0 } else { 0.0 };
        assert_eq!(scan.intensities[i], expect_i, "sample {i}");
    }
}

#[test]
fn sensors_only_see_blocks_in_their_height_band() {
    let mut d = WorldDesc::default();
    let r = d.add(robot("r", 0.0, 0.0, 0.0, Drive::Diff), None);
    let l = d.add(laser(1, 0.0, 8.0), Some(r));
    d.add(wall("low", 2.05, 0.0, 0.1, 4.0, 0.3), None); // below the 0.55 m beam
    d.add(wall("high", 4.05, 0.0, 0.1, 4.0, 1.0), None);
    let mut w = World::from_desc(&d, 1).unwrap();
    w.subscribe(ModelId(l as u32)).unwrap();
    run(&mut w, 1);
    let r = w
        .ranger_scans(ModelId(l as u32))
        .unwrap()
        .scan(0)
        .unwrap()
        .ranges[0];
    assert!((r - 4.0).abs() < 1e-9, "saw {r}");
}

#[test]
fn ranger_return_negative_is_transparent_and_sets_intensity() {
    let mut d = WorldDesc::default();
    let r = d.add(robot("r", 0.0, 0.0, 0.0, Drive::Diff), None);
    let l = d.add(laser(1, 0.0, 8.0), Some(r));
    let mut glass = wall("glass", 1.05, 0.0, 0.1, 4.0, 1.0);
    glass.returns.ranger = -1.0;
    d.add(glass, None);
    let mut shiny = wall("shiny", 3.05, 0.0, 0.1, 4.0, 1.0);
    shiny.returns.ranger = 2.0;
    d.add(shiny, None);
    let mut w = World::from_desc(&d, 1).unwrap();
    w.subscribe(ModelId(l as u32)).unwrap();
    run(&mut w, 1);
    let s = w.ranger_scans(ModelId(l as u32)).unwrap().scan(0).unwrap();
    assert!((s.ranges[0] - 3.0).abs() < 1e-9);
    assert_eq!(s.intensities[0], 2.0);
}

#[test]
fn a_ray_starting_inside_a_box_stops_at_its_far_wall() {
    let mut d = WorldDesc::default();
    let r = d.add(robot("r", 0.0, 0.0, 0.0, Drive::Diff), None);
    let l = d.add(laser(1, 0.0, 8.0), Some(r));
    d.add(wall("box", 0.0, 0.0, 2.0, 2.0, 1.0), None);
    let mut w = World::from_desc(&d, 1).unwrap();
    w.subscribe(ModelId(l as u32)).unwrap();
    run(&mut w, 1);
    let s = w.ranger_scans(ModelId(l as u32)).unwrap().scan(0).unwrap();
    assert!((s.ranges[0] - 1.0).abs() < 1e-9);
}

fn drive_for(drive: Drive, cmd: (f64, f64, f64), steps: usize) -> (Pose, World, ModelId) {
    let mut d = WorldDesc::default();
    d.add(robot("r", 1.0, 2.0, 0.3, drive), None);
    let mut w = World::from_desc(&d, 1).unwrap();
    let id = w.model_by_name("r").unwrap();
    w.subscribe(id).unwrap();
    match drive {
        Drive::Car => w.position_cmd_car(id, cmd.0, cmd.2).unwrap(),
        _ => w.position_cmd_vel(id, cmd.0, cmd.1, cmd.2).unwrap(),
    }
    run(&mut w, steps);
    (w.pose(id).unwrap(), w, id)
}

#[test]
fn straight_driving_and_turning_integrate_for_each_drive() {
    // diff: 0.5 m/s along the 0.3 rad heading for 2 s
    let (p, w, id) = drive_for(Drive::Diff, (0.5, 0.7, 0.0), 20);
    assert!((p.x - (1.0 + 1.0 * 0.3f64.cos())).abs() < 1e-9, "{p:?}");
    assert!((p.y - (2.0 + 1.0 * 0.3f64.sin())).abs() < 1e-9);
    assert!(!w.position_state(id).unwrap().stall);
    // diff turning in place: 0.5 rad/s for 1 s
    let (p, ..) = drive_for(Drive::Diff, (0.0, 0.0, 0.5), 10);
    assert!((p.a - 0.8).abs() < 1e-9 && (p.x - 1.0).abs() < 1e-12);
    // omni: sideways 0.3 m/s for 1 s
    let (p, ..) = drive_for(Drive::Omni, (0.0, 0.3, 0.0), 10);
    assert!((p.x - (1.0 - 0.3 * 0.3f64.sin())).abs() < 1e-9);
    assert!((p.y - (2.0 + 0.3 * 0.3f64.cos())).abs() < 1e-9);
    // car: speed 0.5, steering 0.2 rad, wheelbase 1: Euler steps with start-of-step heading
    let (p, ..) = drive_for(Drive::Car, (0.5, 0.0, 0.2), 10);
    let (vx, va) = (0.5 * 0.2f64.cos(), 0.5 * 0.2f64.sin());
    let (mut x, mut y, mut a) = (1.0f64, 2.0f64, 0.3f64);
    for _ in 0..10 {
        x += vx * 0.1 * a.cos();
        y += vx * 0.1 * a.sin();
        a += va * 0.1;
    }
    assert!((p.x - x).abs() < 1e-9 && (p.y - y).abs() < 1e-9 && (p.a - a).abs() < 1e-9);
}

#[test]
fn gps_pose_lags_one_step_and_odom_uses_error_factors() {
    let (_, w, id) = drive_for(Drive::Diff, (0.5, 0.0, 0.0), 10);
    let est = w.position_state(id).unwrap().pose;
    let truth = w.pose(id).unwrap();
    // GPS (localization_origin 0): the estimate is the pose before the last move
    assert!((truth.x - est.x - 0.05 * 0.3f64.cos()).abs() < 1e-9);

    let mut d = WorldDesc::default();
    let mut m = robot("r", 0.0, 0.0, 0.0, Drive::Diff);
    if let KindDesc::Position(p) = &mut m.kind {
        p.localization = Localization::Odom;
        p.odom_error = Some([0.1, 0.0, 0.0, 0.0]);
    }
    d.add(m, None);
    let mut w = World::from_desc(&d, 1).unwrap();
    let id = ModelId(0);
    w.subscribe(id).unwrap();
    w.position_cmd_vel(id, 1.0, 0.0, 0.0).unwrap();
    run(&mut w, 10);
    let est = w.position_state(id).unwrap().pose;
    assert!((est.x - 1.1).abs() < 1e-9, "{est:?}");
    assert!((w.pose(id).unwrap().x - 1.0).abs() < 1e-9);
}

#[test]
fn collision_stops_robot_at_wall_with_stall() {
    let mut d = WorldDesc::default();
    d.add(robot("r", 0.0, 0.0, 0.0, Drive::Diff), None);
    // wall face at x = 0.9
    d.add(wall("wall", 1.0, 0.0, 0.2, 4.0, 1.0), None);
    let mut w = World::from_desc(&d, 1).unwrap();
    let id = ModelId(0);
    w.subscribe(id).unwrap();
    w.position_cmd_vel(id, 1.0, 0.0, 0.0).unwrap();
    run(&mut w, 30);
    let x = w.pose(id).unwrap().x;
    assert!(
        x + 0.2 <= 0.9 + 1e-12,
        "robot front {} passed the wall",
        x + 0.2
    );
    assert!(x + 0.2 > 0.9 - 0.1 - 1e-9, "stopped too early at {x}");
    run(&mut w, 2);
    assert!(w.position_state(id).unwrap().stall);
    assert_eq!(w.pose(id).unwrap().x, x, "stays put while blocked");
    // reversing clears the stall
    w.position_cmd_vel(id, -0.5, 0.0, 0.0).unwrap();
    run(&mut w, 2);
    assert!(!w.position_state(id).unwrap().stall);
    assert!(w.pose(id).unwrap().x < x);
}

/// A stall is kept while the robot stands still; `set_stall` (a reset or teleport out of the
/// collision) clears it, and the flag stays clear while the robot does not move into anything.
#[test]
fn set_stall_clears_a_kept_stall() {
    let mut d = WorldDesc::default();
    d.add(robot("r", 0.0, 0.0, 0.0, Drive::Diff), None);
    d.add(wall("wall", 1.0, 0.0, 0.2, 4.0, 1.0), None);
    let mut w = World::from_desc(&d, 1).unwrap();
    let id = ModelId(0);
    w.subscribe(id).unwrap();
    w.position_cmd_vel(id, 1.0, 0.0, 0.0).unwrap();
    run(&mut w, 30);
    w.position_cmd_vel(id, 0.0, 0.0, 0.0).unwrap();
    run(&mut w, 3);
    assert!(w.position_state(id).unwrap().stall, "kept while stopped");
    w.set_pose(id, Pose::new(-1.0, 0.0, 0.0, 0.0)).unwrap();
    w.set_stall(id, false).unwrap();
    assert!(!w.position_state(id).unwrap().stall);
    run(&mut w, 3);
    assert!(!w.position_state(id).unwrap().stall, "clear after steps");
}

/// Moves happen one at a time in creation order, each against the already-moved robots, even
/// when the moves are planned in parallel: a robot driving into the spot another one is just
/// leaving is blocked only if it moves first.
#[test]
fn robots_move_in_creation_order_against_already_moved_robots() {
    let first_step = |rear_first: bool| {
        let mut d = WorldDesc::default();
        let rear = robot("rear", 0.0, 0.0, 0.0, Drive::Diff);
        let front = robot("front", 0.41, 0.0, 0.0, Drive::Diff);
        let (rear_id, front_id) = if rear_first {
            d.add(rear, None);
            d.add(front, None);
            (ModelId(0), ModelId(1))
        } else {
            d.add(front, None);
            d.add(rear, None);
            (ModelId(1), ModelId(0))
        };
        // enough robots that the moves are planned in parallel
        for i in 0..20 {
            d.add(
                robot(&format!("idle{i}"), 10.0 + i as f64, 10.0, 0.0, Drive::Diff),
                None,
            );
        }
        let pool = pool_of(2);
        pool.install(|| {
            let mut w = World::from_desc(&d, 1).unwrap();
            for id in [rear_id, front_id] {
                w.subscribe(id).unwrap();
                w.position_cmd_vel(id, 1.0, 0.0, 0.0).unwrap();
            }
            for i in 0..20 {
                let id = w.model_by_name(&format!("idle{i}")).unwrap();
                w.subscribe(id).unwrap();
                w.position_cmd_vel(id, 0.5, 0.0, 0.3).unwrap();
            }
            w.step();
            let rear = (
                w.pose(rear_id).unwrap().x,
                w.position_state(rear_id).unwrap().stall,
            );
            let front = (
                w.pose(front_id).unwrap().x,
                w.position_state(front_id).unwrap().stall,
            );
            (rear, front)
        })
    };
    // the rear robot moves first, into the front robot's old place: refused
    let (rear, front) = first_step(true);
    assert_eq!(rear, (0.0, true));
    assert!(front.0 > 0.41 && !front.1, "{front:?}");
    // the front robot moves away first: the rear one follows
    let (rear, front) = first_step(false);
    assert!(rear.0 > 0.0 && !rear.1, "{rear:?}");
    assert!(front.0 > 0.41 && !front.1, "{front:?}");
}

#[test]
fn obstacle_return_zero_lets_robots_pass() {
    let mut d = WorldDesc::default();
    d.add(robot("r", 0.0, 0.0, 0.0, Drive::Diff), None);
    let mut floor = wall("floorplan", 1.0, 0.0, 0.2, 4.0, 1.0);
    floor.returns.obstacle = false;
    d.add(floor, None);
    let mut w = World::from_desc(&d, 1).unwrap();
    w.subscribe(ModelId(0)).unwrap();
    w.position_cmd_vel(ModelId(0), 1.0, 0.0, 0.0).unwrap();
    run(&mut w, 20);
    assert!(w.pose(ModelId(0)).unwrap().x > 1.5);
    assert!(!w.position_state(ModelId(0)).unwrap().stall);
}

#[test]
fn unsubscribed_models_do_not_move_or_sense() {
    let mut d = WorldDesc::default();
    let r = d.add(robot("r", 0.0, 0.0, 0.0, Drive::Diff), None);
    let l = d.add(laser(5, 1.0, 8.0), Some(r));
    let mut w = World::from_desc(&d, 1).unwrap();
    w.position_cmd_vel(ModelId(0), 1.0, 0.0, 0.0).unwrap();
    run(&mut w, 5);
    assert_eq!(w.pose(ModelId(0)).unwrap().x, 0.0);
    assert!(w.ranger_scans(ModelId(l as u32)).unwrap().scans().len() == 0);
    w.subscribe(ModelId(0)).unwrap();
    w.position_cmd_vel(ModelId(0), 1.0, 0.0, 0.0).unwrap();
    run(&mut w, 5);
    assert!(w.pose(ModelId(0)).unwrap().x > 0.3);
    w.unsubscribe(ModelId(0)).unwrap();
    let x = w.pose(ModelId(0)).unwrap().x;
    run(&mut w, 5);
    assert_eq!(
        w.pose(ModelId(0)).unwrap().x,
        x,
        "shutdown zeroes the velocity"
    );
}

#[test]
fn update_interval_rounds_up_to_world_steps_and_quit_time_overshoots() {
    let mut d = WorldDesc::default();
    d.config.quit_time_us = 350_000;
    let r = d.add(robot("r", 0.0, 0.0, 0.0, Drive::Diff), None);
    let mut l = laser(1, 0.0, 8.0);
    l.update_interval_us = 150_000;
    let l = d.add(l, Some(r));
    let mut w = World::from_desc(&d, 1).unwrap();
    w.subscribe(ModelId(l as u32)).unwrap();
    let mut times = Vec::new();
    while w.step() {
        if w.last_update(ModelId(l as u32)).unwrap() == Some(w.sim_time()) {
            times.push(w.sim_time());
        }
    }
    assert_eq!(w.sim_time(), 400_000);
    assert_eq!(times, vec![200_000, 400_000]);
    assert!(!w.step());
}

#[test]
fn blobfinder_sees_coloured_box_at_expected_columns() {
    let mut d = WorldDesc::default();
    let r = d.add(robot("r", 0.0, 0.0, 0.0, Drive::Diff), None);
    let mut bf = ModelDesc::new("bf", KindDesc::Blobfinder(BlobfinderDesc::default()));
    bf.size = [0.0, 0.0, 0.0];
    let b = d.add(bf, Some(r));
    let mut bx = wall("box", 2.0, 0.0, 0.2, 0.3, 0.5);
    bx.color = Color::rgb(0.0, 1.0, 0.0);
    d.add(bx, None);
    let mut w = World::from_desc(&d, 1).unwrap();
    w.subscribe(ModelId(b as u32)).unwrap();
    run(&mut w, 1);
    let data = w.blobfinder_blobs(ModelId(b as u32)).unwrap();
    assert_eq!(data.blobs.len(), 1, "{:?}", data.blobs);
    let blob = data.blobs[0];
    // analytic: sample s looks at -30° + s·60°/79; the box front face (x = 1.9, |y| ≤ 0.15)
    let half = (0.15f64 / 1.9).atan();
    let seen: Vec<usize> = (0..80)
        .filter(|&s| (-PI / 6.0 + s as f64 * (PI / 3.0) / 79.0).abs() <= half)
        .collect();
    let (lo, hi) = (seen[0], *seen.last().unwrap());
    assert_eq!(blob.left as usize, 79 - hi);
    assert_eq!(blob.right as usize, 79 - lo);
    let mean: f64 = seen
        .iter()
        .map(|&s| 1.9 / (-PI / 6.0 + s as f64 * (PI / 3.0) / 79.0).cos())
        .sum::<f64>()
        / seen.len() as f64;
    assert!((blob.range - mean).abs() < 1e-9);
    let half_px = (0.3f64.atan2(mean) / (PI / 3.0 / 60.0)) as u32;
    assert_eq!((blob.top, blob.bottom), (30 - half_px, 30 + half_px));
    assert!(same_rgb(&blob.color, &Color::rgb(0.0, 1.0, 0.0)));
    // rows grow downwards, so Player's area (right-left)·(top-bottom) is < 0 (its wrap into the
    // unsigned field is the stage driver's, tested in player-server's stage::convert)
    let area = (blob.right as i64 - blob.left as i64) * (blob.top as i64 - blob.bottom as i64);
    assert!(area < 0);
    // a colour filter without green drops it
    let mut d2 = d.clone();
    if let KindDesc::Blobfinder(c) = &mut d2.models[b].kind {
        c.colors = vec![Color::RED];
    }
    let mut w2 = World::from_desc(&d2, 1).unwrap();
    w2.subscribe(ModelId(b as u32)).unwrap();
    run(&mut w2, 1);
    assert!(
        w2.blobfinder_blobs(ModelId(b as u32))
            .unwrap()
            .blobs
            .is_empty()
    );
}

fn fiducial_world(range_max_id: f64, occluder: bool, key: i32) -> (World, ModelId) {
    let mut d = WorldDesc::default();
    let r = d.add(robot("r", 0.0, 0.0, 0.0, Drive::Diff), None);
    let f = d.add(
        ModelDesc::new(
            "fid",
            KindDesc::Fiducial(FiducialDesc {
                range_max_id,
                ..FiducialDesc::default()
            }),
        ),
        Some(r),
    );
    d.models[f].pose = Pose::new(0.0, 0.0, -0.3, 0.0); // beam at z 0.2
    let mut t = wall("target", 2.0, 1.0, 0.3, 0.3, 1.0);
    t.returns.fiducial = 7;
    t.returns.fiducial_key = key;
    t.pose.a = 0.5;
    d.add(t, None);
    if occluder {
        d.add(wall("occluder", 1.0, 0.5, 0.1, 0.1, 1.0), None);
    }
    let mut w = World::from_desc(&d, 1).unwrap();
    w.subscribe(ModelId(f as u32)).unwrap();
    run(&mut w, 1);
    (w, ModelId(f as u32))
}

#[test]
fn fiducial_reports_range_bearing_id_and_respects_range_max_id_and_occlusion() {
    let (w, f) = fiducial_world(5.0, false, 0);
    let fs = &w.fiducials(f).unwrap().fiducials;
    assert_eq!(fs.len(), 1);
    assert_eq!(fs[0].id, 7);
    assert!((fs[0].range - 5f64.sqrt()).abs() < 1e-9);
    assert!((fs[0].bearing - 0.5f64.atan2(1.0)).abs() < 1e-9);
    assert!((fs[0].heading - 0.5).abs() < 1e-9);
    let (w, f) = fiducial_world(2.0, false, 0);
    assert_eq!(
        w.fiducials(f).unwrap().fiducials[0].id,
        0,
        "beyond range_max_id"
    );
    let (w, f) = fiducial_world(5.0, true, 0);
    assert!(w.fiducials(f).unwrap().fiducials.is_empty(), "occluded");
    let (w, f) = fiducial_world(5.0, false, 3);
    assert!(w.fiducials(f).unwrap().fiducials.is_empty(), "key mismatch");
}

#[test]
fn gripper_picks_up_carries_and_drops_a_puck() {
    let mut d = WorldDesc::default();
    let r = d.add(robot("r", 0.0, 0.0, 0.0, Drive::Diff), None);
    let mut g = ModelDesc::new("grip", KindDesc::Gripper(GripperDesc::default()));
    g.pose = Pose::new(0.3, 0.0, -0.5, 0.0); // on the floor in front of the robot
    let g = d.add(g, Some(r));
    let mut puck = wall("puck", 0.34, 0.0, 0.06, 0.06, 0.1);
    puck.returns.gripper = true;
    puck.returns.obstacle = false;
    let p = d.add(puck, None);
    let mut w = World::from_desc(&d, 1).unwrap();
    let (rid, gid, pid) = (ModelId(r as u32), ModelId(g as u32), ModelId(p as u32));
    w.subscribe(rid).unwrap();
    w.subscribe(gid).unwrap();
    run(&mut w, 1);
    let st = w.gripper_state(gid).unwrap();
    assert!(st.beams.contains(&Some(pid)), "puck breaks a beam: {st:?}");
    w.gripper_cmd(gid, GripperCmd::Close).unwrap();
    run(&mut w, 25);
    let st = *w.gripper_state(gid).unwrap();
    assert_eq!(st.carrying, Some(pid), "{st:?}");
    assert_eq!(st.paddles, PaddleState::Closed);
    assert_eq!(w.parent(pid).unwrap(), Some(gid));
    assert!(w.related(pid, rid).unwrap());
    // carry it 1 m
    w.position_cmd_vel(rid, 0.5, 0.0, 0.0).unwrap();
    run(&mut w, 20);
    w.position_cmd_vel(rid, 0.0, 0.0, 0.0).unwrap();
    let gp = w.global_pose(pid).unwrap();
    assert!(
        (gp.x - (w.pose(rid).unwrap().x + 0.3)).abs() < 1e-9,
        "{gp:?}"
    );
    assert!(w.pose(rid).unwrap().x > 0.9);
    // drop it
    w.gripper_cmd(gid, GripperCmd::Open).unwrap();
    run(&mut w, 2);
    assert_eq!(w.parent(pid).unwrap(), None);
    assert!(w.gripper_state(gid).unwrap().carrying.is_none());
    let dropped = w.pose(pid).unwrap();
    assert!((dropped.x - w.global_pose(gid).unwrap().x).abs() < 1e-9);
    // it stays behind when the robot reverses
    w.position_cmd_vel(rid, -0.5, 0.0, 0.0).unwrap();
    run(&mut w, 10);
    assert_eq!(w.pose(pid).unwrap(), dropped);
}

fn busy_world() -> WorldDesc {
    let mut d = WorldDesc::default();
    for (i, (x, y)) in [(2.0, 0.0), (-2.0, 0.0), (0.0, 2.0), (0.0, -2.0)]
        .iter()
        .enumerate()
    {
        let (sx, sy) = if *x != 0.0 { (0.1, 4.2) } else { (4.2, 0.1) };
        d.add(wall(&format!("w{i}"), *x, *y, sx, sy, 1.0), None);
    }
    for i in 0..6 {
        let mut r = robot(
            &format!("r{i}"),
            -1.2 + 0.5 * i as f64,
            0.3 * (i % 3) as f64 - 0.3,
            i as f64,
            Drive::Diff,
        );
        r.size = [0.3, 0.3, 0.5];
        r.ctrl = vec!["wander".into()];
        let ri = d.add(r, None);
        // 90 samples: cast in parallel chunks; the noise must still draw in ray order
        let mut l = laser(90, PI, 4.0);
        if let KindDesc::Ranger(sensors) = &mut l.kind {
            sensors[0].noise = 0.01;
        }
        d.add(l, Some(ri));
    }
    d
}

#[test]
fn determinism_same_seed_same_state_after_1000_steps_any_thread_count() {
    let d = busy_world();
    let digest = |seed: u64, threads: usize| {
        let pool = pool_of(threads);
        pool.install(|| {
            let mut w = World::from_desc(&d, seed).unwrap();
            for _ in 0..1000 {
                w.step();
            }
            (w.state_digest(), w.pose(ModelId(4)).unwrap())
        })
    };
    let a = digest(42, 1);
    let b = digest(42, 2);
    let c = digest(42, 2);
    let d4 = digest(42, 4);
    assert_eq!(a, b);
    assert_eq!(b, c);
    assert_eq!(a, d4);
    assert_ne!(a.1, Pose::new(-1.2, -0.3, 0.0, 0.0), "robots moved");
}

/// A crowd large enough for every parallel path of a step (updates cut into pieces, moves
/// planned in parallel, controllers in parallel beside the ordered move pass) ends in the same
/// state on one thread as on two or three.
#[test]
fn determinism_of_a_crowd_any_thread_count() {
    let mut d = WorldDesc::default();
    let side = 9;
    let pitch = 0.8;
    room_walls(&mut d, side as f64 * pitch);
    for i in 0..side * side {
        let (col, row) = ((i % side) as f64, (i / side) as f64);
        let mut r = robot(
            &format!("r{i}"),
            col * pitch,
            row * pitch,
            0.7 * i as f64,
            Drive::Diff,
        );
        r.size = [0.3, 0.3, 0.5];
        r.ctrl = vec!["wander".into()];
        let ri = d.add(r, None);
        d.add(laser(16, PI, 3.0), Some(ri));
    }
    let digest = |threads: usize| {
        let pool = pool_of(threads);
        pool.install(|| {
            let mut w = World::from_desc(&d, 7).unwrap();
            for _ in 0..300 {
                w.step();
            }
            // enough rays a step for the updates to be split (crate::world::step)
            assert!(w.rays_cast() >= 300 * 1024, "{} rays", w.rays_cast());
            w.state_digest()
        })
    };
    let one = digest(1);
    assert_eq!(one, digest(2));
    assert_eq!(one, digest(3));
}

#[test]
fn wander_avoids_walls_in_a_closed_room() {
    let d = busy_world();
    let mut w = World::from_desc(&d, 3).unwrap();
    for _ in 0..600 {
        w.step();
    }
    for i in 0..6 {
        let id = w.model_by_name(&format!("r{i}")).unwrap();
        let p = w.pose(id).unwrap();
        assert!(
            p.x.abs() < 2.0 && p.y.abs() < 2.0,
            "robot {i} escaped: {p:?}"
        );
    }
    let moved = (0..6)
        .filter(|i| {
            let id = w.model_by_name(&format!("r{i}")).unwrap();
            let p = w.pose(id).unwrap();
            (p.x - (-1.2 + 0.5 * *i as f64)).abs() > 0.2
        })
        .count();
    assert!(moved >= 3, "wanderers wander");
}

#[test]
fn invalid_descriptions_are_errors_not_panics() {
    let mut d = WorldDesc::default();
    let mut m = wall("bad", 0.0, 0.0, 1.0, 1.0, 1.0);
    m.default_body = false;
    m.blocks = vec![BlockDesc {
        points: vec![[0.0, 0.0]],
        zmin: 0.0,
        zmax: 1.0,
        color: None,
    }];
    d.add(m, None);
    assert!(World::from_desc(&d, 1).is_err());
    let mut d = WorldDesc::default();
    d.add(wall("a", 0.0, 0.0, 1.0, 1.0, 1.0), Some(3));
    assert!(World::from_desc(&d, 1).is_err());
}

#[test]
fn unknown_controller_is_a_warning_naming_the_model() {
    let mut d = WorldDesc::default();
    let mut r = robot("bob", 0.0, 0.0, 0.0, Drive::Diff);
    r.ctrl = vec!["fasr 1 2".into()];
    d.add(r, None);
    let w = World::from_desc(&d, 1).unwrap();
    assert_eq!(w.warnings().len(), 1);
    assert!(w.warnings()[0].contains("fasr") && w.warnings()[0].contains("bob"));
}

#[test]
fn camera_sees_wall_colour_and_depth() {
    let mut d = WorldDesc::default();
    let r = d.add(robot("r", 0.0, 0.0, 0.0, Drive::Diff), None);
    let c = d.add(
        ModelDesc::new("cam", KindDesc::Camera(CameraDesc::default())),
        Some(r),
    );
    let mut wl = wall("wall", 3.05, 0.0, 0.1, 20.0, 2.0);
    wl.color = Color::rgb(0.0, 0.0, 1.0);
    d.add(wl, None);
    let mut w = World::from_desc(&d, 1).unwrap();
    w.subscribe(ModelId(c as u32)).unwrap();
    run(&mut w, 1);
    let img = w.camera_image(ModelId(c as u32)).unwrap();
    assert_eq!((img.width, img.height), (32, 32));
    // the centre pixel looks straight ahead at the wall, 3 m away
    let i = 16 * 32 + 16;
    assert_eq!(&img.rgba[i * 4..i * 4 + 4], &[0, 0, 255, 255]);
    let el = 20f64.to_radians() - 16.5 * 40f64.to_radians() / 32.0;
    let az = 35f64.to_radians() - 16.5 * 70f64.to_radians() / 32.0;
    let expect = 3.0 / az.cos() / el.cos();
    assert!(
        (img.depth[i] as f64 - expect).abs() < 1e-4,
        "{} vs {expect}",
        img.depth[i]
    );
}

#[test]
fn lasernoise_controller_perturbs_ranges_multiplicatively() {
    let mut d = WorldDesc::default();
    let r = d.add(robot("r", 0.0, 0.0, 0.0, Drive::Diff), None);
    let mut l = laser(181, 0.5, 8.0);
    l.ctrl = vec!["lasernoise".into()];
    let l = d.add(l, Some(r));
    d.add(wall("wall", 2.05, 0.0, 0.1, 100.0, 1.0), None);
    let mut w = World::from_desc(&d, 9).unwrap();
    assert!(w.warnings().is_empty(), "{:?}", w.warnings());
    run(&mut w, 1);
    let s = w.ranger_scans(ModelId(l as u32)).unwrap().scan(0).unwrap();
    let rel: Vec<f64> = s
        .ranges
        .iter()
        .zip(s.bearings)
        .map(|(r, b)| r / (2.0 / b.cos()) - 1.0)
        .collect();
    let mean = rel.iter().sum::<f64>() / rel.len() as f64;
    let sd = (rel.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / rel.len() as f64).sqrt();
    assert!(mean.abs() < 0.02, "mean {mean}");
    assert!((sd - 0.05).abs() < 0.015, "sd {sd}");
}

#[test]
fn pioneer_flocking_controller_installs_and_drives() {
    let mut d = WorldDesc::default();
    for i in 0..2 {
        let mut r = robot(&format!("r{i}"), 0.0, 2.0 * i as f64, 0.0, Drive::Diff);
        r.ctrl = vec!["pioneer_flocking".into()];
        r.returns.fiducial = 1;
        let ri = d.add(r, None);
        let sonar = (0..16)
            .map(|k| SensorDesc {
                pose: Pose::new(0.0, 0.0, 0.0, (-90.0 + 22.5 * k as f64).to_radians()),
                range: [0.0, 5.0],
                ..SensorDesc::default()
            })
            .collect();
        d.add(ModelDesc::new("sonar", KindDesc::Ranger(sonar)), Some(ri));
        d.add(
            ModelDesc::new("fid", KindDesc::Fiducial(FiducialDesc::default())),
            Some(ri),
        );
    }
    let mut w = World::from_desc(&d, 1).unwrap();
    assert!(w.warnings().is_empty(), "{:?}", w.warnings());
    run(&mut w, 20);
    assert!(
        w.pose(ModelId(0)).unwrap().x > 0.3,
        "{:?}",
        w.pose(ModelId(0)).unwrap()
    );
}

#[test]
fn teleporting_a_static_model_moves_it_for_sensors_and_contacts() {
    let mut d = WorldDesc::default();
    let r = d.add(robot("r", 0.0, 0.0, 0.0, Drive::Diff), None);
    let l = d.add(laser(1, 0.0, 8.0), Some(r));
    let b = d.add(wall("box", 3.0, 0.0, 0.2, 1.0, 1.0), None);
    let mut w = World::from_desc(&d, 1).unwrap();
    let (lid, bid) = (ModelId(l as u32), ModelId(b as u32));
    w.subscribe(lid).unwrap();
    run(&mut w, 1);
    assert!((w.ranger_scans(lid).unwrap().scan(0).unwrap().ranges[0] - 2.9).abs() < 1e-9);
    w.set_pose(bid, Pose::new(1.0, 0.0, 0.0, 0.0)).unwrap();
    run(&mut w, 1);
    assert!((w.ranger_scans(lid).unwrap().scan(0).unwrap().ranges[0] - 0.9).abs() < 1e-9);
    w.set_pose(bid, Pose::new(1.0, 5.0, 0.0, 0.0)).unwrap();
    run(&mut w, 1);
    assert_eq!(w.ranger_scans(lid).unwrap().scan(0).unwrap().ranges[0], 8.0);
    // and it blocks a robot at its new place
    w.set_pose(bid, Pose::new(0.5, 0.0, 0.0, 0.0)).unwrap();
    w.subscribe(ModelId(0)).unwrap();
    w.position_cmd_vel(ModelId(0), 0.5, 0.0, 0.0).unwrap();
    run(&mut w, 5);
    assert!(w.position_state(ModelId(0)).unwrap().stall);
    assert!(w.pose(ModelId(0)).unwrap().x + 0.2 <= 0.4 + 1e-12);
}

#[test]
fn child_poses_stack_on_the_parent_and_origin_shifts_body_and_rays() {
    let mut d = WorldDesc::default();
    let mut p = wall("parent", 1.0, 2.0, 2.0, 1.0, 0.5);
    p.pose = Pose::new(1.0, 2.0, 0.5, std::f64::consts::FRAC_PI_2);
    p.origin = Pose::new(0.1, 0.0, 0.2, 0.0);
    let pi = d.add(p, None);
    let mut c = wall("child", 0.0, 0.0, 0.1, 0.1, 0.1);
    c.pose = Pose::new(1.0, 0.0, 0.1, 0.0);
    let ci = d.add(c, Some(pi));
    let w = World::from_desc(&d, 1).unwrap();
    // spec §1.2 (verified against Stage): (1, 3, 1.1, 90°); the parent's origin is not used
    let g = w.global_pose(ModelId(ci as u32)).unwrap();
    assert!((g.x - 1.0).abs() < 1e-12 && (g.y - 3.0).abs() < 1e-12);
    assert!((g.z - 1.1).abs() < 1e-12);
    // the parent's body is shifted by its origin (0.1 along its heading = +y) and lifted
    let body = w.body(ModelId(pi as u32)).unwrap();
    assert!(
        (body.aabb.min[1] - (2.1 - 1.0)).abs() < 1e-9,
        "{:?}",
        body.aabb
    );
    assert!((body.blocks[0].zmin - 0.7).abs() < 1e-12 && (body.blocks[0].zmax - 1.2).abs() < 1e-12);
}

#[test]
fn blobfinder_skips_the_column_after_a_blob() {
    let mut d = WorldDesc::default();
    let r = d.add(robot("r", 0.0, 0.0, 0.0, Drive::Diff), None);
    let bf = BlobfinderDesc {
        image: [3, 10],
        fov: 0.2,
        ..Default::default()
    };
    let b = d.add(ModelDesc::new("bf", KindDesc::Blobfinder(bf)), Some(r));
    // three adjacent boxes straight ahead, one per ray: the right one red, the others green
    let ang = [-0.1f64, 0.0, 0.1];
    let cols = [
        Color::RED,
        Color::rgb(0.0, 1.0, 0.0),
        Color::rgb(0.0, 0.0, 1.0),
    ];
    for (i, (a, c)) in ang.iter().zip(cols).enumerate() {
        let mut bx = wall(
            &format!("b{i}"),
            3.0 * a.cos(),
            3.0 * a.sin(),
            0.1,
            0.1,
            1.0,
        );
        bx.color = c;
        d.add(bx, None);
    }
    let mut w = World::from_desc(&d, 1).unwrap();
    w.subscribe(ModelId(b as u32)).unwrap();
    run(&mut w, 1);
    let blobs = &w.blobfinder_blobs(ModelId(b as u32)).unwrap().blobs;
    // sample 0 (red) is a blob, sample 1 (green) is skipped, sample 2 (blue) is a blob
    assert_eq!(blobs.len(), 2, "{blobs:?}");
    assert!(same_rgb(&blobs[0].color, &Color::RED));
    assert_eq!((blobs[0].left, blobs[0].right), (2, 2));
    assert!(same_rgb(&blobs[1].color, &Color::rgb(0.0, 0.0, 1.0)));
    assert_eq!((blobs[1].left, blobs[1].right), (0, 0));
}

#[test]
fn world_can_move_between_threads() {
    fn assert_send_sync<T: Send + Sync>() {}
    assert_send_sync::<World>();
}

#[test]
fn a_model_rasterises_to_its_own_blocks_over_its_footprint() {
    let mut d = WorldDesc::default();
    // A 4 m × 2 m model centred on (1, 2): an L of two blocks (the left metre and the bottom
    // half metre), a child robot on it that is not part of its map.
    let mut floor = wall("floor", 1.0, 2.0, 4.0, 2.0, 1.0);
    floor.default_body = false;
    floor.blocks = vec![
        BlockDesc::rect(-2.0, -1.0, 1.0, 2.0, 1.0),
        BlockDesc::rect(-1.0, -1.0, 3.0, 0.5, 1.0),
    ];
    let f = d.add(floor, None);
    d.add(robot("r", 1.0, 0.5, 0.0, Drive::Diff), Some(f));
    let w = World::from_desc(&d, 1).unwrap();
    let r = w.rasterize(ModelId(f as u32), 0.5, 1000).unwrap().unwrap();
    assert_eq!((r.width, r.height, r.cell), (8, 4, 0.5));
    assert_eq!(r.origin, [-1.0, 1.0]);
    let rows: Vec<String> = (0..r.height)
        .rev()
        .map(|j| {
            (0..r.width)
                .map(|i| if r.get(i, j) { '#' } else { '.' })
                .collect()
        })
        .collect();
    assert_eq!(rows, ["##......", "##......", "##......", "########"]);
    // Too many cells, or no cell size: no raster.
    assert!(w.rasterize(ModelId(f as u32), 0.5, 31).unwrap().is_none());
    assert!(w.rasterize(ModelId(f as u32), 0.0, 1000).unwrap().is_none());
}

#[test]
fn a_turned_model_rasterises_over_its_world_bounding_box() {
    let mut d = WorldDesc::default();
    let mut m = wall("box", 0.0, 0.0, 2.0, 1.0, 1.0);
    m.pose = Pose::new(0.0, 0.0, 0.0, PI / 2.0);
    let b = d.add(m, None);
    let w = World::from_desc(&d, 1).unwrap();
    let r = w.rasterize(ModelId(b as u32), 0.25, 1000).unwrap().unwrap();
    // Standing on end: 1 m wide, 2 m tall, every cell covered.
    assert_eq!((r.width, r.height), (4, 8));
    assert!((r.origin[0] + 0.5).abs() < 1e-12 && (r.origin[1] + 1.0).abs() < 1e-12);
    assert!(r.cells.iter().all(|&c| c));
}

/// Stage's load computes every position model's estimate from its start pose in the
/// `localization_origin` frame, odometry included: a robot placed at (-6.946, -6.947, 45°)
/// with `localization_origin [0 0 0 0]` (as Stage's pioneer.inc sets it) reports that pose,
/// a robot without the property reports zero, and other origins see the start from there.
#[test]
fn odometry_starts_from_the_start_pose_in_the_localization_origin_frame() {
    let text = r#"
define bot position ( size [0.4 0.4 0.3] localization "odom" odom_error [0 0 0 0] )
bot ( name "world_frame" pose [-6.946 -6.947 0 45] localization_origin [0 0 0 0] )
bot ( name "own_frame" pose [2 3 0 30] )
bot ( name "shifted" pose [2 3 0 30] localization_origin [1 1 0 90] )
"#;
    let opts = worldfile::LoadOptions::default();
    let spec = worldfile::WorldSpec::parse(std::path::Path::new("odom.world"), text, &opts)
        .expect("world parses");
    let mut w = World::from_spec(&spec, 1).unwrap();
    let ids: Vec<ModelId> = ["world_frame", "own_frame", "shifted"]
        .iter()
        .map(|n| w.model_by_name(n).unwrap())
        .collect();
    for &id in &ids {
        w.subscribe(id).unwrap();
    }
    run(&mut w, 3);
    let est = |w: &World, i: usize| w.position_state(ids[i]).unwrap().pose;
    let close = |p: Pose, x: f64, y: f64, a: f64| {
        (p.x - x).abs() < 1e-9 && (p.y - y).abs() < 1e-9 && (p.a - a).abs() < 1e-9
    };
    assert!(
        close(est(&w, 0), -6.946, -6.947, PI / 4.0),
        "{:?}",
        est(&w, 0)
    );
    assert!(close(est(&w, 1), 0.0, 0.0, 0.0), "{:?}", est(&w, 1));
    // (2, 3) seen from (1, 1) facing +y: 2 m ahead, 1 m to the right; heading 30° - 90°
    assert!(close(est(&w, 2), 2.0, -1.0, -PI / 3.0), "{:?}", est(&w, 2));

    // Driving integrates from there; SET_ODOM then moves the estimate, not the robot.
    w.position_cmd_vel(ids[0], 0.5, 0.0, 0.0).unwrap();
    run(&mut w, 10);
    let d = 0.5 * 1.0 / 2f64.sqrt();
    assert!(
        close(est(&w, 0), -6.946 + d, -6.947 + d, PI / 4.0),
        "{:?}",
        est(&w, 0)
    );
    w.set_odom(ids[0], Pose::new(0.0, 0.0, 0.0, 0.0)).unwrap();
    w.position_cmd_vel(ids[0], 0.0, 0.0, 0.0).unwrap();
    run(&mut w, 2);
    assert!(close(est(&w, 0), 0.0, 0.0, 0.0), "{:?}", est(&w, 0));
    assert!((w.pose(ids[0]).unwrap().x - (-6.946 + d)).abs() < 1e-9);
}

/// The digest covers every model's state: a change in any one part (colour, speech, an
/// actuator's goal, a light) changes it, and replaying the same changes gives
/// the same digest again.
#[test]
fn the_digest_covers_colours_speech_actuators_cameras_and_lights() {
    let mut d = WorldDesc::default();
    d.add(wall("box", 2.0, 0.0, 0.5, 0.5, 0.5), None);
    let r = d.add(robot("r", 0.0, 0.0, 0.0, Drive::Diff), None);
    d.add(
        ModelDesc::new("cam", KindDesc::Camera(CameraDesc::default())),
        Some(r),
    );
    d.add(
        ModelDesc::new("act", KindDesc::Actuator(ActuatorDesc::default())),
        Some(r),
    );
    d.add(
        ModelDesc::new(
            "light",
            KindDesc::Blinkenlight(BlinkenlightDesc {
                period_ms: 100,
                dutycycle: 0.5,
            }),
        ),
        Some(r),
    );
    let fresh = || World::from_desc(&d, 7).unwrap();
    let id = |w: &World, n: &str| w.model_by_name(n).unwrap();
    let base = {
        let mut w = fresh();
        run(&mut w, 3);
        w.state_digest()
    };
    // the same run twice: the same digest
    let mut again = fresh();
    run(&mut again, 3);
    assert_eq!(again.state_digest(), base);
    let changed = |edit: &dyn Fn(&mut World)| {
        let mut w = fresh();
        edit(&mut w);
        run(&mut w, 3);
        w.state_digest()
    };
    let colour = changed(&|w| {
        let b = id(w, "box");
        w.set_color(b, Color::rgb(0.1, 0.2, 0.3)).unwrap()
    });
    let speech = changed(&|w| {
        let b = id(w, "r");
        w.say(b, "hello").unwrap()
    });
    let goal = changed(&|w| {
        let a = id(w, "act");
        w.subscribe(a).unwrap();
        w.actuator_cmd(a, true, 0.5).unwrap();
    });
    let light = changed(&|w| {
        let l = id(w, "light");
        w.set_light(l, true).unwrap()
    });
    let all = [base, colour, speech, goal, light];
    for (i, a) in all.iter().enumerate() {
        for b in &all[i + 1..] {
            assert_ne!(a, b, "{all:x?}");
        }
    }
}

/// A camera's digest follows its image, colour and depth alike.
#[test]
fn a_camera_digest_follows_its_pixels() {
    let mut c = crate::models::camera::CameraModel::new(CameraDesc::default());
    c.image.rgba = vec![10; 16];
    c.image.depth = vec![1.0; 4];
    let digest = |c: &crate::models::camera::CameraModel| {
        let mut d = crate::digest::Digest::new();
        crate::models::ModelKind::digest(c, &mut d);
        d.finish()
    };
    let a = digest(&c);
    c.image.rgba[5] = 11;
    let b = digest(&c);
    c.image.depth[3] = 2.0;
    let e = digest(&c);
    assert!(a != b && b != e && a != e);
}

/// The four walls (`w0` … `w3`, 0.1 m thick) of a square room around `0..span` along both
/// axes (inner faces at −0.35 m and `span` + 0.15 m).
fn room_walls(d: &mut WorldDesc, span: f64) {
    for (i, (x, y, sx, sy)) in [
        (-0.4, span / 2.0, 0.1, span + 1.0),
        (span + 0.2, span / 2.0, 0.1, span + 1.0),
        (span / 2.0, -0.4, span + 1.0, 0.1),
        (span / 2.0, span + 0.2, span + 1.0, 0.1),
    ]
    .into_iter()
    .enumerate()
    {
        d.add(wall(&format!("w{i}"), x, y, sx, sy, 1.0), None);
    }
}

/// A crowded random world for comparing the move passes: `robots` robots of random sizes on
/// a jittered lattice (neighbours touching, overlapping or a hair apart), some with a laser,
/// some that are no obstacle, between static walls; with `carried`, every seventh robot rides
/// on the robot before it.
fn crowded_world(seed: u64, robots: usize, carried: bool) -> WorldDesc {
    let mut rng = crate::rng::SimRng::new(seed, 0);
    let mut d = WorldDesc::default();
    let side = (robots as f64).sqrt().ceil() as usize;
    let pitch = 0.6;
    let span = side as f64 * pitch;
    room_walls(&mut d, span);
    d.add(wall("pillar", span / 2.0, span / 2.0, 0.3, 0.3, 1.0), None);
    let mut last = None;
    for i in 0..robots {
        let (col, row) = ((i % side) as f64, (i / side) as f64);
        let x = col * pitch + rng.uniform(-0.03, 0.03);
        let y = row * pitch + rng.uniform(-0.03, 0.03);
        let drive = if i % 5 == 0 { Drive::Omni } else { Drive::Diff };
        let mut r = robot(&format!("r{i}"), x, y, rng.uniform(-PI, PI), drive);
        let s = rng.uniform(0.3, 0.5);
        r.size = [s, rng.uniform(0.3, 0.44), 0.5];
        r.returns.obstacle = i % 11 != 3;
        let rides = carried && i % 7 == 6 && last.is_some();
        if rides {
            r.pose = Pose::new(0.0, 0.0, 0.5, 0.0);
            r.size = [0.2, 0.2, 0.2];
        }
        let id = d.add(r, if rides { last } else { None });
        if i % 4 == 1 {
            d.add(laser(8, PI, 2.0), Some(id));
        }
        last = Some(id);
    }
    d
}

/// Controllers run beside the ordered move pass (on the other thread, reading the sensor data
/// the moves leave alone) and the stalls that pass finds are recorded after it: the state is
/// bit for bit that of moving one by one and running the controllers after the moves, on a
/// crowd of wanderers that push into each other and into the walls.
#[test]
fn controllers_beside_the_moves_match_controllers_after_them() {
    let robots = 100;
    let mut d = crowded_world(4, robots, false);
    // the robots that carry a laser (crowded_world gives every fourth one) wander by it
    for i in (1..robots).step_by(4) {
        let name = format!("r{i}");
        let r = d.models.iter_mut().find(|m| m.name == name).unwrap();
        r.ctrl = vec!["wander".into()];
    }
    let pool = pool_of(2);
    pool.install(|| {
        let mut beside = World::from_desc(&d, 4).unwrap();
        let mut after = World::from_desc(&d, 4).unwrap();
        after.set_moves_one_by_one(true);
        let ids: Vec<ModelId> = (0..robots)
            .map(|i| beside.model_by_name(&format!("r{i}")).unwrap())
            .collect();
        let mut stalls = 0;
        for step in 0..150 {
            beside.step();
            after.step();
            let what = format!("step {step}");
            assert_eq!(beside.state_digest(), after.state_digest(), "{what}");
            for &id in &ids {
                let stall = beside.position_state(id).unwrap().stall;
                assert_eq!(stall, after.position_state(id).unwrap().stall, "{what}");
                stalls += stall as usize;
            }
        }
        assert!(stalls > 100, "only {stalls} stalls");
        assert!(beside.planned_moves() > 1000, "the moves were planned");
    });
}

/// The moves planned in parallel and installed in order leave every pose, stall, outline,
/// sensor reading and the dynamic grid (as sets per cell) bit for bit as one-by-one moves do,
/// step after step, on crowded worlds where robots push into each other and into walls, with
/// and without robots carried by robots (whose trees move one by one in either pass).
#[test]
fn planned_moves_match_one_by_one_moves_bit_for_bit() {
    let pool = pool_of(2);
    pool.install(|| {
        for (seed, robots, carried) in [(1, 60, false), (2, 150, false), (3, 80, true)] {
            let d = crowded_world(seed, robots, carried);
            let mut fast = World::from_desc(&d, seed).unwrap();
            let mut plain = World::from_desc(&d, seed).unwrap();
            plain.set_moves_one_by_one(true);
            let mut rng = crate::rng::SimRng::new(seed, 1);
            let ids: Vec<ModelId> = (0..robots)
                .map(|i| fast.model_by_name(&format!("r{i}")).unwrap())
                .collect();
            for w in [&mut fast, &mut plain] {
                for &id in &ids {
                    w.subscribe(id).unwrap();
                }
            }
            let mut stalls = 0;
            for step in 0..120 {
                if step % 10 == 0 {
                    for &id in &ids {
                        let v = rng.uniform(-0.3, 0.6);
                        let vy = rng.uniform(-0.2, 0.2);
                        let va = rng.uniform(-2.0, 2.0);
                        for w in [&mut fast, &mut plain] {
                            w.position_cmd_vel(id, v, vy, va).unwrap();
                        }
                    }
                }
                fast.step();
                plain.step();
                let what = format!("seed {seed}, step {step}");
                assert_eq!(fast.state_digest(), plain.state_digest(), "{what}");
                for m in 0..fast.model_count() {
                    let m = ModelId(m as u32);
                    assert_eq!(fast.pose(m).unwrap(), plain.pose(m).unwrap(), "{what}");
                    let (a, b) = (fast.body(m).unwrap(), plain.body(m).unwrap());
                    assert_eq!(a.pts, b.pts, "{what}, model {m:?}");
                    assert_eq!(a.blocks, b.blocks, "{what}, model {m:?}");
                    assert_eq!(a.aabb, b.aabb, "{what}, model {m:?}");
                }
                for &id in &ids {
                    let stall = fast.position_state(id).unwrap().stall;
                    assert_eq!(stall, plain.position_state(id).unwrap().stall, "{what}");
                    stalls += stall as usize;
                }
                assert!(
                    fast.dynamic_grid_as_sets() == plain.dynamic_grid_as_sets(),
                    "{what}: the dynamic grids differ"
                );
            }
            assert!(stalls > 1000, "seed {seed}: only {stalls} stalls");
            let planned = fast.planned_moves();
            assert!(planned > 1000, "seed {seed}: only {planned} planned moves");
            assert_eq!(plain.planned_moves(), 0, "the plain world moved one by one");
        }
    });
}
