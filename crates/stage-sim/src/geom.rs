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
        let (t0, t1) = self.ray_span(o, inv, tmax);
        (t0 <= t1).then_some(t0)
    }

    /// Whether the ray meets the box within `[0, tmax]`: [`Aabb::ray_entry`]`.is_some()`, for
    /// the hot rejection tests that need no distance.
    #[inline(always)]
    pub fn ray_meets(&self, o: [f64; 2], inv: [f64; 2], tmax: f64) -> bool {
        let (t0, t1) = self.ray_span(o, inv, tmax);
        t0 <= t1
    }

    /// The slab test, both axes written out: the parameter interval `(t0, t1)` of the ray inside
    /// the box, clipped to `[0, tmax]` (empty when `t0 > t1`).
    ///
    /// Along each axis the nearer face's distance is `min(a, b)` and the farther's `max(b, a)`
    /// as x86's `minpd`/`maxpd` pick them (`x < y ? x : y`, `x > y ? x : y`): a NaN (0·∞, the
    /// origin on a face of an axis-parallel ray) keeps the interval open along that axis, and
    /// equal distances differ at most in a zero's sign, which no comparison here sees and the
    /// interval never carries (`t0` starts at +0 and only grows past it). Written with SSE2
    /// (the x86-64 baseline) because the compiler, left to itself, pairs the two axes' compares
    /// in one register and then branches on each lane, and which face comes first is the ray's
    /// direction, a coin toss the predictor lost on about one slab test in six (callgrind's
    /// branch simulation, hospital).
    #[inline(always)]
    fn ray_span(&self, o: [f64; 2], inv: [f64; 2], tmax: f64) -> (f64, f64) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{
                _mm_cvtsd_f64, _mm_max_pd, _mm_max_sd, _mm_min_pd, _mm_min_sd, _mm_mul_pd,
                _mm_set_pd, _mm_set_sd, _mm_setzero_pd, _mm_sub_pd, _mm_unpackhi_pd,
            };
            // SAFETY: these intrinsics only need SSE2, which every x86-64 processor has (the
            // target's baseline, always enabled); none of them reads or writes memory
            unsafe {
                // lanes (low, high) = (x, y)
                let o = _mm_set_pd(o[1], o[0]);
                let inv = _mm_set_pd(inv[1], inv[0]);
                let a = _mm_mul_pd(_mm_sub_pd(_mm_set_pd(self.min[1], self.min[0]), o), inv);
                let b = _mm_mul_pd(_mm_sub_pd(_mm_set_pd(self.max[1], self.max[0]), o), inv);
                let near = _mm_min_pd(a, b);
                let far = _mm_max_pd(b, a);
                // x, then y: t0 = near > t0 ? near : t0, t1 = far < t1 ? far : t1
                let t0 = _mm_max_sd(near, _mm_setzero_pd());
                let t1 = _mm_min_sd(far, _mm_set_sd(tmax));
                let t0 = _mm_max_sd(_mm_unpackhi_pd(near, near), t0);
                let t1 = _mm_min_sd(_mm_unpackhi_pd(far, far), t1);
                (_mm_cvtsd_f64(t0), _mm_cvtsd_f64(t1))
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            #[inline(always)]
            fn axis(min: f64, max: f64, o: f64, inv: f64, t0: f64, t1: f64) -> (f64, f64) {
                let a = (min - o) * inv;
                let b = (max - o) * inv;
                let near = if a < b { a } else { b };
                let far = if b > a { b } else { a };
                (
                    if near > t0 { near } else { t0 },
                    if far < t1 { far } else { t1 },
                )
            }
            let (t0, t1) = axis(self.min[0], self.max[0], o[0], inv[0], 0.0, tmax);
            axis(self.min[1], self.max[1], o[1], inv[1], t0, t1)
        }
    }
}

/// `x.floor() as i32` without a libm call (saturating like `as`; NaN gives 0 like `as`).
#[inline(always)]
pub fn floor_i32(x: f64) -> i32 {
    let i = x as i32;
    if (i as f64) > x {
        i.saturating_sub(1)
    } else {
        i
    }
}

/// Distance along the ray `o + t·d` to segment `a–b`, if the ray meets it at `t ∈ [0, tmax]`.
/// Parallel (and collinear) segments are not hit: a ray grazing along a wall passes.
#[inline]
pub fn ray_segment(o: [f64; 2], d: [f64; 2], a: [f64; 2], b: [f64; 2], tmax: f64) -> Option<f64> {
    ray_crossing::<true>(o, d, a, b, tmax)
}

/// [`ray_segment`] (`SEGMENT`), or without its test of where along `a–b` the ray crosses: the
/// distance to the line through `a` and `b`.
#[inline(always)]
fn ray_crossing<const SEGMENT: bool>(
    o: [f64; 2],
    d: [f64; 2],
    a: [f64; 2],
    b: [f64; 2],
    tmax: f64,
) -> Option<f64> {
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
    if nt < 0.0 || (SEGMENT && (ns < 0.0 || ns > den)) || nt > tmax * den {
        return None;
    }
    let t = nt / den;
    (t <= tmax).then_some(t)
}

/// The nearest distance `t ∈ [0, tmax]` at which the ray `o + t·d` (`d` a unit vector) crosses
/// an edge of the polygon `pts` (closed; a 2-point polygon is one segment).
///
/// Which side of the ray's line each vertex lies on is worked out once per vertex, and only the
/// edges whose ends lie on different sides (or on the line) get a distance, by the same formula
/// as [`ray_segment`]: a convex block's outline costs one cross product per vertex and two
/// distances instead of a full segment test per edge. The distances are [`ray_segment`]'s own.
/// Only near a vertex on the ray's line can the two disagree, by rounding: a vertex whose side
/// comes out as exactly 0 counts both its edges as crossed (so a ray through a vertex cannot
/// slip between them), and a ray grazing a corner may touch it here and not there, or the
/// other way round.
#[inline]
pub fn ray_polygon(o: [f64; 2], d: [f64; 2], pts: &[[f64; 2]], tmax: f64) -> Option<f64> {
    let n = pts.len();
    if !(3..=MASKED_VERTICES).contains(&n) {
        return ray_polygon_edge_by_edge(o, d, pts, tmax);
    }
    let (le, ge) = side_masks(o, d, pts);
    nearest_crossing(o, d, pts, crossed_edges(le, ge, n), tmax)
}

/// The most vertices [`side_masks`] can answer for: one bit each in a `u64`.
const MASKED_VERTICES: usize = 64;

/// [`ray_polygon`] one edge after another: each vertex's side worked out as the walk reaches
/// it, then the edge's crossing rule. The path for a segment (2 points) and for outlines of
/// more than [`MASKED_VERTICES`] points, and the reference the masked form is tested against.
fn ray_polygon_edge_by_edge(o: [f64; 2], d: [f64; 2], pts: &[[f64; 2]], tmax: f64) -> Option<f64> {
    let n = pts.len();
    if n < 2 {
        return None;
    }
    let mut best: Option<f64> = None;
    let first = side_of(o, d, pts[0]);
    let mut sa = first;
    for w in pts.windows(2) {
        let sb = side_of(o, d, w[1]);
        cross_edge(o, d, (w[0], sa), (w[1], sb), tmax, &mut best);
        sa = sb;
    }
    if n > 2 {
        cross_edge(o, d, (pts[n - 1], sa), (pts[0], first), tmax, &mut best);
    }
    best
}

/// Which side of the line of the ray `o + t·d` point `p` lies on (its sign; 0 on the line):
/// the same expression as `ns` in [`ray_segment`], for an edge's first end.
#[inline(always)]
fn side_of(o: [f64; 2], d: [f64; 2], p: [f64; 2]) -> f64 {
    (p[0] - o[0]) * d[1] - (p[1] - o[1]) * d[0]
}

/// One edge `a–b` of a polygon in the search for its nearest crossing, given the sides `sa`,
/// `sb` of its ends ([`side_of`]): an edge whose ends lie on different sides (or one on the
/// line, but not both) gets its distance, kept in `best` when within `best` or `tmax`.
#[inline(always)]
fn cross_edge(
    o: [f64; 2],
    d: [f64; 2],
    (a, sa): ([f64; 2], f64),
    (b, sb): ([f64; 2], f64),
    tmax: f64,
    best: &mut Option<f64>,
) {
    let crosses = (sa <= 0.0 && sb >= 0.0) || (sa >= 0.0 && sb <= 0.0);
    if crosses && !(sa == 0.0 && sb == 0.0) {
        let limit = best.unwrap_or(tmax);
        if let Some(t) = ray_crossing::<false>(o, d, a, b, limit) {
            *best = Some(t);
        }
    }
}

/// [`ray_polygon`] for four points (a rectangle: every default body), the same masked test
/// with the length known, for the compiler to unroll and keep in registers and the edge
/// indices wrapping by a mask: the moving-body ray tests' polygon test.
#[inline(always)]
pub fn ray_quad(o: [f64; 2], d: [f64; 2], p: &[[f64; 2]; 4], tmax: f64) -> Option<f64> {
    let (le, ge) = side_masks(o, d, p);
    let mut edges = crossed_edges(le, ge, 4);
    let mut best: Option<f64> = None;
    // nearest_crossing's loop with the wrap to vertex 0 as a mask (no bounds checks)
    while edges != 0 {
        let i = edges.trailing_zeros() as usize & 3;
        edges &= edges - 1;
        if let Some(t) = ray_crossing::<false>(o, d, p[i], p[(i + 1) & 3], best.unwrap_or(tmax)) {
            best = Some(t);
        }
    }
    best
}

/// The sides of the ray's line the vertices `pts` (at most [`MASKED_VERTICES`]) lie on, as
/// two masks: bit `i` of the first is set when [`side_of`] vertex `i` is ≤ 0, of the second
/// when it is ≥ 0 (both: on the line; neither: NaN, as the edge-by-edge comparisons answer).
///
/// Masks instead of a comparison per edge because whether an edge's ends straddle the ray's
/// line is a coin toss to the branch predictor: the per-edge branches were 14% of the
/// hospital's mispredicted branches (callgrind's branch simulation), for about as many
/// instructions as the masks take. On x86-64 two vertices at a time in SSE2 lanes (part of
/// the architecture's baseline): each lane does [`side_of`]'s own subtractions and products in
/// its order, with no fused multiply-add, so every side is the scalar one to the bit and the
/// masks are the scalar comparisons'.
#[inline(always)]
fn side_masks(o: [f64; 2], d: [f64; 2], pts: &[[f64; 2]]) -> (u64, u64) {
    let (mut le, mut ge) = (0u64, 0u64);
    let pairs = pts.chunks_exact(2);
    let rest = pairs.remainder();
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{
            _mm_cmpge_pd, _mm_cmple_pd, _mm_movemask_pd, _mm_mul_pd, _mm_set_pd, _mm_setzero_pd,
            _mm_sub_pd, _mm_unpackhi_pd, _mm_unpacklo_pd,
        };
        // SAFETY: these intrinsics only need SSE2, which every x86-64 processor has (the
        // target's baseline, always enabled); none of them reads or writes memory
        unsafe {
            // lanes (low, high): the origin (x, y) and the direction crossed over, (dy, dx)
            let origin = _mm_set_pd(o[1], o[0]);
            let across = _mm_set_pd(d[0], d[1]);
            let zero = _mm_setzero_pd();
            for (k, pair) in pairs.enumerate() {
                // (px - ox)·dy and (py - oy)·dx of each vertex, then their difference
                let w0 = _mm_set_pd(pair[0][1], pair[0][0]);
                let w1 = _mm_set_pd(pair[1][1], pair[1][0]);
                let w0 = _mm_mul_pd(_mm_sub_pd(w0, origin), across);
                let w1 = _mm_mul_pd(_mm_sub_pd(w1, origin), across);
                let sides = _mm_sub_pd(_mm_unpacklo_pd(w0, w1), _mm_unpackhi_pd(w0, w1));
                le |= (_mm_movemask_pd(_mm_cmple_pd(sides, zero)) as u64) << (2 * k);
                ge |= (_mm_movemask_pd(_mm_cmpge_pd(sides, zero)) as u64) << (2 * k);
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    for (k, pair) in pairs.enumerate() {
        for (j, &p) in pair.iter().enumerate() {
            let s = side_of(o, d, p);
            le |= ((s <= 0.0) as u64) << (2 * k + j);
            ge |= ((s >= 0.0) as u64) << (2 * k + j);
        }
    }
    if let [p] = rest {
        let s = side_of(o, d, *p);
        let i = pts.len() - 1;
        le |= ((s <= 0.0) as u64) << i;
        ge |= ((s >= 0.0) as u64) << i;
    }
    (le, ge)
}

/// The edges `i → i+1` (the last closing on vertex 0) of an `n`-point outline (3 to
/// [`MASKED_VERTICES`]) that [`cross_edge`] gives a distance, from [`side_masks`]: bit `i` set
/// when one end lies on or below the line and the other on or above it, not both on it.
#[inline(always)]
fn crossed_edges(le: u64, ge: u64, n: usize) -> u64 {
    let next = |m: u64| (m >> 1) | ((m & 1) << (n - 1));
    let on_line = le & ge;
    ((le & next(ge)) | (ge & next(le))) & !(on_line & next(on_line))
}

/// The nearest crossing within `tmax` of the edges of `pts` marked in `edges`
/// ([`crossed_edges`]), visited in the edge-by-edge order with its limits, so the answer is
/// [`ray_polygon_edge_by_edge`]'s to the bit.
#[inline(always)]
fn nearest_crossing(
    o: [f64; 2],
    d: [f64; 2],
    pts: &[[f64; 2]],
    mut edges: u64,
    tmax: f64,
) -> Option<f64> {
    let mut best: Option<f64> = None;
    while edges != 0 {
        let i = edges.trailing_zeros() as usize;
        edges &= edges - 1;
        let j = if i + 1 == pts.len() { 0 } else { i + 1 };
        if let Some(t) = ray_crossing::<false>(o, d, pts[i], pts[j], best.unwrap_or(tmax)) {
            best = Some(t);
        }
    }
    best
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

    /// The four-point case answers exactly as the edge-by-edge loop does, degenerate rays
    /// included: through vertices, along edges, from a corner, parallel to the axes.
    #[test]
    fn quads_answer_as_the_loop_does() {
        use crate::rng::SimRng;
        let mut rng = SimRng::new(4, 4);
        let square = [[1.0, -1.0], [3.0, -1.0], [3.0, 1.0], [1.0, 1.0]];
        type Case = ([f64; 2], [f64; 2], [[f64; 2]; 4]);
        let mut cases: Vec<Case> = Vec::new();
        let diag = std::f64::consts::FRAC_1_SQRT_2;
        for o in [
            [0.0, 0.0],
            [0.0, -1.0],
            [1.0, -1.0],
            [0.0, -2.0],
            [2.0, 0.0],
        ] {
            for d in [
                [1.0, 0.0],
                [0.0, 1.0],
                [diag, diag],
                [-1.0, 0.0],
                [diag, -diag],
            ] {
                cases.push((o, d, square));
            }
        }
        for _ in 0..2000 {
            let q = std::array::from_fn(|_| [rng.uniform(-2.0, 2.0), rng.uniform(-2.0, 2.0)]);
            // from a random point or from a vertex, towards a random point or a vertex
            let o = if rng.uniform(0.0, 1.0) < 0.2 {
                q[0]
            } else {
                [rng.uniform(-3.0, 3.0), rng.uniform(-3.0, 3.0)]
            };
            let to = if rng.uniform(0.0, 1.0) < 0.3 {
                q[2]
            } else {
                [rng.uniform(-3.0, 3.0), rng.uniform(-3.0, 3.0)]
            };
            let len = (to[0] - o[0]).hypot(to[1] - o[1]);
            if len > 0.0 {
                cases.push((o, [(to[0] - o[0]) / len, (to[1] - o[1]) / len], q));
            }
        }
        for (o, d, q) in cases {
            for tmax in [0.5, 10.0] {
                let looped = ray_polygon_edge_by_edge(o, d, &q, tmax).map(f64::to_bits);
                let quad = ray_quad(o, d, &q, tmax).map(f64::to_bits);
                let masked = ray_polygon(o, d, &q, tmax).map(f64::to_bits);
                assert_eq!(quad, looped, "{q:?} from {o:?} along {d:?}");
                assert_eq!(masked, looped, "{q:?} from {o:?} along {d:?}");
            }
        }
    }

    /// The masked polygon test (sides two vertices at a time) answers exactly as the
    /// edge-by-edge loop, for outlines of 2 to 70 points (past the 64 a mask holds), convex or
    /// not, on a lattice where vertices fall on the ray's line, the ray runs along edges or
    /// starts at a vertex, and at random; and a NaN side counts on neither side in both.
    #[test]
    fn masked_polygons_answer_as_the_loop_does() {
        use crate::rng::SimRng;
        let mut rng = SimRng::new(8, 21);
        let mut hits = 0;
        for k in 0..6000 {
            let n = 2 + k % 69;
            let on_lattice = k % 3 == 0;
            let coord = |rng: &mut SimRng| {
                if on_lattice {
                    (rng.uniform(-4.0, 4.0)).round() * 0.5
                } else {
                    rng.uniform(-2.0, 2.0)
                }
            };
            let mut pts: Vec<[f64; 2]> =
                (0..n).map(|_| [coord(&mut rng), coord(&mut rng)]).collect();
            let o = if k % 7 == 0 {
                pts[k % n]
            } else {
                [coord(&mut rng), coord(&mut rng)]
            };
            let d = match k % 5 {
                0 => [1.0, 0.0],
                1 => [0.0, -1.0],
                2 => [std::f64::consts::FRAC_1_SQRT_2; 2],
                _ => {
                    let a: f64 = rng.uniform(-4.0, 4.0);
                    [a.cos(), a.sin()]
                }
            };
            if k % 4 == 1 {
                // an edge on the ray's line to within rounding: its ends' sides come out 0 or
                // nearly, on either side, while its direction may differ from the ray's
                for p in &mut pts[..2] {
                    let t = rng.uniform(-1.0, 3.0);
                    *p = [o[0] + t * d[0], o[1] + t * d[1]];
                }
            }
            for tmax in [0.7, 10.0] {
                let looped = ray_polygon_edge_by_edge(o, d, &pts, tmax);
                let masked = ray_polygon(o, d, &pts, tmax);
                assert_eq!(
                    masked.map(f64::to_bits),
                    looped.map(f64::to_bits),
                    "{pts:?} from {o:?} along {d:?} within {tmax}"
                );
                if let Ok(quad) = <&[[f64; 2]; 4]>::try_from(&pts[..]) {
                    assert_eq!(
                        ray_quad(o, d, quad, tmax).map(f64::to_bits),
                        looped.map(f64::to_bits),
                        "{pts:?} from {o:?} along {d:?} within {tmax}"
                    );
                }
                hits += looped.is_some() as usize;
            }
        }
        assert!(hits > 3000, "{hits} hits");
        let square = [[1.0, -1.0], [3.0, -1.0], [3.0, 1.0], [f64::NAN, 1.0]];
        for d in [[1.0, 0.0], [0.0, 1.0], [0.6, 0.8]] {
            assert_eq!(
                ray_polygon([0.0, 0.0], d, &square, 10.0).map(f64::to_bits),
                ray_polygon_edge_by_edge([0.0, 0.0], d, &square, 10.0).map(f64::to_bits),
            );
        }
    }

    /// Away from vertices on the ray's line, a polygon's crossing is the nearest of its edges'
    /// own, to the bit.
    #[test]
    fn polygon_crossing_is_the_nearest_edge_crossing() {
        use crate::rng::SimRng;
        let mut rng = SimRng::new(9, 2);
        let mut hits = 0;
        for k in 0..4000 {
            // random polygons of 2 (a segment) to 9 vertices, convex or not
            let n = 2 + k % 8;
            let c = [rng.uniform(-3.0, 3.0), rng.uniform(-3.0, 3.0)];
            let pts: Vec<[f64; 2]> = (0..n)
                .map(|i| {
                    let a = i as f64 / n as f64 * std::f64::consts::TAU;
                    let r = rng.uniform(0.2, 1.5);
                    [c[0] + r * a.cos(), c[1] + r * a.sin()]
                })
                .collect();
            let o = [rng.uniform(-5.0, 5.0), rng.uniform(-5.0, 5.0)];
            // half the rays aimed near the polygon
            let aim = (c[1] - o[1]).atan2(c[0] - o[0]) + rng.uniform(-0.4, 0.4);
            let a = if k % 2 == 0 {
                aim
            } else {
                rng.uniform(-4.0, 4.0)
            };
            let d = [a.cos(), a.sin()];
            let tmax = rng.uniform(0.5, 10.0);
            let closing = (n > 2).then(|| (pts[n - 1], pts[0]));
            let want = pts
                .windows(2)
                .map(|w| (w[0], w[1]))
                .chain(closing)
                .filter_map(|(a, b)| ray_segment(o, d, a, b, tmax))
                .fold(None, |m: Option<f64>, t| Some(m.map_or(t, |m| m.min(t))));
            assert_eq!(
                ray_polygon(o, d, &pts, tmax),
                want,
                "{pts:?} from {o:?} along {d:?}"
            );
            hits += want.is_some() as usize;
        }
        assert!(hits > 600, "{hits} hits");
        // a ray through a vertex meets the polygon there
        let square = [[1.0, -1.0], [3.0, -1.0], [3.0, 1.0], [1.0, 1.0]];
        let diag = std::f64::consts::FRAC_1_SQRT_2;
        let t = ray_polygon([0.0, -2.0], [diag, diag], &square, 10.0).unwrap();
        assert!((t - 2f64.sqrt()).abs() < 1e-12, "{t}");
        assert_eq!(ray_polygon([0.0, 0.0], [1.0, 0.0], &square, 0.5), None);
        assert_eq!(
            ray_polygon([0.0, 0.0], [1.0, 0.0], &square[..1], 10.0),
            None
        );
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

    /// The slab test as first written, each axis's faces ordered by `a <= b` (a branch): the
    /// reference [`Aabb::ray_span`]'s selects must answer as.
    fn ray_span_by_branches(b: &Aabb, o: [f64; 2], inv: [f64; 2], tmax: f64) -> (f64, f64) {
        let axis = |min: f64, max: f64, o: f64, inv: f64, t0: f64, t1: f64| {
            let a = (min - o) * inv;
            let b = (max - o) * inv;
            let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
            (if lo > t0 { lo } else { t0 }, if hi < t1 { hi } else { t1 })
        };
        let (t0, t1) = axis(b.min[0], b.max[0], o[0], inv[0], 0.0, tmax);
        axis(b.min[1], b.max[1], o[1], inv[1], t0, t1)
    }

    /// The branch-free slab test meets the same boxes at the same entry distances as the
    /// branching one, to the bit: random rays and boxes, and the degenerate ones where a NaN
    /// (0·∞) or equal face distances arise: axis-parallel rays from a face or a corner, flat
    /// and point boxes, a zero reach.
    #[test]
    fn slab_test_answers_as_the_branching_form() {
        use crate::rng::SimRng;
        let mut rng = SimRng::new(3, 21);
        let mut met = 0;
        let mut check = |b: Aabb, o: [f64; 2], d: [f64; 2], tmax: f64| {
            let inv = [1.0 / d[0], 1.0 / d[1]];
            let (r0, r1) = ray_span_by_branches(&b, o, inv, tmax);
            let want = (r0 <= r1).then_some(r0.to_bits());
            assert_eq!(
                b.ray_entry(o, inv, tmax).map(f64::to_bits),
                want,
                "{b:?} from {o:?} along {d:?} within {tmax}"
            );
            assert_eq!(b.ray_meets(o, inv, tmax), want.is_some());
            met += want.is_some() as usize;
        };
        let grid = |rng: &mut SimRng| (rng.uniform(-3.0, 3.0)).round() * 0.5;
        let axes = [
            [1.0, 0.0],
            [-1.0, 0.0],
            [0.0, 1.0],
            [0.0, -1.0],
            [-0.0, 1.0],
        ];
        for k in 0..20000 {
            let lattice = k % 2 == 0;
            let pick = |rng: &mut SimRng| {
                if lattice {
                    grid(rng)
                } else {
                    rng.uniform(-2.0, 2.0)
                }
            };
            let mut b = Aabb::EMPTY;
            b.add([pick(&mut rng), pick(&mut rng)]);
            if k % 5 != 0 {
                b.add([pick(&mut rng), pick(&mut rng)]);
            }
            let o = [pick(&mut rng), pick(&mut rng)];
            let d = if k % 3 == 0 {
                axes[k % axes.len()]
            } else {
                let a: f64 = rng.uniform(-4.0, 4.0);
                [a.cos(), a.sin()]
            };
            let tmax = [0.0, 0.5, 4.0][k % 3];
            check(b, o, d, tmax);
        }
        assert!(met > 2500, "{met} met");
    }
}
