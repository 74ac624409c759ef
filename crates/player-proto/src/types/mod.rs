//! Every message struct of the supported interfaces, one declaration each.
//!
//! Names are the C names without `player_` and `_t`, in CamelCase (`player_position2d_cmd_vel_t`
//! → `Position2dCmdVel`). Where that would collide with a typed message enum, the struct is named
//! after the message that carries it (`player_position2d_data_t` → `Position2dDataState`); each
//! struct's documentation gives its C name.

mod actarray;
mod blackboard;
mod blinkenlight;
mod blobfinder;
mod bumper;
mod camera;
mod common;
mod fiducial;
mod graphics;
mod gripper;
mod ir;
mod laser;
mod localize;
mod log;
mod map;
mod opaque;
mod planner;
mod player;
mod position2d;
mod power;
mod ptz;
mod ranger;
mod simulation;
mod sonar;
mod speech;

pub use actarray::*;
pub use blackboard::*;
pub use blinkenlight::*;
pub use blobfinder::*;
pub use bumper::*;
pub use camera::*;
pub use common::*;
pub use fiducial::*;
pub use graphics::*;
pub use gripper::*;
pub use ir::*;
pub use laser::*;
pub use localize::*;
pub use log::*;
pub use map::*;
pub use opaque::*;
pub use planner::*;
pub use player::*;
pub use position2d::*;
pub use power::*;
pub use ptz::*;
pub use ranger::*;
pub use simulation::*;
pub use sonar::*;
pub use speech::*;
