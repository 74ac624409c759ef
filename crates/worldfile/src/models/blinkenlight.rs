//! `blinkenlight`: a blinking light (stage-models.md §14).

use super::TypeDefaults;
use crate::color::Rgba;
use crate::error::Error;
use crate::reader::Reader;
use crate::table::property_table;

/// The `blinkenlight` defaults (its row of the type table).
pub const DEFAULTS: TypeDefaults = TypeDefaults::new([0.02, 0.02, 0.02], Rgba::rgb(0.0, 1.0, 0.0));

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

/// Reads a blinkenlight's properties.
pub(crate) fn read(r: &mut Reader<'_, '_>) -> Result<BlinkenlightSpec, Error> {
    BlinkenlightSpec::read(r)
}
