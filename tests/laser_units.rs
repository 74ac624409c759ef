//! A laser SET_CONFIG in Player 2's units (issue 40): libplayerc's own laser test
//! (`test_laser.c`) sends `resolution 100, range_res 1`, meant as hundredths of a degree and
//! millimetres. Player 3 reads every field in radians and metres, and the LMS200 driver refuses
//! it; our laser on a Stage ranger had taken it and floored every client's ranges to whole
//! metres. It must be refused, and the data other clients read must stay as simulated.
//!
//! The same runs as a libplayerc program (`examples/c/laser_units.c`) when `pkg-config` finds
//! `playerc` (skipped with a message otherwise).

mod common;

use std::time::{Duration, Instant};

use common::{
    assert_example_ok, build_example, pioneer_odom_cfg, player_2_units_laser_request, run_bounded,
    serve_cfg, serve_cfg_with_drivers,
};
use player_client::{ClientError, LaserProxy, PlayerClient};
use player_proto::LaserConfig;
use player_server::Pace;

/// The next scan `laser` receives (fails after 10 s).
fn next_scan(client: &PlayerClient, laser: &LaserProxy) -> Vec<f32> {
    laser.not_fresh();
    let start = Instant::now();
    while !laser.is_fresh() {
        match client.read() {
            Ok(()) | Err(ClientError::Overflow { .. } | ClientError::NoData) => {}
            Err(e) => panic!("reading a scan: {e}"),
        }
        assert!(start.elapsed() < Duration::from_secs(10), "no scan");
    }
    laser.ranges()
}

/// Ranges that are not all whole metres (the wall 2.85 m east of `r0` is seen at 45°).
fn fractional(ranges: &[f32]) -> usize {
    ranges.iter().filter(|r| r.fract() != 0.0).count()
}

#[test]
fn a_laser_config_in_player_2_units_is_refused_and_others_keep_their_ranges() {
    let (cfg, dir) = pioneer_odom_cfg("laser-units");
    let server = serve_cfg(&cfg, Pace::AsFastAsPossible);
    let reader = PlayerClient::connect("localhost", server.port(6665)).unwrap();
    let reading = LaserProxy::new(&reader, 0).unwrap();
    let before = next_scan(&reader, &reading);
    assert_eq!(before.len(), 180);
    assert!(fractional(&before) > 100, "{before:?}");
    let default = reading.request_config().unwrap();

    let tester = PlayerClient::connect("localhost", server.port(6665)).unwrap();
    let testing = LaserProxy::new(&tester, 0).unwrap();
    let err = testing
        .configure(player_2_units_laser_request())
        .unwrap_err();
    assert!(matches!(err, ClientError::Nack { .. }), "{err:?}");
    // Radians, but ranges in whole metres: no LMS200 unit either.
    let metres = LaserConfig {
        resolution: default.resolution,
        ..player_2_units_laser_request()
    };
    let err = testing.configure(metres).unwrap_err();
    assert!(matches!(err, ClientError::Nack { .. }), "{err:?}");
    assert_eq!(
        testing.request_config().unwrap(),
        default,
        "nothing changed"
    );

    // The robot stands still: the other client's ranges are the same, unfloored.
    for _ in 0..3 {
        let after = next_scan(&reader, &reading);
        assert_eq!(after, before);
    }
    drop(server);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Upstream's `rangertolaser` forwards the request unchanged as a ranger SET_CONFIG (and
/// INTNS), which Stage's ranger refuses: the laser client gets a NACK, and the scans stay.
#[test]
fn rangertolaser_on_a_stage_ranger_refuses_it_too() {
    let (_, dir) = pioneer_odom_cfg("laser-units-r2l");
    let cfg = dir.join("rangertolaser.cfg");
    std::fs::write(
        &cfg,
        "driver( name \"stage\" provides [\"simulation:0\"] worldfile \"pioneer.world\" )\n\
         driver( name \"stage\" provides [\"ranger:0\"] model \"r0\" )\n\
         driver( name \"rangertolaser\" requires [\"ranger:0\"] provides [\"laser:0\"] )\n",
    )
    .unwrap();
    let server = serve_cfg_with_drivers(&cfg, Pace::AsFastAsPossible);
    let reader = PlayerClient::connect("localhost", server.port(6665)).unwrap();
    let reading = LaserProxy::new(&reader, 0).unwrap();
    let before = next_scan(&reader, &reading);
    assert_eq!(before.len(), 180);
    assert!(fractional(&before) > 100, "{before:?}");

    let tester = PlayerClient::connect("localhost", server.port(6665)).unwrap();
    let testing = LaserProxy::new(&tester, 0).unwrap();
    let err = testing
        .configure(player_2_units_laser_request())
        .unwrap_err();
    assert!(matches!(err, ClientError::Nack { .. }), "{err:?}");
    for _ in 0..3 {
        assert_eq!(next_scan(&reader, &reading), before);
    }
    drop(server);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `examples/c/laser_units.c`: two libplayerc clients, one sending `test_laser.c`'s request,
/// the other reading; exits non-zero when the request is accepted or the ranges change.
#[test]
fn libplayerc_laser_config_in_player_2_units_is_refused() {
    if !test_support::pkg_config_finds(&["playerc"], "the libplayerc laser units test") {
        return;
    }
    let program = build_example("c", "laser_units");
    let (cfg, dir) = pioneer_odom_cfg("laser-units-c");
    let server = serve_cfg(&cfg, Pace::RealTime { speedup: 5.0 });
    let args = ["localhost".to_string(), server.port(6665).to_string()];
    let out = run_bounded(&program, &args, Duration::from_secs(60));
    drop(server);
    let _ = std::fs::remove_dir_all(program.parent().unwrap());
    let _ = std::fs::remove_dir_all(&dir);
    assert_example_ok("laser_units", &out);
}
