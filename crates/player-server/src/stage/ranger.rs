//! `ranger` on a Stage `ranger` model (player-protocol.md §6.2, stage-models.md §8.3).

use std::ops::Deref;

use player_proto::{
    Bbox3d, Body, RangerConfig, RangerData, RangerDataIntns, RangerDataRange, RangerGeom,
    RangerMsg, RangerReq,
};
use stage_sim::World;
use worldfile::TypeSpec;

use super::{Bound, Interface, Out, Writing, spec_pose3d};
use crate::driver::Reply;

/// A `ranger` device.
#[derive(Debug, Default)]
pub(super) struct Ranger;

impl Interface for Ranger {
    /// RANGE then INTNS, each only when it has values (none before the first scan). One
    /// transducer: all its samples; several: the first sample of each.
    fn publish(&mut self, b: &Bound<'_, &World>, out: &mut Out<'_, '_>) -> Option<()> {
        let data = out.new_sample(b.answer(b.world.ranger_scans(b.model)), |s| s.time_us)?;
        let ranges = super::convert::ranger_ranges(data);
        if !ranges.is_empty() {
            out.publish(RangerData::Range(RangerDataRange { ranges }));
        }
        let intensities = super::convert::ranger_intensities(data);
        if !intensities.is_empty() {
            out.publish(RangerData::Intns(RangerDataIntns { intensities }));
        }
        Some(())
    }

    fn request(&mut self, b: &mut Writing<'_>, body: &Body) -> Reply {
        match body {
            Body::Ranger(RangerMsg::Req(RangerReq::GetGeom(None))) => {
                Reply::ack(RangerReq::GetGeom(Some(geometry(b))))
            }
            Body::Ranger(RangerMsg::Req(RangerReq::GetConfig(None))) => match config(b) {
                Some(c) => Reply::ack(RangerReq::GetConfig(Some(c))),
                // Stage crashes on a ranger without transducers.
                None => Reply::Nack,
            },
            // POWER, INTNS, SET_CONFIG: NACK, as Stage.
            _ => Reply::NotHandled,
        }
    }
}

/// The transducers as written in the worldfile (poses exactly as Stage reports them, heading
/// not normalised); a Stage 3 `laser` model is one transducer.
pub(super) fn sensors<W: Deref<Target = World>>(
    b: &Bound<'_, W>,
) -> Vec<worldfile::models::SensorSpec> {
    match &b.model_spec().spec {
        TypeSpec::Ranger(r) => r.sensors.clone(),
        TypeSpec::Laser(l) => vec![l.as_sensor()],
        _ => Vec::new(),
    }
}

/// GET_GEOM: the ranger's pose in its parent, its size, and per transducer its pose and size
/// (with Stage's width/length swap for the transducer sizes).
pub(super) fn geometry<W: Deref<Target = World>>(b: &Bound<'_, W>) -> RangerGeom {
    let mut pose = b.local_pose3d();
    pose.pz = 0.0;
    let sensors = sensors(b);
    RangerGeom {
        pose,
        size: Bbox3d {
            sh: 0.0,
            ..b.bbox()
        },
        element_poses: sensors.iter().map(|s| spec_pose3d(&s.pose)).collect(),
        element_sizes: sensors
            .iter()
            // Stage reports a transducer's size with x as the width (its plugin's order)
            .map(|s| Bbox3d {
                sw: s.size[0],
                sl: s.size[1],
                sh: s.size[2],
            })
            .collect(),
    }
}

/// GET_CONFIG: the first transducer only, with Stage's `fov / samples` resolution.
fn config<W: Deref<Target = World>>(b: &Bound<'_, W>) -> Option<RangerConfig> {
    let data = b.answer(b.world.ranger_scans(b.model))?;
    let s = data.sensors.first()?;
    let interval_us = b.node().update_interval_us.max(1);
    Some(RangerConfig {
        min_angle: -s.fov / 2.0,
        max_angle: s.fov / 2.0,
        angular_res: s.fov / f64::from(s.samples.max(1)),
        min_range: s.range[0],
        max_range: s.range[1],
        range_res: b.world.config().resolution,
        frequency: 1e6 / interval_us as f64,
    })
}
