//! A plain-data description of a world: what [`crate::World::from_desc`] builds from. It mirrors
//! the resolved worldfile model tree (stage-models.md §3–§14) with every default applied, so
//! tests and tools can build worlds without a file, and `World::from_spec` only has to translate
//! the `worldfile` crate's `WorldSpec` into it.

use crate::pose::Pose;

/// An RGBA colour (components in `0..=1`, doubles as Stage keeps them): the worldfile crate's
/// type, so colour facts (X11 table, Player packing) live in one place.
pub use worldfile::color::Rgba as Color;

/// Blobfinder colour equality: RGB within 1e-5, alpha ignored (spec §9.2, §16).
pub fn same_rgb(a: &Color, b: &Color) -> bool {
    (a.r - b.r).abs() < 1e-5 && (a.g - b.g).abs() < 1e-5 && (a.b - b.b).abs() < 1e-5
}

/// One block: a polygon in the model's body frame (metres, already stretched to `size` by the
/// worldfile resolver, spec §2.3) extruded over `[zmin, zmax]` above the body base.
#[derive(Clone, Debug, PartialEq)]
pub struct BlockDesc {
    /// Vertices (at least 2), metres in the body frame.
    pub points: Vec<[f64; 2]>,
    /// Lower z above the body base (m).
    pub zmin: f64,
    /// Upper z above the body base (m).
    pub zmax: f64,
    /// Own colour; `None` inherits the model's current colour.
    pub color: Option<Color>,
}

impl BlockDesc {
    /// An axis-aligned rectangle block `[x, x+w] × [y, y+h]`, z `[0, height]`, inherited colour.
    pub fn rect(x: f64, y: f64, w: f64, h: f64, height: f64) -> BlockDesc {
        BlockDesc {
            points: vec![[x, y], [x + w, y], [x + w, y + h], [x, y + h]],
            zmin: 0.0,
            zmax: height,
            color: None,
        }
    }
}

// The drive and localisation words are the worldfile crate's (one vocabulary for every crate).
pub use worldfile::models::{Drive, Localization, ModelType};

/// Position-model properties (spec §7.1); angles in radians.
#[derive(Clone, Debug, PartialEq)]
pub struct PositionDesc {
    /// Drive model.
    pub drive: Drive,
    /// Localization mode.
    pub localization: Localization,
    /// Origin of the reported pose frame; `None`: the model's global pose at load.
    pub localization_origin: Option<Pose>,
    /// Odometry error factors `(x, y, z, a)`; `None`: drawn at random per model (spec §7.7).
    pub odom_error: Option<[f64; 4]>,
    /// Wheelbase for `car` drive (m).
    pub wheelbase: f64,
    /// `[xmin xmax ymin ymax zmin zmax amin amax]` (m/s, rad/s).
    pub velocity_bounds: [f64; 8],
    /// Same layout as `velocity_bounds`, for acceleration mode (m/s², rad/s²).
    pub acceleration_bounds: [f64; 8],
    /// Initial velocity (overwritten by the first control update, as in Stage).
    pub velocity: Pose,
}

impl Default for PositionDesc {
    /// Stage's defaults, from the worldfile crate's property table (one source of truth).
    fn default() -> Self {
        let mut d = crate::spec::position(&worldfile::models::PositionSpec::default());
        // "the model's global pose at load", which the resolver fills in for real models
        d.localization_origin = None;
        d
    }
}

/// One ranger transducer (`sensor` entity, spec §8.1).
#[derive(Clone, Debug, PartialEq)]
pub struct SensorDesc {
    /// Pose in the ranger's body frame.
    pub pose: Pose,
    /// Size (m); `size.z/2` raises the ray origin.
    pub size: [f64; 3],
    /// `[min, max]` range (m); only `max` limits rays.
    pub range: [f64; 2],
    /// Angular spread (rad).
    pub fov: f64,
    /// Number of rays.
    pub samples: u32,
    /// Standard deviation of additive Gaussian range noise (m); 0 = Stage's noiseless ranger.
    pub noise: f64,
    /// Standard deviation of multiplicative range noise: each range is multiplied by a draw
    /// from N(1, sd), as Stage's `lasernoise` example controller does; 0 = none.
    pub noise_relative: f64,
    /// GUI colour.
    pub color: Color,
}

impl Default for SensorDesc {
    /// Stage's defaults, from the worldfile crate's property table.
    fn default() -> Self {
        crate::spec::sensor(
            &worldfile::models::SensorSpec::default(),
            &mut crate::rng::SimRng::new(0, 0),
        )
    }
}

/// Blobfinder properties (spec §9.1).
#[derive(Clone, Debug, PartialEq)]
pub struct BlobfinderDesc {
    /// Image width (rays) and height (pixels).
    pub image: [u32; 2],
    /// Ray length (m).
    pub range: f64,
    /// Horizontal field of view (rad).
    pub fov: f64,
    /// Centre direction relative to the body heading (rad).
    pub pan: f64,
    /// Colour channels; empty = report every colour.
    pub colors: Vec<Color>,
}

impl Default for BlobfinderDesc {
    /// Stage's defaults, from the worldfile crate's property table.
    fn default() -> Self {
        crate::spec::blobfinder(&worldfile::models::BlobfinderSpec::default())
    }
}

/// Fiducial-finder properties (spec §10.1).
#[derive(Clone, Debug, PartialEq)]
pub struct FiducialDesc {
    /// Read but unused by Stage (kept for the Player geometry).
    pub range_min: f64,
    /// Detection range (m, strict).
    pub range_max: f64,
    /// Beyond this the id is reported as 0 (m).
    pub range_max_id: f64,
    /// Field of view (rad).
    pub fov: f64,
    /// Accept targets whose line-of-sight ray hits nothing.
    pub ignore_zloc: bool,
}

impl Default for FiducialDesc {
    /// Stage's defaults, from the worldfile crate's property table.
    fn default() -> Self {
        crate::spec::fiducial(&worldfile::models::FiducialSpec::default())
    }
}

/// Gripper properties (spec §11.1).
#[derive(Clone, Debug, PartialEq)]
pub struct GripperDesc {
    /// Paddle length, width, height as fractions of the gripper size.
    pub paddle_size: [f64; 3],
    /// Initially closed.
    pub closed: bool,
    /// Initially lifted.
    pub up: bool,
    /// Beams drive the paddles.
    pub autosnatch: bool,
}

impl Default for GripperDesc {
    /// Stage's defaults, from the worldfile crate's property table.
    fn default() -> Self {
        crate::spec::gripper(&worldfile::models::GripperSpec::default())
    }
}

/// Camera properties (spec §12).
#[derive(Clone, Debug, PartialEq)]
pub struct CameraDesc {
    /// Image width and height (pixels).
    pub resolution: [u32; 2],
    /// Near and far clipping distances (m).
    pub range: [f64; 2],
    /// Horizontal and vertical field of view (rad).
    pub fov: [f64; 2],
    /// Pan and tilt (rad).
    pub pantilt: [f64; 2],
}

impl Default for CameraDesc {
    /// Stage's defaults, from the worldfile crate's property table.
    fn default() -> Self {
        crate::spec::camera(&worldfile::models::CameraSpec::default())
    }
}

/// Actuator joint type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ActuatorKind {
    /// Moves along `axis`.
    Linear,
    /// Turns about z.
    Rotational,
}

/// Actuator properties (spec §13).
#[derive(Clone, Debug, PartialEq)]
pub struct ActuatorDesc {
    /// Joint type.
    pub kind: ActuatorKind,
    /// Unit axis for linear joints.
    pub axis: [f64; 3],
    /// Lower limit.
    pub min_position: f64,
    /// Upper limit.
    pub max_position: f64,
    /// Speed limit.
    pub max_speed: f64,
    /// Initial position.
    pub start_position: f64,
}

impl Default for ActuatorDesc {
    /// Stage's defaults, from the worldfile crate's property table.
    fn default() -> Self {
        crate::spec::actuator(&worldfile::models::ActuatorSpec::default())
    }
}

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
    /// Takes part in collisions.
    pub obstacle_return: bool,
    /// Ranger intensity; < 0 makes the model transparent to rangers.
    pub ranger_return: f64,
    /// Fiducial id (0 = not a fiducial).
    pub fiducial_return: i32,
    /// Fiducial key.
    pub fiducial_key: i32,
    /// Graspable by grippers.
    pub gripper_return: bool,
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
        let (size, color) = (info.size, info.color);
        // the gripper's own base-and-paddles body is built by the world from its state
        let body = info.body == worldfile::models::DefaultBody::UnitSquare;
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
            obstacle_return: common.obstacle_return,
            ranger_return: common.ranger_return,
            fiducial_return: common.fiducial_return as i32,
            fiducial_key: common.fiducial_key as i32,
            gripper_return: common.gripper_return,
            update_interval_us: common.update_interval as u64 * 1000,
            alwayson: common.alwayson,
            ctrl: Vec::new(),
            say: common.say,
            mass: common.mass,
            source: String::new(),
        }
    }
}

/// World-level settings (stage-worldfile.md §10) and the model tree. The default settings are
/// the worldfile crate's.
#[derive(Clone, Debug, PartialEq)]
pub struct WorldDesc {
    /// World name.
    pub name: String,
    /// Simulated time per step (µs).
    pub interval_sim_us: u64,
    /// Stop at this simulated time (µs); 0 = never.
    pub quit_time_us: u64,
    /// Stage's grid cell size (m): reported as ranger `range_res`; geometry here is exact.
    pub resolution: f64,
    /// Target multiple of real time; ≤ 0 = as fast as possible.
    pub speedup: f64,
    /// Start paused (GUI).
    pub paused: bool,
    /// Worker threads requested by the file (we use rayon's pool; kept for reporting).
    pub threads: usize,
    /// Print the clock.
    pub show_clock: bool,
    /// Clock printing period (updates).
    pub show_clock_interval: u64,
    /// Models in pre-order (parents before children).
    pub models: Vec<ModelDesc>,
}

impl Default for WorldDesc {
    fn default() -> Self {
        crate::spec::settings(&worldfile::world::WorldSettings::default(), String::new())
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
