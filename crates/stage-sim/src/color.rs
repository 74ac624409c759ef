//! Colours: the worldfile crate's RGBA type (one home for the X11 table and Player's packing),
//! Stage's blob colour equality and the seeded draw behind `color "random"`.

use worldfile::color::ColorSpec;

use crate::rng::SimRng;

/// An RGBA colour (components in `0..=1`, doubles as Stage keeps them).
pub use worldfile::color::Rgba as Color;

/// Blobfinder colour equality: RGB within 1e-5, alpha ignored (spec §9.2, §16).
pub fn same_rgb(a: &Color, b: &Color) -> bool {
    (a.r - b.r).abs() < 1e-5 && (a.g - b.g).abs() < 1e-5 && (a.b - b.b).abs() < 1e-5
}

/// A worldfile colour; `random` draws its components from `rng`, as Stage does at load.
pub(crate) fn from_spec(c: &ColorSpec, rng: &mut SimRng) -> Color {
    match c {
        ColorSpec::Rgba(c) => *c,
        ColorSpec::Random => Color::rgb(rng.next_f64(), rng.next_f64(), rng.next_f64()),
    }
}
