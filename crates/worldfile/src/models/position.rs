//! `position`: a mobile base (stage-models.md §7.1).

use std::f64::consts::PI;

use super::{BASE_SIZE, TypeDefaults};
use crate::color::Rgba;
use crate::error::Error;
use crate::reader::{Pose, Reader};
use crate::table::{property_table, word_enum};

/// The `position` defaults (its row of the type table).
pub const DEFAULTS: TypeDefaults = TypeDefaults::new(BASE_SIZE, Rgba::RED);

word_enum! {
    /// Position drive models.
    pub enum Drive in DRIVES {
        /// Differential steering.
        Diff = "diff",
        /// Omnidirectional.
        Omni = "omni",
        /// Car-like (speed and steering angle).
        Car = "car",
    }
}

word_enum! {
    /// Position localization modes.
    pub enum Localization in LOCALIZATIONS {
        /// Perfect pose relative to `localization_origin`.
        Gps = "gps",
        /// Integrated odometry with `odom_error`.
        Odom = "odom",
    }
}

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

/// Reads a position model's properties; Stage 3's `odom` is reported as ignored.
pub(crate) fn read(r: &mut Reader<'_, '_>) -> Result<PositionSpec, Error> {
    let spec = PositionSpec::read(r)?;
    if let Some(p) = r.prop("odom") {
        r.warn_at(
            p,
            "`odom` is obsolete and ignored (Stage warns too); use `localization_origin`",
        );
    }
    Ok(spec)
}
