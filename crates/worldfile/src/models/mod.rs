//! Model types, their defaults and their properties (stage-models.md §3, §4, §7–§14).
//!
//! Each model type has its own module here, named by Stage's word for the type, holding its
//! defaults ([`TypeDefaults`]: size, colour and body, and the few common values it overrides;
//! with the type and word, its row of the type table, [`TypeInfo`]), its properties
//! as a `property_table!` spec struct with Stage's defaults, and the `read` function that reads
//! them. The one `model_types!` list below registers the modules (one line a type): it generates
//! [`ModelType`], [`TypeSpec`], the type table [`TYPES`] and the dispatch of `TypeSpec::read`.
//! The properties every model reads are [`CommonSpec`], here.

pub use actuator::ActuatorType;
pub use gripper::{Lift, PaddleState, Paddles};
pub use position::{Drive, Localization};
pub use ranger::SensorSpec;

use serde::Serialize;

use crate::color::Rgba;
use crate::error::Error;
use crate::reader::Reader;
use crate::table::property_table;

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

/// One row of the type table (stage-models.md §4): a type, its word and its defaults.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TypeInfo {
    /// The type.
    pub model_type: ModelType,
    /// The word Stage uses for the type (and in generated names).
    pub name: &'static str,
    /// The defaults the type's module gives.
    #[serde(flatten)]
    pub defaults: TypeDefaults,
}

/// Per-type defaults (stage-models.md §4), as a type's module gives them (its `DEFAULTS`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TypeDefaults {
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

impl TypeDefaults {
    /// The usual values for everything but the size and colour: the unit square body, no power
    /// draw, seen by obstacles and blobfinders, updated in the main thread, a Stage 4.1.1 type.
    /// A module overrides the rest with struct update syntax.
    pub const fn new(size: [f64; 3], color: Rgba) -> Self {
        TypeDefaults {
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
}

/// Stage's default `size` (most types keep it).
pub const BASE_SIZE: [f64; 3] = [0.4, 0.4, 1.0];

/// Builds every per-type item from the list of type modules: one line a type, in the order of
/// [`ModelType`] (which orders types). A line is `word: Variant` for a type with no properties
/// of its own, or `word: Variant(Spec)` for one whose module defines `Spec` and
/// `read(&mut Reader) -> Result<Spec, Error>`; `word` is Stage's word for the type and the name
/// of its module, which defines `DEFAULTS`, its [`TypeDefaults`].
macro_rules! model_types {
    ( $( $(#[$doc:meta])* $module:ident : $variant:ident $( ($spec:ident) )? , )* ) => {
        $(
            pub mod $module;
            $( pub use $module::$spec; )?
        )*

        /// A model type that Stage (4.1.1, or an older version for legacy suite worlds) can
        /// build.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
        #[serde(rename_all = "lowercase")]
        pub enum ModelType {
            $( $(#[$doc])* $variant, )*
        }

        /// The type table, in [`ModelType`] order.
        pub const TYPES: &[TypeInfo] = &[
            $(
                TypeInfo {
                    model_type: ModelType::$variant,
                    name: stringify!($module),
                    defaults: $module::DEFAULTS,
                }
            ),*
        ];

        /// The type-specific part of a model.
        #[derive(Clone, Debug, PartialEq, Serialize)]
        #[serde(tag = "type", rename_all = "lowercase")]
        pub enum TypeSpec {
            $( $(#[$doc])* $variant $( ($spec) )?, )*
        }

        impl TypeSpec {
            /// Reads the type-specific properties of a model of type `t`.
            pub(crate) fn read(t: ModelType, r: &mut Reader<'_, '_>) -> Result<TypeSpec, Error> {
                Ok(match t {
                    $( ModelType::$variant => read_spec!($variant, $module, r $(, $spec)?), )*
                })
            }
        }
    };
}

/// The [`TypeSpec`] of a type without properties, or its module's reading.
macro_rules! read_spec {
    ($variant:ident, $module:ident, $r:ident) => {
        TypeSpec::$variant
    };
    ($variant:ident, $module:ident, $r:ident, $spec:ident) => {
        TypeSpec::$variant($module::read($r)?)
    };
}

model_types! {
    /// `model`: a plain body.
    model: Model,
    /// `position`: a mobile base.
    position: Position(PositionSpec),
    /// `ranger`: range sensors, one per `sensor` sub-entity.
    ranger: Ranger(RangerSpec),
    /// `blobfinder`: colour blob detector.
    blobfinder: Blobfinder(BlobfinderSpec),
    /// `fiducial`: fiducial (landmark ID) finder.
    fiducial: Fiducial(FiducialSpec),
    /// `gripper`: a two-paddle gripper.
    gripper: Gripper(GripperSpec),
    /// `camera`: an OpenGL camera (GUI only in Stage).
    camera: Camera(CameraSpec),
    /// `actuator`: a linear or rotational actuator.
    actuator: Actuator(ActuatorSpec),
    /// `blinkenlight`: a blinking light.
    blinkenlight: Blinkenlight(BlinkenlightSpec),
    /// `lightindicator`: an on/off light.
    lightindicator: Lightindicator,
    /// Stage 3 `laser` (not in Stage 4.1.1): a single-scan laser.
    laser: Laser(LaserSpec),
    /// Stage 3 `wifi` patch model (not in Stage 4.1.1): properties kept as data.
    wifi: Wifi(WifiSpec),
}

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
        // the table holds one row per type, in the enum's order
        &TYPES[self as usize]
    }

    /// Stage's word for the type.
    pub fn name(self) -> &'static str {
        self.info().name
    }

    /// The type for an entity type word: a Stage 4.1.1 type, a legacy type or alias (with the
    /// warning to give), or `None` for a word no Stage version knows.
    pub fn from_word(word: &str) -> Option<(ModelType, Option<&'static str>)> {
        if let Some(t) = TYPES.iter().find(|t| t.name == word) {
            return Some((t.model_type, t.defaults.legacy));
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
        let i = &t.info().defaults;
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

#[cfg(test)]
mod tests {
    use super::*;

    /// `ModelType::info` indexes the table by the type: every row must sit at its type's place,
    /// and every word must lead back to its type.
    #[test]
    fn every_type_finds_its_own_row_and_word() {
        for (i, row) in TYPES.iter().enumerate() {
            assert_eq!(row.model_type as usize, i, "row of {}", row.name);
            assert_eq!(row.model_type.info(), row);
            assert_eq!(
                ModelType::from_word(row.name).map(|(t, _)| t),
                Some(row.model_type)
            );
        }
        assert_eq!(ModelType::Model.name(), "model");
        assert_eq!(ModelType::Lightindicator.name(), "lightindicator");
        assert_eq!(ModelType::Actuator.info().defaults.watts, 2.0);
        assert!(ModelType::Laser.info().defaults.legacy.is_some());
    }

    /// The spec of a type without properties serialises as the bare tag, like the type's word.
    #[test]
    fn type_specs_serialise_with_their_word() {
        let json = |s: &TypeSpec| serde_json::to_string(s).unwrap();
        assert_eq!(json(&TypeSpec::Model), r#"{"type":"model"}"#);
        let fid = json(&TypeSpec::Fiducial(FiducialSpec::default()));
        assert!(
            fid.starts_with(r#"{"type":"fiducial","range_min":0.0"#),
            "{fid}"
        );
        let drive = serde_json::to_string(&Drive::Omni).unwrap();
        assert_eq!(drive, r#""omni""#);
    }
}
