//! Stage 3 `laser` (not in Stage 4.1.1): a single-scan laser, which the simulator runs as a
//! ranger with one sensor.

use std::f64::consts::PI;

use super::{SensorSpec, TypeDefaults};
use crate::color::Rgba;
use crate::error::Error;
use crate::reader::Reader;
use crate::table::property_table;

/// The `laser` defaults (its row of the type table), with the warning Stage
/// 4.1.1's refusal deserves.
pub const DEFAULTS: TypeDefaults = TypeDefaults {
    watts: 17.5,
    thread_safe: true,
    legacy: Some(
        "Stage 4.1.1 has no `laser` model type (it exits with \"Unknown model type laser\"); loaded as a Stage 3 laser (use a `ranger` with a `sensor` in Stage 4)",
    ),
    ..TypeDefaults::new([0.15, 0.15, 0.2], Rgba::rgb(0.0, 0.0, 1.0))
};

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

/// Reads a laser's properties; a `resolution` below 1 is forced to 1 as Stage 3 does.
pub(crate) fn read(r: &mut Reader<'_, '_>) -> Result<LaserSpec, Error> {
    let mut spec = LaserSpec::read(r)?;
    if spec.resolution < 1 {
        r.warn("laser `resolution` < 1; forced to 1 as Stage 3 does");
        spec.resolution = 1;
    }
    Ok(spec)
}
