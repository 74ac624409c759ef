//! `actuator`: a linear or rotational actuator (stage-models.md §13). Its `start_position`
//! displaces the model's pose, which the resolver applies ([`crate::world::WorldSpec::load`]).

use super::{BASE_SIZE, TypeDefaults};
use crate::color::Rgba;
use crate::error::Error;
use crate::reader::Reader;
use crate::table::{property_table, word_enum};

/// The `actuator` defaults (its row of the type table): it draws 2 W.
pub const DEFAULTS: TypeDefaults = TypeDefaults {
    watts: 2.0,
    ..TypeDefaults::new(BASE_SIZE, Rgba::RED)
};

word_enum! {
    /// Actuator kinds.
    pub enum ActuatorType in ACTUATOR_TYPES {
        /// Moves along `axis`.
        Linear = "linear",
        /// Rotates about z.
        Rotational = "rotational",
    }
}

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

/// Reads an actuator's properties; a linear actuator's given `axis` is made a unit vector
/// ((1, 0, 0) when it has no length, as in Stage).
pub(crate) fn read(r: &mut Reader<'_, '_>) -> Result<ActuatorSpec, Error> {
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
    Ok(spec)
}
