//! Colours (stage-models.md §16): X11 names looked up exactly, `color_rgba`, and `"random"`.

use rand::{Rng, SeedableRng};
use serde::Serialize;

use crate::colors_x11::X11_COLORS;

/// An RGBA colour with components in 0..=1.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Rgba {
    /// Red.
    pub r: f64,
    /// Green.
    pub g: f64,
    /// Blue.
    pub b: f64,
    /// Alpha (1 = opaque).
    pub a: f64,
}

impl Rgba {
    /// An opaque colour.
    pub const fn rgb(r: f64, g: f64, b: f64) -> Self {
        Rgba { r, g, b, a: 1.0 }
    }

    /// Stage's fallback for unknown names.
    pub const RED: Rgba = Rgba::rgb(1.0, 0.0, 0.0);

    /// Looks up an X11 colour name exactly (case-sensitive, spaces significant), as Stage does.
    pub fn from_x11_name(name: &str) -> Option<Rgba> {
        X11_COLORS
            .binary_search_by(|(n, ..)| n.as_bytes().cmp(name.as_bytes()))
            .ok()
            .map(|i| {
                let (_, r, g, b) = X11_COLORS[i];
                Rgba::rgb(r as f64 / 255.0, g as f64 / 255.0, b as f64 / 255.0)
            })
    }

    /// Player's packed `0xRRGGBB` (each component truncated after scaling by 255).
    pub fn packed_rgb(&self) -> u32 {
        let c = |v: f64| ((v * 255.0) as u32).min(255);
        (c(self.r) << 16) | (c(self.g) << 8) | c(self.b)
    }
}

/// A model or sensor colour as written: a fixed colour, or `"random"` (uniform random RGB, alpha
/// 1) left for the simulator to draw from its own seeded generator so runs repeat bit for bit.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum ColorSpec {
    /// A fixed colour.
    Rgba(Rgba),
    /// `color "random"`.
    Random,
}

impl ColorSpec {
    /// The fixed colour, or a draw from `rng` for `Random`.
    pub fn resolve(&self, rng: &mut impl Rng) -> Rgba {
        match self {
            ColorSpec::Rgba(c) => *c,
            ColorSpec::Random => Rgba::rgb(rng.random(), rng.random(), rng.random()),
        }
    }
}

/// A deterministic generator for resolving `random` colours from a caller's seed.
pub fn seeded_rng(seed: u64) -> rand_chacha::ChaCha8Rng {
    rand_chacha::ChaCha8Rng::seed_from_u64(seed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_exact_and_case_sensitive() {
        assert_eq!(Rgba::from_x11_name("red"), Some(Rgba::rgb(1.0, 0.0, 0.0)));
        let navy = Rgba::from_x11_name("NavyBlue").unwrap();
        assert_eq!(Rgba::from_x11_name("navy blue"), Some(navy));
        assert_eq!(navy, Rgba::rgb(0.0, 0.0, 128.0 / 255.0));
        assert_eq!(Rgba::from_x11_name("navyblue"), None);
        assert_eq!(Rgba::from_x11_name("Red"), None);
        // X11 gray is 190, not CSS grey.
        assert_eq!(
            Rgba::from_x11_name("gray"),
            Some(Rgba::rgb(190.0 / 255.0, 190.0 / 255.0, 190.0 / 255.0))
        );
        assert_eq!(
            Rgba::from_x11_name("gray30"),
            Some(Rgba::rgb(77.0 / 255.0, 77.0 / 255.0, 77.0 / 255.0))
        );
        assert_eq!(Rgba::from_x11_name(""), None);
    }

    #[test]
    fn table_is_sorted_and_complete() {
        assert_eq!(X11_COLORS.len(), 752);
        assert!(
            X11_COLORS
                .windows(2)
                .all(|w| w[0].0.as_bytes() < w[1].0.as_bytes())
        );
    }

    #[test]
    fn random_colours_repeat_for_a_seed() {
        let a = ColorSpec::Random.resolve(&mut seeded_rng(7));
        let b = ColorSpec::Random.resolve(&mut seeded_rng(7));
        let c = ColorSpec::Random.resolve(&mut seeded_rng(8));
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert!((0.0..1.0).contains(&a.r) && a.a == 1.0);
    }

    #[test]
    fn packed_rgb() {
        assert_eq!(Rgba::rgb(1.0, 0.5, 0.0).packed_rgb(), 0xFF7F00);
    }
}
