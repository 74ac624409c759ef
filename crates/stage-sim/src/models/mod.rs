//! Per-type model behaviour and the data each type publishes: one module per Stage model type,
//! each owning its description (with its worldfile conversion and defaults), its state, its
//! update and what its last unsubscription shuts down; `KindState` dispatches to them in one
//! place, where a new type adds one variant and the compiler points at every arm to write.

pub mod actuator;
pub mod blobfinder;
pub mod camera;
pub mod fiducial;
pub mod gripper;
pub mod position;
pub mod ranger;

use actuator::ActuatorModel;
use blobfinder::BlobfinderModel;
use camera::CameraModel;
use fiducial::{FiducialData, FiducialDesc};
use gripper::GripperModel;
use position::PositionModel;
use ranger::RangerData;

use crate::block::BlockDesc;
use crate::digest::Digest;
use crate::node::{ModelId, Node};
use crate::pose::Pose;
use crate::rng::SimRng;
use crate::view::View;

pub use actuator::ActuatorDesc;
pub use blobfinder::BlobfinderDesc;
pub use camera::CameraDesc;
pub use gripper::GripperDesc;
pub use position::PositionDesc;
pub use ranger::SensorDesc;
use worldfile::models::ModelType;

/// The type of a model and its type-specific configuration.
#[derive(Clone, Debug, PartialEq)]
pub enum KindDesc {
    /// A plain `model` (walls, boxes, pucks, floorplans).
    Model,
    /// A mobile base.
    Position(PositionDesc),
    /// A ranger with its transducers (laser-like with one many-sample sensor, sonar-like with
    /// many single-sample ones).
    Ranger(Vec<SensorDesc>),
    /// A colour blob finder.
    Blobfinder(BlobfinderDesc),
    /// A fiducial finder.
    Fiducial(FiducialDesc),
    /// A paddle gripper.
    Gripper(GripperDesc),
    /// A colour + depth camera.
    Camera(CameraDesc),
    /// An actuator joint.
    Actuator(ActuatorDesc),
    /// A blinking light (`period` ms, `dutycycle`).
    Blinkenlight {
        /// Period (ms, unused by Stage).
        period_ms: u32,
        /// Duty cycle (unused by Stage).
        dutycycle: f64,
    },
    /// A light indicator (on/off from the API).
    LightIndicator,
}

impl KindDesc {
    /// The worldfile crate's model type (whose table holds the per-type defaults).
    pub fn model_type(&self) -> ModelType {
        use ModelType as T;
        match self {
            KindDesc::Model => T::Model,
            KindDesc::Position(_) => T::Position,
            KindDesc::Ranger(_) => T::Ranger,
            KindDesc::Blobfinder(_) => T::Blobfinder,
            KindDesc::Fiducial(_) => T::Fiducial,
            KindDesc::Gripper(_) => T::Gripper,
            KindDesc::Camera(_) => T::Camera,
            KindDesc::Actuator(_) => T::Actuator,
            KindDesc::Blinkenlight { .. } => T::Blinkenlight,
            KindDesc::LightIndicator => T::Lightindicator,
        }
    }

    /// The Stage type word.
    pub fn type_name(&self) -> &'static str {
        self.model_type().name()
    }
}

/// Type-specific mutable state.
#[derive(Clone, Debug)]
pub(crate) enum KindState {
    Plain,
    Position(Box<PositionModel>),
    Ranger(RangerData),
    Blobfinder(Box<BlobfinderModel>),
    Fiducial(FiducialDesc, FiducialData),
    Gripper(Box<GripperModel>),
    Camera(Box<CameraModel>),
    Actuator(ActuatorModel),
    Blinkenlight { on: bool },
    LightIndicator { on: bool },
}

impl KindState {
    /// The state a model of this description starts in; `global` is its pose at load and `rng`
    /// its own stream (position models draw their odometry error from it, spec §7.7).
    pub(crate) fn new(kind: &KindDesc, global: &Pose, rng: &mut SimRng) -> KindState {
        match kind {
            KindDesc::Model => KindState::Plain,
            KindDesc::Position(p) => {
                KindState::Position(Box::new(PositionModel::from_desc(p, global, rng)))
            }
            KindDesc::Ranger(s) => KindState::Ranger(RangerData::new(s.clone())),
            KindDesc::Blobfinder(b) => {
                KindState::Blobfinder(Box::new(BlobfinderModel::new(b.clone())))
            }
            KindDesc::Fiducial(f) => KindState::Fiducial(f.clone(), FiducialData::default()),
            KindDesc::Gripper(g) => KindState::Gripper(Box::new(GripperModel::new(g.clone()))),
            KindDesc::Camera(c) => KindState::Camera(Box::new(CameraModel::new(c.clone()))),
            KindDesc::Actuator(a) => KindState::Actuator(ActuatorModel::new(a.clone())),
            KindDesc::Blinkenlight { .. } => KindState::Blinkenlight { on: false },
            KindDesc::LightIndicator => KindState::LightIndicator { on: true },
        }
    }

    /// The body a type builds itself instead of the worldfile's (the gripper's base and paddles
    /// for a model of `size`); `None` keeps the described blocks.
    pub(crate) fn own_blocks(&self, size: [f64; 3]) -> Option<Vec<BlockDesc>> {
        match self {
            KindState::Gripper(g) => Some(g.blocks(size)),
            KindState::Plain
            | KindState::Position(_)
            | KindState::Ranger(_)
            | KindState::Blobfinder(_)
            | KindState::Fiducial(..)
            | KindState::Camera(_)
            | KindState::Actuator(_)
            | KindState::Blinkenlight { .. }
            | KindState::LightIndicator { .. } => None,
        }
    }

    /// Whether the model updates once without being subscribed (Stage starts cameras and
    /// blinkenlights itself).
    pub(crate) fn starts_itself(&self) -> bool {
        match self {
            KindState::Camera(_) | KindState::Blinkenlight { .. } => true,
            KindState::Plain
            | KindState::Position(_)
            | KindState::Ranger(_)
            | KindState::Blobfinder(_)
            | KindState::Fiducial(..)
            | KindState::Gripper(_)
            | KindState::Actuator(_)
            | KindState::LightIndicator { .. } => false,
        }
    }

    /// About how many rays one update casts: decides whether a step's updates are worth
    /// spreading over threads.
    pub(crate) fn ray_cost(&self) -> usize {
        match self {
            KindState::Ranger(r) => r.ray_count(),
            KindState::Blobfinder(b) => b.cfg.image[0] as usize,
            KindState::Camera(c) => (c.cfg.resolution[0] * 4) as usize,
            KindState::Fiducial(..) => 8,
            KindState::Gripper(_) => 4,
            KindState::Plain
            | KindState::Position(_)
            | KindState::Actuator(_)
            | KindState::Blinkenlight { .. }
            | KindState::LightIndicator { .. } => 0,
        }
    }

    /// One update of model `m` against the view of the previous step's end (phase 1); `local`
    /// is its pose in the parent frame.
    #[inline]
    pub(crate) fn update(
        &mut self,
        v: &View,
        m: ModelId,
        local: &Pose,
        node: &Node,
        rng: &mut SimRng,
    ) {
        match self {
            KindState::Plain | KindState::LightIndicator { .. } => {}
            KindState::Position(p) => p.update(&v.globals[m.index()], v.dt, node.mass, v.sim_time),
            KindState::Ranger(r) => ranger::update(v, m, r, rng),
            KindState::Blobfinder(b) => blobfinder::update(v, m, b),
            KindState::Fiducial(cfg, d) => fiducial::update(v, m, cfg, d),
            KindState::Gripper(g) => gripper::update(v, m, g),
            KindState::Camera(c) => camera::update(v, m, c),
            KindState::Actuator(a) => a.update(local, v.sim_time),
            KindState::Blinkenlight { on } => *on = !*on,
        }
    }

    /// What the last unsubscription does: position models stop, actuators drop their goal,
    /// sensors clear their data.
    pub(crate) fn shutdown(&mut self) {
        match self {
            KindState::Position(p) => p.shutdown(),
            KindState::Actuator(a) => a.shutdown(),
            KindState::Ranger(r) => r.clear(),
            KindState::Blobfinder(b) => b.data.blobs.clear(),
            KindState::Fiducial(_, f) => f.fiducials.clear(),
            KindState::Plain
            | KindState::Gripper(_)
            | KindState::Camera(_)
            | KindState::Blinkenlight { .. }
            | KindState::LightIndicator { .. } => {}
        }
    }

    /// Feeds the type's whole state to the determinism digest ([`crate::World::state_digest`]).
    pub(crate) fn digest(&self, d: &mut Digest) {
        match self {
            KindState::Plain => {}
            KindState::Position(p) => p.digest(d),
            KindState::Ranger(r) => r.digest(d),
            KindState::Blobfinder(b) => b.digest(d),
            KindState::Fiducial(_, f) => f.digest(d),
            KindState::Gripper(g) => g.digest(d),
            KindState::Camera(c) => c.digest(d),
            KindState::Actuator(a) => a.digest(d),
            KindState::Blinkenlight { on } | KindState::LightIndicator { on } => d.u64(*on as u64),
        }
    }
}
