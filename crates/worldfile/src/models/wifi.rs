//! Stage 3 `wifi` patch model (not in Stage 4.1.1): its properties are kept as data.

use std::collections::BTreeMap;

use serde::Serialize;

use super::TypeDefaults;
use crate::color::Rgba;
use crate::error::Error;
use crate::reader::Reader;

/// The `wifi` defaults (its row of the type table): nothing collides with or sees it, and Stage 4.1.1 would
/// refuse it.
pub const DEFAULTS: TypeDefaults = TypeDefaults {
    obstacle_return: false,
    blob_return: false,
    thread_safe: true,
    legacy: Some(
        "Stage 4.1.1 has no `wifi` model type (it exits with \"Unknown model type wifi\"); loaded as a Stage 3 wifi model whose properties are kept as data",
    ),
    ..TypeDefaults::new([0.0, 0.0, 0.0], Rgba::RED)
};

/// A Stage 3 `wifi` model: every property it was given, as raw text.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct WifiSpec {
    /// Property name to its values.
    pub properties: BTreeMap<String, Vec<String>>,
}

/// Keeps every property no other table read, as written (so none is reported unused).
pub(crate) fn read(r: &mut Reader<'_, '_>) -> Result<WifiSpec, Error> {
    let mut spec = WifiSpec::default();
    let (doc, entity) = (r.doc(), r.entity());
    for (k, p) in doc.properties(entity).iter().enumerate() {
        if doc.is_used(entity, k) {
            continue;
        }
        doc.mark_used(entity, k);
        spec.properties.insert(
            doc.name(p).to_string(),
            doc.values(p).iter().map(|v| v.text.to_string()).collect(),
        );
    }
    Ok(spec)
}
