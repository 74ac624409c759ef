//! Model types, their defaults and their properties (stage-models.md §3, §4, §7–§14).
//!
//! Every default lives in exactly one place: [`TypeInfo`] for the per-type body, size, colour and
//! the few common values a type overrides, and one `property_table!` per property group.

use std::collections::BTreeMap;
use std::f64::consts::PI;

use serde::Serialize;

use crate::color::{ColorSpec, Rgba};
use crate::error::Error;
use crate::reader::{Pose, Reader};
use crate::table::property_table;

/// A model type that Stage (4.1.1, or an older version for legacy suite worlds) can build.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ModelType {
    /// `model`: a plain body.
    Model,
    /// `position`: a mobile base.
    Position,
    /// `ranger`: range sensors, one per `sensor` sub-entity.
    Ranger,
    /// `blobfinder`: colour blob detector.
    Blobfinder,
    /// `fiducial`: fiducial (landmark ID) finder.
    Fiducial,
    /// `gripper`: a two-paddle gripper.
    Gripper,
    /// `camera`: an OpenGL camera (GUI only in Stage).
    Camera,
    /// `actuator`: a linear or rotational actuator.
    Actuator,
    /// `blinkenlight`: a blinking light.
    Blinkenlight,
    /// `lightindicator`: an on/off light.
    Lightindicator,
    /// Stage 3 `laser` (not in Stage 4.1.1): a single-scan laser.
    Laser,
    /// Stage 3 `wifi` patch model (not in Stage 4.1.1): properties kept as data.
    Wifi,
}

/// What a model's body is before any `bitmap`, `noblocks` or `block` is applied.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum DefaultBody {
    /// The unit square filling the bounding box.
    UnitSquare,
    /// No blocks (sensors that are invisible unless given blocks).
    Empty,
    /// The gripper's base and two paddles (stage-models.md §11.2).
    Gripper,
}

/// Per-type defaults (stage-models.md §4).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TypeInfo {
    /// The type.
    pub model_type: ModelType,
    /// The word Stage uses for the type (and in generated names).
    pub name: &'static str,
    /// Default `size`.
    pub size: [f64; 3],
    /// Default colour.
    pub color: Rgba,
    /// Default body.
    pub body: DefaultBody,
    /// Default `watts`.
    pub watts: f64,
    /// Default `obstacle_return`.
    pub obstacle_return: bool,
    /// Default `blob_return`.
    pub blob_return: bool,
    /// Whether Stage updates this type in worker threads (§5.6).
    pub thread_safe: bool,
    /// For types Stage 4.1.1 does not have: what it would do, for the warning.
    pub legacy: Option<&'static str>,
}

const fn info(model_type: ModelType, name: &'static str, size: [f64; 3], color: Rgba) -> TypeInfo {
    TypeInfo {
        model_type,
        name,
        size,
        color,
        body: DefaultBody::UnitSquare,
        watts: 0.0,
        obstacle_return: true,
        blob_return: true,
        thread_safe: false,
        legacy: None,
    }
}

const BASE_SIZE: [f64; 3] = [0.4, 0.4, 1.0];

/// The type table.
pub const TYPES: &[TypeInfo] = &[
    info(ModelType::Model, "model", BASE_SIZE, Rgba::RED),
    info(ModelType::Position, "position", BASE_SIZE, Rgba::RED),
    TypeInfo {
        body: DefaultBody::Empty,
        thread_safe: true,
        ..info(
            ModelType::Ranger,
            "ranger",
            [0.15, 0.15, 0.2],
            Rgba::rgb(0.0, 0.0, 0.5),
        )
    },
    TypeInfo {
        body: DefaultBody::Empty,
        ..info(ModelType::Blobfinder, "blobfinder", BASE_SIZE, Rgba::RED)
    },
    TypeInfo {
        body: DefaultBody::Empty,
        thread_safe: true,
        ..info(ModelType::Fiducial, "fiducial", [0.0, 0.0, 0.0], Rgba::RED)
    },
    TypeInfo {
        body: DefaultBody::Gripper,
        ..info(
            ModelType::Gripper,
            "gripper",
            [0.2, 0.3, 0.2],
            Rgba::rgb(0.3, 0.3, 0.3),
        )
    },
    info(
        ModelType::Camera,
        "camera",
        [0.1, 0.07, 0.05],
        Rgba::rgb(0.0, 0.0, 0.0),
    ),
    TypeInfo {
        watts: 2.0,
        ..info(ModelType::Actuator, "actuator", BASE_SIZE, Rgba::RED)
    },
    info(
        ModelType::Blinkenlight,
        "blinkenlight",
        [0.02, 0.02, 0.02],
        Rgba::rgb(0.0, 1.0, 0.0),
    ),
    info(
        ModelType::Lightindicator,
        "lightindicator",
        BASE_SIZE,
        Rgba::RED,
    ),
    TypeInfo {
        watts: 17.5,
        thread_safe: true,
        legacy: Some(
            "Stage 4.1.1 has no `laser` model type (it exits with \"Unknown model type laser\"); loaded as a Stage 3 laser (use a `ranger` with a `sensor` in Stage 4)",
        ),
        ..info(
            ModelType::Laser,
            "laser",
            [0.15, 0.15, 0.2],
            Rgba::rgb(0.0, 0.0, 1.0),
        )
    },
    TypeInfo {
        obstacle_return: false,
        blob_return: false,
        thread_safe: true,
        legacy: Some(
            "Stage 4.1.1 has no `wifi` model type (it exits with \"Unknown model type wifi\"); loaded as a Stage 3 wifi model whose properties are kept as data",
        ),
        ..info(ModelType::Wifi, "wifi", [0.0, 0.0, 0.0], Rgba::RED)
    },
];

/// Type words of older Stage versions that name a 4.1.1 type (Stage 3's `map.inc` defined `map`
/// as a `model`): `(word, type, what Stage 4.1.1 would do)`.
pub const LEGACY_ALIASES: &[(&str, ModelType, &str)] = &[(
    "map",
    ModelType::Model,
    "Stage 4.1.1 has no `map` model type (it exits with \"Unknown model type map\"); Stage 3's map.inc defined `map` as a `model`, so it is loaded as one (Stage 4's map.inc defines `floorplan`)",
)];

impl ModelType {
    /// The defaults of this type.
    pub fn info(self) -> &'static TypeInfo {
        TYPES
            .iter()
            .find(|t| t.model_type == self)
            .unwrap_or(&TYPES[0])
    }

    /// Stage's word for the type.
    pub fn name(self) -> &'static str {
        self.info().name
    }

    /// The type for an entity type word: a Stage 4.1.1 type, a legacy type or alias (with the
    /// warning to give), or `None` for a word no Stage version knows.
    pub fn from_word(word: &str) -> Option<(ModelType, Option<&'static str>)> {
        if let Some(t) = TYPES.iter().find(|t| t.name == word) {
            return Some((t.model_type, t.legacy));
        }
        LEGACY_ALIASES
            .iter()
            .find(|(w, ..)| *w == word)
            .map(|(_, t, why)| (*t, Some(*why)))
    }
}

/// A Stage power pack (stage-models.md §15).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PowerPackSpec {
    /// Stored energy in joules (negative: an infinite source).
    pub stored: f64,
    /// Capacity in joules.
    pub capacity: f64,
}

property_table! {
    /// Properties every model reads (stage-models.md §3), apart from name, pose, size, origin,
    /// colour and the body, which [`crate::world::ModelSpec`] holds directly.
    pub struct CommonSpec {
        /// Remove the default body.
        noblocks: bool = false, flag("noblocks");
        /// Image file for the body (as written).
        bitmap: Option<String> = None, string("bitmap");
        /// Whether a thin boundary was added around the body.
        boundary: bool = false, flag("boundary");
        /// Children's z measured from this model's top.
        stack_children: bool = true, flag("stack_children");
        /// Mass in kg (only used by the position power model).
        mass: f64 = 0.0, float("mass");
        /// Seen by blobfinders (read but unused in 4.1.1).
        blob_return: bool = true, flag("blob_return");
        /// Fiducial key: finder and target must match.
        fiducial_key: i64 = 0, int("fiducial_key");
        /// Fiducial ID; non-zero makes the model detectable.
        fiducial_return: i64 = 0, int("fiducial_return");
        /// Can be gripped.
        gripper_return: bool = false, flag("gripper_return");
        /// Takes part in collisions.
        obstacle_return: bool = true, flag("obstacle_return");
        /// Ranger intensity; negative makes the model invisible to rangers.
        ranger_return: f64 = 1.0, float("ranger_return");
        /// GUI: draw a heading marker.
        gui_nose: bool = false, flag("gui_nose");
        /// GUI: draw a grid.
        gui_grid: bool = false, flag("gui_grid");
        /// GUI: draw the bounding box.
        gui_outline: bool = false, flag("gui_outline");
        /// GUI: draggable (`None`: top-level models yes, children no).
        gui_move: Option<bool> = None, flag("gui_move");
        /// Stored only (the Player `map` interface is not provided).
        map_resolution: f64 = 0.1, float("map_resolution");
        /// Stored only.
        friction: f64 = 0.0, float("friction");
        /// Controllers: each string is a controller name followed by its arguments.
        ctrl: Vec<String> = Vec::new(), strings("ctrl");
        /// Milliseconds between updates.
        update_interval: i64 = 100, int("update_interval");
        /// Speech bubble text.
        say: String = String::new(), string("say");
        /// GUI trail length (global in Stage).
        trail_length: i64 = 50, int("trail_length");
        /// GUI trail sampling interval (global in Stage).
        trail_interval: i64 = 5, int("trail_interval");
        /// Subscribed at load time.
        alwayson: bool = false, flag("alwayson");
        /// Power drawn, W.
        watts: f64 = 0.0, float("watts");
        /// Charging power given to touching models, W.
        give_watts: f64 = 0.0, float("give_watts");
        /// Charging power accepted, W.
        take_watts: f64 = 0.0, float("take_watts");
        /// `joules`: a full power pack of this many J.
        joules: Option<f64> = None, float("joules");
        /// `joules_capacity`.
        joules_capacity: Option<f64> = None, float("joules_capacity");
        /// `kjoules`: a full power pack of this many kJ.
        kjoules: Option<f64> = None, float("kjoules");
        /// `kjoules_capacity`.
        kjoules_capacity: Option<f64> = None, float("kjoules_capacity");
        /// Debug flag.
        debug: i64 = 0, int("debug");
        /// Worker queue (overwritten at subscription in Stage; no effect).
        event_queue: i64 = 0, int("event_queue");
    }
}

impl CommonSpec {
    /// The defaults of a model of this type.
    pub fn for_type(t: ModelType) -> Self {
        let i = t.info();
        CommonSpec {
            watts: i.watts,
            obstacle_return: i.obstacle_return,
            blob_return: i.blob_return,
            ..CommonSpec::default()
        }
    }

    /// The power pack the `joules`/`kjoules` properties create, in Stage's order of application.
    pub fn power_pack(&self) -> Option<PowerPackSpec> {
        let mut pack: Option<PowerPackSpec> = None;
        let blank = PowerPackSpec {
            stored: 0.0,
            capacity: 0.0,
        };
        if let Some(j) = self.joules {
            pack = Some(PowerPackSpec {
                stored: j,
                capacity: j,
            });
        }
        if let Some(c) = self.joules_capacity {
            pack.get_or_insert(blank).capacity = c;
        }
        if let Some(k) = self.kjoules {
            pack = Some(PowerPackSpec {
                stored: 1000.0 * k,
                capacity: 1000.0 * k,
            });
        }
        if let Some(c) = self.kjoules_capacity {
            pack.get_or_insert(blank).capacity = 1000.0 * c;
        }
        // Setting the capacity clamps the stored energy (a negative store means infinite).
        if let Some(p) = &mut pack {
            if p.stored > p.capacity && p.stored >= 0.0 {
                p.stored = p.capacity;
            }
        }
        pack
    }
}

/// Position drive models.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Drive {
    /// Differential steering.
    Diff,
    /// Omnidirectional.
    Omni,
    /// Car-like (speed and steering angle).
    Car,
}

/// Position localization modes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Localization {
    /// Perfect pose relative to `localization_origin`.
    Gps,
    /// Integrated odometry with `odom_error`.
    Odom,
}

const DRIVES: &[(&str, Drive)] = &[
    ("diff", Drive::Diff),
    ("omni", Drive::Omni),
    ("car", Drive::Car),
];
const LOCALIZATIONS: &[(&str, Localization)] =
    &[("gps", Localization::Gps), ("odom", Localization::Odom)];

const DEFAULT_BOUNDS: [f64; 8] = [-1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -PI / 2.0, PI / 2.0];

property_table! {
    /// A `position` model (stage-models.md §7.1). Velocities in m/s and rad/s.
    pub struct PositionSpec {
        /// Drive model.
        drive: Drive = Drive::Diff, choice("drive", DRIVES);
        /// Initial velocity `[x y z a]` (overwritten by the first control update in Stage).
        velocity: Pose = [0.0; 4], pose("velocity");
        /// Localization mode.
        localization: Localization = Localization::Gps, choice("localization", LOCALIZATIONS);
        /// Origin of the reported pose frame. Stage's default, the model's global pose at load
        /// time, is filled in by the resolver.
        localization_origin: Pose = [0.0; 4], pose("localization_origin");
        /// Odometry error factors `[x y z a]` (the 4th converted as an angle, a Stage quirk).
        /// `None`: Stage draws each uniformly from `[-s/2, s/2)` with `s` =
        /// [`PositionSpec::ODOM_ERROR_SPAN`], once per model — the simulator draws them from
        /// its seeded generator.
        odom_error: Option<Pose> = None, pose("odom_error");
        /// Wheelbase for car drive, m.
        wheelbase: f64 = 1.0, length("wheelbase");
        /// `[xmin xmax ymin ymax zmin zmax amin amax]` velocity clamp.
        velocity_bounds: [f64; 8] = DEFAULT_BOUNDS, floats::<8>("velocity_bounds", "llllllaa");
        /// Same layout, clamp on commanded accelerations.
        acceleration_bounds: [f64; 8] = DEFAULT_BOUNDS, floats::<8>("acceleration_bounds", "llllllaa");
    }
}

impl PositionSpec {
    /// Spans of the random default odometry errors for x, y, z, a (model_position.cc).
    pub const ODOM_ERROR_SPAN: [f64; 4] = [0.03, 0.03, 0.0, 0.05];
}

property_table! {
    /// One `sensor` of a ranger (stage-models.md §8.1).
    pub struct SensorSpec {
        /// Pose in the ranger's body frame (heading as written, not normalised).
        pose: Pose = [0.0; 4], raw_pose("pose");
        /// Visual size; `size[2] / 2` raises the ray origin.
        size: [f64; 3] = [0.02, 0.02, 0.02], size("size", 0.02);
        /// `[min max]` range, m (`min` is not applied to data in Stage).
        range: [f64; 2] = [0.0, 5.0], floats::<2>("range", "ll");
        /// Angular spread of the samples, rad.
        fov: f64 = 0.1, angle("fov");
        /// Number of rays.
        samples: i64 = 1, int("samples");
        /// Colour (GUI only); `"random"` allowed.
        color: ColorSpec = ColorSpec::Rgba(Rgba { r: 0.0, g: 1.0, b: 0.0, a: 0.3 }), color_prop("color");
    }
}

/// A ranger: its transducers in `sensor` order.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct RangerSpec {
    /// Transducers.
    pub sensors: Vec<SensorSpec>,
}

property_table! {
    /// A `blobfinder` (stage-models.md §9.1).
    pub struct BlobfinderSpec {
        /// `[width height]` of the image in pixels (rays, rows).
        image: [i64; 2] = [80, 60], ints::<2>("image");
        /// Ray length in metres (not converted by `unit_length`, as in Stage).
        range: f64 = 12.0, float("range");
        /// Horizontal field of view, rad.
        fov: f64 = PI / 3.0, angle("fov");
        /// Centre direction relative to the heading, rad.
        pan: f64 = 0.0, angle("pan");
        /// Colour filter; empty means every colour is reported.
        colors: Vec<Rgba> = Vec::new(), blob_colors("colors");
    }
}

property_table! {
    /// A `fiducial` finder (stage-models.md §10.1).
    pub struct FiducialSpec {
        /// Read but unused by Stage, m.
        range_min: f64 = 0.0, length("range_min");
        /// Detection range (exclusive), m.
        range_max: f64 = 8.0, length("range_max");
        /// Beyond this the ID is reported as 0, m.
        range_max_id: f64 = 5.0, length("range_max_id");
        /// Field of view, rad.
        fov: f64 = PI, angle("fov");
        /// Accept targets whose line-of-sight ray hits nothing.
        ignore_zloc: bool = false, flag("ignore_zloc");
    }
}

/// Gripper paddle states.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Paddles {
    /// Open (position 0).
    Open,
    /// Closed (position 1).
    Closed,
}

/// Gripper lift states.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Lift {
    /// Down (position 0).
    Down,
    /// Up (position 1).
    Up,
}

/// Initial paddle and lift state (`paddle_state [ "open" "down" ]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct PaddleState {
    /// Paddles.
    pub paddles: Paddles,
    /// Lift.
    pub lift: Lift,
}

impl Default for PaddleState {
    fn default() -> Self {
        PaddleState {
            paddles: Paddles::Open,
            lift: Lift::Down,
        }
    }
}

property_table! {
    /// A `gripper` (stage-models.md §11.1).
    pub struct GripperSpec {
        /// Paddle length, width, height as fractions of the gripper size (converted as lengths,
        /// a Stage quirk that only matters with `unit_length` other than metres).
        paddle_size: [f64; 3] = [0.66, 0.1, 0.4], floats::<3>("paddle_size", "lll");
        /// Initial paddle and lift state.
        paddle_state: PaddleState = PaddleState::default(), paddle_state("paddle_state");
        /// The break beams drive the paddles.
        autosnatch: bool = false, flag("autosnatch");
    }
}

property_table! {
    /// A `camera` (stage-models.md §12).
    pub struct CameraSpec {
        /// `[width height]` in pixels.
        resolution: [i64; 2] = [32, 32], ints::<2>("resolution");
        /// `[near far]` clip distances, m.
        range: [f64; 2] = [0.2, 8.0], floats::<2>("range", "ll");
        /// `[horizontal vertical]` field of view in **degrees** (never converted, as in Stage).
        fov: [f64; 2] = [70.0, 40.0], floats::<2>("fov", "ff");
        /// `[pan tilt]` in **degrees** (never converted).
        pantilt: [f64; 2] = [0.0, 0.0], floats::<2>("pantilt", "ff");
    }
}

/// Actuator kinds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ActuatorType {
    /// Moves along `axis`.
    Linear,
    /// Rotates about z.
    Rotational,
}

const ACTUATOR_TYPES: &[(&str, ActuatorType)] = &[
    ("linear", ActuatorType::Linear),
    ("rotational", ActuatorType::Rotational),
];

property_table! {
    /// An `actuator` (stage-models.md §13). Positions in raw units (radians when rotational).
    pub struct ActuatorSpec {
        /// Linear or rotational.
        actuator_type: ActuatorType = ActuatorType::Linear, choice("type", ACTUATOR_TYPES);
        /// Unit axis for a linear actuator (Stage leaves (0,0,0) when absent).
        axis: [f64; 3] = [0.0, 0.0, 0.0], floats::<3>("axis", "fff");
        /// Lower position limit.
        min_position: f64 = 0.0, float("min_position");
        /// Upper position limit.
        max_position: f64 = 1.0, float("max_position");
        /// Speed limit.
        max_speed: f64 = 1.0, float("max_speed");
        /// Initial position (already applied to the model's pose by the resolver).
        start_position: Option<f64> = None, float("start_position");
    }
}

property_table! {
    /// A `blinkenlight` (stage-models.md §14).
    pub struct BlinkenlightSpec {
        /// Blink period, ms (unused by Stage).
        period: i64 = 1000, int("period");
        /// Duty cycle (unused by Stage).
        dutycycle: f64 = 1.0, float("dutycycle");
        /// Enabled — read from the `dutycycle` property as an integer (a Stage quirk, so
        /// `dutycycle 0.5` disables the light).
        enabled: bool = true, flag("dutycycle");
    }
}

property_table! {
    /// A Stage 3 `laser` (Stage 3.2 defaults: 180 samples over 180°, 8 m).
    pub struct LaserSpec {
        /// Number of samples.
        samples: i64 = 180, int("samples");
        /// Maximum range, m.
        range_max: f64 = 8.0, length("range_max");
        /// Field of view, rad.
        fov: f64 = PI, angle("fov");
        /// Compute every n-th sample (at least 1).
        resolution: i64 = 1, int("resolution");
    }
}

impl LaserSpec {
    /// The equivalent Stage 4 ranger transducer (one sensor at the laser's origin).
    pub fn as_sensor(&self) -> SensorSpec {
        SensorSpec {
            range: [0.0, self.range_max],
            fov: self.fov,
            samples: self.samples,
            ..SensorSpec::default()
        }
    }
}

/// A Stage 3 `wifi` model: every property it was given, as raw text.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct WifiSpec {
    /// Property name to its values.
    pub properties: BTreeMap<String, Vec<String>>,
}

/// The type-specific part of a model.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "type", rename_all = "lowercase")]
pub enum TypeSpec {
    /// `model`.
    Model,
    /// `position`.
    Position(PositionSpec),
    /// `ranger`.
    Ranger(RangerSpec),
    /// `blobfinder`.
    Blobfinder(BlobfinderSpec),
    /// `fiducial`.
    Fiducial(FiducialSpec),
    /// `gripper`.
    Gripper(GripperSpec),
    /// `camera`.
    Camera(CameraSpec),
    /// `actuator`.
    Actuator(ActuatorSpec),
    /// `blinkenlight`.
    Blinkenlight(BlinkenlightSpec),
    /// `lightindicator`.
    Lightindicator,
    /// Stage 3 `laser`.
    Laser(LaserSpec),
    /// Stage 3 `wifi`.
    Wifi(WifiSpec),
}

impl TypeSpec {
    /// Reads the type-specific properties of a model of type `t`.
    pub(crate) fn read(t: ModelType, r: &mut Reader<'_, '_>) -> Result<TypeSpec, Error> {
        Ok(match t {
            ModelType::Model => TypeSpec::Model,
            ModelType::Position => {
                let spec = PositionSpec::read(r)?;
                if let Some(p) = r.prop("odom") {
                    r.warn_at(
                        p,
                        "`odom` is obsolete and ignored (Stage warns too); use `localization_origin`",
                    );
                }
                TypeSpec::Position(spec)
            }
            ModelType::Ranger => TypeSpec::Ranger(RangerSpec::default()),
            ModelType::Blobfinder => TypeSpec::Blobfinder(BlobfinderSpec::read(r)?),
            ModelType::Fiducial => TypeSpec::Fiducial(FiducialSpec::read(r)?),
            ModelType::Gripper => TypeSpec::Gripper(GripperSpec::read(r)?),
            ModelType::Camera => TypeSpec::Camera(CameraSpec::read(r)?),
            ModelType::Actuator => {
                let mut spec = ActuatorSpec::read(r)?;
                if spec.actuator_type == ActuatorType::Linear && r.exists("axis") {
                    let [x, y, z] = spec.axis;
                    let len = (x * x + y * y + z * z).sqrt();
                    if len == 0.0 || !len.is_finite() {
                        r.warn("actuator `axis` has zero length; using (1, 0, 0) as Stage does");
                        spec.axis = [1.0, 0.0, 0.0];
                    } else {
                        spec.axis = [x / len, y / len, z / len];
                    }
                }
                TypeSpec::Actuator(spec)
            }
            ModelType::Blinkenlight => TypeSpec::Blinkenlight(BlinkenlightSpec::read(r)?),
            ModelType::Lightindicator => TypeSpec::Lightindicator,
            ModelType::Laser => {
                let mut spec = LaserSpec::read(r)?;
                if spec.resolution < 1 {
                    r.warn("laser `resolution` < 1; forced to 1 as Stage 3 does");
                    spec.resolution = 1;
                }
                TypeSpec::Laser(spec)
            }
            ModelType::Wifi => {
                let mut spec = WifiSpec::default();
                let doc = r.doc();
                for p in &doc.entity(r.entity()).properties {
                    if p.is_used() {
                        continue;
                    }
                    p.mark_used();
                    spec.properties.insert(
                        p.name.to_string(),
                        p.values.iter().map(|v| v.text.to_string()).collect(),
                    );
                }
                TypeSpec::Wifi(spec)
            }
        })
    }
}

impl Reader<'_, '_> {
    /// A sensor or model colour under the `color`/`color_rgba` pair.
    pub(crate) fn color_prop(&mut self, _name: &str) -> Result<Option<ColorSpec>, Error> {
        self.color(true)
    }

    /// Blobfinder `colors`: `colors_count` names, read only when `colors` exists (Stage).
    pub(crate) fn blob_colors(&mut self, name: &str) -> Result<Option<Vec<Rgba>>, Error> {
        if !self.exists(name) {
            return Ok(None);
        }
        let count = self.int("colors_count")?.unwrap_or(0);
        let Some(p) = self.prop(name) else {
            return Ok(Some(Vec::new()));
        };
        let count = usize::try_from(count).unwrap_or(0);
        if count > p.values.len() {
            // Stage exits: the tuple is too short for `colors_count`.
            return Err(Error::at(
                crate::error::ErrorKind::TupleTooShort {
                    name: name.into(),
                    needed: count,
                    found: p.values.len(),
                },
                &self.doc().sources,
                p.loc,
                name,
            ));
        }
        let mut out = Vec::with_capacity(count);
        for v in &p.values[..count] {
            out.push(self.named_color(p, &v.text));
        }
        Ok(Some(out))
    }

    /// Gripper `paddle_state [ "open"|"closed" "up"|"down" ]`.
    pub(crate) fn paddle_state(&mut self, name: &str) -> Result<Option<PaddleState>, Error> {
        let Some([paddles, lift]) = self.string_tuple::<2>(name)? else {
            return Ok(None);
        };
        let mut state = PaddleState::default();
        match paddles.as_str() {
            "open" => state.paddles = Paddles::Open,
            "closed" => state.paddles = Paddles::Closed,
            other => self.warn(format!(
                "gripper paddle state \"{other}\" is not \"open\" or \"closed\"; ignored as in Stage"
            )),
        }
        match lift.as_str() {
            "down" => state.lift = Lift::Down,
            "up" => state.lift = Lift::Up,
            other => self.warn(format!(
                "gripper lift state \"{other}\" is not \"up\" or \"down\"; ignored as in Stage"
            )),
        }
        Ok(Some(state))
    }
}
