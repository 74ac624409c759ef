//! A plain-data description of a world: what [`crate::World::from_desc`] builds from. It mirrors
//! the resolved worldfile model tree (stage-models.md §3–§14) with every default applied, so
//! tests and tools can build worlds without a file, and `World::from_spec` only has to translate
//! the `worldfile` crate's `WorldSpec` into it.

use crate::pose::Pose;

pub use crate::block::BlockDesc;
pub use crate::color::{Color, same_rgb};
pub use crate::models::KindDesc;
pub use crate::models::actuator::{ActuatorDesc, ActuatorKind};
pub use crate::models::blinkenlight::BlinkenlightDesc;
pub use crate::models::blobfinder::BlobfinderDesc;
pub use crate::models::camera::CameraDesc;
pub use crate::models::fiducial::FiducialDesc;
pub use crate::models::gripper::GripperDesc;
pub use crate::models::position::PositionDesc;
pub use crate::models::ranger::SensorDesc;
pub use crate::node::Returns;

// The drive and localisation words are the worldfile crate's (one vocabulary for every crate).
pub use worldfile::models::{Drive, Localization, ModelType};

/// One model with every common property resolved (spec §3); units: m, rad, µs.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelDesc {
    /// Name (explicit or generated).
    pub name: String,
    /// Other registered names (Stage registers the generated name too).
    pub aliases: Vec<String>,
    /// Index of the parent in [`WorldDesc::models`] (which is in pre-order).
    pub parent: Option<usize>,
    /// Type and type-specific properties.
    pub kind: KindDesc,
    /// Pose in the parent frame.
    pub pose: Pose,
    /// Bounding-box size `[x y z]`.
    pub size: [f64; 3],
    /// Body/sensor offset from the pose.
    pub origin: Pose,
    /// Model colour.
    pub color: Color,
    /// Body blocks in the body frame (metres); with `default_body`, a box filling `size` is
    /// used instead.
    pub blocks: Vec<BlockDesc>,
    /// The body is Stage's default unit square stretched to `size` (a `size.x × size.y` box,
    /// `size.z` high), whatever `size` is when the world is built.
    pub default_body: bool,
    /// Children's z measured from this model's top.
    pub stack_children: bool,
    /// What the model is to collisions and to other models' sensors.
    pub returns: Returns,
    /// Time between updates (µs).
    pub update_interval_us: u64,
    /// Subscribed from the start.
    pub alwayson: bool,
    /// Controller strings (first word = controller name).
    pub ctrl: Vec<String>,
    /// Initial speech-bubble text.
    pub say: String,
    /// Mass (kg; power model only).
    pub mass: f64,
    /// Where it was defined, for messages (`file:line`).
    pub source: String,
}

impl ModelDesc {
    /// A model of the given kind with Stage's common defaults for that type (spec §3, §4),
    /// taken from the worldfile crate's type and property tables.
    pub fn new(name: &str, kind: KindDesc) -> ModelDesc {
        let info = kind.model_type().info();
        let common = worldfile::models::CommonSpec::for_type(info.model_type);
        let (size, color) = (info.defaults.size, info.defaults.color);
        // the gripper's own base-and-paddles body is built by the world from its state
        let body = info.defaults.body == worldfile::models::DefaultBody::UnitSquare;
        ModelDesc {
            name: name.to_string(),
            aliases: Vec::new(),
            parent: None,
            kind,
            pose: Pose::ZERO,
            size,
            origin: Pose::ZERO,
            color,
            blocks: Vec::new(),
            default_body: body,
            stack_children: common.stack_children,
            returns: Returns {
                obstacle: common.obstacle_return,
                ranger: common.ranger_return,
                fiducial: common.fiducial_return as i32,
                fiducial_key: common.fiducial_key as i32,
                gripper: common.gripper_return,
            },
            update_interval_us: common.update_interval as u64 * 1000,
            alwayson: common.alwayson,
            ctrl: Vec::new(),
            say: common.say,
            mass: common.mass,
            source: String::new(),
        }
    }
}

/// World-level settings (stage-worldfile.md §10) in internal units: what a description gives
/// and a running world keeps ([`crate::World::config`]).
#[derive(Clone, Debug, PartialEq)]
pub struct WorldConfig {
    /// World name.
    pub name: String,
    /// Simulated time per step (µs).
    pub interval_sim_us: u64,
    /// Quit time (µs); 0 = never.
    pub quit_time_us: u64,
    /// Stage's grid resolution (m).
    pub resolution: f64,
    /// Target multiple of real time; ≤ 0 = as fast as possible.
    pub speedup: f64,
    /// Start paused (GUI).
    pub paused: bool,
    /// `threads` from the file (informational: the step uses rayon's pool).
    pub threads: usize,
    /// Print the clock.
    pub show_clock: bool,
    /// Clock printing period (updates).
    pub show_clock_interval: u64,
}

/// A world: its settings and its model tree. The default settings are the worldfile crate's.
#[derive(Clone, Debug, PartialEq)]
pub struct WorldDesc {
    /// World-level settings.
    pub config: WorldConfig,
    /// Models in pre-order (parents before children).
    pub models: Vec<ModelDesc>,
}

impl Default for WorldDesc {
    fn default() -> Self {
        WorldDesc::from_settings(&worldfile::world::WorldSettings::default(), String::new())
    }
}

impl WorldDesc {
    /// Appends a model (with an optional parent index) and returns its index.
    pub fn add(&mut self, mut m: ModelDesc, parent: Option<usize>) -> usize {
        m.parent = parent;
        self.models.push(m);
        self.models.len() - 1
    }
}

impl WorldDesc {
    /// World-level settings with an empty model list.
    pub(crate) fn from_settings(s: &worldfile::world::WorldSettings, name: String) -> WorldDesc {
        WorldDesc {
            config: WorldConfig {
                name,
                interval_sim_us: s.interval_sim_usec().max(1),
                quit_time_us: s.quit_time_usec(),
                resolution: s.resolution,
                speedup: s.speedup,
                paused: s.paused,
                threads: s.threads.max(1) as usize,
                show_clock: s.show_clock,
                show_clock_interval: s.show_clock_interval.max(1) as u64,
            },
            models: Vec::new(),
        }
    }
}
