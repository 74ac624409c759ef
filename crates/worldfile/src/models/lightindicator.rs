//! `lightindicator`: an on/off light switched through the API, with only the common properties.

use super::{BASE_SIZE, TypeDefaults};
use crate::color::Rgba;

/// The `lightindicator` defaults (its row of the type table).
pub const DEFAULTS: TypeDefaults = TypeDefaults::new(BASE_SIZE, Rgba::RED);
