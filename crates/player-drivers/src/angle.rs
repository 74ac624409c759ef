//! Player's heading arithmetic, as its drivers share it: `NORMALIZE` (the heading whose sine
//! and cosine are `a`'s) and `angle_diff` (the signed smallest turn from one heading to
//! another). One copy for every driver here that uses upstream's; the drivers whose upstream
//! folds angles its own way keep their own (mbicp's `floor` fold, wavefront's `angle_diff`),
//! and the simulator keeps Stage's (add or subtract a turn until inside).

use std::f64::consts::PI;

/// Player's `NORMALIZE`: `a` in (-pi, pi], as `atan2(sin a, cos a)`.
pub fn normalize(a: f64) -> f64 {
    a.sin().atan2(a.cos())
}

/// Player's `angle_diff`: the signed smallest difference `a - b` between two headings, in
/// [-pi, pi].
pub fn angle_diff(a: f64, b: f64) -> f64 {
    let d1 = normalize(a) - normalize(b);
    let d2 = 2.0 * PI - d1.abs();
    let d2 = if d1 > 0.0 { -d2 } else { d2 };
    if d1.abs() < d2.abs() { d1 } else { d2 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headings_wrap_and_differences_take_the_short_way() {
        assert!((normalize(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-12);
        assert!((normalize(-0.25) + 0.25).abs() < 1e-15);
        assert!((angle_diff(0.1, -0.1) - 0.2).abs() < 1e-12);
        assert!((angle_diff(-PI + 0.1, PI - 0.1) - 0.2).abs() < 1e-12);
        assert!((angle_diff(PI - 0.1, -PI + 0.1) + 0.2).abs() < 1e-12);
        assert!((angle_diff(2.0, 0.5) - 1.5).abs() < 1e-12);
    }
}
