//! `fiducial` on a Stage `fiducial` finder (player-protocol.md §6.4, stage-models.md §10.3).

use std::ops::Deref;

use player_proto::{
    Bbox2d, Bbox3d, Body, FiducialData, FiducialDataScan, FiducialGeom, FiducialId, FiducialItem,
    FiducialMsg, FiducialReq, Pose3d,
};
use stage_sim::World;

use super::{Bound, Interface, Out, Writing};
use crate::driver::Reply;

/// A `fiducial` device.
#[derive(Debug, Default)]
pub(super) struct Fiducial;

impl Interface for Fiducial {
    /// DATA SCAN, also when nothing is seen: per detection its id and its position in the sensor
    /// frame (range and bearing) with the target's relative heading; `upose` (left uninitialised
    /// by Stage) is zero.
    fn publish(&mut self, b: &Bound<'_, &World>, out: &mut Out<'_, '_>) -> Option<()> {
        let data = out.new_sample(b.answer(b.world.fiducials(b.model)), |s| s.time_us)?;
        let fiducials = data
            .fiducials
            .iter()
            .map(|f| FiducialItem {
                id: f.id,
                pose: Pose3d {
                    px: f.range * f.bearing.cos(),
                    py: f.range * f.bearing.sin(),
                    pyaw: f.heading,
                    ..Pose3d::default()
                },
                upose: Pose3d::default(),
            })
            .collect();
        out.publish(FiducialData::Scan(FiducialDataScan { fiducials }));
        Some(())
    }

    fn request(&mut self, b: &mut Writing<'_>, body: &Body) -> Reply {
        let Body::Fiducial(FiducialMsg::Req(req)) = body else {
            return Reply::NotHandled;
        };
        match req {
            FiducialReq::GetGeom(None) => Reply::ack(FiducialReq::GetGeom(Some(geometry(b)))),
            // The finder's own fiducial return: the sensor itself becomes a beacon.
            FiducialReq::GetId(_) => match b.answer(b.world.fiducial_id(b.model)) {
                Some(id) => Reply::ack(FiducialReq::GetId(Some(FiducialId { id: id as u32 }))),
                None => Reply::Nack,
            },
            FiducialReq::SetId(Some(FiducialId { id })) => {
                let set = b.world.set_fiducial_id(b.model, *id as i32);
                match b.answer(set) {
                    Some(()) => Reply::ack(FiducialReq::SetId(Some(FiducialId { id: *id }))),
                    None => Reply::Nack,
                }
            }
            // FOV requests: NACK, as Stage.
            _ => Reply::NotHandled,
        }
    }
}

/// GET_GEOM: the finder's pose in its parent and its size; Stage fills only a laser-sized
/// part of the struct, so the height and the fiducial size are 0.
fn geometry<W: Deref<Target = World>>(b: &Bound<'_, W>) -> FiducialGeom {
    FiducialGeom {
        pose: b.local_pose3d(),
        size: Bbox3d {
            sh: 0.0,
            ..b.bbox()
        },
        fiducial_size: Bbox2d::default(),
    }
}
