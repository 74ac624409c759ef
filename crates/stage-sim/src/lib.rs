//! A Stage 4.1.1-compatible 2D multi-robot simulation built from a `worldfile` model tree.
//!
//! # Building and stepping
//!
//! [`World::from_desc`] builds a world from a plain [`WorldDesc`] (what the `worldfile` crate's
//! resolved tree translates into); [`World::step`] advances one `interval_sim`.
//!
//! Each step is deterministic and uses every core:
//! 1. every due model that is subscribed (Stage only updates subscribed models, spec §5.4)
//!    updates against an immutable snapshot of the previous step's end state — sensors cast
//!    their rays, position models compute velocities and localization — in parallel (rayon);
//! 2. gripper grasps/releases are applied, then position models move one at a time in model
//!    creation order, each tested for contact against the already-moved state;
//! 3. controllers attached to models that updated run (in parallel) and their commands apply
//!    in controller order.
//!
//! Randomness comes from one seed: each model owns a stream derived from `(seed, model index)`,
//! so the same world, seed and commands give bit-identical poses and readings whatever the
//! thread count ([`World::state_digest`]).
//!
//! # Geometry
//!
//! Bodies are polygon *outlines* in world space ([`space`]): static bodies in a parry2d BVH
//! built once, moving ones in a uniform grid updated incrementally. Rays stop at the first edge
//! crossed whose block spans the ray height; contacts are edge–edge intersections with
//! overlapping z ranges; containment is not contact — all as in Stage's grid, but exact:
//! Stage's grid quantises ranges and contacts by up to one cell (`resolution`), we do not.
//!
//! # API for servers and viewers
//!
//! Look models up with [`World::model_by_name`], walk the tree with [`World::parent`],
//! [`World::children`], [`World::subtree`] (pre-order), [`World::type_name`]; drive models with
//! [`World::subscribe`]/[`World::unsubscribe`] (counted), [`World::position_cmd_vel`],
//! [`World::position_cmd_pos`], [`World::position_cmd_car`], [`World::gripper_cmd`],
//! [`World::actuator_cmd`], [`World::say`], [`World::set_color`], [`World::set_pose`]; read
//! [`World::position_state`], [`World::ranger_scans`], [`World::blobfinder_blobs`],
//! [`World::fiducials`], [`World::gripper_state`], [`World::camera_image`],
//! [`World::actuator`]. Every sensor output carries the sim time it was produced. A viewer reads
//! [`World::global_pose`], [`World::body`] and [`World::block_color`] by reference.

pub mod controller;
pub mod desc;
pub mod error;
pub mod generate;
pub mod geom;
pub mod models;
pub mod pose;
pub mod rng;
pub mod space;
pub mod world;

pub use controller::{Command, Commands, Controller};
pub use desc::{
    ActuatorDesc, ActuatorKind, BlobfinderDesc, BlockDesc, CameraDesc, Color, Drive, FiducialDesc,
    GripperDesc, KindDesc, Localization, ModelDesc, PositionDesc, SensorDesc, WorldDesc,
};
pub use error::{Error, Result};
pub use models::blobfinder::{Blob, BlobfinderData};
pub use models::camera::CameraImage;
pub use models::fiducial::{Fiducial, FiducialData};
pub use models::gripper::{GripperCmd, GripperData, LiftState, PaddleState};
pub use models::position::{ControlMode, PositionData};
pub use models::ranger::{RangerData, SensorScan};
pub use pose::Pose;
pub use rng::SimRng;
pub use space::{Body, RayHit, RayQuery};
pub use world::{ModelId, World};

#[cfg(test)]
mod tests;
