//! Every way the original folds a heading, each named for whose arithmetic it is. Results are
//! compared bit for bit against the original (state digests, driver references), so the folds
//! are not interchangeable even where they agree to within a rounding error.

use std::f64::consts::PI;

/// Stage's fold into `[-π, π]`: add or subtract a whole turn until inside. Used for every pose
/// Stage stores (the worldfile's, the simulator's). Non-finite input is returned as it is; a
/// huge one is first reduced with a remainder so the loop stays short.
#[inline]
pub fn normalize(mut a: f64) -> f64 {
    if !a.is_finite() {
        return a;
    }
    if a.abs() > 64.0 * PI {
        a %= 2.0 * PI;
    }
    while a < -PI {
        a += 2.0 * PI;
    }
    while a > PI {
        a -= 2.0 * PI;
    }
    a
}

/// Player's `NORMALIZE`: the heading in (-π, π] whose sine and cosine are `a`'s, as
/// `atan2(sin a, cos a)` (amcl, nd, snd, vfh, laserposeinterpolator).
pub fn normalize_atan2(a: f64) -> f64 {
    a.sin().atan2(a.cos())
}

/// Player's `angle_diff`: the signed smallest turn `a - b` between two headings, in [-π, π].
pub fn diff(a: f64, b: f64) -> f64 {
    let d1 = normalize_atan2(a) - normalize_atan2(b);
    let d2 = 2.0 * PI - d1.abs();
    let d2 = if d1 > 0.0 { -d2 } else { d2 };
    if d1.abs() < d2.abs() { d1 } else { d2 }
}

/// The scan matcher's (mbicp) fold into (-π, π]: a whole number of turns chosen with `floor`.
pub fn fold_floor(a: f64) -> f64 {
    a + 2.0 * PI * ((PI - a) / (2.0 * PI)).floor()
}

/// The wavefront planner's signed difference `a - b` in (-π, π], through a Euclidean remainder.
pub fn diff_rem_euclid(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(2.0 * PI);
    if d > PI { d - 2.0 * PI } else { d }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stage_fold_adds_or_subtracts_whole_turns() {
        assert!((normalize(3.0 * PI) - PI).abs() < 1e-12);
        assert!((normalize(-1.5 * PI) - 0.5 * PI).abs() < 1e-12);
        assert_eq!(normalize(0.25), 0.25);
        assert_eq!(normalize(PI), PI);
        assert_eq!(normalize(-PI), -PI);
        assert!(normalize(1e9).abs() <= PI);
        assert!(normalize(f64::NAN).is_nan());
        // bit for bit the loop: one subtraction of 2π, not a remainder
        let a = 4.0;
        assert_eq!(normalize(a), a - 2.0 * PI);
    }

    #[test]
    fn player_fold_and_difference_take_the_short_way() {
        assert!((normalize_atan2(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-12);
        assert!((normalize_atan2(-0.25) + 0.25).abs() < 1e-15);
        assert!((diff(0.1, -0.1) - 0.2).abs() < 1e-12);
        assert!((diff(PI - 0.1, -PI + 0.1) + 0.2).abs() < 1e-12);
        assert!((diff(-PI + 0.1, PI - 0.1) - 0.2).abs() < 1e-12);
        assert!((diff(2.0, 0.5) - 1.5).abs() < 1e-12);
    }

    #[test]
    fn upstream_folds_land_in_the_half_open_turn() {
        assert!((fold_floor(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-12);
        assert!((fold_floor(PI) - PI).abs() < 1e-12);
        assert!((fold_floor(-PI) - PI).abs() < 1e-12);
        assert!((diff_rem_euclid(0.1, 2.0 * PI - 0.1) - 0.2).abs() < 1e-12);
        assert!((diff_rem_euclid(-PI, 0.0) - PI).abs() < 1e-12);
        assert!((diff_rem_euclid(0.5, 0.25) - 0.25).abs() < 1e-12);
    }
}
