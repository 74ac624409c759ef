//! The pose of a frame in its parent (stage-models.md §1.1): `(x, y, z, a)` with composition
//! `P ⊕ Q`, in `f64` as Stage keeps it.

use nalgebra::{Isometry2, Vector2};

use crate::angle::normalize;

/// A pose in a parent frame: position in metres, heading `a` in radians (counter-clockwise).
/// Every constructor folds the heading the way Stage does ([`normalize`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pose {
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// z (m), height of the frame's base.
    pub z: f64,
    /// Heading (rad).
    pub a: f64,
}

impl Pose {
    /// The identity pose.
    pub const ZERO: Pose = Pose {
        x: 0.0,
        y: 0.0,
        z: 0.0,
        a: 0.0,
    };

    /// A pose from its four components (the heading is normalised).
    #[inline]
    pub fn new(x: f64, y: f64, z: f64, a: f64) -> Pose {
        Pose {
            x,
            y,
            z,
            a: normalize(a),
        }
    }

    /// A pose from the worldfile's `[x y z a]` (m, rad).
    #[inline]
    pub fn from_array(p: [f64; 4]) -> Pose {
        Pose::new(p[0], p[1], p[2], p[3])
    }

    /// The worldfile's `[x y z a]` form.
    pub fn to_array(&self) -> [f64; 4] {
        [self.x, self.y, self.z, self.a]
    }

    /// `self ⊕ q`: `q`, given in this pose's frame, expressed in this pose's parent frame.
    #[inline]
    pub fn compose(&self, q: &Pose) -> Pose {
        // `q` only raises or turns (a sensor mounted at its parent's centre, a zero origin):
        // its zero x and y times the cosine and sine add nothing, so skip computing them.
        // Exact when x and y are non-zero and the heading is finite (otherwise signed zeros
        // and NaNs take the full path below)
        if q.x == 0.0 && q.y == 0.0 && self.x != 0.0 && self.y != 0.0 && self.a.is_finite() {
            return Pose {
                x: self.x,
                y: self.y,
                z: self.z + q.z,
                a: normalize(self.a + q.a),
            };
        }
        let (s, c) = self.a.sin_cos();
        Pose {
            x: self.x + q.x * c - q.y * s,
            y: self.y + q.x * s + q.y * c,
            z: self.z + q.z,
            a: normalize(self.a + q.a),
        }
    }

    /// Transforms a point of this frame into the parent frame (the z of the point is ignored).
    #[inline]
    pub fn transform_xy(&self, x: f64, y: f64) -> (f64, f64) {
        let (s, c) = self.a.sin_cos();
        (self.x + x * c - y * s, self.y + x * s + y * c)
    }

    /// The inverse of [`Pose::compose`]: `g` (parent frame) expressed in this pose's frame.
    /// Used by re-parenting (Stage's `GlobalToLocal`), which ignores stacking.
    #[inline]
    pub fn relative(&self, g: &Pose) -> Pose {
        let (s, c) = self.a.sin_cos();
        let dx = g.x - self.x;
        let dy = g.y - self.y;
        Pose {
            x: dx * c + dy * s,
            y: -dx * s + dy * c,
            z: g.z - self.z,
            a: normalize(g.a - self.a),
        }
    }

    /// The planar part as a nalgebra isometry (for callers that work in nalgebra types).
    pub fn to_isometry(&self) -> Isometry2<f64> {
        Isometry2::new(Vector2::new(self.x, self.y), self.a)
    }

    /// Distance between the xy positions of two poses.
    pub fn distance_xy(&self, o: &Pose) -> f64 {
        (self.x - o.x).hypot(self.y - o.y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn compose_and_relative_are_inverse() {
        let p = Pose::new(1.0, 2.0, 0.5, PI / 2.0);
        let q = Pose::new(1.0, 0.0, 0.1, 0.3);
        let g = p.compose(&q);
        assert!((g.x - 1.0).abs() < 1e-12 && (g.y - 3.0).abs() < 1e-12);
        assert!((g.z - 0.6).abs() < 1e-12);
        let back = p.relative(&g);
        assert!((back.x - q.x).abs() < 1e-12 && (back.y - q.y).abs() < 1e-12);
        assert!((back.a - q.a).abs() < 1e-12);
        let iso = p.to_isometry();
        let t = iso * nalgebra::Point2::new(q.x, q.y);
        assert!((t.x - g.x).abs() < 1e-12 && (t.y - g.y).abs() < 1e-12);
    }

    /// Composing with an offset that only raises or turns gives, bit for bit, what the full
    /// rotation gives: signed zeros, huge and non-finite values included (NaN payloads aside).
    #[test]
    fn offsets_without_x_and_y_compose_exactly() {
        let full = |p: &Pose, q: &Pose| {
            let (s, c) = p.a.sin_cos();
            [
                p.x + q.x * c - q.y * s,
                p.y + q.x * s + q.y * c,
                p.z + q.z,
                normalize(p.a + q.a),
            ]
        };
        let values = [
            0.0,
            -0.0,
            1.5,
            -2.25,
            1e-300,
            -7e12,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        let headings = [0.0, -0.0, 0.3, -PI, PI / 2.0, 1e9, f64::INFINITY, f64::NAN];
        for &x in &values {
            for &y in &values {
                for &a in &headings {
                    for (qx, qy) in [(0.0, 0.0), (-0.0, 0.0), (0.0, -0.0), (-0.0, -0.0)] {
                        let p = Pose { x, y, z: 0.5, a };
                        let q = Pose {
                            x: qx,
                            y: qy,
                            z: -0.05,
                            a: 0.7,
                        };
                        // bits, signed zeros included; any NaN counts as the same NaN
                        let bits = |v: f64| if v.is_nan() { u64::MAX } else { v.to_bits() };
                        let g = p.compose(&q);
                        let want = full(&p, &q).map(bits);
                        assert_eq!([g.x, g.y, g.z, g.a].map(bits), want, "{p:?} ⊕ {q:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn arrays_round_trip_with_the_heading_folded() {
        let p = Pose::from_array([1.0, -2.0, 0.25, 3.0 * PI]);
        assert_eq!(p.to_array()[..3], [1.0, -2.0, 0.25]);
        assert!((p.a - PI).abs() < 1e-12);
    }
}
