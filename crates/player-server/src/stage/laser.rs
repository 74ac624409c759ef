//! The legacy `laser` interface (Player 2 / Stage 3) on a Stage 4 ranger: the scan of its first
//! transducer (player-protocol.md §6.8). Stage 4.1.1 dropped it; clients written for Player 2
//! still use `LaserProxy`.

use std::ops::Deref;

use player_proto::{
    Bbox3d, Body, LaserConfig, LaserData, LaserDataScan, LaserGeom, LaserGetIdConfig, LaserMsg,
    LaserReq,
};
use stage_sim::{Pose, SensorDesc, World};

use super::{Bound, Out, pose3d, ranger};
use crate::driver::Reply;

/// The scan's angular layout: first bearing, last bearing and the step between rays, as the
/// simulator casts them (first and last ray at ±fov/2).
fn fan(s: &SensorDesc) -> (f64, f64, f64) {
    if s.samples > 1 {
        (-s.fov / 2.0, s.fov / 2.0, s.fov / f64::from(s.samples - 1))
    } else {
        (0.0, 0.0, 0.0)
    }
}

/// A ranger intensity (the hit model's `ranger_return`) as a laser intensity byte.
fn intensity_byte(v: f64) -> u8 {
    v.round().clamp(0.0, 255.0) as u8
}

/// DATA SCAN: the first transducer's ranges (floats, never negative: libplayerc asserts it) and
/// intensities, with its fan; `id` counts the scans.
pub(super) fn publish<W: Deref<Target = World>>(
    b: &Bound<'_, W>,
    out: &mut Out<'_, '_>,
    scan_id: u32,
) {
    let Some(data) = b.world.ranger_scans(b.model) else {
        return;
    };
    let (Some(sensor), Some(scan)) = (data.sensors.first(), data.scans.first()) else {
        return;
    };
    let (min_angle, max_angle, resolution) = fan(sensor);
    out.publish(LaserData::Scan(LaserDataScan {
        min_angle: min_angle as f32,
        max_angle: max_angle as f32,
        resolution: resolution as f32,
        max_range: sensor.range[1] as f32,
        ranges: scan.ranges.iter().map(|&r| r.max(0.0) as f32).collect(),
        intensity: scan
            .intensities
            .iter()
            .map(|&v| intensity_byte(v))
            .collect(),
        id: scan_id,
    }));
}

/// GET_GEOM: the first transducer's pose in the robot (the ranger's pose composed with the
/// transducer's) and size.
fn geometry<W: Deref<Target = World>>(b: &Bound<'_, W>) -> Option<LaserGeom> {
    let sensor = ranger::sensors(b).into_iter().next()?;
    let [x, y, z, a] = sensor.pose;
    let pose = b.world.pose(b.model).compose(&Pose { x, y, z, a });
    Some(LaserGeom {
        pose: pose3d(&pose),
        size: Bbox3d {
            sw: sensor.size[1],
            sl: sensor.size[0],
            sh: sensor.size[2],
        },
    })
}

fn config<W: Deref<Target = World>>(b: &Bound<'_, W>) -> Option<LaserConfig> {
    let data = b.world.ranger_scans(b.model)?;
    let sensor = data.sensors.first()?;
    let (min_angle, max_angle, resolution) = fan(sensor);
    let interval_us = b.world.node(b.model).update_interval_us.max(1);
    Some(LaserConfig {
        min_angle: min_angle as f32,
        max_angle: max_angle as f32,
        resolution: resolution as f32,
        max_range: sensor.range[1] as f32,
        range_res: b.world.config().resolution as f32,
        intensity: 1,
        scanning_frequency: (1e6 / interval_us as f64) as f32,
    })
}

pub(super) fn request<W: Deref<Target = World>>(b: &Bound<'_, W>, body: &Body) -> Reply {
    let Body::Laser(LaserMsg::Req(req)) = body else {
        return Reply::NotHandled;
    };
    match req {
        LaserReq::GetGeom(None) => match geometry(b) {
            Some(g) => Reply::ack(LaserReq::GetGeom(Some(g))),
            None => Reply::Nack,
        },
        LaserReq::GetConfig(None) => match config(b) {
            Some(c) => Reply::ack(LaserReq::GetConfig(Some(c))),
            None => Reply::Nack,
        },
        LaserReq::GetId(_) => Reply::ack(LaserReq::GetId(Some(LaserGetIdConfig {
            serial_number: b.model.0,
        }))),
        // The transducer's fan is fixed by the worldfile: SET_CONFIG, POWER and filters are
        // refused rather than acknowledged without effect.
        _ => Reply::NotHandled,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fan_matches_the_simulated_rays() {
        let s = SensorDesc {
            fov: 1.0,
            samples: 5,
            ..SensorDesc::default()
        };
        assert_eq!(fan(&s), (-0.5, 0.5, 0.25));
        let one = SensorDesc {
            samples: 1,
            ..s.clone()
        };
        assert_eq!(fan(&one), (0.0, 0.0, 0.0));
        assert_eq!(intensity_byte(0.5), 1);
        assert_eq!(intensity_byte(0.0), 0);
        assert_eq!(intensity_byte(300.0), 255);
        assert_eq!(intensity_byte(-1.0), 0);
    }
}
