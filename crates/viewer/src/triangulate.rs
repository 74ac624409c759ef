//! Polygon filling: model blocks are arbitrary simple polygons (often concave in hand-written
//! worlds), so they are cut into triangles by ear clipping; convex ones take a plain fan.

/// Twice the signed area (positive: counter-clockwise).
fn area2(p: &[[f64; 2]]) -> f64 {
    let n = p.len();
    (0..n)
        .map(|i| {
            let (a, b) = (p[i], p[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum()
}

#[inline]
fn cross(o: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

fn is_convex(p: &[[f64; 2]], ccw: bool) -> bool {
    let n = p.len();
    (0..n).all(|i| {
        let c = cross(p[i], p[(i + 1) % n], p[(i + 2) % n]);
        if ccw { c >= 0.0 } else { c <= 0.0 }
    })
}

fn in_triangle(p: [f64; 2], a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> bool {
    // counter-clockwise triangle; points on the boundary count as inside (blocks an ear)
    cross(a, b, p) >= 0.0 && cross(b, c, p) >= 0.0 && cross(c, a, p) >= 0.0
}

/// Emits the triangles filling polygon `pts` (three vertices each) through `out`. Fewer than
/// three points or zero area emit nothing; a polygon the clipper cannot finish (self-
/// intersecting) has its remainder fanned.
pub fn fill_polygon(pts: &[[f64; 2]], mut out: impl FnMut([f64; 2])) {
    let n = pts.len();
    if n < 3 {
        return;
    }
    let a2 = area2(pts);
    if a2 == 0.0 || !a2.is_finite() {
        return;
    }
    let ccw = a2 > 0.0;
    if is_convex(pts, ccw) {
        for i in 1..n - 1 {
            out(pts[0]);
            out(pts[i]);
            out(pts[i + 1]);
        }
        return;
    }
    // ear clipping over indices in counter-clockwise order
    let mut idx: Vec<usize> = if ccw {
        (0..n).collect()
    } else {
        (0..n).rev().collect()
    };
    let mut guard = 0usize;
    let mut i = 0usize;
    while idx.len() > 3 {
        let m = idx.len();
        let (ia, ib, ic) = (idx[(i + m - 1) % m], idx[i % m], idx[(i + 1) % m]);
        let (a, b, c) = (pts[ia], pts[ib], pts[ic]);
        let ear = cross(a, b, c) > 0.0
            && idx
                .iter()
                .all(|&k| k == ia || k == ib || k == ic || !in_triangle(pts[k], a, b, c));
        if ear {
            out(a);
            out(b);
            out(c);
            idx.remove(i % m);
            guard = 0;
        } else {
            i += 1;
            guard += 1;
            if guard > m {
                // no ear left (self-intersecting input): fan what remains
                for k in 1..m - 1 {
                    out(pts[idx[0]]);
                    out(pts[idx[k]]);
                    out(pts[idx[k + 1]]);
                }
                return;
            }
        }
    }
    for &k in &idx {
        out(pts[k]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tris(p: &[[f64; 2]]) -> Vec<[[f64; 2]; 3]> {
        let mut v = Vec::new();
        fill_polygon(p, |q| v.push(q));
        assert_eq!(v.len() % 3, 0);
        v.chunks(3).map(|c| [c[0], c[1], c[2]]).collect()
    }

    fn area(t: &[[[f64; 2]; 3]]) -> f64 {
        t.iter()
            .map(|t| (cross(t[0], t[1], t[2]) / 2.0).abs())
            .sum()
    }

    #[test]
    fn convex_and_concave_polygons_are_covered_exactly() {
        let square = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];
        assert_eq!(tris(&square).len(), 2);
        assert!((area(&tris(&square)) - 4.0).abs() < 1e-12);
        // an L shape, both orientations: area 3, and no triangle covers the notch (1.5, 1.5)
        let l = [
            [0.0, 0.0],
            [2.0, 0.0],
            [2.0, 1.0],
            [1.0, 1.0],
            [1.0, 2.0],
            [0.0, 2.0],
        ];
        let mut rev = l;
        rev.reverse();
        for poly in [&l[..], &rev[..]] {
            let t = tris(poly);
            assert_eq!(t.len(), 4);
            assert!((area(&t) - 3.0).abs() < 1e-12);
            for tri in &t {
                let mut ccw = *tri;
                if cross(ccw[0], ccw[1], ccw[2]) < 0.0 {
                    ccw.swap(1, 2);
                }
                assert!(!in_triangle([1.5, 1.5], ccw[0], ccw[1], ccw[2]));
            }
        }
    }

    #[test]
    fn degenerate_input_draws_nothing() {
        assert!(tris(&[[0.0, 0.0], [1.0, 1.0]]).is_empty());
        assert!(tris(&[[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]).is_empty());
        assert!(tris(&[[0.0, 0.0], [f64::NAN, 1.0], [2.0, 0.0]]).is_empty());
    }

    #[test]
    fn self_intersecting_input_terminates() {
        // a bow tie: zero net area draws nothing; a star with crossings is still emitted
        let star: Vec<[f64; 2]> = (0..5)
            .map(|i| {
                let a = i as f64 * 4.0 * std::f64::consts::PI / 5.0;
                [a.cos(), a.sin()]
            })
            .collect();
        let t = tris(&star);
        assert!(!t.is_empty());
    }
}
