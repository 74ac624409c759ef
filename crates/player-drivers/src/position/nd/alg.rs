//! The Nearness Diagram algorithm (Minguez & Montano, IEEE T-RA 2004, with the situation
//! split of Minguez, Osuna & Montano, ICRA 2004) as Player 3.0.2 runs it for a rectangular,
//! differential-drive robot.
//!
//! The space around the robot is cut into [`SECTORS`] angular sectors; each keeps its
//! nearest obstacle point. Jumps between neighbouring sectors (an empty sector next to an
//! occupied one, or a range jump wider than the robot) are discontinuities; the sectors
//! between two of them form a region ("valley"). The region nearest the goal that the robot
//! can pass through is chosen, then the situation decides the heading:
//!
//! * no obstacle within the security distance: `HSGR` (goal inside the region: head for
//!   it), `HSWR` (wide region: skirt its discontinuity), `HSNR` (narrow: its middle);
//! * obstacles on one side: `LSG` (goal region) or `LS1`, the heading pushed away from the
//!   nearest obstacle in proportion to how close it is;
//! * obstacles on both sides: `LS2`, balanced between them.
//!
//! Sector 0 points backwards and numbers grow clockwise, so sector `SECTORS / 2` is straight
//! ahead (upstream's convention, which its geometry tables depend on).
//!
//! Everything here is a pure function of plain data; the driver keeps the state.

use std::f64::consts::PI;

use pose::angle::normalize_atan2 as normalize;

/// Number of sectors of the nearness diagram (a multiple of 4).
pub const SECTORS: usize = 180;

/// Range added to a discontinuity whose far side is empty, so the intermediate goal lies
/// "at infinity" in that direction.
const INFINITE_DISTANCE: f64 = 1e6;

/// The robot and tuning the algorithm is built for (upstream's `TParametersND`, rectangular
/// and non-holonomic, which is all the Player driver uses).
#[derive(Clone, Debug, PartialEq)]
pub struct NdParams {
    /// Distance from the rotation centre to the front (m).
    pub front: f64,
    /// Distance from the rotation centre to the back (m).
    pub back: f64,
    /// Distance from the rotation centre to either side (m); the robot is symmetric.
    pub left: f64,
    /// Largest forward speed (m/s).
    pub vlmax: f64,
    /// Largest turn rate (rad/s).
    pub vamax: f64,
    /// Linear acceleration (m/s²), for the motion generator.
    pub almax: f64,
    /// Angular acceleration (rad/s²), for the motion generator.
    pub aamax: f64,
    /// Security distance at the front: obstacles nearer than this are avoided (m).
    pub dsmax: f64,
    /// Security distance at the back (m).
    pub dsmin: f64,
    /// Margin around the robot under which a sharp turn or a cut is forced (m).
    pub enlarge: f64,
    /// Smallest gap the robot fits through (m).
    pub discontinuity: f64,
    /// Control period (s).
    pub period: f64,
}

/// The robot tables derived once from [`NdParams`] (upstream's `InicializarND`).
#[derive(Clone, Debug)]
pub struct Robot {
    /// back (negative x), left, front, right (negative y) extents.
    dims: [f64; 4],
    enlarge: f64,
    /// Distance from the centre to the robot's outline along each sector's bisector.
    e: [f64; SECTORS],
    /// Security distance beyond the outline, per sector.
    ds: [f64; SECTORS],
    vlmax: f64,
    vamax: f64,
    almax: f64,
    aamax: f64,
    discontinuity: f64,
    period: f64,
}

/// The centre direction (rad) of a sector.
pub fn sector_to_angle(sector: usize) -> f64 {
    -(2.0 * PI / SECTORS as f64) * (sector as f64 - (SECTORS / 2) as f64)
}

/// The sector holding a direction (rad, in [-pi, pi]).
pub fn angle_to_sector(angle: f64) -> usize {
    let s = (-(SECTORS as f64) / (2.0 * PI) * angle + (SECTORS as f64 + 1.0) / 2.0) as i64;
    s.rem_euclid(SECTORS as i64) as usize
}

fn inc(s: usize) -> usize {
    (s + 1) % SECTORS
}

fn dec(s: usize) -> usize {
    (s + SECTORS - 1) % SECTORS
}

/// Sectors from `s1` forward (clockwise) to `s2`.
fn sector_distance(s1: usize, s2: usize) -> usize {
    if s1 <= s2 {
        s2 - s1
    } else {
        (s2 + SECTORS - s1) % SECTORS
    }
}

/// The bisector of the smaller angle between two directions.
fn unoriented_bisector(a: f64, b: f64) -> f64 {
    let mid = (a + b) / 2.0;
    if (a - b).abs() <= PI {
        mid
    } else {
        normalize(mid + PI)
    }
}

fn polar(x: f64, y: f64) -> Polar {
    Polar {
        r: x.hypot(y),
        a: y.atan2(x),
    }
}

/// A point in polar form: range `r` (m) and bearing `a` (rad).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Polar {
    /// Range; negative marks an empty sector.
    pub r: f64,
    /// Bearing.
    pub a: f64,
}

impl Robot {
    /// The tables for a robot (upstream's `InicializarE` and `InicializarDS`).
    pub fn new(p: &NdParams) -> Robot {
        let dims = [-p.back, p.left, p.front, -p.left];
        let e = outline_distances(dims);
        let ds = security_distances(dims, &e, p.dsmax, p.dsmin);
        Robot {
            dims,
            enlarge: p.enlarge,
            e,
            ds,
            vlmax: p.vlmax,
            vamax: p.vamax,
            almax: p.almax,
            aamax: p.aamax,
            discontinuity: p.discontinuity,
            period: p.period,
        }
    }

    /// Distance from the centre to the outline in `sector`.
    pub fn outline(&self, sector: usize) -> f64 {
        self.e[sector]
    }

    /// Security distance beyond the outline in `sector`.
    pub fn security(&self, sector: usize) -> f64 {
        self.ds[sector]
    }
}

/// First sector whose bisector lies at or clockwise of `angle`.
fn first_sector_after(angle: f64) -> usize {
    let s = angle_to_sector(angle);
    if sector_to_angle(s) > angle { s + 1 } else { s }
}

fn outline_distances(dims: [f64; 4]) -> [f64; SECTORS] {
    let mut e = [0.0; SECTORS];
    let back_corner = dims[1].atan2(dims[0]);
    let li = first_sector_after(back_corner);
    let front_corner = polar(dims[2], dims[1]);
    let ld = first_sector_after(front_corner.a);
    e[0] = -dims[0];
    for (i, ei) in e.iter_mut().enumerate().take(li).skip(1) {
        *ei = dims[0] / sector_to_angle(i).cos();
    }
    for (i, ei) in e.iter_mut().enumerate().take(ld).skip(li) {
        *ei = dims[1] / sector_to_angle(i).sin();
    }
    // Upstream takes the corner's range for the whole front arc.
    for ei in e.iter_mut().take(SECTORS / 2 + 1).skip(ld) {
        *ei = front_corner.r;
    }
    for i in SECTORS / 2 + 1..SECTORS {
        e[i] = e[SECTORS - i];
    }
    e
}

fn security_distances(
    dims: [f64; 4],
    e: &[f64; SECTORS],
    dsmax: f64,
    dsmin: f64,
) -> [f64; SECTORS] {
    let mut ds = [0.0; SECTORS];
    let p1 = (dims[0], dims[1]);
    let p2 = (dims[2], dims[1]);
    let b = dsmax - dsmin;
    let c = p2.0 - p1.0;
    let a = (c * c - b * b).sqrt();
    let (cos, sin) = (a / c, b / c);
    let q1 = (p1.0 - dsmin, p1.1);
    let q2 = (p1.0 - dsmin * sin, p1.1 + dsmin * cos);
    let q3 = (p2.0 - dsmax * sin, p2.1 + dsmax * cos);
    let mut q4 = polar(p2.0, p2.1);
    q4.r += dsmax;
    let lim1 = q1.1.atan2(q1.0);
    let lim2 = q2.1.atan2(q2.0);
    let lim3 = q3.1.atan2(q3.0);
    let lim4 = q4.a;
    ds[0] = -q1.0 - e[0];
    let m = p1.0 * p1.0 + p1.1 * p1.1 - dsmin * dsmin;
    let n = p2.0 * p2.0 + p2.1 * p2.1 - dsmax * dsmax;
    let lb = q3.0 - q2.0;
    let lc = q3.1 - q2.1;
    let la = lb * q2.1 - lc * q2.0;
    for i in 1..SECTORS / 2 {
        let ang = sector_to_angle(i);
        let d = if ang >= lim1 {
            q1.0 / ang.cos()
        } else if ang >= lim2 {
            let t = p1.0 * ang.cos() + p1.1 * ang.sin();
            t + (t * t - m).sqrt()
        } else if ang >= lim3 {
            la / (lb * ang.sin() - lc * ang.cos())
        } else if ang >= lim4 {
            let t = p2.0 * ang.cos() + p2.1 * ang.sin();
            t + (t * t - n).sqrt()
        } else {
            q4.r
        };
        ds[i] = d - e[i];
        ds[SECTORS - i] = ds[i];
    }
    ds[SECTORS / 2] = q4.r - e[SECTORS / 2];
    ds
}

/// The robot's pose in the frame the obstacle points are given in.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pose {
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// Heading (rad).
    pub a: f64,
}

impl Pose {
    /// A point of the outer frame in the robot's frame.
    fn to_robot(self, (x, y): (f64, f64)) -> (f64, f64) {
        let (dx, dy) = (x - self.x, y - self.y);
        let (s, c) = self.a.sin_cos();
        (dx * c + dy * s, -dx * s + dy * c)
    }
}

/// The nearest obstacle of every sector, in the robot's frame (upstream's
/// `SectorizarMapa`). Empty sectors have `r < 0`; an obstacle inside the outline is pushed
/// just outside it (except straight ahead, where the emergency check looks).
pub fn sectorize(robot: &Robot, pose: Pose, points: &[(f64, f64)]) -> [Polar; SECTORS] {
    let mut d = [Polar { r: -1.0, a: 0.0 }; SECTORS];
    for &p in points {
        let (x, y) = pose.to_robot(p);
        let pp = Polar {
            r: x * x + y * y,
            a: y.atan2(x),
        };
        let j = angle_to_sector(pp.a);
        if d[j].r < 0.0 || pp.r < d[j].r {
            d[j] = pp;
        }
    }
    for (i, s) in d.iter_mut().enumerate() {
        if s.r >= 0.0 {
            s.r = s.r.sqrt();
            if i != SECTORS / 2 && s.r < robot.e[i] + 0.01 {
                s.r = robot.e[i] + 0.01;
            }
        }
    }
    d
}

/// Whether an obstacle sits in front of the robot within its front corners' reach
/// (upstream's `ParadaEmergencia`).
pub fn emergency_stop(robot: &Robot, d: &[Polar; SECTORS]) -> bool {
    let corner = polar(robot.dims[2], robot.dims[1]);
    (angle_to_sector(corner.a)..=angle_to_sector(-corner.a))
        .any(|i| d[i].r >= 0.0 && d[i].r <= corner.r && d[i].a.abs() <= corner.a)
}

/// How a region is to be entered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Direction {
    /// Straight at the goal.
    #[default]
    Goal,
    /// At the discontinuity where the region starts (its counter-clockwise end).
    StartDiscontinuity,
    /// At the discontinuity where the region ends (its clockwise end).
    EndDiscontinuity,
}

/// A run of sectors between two discontinuities (a "valley").
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Region {
    /// First sector (counter-clockwise end).
    pub start: usize,
    /// Last sector (clockwise end).
    pub end: usize,
    /// Whether the region is the deep side (farther, or empty) of its start discontinuity:
    /// such an edge is a way into open space.
    pub start_rising: bool,
    /// Whether the region is the deep side of its end discontinuity.
    pub end_rising: bool,
    /// Tried and found impassable.
    pub discarded: bool,
    /// How the region is entered.
    pub direction: Direction,
    /// The sector of that direction.
    pub direction_sector: usize,
    /// The direction (rad, robot frame).
    pub direction_angle: f64,
}

/// The goal in the robot's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Goal {
    /// Polar position.
    pub p: Polar,
    /// Its sector.
    pub sector: usize,
}

/// The next discontinuity from `from` going counter-clockwise (`left`) or clockwise:
/// the last sector before the jump, and whether that side is the deep one (farther or
/// empty; upstream's "ascending", `SiguienteDiscontinuidad`). `None` when there is none all the way round.
pub fn next_discontinuity(
    robot: &Robot,
    d: &[Polar; SECTORS],
    from: usize,
    left: bool,
) -> Option<(usize, bool)> {
    let mut j = from;
    let mut dj = d[j].r;
    // Upstream tests the starting sector with `< 0` and every later one with `<= 0`.
    let mut free_j = dj < 0.0;
    loop {
        let (i, di, free_i) = (j, dj, free_j);
        j = if left { dec(i) } else { inc(i) };
        dj = d[j].r;
        free_j = dj <= 0.0;
        if !(free_i && free_j) {
            if free_i || free_j {
                return Some((i, free_i));
            }
            if (di - dj).abs() >= robot.discontinuity {
                return Some((i, di > dj));
            }
        }
        if j == from {
            return None;
        }
    }
}

/// Whether the robot can reach the region's direction (the goal or the middle of a
/// discontinuity) without passing a gap narrower than itself; sets the region's direction
/// on the way (upstream's `ObjetivoAlcanzable`).
fn reachable(
    robot: &Robot,
    d: &[Polar; SECTORS],
    goal: &Goal,
    region: &mut Region,
    direction: Direction,
) -> bool {
    region.direction = direction;
    let target = match direction {
        Direction::Goal => {
            region.direction_sector = goal.sector;
            goal.p
        }
        Direction::StartDiscontinuity | Direction::EndDiscontinuity => {
            let (s, aux) = if direction == Direction::StartDiscontinuity {
                (region.start, dec(region.start))
            } else {
                (region.end, inc(region.end))
            };
            region.direction_sector = s;
            if d[s].r < 0.0 {
                Polar {
                    r: d[aux].r + INFINITE_DISTANCE,
                    a: unoriented_bisector(sector_to_angle(s), d[aux].a),
                }
            } else {
                let (x1, y1) = (d[s].r * d[s].a.cos(), d[s].r * d[s].a.sin());
                let (x2, y2) = (d[aux].r * d[aux].a.cos(), d[aux].r * d[aux].a.sin());
                polar((x1 + x2) / 2.0, (y1 + y2) / 2.0)
            }
        }
    };
    region.direction_angle = target.a;
    let tx = target.r;
    let half = (robot.discontinuity / 2.0).powi(2);
    let mut left = Vec::new();
    let mut right = Vec::new();
    for s in d.iter().filter(|s| s.r >= 0.0) {
        let a = s.a - region.direction_angle;
        let (x, y) = (s.r * a.cos(), s.r * a.sin());
        if x < 0.0 || x >= tx || y.abs() > robot.discontinuity {
            continue;
        }
        if (x - tx).powi(2) + y * y < half {
            return false;
        }
        if y > 0.0 {
            left.push((x, y));
        } else {
            right.push((x, y));
        }
    }
    let width = robot.discontinuity * robot.discontinuity;
    !left.iter().any(|l| {
        right
            .iter()
            .any(|r| (l.0 - r.0).powi(2) + (l.1 - r.1).powi(2) < width)
    })
}

/// Every region examined and the chosen one's index (upstream's `SeleccionarRegion`).
#[derive(Clone, Debug, Default)]
pub struct Regions {
    /// Regions in the order they were examined.
    pub list: Vec<Region>,
    /// The chosen one, if any is passable.
    pub chosen: Option<usize>,
}

/// Makes slot `i` exist (upstream's fixed array has room for it).
fn slot(slots: &mut Vec<Region>, i: usize) {
    if slots.len() <= i {
        slots.resize(i + 1, Region::default());
    }
}

/// When both sides of the search agree on a region, the duplicate is dropped and the one
/// earlier in the list kept (upstream's bookkeeping at each success); returns the region
/// chosen.
fn settle(slots: &mut [Region], len: &mut usize, won: usize, other: usize) -> usize {
    let o = slots[other];
    if o.start_rising || o.end_rising {
        return won;
    }
    if other > won {
        *len -= 1;
        return won;
    }
    slots[other] = slots[won];
    *len -= 1;
    other
}

/// A side of the alternating region search: `Left` walks counter-clockwise from the goal
/// (its regions' near edge is their start), `Right` clockwise (their end). Upstream writes
/// the two searches out mirrored; one [`search_side`] with this parameter is both.
#[derive(Clone, Copy)]
enum Side {
    Left,
    Right,
}

impl Side {
    /// The edge the search moves on: (sector, rising).
    fn edge(self, r: &Region) -> (usize, bool) {
        match self {
            Side::Left => (r.start, r.start_rising),
            Side::Right => (r.end, r.end_rising),
        }
    }

    fn set_edge(self, r: &mut Region, (s, rising): (usize, bool)) {
        match self {
            Side::Left => (r.start, r.start_rising) = (s, rising),
            Side::Right => (r.end, r.end_rising) = (s, rising),
        }
    }

    /// Sets the edge facing the goal: one sector beyond the previous region's `edge`, on the
    /// other side of its discontinuity.
    fn set_back_edge(self, r: &mut Region, (s, rising): (usize, bool)) {
        match self {
            Side::Left => (r.end, r.end_rising) = (dec(s), !rising),
            Side::Right => (r.start, r.start_rising) = (inc(s), !rising),
        }
    }

    /// The region's discontinuity on this side, and on the other.
    fn directions(self) -> (Direction, Direction) {
        match self {
            Side::Left => (Direction::StartDiscontinuity, Direction::EndDiscontinuity),
            Side::Right => (Direction::EndDiscontinuity, Direction::StartDiscontinuity),
        }
    }

    /// Finds the next discontinuity from `r`'s back edge and makes it `r`'s edge.
    fn extend(self, robot: &Robot, d: &[Polar; SECTORS], r: &mut Region) {
        let (from, left) = match self {
            Side::Left => (r.end, true),
            Side::Right => (r.start, false),
        };
        let found = next_discontinuity(robot, d, from, left).unwrap_or((0, false));
        self.set_edge(r, found);
    }
}

/// One step of the region search on `side`: the region `cur` is tried through its edge (when
/// rising) or the search moves past it to the next one and tries that through its back edge.
/// `other` is the other side's current region. The chosen region's index when one is reachable.
#[allow(clippy::too_many_arguments)]
fn search_side(
    side: Side,
    robot: &Robot,
    d: &[Polar; SECTORS],
    goal: &Goal,
    slots: &mut Vec<Region>,
    len: &mut usize,
    cur: &mut usize,
    other: usize,
) -> Option<usize> {
    let (near, far) = side.directions();
    let new_slot = |slots: &mut Vec<Region>, len: &mut usize, cur: &mut usize| {
        let prev = slots[*cur];
        *cur = *len;
        *len += 1;
        slot(slots, *cur);
        slots[*cur] = Region::default();
        side.set_back_edge(&mut slots[*cur], side.edge(&prev));
    };
    if side.edge(&slots[*cur]).1 {
        if reachable(robot, d, goal, &mut slots[*cur], near) {
            return Some(settle(slots, len, *cur, other));
        }
        if *cur != other {
            slots[*cur].discarded = true;
        }
        new_slot(slots, len, cur);
        side.extend(robot, d, &mut slots[*cur]);
    } else {
        if *cur != other {
            let r = &mut slots[*cur];
            side.set_back_edge(r, side.edge(r));
        } else {
            new_slot(slots, len, cur);
        }
        side.extend(robot, d, &mut slots[*cur]);
        if reachable(robot, d, goal, &mut slots[*cur], far) {
            return Some(settle(slots, len, *cur, other));
        }
    }
    None
}

/// Chooses the region to move through: the goal's own if it is in sight and reachable,
/// else the nearest passable one, searching to both sides alternately.
pub fn select_region(robot: &Robot, d: &[Polar; SECTORS], goal: &Goal) -> Regions {
    let in_sight = d[goal.sector].r < 0.0 || goal.p.r <= d[goal.sector].r;
    // Upstream keeps a fixed array with a length and sometimes uses the slot just past it;
    // `slots` is that array, `len` its length.
    let mut slots: Vec<Region> = vec![Region::default(); 2];
    let mut len = 1usize;
    let finish = |slots: Vec<Region>, len: usize, chosen: Option<usize>| {
        let mut list = slots;
        list.truncate(len);
        Regions { list, chosen }
    };
    let mut idx = 0usize;
    let Some((start, start_rising)) = next_discontinuity(robot, d, goal.sector, true) else {
        let r = &mut slots[0];
        r.start = 0;
        r.end = SECTORS - 1;
        if in_sight {
            r.direction = Direction::Goal;
            r.direction_sector = goal.sector;
            r.direction_angle = goal.p.a;
            return finish(slots, len, Some(0));
        }
        r.discarded = true;
        return finish(slots, len, None);
    };
    slots[0].start = start;
    slots[0].start_rising = start_rising;
    // A discontinuity exists, so the clockwise search finds one too.
    let (end, end_rising) =
        next_discontinuity(robot, d, goal.sector, false).unwrap_or((start, false));
    slots[0].end = end;
    slots[0].end_rising = end_rising;
    if end == dec(start) {
        // A single discontinuity.
        if in_sight {
            let r = &mut slots[0];
            r.direction = Direction::Goal;
            r.direction_sector = goal.sector;
            r.direction_angle = goal.p.a;
            return finish(slots, len, Some(0));
        }
        // Upstream tests the address of the flag, which is always true: the start is taken.
        if reachable(robot, d, goal, &mut slots[0], Direction::StartDiscontinuity) {
            return finish(slots, len, Some(0));
        }
        slots[0].discarded = true;
        return finish(slots, len, None);
    }
    if in_sight {
        if !slots[idx].start_rising && !slots[idx].end_rising {
            // An artificial region round the goal alone; the natural one is kept aside.
            let aux = len;
            slot(&mut slots, aux);
            slots[aux] = slots[idx];
            slots[idx].start = goal.sector;
            slots[idx].end = goal.sector;
            if reachable(robot, d, goal, &mut slots[idx], Direction::Goal) {
                return finish(slots, len, Some(idx));
            }
            len += 1;
            idx = aux;
        } else if reachable(robot, d, goal, &mut slots[idx], Direction::Goal) {
            return finish(slots, len, Some(idx));
        }
    }
    let (mut il, mut ir) = (idx, idx);
    loop {
        let dl = sector_distance(slots[il].start, goal.sector);
        let dr = sector_distance(goal.sector, slots[ir].end);
        let found = if dl <= dr {
            search_side(
                Side::Left,
                robot,
                d,
                goal,
                &mut slots,
                &mut len,
                &mut il,
                ir,
            )
        } else {
            search_side(
                Side::Right,
                robot,
                d,
                goal,
                &mut slots,
                &mut len,
                &mut ir,
                il,
            )
        };
        if let Some(c) = found {
            return finish(slots, len, Some(c));
        }
        if dl >= SECTORS / 2 && dr >= SECTORS / 2 {
            break;
        }
        // Guard against a list longer than upstream's array could hold.
        if len > 2 * SECTORS {
            break;
        }
    }
    len -= 1;
    if len > 0 {
        slots[len - 1].discarded = true;
    }
    finish(slots, len, None)
}

/// The situation ND classified the robot in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Situation {
    /// High safety, goal in the region.
    Hsgr,
    /// High safety, wide region.
    Hswr,
    /// High safety, narrow region.
    Hsnr,
    /// Low safety, obstacles on one side, goal in the region.
    Lsg,
    /// Low safety, obstacles on one side.
    Ls1,
    /// Low safety, obstacles on both sides.
    Ls2,
}

/// The nearest obstacles within the security distance on either side of `beta`, by their
/// distance over the security distance (upstream's `ObtenerObstaculos`).
fn nearest_obstacles(
    robot: &Robot,
    d: &[Polar; SECTORS],
    dr: &[f64; SECTORS],
    beta: f64,
) -> (Option<usize>, Option<usize>) {
    let mut left: Option<(usize, f64)> = None;
    let mut right: Option<(usize, f64)> = None;
    for i in 0..SECTORS {
        if dr[i] >= 0.0 && dr[i] <= robot.ds[i] {
            let v = dr[i] / robot.ds[i];
            let side = if d[i].a >= beta {
                &mut left
            } else {
                &mut right
            };
            if side.is_none_or(|(_, m)| v < m) {
                *side = Some((i, v));
            }
        }
    }
    (left.map(|l| l.0), right.map(|r| r.0))
}

/// The heading of the skirt round a region's discontinuity (`HSWR`, and `LS1`'s wide case).
fn skirt(robot: &Robot, d: &[Polar; SECTORS], region: &Region) -> f64 {
    let clearance = robot.discontinuity / 2.0 + robot.ds[SECTORS / 2];
    if region.direction == Direction::StartDiscontinuity {
        let s = d[dec(region.start)];
        s.a - clearance.atan2(s.r)
    } else {
        let s = d[inc(region.end)];
        s.a + clearance.atan2(s.r)
    }
}

fn region_middle(region: &Region) -> f64 {
    let end = if region.start > region.end {
        region.end + SECTORS
    } else {
        region.end
    };
    sector_to_angle(((region.start + end) / 2) % SECTORS)
}

fn region_width(region: &Region) -> usize {
    let end = if region.start > region.end {
        region.end + SECTORS
    } else {
        region.end
    };
    end - region.start
}

/// The heading pushed away from the single near obstacle (`LS1`, `LSG`).
fn away_from_one(
    robot: &Robot,
    d: &[Polar; SECTORS],
    dr: &[f64; SECTORS],
    partial: f64,
    obstacle: usize,
) -> f64 {
    let bound = normalize(d[obstacle].a + PI - partial) + partial;
    let ratio = dr[obstacle] / robot.ds[obstacle];
    let mut a = partial * ratio + bound * (1.0 - ratio);
    if a > PI {
        a = PI - 0.01;
    } else if a < -PI {
        a = -(PI + 0.01);
    }
    normalize(a)
}

/// The motion direction (rad, robot frame, clamped to ±pi/2) and the situation
/// (upstream's `control_angulo`), with the nearest left and right obstacles.
pub fn motion_angle(
    robot: &Robot,
    d: &[Polar; SECTORS],
    dr: &[f64; SECTORS],
    region: &Region,
) -> (f64, Situation, Option<usize>, Option<usize>) {
    let (left, right) = nearest_obstacles(robot, d, dr, region.direction_angle);
    let wide = region_width(region) > SECTORS / 4;
    let (angle, situation) = match (left, right) {
        (None, None) => {
            if region.direction == Direction::Goal {
                (region.direction_angle, Situation::Hsgr)
            } else if wide {
                (skirt(robot, d, region), Situation::Hswr)
            } else {
                (region_middle(region), Situation::Hsnr)
            }
        }
        (Some(l), Some(r)) => {
            let ci = dr[l] / robot.ds[l];
            let cd = dr[r] / robot.ds[r];
            let partial = region.direction_angle;
            let a = if ci <= cd {
                partial + (ci - cd) / (ci + cd) * (partial + PI / 2.0)
            } else {
                partial + (ci - cd) / (ci + cd) * (PI / 2.0 - partial)
            };
            (normalize(a), Situation::Ls2)
        }
        (one_l, one_r) => {
            let o = one_l.or(one_r).unwrap_or(0);
            if region.direction == Direction::Goal {
                (
                    away_from_one(robot, d, dr, region.direction_angle, o),
                    Situation::Lsg,
                )
            } else {
                let partial = if wide {
                    skirt(robot, d, region)
                } else {
                    region_middle(region)
                };
                (away_from_one(robot, d, dr, partial, o), Situation::Ls1)
            }
        }
    };
    (angle.clamp(-PI / 2.0, PI / 2.0), situation, left, right)
}

/// Velocities: forward (m/s) and turn rate (rad/s).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Velocities {
    /// Forward speed.
    pub v: f64,
    /// Turn rate.
    pub w: f64,
}

/// Which sides of the robot's rear half an obstacle is about to touch.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Cut {
    None,
    Left,
    Right,
    Both,
}

fn cut_situation(robot: &Robot, d: &[Polar; SECTORS], dr: &[f64; SECTORS]) -> Cut {
    let mut result = Cut::None;
    let (mut seen_left, mut seen_right) = (false, false);
    let rear = (0..=SECTORS / 4).chain(3 * SECTORS / 4..SECTORS);
    for i in rear {
        if (d[i].a < -PI / 2.0 || d[i].a > PI / 2.0)
            && d[i].r >= 0.0
            && dr[i] <= robot.enlarge / 2.0
        {
            let (x, y) = (d[i].r * d[i].a.cos(), d[i].r * d[i].a.sin());
            if y >= robot.dims[1] {
                if seen_right {
                    return Cut::Both;
                }
                seen_left = true;
                result = Cut::Left;
            } else if y <= robot.dims[3] {
                if seen_left {
                    return Cut::Both;
                }
                seen_right = true;
                result = Cut::Right;
            } else if x <= robot.dims[0] {
                return Cut::Both;
            }
        }
    }
    result
}

/// Why ND stopped the robot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Halt {
    /// An obstacle right in front.
    Emergency,
    /// No region the robot fits through leads towards the goal.
    NoRegion,
}

/// One ND step's result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step {
    /// The command; zero when the goal is within tolerance.
    pub cmd: Velocities,
    /// The situation, `None` at the goal.
    pub situation: Option<Situation>,
}

/// One ND step (upstream's `IterarND`): the command that moves the robot at `pose` towards
/// `goal` among `points` (both in the same outer frame). `current` is the robot's velocity,
/// used only when a rear cut forces the motion generator's braking.
pub fn iterate(
    robot: &Robot,
    goal: (f64, f64),
    goal_tol: f64,
    pose: Pose,
    current: Velocities,
    points: &[(f64, f64)],
) -> Result<Step, Halt> {
    let (gx, gy) = pose.to_robot(goal);
    let gp = polar(gx, gy);
    let goal_r = Goal {
        p: gp,
        sector: angle_to_sector(gp.a),
    };
    let d = sectorize(robot, pose, points);
    if emergency_stop(robot, &d) {
        return Err(Halt::Emergency);
    }
    let regions = select_region(robot, &d, &goal_r);
    let Some(&region) = regions.chosen.and_then(|c| regions.list.get(c)) else {
        return Err(Halt::NoRegion);
    };
    let mut dr = [0.0; SECTORS];
    for i in 0..SECTORS {
        dr[i] = if d[i].r < 0.0 {
            -1.0
        } else {
            d[i].r - robot.e[i]
        };
    }
    // Upstream replaced its "goal inside the outline" test by the user's tolerance.
    if (goal.0 - pose.x).hypot(goal.1 - pose.y) < goal_tol {
        return Ok(Step {
            cmd: Velocities::default(),
            situation: None,
        });
    }
    let (angle, situation, left, right) = motion_angle(robot, &d, &dr, &region);
    let coef = |o: Option<usize>| o.map_or(1.0, |i| dr[i] / robot.ds[i]);
    let (ci, cd) = (coef(left), coef(right));
    // Upstream computes a speed from the clearance, then overrides it with the maximum.
    let speed = robot.vlmax;
    let cvmax = ci.min(cd).max(0.2);
    let mut cmd = Velocities {
        v: (robot.vlmax * cvmax * angle.cos()).clamp(0.0, robot.vlmax),
        w: (robot.vamax * cvmax * angle.sin()).clamp(-robot.vamax, robot.vamax),
    };
    // Sharp turn: an obstacle at a front corner on one side stops forward motion, on both
    // sides stops the turn.
    let corner = polar(robot.dims[2], robot.dims[1]);
    let at_corner = |o: Option<usize>| {
        o.is_some_and(|i| d[i].a.abs() <= corner.a && d[i].r <= corner.r + robot.enlarge)
    };
    let (at_r, at_l) = (at_corner(right), at_corner(left));
    if at_r && at_l {
        cmd.w = 0.0;
    } else if at_r || at_l {
        cmd.v = 0.0;
    }
    // Cutting: an obstacle grazing the rear on the side the turn swings it towards.
    let cut = cut_situation(robot, &d, &dr);
    let brake = match cut {
        Cut::None => false,
        Cut::Left => cmd.w < 0.0,
        Cut::Right => cmd.w > 0.0,
        Cut::Both => true,
    };
    if brake {
        let dw = robot.aamax * robot.period;
        if dw < current.w.abs() {
            cmd.w = if current.w > 0.0 {
                current.w - dw
            } else {
                current.w + dw
            };
            let dv = robot.almax * robot.period;
            cmd.v = if dv < current.v { current.v - dv } else { 0.0 };
        } else {
            cmd.v = speed;
            cmd.w = 0.0;
        }
    }
    cmd.v = cmd.v.clamp(0.0, robot.vlmax);
    cmd.w = cmd.w.clamp(-robot.vamax, robot.vamax);
    Ok(Step {
        cmd,
        situation: Some(situation),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A Pioneer-sized robot with the driver's defaults.
    fn params() -> NdParams {
        NdParams {
            front: 0.22,
            back: 0.22,
            left: 0.19,
            vlmax: 0.3,
            vamax: 45f64.to_radians(),
            almax: 0.75,
            aamax: 0.75,
            dsmax: 0.5,
            dsmin: 0.125,
            enlarge: 0.025,
            discontinuity: 0.38,
            period: 0.1,
        }
    }

    /// A laser's points: `range(bearing)` over 181 beams from -90° to 90°, robot at origin.
    fn scan(range: impl Fn(f64) -> Option<f64>) -> Vec<(f64, f64)> {
        (0..=180)
            .filter_map(|i| {
                let b = (i as f64 - 90.0).to_radians();
                range(b).map(|r| (r * b.cos(), r * b.sin()))
            })
            .collect()
    }

    /// Points along the segment from `a` to `b`, every 2 cm.
    fn wall(a: (f64, f64), b: (f64, f64)) -> Vec<(f64, f64)> {
        let n = ((b.0 - a.0).hypot(b.1 - a.1) / 0.02) as usize;
        (0..=n)
            .map(|k| {
                let t = k as f64 / n as f64;
                (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1))
            })
            .collect()
    }

    /// One iteration for a robot at rest at the origin, facing +x: towards `goal`, reached
    /// within `goal_tol`, among `points`.
    fn from_rest(
        r: &Robot,
        goal: (f64, f64),
        goal_tol: f64,
        points: &[(f64, f64)],
    ) -> Result<Step, Halt> {
        iterate(
            r,
            goal,
            goal_tol,
            Pose::default(),
            Velocities::default(),
            points,
        )
    }

    #[test]
    fn sectors_run_clockwise_from_behind() {
        assert_eq!(angle_to_sector(0.0), SECTORS / 2);
        assert_eq!(angle_to_sector(PI), 0);
        assert_eq!(angle_to_sector(-PI), 0);
        assert_eq!(angle_to_sector(PI / 2.0), SECTORS / 4);
        assert_eq!(angle_to_sector(-PI / 2.0), 3 * SECTORS / 4);
        for s in 0..SECTORS {
            assert_eq!(
                angle_to_sector(normalize(sector_to_angle(s))),
                s,
                "sector {s}"
            );
        }
    }

    #[test]
    fn the_outline_is_the_rectangle_and_security_grows_to_the_front() {
        let r = Robot::new(&params());
        assert!((r.outline(0) - 0.22).abs() < 1e-9, "behind: the back");
        assert!(
            (r.outline(SECTORS / 4) - 0.19).abs() < 1e-3,
            "left: the side"
        );
        assert_eq!(
            r.outline(SECTORS / 4),
            r.outline(3 * SECTORS / 4),
            "symmetric"
        );
        let corner = 0.22f64.hypot(0.19);
        assert!((r.outline(SECTORS / 2) - corner).abs() < 1e-9);
        assert!((r.security(SECTORS / 2) - 0.5).abs() < 1e-9, "dsmax ahead");
        assert!((r.security(0) - 0.125).abs() < 1e-9, "dsmin behind");
        for s in 1..SECTORS / 2 {
            assert!(r.security(s) > 0.0);
            assert_eq!(r.security(s), r.security(SECTORS - s));
        }
    }

    #[test]
    fn open_space_heads_straight_for_the_goal() {
        let r = Robot::new(&params());
        let step = from_rest(&r, (3.0, 1.0), 0.5, &[]).unwrap();
        assert_eq!(step.situation, Some(Situation::Hsgr));
        assert!(step.cmd.v > 0.0 && step.cmd.w > 0.0, "{:?}", step.cmd);
        // Far walls, all outside the security zone: still high safety.
        let pts = scan(|_| Some(4.0));
        let step = from_rest(&r, (2.0, 0.0), 0.5, &pts).unwrap();
        assert_eq!(step.situation, Some(Situation::Hsgr));
        assert!((step.cmd.v - 0.3).abs() < 1e-9 && step.cmd.w.abs() < 1e-6);
    }

    #[test]
    fn within_tolerance_the_command_is_zero() {
        let r = Robot::new(&params());
        let pose = Pose {
            x: 1.0,
            y: 1.0,
            a: 0.3,
        };
        let step = iterate(&r, (1.2, 1.1), 0.5, pose, Velocities::default(), &[]).unwrap();
        assert_eq!(step.cmd, Velocities::default());
        assert_eq!(step.situation, None);
    }

    #[test]
    fn points_are_taken_in_the_robots_frame() {
        let r = Robot::new(&params());
        let pose = Pose {
            x: 2.0,
            y: -1.0,
            a: PI / 2.0,
        };
        // A point 1 m ahead of a robot facing +y.
        let d = sectorize(&r, pose, &[(2.0, 0.0)]);
        let s = &d[SECTORS / 2];
        assert!((s.r - 1.0).abs() < 1e-9 && s.a.abs() < 1e-9, "{s:?}");
        assert_eq!(d.iter().filter(|s| s.r >= 0.0).count(), 1);
    }

    #[test]
    fn an_obstacle_touching_the_front_is_an_emergency() {
        let r = Robot::new(&params());
        let pts = [(0.2, 0.0)];
        assert_eq!(from_rest(&r, (3.0, 0.0), 0.5, &pts), Err(Halt::Emergency));
    }

    #[test]
    fn a_wall_across_the_way_is_skirted_through_a_gap() {
        let r = Robot::new(&params());
        // A wall 1.5 m ahead from y = -3 to y = 0.5; the goal straight behind it; free space
        // past its left end.
        let pts = wall((1.5, -3.0), (1.5, 0.5));
        let goal = (4.0, 0.0);
        let d = sectorize(&r, Pose::default(), &pts);
        let g = polar(goal.0, goal.1);
        let goal_s = Goal {
            p: g,
            sector: angle_to_sector(g.a),
        };
        let regions = select_region(&r, &d, &goal_s);
        let chosen = regions.list[regions.chosen.expect("a region")];
        assert_ne!(chosen.direction, Direction::Goal, "the goal is hidden");
        assert!(chosen.direction_angle > 0.0, "to the left: {chosen:?}");
        let step = from_rest(&r, goal, 0.5, &pts).unwrap();
        assert!(step.cmd.w > 0.0, "turns left: {:?}", step.cmd);
        assert!(
            matches!(step.situation, Some(Situation::Hswr | Situation::Hsnr)),
            "{:?}",
            step.situation
        );
    }

    #[test]
    fn a_closed_ring_has_no_way_out() {
        let r = Robot::new(&params());
        let ring: Vec<(f64, f64)> = (0..360)
            .map(|k| {
                let a = (k as f64).to_radians();
                (1.0 * a.cos(), 1.0 * a.sin())
            })
            .collect();
        assert_eq!(from_rest(&r, (3.0, 0.0), 0.5, &ring), Err(Halt::NoRegion));
    }

    #[test]
    fn a_near_obstacle_on_one_side_pushes_the_heading_away() {
        let r = Robot::new(&params());
        // A wall along the right side, 0.35 m away, goal straight ahead.
        let pts = wall((-1.0, -0.35), (3.0, -0.35));
        let step = from_rest(&r, (3.0, 0.0), 0.3, &pts).unwrap();
        assert_eq!(step.situation, Some(Situation::Lsg));
        assert!(step.cmd.w > 0.0, "turns away to the left: {:?}", step.cmd);
        // Walls near both sides: LS2.
        let mut both = pts.clone();
        both.extend(wall((-1.0, 0.4), (3.0, 0.4)));
        let step = from_rest(&r, (3.0, 0.0), 0.3, &both).unwrap();
        assert_eq!(step.situation, Some(Situation::Ls2));
        // Closer to the right wall than the left: still edges left.
        assert!(step.cmd.w > 0.0, "{:?}", step.cmd);
    }

    #[test]
    fn discontinuities_are_range_jumps_wider_than_the_robot() {
        let r = Robot::new(&params());
        // Obstacles 2 m away ahead, 4 m on the left half: a jump at the front.
        let pts = scan(|b| Some(if b > 0.2 { 4.0 } else { 2.0 }));
        let d = sectorize(&r, Pose::default(), &pts);
        // Going left from straight ahead: the near side (this region) is the shallow one.
        let (s, rising) = next_discontinuity(&r, &d, SECTORS / 2, true).unwrap();
        assert!(!rising, "the region is nearer than past the jump");
        assert!(
            (sector_to_angle(s) - 0.2).abs() < 0.05,
            "at {}",
            sector_to_angle(s)
        );
        // Going right from the far part: the same jump, seen from the deep side.
        let (s, rising) = next_discontinuity(&r, &d, angle_to_sector(1.0), false).unwrap();
        assert!(rising);
        assert!(
            (sector_to_angle(s) - 0.2).abs() < 0.05,
            "at {}",
            sector_to_angle(s)
        );
        // Going right from straight ahead: the end of the scan, empty space behind.
        let (s, rising) = next_discontinuity(&r, &d, SECTORS / 2, false).unwrap();
        assert!(!rising);
        assert!(sector_to_angle(s) < -1.5, "at {}", sector_to_angle(s));
        assert_eq!(
            next_discontinuity(&r, &[Polar { r: -1.0, a: 0.0 }; SECTORS], 0, true),
            None
        );
    }
}
