//! The legacy `sonar` interface (Player 2 / Stage 3) on a Stage 4 ranger: one range per
//! transducer (player-protocol.md §6.9). Stage 4.1.1 dropped it; Player 2 clients still use
//! `SonarProxy`.

use std::ops::Deref;

use player_proto::{Body, SonarData, SonarDataRanges, SonarGeom, SonarMsg, SonarReq};
use stage_sim::{Pose, World};

use super::{Bound, Interface, Out, Writing, pose3d, ranger};
use crate::driver::Reply;

/// A `sonar` device.
#[derive(Debug, Default)]
pub(super) struct Sonar;

impl Interface for Sonar {
    fn request(&mut self, b: &mut Writing<'_>, body: &Body) -> Reply {
        match body {
            Body::Sonar(SonarMsg::Req(SonarReq::GetGeom(None))) => {
                Reply::ack(SonarReq::GetGeom(Some(geometry(b))))
            }
            // POWER: refused, as the ranger's.
            _ => Reply::NotHandled,
        }
    }

    /// DATA RANGES: the first sample of each transducer, as floats.
    fn publish(&mut self, b: &Bound<'_, &World>, out: &mut Out<'_, '_>) -> Option<()> {
        let data = out.new_sample(b.answer(b.world.ranger_scans(b.model)), |s| s.time_us)?;
        let ranges: Vec<f32> = data.first_ranges().flatten().map(|r| r as f32).collect();
        if !ranges.is_empty() {
            out.publish(SonarData::Ranges(SonarDataRanges { ranges }));
        }
        Some(())
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
