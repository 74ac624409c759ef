//! `position2d` on a Stage `position` model (player-protocol.md §6.1, stage-models.md §7.10).

use std::ops::Deref;

use player_proto::{
    Body, Pose2d, Pose3d, Position2dCmd, Position2dData, Position2dDataState, Position2dGeom,
    Position2dMsg, Position2dReq,
};
use stage_sim::{Pose, World};

use super::{Bound, Interface, Out, Sender, Writing};
use crate::driver::Reply;

/// A `position2d` device.
#[derive(Debug, Default)]
pub(super) struct Position;

impl Interface for Position {
    fn request(&mut self, b: &mut Writing<'_>, body: &Body) -> Reply {
        let Body::Position2d(Position2dMsg::Req(req)) = body else {
            return Reply::NotHandled;
        };
        let m = b.model;
        match req {
            Position2dReq::GetGeom(None) => Reply::ack(Position2dReq::GetGeom(Some(geometry(b)))),
            // Stage acknowledges and ignores motor power and position mode.
            Position2dReq::MotorPower(Some(_)) | Position2dReq::PositionMode(Some(_)) => {
                Reply::empty_ack()
            }
            Position2dReq::SetOdom(Some(o)) => {
                let p = Pose::new(o.pose.px, o.pose.py, 0.0, o.pose.pa);
                match b.world.set_odom(m, p) {
                    Ok(()) => Reply::empty_ack(),
                    Err(_) => Reply::Nack,
                }
            }
            Position2dReq::ResetOdom => match b.world.reset_odom(m) {
                Ok(()) => Reply::empty_ack(),
                Err(_) => Reply::Nack,
            },
            // VELOCITY_MODE (which libplayerc's position_control sends), the PID and profile
            // requests, and requests with an unexpected body: NACK, as Stage.
            _ => Reply::NotHandled,
        }
    }

    /// Velocity, position and car-like commands; VEL_HEAD is ignored as by Stage.
    fn command(&mut self, b: &mut Writing<'_>, _sender: &Sender<'_>, body: &Body) -> bool {
        let Body::Position2d(Position2dMsg::Cmd(cmd)) = body else {
            return false;
        };
        let m = b.model;
        let done = match cmd {
            Position2dCmd::Vel(v) => b.world.position_cmd_vel(m, v.vel.px, v.vel.py, v.vel.pa),
            Position2dCmd::Pos(p) => b.world.position_cmd_pos(m, p.pos.px, p.pos.py, p.pos.pa),
            // Stage uses the steering angle as a turn rate.
            Position2dCmd::Car(c) => b.world.position_cmd_car(m, c.velocity, c.angle),
            Position2dCmd::VelHead(_) => return false,
        };
        done.is_ok()
    }

    /// DATA STATE: the pose estimate (odometry or "gps"), the velocity and the stall flag.
    fn publish(&mut self, b: &Bound<'_, &World>, out: &mut Out<'_, '_>) -> Option<()> {
        let s = out.new_sample(b.answer(b.world.position_state(b.model)), |s| s.time_us)?;
        let pose2d = |p: &Pose| Pose2d {
            px: p.x,
            py: p.y,
            pa: p.a,
        };
        out.publish(Position2dData::State(Position2dDataState {
            pos: pose2d(&s.pose),
            vel: pose2d(&s.velocity),
            stall: u8::from(s.stall),
        }));
        Some(())
    }
}

/// The geometry: the body offset (`origin`) and the size; Stage leaves z, roll, pitch and the
/// height uninitialised, we send 0 and the model's height.
fn geometry<W: Deref<Target = World>>(b: &Bound<'_, W>) -> Position2dGeom {
    let node = b.node();
    Position2dGeom {
        pose: Pose3d {
            px: node.origin.x,
            py: node.origin.y,
            pyaw: node.origin.a,
            ..Pose3d::default()
        },
        size: super::size_bbox(node.size),
    }
}
