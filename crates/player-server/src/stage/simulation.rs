//! The `simulation` interface: model poses and properties by name (player-protocol.md §6.6,
//! player-cfg.md §8.2). Poses are in the model's parent frame (the world for top-level
//! models), as Stage reports them.

use player_proto::{
    Body, CapabilitiesReq, MsgType, Pose2d, Pose3d, SimulationMsg, SimulationPose2dReq,
    SimulationPose3dReq, SimulationPropertyReq, SimulationReq, Text, UniversalMsg, UniversalReq,
};
use stage_sim::{Color, ModelId, Pose, World};

use super::Interface;
use crate::driver::Reply;

/// The `simulation` device: the world itself (the first one creates it).
#[derive(Debug, Default)]
pub(super) struct Simulation;

impl Interface for Simulation {
    /// Answers one request to the simulation device.
    fn world_request(&mut self, world: &mut World, body: &Body) -> Reply {
        match body {
            Body::Simulation(SimulationMsg::Req(req)) => match req {
                SimulationReq::GetPose2d(Some(r)) => match model(world, &r.name) {
                    Some(m) => {
                        let p = world.pose(m).expect(BY_NAME);
                        Reply::ack(SimulationReq::GetPose2d(Some(SimulationPose2dReq {
                            name: r.name.clone(),
                            pose: Pose2d {
                                px: p.x,
                                py: p.y,
                                pa: p.a,
                            },
                        })))
                    }
                    None => Reply::Nack,
                },
                SimulationReq::SetPose2d(Some(r)) => match model(world, &r.name) {
                    Some(m) => {
                        let z = world.pose(m).expect(BY_NAME).z;
                        world
                            .set_pose(m, Pose::new(r.pose.px, r.pose.py, z, r.pose.pa))
                            .expect(BY_NAME);
                        Reply::empty_ack()
                    }
                    None => Reply::Nack,
                },
                SimulationReq::GetPose3d(Some(r)) => match model(world, &r.name) {
                    Some(m) => {
                        let p = world.pose(m).expect(BY_NAME);
                        Reply::ack(SimulationReq::GetPose3d(Some(SimulationPose3dReq {
                            name: r.name.clone(),
                            pose: super::pose3d(&p),
                            // Microseconds, as Stage sends it.
                            simtime: world.sim_time() as f64,
                        })))
                    }
                    None => Reply::Nack,
                },
                SimulationReq::SetPose3d(Some(r)) => match model(world, &r.name) {
                    Some(m) => {
                        let Pose3d {
                            px, py, pz, pyaw, ..
                        } = r.pose;
                        world
                            .set_pose(m, Pose::new(px, py, pz, pyaw))
                            .expect(BY_NAME);
                        Reply::empty_ack()
                    }
                    None => Reply::Nack,
                },
                SimulationReq::GetProperty(Some(r)) => get_property(world, r),
                SimulationReq::SetProperty(Some(r)) => set_property(world, r),
                _ => Reply::NotHandled,
            },
            // Stage's evident intent (it crashes on the body Player 3.0.2 strips): the 3D pose
            // requests are supported, nothing else is.
            Body::Universal(UniversalMsg::Req(UniversalReq::Capabilities(Some(
                CapabilitiesReq { msg_type, subtype },
            )))) => {
                if *msg_type == u32::from(MsgType::Req.code())
                    && [
                        u32::from(SimulationReq::GET_POSE3D),
                        u32::from(SimulationReq::SET_POSE3D),
                    ]
                    .contains(subtype)
                {
                    Reply::empty_ack()
                } else {
                    Reply::Nack
                }
            }
            _ => Reply::NotHandled,
        }
    }
}

/// Stage's property-name test: `strncmp(prop, name, prop_count)`, so with the NUL libplayerc
/// sends it is an exact match, and a shorter count matches a prefix (QUIRK kept).
fn prop_is(prop: &Text, name: &str) -> bool {
    let wanted = name.as_bytes();
    for (i, &a) in prop.as_bytes().iter().enumerate() {
        let b = wanted.get(i).copied().unwrap_or(0);
        if a != b {
            return false;
        }
        if a == 0 {
            return true;
        }
    }
    true
}

/// Why the world calls below cannot refuse: their ids come from [`model`].
const BY_NAME: &str = "a model found by name in this world belongs to it";

fn model(world: &World, name: &Text) -> Option<ModelId> {
    world.model_by_name(&name.to_str_lossy())
}

/// A colour as the property bytes x86 clients expect: four little-endian floats R, G, B, A.
fn color_bytes(c: &Color) -> Vec<u8> {
    [c.r, c.g, c.b, c.a]
        .iter()
        .flat_map(|&v| (v as f32).to_le_bytes())
        .collect()
}

fn color_from_bytes(v: &[u8]) -> Option<Color> {
    let f = |i: usize| -> Option<f64> {
        let b: [u8; 4] = v.get(i * 4..i * 4 + 4)?.try_into().ok()?;
        Some(f64::from(f32::from_le_bytes(b)))
    };
    (v.len() == 16).then_some(())?;
    Some(Color {
        r: f(0)?,
        g: f(1)?,
        b: f(2)?,
        a: f(3)?,
    })
}

fn get_property(world: &World, req: &SimulationPropertyReq) -> Reply {
    let Some(m) = model(world, &req.name) else {
        return Reply::Nack;
    };
    let value = if prop_is(&req.prop, "color") {
        if req.value.len() != 16 {
            return Reply::Nack;
        }
        color_bytes(&world.color(m).expect(BY_NAME))
    } else if prop_is(&req.prop, "time") {
        if req.value.len() != 8 {
            return Reply::Nack;
        }
        // What Stage evidently meant (it writes over the pointer and crashes).
        world.sim_time().to_le_bytes().to_vec()
    } else {
        return Reply::Nack;
    };
    Reply::ack(SimulationReq::GetProperty(Some(SimulationPropertyReq {
        value,
        ..req.clone()
    })))
}

fn set_property(world: &mut World, req: &SimulationPropertyReq) -> Reply {
    let Some(m) = model(world, &req.name) else {
        return Reply::Nack;
    };
    if !prop_is(&req.prop, "color") {
        return Reply::Nack;
    }
    match color_from_bytes(&req.value) {
        Some(c) => {
            world.set_color(m, c).expect(BY_NAME);
            Reply::empty_ack()
        }
        None => Reply::Nack,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn property_names_compare_like_strncmp() {
        assert!(prop_is(&Text::new("color"), "color"));
        assert!(!prop_is(&Text::new("colour"), "color"));
        assert!(!prop_is(&Text::new("col"), "color"), "NUL differs from 'o'");
        assert!(
            prop_is(&Text::from_bytes(b"col".to_vec()), "color"),
            "prefix"
        );
        assert!(prop_is(&Text::empty(), "color"), "count 0");
        assert!(!prop_is(&Text::new("colors"), "color"));
        assert!(prop_is(&Text::new("time"), "time"));
    }

    #[test]
    fn colour_bytes_are_little_endian_floats() {
        let c = Color {
            r: 1.0,
            g: 0.0,
            b: 0.5,
            a: 1.0,
        };
        let b = color_bytes(&c);
        assert_eq!(&b[..4], &[0, 0, 128, 63]);
        assert_eq!(color_from_bytes(&b), Some(c));
        assert_eq!(color_from_bytes(&b[..12]), None);
    }
}
