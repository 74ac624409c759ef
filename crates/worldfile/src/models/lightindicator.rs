//! `lightindicator`: an on/off light switched through the API, with only the common properties.

use super::{BASE_SIZE, ModelType, TypeInfo};
use crate::color::Rgba;

/// The `lightindicator` row of the type table.
pub const INFO: TypeInfo = TypeInfo::new(
    ModelType::Lightindicator,
    "lightindicator",
    BASE_SIZE,
    Rgba::RED,
);
