//! A block as described: a polygon extruded over a z interval, the unit bodies are made of.

use crate::color::Color;

/// One block: a polygon in the model's body frame (metres, already stretched to `size` by the
/// worldfile resolver, spec §2.3) extruded over `[zmin, zmax]` above the body base.
#[derive(Clone, Debug, PartialEq)]
pub struct BlockDesc {
    /// Vertices (at least 2), metres in the body frame.
    pub points: Vec<[f64; 2]>,
    /// Lower z above the body base (m).
    pub zmin: f64,
    /// Upper z above the body base (m).
    pub zmax: f64,
    /// Own colour; `None` inherits the model's current colour.
    pub color: Option<Color>,
}

impl BlockDesc {
    /// An axis-aligned rectangle block `[x, x+w] × [y, y+h]`, z `[0, height]`, inherited colour.
    pub fn rect(x: f64, y: f64, w: f64, h: f64, height: f64) -> BlockDesc {
        BlockDesc {
            points: vec![[x, y], [x + w, y], [x + w, y + h], [x, y + h]],
            zmin: 0.0,
            zmax: height,
            color: None,
        }
    }
}
