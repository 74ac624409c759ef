//! A Stage 4.1.1-compatible 2D multi-robot simulation built from a `worldfile` model tree.
//!
//! # Building and stepping
//!
//! `World::from_spec` (or `World::load`) builds a world from the `worldfile` crate's resolved
//! `WorldSpec`; [`World::from_desc`] builds one from a plain [`WorldDesc`] (what a spec
//! translates into, handy for tests and generated worlds). [`World::step`] advances one
//! `interval_sim`; [`World::sim_time`] is in microseconds.
//!
//! Each step is deterministic and uses every core:
//! 1. every due model that is subscribed (Stage only updates subscribed models, spec §5.4 —
//!    a large part of its speed) updates against an immutable snapshot of the previous step's
//!    end state: sensors cast their rays, position models compute velocities and localization —
//!    in parallel (rayon) when there is enough work, long ray fans split into chunks; a loop of
//!    steps run through [`on_sim_threads`] makes these splits cheap;
//! 2. gripper grasps/releases are applied, then position models move one at a time in model
//!    creation order, each tested for contact against the already-moved state (what does not
//!    depend on the order — new outlines, contacts with static blocks — is worked out for all
//!    robots in parallel first);
//! 3. controllers attached to models that updated run and their commands are applied in
//!    controller order; they take effect at the next step, as Stage's update callbacks do.
//!    A controller reads only the sensor data of 1 ([`Sensors`]), which the moves leave
//!    alone, so the controllers run on another core while the moves of 2 are installed.
//!
//! Randomness comes from one seed: each model owns a stream derived from `(seed, model index)`,
//! so the same world, seed and commands give bit-identical poses and readings whatever the
//! thread count ([`World::state_digest`]).
//!
//! # Geometry
//!
//! Bodies are polygon *outlines* in world space ([`space`]): static bodies (floorplans and
//! everything not in a robot's tree) in a parry2d BVH (contacts) and a uniform edge grid (rays),
//! both built once, moving ones in a uniform grid
//! updated incrementally on every move. Rays stop at the first edge crossed whose block spans the
//! ray's height (inclusive, as Stage's `ztest`); contacts are edge–edge intersections with
//! overlapping z ranges; a ray starting inside a body passes out of it (inside a wall built of
//! touching blocks of one model it may also pass their shared sides, which rays from open
//! space can never reach first) and containment is not contact — all as in Stage's occupancy
//! grid (spec §6.2), but exact. Stage's grid quantises:
//! its ranges are up to one cell (`resolution`, 2 cm by default; more at oblique angles) short,
//! its contacts fire up to one cell early, and bodies smaller than a cell may vanish there.
//! Ours are the true distances and contacts, so readings differ from Stage's by at most about
//! one cell.
//!
//! # API for servers and viewers
//!
//! * Model ids ([`ModelId`]) come from the world ([`World::models`], [`World::model_by_name`],
//!   tree links, ray hits, or [`World::model_id`] for a number). Every function below that
//!   takes one answers a `Result`: [`Error::ForeignModel`] for an id the world does not have,
//!   [`Error::BadModel`] for a type-specific call on a model of another type (see [`World`]).
//! * Lookup and tree: [`World::model_by_name`] (explicit and generated names; the last one
//!   registered wins, as in Stage), [`World::parent`], [`World::children`],
//!   [`World::subtree`] (pre-order, how the stage driver binds devices), [`World::type_name`],
//!   [`World::node`] (size, origin, returns, update interval, body blocks).
//! * Subscriptions: [`World::subscribe`] / [`World::unsubscribe`] (counted; the first starts the
//!   model, the last shuts it down — position models stop, sensors clear their data).
//! * Simulation interface: [`World::pose`] / [`World::set_pose`] (parent frame, no collision
//!   test), [`World::global_pose`], [`World::color`] / [`World::set_color`], [`World::say`].
//! * Commands: [`World::position_cmd_vel`], [`World::position_cmd_pos`],
//!   [`World::position_cmd_car`], [`World::set_odom`], [`World::reset_odom`],
//!   [`World::gripper_cmd`], [`World::actuator_cmd`], [`World::set_fiducial_id`].
//! * Data, each stamped with the sim time it was produced (publish at each model's update
//!   interval by comparing stamps): [`World::position_state`], [`World::ranger_scans`]
//!   (per-sensor ranges, intensities and configuration; Player's flattening is the stage
//!   driver's), [`World::blobfinder_blobs`], [`World::fiducials`],
//!   [`World::gripper_state`], [`World::camera_image`], [`World::actuator`].
//! * Drawing without copying: [`World::global_pose`], [`World::body`] (world-space polygons with
//!   z ranges, borrowed) and [`World::block_color`] for every model, plus the sensor data above.
//!
//! # Where we differ from Stage, and Stage bugs we do not reproduce
//!
//! * Sensors all see the state at the end of the previous step; Stage's threaded rangers see
//!   their own robot's pose before or after that step's move at random (±1 step, spec §5.6).
//! * Moves happen in model creation order (Stage: object address order) against fully current
//!   poses (Stage's double-buffered grid can be one or two steps stale for moving robots).
//! * Random choices (`color "random"`, default `odom_error`, controllers' random turns) come
//!   from the seed; Stage seeds `drand48` from the clock, so its runs are not repeatable.
//! * Stage's worker threads can lose a wake-up and hang on the first update; ours cannot.
//! * Models without any block height get full-height blocks (the worldfile resolver's choice),
//!   where Stage computes NaN heights that rays always hit and collisions never see.
//! * The camera is ray-cast, headless too (Stage renders it with OpenGL in the GUI only and
//!   crashes headless); the ground is drawn grey and the sky transparent.
//! * Power packs and energy accounting are not simulated: they have no effect on behaviour in
//!   Stage 4.1.1 either.
//! * Stage 3 `laser` models run as one-sensor rangers; Stage 3 `wifi` models are plain models
//!   (with a warning).
//! * Kept because clients can observe them: the GPS pose lags the true pose by one step, the
//!   odometry flips the sign of lateral (omni) motion and integrates commanded velocities,
//!   `odom_error` values are used as exact bias factors, SET/RESET_ODOM do not last in GPS
//!   mode, the blobfinder skips the column after each blob (Player's blob area, which wraps,
//!   is the stage driver's), fiducial ids beyond `range_max_id` are 0, dropped objects land
//!   at the gripper's pose and height, `update_interval` rounds up to whole world steps and
//!   `quit_time` overshoots to the end of the step that crosses it.

pub mod block;
pub mod color;
pub mod controller;
pub mod desc;
mod digest;
pub mod error;
pub mod fork;
pub mod generate;
pub mod geom;
pub mod models;
pub mod node;
pub mod pacing;
pub mod pool;
pub mod pose;
pub mod raster;
pub mod rng;
pub mod space;
pub mod spec;
mod view;
pub mod world;

pub use controller::{Command, Commands, Controller};
pub use desc::{
    ActuatorDesc, ActuatorKind, BlinkenlightDesc, BlobfinderDesc, BlockDesc, CameraDesc, Color,
    Drive, FiducialDesc, GripperDesc, KindDesc, Localization, ModelDesc, ModelType, PositionDesc,
    SensorDesc, WorldDesc,
};
pub use error::{Error, Result};
pub use models::blobfinder::{Blob, BlobfinderData};
pub use models::camera::CameraImage;
pub use models::fiducial::{Fiducial, FiducialData};
pub use models::gripper::{GripperCmd, GripperData, LiftState, PaddleState};
pub use models::position::{ControlMode, PositionData};
pub use models::ranger::{RangerData, SensorScan};
pub use pool::on_sim_threads;
pub use pose::Pose;
pub use raster::Raster;
pub use rng::SimRng;
pub use space::{Body, RayHit, RayQuery};
pub use world::{ModelId, Sensors, World};

#[cfg(test)]
mod tests;
