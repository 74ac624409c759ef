//! `fiducial`: a fiducial (landmark ID) finder (stage-models.md §10.1).

use std::f64::consts::PI;

use super::TypeDefaults;
use crate::color::Rgba;
use crate::error::Error;
use crate::reader::Reader;
use crate::table::property_table;

/// The `fiducial` defaults (its row of the type table): no size, no body, updated in worker threads.
pub const DEFAULTS: TypeDefaults = TypeDefaults {
    body: super::DefaultBody::Empty,
    thread_safe: true,
    ..TypeDefaults::new([0.0, 0.0, 0.0], Rgba::RED)
};

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

/// Reads a fiducial finder's properties.
pub(crate) fn read(r: &mut Reader<'_, '_>) -> Result<FiducialSpec, Error> {
    FiducialSpec::read(r)
}
