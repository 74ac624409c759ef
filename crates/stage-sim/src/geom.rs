//! Exact planar primitives used by ray casts and contact tests: axis-aligned boxes, ray–segment
//! and segment–segment intersection. Stage stores only polygon *outlines* (spec §6.2), so every
//! query here works on edges: a ray stops at the first edge it crosses and two bodies touch iff
//! two of their edges intersect (containment is not contact).

/// An axis-aligned bounding box in world coordinates (metres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: [f64; 2],
    /// Upper corner.
    pub max: [f64; 2],
}

impl Default for Aabb {
    fn default() -> Self {
        Aabb::EMPTY
    }
}

impl Aabb {
    /// The empty box (grows from nothing with [`Aabb::add`]).
    pub const EMPTY: Aabb = Aabb {
        min: [f64::INFINITY, f64::INFINITY],
        max: [f64::NEG_INFINITY, f64::NEG_INFINITY],
    };

    /// Grows the box to contain a point.
    #[inline]
    pub fn add(&mut self, p: [f64; 2]) {
        self.min[0] = self.min[0].min(p[0]);
        self.min[1] = self.min[1].min(p[1]);
        self.max[0] = self.max[0].max(p[0]);
        self.max[1] = self.max[1].max(p[1]);
    }

    /// Grows the box to contain another box.
    #[inline]
    pub fn merge(&mut self, o: &Aabb) {
        if o.is_empty() {
            return;
        }
        self.add(o.min);
        self.add(o.max);
    }

    /// Whether the box contains nothing.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.min[0] > self.max[0] || self.min[1] > self.max[1]
    }

    /// Whether two boxes overlap (touching counts).
    #[inline]
    pub fn intersects(&self, o: &Aabb) -> bool {
        self.min[0] <= o.max[0]
            && o.min[0] <= self.max[0]
            && self.min[1] <= o.max[1]
            && o.min[1] <= self.max[1]
    }

    /// The entry distance of the ray `o + t·d` (`inv` = 1/d per axis) if it meets the box
    /// within `[0, tmax]`.
    #[inline]
    pub fn ray_entry(&self, o: [f64; 2], inv: [f64; 2], tmax: f64) -> Option<f64> {
        let mut t0 = 0.0f64;
        let mut t1 = tmax;
        for k in 0..2 {
            let a = (self.min[k] - o[k]) * inv[k];
            let b = (self.max[k] - o[k]) * inv[k];
            let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
            // NaN (0·inf on a face) keeps the interval: treat as inside along that axis.
            if lo > t0 {
                t0 = lo;
            }
            if hi < t1 {
                t1 = hi;
            }
        }
        (t0 <= t1).then_some(t0)
    }
}

/// Distance along the ray `o + t·d` to segment `a–b`, if the ray meets it at `t ∈ [0, tmax]`.
/// Parallel (and collinear) segments are not hit: a ray grazing along a wall passes.
#[inline]
pub fn ray_segment(o: [f64; 2], d: [f64; 2], a: [f64; 2], b: [f64; 2], tmax: f64) -> Option<f64> {
    let ex = b[0] - a[0];
    let ey = b[1] - a[1];
    let denom = d[0] * ey - d[1] * ex;
    let wx = a[0] - o[0];
    let wy = a[1] - o[1];
    let nt = wx * ey - wy * ex;
    let ns = wx * d[1] - wy * d[0];
    // reject by sign before dividing: t = nt/denom ∈ [0, tmax], s = ns/denom ∈ [0, 1]
    let (nt, ns, den) = if denom > 0.0 {
        (nt, ns, denom)
    } else if denom < 0.0 {
        (-nt, -ns, -denom)
    } else {
        return None;
    };
    if nt < 0.0 || ns < 0.0 || ns > den || nt > tmax * den {
        return None;
    }
    let t = nt / den;
    (t <= tmax).then_some(t)
}

#[inline]
fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

#[inline]
fn on_segment(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> bool {
    p[0] >= a[0].min(b[0])
        && p[0] <= a[0].max(b[0])
        && p[1] >= a[1].min(b[1])
        && p[1] <= a[1].max(b[1])
}

/// Whether segments `p1–p2` and `q1–q2` share at least one point (touching counts).
#[inline]
pub fn segments_intersect(p1: [f64; 2], p2: [f64; 2], q1: [f64; 2], q2: [f64; 2]) -> bool {
    let d1 = orient(q1, q2, p1);
    let d2 = orient(q1, q2, p2);
    let d3 = orient(p1, p2, q1);
    let d4 = orient(p1, p2, q2);
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    (d1 == 0.0 && on_segment(q1, q2, p1))
        || (d2 == 0.0 && on_segment(q1, q2, p2))
        || (d3 == 0.0 && on_segment(p1, p2, q1))
        || (d4 == 0.0 && on_segment(p1, p2, q2))
}

/// Signed area of a polygon (positive when counter-clockwise).
pub fn signed_area(pts: &[[f64; 2]]) -> f64 {
    let n = pts.len();
    let mut s = 0.0;
    for i in 0..n {
        let a = pts[i];
        let b = pts[(i + 1) % n];
        s += a[0] * b[1] - b[0] * a[1];
    }
    0.5 * s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ray_hits_segment_at_expected_distance() {
        let t = ray_segment([0.0, 0.0], [1.0, 0.0], [2.0, -1.0], [2.0, 1.0], 10.0);
        assert_eq!(t, Some(2.0));
        // behind the origin, beyond tmax, beside the segment, parallel: misses
        assert_eq!(
            ray_segment([3.0, 0.0], [1.0, 0.0], [2.0, -1.0], [2.0, 1.0], 10.0),
            None
        );
        assert_eq!(
            ray_segment([0.0, 0.0], [1.0, 0.0], [2.0, -1.0], [2.0, 1.0], 1.5),
            None
        );
        assert_eq!(
            ray_segment([0.0, 2.0], [1.0, 0.0], [2.0, -1.0], [2.0, 1.0], 10.0),
            None
        );
        assert_eq!(
            ray_segment([0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [3.0, 0.0], 10.0),
            None
        );
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let t = ray_segment([0.0, 0.0], [s, s], [1.0, -5.0], [1.0, 5.0], 10.0).unwrap();
        assert!((t - 2f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn segment_intersection_includes_touching_excludes_disjoint() {
        assert!(segments_intersect(
            [0.0, 0.0],
            [2.0, 2.0],
            [0.0, 2.0],
            [2.0, 0.0]
        ));
        assert!(segments_intersect(
            [0.0, 0.0],
            [1.0, 0.0],
            [1.0, 0.0],
            [1.0, 1.0]
        ));
        assert!(segments_intersect(
            [0.0, 0.0],
            [2.0, 0.0],
            [1.0, 0.0],
            [3.0, 0.0]
        ));
        assert!(!segments_intersect(
            [0.0, 0.0],
            [1.0, 0.0],
            [0.0, 1.0],
            [1.0, 1.0]
        ));
        assert!(!segments_intersect(
            [0.0, 0.0],
            [1.0, 0.0],
            [2.0, 0.0],
            [3.0, 0.0]
        ));
    }

    #[test]
    fn aabb_ray_entry() {
        let b = Aabb {
            min: [1.0, -1.0],
            max: [2.0, 1.0],
        };
        assert_eq!(
            b.ray_entry([0.0, 0.0], [1.0, f64::INFINITY], 5.0),
            Some(1.0)
        );
        assert_eq!(b.ray_entry([0.0, 0.0], [1.0, f64::INFINITY], 0.5), None);
        assert_eq!(
            b.ray_entry([1.5, 0.0], [1.0, f64::INFINITY], 5.0),
            Some(0.0)
        );
        assert_eq!(b.ray_entry([0.0, 3.0], [1.0, f64::INFINITY], 5.0), None);
        assert!((signed_area(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]) - 0.5).abs() < 1e-12);
    }
}
