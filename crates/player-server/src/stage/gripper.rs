//! `gripper` on a Stage `gripper` (player-protocol.md §6.5, stage-models.md §11.4).

use std::ops::Deref;

use player_proto::constants::{
    PLAYER_GRIPPER_STATE_CLOSED, PLAYER_GRIPPER_STATE_MOVING, PLAYER_GRIPPER_STATE_OPEN,
};
use player_proto::{
    Bbox3d, Body, GripperCmd as PlayerGripperCmd, GripperData, GripperDataState, GripperGeom,
    GripperMsg, GripperReq,
};
use stage_sim::{GripperCmd, PaddleState, World};

use super::{Bound, Interface, Out, Sender, Writing};
use crate::driver::Reply;

/// Player's `beams` bits: 0x04 for break beam 0, 0x08 for break beam 1.
const BEAM_BITS: [u32; 2] = [0x04, 0x08];

/// A `gripper` device.
#[derive(Debug, Default)]
pub(super) struct Gripper;

impl Interface for Gripper {
    /// DATA STATE: paddle state, the break-beam bits; `stored` is always 0 in Stage.
    fn publish(&mut self, b: &Bound<'_, &World>, out: &mut Out<'_, '_>) -> Option<()> {
        let s = out.new_sample(b.answer(b.world.gripper_state(b.model)), |s| s.time_us)?;
        let state = match s.paddles {
            PaddleState::Open => PLAYER_GRIPPER_STATE_OPEN,
            PaddleState::Closed => PLAYER_GRIPPER_STATE_CLOSED,
            PaddleState::Opening | PaddleState::Closing => PLAYER_GRIPPER_STATE_MOVING,
        };
        let beams = s
            .beams
            .iter()
            .zip(BEAM_BITS)
            .filter(|(hit, _)| hit.is_some())
            .fold(0, |acc, (_, bit)| acc | bit);
        out.publish(GripperData::State(GripperDataState {
            state,
            beams,
            stored: 0,
        }));
        Some(())
    }

    fn request(&mut self, b: &mut Writing<'_>, body: &Body) -> Reply {
        match body {
            Body::Gripper(GripperMsg::Req(GripperReq::GetGeom(None))) => {
                Reply::ack(GripperReq::GetGeom(Some(geometry(b))))
            }
            _ => Reply::NotHandled,
        }
    }

    /// OPEN and CLOSE; STOP, STORE and RETRIEVE are ignored as by Stage.
    fn command(&mut self, b: &mut Writing<'_>, _sender: &Sender<'_>, body: &Body) -> bool {
        let cmd = match body {
            Body::Gripper(GripperMsg::Cmd(PlayerGripperCmd::Open)) => GripperCmd::Open,
            Body::Gripper(GripperMsg::Cmd(PlayerGripperCmd::Close)) => GripperCmd::Close,
            _ => return false,
        };
        b.world.gripper_cmd(b.model, cmd).is_ok()
    }
}

/// GET_GEOM: the gripper's pose in its parent and size; two beams, no capacity.
fn geometry<W: Deref<Target = World>>(b: &Bound<'_, W>) -> GripperGeom {
    GripperGeom {
        pose: b.local_pose3d(),
        outer_size: b.bbox(),
        inner_size: Bbox3d::default(),
        num_beams: 2,
        capacity: 0,
    }
}
