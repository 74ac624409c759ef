//! What the model tree holds per model: its id, and the configuration every phase of a step
//! reads (tree links, size, returns, update period, body blocks).

use crate::color::Color;
use crate::pose::Pose;
use worldfile::models::ModelType;

/// Identifies a model of one [`World`](crate::World): its index in creation (pre-)order.
///
/// Other crates get ids only from a world ([`World::models`](crate::World::models),
/// [`World::model_by_name`](crate::World::model_by_name), tree links, ray hits, or the checked
/// [`World::model_id`](crate::World::model_id) for a number), never by building one, so an id
/// normally belongs to the world it came from. Every public `World` function that takes an id
/// checks it and answers [`Error::ForeignModel`](crate::Error::ForeignModel) for an index the
/// world does not have (see [`World`](crate::World) for what that check cannot see).
///
/// The id is a bare 4-byte index, with no tag naming its world: ids are stored in the spatial
/// index's cells and scanned in the ray and contact loops, where doubling their size would cost
/// memory and cache misses on every step. So an id taken from another world whose index is in
/// range here is not detected; it names this world's model with that index.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ModelId(pub(crate) u32);

impl ModelId {
    /// The index into per-model tables (creation order), for callers that keep their own
    /// per-model arrays; turn a number back into an id with
    /// [`World::model_id`](crate::World::model_id).
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

impl std::fmt::Display for ModelId {
    /// The index, as messages name models ("model 3").
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.0)
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
    pub parent: Option<ModelId>,
    /// Children in creation order.
    pub children: Vec<ModelId>,
    /// Root of the tree the model is in (models with the same root are "related").
    pub root: ModelId,
    /// Size `[x y z]` (m).
    pub size: [f64; 3],
    /// Body offset from the pose.
    pub origin: Pose,
    /// Children's z measured from this model's top.
    pub stack_children: bool,
    /// Update period (µs).
    pub update_interval_us: u64,
    /// Mass (kg).
    pub mass: f64,
    /// Body blocks in the body frame.
    pub blocks: Vec<LocalBlock>,
    /// Where the model was defined.
    pub source: String,
}

/// What a model is to collisions and to other models' sensors: Stage's `*_return` properties
/// (and the fiducial key), described once for [`crate::desc::ModelDesc`] and kept in [`Node`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Returns {
    /// Takes part in collisions (`obstacle_return`).
    pub obstacle: bool,
    /// Ranger intensity; < 0 makes the model transparent to rangers (`ranger_return`).
    pub ranger: f64,
    /// Fiducial id; 0 = not a fiducial (`fiducial_return`).
    pub fiducial: i32,
    /// Fiducial key: finders see only targets with their own key (`fiducial_key`).
    pub fiducial_key: i32,
    /// Graspable by grippers (`gripper_return`).
    pub gripper: bool,
}
