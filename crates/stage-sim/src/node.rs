//! What the model tree holds per model: its id, and the configuration every phase of a step
//! reads (tree links, size, returns, update period, body blocks).

use crate::color::Color;
use crate::pose::Pose;
use worldfile::models::ModelType;

/// Identifies a model: its index in creation (pre-)order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ModelId(pub u32);

impl ModelId {
    /// The index into per-model tables.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// A block in the model's body frame, already scaled to `size` (spec §2.3).
#[derive(Clone, Debug, PartialEq)]
pub struct LocalBlock {
    /// Vertices in the body frame (m).
    pub pts: Vec<[f64; 2]>,
    /// z interval relative to the body base (m).
    pub z: [f64; 2],
    /// Own colour, or `None` to inherit the model's.
    pub color: Option<Color>,
}

/// Per-model tree and configuration data (read by every phase of a step).
#[derive(Clone, Debug)]
pub struct Node {
    /// Name.
    pub name: String,
    /// Stage model type.
    pub model_type: ModelType,
    /// Parent model.
    pub parent: Option<u32>,
    /// Children in creation order.
    pub children: Vec<u32>,
    /// Root of the tree the model is in (models with the same root are "related").
    pub root: u32,
    /// Size `[x y z]` (m).
    pub size: [f64; 3],
    /// Body offset from the pose.
    pub origin: Pose,
    /// Children's z measured from this model's top.
    pub stack_children: bool,
    /// Takes part in collisions.
    pub obstacle_return: bool,
    /// Ranger intensity (< 0: transparent to rangers).
    pub ranger_return: f64,
    /// Fiducial id (0: none).
    pub fiducial_return: i32,
    /// Fiducial key.
    pub fiducial_key: i32,
    /// Graspable.
    pub gripper_return: bool,
    /// Update period (µs).
    pub update_interval_us: u64,
    /// Mass (kg).
    pub mass: f64,
    /// Body blocks in the body frame.
    pub blocks: Vec<LocalBlock>,
    /// Where the model was defined.
    pub source: String,
}
