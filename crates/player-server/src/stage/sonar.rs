//! The legacy `sonar` interface (Player 2 / Stage 3) on a Stage 4 ranger: one range per
//! transducer (player-protocol.md §6.9). Stage 4.1.1 dropped it; Player 2 clients still use
//! `SonarProxy`.

use std::ops::Deref;

use player_proto::{Body, SonarData, SonarDataRanges, SonarGeom, SonarMsg, SonarReq};
use stage_sim::{Pose, World};

use super::{Bound, Out, pose3d, ranger};
use crate::driver::Reply;

/// DATA RANGES: the first sample of each transducer, as floats.
pub(super) fn publish<W: Deref<Target = World>>(b: &Bound<'_, W>, out: &mut Out<'_, '_>) {
    let Some(data) = b.answer(b.world.ranger_scans(b.model)) else {
        return;
    };
    let ranges: Vec<f32> = data
        .scans
        .iter()
        .filter_map(|s| s.ranges.first())
        .map(|&r| r as f32)
        .collect();
    if !ranges.is_empty() {
        out.publish(SonarData::Ranges(SonarDataRanges { ranges }));
    }
}

/// GET_GEOM: each transducer's pose in the robot (the ranger's pose composed with it).
fn geometry<W: Deref<Target = World>>(b: &Bound<'_, W>) -> SonarGeom {
    let base = b.pose();
    SonarGeom {
        poses: ranger::sensors(b)
            .iter()
            .map(|s| {
                let [x, y, z, a] = s.pose;
                pose3d(&base.compose(&Pose { x, y, z, a }))
            })
            .collect(),
    }
}

pub(super) fn request<W: Deref<Target = World>>(b: &Bound<'_, W>, body: &Body) -> Reply {
    match body {
        Body::Sonar(SonarMsg::Req(SonarReq::GetGeom(None))) => {
            Reply::ack(SonarReq::GetGeom(Some(geometry(b))))
        }
        // POWER: refused, as the ranger's.
        _ => Reply::NotHandled,
    }
}
