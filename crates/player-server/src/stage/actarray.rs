//! `actarray` on a Stage `actuator`: a single joint (player-protocol.md §6.13,
//! stage-models.md §13). Stage 4.1.1 computes the joint's motion but never applies it, so the
//! reported position does not follow the goal; we report what Stage reports.

use std::ops::Deref;

use player_proto::constants::{
    PLAYER_ACTARRAY_ACTSTATE_IDLE, PLAYER_ACTARRAY_ACTSTATE_MOVING, PLAYER_ACTARRAY_TYPE_LINEAR,
};
use player_proto::{
    ActarrayActuator, ActarrayActuatorgeom, ActarrayCmd, ActarrayData, ActarrayDataState,
    ActarrayGeom, ActarrayMsg, ActarrayReq, Body, Orientation3d, Point3d,
};
use stage_sim::World;
use worldfile::TypeSpec;

use super::{Bound, Interface, Out, Sender, Writing};
use crate::driver::Reply;

/// An `actarray` device.
#[derive(Debug, Default)]
pub(super) struct Actarray;

impl Interface for Actarray {
    /// DATA STATE: one actuator, as Stage's plugin fills it: the position, the goal as the speed
    /// (a position goal clamped to the joint's limits, a speed goal as commanded), moving while
    /// that goal is non-zero; acceleration and current are 0 (Stage models neither).
    fn publish(&mut self, b: &Bound<'_, &World>, out: &mut Out<'_, '_>) -> Option<()> {
        let a = out.new_sample(b.answer(b.world.actuator(b.model)), |s| s.time_us)?;
        out.publish(ActarrayData::State(ActarrayDataState {
            actuators: vec![ActarrayActuator {
                position: a.position as f32,
                speed: a.speed as f32,
                acceleration: 0.0,
                current: 0.0,
                state: if a.moving {
                    PLAYER_ACTARRAY_ACTSTATE_MOVING
                } else {
                    PLAYER_ACTARRAY_ACTSTATE_IDLE
                },
            }],
            motor_state: 0,
        }));
        Some(())
    }

    fn request(&mut self, b: &mut Writing<'_>, body: &Body) -> Reply {
        match body {
            Body::Actarray(ActarrayMsg::Req(ActarrayReq::GetGeom(None))) => match geometry(b) {
                Some(g) => Reply::ack(ActarrayReq::GetGeom(Some(g))),
                None => Reply::Nack,
            },
            // POWER, BRAKES, SPEED and ACCEL configuration: NACK, as Stage.
            _ => Reply::NotHandled,
        }
    }

    /// POS and SPEED set the goal (the joint index is ignored: there is one); the multi-joint,
    /// home and current commands are ignored as by Stage.
    fn command(&mut self, b: &mut Writing<'_>, _sender: &Sender<'_>, body: &Body) -> bool {
        let (position, goal) = match body {
            Body::Actarray(ActarrayMsg::Cmd(ActarrayCmd::Pos(c))) => (true, c.position),
            Body::Actarray(ActarrayMsg::Cmd(ActarrayCmd::Speed(c))) => (false, c.speed),
            _ => return false,
        };
        b.world
            .actuator_cmd(b.model, position, f64::from(goal))
            .is_ok()
    }
}

/// GET_GEOM: one linear actuator (Stage reports every joint as linear) with its limits; the
/// base is the model's body offset.
fn geometry<W: Deref<Target = World>>(b: &Bound<'_, W>) -> Option<ActarrayGeom> {
    let TypeSpec::Actuator(spec) = &b.model_spec().spec else {
        return None;
    };
    let origin = b.node().origin;
    Some(ActarrayGeom {
        actuators: vec![ActarrayActuatorgeom {
            kind: PLAYER_ACTARRAY_TYPE_LINEAR,
            min: spec.min_position as f32,
            max: spec.max_position as f32,
            ..ActarrayActuatorgeom::default()
        }],
        base_pos: Point3d {
            px: origin.x,
            py: origin.y,
            pz: origin.z,
        },
        base_orientation: Orientation3d {
            proll: 0.0,
            ppitch: 0.0,
            pyaw: origin.a,
        },
    })
}
