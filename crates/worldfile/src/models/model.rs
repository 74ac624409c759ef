//! `model`: a plain body (walls, boxes, pucks, floorplans) with only the common properties.

use super::{BASE_SIZE, TypeDefaults};
use crate::color::Rgba;

/// The `model` defaults (its row of the type table).
pub const DEFAULTS: TypeDefaults = TypeDefaults::new(BASE_SIZE, Rgba::RED);
