//! `laserposeinterpolator` on the stage driver, over TCP: Bigbob's tooth laser (served as
//! `laser:0` on its one-beam ranger) and odometry in, pose-stamped scans out; requests to the
//! stamped laser are answered by the laser below it.

mod common;

use std::time::{Duration, Instant};

use player_client::{LaserProxy, PlayerClient, Position2dProxy};
use player_server::Pace;

const CFG: &str = r#"
driver( name "stage" provides ["0:simulation:0"] plugin "stageplugin" worldfile "bigbob.world" )
driver( name "laserposeinterpolator" provides ["0:laser:1"] requires ["0:laser:0" "0:position2d:0"] )
driver( name "stage" provides ["0:position2d:0" "0:laser:0"] model "bob1" )
"#;

#[test]
fn stage_scans_come_back_stamped_with_interpolated_odometry() {
    let handle = common::serve_cfg(
        &common::worlds(),
        "lpi-test.cfg",
        CFG,
        Pace::RealTime { speedup: 4.0 },
    );
    let port = handle.ports()[0];

    let client = PlayerClient::connect("localhost", port).unwrap();
    let stamped = LaserProxy::new(&client, 1).unwrap();
    // The request goes through the interpolator to the stage laser and back.
    let geom = stamped.request_geom().unwrap();
    let raw = LaserProxy::new(&client, 0).unwrap();
    assert_eq!(geom, raw.request_geom().unwrap());
    let base = Position2dProxy::new(&client, 0).unwrap();
    base.set_speed(0.4, 0.0, 0.3).unwrap();

    let deadline = Instant::now() + Duration::from_secs(10);
    let mut seen = 0;
    let mut last_t = f64::NEG_INFINITY;
    while seen < 5 {
        assert!(
            Instant::now() < deadline,
            "only {seen} stamped scans arrived"
        );
        client.read().unwrap();
        if !stamped.is_fresh() {
            continue;
        }
        stamped.not_fresh();
        let Some(sp) = stamped.scan_pose() else {
            continue;
        };
        // One beam, as the tooth laser has; a pose stamped from odometry that is moving.
        assert_eq!(
            sp.scan.ranges.len(),
            raw.scan().map_or(1, |s| s.ranges.len())
        );
        let t = stamped.datatime();
        assert!(t > last_t, "scans stay in time order");
        last_t = t;
        let odom = base.pose();
        assert!(
            (sp.pose.px - odom.px).abs() < 0.5 && (sp.pose.py - odom.py).abs() < 0.5,
            "stamped pose {:?} far from odometry {:?}",
            sp.pose,
            odom
        );
        seen += 1;
    }
    base.set_speed(0.0, 0.0, 0.0).unwrap();
    drop((stamped, raw, base));
    drop(client);
    handle.shutdown();
}
