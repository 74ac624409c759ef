//! A plain-data description of a world: what [`crate::World::from_desc`] builds from. It mirrors
//! the resolved worldfile model tree (stage-models.md §3–§14) with every default applied, so
//! tests and tools can build worlds without a file, and `World::from_spec` only has to translate
//! the `worldfile` crate's `WorldSpec` into it.

use crate::pose::Pose;

/// An RGBA colour, components in `0..=1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Color {
    /// Red.
    pub r: f32,
    /// Green.
    pub g: f32,
    /// Blue.
    pub b: f32,
    /// Alpha.
    pub a: f32,
}

impl Color {
    /// Opaque colour from components.
    pub const fn rgb(r: f32, g: f32, b: f32) -> Color {
        Color { r, g, b, a: 1.0 }
    }
    /// Stage's default model colour.
    pub const RED: Color = Color::rgb(1.0, 0.0, 0.0);

    /// Blobfinder colour equality: RGB within 1e-5, alpha ignored (spec §9.2).
    pub fn same_rgb(&self, o: &Color) -> bool {
        (self.r - o.r).abs() < 1e-5 && (self.g - o.g).abs() < 1e-5 && (self.b - o.b).abs() < 1e-5
    }

    /// Packed `0xRRGGBB` as Player reports blob colours (`trunc(c·255)` per channel).
    pub fn packed_rgb(&self) -> u32 {
        let c = |v: f32| ((v as f64 * 255.0) as u32).min(255);
        (c(self.r) << 16) | (c(self.g) << 8) | c(self.b)
    }
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

/// `drive` of a position model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Drive {
    /// Differential: x speed and turn rate.
    Diff,
    /// Holonomic: x, y and turn.
    Omni,
    /// Car-like: speed and steering angle, with `wheelbase`.
    Car,
}

/// `localization` of a position model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Localization {
    /// Report the true pose in the `localization_origin` frame (one step late, like Stage).
    Gps,
    /// Integrate commanded velocities with `odom_error` biases.
    Odom,
}

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
    fn default() -> Self {
        let a = 90f64.to_radians();
        PositionDesc {
            drive: Drive::Diff,
            localization: Localization::Gps,
            localization_origin: None,
            odom_error: None,
            wheelbase: 1.0,
            velocity_bounds: [-1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -a, a],
            acceleration_bounds: [-1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -a, a],
            velocity: Pose::ZERO,
        }
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
    fn default() -> Self {
        SensorDesc {
            pose: Pose::ZERO,
            size: [0.02, 0.02, 0.02],
            range: [0.0, 5.0],
            fov: 0.1,
            samples: 1,
            noise: 0.0,
            noise_relative: 0.0,
            color: Color {
                r: 0.0,
                g: 1.0,
                b: 0.0,
                a: 0.3,
            },
        }
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
    fn default() -> Self {
        BlobfinderDesc {
            image: [80, 60],
            range: 12.0,
            fov: std::f64::consts::PI / 3.0,
            pan: 0.0,
            colors: Vec::new(),
        }
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
    fn default() -> Self {
        FiducialDesc {
            range_min: 0.0,
            range_max: 8.0,
            range_max_id: 5.0,
            fov: std::f64::consts::PI,
            ignore_zloc: false,
        }
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
    fn default() -> Self {
        GripperDesc {
            paddle_size: [0.66, 0.1, 0.4],
            closed: false,
            up: false,
            autosnatch: false,
        }
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
    fn default() -> Self {
        CameraDesc {
            resolution: [32, 32],
            range: [0.2, 8.0],
            fov: [70f64.to_radians(), 40f64.to_radians()],
            pantilt: [0.0, 0.0],
        }
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
    fn default() -> Self {
        ActuatorDesc {
            kind: ActuatorKind::Linear,
            axis: [1.0, 0.0, 0.0],
            min_position: 0.0,
            max_position: 1.0,
            max_speed: 1.0,
            start_position: 0.0,
        }
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
    /// The Stage type word.
    pub fn type_name(&self) -> &'static str {
        match self {
            KindDesc::Model => "model",
            KindDesc::Position(_) => "position",
            KindDesc::Ranger(_) => "ranger",
            KindDesc::Blobfinder(_) => "blobfinder",
            KindDesc::Fiducial(_) => "fiducial",
            KindDesc::Gripper(_) => "gripper",
            KindDesc::Camera(_) => "camera",
            KindDesc::Actuator(_) => "actuator",
            KindDesc::Blinkenlight { .. } => "blinkenlight",
            KindDesc::LightIndicator => "lightindicator",
        }
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
    /// A model of the given kind with Stage's common defaults for that type (spec §3, §4).
    pub fn new(name: &str, kind: KindDesc) -> ModelDesc {
        let (size, color, body) = match &kind {
            KindDesc::Ranger(_) => ([0.15, 0.15, 0.2], Color::rgb(0.0, 0.0, 0.5), false),
            KindDesc::Blobfinder(_) => ([0.4, 0.4, 1.0], Color::RED, false),
            KindDesc::Fiducial(_) => ([0.0, 0.0, 0.0], Color::RED, false),
            KindDesc::Gripper(_) => ([0.2, 0.3, 0.2], Color::rgb(0.3, 0.3, 0.3), false),
            KindDesc::Camera(_) => ([0.1, 0.07, 0.05], Color::rgb(0.0, 0.0, 0.0), true),
            KindDesc::Blinkenlight { .. } => ([0.02, 0.02, 0.02], Color::rgb(0.0, 1.0, 0.0), true),
            _ => ([0.4, 0.4, 1.0], Color::RED, true),
        };
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
            stack_children: true,
            obstacle_return: true,
            ranger_return: 1.0,
            fiducial_return: 0,
            fiducial_key: 0,
            gripper_return: false,
            update_interval_us: 100_000,
            alwayson: false,
            ctrl: Vec::new(),
            say: String::new(),
            mass: 0.0,
            source: String::new(),
        }
    }
}

/// World-level settings (stage-worldfile.md §10) and the model tree.
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
        WorldDesc {
            name: String::new(),
            interval_sim_us: 100_000,
            quit_time_us: 0,
            resolution: 0.02,
            speedup: 1.0,
            paused: false,
            threads: 1,
            show_clock: false,
            show_clock_interval: 100,
            models: Vec::new(),
        }
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
