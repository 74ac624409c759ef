//! Which parts of the static edges a ray coming from open space can meet first.
//!
//! A bitmap floorplan becomes thousands of touching rectangles (one block each), and most of
//! their edges lie inside the wall they build: the shared side of two stacked runs. A ray that
//! starts outside every block first meets the union's boundary, and every boundary point lies
//! on an edge part that no other block covers. So the static grid lists each edge only in the
//! cells of its *exposed* parts: fewer edges per wall cell and more empty cells to jump over.
//!
//! The edge itself stays whole (its intersection is computed from the same end points as
//! before), so every hit is the same number as without the pruning; only edges whose every
//! candidate hit lies inside a wall are no longer tested. (Up to ties: a ray exactly through
//! a wall corner where hidden sides meet may now report the neighbouring block, at a distance
//! that rounds differently by an ulp.) Covering is only decided between axis-aligned
//! rectangles of the same model and the same z interval, so a ray that sees one of them (its
//! height band, its model's `ranger_return`, the model still static) sees the other.
//! A ray that *starts* inside a wall may now pass the shared sides and read a side further on
//! (at the latest, where it leaves the wall) instead of the side of its own block; Stage reads
//! such a ray as blocked at once, which neither matched.

/// An axis-aligned rectangle `[x0, x1] × [y0, y1]` with positive area, from a block's vertices.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Rect {
    pub min: [f64; 2],
    pub max: [f64; 2],
}

impl Rect {
    /// The rectangle a 4-vertex polygon is, if it is one: every vertex at a corner and the edges
    /// along the two axes in turn (so the outline visits all four corners: a spike that doubles
    /// back along one side is not a rectangle, whatever its bounding box).
    pub fn of(pts: &[[f64; 2]]) -> Option<Rect> {
        if pts.len() != 4 {
            return None;
        }
        let mut min = pts[0];
        let mut max = pts[0];
        for p in pts {
            for k in 0..2 {
                min[k] = min[k].min(p[k]);
                max[k] = max[k].max(p[k]);
            }
        }
        if !(min[0] < max[0] && min[1] < max[1]) {
            return None;
        }
        let at_corner =
            |p: &[f64; 2]| (p[0] == min[0] || p[0] == max[0]) && (p[1] == min[1] || p[1] == max[1]);
        // Some(true): the edge from vertex i runs along x; None: not along one axis
        let along_x = |i: usize| {
            let (a, b) = (pts[i], pts[(i + 1) % 4]);
            ((a[0] == b[0]) != (a[1] == b[1])).then_some(a[1] == b[1])
        };
        let alternating = (0..4).all(|i| match (along_x(i), along_x((i + 1) % 4)) {
            (Some(x), Some(next)) => x != next,
            _ => false,
        });
        (pts.iter().all(at_corner) && alternating).then_some(Rect { min, max })
    }
}

/// The exposed parts of edge `a–b` of rectangle `own`, given the other rectangles (same model,
/// same z interval) whose boxes come near the edge; each part is a sub-segment of `a–b`.
///
/// Along the edge's axis `k` and across it `j`: an edge on `own`'s high side (`own.max[j]`) is
/// covered where another rectangle reaches from at or below the line to strictly above it, an
/// edge on the low side where one reaches from strictly below to at or above it; only the open
/// overlap of the two spans counts, so corners stay.
pub(super) fn exposed_parts(
    a: [f64; 2],
    b: [f64; 2],
    own: &Rect,
    others: impl Iterator<Item = Rect>,
) -> Vec<[[f64; 2]; 2]> {
    // the axis the edge runs along and the one it sits on
    let (k, j) = if a[1] == b[1] { (0, 1) } else { (1, 0) };
    let line = a[j];
    let high = line == own.max[j];
    let (lo, hi) = (a[k].min(b[k]), a[k].max(b[k]));
    let mut covered: Vec<(f64, f64)> = others
        .filter(|s| {
            if high {
                s.min[j] <= line && line < s.max[j]
            } else {
                s.min[j] < line && line <= s.max[j]
            }
        })
        .map(|s| (lo.max(s.min[k]), hi.min(s.max[k])))
        .filter(|(u, v)| u < v)
        .collect();
    if covered.is_empty() {
        return vec![[a, b]];
    }
    covered.sort_by(|p, q| p.0.total_cmp(&q.0));
    let point = |t: f64| {
        let mut p = a;
        p[k] = t;
        p
    };
    let mut parts = Vec::new();
    // `from`: the start of the still-exposed stretch
    let mut from = lo;
    for (u, v) in covered {
        if u > from {
            parts.push([point(from), point(u)]);
        }
        from = from.max(v);
    }
    if hi > from {
        parts.push([point(from), point(hi)]);
    }
    parts
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Rect {
        Rect {
            min: [x0, y0],
            max: [x1, y1],
        }
    }

    #[test]
    fn rectangles_are_recognised_in_either_winding() {
        let ccw = [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]];
        let cw = [[0.0, 0.0], [0.0, 1.0], [2.0, 1.0], [2.0, 0.0]];
        assert_eq!(Rect::of(&ccw), Some(rect(0.0, 0.0, 2.0, 1.0)));
        assert_eq!(Rect::of(&cw), Some(rect(0.0, 0.0, 2.0, 1.0)));
        let not_rectangles: [&[[f64; 2]]; 6] = [
            // a bow tie has its vertices at the corners but crosses itself
            &[[0.0, 0.0], [2.0, 1.0], [2.0, 0.0], [0.0, 1.0]],
            &[[0.0, 0.0], [2.0, 0.0], [2.5, 1.0], [0.0, 1.0]],
            &[[0.0, 0.0], [2.0, 0.0], [2.0, 0.0], [0.0, 0.0]],
            // spikes whose vertices all sit at corners of their bounding box
            &[[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [2.0, 0.0]],
            &[[0.0, 0.0], [2.0, 0.0], [0.0, 0.0], [0.0, 1.0]],
            &[[0.0, 0.0], [2.0, 0.0], [2.0, 1.0]],
        ];
        for pts in not_rectangles {
            assert_eq!(Rect::of(pts), None, "{pts:?}");
        }
    }

    #[test]
    fn a_shared_side_is_hidden_and_the_rest_stays() {
        // own [0,4]×[0,1]; above it [1,2]×[1,3] and [3,5]×[1,2]
        let own = rect(0.0, 0.0, 4.0, 1.0);
        let others = [rect(1.0, 1.0, 2.0, 3.0), rect(3.0, 1.0, 5.0, 2.0)];
        let top = exposed_parts([4.0, 1.0], [0.0, 1.0], &own, others.iter().copied());
        assert_eq!(
            top,
            vec![[[0.0, 1.0], [1.0, 1.0]], [[2.0, 1.0], [3.0, 1.0]]]
        );
        // the bottom edge is not covered by rectangles above the top
        let bottom = exposed_parts([0.0, 0.0], [4.0, 0.0], &own, others.iter().copied());
        assert_eq!(bottom, vec![[[0.0, 0.0], [4.0, 0.0]]]);
    }

    #[test]
    fn touching_only_at_a_corner_or_a_line_hides_nothing() {
        let own = rect(0.0, 0.0, 1.0, 1.0);
        // diagonal neighbour, and a neighbour whose side only touches the top edge's end
        let others = [rect(1.0, 1.0, 2.0, 2.0), rect(1.0, 0.0, 2.0, 1.0)];
        for (a, b) in [
            ([1.0, 1.0], [0.0, 1.0]),
            ([0.0, 0.0], [1.0, 0.0]),
            ([0.0, 1.0], [0.0, 0.0]),
        ] {
            assert_eq!(
                exposed_parts(a, b, &own, others.iter().copied()),
                vec![[a, b]]
            );
        }
        // the right side is shared with the neighbour on the right
        assert!(exposed_parts([1.0, 0.0], [1.0, 1.0], &own, others.iter().copied()).is_empty());
    }

    #[test]
    fn overlapping_coverers_merge() {
        let own = rect(0.0, 0.0, 1.0, 10.0);
        // to the left of the left edge, overlapping spans [1,4] and [3,6], and [8,12]
        let others = [
            rect(-1.0, 1.0, 0.0, 4.0),
            rect(-2.0, 3.0, 0.5, 6.0),
            rect(-1.0, 8.0, 0.0, 12.0),
        ];
        let left = exposed_parts([0.0, 10.0], [0.0, 0.0], &own, others.iter().copied());
        assert_eq!(
            left,
            vec![[[0.0, 0.0], [0.0, 1.0]], [[0.0, 6.0], [0.0, 8.0]]]
        );
    }
}
