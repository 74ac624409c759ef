//! Level of detail: leave out vertices and primitives the screen cannot show.
//!
//! A 180-ray laser seen from afar has ray ends a fraction of a pixel apart, and 1,000 of them are
//! 180,000 triangles whose per-triangle cost dominates a frame on a software rasteriser. These pure
//! functions thin a scan to what differs by at least a given tolerance in metres (the caller
//! passes a fraction of a pixel), so the picture stays the same to within that tolerance.

/// Thins the rim of a ranger footprint (the scan's ray ends, in fan order) to the points that
/// matter at tolerance `tol` (m), appending their indices to `keep` (cleared first).
///
/// Every dropped point lies within `tol * sqrt(2)` of the chord joining the kept points around
/// it; the first and last points are always kept. Linear time: the chords are grown with a
/// "sleeve" (the wedge of directions from the run's first point whose lines pass within `tol` of
/// every point so far, narrowed per point with one square root, no trigonometry).
pub fn simplify_rim(rim: &[[f64; 2]], tol: f64, keep: &mut Vec<usize>) {
    keep.clear();
    let n = rim.len();
    if n == 0 {
        return;
    }
    keep.push(0);
    if n <= 2 || tol.is_nan() || tol <= 0.0 {
        keep.extend(1..n);
        return;
    }
    let mut anchor = 0;
    // the sleeve: directions between `lo` and `hi` (counter-clockwise), None while unconstrained
    let mut sleeve: Option<([f64; 2], [f64; 2])> = None;
    // the farthest point of the run from the anchor, so no dropped point lies beyond the chord
    let mut reach = 0.0f64;
    let mut j = 1;
    while j < n {
        let v = [rim[j][0] - rim[anchor][0], rim[j][1] - rim[anchor][1]];
        // (hypot's overflow care is not needed for metres and costs several times a sqrt)
        let d = (v[0] * v[0] + v[1] * v[1]).sqrt();
        let inside = match sleeve {
            None => true,
            Some((lo, hi)) => cross(lo, v) >= 0.0 && cross(v, hi) >= 0.0,
        };
        if j == anchor + 1 || (d.is_finite() && inside && d + tol >= reach) {
            narrow(&mut sleeve, v, d, tol);
            reach = reach.max(d);
            j += 1;
        } else {
            // the chord anchor..j would stray: end the run at j - 1, where j starts the next
            anchor = j - 1;
            keep.push(anchor);
            sleeve = None;
            reach = 0.0;
        }
    }
    if *keep.last().expect("the first index is kept") != n - 1 {
        keep.push(n - 1);
    }
}

/// The unit directions of rays with `bearings` from a sensor heading `heading` (rad), into
/// `out` (cleared first). Evenly spaced bearings (every Stage ranger's, within a nanoradian)
/// are turned one step at a time instead of each taking a sine and cosine: 1,000 lasers of
/// 180 rays are 180,000 of those a frame, some 3 ms. Over a few thousand steps the turned
/// directions stay within 1e-12 of the exact ones.
pub fn ray_directions(heading: f64, bearings: &[f64], out: &mut Vec<[f64; 2]>) {
    out.clear();
    let n = bearings.len();
    let step = if n >= 2 {
        (bearings[n - 1] - bearings[0]) / (n - 1) as f64
    } else {
        0.0
    };
    let even = n >= 3
        && step.is_finite()
        && bearings
            .iter()
            .enumerate()
            .all(|(i, b)| (b - (bearings[0] + step * i as f64)).abs() <= 1e-9);
    if !even {
        out.extend(bearings.iter().map(|b| {
            let (s, c) = (heading + b).sin_cos();
            [c, s]
        }));
        return;
    }
    turned_directions(heading + bearings[0], step, n, out);
}

/// Appends `n` unit directions to `out`, the first at angle `start` and each next turned by
/// `step` (rad), with one sine and cosine for all of them: rays of an evenly spaced scan, or
/// the chord ends of an arc.
pub fn turned_directions(start: f64, step: f64, n: usize, out: &mut Vec<[f64; 2]>) {
    let (s, c) = step.sin_cos();
    let (s0, c0) = start.sin_cos();
    let mut d = [c0, s0];
    for _ in 0..n {
        out.push(d);
        d = [d[0] * c - d[1] * s, d[0] * s + d[1] * c];
    }
}

/// Narrows the sleeve to the directions whose lines from the anchor pass within `tol` of the
/// point at offset `v` (at distance `d`); points within `tol` of the anchor constrain nothing.
fn narrow(sleeve: &mut Option<([f64; 2], [f64; 2])>, v: [f64; 2], d: f64, tol: f64) {
    if d.is_nan() || d <= tol {
        return;
    }
    // v turned clockwise and counter-clockwise by asin(tol / d), scaled by d (only the
    // directions matter: they are compared by the sign of cross products), which spares the
    // divisions of normalising: cos = e / d and sin = tol / d
    let e = ((d - tol) * (d + tol)).sqrt();
    let lo_v = [e * v[0] + tol * v[1], -tol * v[0] + e * v[1]];
    let hi_v = [e * v[0] - tol * v[1], tol * v[0] + e * v[1]];
    *sleeve = Some(match *sleeve {
        None => (lo_v, hi_v),
        Some((lo, hi)) => (
            if cross(lo, lo_v) >= 0.0 { lo_v } else { lo },
            if cross(hi_v, hi) >= 0.0 { hi_v } else { hi },
        ),
    });
}

fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// The number of chords that draw an arc of `radius` (m) over `angle` (rad) with no point of
/// the arc farther than `tol` (m) from them, between 1 and `max`.
pub fn arc_segments(radius: f64, angle: f64, tol: f64, max: usize) -> usize {
    if radius.is_nan() || tol.is_nan() || radius <= tol || tol <= 0.0 || !angle.is_finite() {
        return 1;
    }
    // a chord spanning `phi` sags radius * (1 - cos(phi / 2)) below the arc
    let phi = 2.0 * (1.0 - tol / radius).acos();
    let n = (angle.abs() / phi).ceil();
    if n.is_finite() {
        (n as usize).clamp(1, max.max(1))
    } else {
        max.max(1)
    }
}

/// Whether a disc (a sensor's reach) at `c` of radius `r` touches the box `min`..`max` (the
/// visible part of the world): what is off screen is not built at all.
pub fn disc_touches_box(c: [f64; 2], r: f64, min: [f64; 2], max: [f64; 2]) -> bool {
    let dx = (min[0] - c[0]).max(c[0] - max[0]).max(0.0);
    let dy = (min[1] - c[1]).max(c[1] - max[1]).max(0.0);
    // NaN radius or centre: draw (and let the rasteriser clip) rather than hide data
    let d2 = dx * dx + dy * dy;
    d2.is_nan() || r.is_nan() || d2 <= r * r
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance from `p` to the segment `a`-`b`.
    fn seg_dist(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let l2 = dx * dx + dy * dy;
        let t = if l2 > 0.0 {
            (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (p[0] - a[0] - t * dx).hypot(p[1] - a[1] - t * dy)
    }

    /// Asserts the contract: indices increasing, ends kept, every dropped point near its chord.
    fn check(rim: &[[f64; 2]], tol: f64) -> Vec<usize> {
        let mut keep = Vec::new();
        simplify_rim(rim, tol, &mut keep);
        assert_eq!(keep[0], 0);
        assert_eq!(*keep.last().unwrap(), rim.len() - 1);
        for w in keep.windows(2) {
            assert!(w[0] < w[1], "indices increase: {keep:?}");
            for p in &rim[w[0] + 1..w[1]] {
                let e = seg_dist(*p, rim[w[0]], rim[w[1]]);
                assert!(
                    e <= tol * std::f64::consts::SQRT_2 + 1e-12,
                    "point {p:?} is {e} from chord {:?}-{:?}",
                    rim[w[0]],
                    rim[w[1]]
                );
            }
        }
        keep
    }

    fn fan(ranges: &[f64]) -> Vec<[f64; 2]> {
        let n = ranges.len();
        ranges
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let a =
                    -std::f64::consts::FRAC_PI_2 + std::f64::consts::PI * i as f64 / (n - 1) as f64;
                [r * a.cos(), r * a.sin()]
            })
            .collect()
    }

    #[test]
    fn a_straight_wall_keeps_only_its_ends() {
        // a laser facing a wall at x = 2 m: the ray ends are collinear
        let rim: Vec<[f64; 2]> = (0..91)
            .map(|i| {
                let a = -0.7 + 1.4 * i as f64 / 90.0;
                [2.0, 2.0 * a.tan()]
            })
            .collect();
        assert_eq!(check(&rim, 0.01), vec![0, 90]);
    }

    #[test]
    fn an_arc_keeps_as_many_points_as_its_sag_needs() {
        let r = 8.0;
        let rim = fan(&[r; 180]);
        let keep = check(&rim, 0.05);
        // a chord may span 2 * acos(1 - tol / r) of the arc: ~0.224 rad, 14 chords for pi
        let need = arc_segments(r, std::f64::consts::PI, 0.05, 1000);
        let chords = keep.len() - 1;
        assert!(chords <= need + 2, "{chords} chords for {need}");
        assert!(chords >= need / 2, "{chords} chords for {need}");
        // at a tolerance far under the ray spacing nothing can go
        assert_eq!(check(&rim, 1e-6).len(), 180);
    }

    #[test]
    fn a_spike_through_a_gap_survives() {
        // one ray escapes through a doorway to 8 m while its neighbours hit at 1 m
        let mut ranges = vec![1.0; 181];
        ranges[90] = 8.0;
        let rim = fan(&ranges);
        let keep = check(&rim, 0.02);
        assert!(keep.contains(&90), "{keep:?}");
    }

    #[test]
    fn random_scans_stay_within_tolerance() {
        let mut x = 0x2545f491u64;
        for _ in 0..200 {
            let ranges: Vec<f64> = (0..180)
                .map(|_| {
                    x ^= x << 13;
                    x ^= x >> 7;
                    x ^= x << 17;
                    0.2 + (x % 1000) as f64 / 125.0
                })
                .collect();
            check(&fan(&ranges), 0.03);
        }
        // smooth random walls too
        let mut r = 3.0;
        let ranges: Vec<f64> = (0..360)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                r = (r + ((x % 100) as f64 - 49.5) / 500.0).clamp(0.5, 8.0);
                r
            })
            .collect();
        let keep = check(&fan(&ranges), 0.03);
        assert!(keep.len() < 360);
    }

    #[test]
    fn degenerate_rims_are_kept_whole() {
        let mut keep = vec![7];
        simplify_rim(&[], 0.1, &mut keep);
        assert!(keep.is_empty());
        simplify_rim(&[[0.0, 0.0]], 0.1, &mut keep);
        assert_eq!(keep, vec![0]);
        simplify_rim(&[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]], 0.0, &mut keep);
        assert_eq!(keep, vec![0, 1, 2]);
        let rim = [[1.0, 0.0], [f64::NAN, 0.0], [1.0, 1.0], [0.0, 1.0]];
        simplify_rim(&rim, 0.1, &mut keep);
        assert!(keep.contains(&0) && keep.contains(&3));
    }

    #[test]
    fn ray_directions_turned_step_by_step_match_each_ray_computed() {
        let mut out = Vec::new();
        for (heading, bearings) in [
            (
                0.3,
                (0..361)
                    .map(|i| -3.0 + 6.0 * i as f64 / 360.0)
                    .collect::<Vec<_>>(),
            ),
            // uneven: each computed
            (-1.0, vec![0.1, 0.2, 0.5, 0.55]),
            (2.0, vec![0.7]),
            (2.0, vec![]),
        ] {
            ray_directions(heading, &bearings, &mut out);
            assert_eq!(out.len(), bearings.len());
            for (d, b) in out.iter().zip(&bearings) {
                let want = [(heading + b).cos(), (heading + b).sin()];
                assert!((d[0] - want[0]).abs() < 1e-12 && (d[1] - want[1]).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn arc_segments_follow_the_sag() {
        assert_eq!(arc_segments(1.0, 0.5, 1.0, 8), 1);
        assert_eq!(arc_segments(0.0, 0.5, 0.01, 8), 1);
        assert_eq!(arc_segments(100.0, 6.0, 0.001, 8), 8);
        let n = arc_segments(4.0, 1.0, 0.01, 1000);
        let sag = 4.0 * (1.0 - (1.0 / n as f64 / 2.0).cos());
        assert!(sag <= 0.01 && n > 1);
        let fewer = 4.0 * (1.0 - (1.0 / (n - 1) as f64 / 2.0).cos());
        assert!(fewer > 0.01);
    }

    #[test]
    fn discs_touch_boxes_they_overlap() {
        let (min, max) = ([0.0, 0.0], [10.0, 5.0]);
        assert!(disc_touches_box([5.0, 2.0], 0.1, min, max));
        assert!(disc_touches_box([-1.0, 2.0], 1.5, min, max));
        assert!(!disc_touches_box([-1.0, 2.0], 0.5, min, max));
        assert!(!disc_touches_box([11.0, 6.0], 1.0, min, max)); // corner distance sqrt(2)
        assert!(disc_touches_box([11.0, 6.0], 1.5, min, max));
        assert!(disc_touches_box([f64::NAN, 0.0], 1.0, min, max));
    }
}
