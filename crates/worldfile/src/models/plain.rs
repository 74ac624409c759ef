//! `model`: a plain body (walls, boxes, pucks, floorplans) with only the common properties.

use super::{BASE_SIZE, ModelType, TypeInfo};
use crate::color::Rgba;

/// The `model` row of the type table.
pub const INFO: TypeInfo = TypeInfo::new(ModelType::Model, "model", BASE_SIZE, Rgba::RED);
