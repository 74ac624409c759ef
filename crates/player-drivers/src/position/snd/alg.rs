//! Smooth Nearness-Diagram navigation (Durham & Bullo, IROS 2008) as Player 3.0.2's `snd`
//! computes one command from one laser scan.
//!
//! The scan is spread over a full circle of sectors one scan step wide (sector `i` looks at
//! `res * (i - n/2)`, counter-clockwise, so `n/2` is straight ahead); sectors the laser does
//! not cover read as its maximum range. Range jumps wider than `min_gap_width` are gaps;
//! a rising gap (one the robot can turn into) and the next gap bound a valley. The valley
//! whose rising gap is nearest the goal is chosen, a target sector picked in it (the goal if
//! the way there is clear, else the valley's middle or a point safely past its corner), and
//! the target is deflected away from nearby obstacles by a weighted average over every
//! sector closer than the safety distance — the smoothing that gives SND its name.

use std::f64::consts::PI;

use pose::angle::normalize_atan2 as normalize;

/// The tuning of the algorithm (the driver's options).
#[derive(Clone, Debug, PartialEq)]
pub struct SndParams {
    /// Radius of the circle holding the robot (m).
    pub robot_radius: f64,
    /// Narrowest passage to try (m).
    pub min_gap_width: f64,
    /// Distance from obstacles at which avoidance starts (m).
    pub obstacle_avoid_dist: f64,
    /// Largest forward speed (m/s).
    pub max_speed: f64,
    /// Largest turn rate (rad/s).
    pub max_turn_rate: f64,
    /// Distance within which the goal position is reached (m).
    pub goal_position_tol: f64,
    /// Heading error within which the goal heading is reached (rad).
    pub goal_angle_tol: f64,
}

/// One laser scan, centred on the robot's heading.
#[derive(Clone, Debug, PartialEq)]
pub struct Scan {
    /// Ranges (m), from the rightmost beam counter-clockwise.
    pub ranges: Vec<f64>,
    /// Angle between beams (rad).
    pub resolution: f64,
    /// The laser's maximum range (m).
    pub max_range: f64,
}

/// What to do.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command {
    /// The goal pose is reached: stop and wait for the next goal.
    Arrived,
    /// Drive at `v` (m/s) turning at `w` (rad/s).
    Drive {
        /// Forward speed.
        v: f64,
        /// Turn rate.
        w: f64,
    },
}

/// `i` wrapped into `0..n`.
fn wrap(i: i64, n: i64) -> usize {
    i.rem_euclid(n) as usize
}

/// Signed sector steps from `s1` to `s2` the shorter way round.
fn between(s1: i64, s2: i64, n: i64) -> i64 {
    let s = wrap(s2, n) as i64 - wrap(s1, n) as i64;
    if s.abs() < n / 2 {
        s
    } else {
        -s.signum() * (n - s.abs())
    }
}

/// Sector steps from `s1` to `s2` going in `dir` (±1).
fn between_directed(s1: i64, s2: i64, n: i64, dir: i64) -> i64 {
    (dir * (wrap(s2, n) as i64 - wrap(s1, n) as i64)).rem_euclid(n)
}

/// A range discontinuity, placed on its far (open) side: `sector` is there, `dist` is the
/// range of the corner on the near side, and `dir` the way from the gap to that corner
/// (+1 counter-clockwise, -1 clockwise).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gap {
    /// The sector on the far side.
    pub sector: i64,
    /// Range of the corner on the near side (m).
    pub dist: f64,
    /// +1: the corner is counter-clockwise of the gap, -1: clockwise.
    pub dir: i64,
}

/// A valley: from its rising gap towards the other gap, `rising_to_other` (±1) the way.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Valley {
    /// The gap the robot can turn round.
    pub rising: Gap,
    /// The other bound.
    pub other: Gap,
    /// Direction from the rising gap into the valley.
    pub rising_to_other: i64,
}

impl Valley {
    fn contains(&self, sector: i64, n: i64) -> bool {
        between_directed(self.rising.sector, sector, n, self.rising_to_other)
            < between_directed(
                self.rising.sector,
                self.other.sector,
                n,
                self.rising_to_other,
            )
    }

    /// Sectors from the rising gap to the first one nearer than the gap's corner, or to the
    /// valley's end.
    fn width(&self, full: &[f64]) -> i64 {
        let n = full.len() as i64;
        let mut s = wrap(self.rising.sector + self.rising_to_other, n) as i64;
        while self.contains(s, n) {
            if full[s as usize] < self.rising.dist {
                break;
            }
            s = wrap(s + self.rising_to_other, n) as i64;
        }
        between_directed(self.rising.sector, s, n, self.rising_to_other)
    }
}

fn sector_point(range: f64, sector: i64, n: i64, res: f64) -> (f64, f64) {
    let a = res * (sector - n / 2) as f64;
    (range * a.cos(), range * a.sin())
}

/// Whether the corner making a rising gap leaves room for the robot: no obstacle within
/// 2.2 radii of it in the quarter circle of sectors into the valley.
pub fn rising_gap_safe(
    gap: &Gap,
    dir: i64,
    full: &[f64],
    res: f64,
    max_range: f64,
    r: f64,
) -> bool {
    let n = full.len() as i64;
    let (xg, yg) = sector_point(gap.dist, gap.sector, n, res);
    (1..n / 4).all(|i| {
        let s = wrap(gap.sector + dir * i, n);
        if full[s] >= max_range - 0.01 {
            return true;
        }
        let (x, y) = sector_point(full[s], s as i64, n, res);
        (xg - x).hypot(yg - y) >= 2.2 * r
    })
}

/// Whether a `width`-wide corridor `length` long towards `center` is free of obstacles (and,
/// with `rear`, the half circle behind within half the width).
pub fn filter_clear(
    center: i64,
    width: f64,
    length: f64,
    rear: bool,
    full: &[f64],
    res: f64,
) -> bool {
    let n = full.len() as i64;
    full.iter().enumerate().all(|(i, &range)| {
        let delta = between(i as i64, center, n).abs();
        if delta > n / 4 {
            !(rear && range < width / 2.0)
        } else {
            let a = delta as f64 * res;
            let d1 = (width / 2.0) / a.sin();
            let d2 = length / a.cos();
            range >= d1.min(d2)
        }
    })
}

/// The gaps of a full-circle range list (`lps` of its sectors are the laser's), in sector
/// order, neighbours going the same way merged.
pub fn find_gaps(full: &[f64], lps: usize, min_gap_width: f64, max_range: f64, r: f64) -> Vec<Gap> {
    let n = full.len() as i64;
    let nl = lps as i64;
    let pnd: Vec<f64> = full
        .iter()
        .map(|&d| {
            if d >= max_range {
                0.0
            } else {
                max_range + 2.0 * r - d
            }
        })
        .collect();
    let mut gaps = Vec::new();
    if nl < n {
        // The laser's right edge: open space clockwise of its first beam.
        let idx = n / 2 - nl / 2;
        gaps.push(Gap {
            sector: wrap(idx - 1, n) as i64,
            dist: full[wrap(idx, n)],
            dir: 1,
        });
    }
    for i in 1..nl {
        let k = i + n / 2 - nl / 2;
        let di = pnd[wrap(k, n)] - pnd[wrap(k - 1, n)];
        if di > min_gap_width {
            gaps.push(Gap {
                sector: wrap(k - 1, n) as i64,
                dist: full[wrap(k, n)],
                dir: 1,
            });
        } else if di < -min_gap_width {
            gaps.push(Gap {
                sector: wrap(k, n) as i64,
                dist: full[wrap(k - 1, n)],
                dir: -1,
            });
        }
    }
    if nl < n {
        // The laser's left edge: open space counter-clockwise of its last beam.
        let idx = n / 2 - nl / 2 + nl;
        gaps.push(Gap {
            sector: wrap(idx, n) as i64,
            dist: full[wrap(idx - 1, n)],
            dir: -1,
        });
    }
    // Adjacent gaps going the same way: keep the rightmost left gap, the leftmost right one.
    let mut k = 0;
    while k < gaps.len() {
        let next = if k + 1 < gaps.len() { k + 1 } else { 0 };
        if next != k
            && gaps[k].sector == wrap(gaps[next].sector - 1, n) as i64
            && gaps[k].dir == gaps[next].dir
        {
            if gaps[k].dir < 0 {
                gaps[k].sector = gaps[next].sector;
            }
            gaps.remove(next);
            if next == 0 {
                k -= 1;
            }
        }
        k += 1;
    }
    gaps
}

/// The valleys between consecutive gaps whose rising side is safe.
pub fn find_valleys(
    gaps: &[Gap],
    full: &[f64],
    goal_sector: i64,
    res: f64,
    max_range: f64,
    r: f64,
) -> Vec<Valley> {
    let n = full.len() as i64;
    let mut valleys = Vec::new();
    for (k, &this) in gaps.iter().enumerate() {
        let next = gaps[(k + 1) % gaps.len()];
        let right_rising = |g: Gap, o: Gap| {
            rising_gap_safe(&g, 1, full, res, max_range, r).then_some(Valley {
                rising: g,
                other: o,
                rising_to_other: 1,
            })
        };
        let left_rising = |g: Gap, o: Gap| {
            rising_gap_safe(&g, -1, full, res, max_range, r).then_some(Valley {
                rising: g,
                other: o,
                rising_to_other: -1,
            })
        };
        let valley = if this.dir < 0 {
            if next.dir > 0 {
                // Both rising: the one nearer the goal.
                let dl = between(this.sector, goal_sector, n).abs();
                let dn = between(next.sector, goal_sector, n).abs();
                if dl <= dn {
                    right_rising(this, next)
                } else {
                    left_rising(next, this)
                }
            } else {
                right_rising(this, next)
            }
        } else if next.dir > 0 {
            left_rising(next, this)
        } else {
            None
        };
        valleys.extend(valley);
    }
    valleys
}

/// One SND step for a robot at `pose` (x, y, heading) heading for `goal` (x, y, heading);
/// `None` when the scan is unusable (no beams, or a resolution outside (0, 1] rad).
pub fn step(
    p: &SndParams,
    scan: &Scan,
    pose: (f64, f64, f64),
    goal: (f64, f64, f64),
) -> Option<Command> {
    let lps = scan.ranges.len();
    let res = scan.resolution;
    if lps == 0 || lps > 100_000 || res <= 0.0 || res > 1.0 {
        return None;
    }
    let n = (2.0 * PI / res + 0.5).round() as i64;
    if n <= 0 || n > 100_000 || n < lps as i64 {
        return None;
    }
    let r = p.robot_radius;
    let max_range = scan.max_range;
    let goal_a = normalize(goal.2);
    let mut dist_to_goal = (goal.0 - pose.0).hypot(goal.1 - pose.1).max(0.01);
    let rad_to_goal = normalize(
        ((goal.1 - pose.1) / dist_to_goal).atan2((goal.0 - pose.0) / dist_to_goal) - pose.2,
    );
    let goal_sector = if dist_to_goal < 1000.0 {
        (n as f64 / 2.0 + rad_to_goal / res).round() as i64
    } else {
        // Very far goals are a direction.
        (n as f64 / 2.0 + goal_a / res).round() as i64
    };
    if dist_to_goal < p.goal_position_tol {
        if normalize(pose.2 - goal_a).abs() < p.goal_angle_tol {
            return Some(Command::Arrived);
        }
        // Upstream turns by the raw difference, not normalized.
        let w = ((goal_a - pose.2) / 3.0).clamp(-p.max_turn_rate, p.max_turn_rate);
        return Some(Command::Drive { v: 0.0, w });
    }
    let nl = lps as i64;
    let full: Vec<f64> = (0..n)
        .map(|i| {
            let k = i - n / 2 + nl / 2;
            if (0..nl).contains(&k) {
                scan.ranges[k as usize]
            } else {
                max_range
            }
        })
        .collect();
    let mut min_obs = max_range;
    for &d in &full {
        if d < max_range && d < min_obs {
            min_obs = d;
        }
    }
    let safety = (5.0 * (min_obs - r)).clamp(0.0, p.obstacle_avoid_dist);
    let gaps = find_gaps(&full, lps, p.min_gap_width, max_range, r);
    let valleys = find_valleys(&gaps, &full, goal_sector, res, max_range, r);

    // Best valley: nearest rising gap to the goal; the valley behind the robot (outside the
    // laser's view) only in a second pass, when the first found nothing within a quarter turn.
    let mut best: Option<Valley> = None;
    let mut best_dist = n;
    for pass in [1, 2] {
        if pass == 2 && nl >= n {
            break;
        }
        for v in &valleys {
            if pass == 1 && nl < n && v.contains(0, n) {
                continue;
            }
            if pass == 2 && best.is_some() && best_dist <= 1 + n / 4 {
                continue;
            }
            let d = between(v.rising.sector, goal_sector, n).abs();
            if d < best_dist {
                best_dist = d;
                best = Some(*v);
            }
        }
    }
    dist_to_goal = (goal.0 - pose.0).hypot(goal.1 - pose.1);
    let corridor = (max_range - r).min(dist_to_goal - r);
    let theta_sector = if min_obs < r {
        n / 2
    } else if let Some(v) = best {
        let rising = v.rising.sector;
        let dir = v.rising_to_other;
        let width = v.width(&full);
        let corner = v.rising.dist;
        let mut angle = if corner < p.obstacle_avoid_dist + r {
            n / 4
        } else {
            (((p.obstacle_avoid_dist + r) / corner)
                .clamp(-1.0, 1.0)
                .asin()
                / res)
                .round() as i64
        };
        // Upstream keeps the safe direction within the laser's view this way.
        angle = angle.min(nl / 3);
        let srd = wrap(rising + angle * dir, n) as i64;
        let mid = wrap(rising + dir * (width / 2 - 1), n) as i64;
        let mut target = -1;
        if between(goal_sector, n / 2, n).abs() < (n / 4).min(nl / 2)
            && filter_clear(goal_sector, 2.0 * r, corridor, false, &full, res)
        {
            target = goal_sector;
        }
        if target < 0 && between(rising, mid, n).abs() < between(rising, srd, n).abs() {
            target = mid;
        }
        if target < 0 {
            target = srd;
        }
        // Deflection: the average sector offset of obstacles inside the safety distance,
        // weighted by the cube of how deep inside they are.
        let (mut sao, mut weights) = (0.0, 0.0);
        for (i, &d) in full.iter().enumerate() {
            let m = ((safety + r - d) / safety).clamp(0.0, 1.0);
            let opposite = wrap(i as i64 + n / 2, n) as i64;
            let delta = between(target, opposite, n) as f64;
            weights += m * m;
            sao += m * m * m * delta;
        }
        let sao = if weights > 0.0 { sao / weights } else { 0.0 };
        ((target as f64 + sao).round() as i64).clamp(0, n - 1)
    } else if filter_clear(goal_sector, 2.0 * r, corridor, false, &full, res) {
        // No gaps at all: go for the goal if the way is clear.
        goal_sector
    } else {
        // Nowhere to go: spin until a valley shows up.
        0
    };
    let theta = res * (theta_sector as f64 - n as f64 / 2.0);
    let theta = theta.clamp(-PI / 2.0, PI / 2.0);
    let w = p.max_turn_rate * (2.0 * theta / PI);
    let theta = theta.clamp(-PI / 4.0, PI / 4.0);
    let v = p.max_speed
        * (2.0 * dist_to_goal).clamp(0.0, 1.0)
        * ((min_obs - r) / p.obstacle_avoid_dist).clamp(0.0, 1.0)
        * ((PI / 6.0 - theta.abs()) / (PI / 6.0)).clamp(0.0, 1.0);
    Some(Command::Drive { v, w })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> SndParams {
        SndParams {
            robot_radius: 0.25,
            min_gap_width: 0.5,
            obstacle_avoid_dist: 1.0,
            max_speed: 0.5,
            max_turn_rate: 60f64.to_radians(),
            goal_position_tol: 0.125,
            goal_angle_tol: 30f64.to_radians(),
        }
    }

    /// A 181-beam, 180° scan with `range(bearing)`.
    fn scan(range: impl Fn(f64) -> f64) -> Scan {
        Scan {
            ranges: (0..=180)
                .map(|i| range((i as f64 - 90.0).to_radians()))
                .collect(),
            resolution: 1f64.to_radians(),
            max_range: 8.0,
        }
    }

    fn drive(c: Option<Command>) -> (f64, f64) {
        match c {
            Some(Command::Drive { v, w }) => (v, w),
            other => panic!("expected a drive command, got {other:?}"),
        }
    }

    #[test]
    fn sector_arithmetic_wraps_the_short_way() {
        assert_eq!(between(10, 20, 360), 10);
        assert_eq!(between(350, 10, 360), 20);
        assert_eq!(between(10, 350, 360), -20);
        assert_eq!(between_directed(10, 350, 360, 1), 340);
        assert_eq!(between_directed(10, 350, 360, -1), 20);
        assert_eq!(wrap(-1, 360), 359);
    }

    #[test]
    fn free_space_goes_straight_at_the_goal() {
        let s = scan(|_| 8.0);
        let (v, w) = drive(step(&params(), &s, (0.0, 0.0, 0.0), (3.0, 0.0, 0.0)));
        // Half a sector off straight ahead: upstream centres sectors on n/2 as a real.
        assert!(v > 0.45 && w.abs() < 0.02, "{v} {w}");
        // A goal to the left: turn left, slowing while the heading is off.
        let (v, w) = drive(step(&params(), &s, (0.0, 0.0, 0.0), (0.0, 3.0, 0.0)));
        assert!(w > 0.5 && v == 0.0, "{v} {w}");
    }

    #[test]
    fn the_goal_pose_is_reached_in_position_then_heading() {
        let s = scan(|_| 8.0);
        let at = step(&params(), &s, (1.0, 1.0, 0.1), (1.05, 1.0, 0.0));
        assert_eq!(at, Some(Command::Arrived));
        // In position, heading 90° off: turn in place by a third of the error.
        let (v, w) = drive(step(&params(), &s, (1.0, 1.0, 0.0), (1.05, 1.0, 1.5)));
        assert_eq!(v, 0.0);
        assert!((w - 0.5).abs() < 1e-9, "{w}");
    }

    #[test]
    fn unusable_scans_give_no_command() {
        let mut s = scan(|_| 8.0);
        s.resolution = 0.0;
        assert_eq!(step(&params(), &s, (0.0, 0.0, 0.0), (3.0, 0.0, 0.0)), None);
        s.ranges.clear();
        s.resolution = 0.01;
        assert_eq!(step(&params(), &s, (0.0, 0.0, 0.0), (3.0, 0.0, 0.0)), None);
    }

    #[test]
    fn gaps_are_range_jumps_and_the_laser_edges() {
        // 2 m ahead on the right half, 6 m on the left: one jump at the front.
        let s = scan(|b| if b > 0.0 { 6.0 } else { 2.0 });
        let n = (2.0 * PI / s.resolution + 0.5).round() as i64;
        let full: Vec<f64> = (0..n)
            .map(|i| {
                let k = i - n / 2 + 90;
                if (0..181).contains(&k) {
                    s.ranges[k as usize]
                } else {
                    8.0
                }
            })
            .collect();
        let gaps = find_gaps(&full, 181, 0.5, 8.0, 0.25);
        // Right edge, the jump, left edge; each at its far side, with the near range, and
        // `dir` pointing at the near side.
        assert_eq!(gaps.len(), 3, "{gaps:?}");
        assert_eq!(gaps[0].dir, 1);
        let jump = gaps[1];
        assert_eq!(jump.dir, -1);
        assert_eq!(jump.sector, n / 2 + 1);
        assert_eq!(jump.dist, 2.0);
        assert_eq!(gaps[2].dir, -1);
    }

    #[test]
    fn a_wall_ahead_is_skirted_towards_its_open_end() {
        // A wall 1.5 m ahead across the right and centre, open on the left beyond 20°.
        let s = scan(|b| {
            if b < 20f64.to_radians() {
                (1.5 / b.cos()).min(8.0)
            } else {
                8.0
            }
        });
        let (_, w) = drive(step(&params(), &s, (0.0, 0.0, 0.0), (4.0, 0.0, 0.0)));
        assert!(w > 0.0, "turns left round the wall's end: {w}");
    }

    #[test]
    fn a_near_obstacle_deflects_and_slows() {
        // A post 0.6 m away, 30° to the right; the goal straight ahead and clear of it.
        let post = 30f64.to_radians();
        let s = scan(|b| if (b + post).abs() < 0.05 { 0.6 } else { 8.0 });
        let (v, w) = drive(step(&params(), &s, (0.0, 0.0, 0.0), (4.0, 0.0, 0.0)));
        let free = drive(step(
            &params(),
            &scan(|_| 8.0),
            (0.0, 0.0, 0.0),
            (4.0, 0.0, 0.0),
        ));
        assert!(v < free.0, "slower near the post: {v}");
        assert!(w > 0.0, "pushed left, away from the post: {w}");
    }

    #[test]
    fn too_close_goes_straight_slowly() {
        // Something inside the robot's radius: heading straight, speed zero.
        let s = scan(|b| if b.abs() < 0.05 { 0.2 } else { 8.0 });
        let (v, w) = drive(step(&params(), &s, (0.0, 0.0, 0.0), (4.0, 2.0, 0.0)));
        assert_eq!(v, 0.0);
        assert!(w.abs() < 0.02, "{w}");
    }
}
