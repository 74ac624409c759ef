//! `camera`: an OpenGL camera in Stage, GUI only (stage-models.md §12).

use super::TypeDefaults;
use crate::color::Rgba;
use crate::error::Error;
use crate::reader::Reader;
use crate::table::property_table;

/// The `camera` defaults (its row of the type table).
pub const DEFAULTS: TypeDefaults = TypeDefaults::new([0.1, 0.07, 0.05], Rgba::rgb(0.0, 0.0, 0.0));

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

/// Reads a camera's properties.
pub(crate) fn read(r: &mut Reader<'_, '_>) -> Result<CameraSpec, Error> {
    CameraSpec::read(r)
}
