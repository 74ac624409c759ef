use super::*;
use player_proto::{Pose2d, Position2dDataState};

fn addr(interf: InterfaceCode, index: u16) -> DeviceAddr {
    DeviceAddr::new(0, 6665, interf, index)
}

fn block(provides: &[DeviceAddr], requires: &[(Option<&str>, DeviceAddr)]) -> DriverBlock {
    DriverBlock::new(NAME, "vfh.cfg:27")
        .providing(provides.iter().copied(), "vfh.cfg:30")
        .requiring(requires.iter().copied(), "vfh.cfg:31")
}

fn stage_block() -> DriverBlock {
    block(
        &[addr(InterfaceCode::POSITION2D, 1)],
        &[
            (None, addr(InterfaceCode::POSITION2D, 0)),
            (None, addr(InterfaceCode::LASER, 0)),
        ],
    )
}

fn set(block: &mut DriverBlock, key: &str, value: &str) {
    block.options.insert(key.into(), vec![value.into()]);
}

#[test]
fn defaults_are_player_3_0_2s() {
    let s = Settings::default();
    let p = &s.algorithm;
    assert_eq!(p.cell_width, 100.0);
    assert_eq!(p.window_diameter, 61);
    assert_eq!(p.sector_angle, 5);
    assert_eq!((p.safety_dist_0ms, p.safety_dist_1ms), (100.0, 100.0));
    assert_eq!(
        (
            p.max_speed,
            p.max_speed_narrow_opening,
            p.max_speed_wide_opening
        ),
        (200, 200, 200)
    );
    assert_eq!(p.max_acceleration, 200);
    assert_eq!(
        (p.min_turnrate, p.max_turnrate_0ms, p.max_turnrate_1ms),
        (10, 40, 40)
    );
    assert_eq!(p.min_turn_radius_safety_factor, 1.0);
    assert_eq!(p.free_space_cutoff_0ms, 2_000_000.0);
    assert_eq!(p.obs_cutoff_0ms, 2_000_000.0);
    assert_eq!(p.free_space_cutoff_1ms, 2_000_000.0);
    assert_eq!(p.obs_cutoff_1ms, 2_000_000.0);
    assert_eq!((p.weight_desired_dir, p.weight_current_dir), (5.0, 3.0));
    assert_eq!(s.goal, GoalSettings::default());
    assert_eq!(s.goal.distance_epsilon, 0.5);
    assert!((s.goal.angle_epsilon - 10f64.to_radians()).abs() < 1e-15);
    assert_eq!(
        (
            s.goal.escape_speed,
            s.goal.escape_time,
            s.goal.escape_max_turnrate
        ),
        (0.0, 0.0, 0.0)
    );
    assert!(!s.synchronous);
}

#[test]
fn derived_defaults_follow_the_options_they_come_from() {
    // Stage's vfh.cfg.
    let mut b = stage_block();
    set(&mut b, "max_speed", "0.3");
    set(&mut b, "max_turnrate_0ms", "90");
    set(&mut b, "max_turnrate_1ms", "35");
    let p = Settings::from_block(&b).unwrap().algorithm;
    assert_eq!(
        (
            p.max_speed,
            p.max_speed_narrow_opening,
            p.max_speed_wide_opening
        ),
        (300, 300, 300)
    );
    assert_eq!((p.max_turnrate_0ms, p.max_turnrate_1ms), (90, 35));

    let mut b = stage_block();
    set(&mut b, "safety_dist_0ms", "0.2");
    set(&mut b, "max_turnrate_0ms", "50.4");
    set(&mut b, "free_space_cutoff_0ms", "1000");
    set(&mut b, "free_space_cutoff_1ms", "500");
    let p = Settings::from_block(&b).unwrap().algorithm;
    assert_eq!((p.safety_dist_0ms, p.safety_dist_1ms), (200.0, 200.0));
    assert_eq!(
        (p.max_turnrate_0ms, p.max_turnrate_1ms),
        (50, 50),
        "whole deg/s"
    );
    assert_eq!(p.obs_cutoff_0ms, 1000.0);
    assert_eq!(p.free_space_cutoff_1ms, 500.0);
    assert_eq!(p.obs_cutoff_1ms, 500.0, "follows free_space_cutoff_1ms");
}

#[test]
fn angles_are_read_in_degrees_and_lengths_in_metres() {
    let mut b = stage_block();
    set(&mut b, "angle_epsilon", "5");
    set(&mut b, "distance_epsilon", "0.3");
    set(&mut b, "escape_max_turnrate", "30");
    set(&mut b, "escape_speed", "-0.1");
    set(&mut b, "escape_time", "2");
    set(&mut b, "cell_size", "0.05");
    set(&mut b, "synchronous", "1");
    let s = Settings::from_block(&b).unwrap();
    assert!((s.goal.angle_epsilon - 5f64.to_radians()).abs() < 1e-15);
    assert_eq!(s.goal.distance_epsilon, 0.3);
    assert!((s.goal.escape_max_turnrate - 30f64.to_radians()).abs() < 1e-15);
    assert_eq!((s.goal.escape_speed, s.goal.escape_time), (-0.1, 2.0));
    assert_eq!(s.algorithm.cell_width, 50.0);
    assert!(s.synchronous);
}

#[test]
fn a_cfg_in_millimetres_and_radians_is_read_as_player_reads_it() {
    let mut b = stage_block();
    b.units = worldfile::Units {
        length: 0.001,
        angle: 1.0,
    };
    for (key, value) in [
        ("cell_size", "50"),
        ("max_speed", "300"),
        ("max_turnrate_0ms", "1"),
        ("angle_epsilon", "0.1"),
        ("escape_time", "2"),
        ("free_space_cutoff_0ms", "1000"),
        ("sector_angle", "5"),
    ] {
        set(&mut b, key, value);
    }
    let s = Settings::from_block(&b).unwrap();
    assert_eq!(s.algorithm.cell_width, 50.0);
    assert_eq!(s.algorithm.max_speed, 300);
    // 1 rad/s is 57.3 deg/s, kept whole.
    assert_eq!(s.algorithm.max_turnrate_0ms, 57);
    assert_eq!(s.goal.angle_epsilon, 0.1);
    // Plain numbers (seconds, cutoffs, integer degrees) are not scaled.
    assert_eq!(s.goal.escape_time, 2.0);
    assert_eq!(s.algorithm.free_space_cutoff_0ms, 1000.0);
    assert_eq!(s.algorithm.sector_angle, 5);
}

#[test]
fn bad_options_are_refused_with_their_name() {
    for (key, value) in [
        ("sector_angle", "0"),
        ("sector_angle", "2.5"),
        ("window_diameter", "0"),
        ("window_diameter", "100000"),
        ("cell_size", "0"),
        ("max_speed", "1e9"),
        ("max_speed", "-1"),
        ("weight_desired_dir", "heavy"),
    ] {
        let mut b = stage_block();
        set(&mut b, key, value);
        let e = Settings::from_block(&b).unwrap_err().to_string();
        assert!(e.contains(key), "{key} {value}: {e}");
    }
}

#[test]
fn requires_a_base_and_exactly_one_range_sensor() {
    let p1 = addr(InterfaceCode::POSITION2D, 1);
    let p0 = addr(InterfaceCode::POSITION2D, 0);
    let laser = addr(InterfaceCode::LASER, 0);
    let sonar = addr(InterfaceCode::SONAR, 0);
    let err = |b: DriverBlock| VfhDriver::from_block(&b).unwrap_err().to_string();

    let d = VfhDriver::from_block(&stage_block()).unwrap();
    assert_eq!(
        (d.addr, d.odom, d.sensor),
        (p1, p0, RangeSensor::Laser(laser))
    );
    let d = VfhDriver::from_block(&block(&[p1], &[(None, p0), (None, sonar)])).unwrap();
    assert_eq!(d.sensor, RangeSensor::Sonar(sonar));
    // Keyed entries count too, as upstream looks them up without a key.
    let d = VfhDriver::from_block(&block(
        &[p1],
        &[(Some("odometry"), p0), (Some("laser"), laser)],
    ))
    .unwrap();
    assert_eq!((d.odom, d.sensor), (p0, RangeSensor::Laser(laser)));

    assert!(err(block(&[p1], &[(None, p0)])).contains("exactly one sonar or one laser"));
    assert!(
        err(block(&[p1], &[(None, p0), (None, laser), (None, sonar)]))
            .contains("exactly one sonar or one laser")
    );
    assert!(err(block(&[p1], &[(None, laser)])).contains("requires a position2d"));
    assert!(err(block(&[laser], &[(None, p0), (None, laser)])).contains("provide a position2d"));
    assert!(err(block(&[p1], &[(None, p1), (None, laser)])).contains("subscribe to self"));
    let planner = addr(InterfaceCode::PLANNER, 0);
    assert!(err(block(&[p1, planner], &[(None, p0), (None, laser)])).contains("planner"));
}

#[test]
fn odometry_is_republished_with_its_timestamp() {
    let mut d = VfhDriver::from_block(&stage_block()).unwrap();
    let state = Position2dDataState {
        pos: Pose2d {
            px: 1.0,
            py: 2.0,
            pa: 0.5,
        },
        vel: Pose2d {
            px: 0.25,
            py: 0.0,
            pa: 0.0,
        },
        stall: 1,
    };
    let data = Message::new(
        addr(InterfaceCode::POSITION2D, 0),
        12.5,
        Position2dData::State(state.clone()),
    );
    let mut published = Vec::new();
    let mut ctx = Context::new(13.0, None, &mut published);
    d.handle_data(&mut ctx, &data);
    drop(ctx);
    assert_eq!(published.len(), 1);
    assert_eq!(published[0].addr, addr(InterfaceCode::POSITION2D, 1));
    assert_eq!(published[0].timestamp, Some(12.5));
    assert_eq!(published[0].body, Body::from(Position2dData::State(state)));
    assert_eq!(
        d.odometry,
        Some(Odometry {
            pose: Pose2d {
                px: 1.0,
                py: 2.0,
                pa: 0.5
            },
            speed: 0.25,
            stall: true,
        })
    );
}

#[test]
fn scans_from_the_required_laser_fill_the_range_table() {
    let mut d = VfhDriver::from_block(&stage_block()).unwrap();
    let scan = player_proto::LaserDataScan {
        min_angle: -std::f32::consts::FRAC_PI_2,
        max_angle: std::f32::consts::FRAC_PI_2,
        resolution: 1f32.to_radians(),
        max_range: 8.0,
        ranges: vec![1.5; 181],
        intensity: vec![0; 181],
        id: 0,
    };
    let mut published = Vec::new();
    let mut ctx = Context::new(0.0, None, &mut published);
    // Another laser's scans are not ours.
    d.handle_data(
        &mut ctx,
        &Message::new(
            addr(InterfaceCode::LASER, 3),
            0.0,
            LaserData::Scan(scan.clone()),
        ),
    );
    assert!(d.ranges.is_none());
    d.handle_data(
        &mut ctx,
        &Message::new(addr(InterfaceCode::LASER, 0), 0.0, LaserData::Scan(scan)),
    );
    drop(ctx);
    assert!(d.ranges.unwrap().iter().all(|&r| r == 1500.0));
    assert!(published.is_empty(), "scans are not republished");
}
