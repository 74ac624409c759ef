//! Metric-based ICP (Minguez, Lamiraux and Montesano, "Metric-Based Iterative Closest Point
//! Scan Matching for Sensor Displacement Estimation", IEEE T-RO 2006) as Player 3.0.2's
//! `mbicp` driver runs it, as pure functions over plain scans.
//!
//! The metric weighs a point-to-point difference `d` seen from a reference point `q` as
//! `|d|² - (d × q)² / (|q|² + L²)`: far from the sensor a rotation moves points a lot, so
//! differences across the line of sight count less there. Each iteration pairs every point
//! of the new scan (moved by the current estimate) with its metric-closest point on the
//! reference scan's polyline, inside an angular window, drops pairs farther than the radial
//! window, trims the worst pairs, and solves the linearised least squares in the metric.

use nalgebra::{Matrix3, Vector3};

/// The residual the first iteration's error ratio is taken against (upstream's constant).
const BIG_INITIAL_ERROR: f64 = 1_000_000.0;

/// A planar frame (or displacement): position and heading (rad).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Frame {
    /// X (m).
    pub x: f64,
    /// Y (m).
    pub y: f64,
    /// Heading (rad).
    pub th: f64,
}

impl Frame {
    /// A frame from its parts.
    pub fn new(x: f64, y: f64, th: f64) -> Frame {
        Frame { x, y, th }
    }

    /// `self ⊕ other`: `other`, given in `self`, expressed where `self` is given.
    pub fn compose(&self, other: &Frame) -> Frame {
        let (s, c) = self.th.sin_cos();
        Frame {
            x: other.x * c - other.y * s + self.x,
            y: other.x * s + other.y * c + self.y,
            th: normalize(self.th + other.th),
        }
    }

    /// `⊖ self`: the frame that undoes this one.
    pub fn inverse(&self) -> Frame {
        let (s, c) = self.th.sin_cos();
        Frame {
            x: -c * self.x - s * self.y,
            y: s * self.x - c * self.y,
            th: normalize(-self.th),
        }
    }

    /// A point given in this frame, expressed where this frame is given.
    fn apply(&self, x: f64, y: f64) -> (f64, f64) {
        let (s, c) = self.th.sin_cos();
        (x * c - y * s + self.x, x * s + y * c + self.y)
    }
}

/// `a` in (-pi, pi], the way upstream folds angles.
pub use ::pose::angle::fold_floor as normalize;

/// The matcher's tuning, with Player 3.0.2's driver defaults.
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    /// Readings at or beyond this range (m) are dropped (`max_laser_range`).
    pub max_laser_range: f64,
    /// Half-width (rad) of the bearing window searched for a match (`angular_window`).
    pub angular_window: f64,
    /// Largest metric distance (m) of a kept pair (`radial_window`; compared squared).
    pub radial_window: f64,
    /// The metric's length (m): large is plain ICP, small weighs rotation (`L`).
    pub l: f64,
    /// Use one reading out of this many (`laserStep`).
    pub laser_step: usize,
    /// Reference neighbours closer than this are joined into a segment to interpolate on
    /// (`MaxDistInter`; upstream compares it with the squared spacing, so do we).
    pub max_dist_inter: f64,
    /// Fraction of the pairs kept, best first (`filter`; 1 keeps all inside the window).
    pub filter: f64,
    /// Drop new points hidden behind others once moved (`ProjectionFilter`).
    pub projection_filter: bool,
    /// Fewer pairs than this fraction of the new points is a failure (`AsocError`).
    pub asoc_error: f64,
    /// Iterations before giving up (`MaxIter`).
    pub max_iter: usize,
    /// Converged when the residual changes by at most this ratio (`errorRatio`).
    pub error_ratio: f64,
    /// ... or when the correction is below these in x, y (m) and heading (rad)
    /// (`errx_out`, `erry_out`, `errt_out`).
    pub err_out: Frame,
    /// Converged after more than this many converging iterations in a row
    /// (`IterSmoothConv`).
    pub iter_smooth_conv: usize,
}

impl Default for Params {
    fn default() -> Params {
        Params {
            max_laser_range: 7.9,
            angular_window: 1.57 / 3.0,
            radial_window: 0.3,
            l: 3.0,
            laser_step: 1,
            max_dist_inter: 0.5,
            filter: 0.85,
            projection_filter: true,
            asoc_error: 0.1,
            max_iter: 50,
            error_ratio: 0.0001,
            err_out: Frame::new(0.0001, 0.0001, 0.0001),
            iter_smooth_conv: 2,
        }
    }
}

/// One laser reading: range (m) and bearing (rad) in the sensor's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reading {
    /// Range (m).
    pub r: f64,
    /// Bearing (rad).
    pub t: f64,
}

/// How a match ended (upstream's return codes 1, 2, -1 and -2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outcome {
    /// The estimate settled: the new scan's frame in the reference scan's frame.
    Converged(Frame),
    /// `max_iter` iterations without settling; the last estimate.
    MaxIterations(Frame),
    /// Too few pairs (or no points) to match.
    AssociationFailure,
    /// The least-squares system was singular.
    MinimizationFailure,
}

/// A paired point of the new scan (`n`, moved by the estimate) and of the reference (`r`).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Pair {
    nx: f64,
    ny: f64,
    rx: f64,
    ry: f64,
    dist: f64,
}

/// A scan point in both coordinates.
#[derive(Clone, Copy, Debug)]
struct Point {
    x: f64,
    y: f64,
    t: f64,
}

/// The usable points of a scan: in range, one out of `laser_step`, as Cartesian points.
fn points(scan: &[Reading], p: &Params) -> Vec<Point> {
    scan.iter()
        .filter(|r| r.r < p.max_laser_range)
        .step_by(p.laser_step.max(1))
        .map(|r| {
            let (x, y) = (r.r * r.t.cos(), r.r * r.t.sin());
            Point {
                x,
                y,
                t: y.atan2(x),
            }
        })
        .collect()
}

/// The metric distance (squared) between `p` and reference point `q`.
fn metric(px: f64, py: f64, qx: f64, qy: f64, l2: f64) -> f64 {
    let (dx, dy) = (px - qx, py - qy);
    let cross = dx * qy - dy * qx;
    dx * dx + dy * dy - cross * cross / (qx * qx + qy * qy + l2)
}

/// The association step: pairs of the new points moved by `motion` with the reference.
/// `None` when there are too few.
fn associate(reference: &[Point], new: &[Point], motion: &Frame, p: &Params) -> Option<Vec<Pair>> {
    let l2 = p.l * p.l;
    let br = p.radial_window * p.radial_window;
    let bw = p.angular_window;
    let moved: Vec<Point> = new
        .iter()
        .map(|q| {
            let (x, y) = motion.apply(q.x, q.y);
            Point {
                x,
                y,
                t: y.atan2(x),
            }
        })
        .collect();
    // Projection filter: keep the points whose bearing keeps increasing; the others are
    // hidden behind what the scan already saw (valid for moderate turns).
    let moved = if p.projection_filter && !moved.is_empty() {
        let mut kept = vec![moved[0]];
        for q in &moved[1..] {
            if q.t >= kept[kept.len() - 1].t {
                kept.push(*q);
            }
        }
        kept
    } else {
        moved
    };
    if moved.is_empty() || reference.is_empty() {
        return None;
    }
    let last = reference.len() - 1;
    // The window [lo, hi] of reference points within `bw` of the bearing of a new point.
    let (mut lo, mut hi, mut first) = (0usize, 0usize, 0usize);
    if moved[0].t < reference[0].t {
        if moved[0].t + bw < reference[0].t {
            while first < moved.len() - 1 && moved[first].t + bw < reference[0].t {
                first += 1;
            }
        } else {
            while hi < last && moved[0].t + bw > reference[hi + 1].t {
                hi += 1;
            }
        }
    } else {
        while lo < last && moved[0].t - bw > reference[lo].t {
            lo += 1;
        }
        hi = lo;
        while hi < last && moved[0].t + bw > reference[hi + 1].t {
            hi += 1;
        }
    }
    let mut pairs = Vec::with_capacity(moved.len());
    for q in &moved[first..] {
        while lo < last && q.t - bw > reference[lo].t {
            lo += 1;
        }
        while hi < last && q.t + bw > reference[hi + 1].t {
            hi += 1;
        }
        let pair = |rx: f64, ry: f64, dist: f64| Pair {
            nx: q.x,
            ny: q.y,
            rx,
            ry,
            dist,
        };
        if lo == hi {
            let r = reference[hi];
            let dist = metric(q.x, q.y, r.x, r.y, l2);
            if dist < br {
                pairs.push(pair(r.x, r.y, dist));
            }
        } else if lo < hi {
            // The metric-closest point on each segment of the window.
            let mut best = (0.0, 0.0, 100_000.0);
            for j in lo + 1..=hi {
                let (q1, q2) = (reference[j - 1], reference[j]);
                let (dqx, dqy) = (q1.x - q2.x, q1.y - q2.y);
                let (dqpx, dqpy) = (q1.x - q.x, q1.y - q.y);
                let a = 1.0 / (q.x * q.x + q.y * q.y + l2);
                let b = 1.0 - a * q.y * q.y;
                let c = 1.0 - a * q.x * q.x;
                let d = a * q.x * q.y;
                let lambda = (d * (dqx * dqpy + dqy * dqpx) + b * dqx * dqpx + c * dqy * dqpy)
                    / (b * dqx * dqx + c * dqy * dqy + 2.0 * d * dqx * dqy);
                let spacing2 = dqx * dqx + dqy * dqy;
                let (cx, cy) = if lambda < 0.0 {
                    (q1.x, q1.y)
                } else if lambda > 1.0 {
                    (q2.x, q2.y)
                } else if spacing2 < p.max_dist_inter {
                    (
                        (1.0 - lambda) * q1.x + lambda * q2.x,
                        (1.0 - lambda) * q1.y + lambda * q2.y,
                    )
                } else if lambda < 0.5 {
                    (q1.x, q1.y)
                } else {
                    (q2.x, q2.y)
                };
                let dist = metric(q.x, q.y, cx, cy, l2);
                if dist < best.2 {
                    best = (cx, cy, dist);
                }
            }
            if best.2 < br {
                pairs.push(pair(best.0, best.1, best.2));
            }
        } else {
            // Cannot happen (the window never inverts); upstream keeps a null pair.
            pairs.push(pair(0.0, 0.0, br));
        }
    }
    if (pairs.len() as f64) < moved.len() as f64 * p.asoc_error {
        return None;
    }
    Some(pairs)
}

/// The displacement that best moves the `n` points onto the `r` points in the metric, from
/// the normal equations of the first-order (small-angle) problem. `None` when singular.
pub fn least_squares_metric(pairs: &[(f64, f64, f64, f64)], l: f64) -> Option<Frame> {
    let l2 = l * l;
    let (mut a1, mut b1, mut c1, mut d1) = (0.0, 0.0, 0.0, 0.0);
    let (mut b2, mut c2, mut d2) = (0.0, 0.0, 0.0);
    let (mut c3, mut d3) = (0.0, 0.0);
    for &(nx, ny, rx, ry) in pairs {
        let k = rx * rx + ry * ry + l2;
        let ds = ny * ry + nx * rx;
        let dsd = ds / k;
        let bs = nx * ry - ny * rx;
        let bsd = bs / k;
        a1 += 1.0 - ry * ry / k;
        b1 += rx * ry / k;
        c1 += -ny + ry * dsd;
        d1 += nx - rx - ry * bsd;
        b2 += 1.0 - rx * rx / k;
        c2 += nx - rx * dsd;
        d2 += ny - ry + rx * bsd;
        c3 += nx * nx + ny * ny - ds * ds / k;
        d3 += bs * (-1.0 + dsd);
    }
    let m = Matrix3::new(a1, b1, c1, b1, b2, c2, c1, c2, c3);
    if m.determinant() == 0.0 {
        return None;
    }
    let sol = m.try_inverse()? * Vector3::new(d1, d2, d3);
    let f = Frame::new(-sol.x, -sol.y, -sol.z);
    (f.x.is_finite() && f.y.is_finite() && f.th.is_finite()).then_some(f)
}

/// Matches `new` against `reference` from the initial guess `guess` (the new scan's frame
/// in the reference scan's frame, from odometry): the MbICP loop of associations and
/// metric least squares until the estimate settles.
pub fn match_scans(reference: &[Reading], new: &[Reading], guess: Frame, p: &Params) -> Outcome {
    let reference = points(reference, p);
    let new = points(new, p);
    let mut motion = guess;
    let mut error_prev = BIG_INITIAL_ERROR;
    let mut converging = 0usize;
    for _ in 0..p.max_iter {
        let Some(mut pairs) = associate(&reference, &new, &motion, p) else {
            return Outcome::AssociationFailure;
        };
        // Trimmed ICP: keep the best fraction; else all pairs inside the radial window.
        let kept: Vec<Pair> = if p.filter < 1.0 {
            pairs.sort_by(|a, b| a.dist.total_cmp(&b.dist));
            let n = ((pairs.len() as f64 * 100.0 * p.filter) as usize) / 100;
            pairs.truncate(n);
            pairs
        } else {
            let br = p.radial_window * p.radial_window;
            pairs.into_iter().filter(|a| a.dist < br).collect()
        };
        let plain: Vec<_> = kept.iter().map(|a| (a.nx, a.ny, a.rx, a.ry)).collect();
        let Some(step) = least_squares_metric(&plain, p.l) else {
            return Outcome::MinimizationFailure;
        };
        let error: f64 = kept
            .iter()
            .map(|a| {
                let (x, y) = step.apply(a.nx, a.ny);
                (x - a.rx).powi(2) + (y - a.ry).powi(2)
            })
            .sum();
        let ratio = error / error_prev;
        let small = step.x.abs() < p.err_out.x
            && step.y.abs() < p.err_out.y
            && step.th.abs() < p.err_out.th;
        if (1.0 - ratio).abs() <= p.error_ratio || small {
            converging += 1;
        } else {
            converging = 0;
        }
        motion = step.compose(&motion);
        error_prev = error;
        if converging > p.iter_smooth_conv {
            return Outcome::Converged(motion);
        }
    }
    Outcome::MaxIterations(motion)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// Walls of a 6 m x 4 m room with a box and a pillar, so no displacement is ambiguous.
    fn walls() -> Vec<[f64; 4]> {
        let mut w = vec![
            [-3.0, -2.0, 3.0, -2.0],
            [3.0, -2.0, 3.0, 2.0],
            [3.0, 2.0, -3.0, 2.0],
            [-3.0, 2.0, -3.0, -2.0],
        ];
        let boxes = [[1.0, 0.6, 1.6, 1.1], [1.5, -1.2, 1.8, -0.9]];
        for [x0, y0, x1, y1] in boxes {
            w.extend([
                [x0, y0, x1, y0],
                [x1, y0, x1, y1],
                [x1, y1, x0, y1],
                [x0, y1, x0, y0],
            ]);
        }
        w
    }

    /// A 181° scan of 361 readings taken from `pose` in the room.
    pub(crate) fn scan(pose: Frame) -> Vec<Reading> {
        let w = walls();
        (0..361)
            .map(|i| {
                let t = -PI / 2.0 + i as f64 * PI / 360.0;
                let (dx, dy) = ((pose.th + t).cos(), (pose.th + t).sin());
                let r = w
                    .iter()
                    .filter_map(|&[x0, y0, x1, y1]| {
                        let (ex, ey) = (x1 - x0, y1 - y0);
                        let den = dx * ey - dy * ex;
                        if den.abs() < 1e-12 {
                            return None;
                        }
                        let (wx, wy) = (x0 - pose.x, y0 - pose.y);
                        let s = (wx * ey - wy * ex) / den;
                        let u = (wx * dy - wy * dx) / den;
                        (s > 0.0 && (0.0..=1.0).contains(&u)).then_some(s)
                    })
                    .fold(8.0, f64::min);
                Reading { r, t }
            })
            .collect()
    }

    fn close(a: Frame, b: Frame, tol_xy: f64, tol_th: f64) -> bool {
        (a.x - b.x).abs() < tol_xy && (a.y - b.y).abs() < tol_xy && (a.th - b.th).abs() < tol_th
    }

    #[test]
    fn frames_compose_and_invert() {
        let a = Frame::new(1.0, 2.0, 0.5);
        let b = Frame::new(-0.3, 0.7, 2.9);
        let back = a.compose(&b).compose(&b.inverse());
        assert!(close(back, a, 1e-12, 1e-12), "{back:?}");
        let id = a.inverse().compose(&a);
        assert!(close(id, Frame::default(), 1e-12, 1e-12), "{id:?}");
        assert!((normalize(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-12);
        assert!((normalize(PI) - PI).abs() < 1e-12);
        assert!((normalize(-PI) - PI).abs() < 1e-12);
    }

    #[test]
    fn identical_scans_give_zero() {
        let s = scan(Frame::new(-1.0, 0.2, 0.1));
        match match_scans(&s, &s, Frame::default(), &Params::default()) {
            Outcome::Converged(f) => assert!(close(f, Frame::default(), 1e-4, 1e-4), "{f:?}"),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_known_displacement_is_recovered_from_a_zero_guess() {
        let a = Frame::new(-1.0, 0.2, 0.1);
        let truth = Frame::new(0.12, -0.06, 0.06);
        let (ra, rb) = (scan(a), scan(a.compose(&truth)));
        let p = Params {
            max_iter: 500,
            ..Params::default()
        };
        match match_scans(&ra, &rb, Frame::default(), &p) {
            Outcome::Converged(f) => assert!(close(f, truth, 0.005, 0.003), "{f:?} vs {truth:?}"),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_wrong_odometry_guess_is_corrected() {
        let a = Frame::new(0.5, -0.4, -0.3);
        let truth = Frame::new(0.25, 0.02, -0.04);
        let guess = Frame::new(0.18, 0.06, 0.0);
        let (ra, rb) = (scan(a), scan(a.compose(&truth)));
        let p = Params {
            max_iter: 500,
            ..Params::default()
        };
        match match_scans(&ra, &rb, guess, &p) {
            Outcome::Converged(f) => assert!(close(f, truth, 0.005, 0.003), "{f:?} vs {truth:?}"),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn scans_with_no_reading_in_range_fail_to_associate() {
        let far: Vec<Reading> = (0..361)
            .map(|i| Reading {
                r: 8.0,
                t: -PI / 2.0 + i as f64 * PI / 360.0,
            })
            .collect();
        let s = scan(Frame::default());
        let p = Params::default();
        assert_eq!(
            match_scans(&far, &s, Frame::default(), &p),
            Outcome::AssociationFailure
        );
        assert_eq!(
            match_scans(&s, &far, Frame::default(), &p),
            Outcome::AssociationFailure
        );
    }

    #[test]
    fn the_least_squares_of_exact_pairs_is_the_small_motion() {
        // Pairs related by a tiny displacement: the linearised solution is that displacement.
        let truth = Frame::new(0.002, -0.001, 0.0005);
        let pts = [(1.0, 0.0), (0.0, 2.0), (-1.5, 0.5), (2.0, -1.0), (0.3, 3.0)];
        let pairs: Vec<_> = pts
            .iter()
            .map(|&(x, y)| {
                let (rx, ry) = truth.apply(x, y);
                (x, y, rx, ry)
            })
            .collect();
        let f = least_squares_metric(&pairs, 3.0).unwrap();
        assert!(close(f, truth, 1e-6, 1e-6), "{f:?}");
        // No pairs: a zero system, singular.
        assert_eq!(least_squares_metric(&[], 3.0), None);
    }

    #[test]
    fn the_metric_discounts_differences_across_the_line_of_sight() {
        // Same Euclidean distance; along the ray counts fully, across it less.
        let along = metric(5.1, 0.0, 5.0, 0.0, 9.0);
        let across = metric(5.0, 0.1, 5.0, 0.0, 9.0);
        assert!((along - 0.01).abs() < 1e-12);
        assert!(
            (across - 0.01 * (1.0 - 25.0 / 34.0)).abs() < 1e-12,
            "{across}"
        );
    }
}
