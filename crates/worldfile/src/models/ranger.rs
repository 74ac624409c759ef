//! `ranger`: range sensors, one per `sensor` sub-entity (stage-models.md §8.1). The sensors are
//! entities of their own, read by the resolver as it meets them
//! ([`crate::world::WorldSpec::load`]); the ranger itself has no properties of its own.

use serde::Serialize;

use super::TypeDefaults;
use crate::color::{ColorSpec, Rgba};
use crate::error::Error;
use crate::reader::{Pose, Reader};
use crate::table::property_table;

/// The `ranger` defaults (its row of the type table): invisible unless given
/// blocks, updated in worker threads.
pub const DEFAULTS: TypeDefaults = TypeDefaults {
    body: super::DefaultBody::Empty,
    thread_safe: true,
    ..TypeDefaults::new([0.15, 0.15, 0.2], Rgba::rgb(0.0, 0.0, 0.5))
};

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

/// A ranger starts with no sensors: each `sensor` entity inside it adds one.
pub(crate) fn read(_: &mut Reader<'_, '_>) -> Result<RangerSpec, Error> {
    Ok(RangerSpec::default())
}

impl Reader<'_, '_> {
    /// A sensor colour under the `color`/`color_rgba` pair.
    pub(crate) fn color_prop(&mut self, _name: &str) -> Result<Option<ColorSpec>, Error> {
        self.color(true)
    }
}
