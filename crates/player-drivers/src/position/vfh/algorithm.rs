//! The VFH+ algorithm (Ulrich and Borenstein's Vector Field Histogram Plus) as Player 3.0.2
//! runs it: an occupancy window around the robot filled from a range scan, a polar histogram of
//! obstacle density, a binary histogram with hysteresis, a mask for the directions the robot's
//! turning radius cannot reach, and a choice among the openings that is then turned into a
//! speed and a turn rate.
//!
//! Units are upstream's: millimetres, mm/s, degrees and deg/s, with speeds and turn rates in
//! whole numbers. The rounding is part of the behaviour (a turn rate below 1 deg/s is 0; speed
//! steps are whole mm/s), so it is kept rather than converted to SI inside.
//!
//! Angles follow upstream's robot-centred convention: 0° is the robot's right, 90° straight
//! ahead, 180° its left (so the forward half is 0–180°).

use super::ranges::HalfDegreeRanges;

/// Magnitude constant of a cell: an occupied cell at distance `d` mm weighs
/// `(BASE_MAG_REACH - d)^4 / BASE_MAG_SCALE`.
const BASE_MAG_REACH: f32 = 3000.0;
const BASE_MAG_SCALE: f32 = 100_000_000.0;

/// Upstream converts radians to degrees with 360/6.28 (not 360/2π) when it works out each
/// cell's direction; kept, since the directions decide which range a cell is compared with.
#[allow(clippy::approx_constant)] // deliberately upstream's 6.28, not TAU
const CELL_DIRECTION_DEG_PER_RAD: f32 = 360.0 / 6.28;

/// Speed-dependent safety distances get this many precomputed sector tables (one when the
/// safety distance does not depend on speed).
const SPEED_TABLES: usize = 20;

/// Openings narrower than this (degrees) are ignored.
const NARROWEST_OPENING: f32 = 10.0;
/// Openings narrower than this (degrees) are aimed at their centre only.
const WIDE_OPENING: f32 = 80.0;
/// In a wide opening, the candidates beside the borders keep this far (degrees) from them.
const BORDER_CLEARANCE: i32 = 40;
/// The turn rate is proportional to the picked direction's offset from straight ahead,
/// reaching the maximum at this offset (degrees).
const FULL_TURN_OFFSET: f64 = 75.0;
/// Speed step (mm/s) used when the time since the last update is unknown or implausible.
const FALLBACK_SPEED_STEP: i32 = 10;
/// Updates further apart than this (s) count as a restart of the speed ramp.
const STALE_UPDATE: f64 = 0.3;

/// The algorithm's parameters, in upstream's internal units.
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    /// Side of an occupancy cell (mm).
    pub cell_width: f32,
    /// Cells across the (square) occupancy window.
    pub window_diameter: usize,
    /// Histogram sector width (degrees).
    pub sector_angle: i32,
    /// Safety distance kept from obstacles when stopped (mm).
    pub safety_dist_0ms: f32,
    /// Safety distance kept from obstacles at 1 m/s (mm).
    pub safety_dist_1ms: f32,
    /// Top speed (mm/s).
    pub max_speed: i32,
    /// Top speed through a narrow opening (mm/s).
    pub max_speed_narrow_opening: i32,
    /// Top speed beside the borders of a wide opening (mm/s).
    pub max_speed_wide_opening: i32,
    /// Largest speed increase per second (mm/s²).
    pub max_acceleration: i32,
    /// Smallest turn rate worth commanding (deg/s); the driver uses it when turning in place.
    pub min_turnrate: i32,
    /// Top turn rate when stopped (deg/s).
    pub max_turnrate_0ms: i32,
    /// Top turn rate at 1 m/s (deg/s); in between it is interpolated linearly.
    pub max_turnrate_1ms: i32,
    /// Multiplies the turning radius the turn rates allow.
    pub min_turn_radius_safety_factor: f64,
    /// Below this density a sector is free when stopped.
    pub free_space_cutoff_0ms: f32,
    /// Above this density a sector is blocked when stopped.
    pub obs_cutoff_0ms: f32,
    /// Below this density a sector is free at 1 m/s.
    pub free_space_cutoff_1ms: f32,
    /// Above this density a sector is blocked at 1 m/s.
    pub obs_cutoff_1ms: f32,
    /// Weight of a candidate's distance from the goal direction.
    pub weight_desired_dir: f32,
    /// Weight of a candidate's distance from the last picked direction.
    pub weight_current_dir: f32,
}

/// Signed smallest turn from `a1` to `a2` in degrees (`a2 - a1` folded into [-180, 180]).
pub fn delta_angle(a1: f32, a2: f32) -> f32 {
    let d = a2 - a1;
    if d > 180.0 {
        d - 360.0
    } else if d < -180.0 {
        d + 360.0
    } else {
        d
    }
}

/// Cells of the window around the robot, precomputed once for a robot radius.
#[derive(Clone, Debug)]
struct Window {
    /// Cells across.
    size: usize,
    /// The robot's cell (column and row).
    center: usize,
    /// Rows in front of the robot that the scan can fill (upstream's `ceil(size / 2)`).
    front_rows: usize,
    /// Direction of each cell from the robot (degrees, 0 = right, 90 = ahead); `None` for the
    /// robot's own cell. Indexed `row * size + column`.
    direction: Vec<Option<f32>>,
    /// Distance of each cell's centre from the robot's (mm).
    dist: Vec<f32>,
    /// Density an occupied cell adds to the sectors it covers.
    base_mag: Vec<f32>,
    /// Per speed table, the sectors each front cell covers once enlarged by the robot's radius
    /// and the safety distance: `sectors[table][cell]`.
    sectors: Vec<Vec<Vec<u16>>>,
}

/// Direction (degrees) from the window's centre to the cell `(x, y)`, `y` growing backwards.
fn cell_direction(x: usize, y: usize, center: usize) -> Option<f32> {
    use std::cmp::Ordering::*;
    let (cx, cy) = (center as f32, center as f32);
    let (xf, yf) = (x as f32, y as f32);
    let atan_deg = |num: f32, den: f32| (num / den).atan() * CELL_DIRECTION_DEG_PER_RAD;
    Some(match (x.cmp(&center), y.cmp(&center)) {
        (Less, Less) => 180.0 - atan_deg(cy - yf, cx - xf),
        (Less, Equal) => 180.0,
        (Less, Greater) => 180.0 + atan_deg(yf - cy, cx - xf),
        (Equal, Less) => 90.0,
        (Equal, Equal) => return None,
        (Equal, Greater) => 270.0,
        (Greater, Less) => atan_deg(cy - yf, xf - cx),
        (Greater, Equal) => 0.0,
        (Greater, Greater) => 360.0 - atan_deg(yf - cy, xf - cx),
    })
}

/// Signed difference `to - from` folded the way upstream's sector test does (only one fold,
/// and only when the gap exceeds 180°).
fn fold(from: f32, to: f32) -> f32 {
    if from - to > 180.0 {
        to - (from - 360.0)
    } else if to - from > 180.0 {
        from - (to + 360.0)
    } else {
        to - from
    }
}

/// The histogram sectors that an obstacle in a cell at `direction`, widened by `enlarge`
/// degrees either side, falls into. A NaN `enlarge` (the cell lies within the enlargement
/// radius itself) covers no sector, as upstream's comparisons with NaN all fail.
fn covered_sectors(direction: f32, enlarge: f32, sector_angle: i32) -> Vec<u16> {
    let plus_dir = direction + enlarge;
    let neg_dir = direction - enlarge;
    let mut out = Vec::new();
    for i in 0..(360 / sector_angle) {
        let neg_sector = (i * sector_angle) as f32;
        let plus_sector = ((i + 1) * sector_angle) as f32;
        let neg_sector_to_neg_dir = fold(neg_sector, neg_dir);
        let plus_sector_to_neg_dir = fold(plus_sector, neg_dir);
        let plus_sector_to_plus_dir = fold(plus_sector, plus_dir);
        let neg_sector_to_plus_dir = fold(neg_sector, plus_dir);
        // Either edge of the widened obstacle lies inside the sector, or it spans the sector.
        let neg_dir_inside = neg_sector_to_neg_dir >= 0.0 && plus_sector_to_neg_dir <= 0.0;
        let plus_dir_inside = (neg_sector_to_plus_dir >= 0.0 && plus_sector_to_plus_dir <= 0.0)
            || (plus_sector_to_neg_dir <= 0.0 && plus_sector_to_plus_dir >= 0.0);
        let spans = neg_sector_to_neg_dir <= 0.0 && neg_sector_to_plus_dir >= 0.0;
        if neg_dir_inside || plus_dir_inside || spans {
            out.push(i as u16);
        }
    }
    out
}

impl Window {
    fn new(p: &Params, robot_radius: f32, tables: usize) -> Window {
        let size = p.window_diameter;
        let center = size / 2;
        let front_rows = size.div_ceil(2);
        let mut direction = Vec::with_capacity(size * size);
        let mut dist = Vec::with_capacity(size * size);
        let mut base_mag = Vec::with_capacity(size * size);
        // In single precision throughout, as upstream (checked against its tables).
        for y in 0..size {
            for x in 0..size {
                let dx = center as f32 - x as f32;
                let dy = center as f32 - y as f32;
                let d = (dx * dx + dy * dy).sqrt() * p.cell_width;
                dist.push(d);
                base_mag.push((BASE_MAG_REACH - d).powi(4) / BASE_MAG_SCALE);
                direction.push(cell_direction(x, y, center));
            }
        }
        let sectors = (0..tables)
            .map(|t| {
                // Each table serves speeds up to its share of the top speed.
                let table_speed = (((t + 1) as f32 / tables as f32) * p.max_speed as f32) as i32;
                let r = robot_radius + safety_dist(p, table_speed) as f32;
                (0..front_rows * size)
                    .map(|cell| {
                        let d = dist[cell];
                        let enlarge = if d > 0.0 {
                            (f64::from((r / d).asin()) * (180.0 / std::f64::consts::PI)) as f32
                        } else {
                            0.0
                        };
                        // The robot's own cell: upstream gives it direction -1.
                        let dir = direction[cell].unwrap_or(-1.0);
                        covered_sectors(dir, enlarge, p.sector_angle)
                    })
                    .collect()
            })
            .collect();
        Window {
            size,
            center,
            front_rows,
            direction,
            dist,
            base_mag,
            sectors,
        }
    }
}

/// Safety distance (mm) at `speed` mm/s, interpolated between the 0 and 1 m/s settings.
fn safety_dist(p: &Params, speed: i32) -> i32 {
    let step =
        (f64::from(speed) * f64::from(p.safety_dist_1ms - p.safety_dist_0ms) / 1000.0) as i32;
    ((p.safety_dist_0ms + step as f32) as i32).max(0)
}

/// `t` seconds in whole microseconds.
fn whole_microseconds(t: f64) -> i64 {
    (t * 1e6).round() as i64
}

/// Top turn rate (deg/s) at `speed` mm/s, interpolated between the 0 and 1 m/s settings.
pub fn max_turnrate(p: &Params, speed: i32) -> i32 {
    let drop =
        (f64::from(speed) * f64::from(p.max_turnrate_0ms - p.max_turnrate_1ms) / 1000.0) as i32;
    (p.max_turnrate_0ms - drop).max(0)
}

/// An opening of the histogram: free sectors from `first` to `second` (degrees, both
/// multiples of the sector angle, counter-clockwise from `first`).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Opening {
    first: i32,
    second: i32,
}

/// A direction the robot may take and the top speed it allows.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Candidate {
    angle: f32,
    speed: i32,
}

/// What one update decided.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Motion {
    /// Forward speed (mm/s, never negative).
    pub speed: i32,
    /// Turn rate (deg/s, positive to the left).
    pub turnrate: i32,
}

/// The VFH+ state of one robot: its precomputed window and what it carries from one update to
/// the next (the binary histogram for hysteresis, the last direction and speed).
#[derive(Clone, Debug)]
pub struct Vfh {
    p: Params,
    robot_radius: f32,
    window: Window,
    hist_size: usize,
    /// The working histogram: primary, then binary, then masked (1 = blocked).
    hist: Vec<f32>,
    last_binary_hist: Vec<f32>,
    /// Occupied cells' densities (0 = free) from the latest scan; front rows only.
    cell_mag: Vec<f32>,
    /// Turning radius (mm) at each speed 0..=current_max_speed.
    min_turning_radius: Vec<i32>,
    current_max_speed: i32,
    desired_angle: f32,
    dist_to_goal: f32,
    goal_distance_tolerance: f32,
    picked_angle: f32,
    last_picked_angle: f32,
    max_speed_for_picked_angle: i32,
    blocked_circle_radius: f32,
    /// Time of the last update in whole microseconds: upstream measures the time between
    /// updates with `timeval`s, so 0.1 s steps of simulated time are exactly 0.1 s apart
    /// (with f64 seconds they can come out a hair short, and the speed step one mm/s less).
    last_update_us: i64,
    last_chosen_speed: i32,
}

impl Vfh {
    /// Precomputes the window for a robot of `robot_radius` mm; `now` (s) starts the clock the
    /// acceleration limit is measured with.
    pub fn new(p: Params, robot_radius: f32, now: f64) -> Vfh {
        let tables = if p.safety_dist_0ms == p.safety_dist_1ms {
            1
        } else {
            SPEED_TABLES
        };
        let window = Window::new(&p, robot_radius, tables);
        let hist_size = (360.0 / f64::from(p.sector_angle)).round_ties_even() as usize;
        let cells = window.front_rows * window.size;
        let mut vfh = Vfh {
            robot_radius,
            window,
            hist_size,
            hist: vec![0.0; hist_size],
            last_binary_hist: vec![1.0; hist_size],
            cell_mag: vec![0.0; cells],
            min_turning_radius: Vec::new(),
            current_max_speed: 0,
            desired_angle: 90.0,
            dist_to_goal: 0.0,
            goal_distance_tolerance: 0.0,
            picked_angle: 90.0,
            last_picked_angle: 90.0,
            max_speed_for_picked_angle: 0,
            blocked_circle_radius: 0.0,
            last_update_us: whole_microseconds(now),
            last_chosen_speed: 0,
            p,
        };
        vfh.set_current_max_speed(vfh.p.max_speed);
        vfh
    }

    /// The parameters.
    pub fn params(&self) -> &Params {
        &self.p
    }

    /// The robot radius (mm) the window was built for.
    pub fn robot_radius(&self) -> f32 {
        self.robot_radius
    }

    /// The top speed in force (mm/s).
    pub fn current_max_speed(&self) -> i32 {
        self.current_max_speed
    }

    /// Top turn rate (deg/s) at `speed` mm/s.
    pub fn max_turnrate(&self, speed: i32) -> i32 {
        max_turnrate(&self.p, speed)
    }

    /// Smallest turn rate worth commanding (deg/s).
    pub fn min_turnrate(&self) -> i32 {
        self.p.min_turnrate
    }

    /// The direction picked by the last update (degrees, 90 = ahead).
    pub fn picked_angle(&self) -> f32 {
        self.picked_angle
    }

    /// The histogram after the last update: 1 for blocked sectors, 0 for free ones (the
    /// masked histogram, or all blocked when something was inside the safety distance).
    pub fn histogram(&self) -> &[f32] {
        &self.hist
    }

    /// Caps the speed and works out the turning radius at every speed up to it.
    fn set_current_max_speed(&mut self, max_speed: i32) {
        self.current_max_speed = max_speed.min(self.p.max_speed).max(0);
        let p = &self.p;
        self.min_turning_radius = (0..=self.current_max_speed)
            .map(|speed| {
                // Radius of a small step forward while turning at the top rate for that speed.
                let dx = f64::from(speed) / 1e6;
                let dtheta = f64::from(max_turnrate(p, speed)).to_radians() / 1000.0;
                ((dx / dtheta.tan()) * 1000.0 * p.min_turn_radius_safety_factor) as i32
            })
            .collect();
    }

    /// Index of the sector table for `speed`.
    fn speed_index(&self, speed: i32) -> usize {
        let tables = self.window.sectors.len();
        if self.current_max_speed <= 0 {
            return 0;
        }
        let i = ((speed as f32 / self.current_max_speed as f32) * tables as f32).floor();
        (i.max(0.0) as usize).min(tables - 1)
    }

    /// Turning radius (mm) at `speed`, the top one for speeds beyond the table.
    fn turning_radius(&self, speed: i32) -> i32 {
        let i = (speed.max(0) as usize).min(self.min_turning_radius.len() - 1);
        self.min_turning_radius[i]
    }

    fn binary_low(&self, speed: i32) -> f32 {
        let p = &self.p;
        p.free_space_cutoff_0ms
            - (speed as f32 * (p.free_space_cutoff_0ms - p.free_space_cutoff_1ms) / 1000.0)
    }

    fn binary_high(&self, speed: i32) -> f32 {
        let p = &self.p;
        p.obs_cutoff_0ms - (speed as f32 * (p.obs_cutoff_0ms - p.obs_cutoff_1ms) / 1000.0)
    }

    /// Marks the front cells the scan shows occupied. `false` when an obstacle is within the
    /// robot radius plus the safety distance (the caller then stops and turns on the spot).
    fn calculate_cells_mag(&mut self, ranges: &HalfDegreeRanges, speed: i32) -> bool {
        let w = &self.window;
        let r = self.robot_radius + safety_dist(&self.p, speed) as f32;
        let half_cell = f64::from(self.p.cell_width) / 2.0;
        for y in 0..w.front_rows {
            for x in 0..w.size {
                let cell = y * w.size + x;
                // The robot's own cell is never an obstacle (upstream reads outside its range
                // table there).
                let Some(dir) = w.direction[cell] else {
                    self.cell_mag[cell] = 0.0;
                    continue;
                };
                let range = ranges[(f64::from(dir) * 2.0).round_ties_even() as usize];
                if f64::from(w.dist[cell]) + half_cell > range {
                    if w.dist[cell] < r {
                        return false;
                    }
                    self.cell_mag[cell] = w.base_mag[cell];
                } else {
                    self.cell_mag[cell] = 0.0;
                }
            }
        }
        true
    }

    /// Sums the occupied cells' densities into sectors; `false` (and every sector blocked)
    /// when something is inside the safety distance.
    fn build_primary_polar_histogram(&mut self, ranges: &HalfDegreeRanges, speed: i32) -> bool {
        self.hist.iter_mut().for_each(|h| *h = 0.0);
        if !self.calculate_cells_mag(ranges, speed) {
            self.hist.iter_mut().for_each(|h| *h = 1.0);
            return false;
        }
        let table = &self.window.sectors[self.speed_index(speed)];
        for (cell, sectors) in table.iter().enumerate() {
            let mag = self.cell_mag[cell];
            for &s in sectors {
                self.hist[usize::from(s)] += mag;
            }
        }
        true
    }

    /// Thresholds the densities with hysteresis: between the free and the obstacle cutoffs a
    /// sector keeps its previous state.
    fn build_binary_polar_histogram(&mut self, speed: i32) {
        let (low, high) = (self.binary_low(speed), self.binary_high(speed));
        for (h, last) in self.hist.iter_mut().zip(&mut self.last_binary_hist) {
            if *h > high {
                *h = 1.0;
            } else if *h < low {
                *h = 0.0;
            } else {
                *h = *last;
            }
            *last = *h;
        }
    }

    /// Blocks the directions the robot cannot turn into at `speed` without sweeping an
    /// obstacle: those beyond the innermost occupied cell inside the circle of its turning
    /// radius on either side. Also sets the blocked circles' radius.
    fn build_masked_polar_histogram(&mut self, speed: i32) {
        let w = &self.window;
        let turning = self.turning_radius(speed) as f32;
        let cell_width = self.p.cell_width;
        let center_x_right = w.center as f32 + turning / cell_width;
        let center_x_left = w.center as f32 - turning / cell_width;
        let center_y = w.center as f32;
        let angle_ahead = 90.0;
        let mut phi_left = 180.0;
        let mut phi_right = 0.0;
        self.blocked_circle_radius =
            turning + self.robot_radius + safety_dist(&self.p, speed) as f32;
        for y in 0..w.front_rows {
            for x in 0..w.size {
                let cell = y * w.size + x;
                if self.cell_mag[cell] == 0.0 {
                    continue;
                }
                let dir = w.direction[cell].unwrap_or(-1.0);
                let (xf, yf) = (x as f32, y as f32);
                if delta_angle(dir, angle_ahead) > 0.0 && delta_angle(dir, phi_right) <= 0.0 {
                    // Between the right limit and straight ahead.
                    let d = (center_x_right - xf).hypot(center_y - yf) * cell_width;
                    if d < self.blocked_circle_radius {
                        phi_right = dir;
                    }
                } else if delta_angle(dir, angle_ahead) <= 0.0 && delta_angle(dir, phi_left) > 0.0 {
                    // Between straight ahead and the left limit.
                    let d = (center_x_left - xf).hypot(center_y - yf) * cell_width;
                    if d < self.blocked_circle_radius {
                        phi_left = dir;
                    }
                }
            }
        }
        let sector_angle = self.p.sector_angle;
        for (i, h) in self.hist.iter_mut().enumerate() {
            let angle = (i as i32 * sector_angle) as f32;
            let right_free =
                delta_angle(angle, phi_right) <= 0.0 && delta_angle(angle, angle_ahead) >= 0.0;
            let left_free =
                delta_angle(angle, phi_left) >= 0.0 && delta_angle(angle, angle_ahead) <= 0.0;
            *h = if *h == 0.0 && (right_free || left_free) {
                0.0
            } else {
                1.0
            };
        }
    }

    /// The openings of the masked histogram, counter-clockwise from the first blocked sector
    /// of the forward half; `None` when the forward half is clear.
    fn openings(&self) -> Option<Vec<Opening>> {
        let n = self.hist_size;
        let blocked = |i: usize| self.hist[i % n] == 1.0;
        let start = (0..n / 2).find(|&i| blocked(i))?;
        let sa = self.p.sector_angle;
        let mut out = Vec::new();
        let mut first = None;
        for i in start..=start + n {
            let sector = (i % n) as i32;
            match (first, blocked(i)) {
                (None, false) => first = Some(sector * sa),
                (Some(f), true) => {
                    let mut second = (sector - 1) * sa;
                    if second < 0 {
                        second += 360;
                    }
                    out.push(Opening { first: f, second });
                    first = None;
                }
                _ => {}
            }
        }
        Some(out)
    }

    /// The candidate directions of each opening: the centre of a narrow one; the centre, the
    /// two directions 40° inside the borders and, if it lies between those, the goal direction
    /// for a wide one.
    fn candidates(&self, openings: &[Opening]) -> Vec<Candidate> {
        let p = &self.p;
        let top = self.current_max_speed;
        let mut out: Vec<Candidate> = Vec::new();
        for o in openings {
            let width = delta_angle(o.first as f32, o.second as f32).abs();
            if width < NARROWEST_OPENING {
                continue;
            }
            let centre = o.first as f32 + (o.second - o.first) as f32 / 2.0;
            if width < WIDE_OPENING {
                out.push(Candidate {
                    angle: centre,
                    speed: top.min(p.max_speed_narrow_opening),
                });
                continue;
            }
            let beside = top.min(p.max_speed_wide_opening);
            out.push(Candidate {
                angle: centre,
                speed: top,
            });
            let after_first = ((o.first + BORDER_CLEARANCE) % 360) as f32;
            let mut before_second = (o.second - BORDER_CLEARANCE) as f32;
            if before_second < 0.0 {
                before_second += 360.0;
            }
            out.push(Candidate {
                angle: after_first,
                speed: beside,
            });
            out.push(Candidate {
                angle: before_second,
                speed: beside,
            });
            if delta_angle(self.desired_angle, after_first) < 0.0
                && delta_angle(self.desired_angle, before_second) > 0.0
            {
                out.push(Candidate {
                    angle: self.desired_angle,
                    speed: beside,
                });
            }
        }
        out
    }

    /// Picks the direction to take: straight for the goal when the forward half is clear,
    /// else the candidate closest to the goal direction and to the last pick (weighted); with
    /// no candidate, keep the last direction at speed 0.
    fn select_direction(&mut self) {
        let Some(openings) = self.openings() else {
            self.picked_angle = self.desired_angle;
            self.last_picked_angle = self.picked_angle;
            self.max_speed_for_picked_angle = self.current_max_speed;
            return;
        };
        let candidates = self.candidates(&openings);
        if candidates.is_empty() {
            self.hemmed_in();
            return;
        }
        self.picked_angle = 90.0;
        let mut min_weight = 10_000_000.0;
        for c in &candidates {
            let weight = self.p.weight_desired_dir * delta_angle(self.desired_angle, c.angle).abs()
                + self.p.weight_current_dir * delta_angle(self.last_picked_angle, c.angle).abs();
            if weight < min_weight {
                min_weight = weight;
                self.picked_angle = c.angle;
                self.max_speed_for_picked_angle = c.speed;
            }
        }
        self.last_picked_angle = self.picked_angle;
    }

    /// Nowhere to go: keep the last direction, speed 0 (the robot turns on the spot).
    fn hemmed_in(&mut self) {
        self.picked_angle = self.last_picked_angle;
        self.max_speed_for_picked_angle = 0;
    }

    /// Whether the goal lies inside one of the circles the robot cannot enter at its speed
    /// (it would overshoot): then it slows down instead of speeding up.
    fn cant_turn_to_goal(&self) -> bool {
        let a = (self.desired_angle).to_radians();
        let goal_x = self.dist_to_goal * a.cos();
        let goal_y = self.dist_to_goal * a.sin();
        let r = self.blocked_circle_radius;
        let right = (goal_x - r).hypot(goal_y);
        let left = (-goal_x - r).hypot(goal_y);
        right + self.goal_distance_tolerance < r || left + self.goal_distance_tolerance < r
    }

    /// The turn rate for `speed` towards the picked direction (deg/s); with no speed, turn
    /// on the spot to the left at the top rate.
    fn set_motion(&self, speed: i32, actual_speed: i32) -> Motion {
        let top = self.max_turnrate(actual_speed);
        if speed <= 0 {
            return Motion {
                speed: 0,
                turnrate: top,
            };
        }
        let a = self.picked_angle;
        let turnrate = if a > 270.0 && a < 360.0 {
            -top
        } else if a < 270.0 && a > 180.0 {
            top
        } else {
            // The offset is single precision, the division double (it decides ties).
            let t =
                (f64::from(a - 90.0) / FULL_TURN_OFFSET * f64::from(top)).round_ties_even() as i32;
            t.clamp(-top, top)
        };
        Motion { speed, turnrate }
    }

    /// One update: a scan, the robot's current forward speed (mm/s), the goal's direction
    /// (degrees, 90 = ahead) and distance (mm), how close counts as there (mm), and the time
    /// (s). Returns the speed and turn rate to command.
    pub fn update(
        &mut self,
        ranges: &HalfDegreeRanges,
        current_speed: i32,
        goal_direction: f32,
        goal_distance: f32,
        goal_distance_tolerance: f32,
        now: f64,
    ) -> Motion {
        self.desired_angle = goal_direction;
        self.dist_to_goal = goal_distance;
        self.goal_distance_tolerance = goal_distance_tolerance;
        // The larger of the measured speed and the last set point: conservative if the robot
        // lags behind its commands.
        let current_pos_speed = current_speed.max(0).max(self.last_chosen_speed);
        let now_us = whole_microseconds(now);
        let elapsed = (now_us - self.last_update_us) as f64 / 1e6;
        self.last_update_us = now_us;

        if self.build_primary_polar_histogram(ranges, current_pos_speed) {
            self.build_binary_polar_histogram(current_pos_speed);
            self.build_masked_polar_histogram(current_pos_speed);
            self.select_direction();
        } else {
            // Something is inside the safety distance: brake and turn on the spot.
            self.hemmed_in();
        }

        let mut speed_incr = if !(0.0..=STALE_UPDATE).contains(&elapsed) {
            FALLBACK_SPEED_STEP
        } else {
            (f64::from(self.p.max_acceleration) * elapsed) as i32
        };
        if self.cant_turn_to_goal() {
            speed_incr = -speed_incr;
        }
        let speed = (self.last_chosen_speed + speed_incr).min(self.max_speed_for_picked_angle);
        let motion = self.set_motion(speed, current_pos_speed);
        self.last_chosen_speed = motion.speed;
        motion
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::position::vfh::ranges::{FAR, RANGE_COUNT};

    /// Player 3.0.2's defaults, converted as its driver converts them.
    pub(crate) fn defaults() -> Params {
        Params {
            cell_width: 100.0,
            window_diameter: 61,
            sector_angle: 5,
            safety_dist_0ms: 100.0,
            safety_dist_1ms: 100.0,
            max_speed: 200,
            max_speed_narrow_opening: 200,
            max_speed_wide_opening: 200,
            max_acceleration: 200,
            min_turnrate: 10,
            max_turnrate_0ms: 40,
            max_turnrate_1ms: 40,
            min_turn_radius_safety_factor: 1.0,
            free_space_cutoff_0ms: 2_000_000.0,
            obs_cutoff_0ms: 2_000_000.0,
            free_space_cutoff_1ms: 2_000_000.0,
            obs_cutoff_1ms: 2_000_000.0,
            weight_desired_dir: 5.0,
            weight_current_dir: 3.0,
        }
    }

    fn open() -> HalfDegreeRanges {
        [FAR; RANGE_COUNT]
    }

    /// A straight wall `d` mm ahead, across the whole view.
    fn wall_ahead(d: f64) -> HalfDegreeRanges {
        let mut r = open();
        for (i, v) in r.iter_mut().enumerate() {
            let bearing = (i as f64 / 2.0 - 90.0).to_radians();
            let c = bearing.cos();
            if c > 1e-6 {
                *v = (d / c).min(FAR);
            }
        }
        r
    }

    /// Blocks bearings (degrees, 90 = ahead) in `[from, to]` at range `d` mm.
    fn block(r: &mut HalfDegreeRanges, from: f64, to: f64, d: f64) {
        for (i, v) in r.iter_mut().enumerate() {
            let a = i as f64 / 2.0;
            if a >= from && a <= to {
                *v = v.min(d);
            }
        }
    }

    fn run(vfh: &mut Vfh, r: &HalfDegreeRanges, goal_dir: f32, steps: usize) -> Motion {
        let mut m = Motion {
            speed: 0,
            turnrate: 0,
        };
        for k in 0..steps {
            m = vfh.update(r, m.speed, goal_dir, 5000.0, 500.0, 0.1 * (k + 1) as f64);
        }
        m
    }

    #[test]
    fn cell_directions_follow_upstreams_layout() {
        assert_eq!(cell_direction(30, 0, 30), Some(90.0));
        assert_eq!(cell_direction(60, 30, 30), Some(0.0));
        assert_eq!(cell_direction(0, 30, 30), Some(180.0));
        assert_eq!(cell_direction(30, 60, 30), Some(270.0));
        assert_eq!(cell_direction(30, 30, 30), None);
        // 45° front-right, scaled by 360/6.28 rather than 180/π.
        let d = cell_direction(40, 20, 30).unwrap();
        assert!((d - 45.02).abs() < 0.01, "{d}");
        let d = cell_direction(20, 20, 30).unwrap();
        assert!((d - 134.98).abs() < 0.01, "{d}");
    }

    #[test]
    fn the_window_is_computed_in_single_precision_as_upstreams() {
        // Values of Player 3.0.2's own tables for a 61-cell window of 0.1 m cells.
        let v = Vfh::new(defaults(), 220.0, 0.0);
        let cell = 3; // column 3 of the front row
        assert_eq!(v.window.dist[cell], 4_036.087);
        assert_eq!(v.window.base_mag[cell], 11_523.51);
        assert_eq!(v.window.direction[cell], Some(131.96286));
        assert_eq!(v.window.sectors[0][cell], [25, 26, 27]);
        let cell = 28 * 61 + 28;
        assert_eq!(v.window.base_mag[cell], 545_078.56);
    }

    #[test]
    fn turn_rates_round_half_to_even_on_a_double_ratio() {
        let mut p = defaults();
        p.max_turnrate_0ms = 90;
        p.max_turnrate_1ms = 35;
        let mut v = Vfh::new(p, 220.0, 0.0);
        v.picked_angle = 97.5;
        // 7.5/75 of 85 deg/s is 8.5 in double precision: 8 (it would be 9 in single).
        assert_eq!(v.set_motion(100, 100).turnrate, 8);
    }

    #[test]
    fn time_between_updates_is_measured_in_whole_microseconds() {
        let mut v = Vfh::new(defaults(), 220.0, 3.2);
        // 3.3 - 3.2 is a hair under 0.1 in f64; upstream's timevals make it 0.1: +20 mm/s.
        let m = v.update(&open(), 0, 90.0, 5000.0, 500.0, 3.3);
        assert_eq!(m.speed, 20);
    }

    #[test]
    fn an_obstacle_covers_the_sectors_of_its_enlarged_direction() {
        // Dead ahead, widened by 12°: 78°..102° are sectors 15..=20 of 5°.
        assert_eq!(covered_sectors(90.0, 12.0, 5), vec![15, 16, 17, 18, 19, 20]);
        // Just right of ahead without widening: only its own sector.
        assert_eq!(covered_sectors(87.0, 0.0, 5), vec![17]);
        // Across 0°: wraps to the last sectors.
        assert_eq!(covered_sectors(2.0, 4.0, 5), vec![0, 1, 71]);
        // A cell within the enlargement radius covers nothing (NaN widening).
        assert!(covered_sectors(90.0, f32::NAN, 5).is_empty());
    }

    #[test]
    fn turn_rates_and_safety_distances_scale_with_speed() {
        let mut p = defaults();
        p.max_turnrate_0ms = 90;
        p.max_turnrate_1ms = 35;
        assert_eq!(max_turnrate(&p, 0), 90);
        assert_eq!(max_turnrate(&p, 300), 74); // 90 - trunc(16.5)
        assert_eq!(max_turnrate(&p, 2000), 0, "never negative");
        p.safety_dist_1ms = 300.0;
        assert_eq!(safety_dist(&p, 0), 100);
        assert_eq!(safety_dist(&p, 500), 200);
    }

    #[test]
    fn turning_radius_follows_speed_and_turn_rate() {
        let v = Vfh::new(defaults(), 250.0, 0.0);
        assert_eq!(v.min_turning_radius.len(), 201);
        assert_eq!(v.turning_radius(0), 0);
        // 0.2 m/s at 40°/s: r = v / w = 0.2 / 0.698 m = 286 mm.
        assert!(
            (v.turning_radius(200) - 286).abs() <= 1,
            "{}",
            v.turning_radius(200)
        );
        assert_eq!(v.turning_radius(5000), v.turning_radius(200), "clamped");
    }

    #[test]
    fn free_space_heads_straight_for_the_goal() {
        let mut v = Vfh::new(defaults(), 250.0, 0.0);
        let m = v.update(&open(), 0, 90.0, 5000.0, 500.0, 0.1);
        assert_eq!(v.picked_angle(), 90.0);
        assert_eq!(m.turnrate, 0);
        assert_eq!(m.speed, 20, "0.1 s at 200 mm/s²");
        // The speed ramps to the top speed and stays there.
        let m = run(&mut v, &open(), 90.0, 30);
        assert_eq!(
            m,
            Motion {
                speed: 200,
                turnrate: 0
            }
        );
        // A goal off to the left turns left, in proportion up to 75° off.
        let m = v.update(&open(), 200, 120.0, 5000.0, 500.0, 3.2);
        assert_eq!(v.picked_angle(), 120.0);
        assert_eq!(m.turnrate, 16, "30/75 of 40 deg/s");
        let m = v.update(&open(), 200, 30.0, 5000.0, 500.0, 3.3);
        assert_eq!(m.turnrate, -32);
    }

    #[test]
    fn the_first_update_and_long_gaps_only_creep() {
        let mut v = Vfh::new(defaults(), 250.0, 0.0);
        let m = v.update(&open(), 0, 90.0, 5000.0, 500.0, 5.0);
        assert_eq!(m.speed, 10);
        let m = v.update(&open(), 0, 90.0, 5000.0, 500.0, 5.25);
        assert_eq!(m.speed, 60, "then 0.25 s at 200 mm/s²");
    }

    #[test]
    fn a_wall_ahead_with_a_gap_on_the_left_turns_left() {
        let mut v = Vfh::new(defaults(), 250.0, 0.0);
        // Obstacles 1.2 m away from the right round to 110°; open beyond.
        let mut r = open();
        block(&mut r, 0.0, 110.0, 1200.0);
        let m = run(&mut v, &r, 90.0, 10);
        assert!(v.picked_angle() > 110.0, "picked {}", v.picked_angle());
        assert!(m.turnrate > 0, "{m:?}");
        assert!(m.speed > 0);
        // And the mirror image turns right.
        let mut v = Vfh::new(defaults(), 250.0, 0.0);
        let mut r = open();
        block(&mut r, 70.0, 180.0, 1200.0);
        let m = run(&mut v, &r, 90.0, 10);
        assert!(v.picked_angle() < 70.0, "picked {}", v.picked_angle());
        assert!(m.turnrate < 0, "{m:?}");
    }

    #[test]
    fn a_goal_behind_a_pillar_is_approached_around_it() {
        let mut v = Vfh::new(defaults(), 250.0, 0.0);
        let mut r = open();
        block(&mut r, 80.0, 100.0, 1000.0);
        run(&mut v, &r, 90.0, 10);
        // The pillar and its enlargement block 75°..100°; the left opening (115°..175°) is
        // narrow, so its centre is taken, which is nearer than the right one's (30°).
        let blocked: Vec<usize> = (0..36).filter(|&i| v.histogram()[i] == 1.0).collect();
        assert_eq!(blocked, [15, 16, 17, 18, 19, 20]);
        assert_eq!(v.picked_angle(), 142.5);
        // Further off, its density is below the cutoff: straight on.
        let mut v = Vfh::new(defaults(), 250.0, 0.0);
        let mut r = open();
        block(&mut r, 80.0, 100.0, 1500.0);
        run(&mut v, &r, 90.0, 10);
        assert_eq!(v.picked_angle(), 90.0);
    }

    #[test]
    fn something_inside_the_safety_distance_stops_and_spins() {
        let mut v = Vfh::new(defaults(), 250.0, 0.0);
        run(&mut v, &open(), 90.0, 20);
        // 0.3 m ahead, inside 250 mm radius + 100 mm safety.
        let m = v.update(&wall_ahead(300.0), 200, 90.0, 5000.0, 500.0, 2.1);
        assert_eq!(
            m,
            Motion {
                speed: 0,
                turnrate: 40
            }
        );
        assert!(v.histogram().iter().all(|&h| h == 1.0));
    }

    #[test]
    fn boxed_in_stops_and_spins_left() {
        let mut v = Vfh::new(defaults(), 250.0, 0.0);
        let r = wall_ahead(600.0);
        let mut r2 = r;
        block(&mut r2, 0.0, 180.0, 600.0);
        let m = run(&mut v, &r2, 90.0, 5);
        assert_eq!(m.speed, 0);
        assert_eq!(m.turnrate, 40);
    }

    #[test]
    fn binary_histogram_keeps_its_state_between_the_cutoffs() {
        let mut p = defaults();
        p.free_space_cutoff_0ms = 100.0;
        p.obs_cutoff_0ms = 200.0;
        p.free_space_cutoff_1ms = 100.0;
        p.obs_cutoff_1ms = 200.0;
        let mut v = Vfh::new(p, 250.0, 0.0);
        v.last_binary_hist.iter_mut().for_each(|h| *h = 0.0);
        v.hist = vec![50.0, 150.0, 250.0, 150.0];
        v.last_binary_hist = vec![1.0, 1.0, 0.0, 0.0];
        v.build_binary_polar_histogram(0);
        assert_eq!(v.hist, [0.0, 1.0, 1.0, 0.0]);
        assert_eq!(v.last_binary_hist, v.hist);
    }

    #[test]
    fn openings_are_found_counter_clockwise_from_the_first_obstacle() {
        let mut v = Vfh::new(defaults(), 250.0, 0.0);
        // Blocked: sectors 10..=20 and the whole back half.
        v.hist = (0..72)
            .map(|i| {
                if (10..=20).contains(&i) || i >= 36 {
                    1.0
                } else {
                    0.0
                }
            })
            .collect();
        let o = v.openings().unwrap();
        assert_eq!(
            o,
            [
                Opening {
                    first: 105,
                    second: 175
                },
                Opening {
                    first: 0,
                    second: 45
                }
            ]
        );
        v.hist = vec![0.0; 72];
        assert!(v.openings().is_none(), "forward half clear");
    }

    #[test]
    fn wide_openings_offer_their_borders_and_the_goal() {
        let mut v = Vfh::new(defaults(), 250.0, 0.0);
        v.desired_angle = 100.0;
        let c = v.candidates(&[
            Opening {
                first: 20,
                second: 170,
            },
            Opening {
                first: 0,
                second: 5,
            },
            Opening {
                first: 0,
                second: 45,
            },
        ]);
        let angles: Vec<f32> = c.iter().map(|c| c.angle).collect();
        assert_eq!(angles, [95.0, 60.0, 130.0, 100.0, 22.5]);
    }

    #[test]
    fn candidates_are_weighed_against_goal_and_last_direction() {
        let mut v = Vfh::new(defaults(), 250.0, 0.0);
        v.desired_angle = 90.0;
        v.last_picked_angle = 90.0;
        // Two narrow openings, centred at 60 and 130: 60 is closer to both.
        v.hist = (0..72)
            .map(|i| {
                if (10..=13).contains(&i) || (24..=28).contains(&i) {
                    0.0
                } else {
                    1.0
                }
            })
            .collect();
        v.select_direction();
        assert_eq!(v.picked_angle(), 57.5);
        // Having just picked far left, the left one wins with a strong current-direction weight.
        v.p.weight_current_dir = 20.0;
        v.last_picked_angle = 150.0;
        v.select_direction();
        assert_eq!(v.picked_angle(), 130.0);
    }

    #[test]
    fn a_goal_inside_the_turning_circle_slows_down() {
        let mut v = Vfh::new(defaults(), 250.0, 0.0);
        let m = run(&mut v, &open(), 90.0, 20);
        assert_eq!(m.speed, 200);
        // A goal 0.5 m to the right: inside the right blocked circle (286 + 250 + 100 mm).
        let m = v.update(&open(), 200, 0.0, 500.0, 100.0, 2.1);
        assert_eq!(m.speed, 180, "decelerates by 0.1 s of max_acceleration");
        assert_eq!(m.turnrate, -40);
    }

    #[test]
    fn speed_dependent_safety_uses_several_tables() {
        let mut p = defaults();
        p.safety_dist_1ms = 500.0;
        let v = Vfh::new(p, 250.0, 0.0);
        assert_eq!(v.window.sectors.len(), SPEED_TABLES);
        assert_eq!(v.speed_index(0), 0);
        assert_eq!(v.speed_index(200), SPEED_TABLES - 1);
        assert_eq!(v.speed_index(100), 10);
        // A faster table widens obstacles more.
        let cell = 20 * 61 + 30; // 1 m ahead
        assert!(v.window.sectors[19][cell].len() > v.window.sectors[0][cell].len());
    }
}
