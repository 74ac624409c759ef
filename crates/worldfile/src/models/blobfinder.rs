//! `blobfinder`: a colour blob detector (stage-models.md §9.1).

use std::f64::consts::PI;

use super::{BASE_SIZE, TypeDefaults};
use crate::color::Rgba;
use crate::error::{Error, ErrorKind};
use crate::reader::Reader;
use crate::table::property_table;

/// The `blobfinder` defaults (its row of the type table): invisible unless given blocks.
pub const DEFAULTS: TypeDefaults = TypeDefaults {
    body: super::DefaultBody::Empty,
    ..TypeDefaults::new(BASE_SIZE, Rgba::RED)
};

property_table! {
    /// A `blobfinder` (stage-models.md §9.1).
    pub struct BlobfinderSpec {
        /// `[width height]` of the image in pixels (rays, rows).
        image: [i64; 2] = [80, 60], ints::<2>("image");
        /// Ray length in metres (not converted by `unit_length`, as in Stage).
        range: f64 = 12.0, float("range");
        /// Horizontal field of view, rad.
        fov: f64 = PI / 3.0, angle("fov");
        /// Centre direction relative to the heading, rad.
        pan: f64 = 0.0, angle("pan");
        /// Colour filter; empty means every colour is reported.
        colors: Vec<Rgba> = Vec::new(), blob_colors("colors");
    }
}

/// Reads a blobfinder's properties.
pub(crate) fn read(r: &mut Reader<'_, '_>) -> Result<BlobfinderSpec, Error> {
    BlobfinderSpec::read(r)
}

impl Reader<'_, '_> {
    /// Blobfinder `colors`: `colors_count` names, read only when `colors` exists (Stage).
    pub(crate) fn blob_colors(&mut self, name: &str) -> Result<Option<Vec<Rgba>>, Error> {
        if !self.exists(name) {
            return Ok(None);
        }
        let count = self.int("colors_count")?.unwrap_or(0);
        let Some(p) = self.prop(name) else {
            return Ok(Some(Vec::new()));
        };
        let count = usize::try_from(count).unwrap_or(0);
        let values = self.values(p);
        if count > values.len() {
            // Stage exits: the tuple is too short for `colors_count`.
            return Err(Error::at(
                ErrorKind::TupleTooShort {
                    name: name.into(),
                    needed: count,
                    found: values.len(),
                },
                &self.doc().sources,
                p.loc,
                name,
            ));
        }
        let mut out = Vec::with_capacity(count);
        for v in &values[..count] {
            out.push(self.named_color(p, &v.text));
        }
        Ok(Some(out))
    }
}
