//! The wavefront planner's grid algorithms (Player's `plan.c`, `plan_plan.c`,
//! `plan_waypoint.c`): configuration space from an occupancy grid, a wavefront (Dijkstra) from
//! the goal with a penalty near obstacles, the path that follows it, and the few waypoints a
//! robot can drive between in straight lines.
//!
//! Everything here is plain data and pure functions, so the driver can run it on a worker
//! thread and the tests can run it on hand-made grids.

use std::cmp::Ordering;

use super::cells::{CellStates, FloodView, NEIGHBOURS};
use super::queue::{WaveOrder, WaveQueue};

/// Cost of a cell the wavefront has not reached (upstream's `PLAN_MAX_COST`): a cell whose
/// cost would come to this or more is not reached.
const MAX_COST: f32 = 1e9;

/// Sight tests left in a waypoint search from which two threads share them (fewer cost
/// less than a thread's start).
const PARALLEL_SIGHT_TESTS: usize = 64;

/// How far along the path (in metres) a waypoint may always reach before straight-line
/// reachability is tested (upstream's fixed 0.5 m in `plan_update_waypoints`).
const WAYPOINT_FREE_RUN: f64 = 0.5;

/// The planner's tuning, as the driver derives it from its options and the robot's size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanParams {
    /// Cells nearer than this to an obstacle are impassable (robot radius + `safety_dist`).
    pub abs_min_radius: f64,
    /// Obstacles farther than this cost nothing extra (`max_radius`); also the reach of the
    /// c-space distance computation.
    pub max_radius: f64,
    /// Extra cost per metre of intrusion within `max_radius` of an obstacle (`dist_penalty`).
    pub dist_penalty: f64,
}

/// A map ready for planning: per cell the occupancy and the distance to the nearest obstacle
/// (capped at `max_radius`), the laser's obstacles on top of it, and what the last plans left
/// (upstream's `plan_t`: each cell's cost and next step towards the goal, the global path and
/// the local path's marks). Cell (i, j) is centred at `origin + (i, j) * scale`, as upstream's
/// `PLAN_WXGX`.
#[derive(Clone, Debug)]
pub struct Plan {
    size_x: usize,
    size_y: usize,
    origin: (f64, f64),
    scale: f64,
    params: PlanParams,
    /// Upstream's `occ_dist`: metres to the nearest occupied (or unknown) cell of the map.
    occ_dist: Vec<f32>,
    /// Upstream's `occ_dist_dyn`: the same with the laser's obstacles added; what planning
    /// uses.
    occ_dist_dyn: Vec<f32>,
    /// Distances of the cells around an obstacle out to `max_radius` (`dist_kernel`: (di, dj,
    /// metres, and the penalty class of that distance, `None` if it blocks the cell).
    kernel: Vec<(i64, i64, f32, Option<u8>)>,
    /// The region the last plan searched (`min_x, min_y, max_x, max_y`, inclusive).
    bounds: Bounds,
    /// What the plans know of each cell: reached, next step, blocked, obstacle penalty,
    /// on the local path (upstream's `plan_cell_t` but for the cost, packed).
    cells: CellStates,
    /// The last global plan's path, start first (`path`); empty when it failed.
    path: Vec<usize>,
    /// The cells of the last local plan's path, marked in `cells`: stepping onto them again is
    /// cheaper, so that successive local plans keep to one route.
    lpath: Vec<u32>,
    /// The wavefront's queue, kept between plans so that its buckets keep their room.
    queue: WaveQueue,
}

/// A grid cell index (column, row).
pub type Cell = (usize, usize);

/// An inclusive rectangle of cells: (min_x, min_y, max_x, max_y).
type Bounds = (usize, usize, usize, usize);

/// How much cheaper a step onto the last local path is (the `hysteresis_factor` the driver
/// gives `plan_alloc`).
const HYSTERESIS_FACTOR: f64 = 0.5;

/// The result of planning from a start to a goal.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlanResult {
    /// Every cell from the start to the goal (empty when there is no path).
    pub path: Vec<Cell>,
    /// The waypoints in world coordinates (m), start first, goal last; empty when no path.
    pub waypoints: Vec<(f64, f64)>,
}

impl Plan {
    /// Builds the c-space of a `size_x` x `size_y` grid of Player map cells (row-major from
    /// the lower left; -1 free, 0 unknown, +1 occupied). As upstream, unknown cells count as
    /// obstacles: only cells known to be free can be driven through.
    ///
    /// `None` when `cells` does not hold `size_x * size_y` values or the scale is not positive.
    pub fn new(
        size_x: usize,
        size_y: usize,
        scale: f64,
        origin: (f64, f64),
        cells: &[i8],
        params: PlanParams,
    ) -> Option<Plan> {
        if size_x.checked_mul(size_y)? != cells.len()
            || size_x == 0
            || cells.len() >= u32::MAX as usize
            || scale.partial_cmp(&0.0)? != Ordering::Greater
        {
            return None;
        }
        let occ_dist = obstacle_distances(size_x, size_y, scale, cells, params.max_radius);
        // The kernel the laser's obstacles are grown with (upstream's dist_kernel); the map's
        // own distances come from a distance transform that gives the kernel's values.
        let half = (params.max_radius / scale).ceil().max(0.0) as i64;
        let kernel: Vec<(i64, i64, f32)> = (-half..=half)
            .flat_map(|dj| (-half..=half).map(move |di| (di, dj)))
            .map(|(di, dj)| (di, dj, (((di * di + dj * dj) as f64).sqrt() * scale) as f32))
            .collect();
        let distances = kernel.iter().map(|&(_, _, d)| d);
        let cells = CellStates::new(size_x, size_y, &occ_dist, distances, &params);
        let kernel = kernel
            .into_iter()
            .map(|(di, dj, d)| (di, dj, d, cells.distance_class(d)))
            .collect();
        Some(Plan {
            size_x,
            size_y,
            origin,
            scale,
            params,
            cells,
            queue: WaveQueue::new(bucket_width(scale, &params)),
            occ_dist_dyn: occ_dist.clone(),
            occ_dist,
            kernel,
            bounds: (0, 0, size_x - 1, size_y - 1),
            path: Vec::new(),
            lpath: Vec::new(),
        })
    }

    /// The parameters the c-space was built with.
    pub fn params(&self) -> PlanParams {
        self.params
    }

    /// The cell holding world point (x, y) (upstream's `PLAN_GXWX`: rounded to the nearest
    /// cell centre), `None` off the grid.
    pub fn cell_of(&self, x: f64, y: f64) -> Option<Cell> {
        let i = ((x - self.origin.0) / self.scale + 0.5).floor();
        let j = ((y - self.origin.1) / self.scale + 0.5).floor();
        (i >= 0.0 && j >= 0.0 && i < self.size_x as f64 && j < self.size_y as f64)
            .then_some((i as usize, j as usize))
    }

    /// The world position of a cell's centre (upstream's `PLAN_WXGX`, `PLAN_WYGY`).
    pub fn world_of(&self, (i, j): Cell) -> (f64, f64) {
        (
            self.origin.0 + i as f64 * self.scale,
            self.origin.1 + j as f64 * self.scale,
        )
    }

    /// Distance (m) from a cell to the nearest obstacle of the map, capped at `max_radius`.
    pub fn occ_dist(&self, (i, j): Cell) -> f32 {
        self.occ_dist[i + j * self.size_x]
    }

    /// The same with the laser's obstacles (see [`Plan::set_obstacles`]) counted.
    pub fn occ_dist_dyn(&self, (i, j): Cell) -> f32 {
        self.occ_dist_dyn[i + j * self.size_x]
    }

    fn index(&self, (i, j): Cell) -> usize {
        i + j * self.size_x
    }

    /// Whether the last global plan found a path (upstream's `path_count > 0`), which local
    /// plans follow.
    pub fn has_global_path(&self) -> bool {
        !self.path.is_empty()
    }

    /// Obstacles seen by the laser (world points, m): from now on each counts as an occupied
    /// cell grown by `max_radius`, on top of the map (upstream's `plan_set_obstacles`; the
    /// previous points are forgotten). As upstream, a point's growth stays inside the region
    /// the last plan searched, and points off the map are dropped.
    pub fn set_obstacles(&mut self, points: &[(f64, f64)]) {
        self.occ_dist_dyn.copy_from_slice(&self.occ_dist);
        self.cells.restore_distances();
        let obstacle_class = self.cells.distance_class(0.0);
        let (x0, y0, x1, y1) = self.bounds;
        for &(x, y) in points {
            let Some(c) = self.cell_of(x, y) else {
                continue;
            };
            let k = self.index(c);
            // A cell at distance 0 is an obstacle already (of the map, or a point before this
            // one): growing it again changes nothing (upstream marks the cells it has grown).
            if self.occ_dist_dyn[k] == 0.0 {
                continue;
            }
            self.occ_dist_dyn[k] = 0.0;
            self.cells
                .set_distance_class(self.cells.index(c), obstacle_class);
            for &(di, dj, d, class) in &self.kernel {
                let (ni, nj) = (c.0 as i64 + di, c.1 as i64 + dj);
                if ni < x0 as i64 || nj < y0 as i64 || ni > x1 as i64 || nj > y1 as i64 {
                    continue;
                }
                let nk = ni as usize + nj as usize * self.size_x;
                if d < self.occ_dist_dyn[nk] {
                    self.occ_dist_dyn[nk] = d;
                    let np = self.cells.index((ni as usize, nj as usize));
                    self.cells.set_distance_class(np, class);
                }
            }
        }
    }

    /// Plans from world point `start` to `goal` over the whole map: the wavefront, the path
    /// and its waypoints (upstream's `plan_do_global` then `plan_update_waypoints`). An empty
    /// result means no path: either point off the map, or the goal unreachable. The start
    /// cell itself is treated as free, so a robot that has drifted close to a wall can still
    /// leave. The plan is kept: [`Plan::plan_local`] follows its path and [`Plan::carrot`]
    /// its steps.
    pub fn plan(&mut self, start: (f64, f64), goal: (f64, f64)) -> PlanResult {
        let path = self.plan_path(start, goal);
        self.result_of(path)
    }

    /// The wavefront and the path of [`Plan::plan`] without the waypoints (upstream's
    /// `plan_do_global` alone): the cells from the start to the goal, empty when there is no
    /// path.
    pub fn plan_path(&mut self, start: (f64, f64), goal: (f64, f64)) -> Vec<Cell> {
        self.path.clear();
        self.bounds = (0, 0, self.size_x - 1, self.size_y - 1);
        self.reset_costs();
        let (Some(s), Some(g)) = (self.cell_of(start.0, start.1), self.cell_of(goal.0, goal.1))
        else {
            return Vec::new();
        };
        if !self.wavefront(s, g) {
            return Vec::new();
        }
        self.path = self.follow(self.cells.index(s));
        self.path.iter().map(|&p| self.cells.cell(p)).collect()
    }

    /// Plans from `start` to the farthest cell of the last global path that stays within
    /// `half_width` metres (in x and in y) of it, searching only that square, and marks the
    /// path as the local one (upstream's `plan_do_local`, which wavefront tries before each
    /// replan, with the laser's range as the half width, so that obstacles the laser sees
    /// are driven round without planning over the whole map). `None` when there is no global
    /// path, the global path does not pass through the square, or the local goal cannot be
    /// reached.
    pub fn plan_local(&mut self, start: (f64, f64), half_width: f64) -> Option<PlanResult> {
        let s = self.cell_of(start.0, start.1)?;
        let grid = |v: f64, o: f64, max: usize| -> usize {
            (((v - o) / self.scale + 0.5).floor().max(0.0) as usize).min(max)
        };
        self.bounds = (
            grid(start.0 - half_width, self.origin.0, self.size_x - 1),
            grid(start.1 - half_width, self.origin.1, self.size_y - 1),
            grid(start.0 + half_width, self.origin.0, self.size_x - 1),
            grid(start.1 + half_width, self.origin.1, self.size_y - 1),
        );
        self.reset_costs();
        let goal = self.local_goal(s)?;
        if !self.wavefront(s, goal) {
            tracing::debug!("wavefront: local plan update failed");
            return None;
        }
        let lpath = self.follow(self.cells.index(s));
        for k in self.lpath.drain(..) {
            self.cells.set_lpath(k as usize, false);
        }
        for &k in &lpath {
            self.cells.set_lpath(k, true);
            self.lpath.push(k as u32);
        }
        let path = lpath.into_iter().map(|p| self.cells.cell(p)).collect();
        Some(self.result_of(path))
    }

    /// Upstream's `_plan_find_local_goal`: the global path's cell nearest `s` (in cells), then
    /// along the path to the last cell inside the current bounds.
    fn local_goal(&self, s: Cell) -> Option<Cell> {
        let sq = |k: usize| {
            let (i, j) = self.cells.cell(k);
            let (di, dj) = (i as i64 - s.0 as i64, j as i64 - s.1 as i64);
            di * di + dj * dj
        };
        let mut nearest = None;
        for (c, &k) in self.path.iter().enumerate() {
            if nearest.is_none_or(|(_, best)| sq(k) < best) {
                nearest = Some((c, sq(k)));
            }
        }
        let (c_min, _) = nearest?;
        let (x0, y0, x1, y1) = self.bounds;
        let inside = |k: usize| {
            let (i, j) = self.cells.cell(k);
            (x0..=x1).contains(&i) && (y0..=y1).contains(&j)
        };
        let mut c = c_min;
        while c < self.path.len() && inside(self.path[c]) {
            c += 1;
        }
        if c == c_min {
            tracing::debug!("wavefront: global path not in local region");
            return None;
        }
        Some(self.cells.cell(self.path[c - 1]))
    }

    /// The cells from `k` along the next steps to the goal.
    fn follow(&self, k: usize) -> Vec<usize> {
        let mut out = vec![k];
        let mut at = k;
        while let Some(n) = self.cells.next_of(at) {
            out.push(n);
            at = n;
        }
        out
    }

    /// A plan's result from its path (start first; empty when there is none): the path and
    /// its waypoints in world coordinates.
    fn result_of(&self, path: Vec<Cell>) -> PlanResult {
        let waypoints = self
            .reduce_to_waypoints(&path)
            .into_iter()
            .map(|c| self.world_of(c))
            .collect();
        PlanResult { path, waypoints }
    }

    /// Upstream's `plan_reset`: costs and next steps forgotten inside the current bounds.
    fn reset_costs(&mut self) {
        let (x0, y0, x1, y1) = self.bounds;
        for j in y0..=y1 {
            self.cells.reset_row(j, x0, x1);
        }
    }

    /// Runs the wavefront from `goal` inside the current bounds and tells whether it reached
    /// `start` (upstream's `_plan_update_plan`).
    ///
    /// As upstream, a cell's cost is fixed when the cell is first reached (a reached cell is
    /// never pushed again), stepping costs the step length (half of it onto the last local
    /// path), and a cell within `max_radius` of an obstacle costs
    /// `dist_penalty * (max_radius - distance)` more, rounded as upstream's mix of `float` and
    /// `double` rounds it. Because nothing about a reached cell changes afterwards, the path
    /// from the start is final as soon as the start is reached, and the wavefront stops there
    /// instead of flooding the rest of the region as upstream does: the same path, found
    /// sooner. (The costs of cells not on it are then not all upstream's; nothing reads them.)
    fn wavefront(&mut self, start: Cell, goal: Cell) -> bool {
        let (x0, y0, x1, y1) = self.bounds;
        let in_bounds = |(i, j): Cell| (x0..=x1).contains(&i) && (y0..=y1).contains(&j);
        if !in_bounds(goal) || !in_bounds(start) {
            return false;
        }
        let s = self.cells.index(start);
        let g = self.cells.index(goal);
        // The start cell is free for this plan whatever is near it: it counts as `max_radius`
        // from any obstacle (blocked too if that is below the minimum).
        let start_open = self
            .cells
            .distance_class(self.params.max_radius as f32)
            .is_some();
        self.cells.open_for_plan(self.bounds, s, start_open, g);
        if s == g {
            return true;
        }
        let (straight, diagonal) = step_lengths(self.scale);
        let offsets = self.cells.neighbour_offsets();
        // The neighbours as (index offset, step length, step onto the local path).
        let neighbours: [(isize, f32, f32); 8] = std::array::from_fn(|n| {
            let (di, dj) = NEIGHBOURS[n];
            let step = if di != 0 && dj != 0 {
                diagonal
            } else {
                straight
            };
            let lpath_step = (f64::from(step) * HYSTERESIS_FACTOR) as f32;
            (offsets[n], step, lpath_step)
        });
        let mut flood = Flood {
            view: self.cells.flood_view(),
            neighbours,
            start: s,
            occ_dist_dyn: &self.occ_dist_dyn,
            size_x: self.size_x,
            bounded: (self.size_x * self.size_y) as f64 * dearest_step(self.scale, &self.params)
                < f64::from(MAX_COST) / 2.0,
        };
        match &mut self.queue {
            WaveQueue::Monotone(q) => flood.run(q, g),
            WaveQueue::General(q) => flood.run(q, g),
        }
    }

    /// The point to steer for from world point `from` under direct velocity control
    /// (upstream's `plan_get_carrot`): for each look-ahead from `max_dist` down to one cell,
    /// the point that far along the last plan's steps; of those whose straight line from
    /// `from` stays clear of the c-space, the one with the least obstacle cost plus
    /// `dist_weight / look-ahead²`. `None` when none is clear (or `from` is off the map).
    pub fn carrot(&self, from: (f64, f64), max_dist: f64, dist_weight: f64) -> Option<(f64, f64)> {
        let s = self.cell_of(from.0, from.1)?;
        let sk = self.cells.index(s);
        let mut best: Option<(f64, Cell)> = None;
        let mut dist = max_dist;
        while dist >= self.scale {
            let mut at = sk;
            let mut d = self.scale;
            while let Some(n) = self.cells.next_of(at) {
                if d >= dist {
                    break;
                }
                at = n;
                d += self.scale;
            }
            let target = self.cells.cell(at);
            if let Some(obstacle_cost) = self.line_cost(s, target) {
                let cost = obstacle_cost + dist_weight * (1.0 / (dist * dist));
                if best.is_none_or(|(b, _)| cost < b) {
                    best = Some((cost, target));
                }
            }
            dist -= self.scale;
        }
        best.map(|(_, c)| self.world_of(c))
    }

    /// Upstream's `_plan_check_path`: walks the Bresenham line from `a` to `b` (the robot's
    /// cell `a` counting as free) and sums `dist_penalty * (max_radius - distance)`, truncated
    /// per cell, over cells within `max_radius` of an obstacle; `None` if any cell is closer
    /// than `abs_min_radius`.
    fn line_cost(&self, a: Cell, b: Cell) -> Option<f64> {
        let dist_of = |c: Cell| {
            if c == a {
                self.params.max_radius as f32
            } else {
                self.occ_dist_dyn[self.index(c)]
            }
        };
        let cell_cost = |c: Cell| -> Option<i64> {
            let d = dist_of(c);
            if d < self.params.abs_min_radius as f32 {
                None
            } else if f64::from(d) < self.params.max_radius {
                Some((self.params.dist_penalty * (self.params.max_radius - f64::from(d))) as i64)
            } else {
                Some(0)
            }
        };
        let (mut x0, mut y0, mut x1, mut y1) = (a.0 as i64, a.1 as i64, b.0 as i64, b.1 as i64);
        let steep = (y1 - y0).abs() > (x1 - x0).abs();
        if steep {
            std::mem::swap(&mut x0, &mut y0);
            std::mem::swap(&mut x1, &mut y1);
        }
        let delta_x = (x1 - x0).abs();
        let delta_y = (y1 - y0).abs();
        let x_step = if x0 < x1 { 1 } else { -1 };
        let y_step = if y0 < y1 { 1 } else { -1 };
        let at = |x: i64, y: i64| -> Cell {
            if steep {
                (y as usize, x as usize)
            } else {
                (x as usize, y as usize)
            }
        };
        let (mut x, mut y, mut error) = (x0, y0, 0i64);
        let mut total = cell_cost(at(x, y))?;
        while x != x1 + x_step {
            x += x_step;
            error += delta_y;
            if 2 * error >= delta_x {
                y += y_step;
                error -= delta_x;
            }
            let c = at(x, y);
            // Upstream walks one cell past `b`; that cell may lie off the grid.
            if c.0 >= self.size_x || c.1 >= self.size_y || x < 0 || y < 0 {
                return None;
            }
            total += cell_cost(c)?;
        }
        Some(total as f64)
    }

    /// Reduces a path to waypoints (upstream's `plan_update_waypoints`): from each waypoint,
    /// walk along the path while the next cell can be reached in a straight line (always for
    /// the first `WAYPOINT_FREE_RUN` metres), and put the next waypoint where that stops.
    pub fn reduce_to_waypoints(&self, path: &[Cell]) -> Vec<Cell> {
        let mut out = Vec::new();
        if path.is_empty() {
            return out;
        }
        let last = path.len() - 1;
        let mut at = 0;
        loop {
            out.push(path[at]);
            if at == last {
                break;
            }
            // The free run, then the first step whose next cell is out of sight (once the run
            // is past the free length it stays past it).
            let mut run = 0.0;
            let mut k = at;
            while k < last && run <= WAYPOINT_FREE_RUN {
                run += self.scale;
                k += 1;
            }
            if k < last {
                k = self.first_out_of_sight(path, at, k);
            }
            if k == at {
                break;
            }
            at = k;
        }
        out
    }

    /// The first `k` from `from` on (below the path's last index) whose next cell cannot be
    /// reached in a straight line from `path[at]`, or the last index if every one can. Long
    /// searches are shared between two threads, one taking the even steps and one the odd,
    /// each stopping at its first miss or once the other has found an earlier one; the answer
    /// is the same as one thread's.
    fn first_out_of_sight(&self, path: &[Cell], at: usize, from: usize) -> usize {
        use std::sync::atomic::{AtomicUsize, Ordering as Atomic};
        let last = path.len() - 1;
        let misses = |k: usize| !self.reachable(path[at], path[k + 1]);
        if last - from < PARALLEL_SIGHT_TESTS || crate::cores() < 2 {
            return (from..last).find(|&k| misses(k)).unwrap_or(last);
        }
        let first = AtomicUsize::new(last);
        let search = |start: usize| {
            for k in (start..last).step_by(2) {
                if k > first.load(Atomic::Relaxed) {
                    return;
                }
                if misses(k) {
                    first.fetch_min(k, Atomic::Relaxed);
                    return;
                }
            }
        };
        std::thread::scope(|scope| {
            scope.spawn(|| search(from + 1));
            search(from);
        });
        first.into_inner()
    }

    /// Whether the straight line from cell `a` to cell `b` stays clear of the c-space
    /// (upstream's `plan_test_reachable`: step along the line one cell length at a time and
    /// test every cell entered against `abs_min_radius`).
    pub fn reachable(&self, a: Cell, b: Cell) -> bool {
        let (bi, bj) = (b.0 as i64, b.1 as i64);
        let theta = ((bj - a.1 as i64) as f64).atan2((bi - a.0 as i64) as f64);
        let (sin, cos) = theta.sin_cos();
        let (mut i, mut j) = (a.0 as f64, a.1 as f64);
        let (mut last_i, mut last_j) = (-1i64, -1i64);
        // The walk ends within one step per cell of the longer side; the bound only guards
        // against rounding keeping it from landing on `b`.
        let limit = 2 * (self.size_x + self.size_y) + 4;
        for _ in 0..limit {
            if last_i == bi && last_j == bj {
                return true;
            }
            let (fi, fj) = (floor(i), floor(j));
            if fi != last_i || fj != last_j {
                last_i = fi;
                last_j = fj;
                if fi < 0 || fj < 0 || fi >= self.size_x as i64 || fj >= self.size_y as i64 {
                    return false;
                }
                if !self
                    .cells
                    .map_free(self.cells.index((fi as usize, fj as usize)))
                {
                    return false;
                }
            }
            if last_i != bi {
                i += cos;
            }
            if last_j != bj {
                j += sin;
            }
        }
        false
    }
}

/// Upstream's c-space distances (`plan_compute_cspace`): per cell the distance (m, as `f32`)
/// to the nearest non-free cell, `max_radius` where none is nearer than that, 0 on obstacles.
///
/// Upstream stamps a square kernel of half-width `r = ceil(max_radius / scale)` cells around
/// every obstacle cell and keeps the minimum of `f32(sqrt(di^2 + dj^2) * scale)`. The same
/// values come from the exact Euclidean distance transform of the grid (Felzenszwalb and
/// Huttenlocher's two passes: per column the distance to the nearest obstacle in that column,
/// then per row the lower envelope of the parabolas `(i - i')^2 + g(i')^2`), which costs a few
/// operations per cell instead of one per kernel entry per obstacle. The nearest obstacle
/// gives the smallest kernel value (the value only grows with `di^2 + dj^2`) and lies within
/// the kernel whenever that value is below `max_radius`; obstacles farther than `r` cells can
/// only give values of at least `max_radius`, so columns whose nearest obstacle is farther
/// than `r` are left out of the envelope. The result is the kernel's bit for bit.
fn obstacle_distances(
    size_x: usize,
    size_y: usize,
    scale: f64,
    cells: &[i8],
    max_radius: f64,
) -> Vec<f32> {
    const NONE: u32 = u32::MAX;
    let max = max_radius as f32;
    // Cells of reach: the kernel's half-width, and never more than the grid spans.
    let reach = (max_radius / scale)
        .ceil()
        .clamp(0.0, (size_x + size_y) as f64) as u32;
    // Vertical distance to the nearest obstacle in the same column (NONE beyond `reach`),
    // swept up then down a row at a time, so both sweeps read memory in order.
    let mut column = vec![NONE; size_x * size_y];
    for j in 0..size_y {
        for i in 0..size_x {
            let k = i + j * size_x;
            column[k] = if cells[k] >= 0 {
                0
            } else if j > 0 && column[k - size_x] < reach {
                column[k - size_x] + 1
            } else {
                NONE
            };
        }
    }
    for j in (0..size_y.saturating_sub(1)).rev() {
        for i in 0..size_x {
            let k = i + j * size_x;
            let above = column[k + size_x];
            if above < reach && above + 1 < column[k] {
                column[k] = above + 1;
            }
        }
    }
    let mut occ_dist = vec![max; size_x * size_y];
    // The distance of every squared cell offset within reach, computed as the kernel computes
    // it. Offsets beyond reach are at least `max_radius` away: the kernel leaves those cells at
    // `max_radius` (for reaches below 2^24 the margin, over 1 / (2 reach^2) relative, dwarfs
    // the rounding of `sqrt(k) * scale`; past that they are computed as the kernel would).
    let exact_cutoff = reach < 1 << 24;
    let reach_squared = u64::from(reach) * u64::from(reach);
    let squares: Vec<f32> = if reach <= 1024 {
        (0..=reach_squared)
            .map(|k| ((k as f64).sqrt() * scale) as f32)
            .collect()
    } else {
        Vec::new()
    };
    // Per row, the lower envelope of the parabolas rooted at the columns with a near
    // obstacle. Each kept root starts to be the lowest at `numer / denom` (exact integers,
    // compared by cross-multiplying; the first root starts at minus infinity, denom 0).
    let mut roots: Vec<Root> = Vec::with_capacity(size_x);
    for j in 0..size_y {
        let row = &column[j * size_x..(j + 1) * size_x];
        roots.clear();
        for (q, &g) in row.iter().enumerate() {
            if g == NONE {
                continue;
            }
            let (q, fq) = (q as i128, i128::from(g) * i128::from(g));
            let (mut numer, mut denom) = (0, 0);
            while let Some(last) = roots.last() {
                // The parabolas of the last root and q meet at
                // (fq + q^2 - fp - p^2) / (2 (q - p)); if that is not after the last root's
                // own start, q undercuts it everywhere it was lowest.
                numer = fq + q * q - last.f - last.at * last.at;
                denom = 2 * (q - last.at);
                if last.denom != 0 && numer * last.denom <= last.numer * denom {
                    roots.pop();
                    (numer, denom) = (0, 0);
                } else {
                    break;
                }
            }
            roots.push(Root {
                at: q,
                f: fq,
                numer,
                denom,
            });
        }
        // Each root is the lowest from the first column past its start to the next root's;
        // only the columns within `reach` of it can be nearer than `max_radius`.
        for (r, root) in roots.iter().enumerate() {
            let first_column = |root: &Root| {
                if root.denom == 0 {
                    0
                } else {
                    (root.numer.div_euclid(root.denom) + 1).clamp(0, size_x as i128) as usize
                }
            };
            let from = first_column(root);
            let to = roots.get(r + 1).map_or(size_x, first_column);
            let at = root.at as usize;
            let from = from.max(at.saturating_sub(reach as usize));
            let to = to.min(at.saturating_add(reach as usize + 1)).min(size_x);
            let f = root.f as u64;
            for q in from..to {
                let di = q.abs_diff(at) as u64;
                let squared = di * di + f;
                let d = if squared <= reach_squared {
                    squares
                        .get(squared as usize)
                        .copied()
                        .unwrap_or_else(|| ((squared as f64).sqrt() * scale) as f32)
                } else if exact_cutoff {
                    continue;
                } else {
                    ((squared as f64).sqrt() * scale) as f32
                };
                if d < max {
                    occ_dist[q + j * size_x] = d;
                }
            }
        }
    }
    // Obstacle cells in rows without any root (reach 0) are still obstacles.
    for (d, &c) in occ_dist.iter_mut().zip(cells) {
        if c >= 0 {
            *d = 0.0;
        }
    }
    occ_dist
}

/// One wavefront's loop and what it reads (see [`Plan::wavefront`]), run on the queue the
/// plan has.
struct Flood<'a> {
    view: FloodView<'a>,
    /// The neighbours as (index offset, step length, step onto the local path).
    neighbours: [(isize, f32, f32); 8],
    /// The start cell, where the wavefront stops.
    start: usize,
    /// Distances, for penalties the states do not hold.
    occ_dist_dyn: &'a [f32],
    size_x: usize,
    /// No cost can reach [`MAX_COST`] on this grid (the cells times the dearest step stay
    /// below it), so the test is left out.
    bounded: bool,
}

impl Flood<'_> {
    /// Floods from `goal`; whether the start was reached.
    fn run(&mut self, queue: &mut impl WaveOrder, goal: usize) -> bool {
        let Flood {
            view,
            neighbours,
            start,
            occ_dist_dyn,
            size_x,
            bounded,
        } = self;
        let (s, size_x, bounded, neighbours) = (*start, *size_x, *bounded, *neighbours);
        queue.clear();
        queue.push(0.0, goal as u32);
        while let Some((here, cell)) = queue.pop() {
            let cell = cell as usize;
            // Closed neighbours are left out: reached (a reached cell keeps its cost),
            // blocked, or outside the bounds. The rest are taken in upstream's order.
            let mut open = view.open_neighbours(cell, size_x + 2);
            while open != 0 {
                // (Below 8: the mask has eight bits; saying so spares a bounds test.)
                let n = open.trailing_zeros() as usize & 7;
                open &= open - 1;
                let (offset, step, lpath_step) = neighbours[n];
                let p = (cell as isize + offset) as usize;
                let state = view.state(p);
                let on_lpath = FloodView::on_lpath(state);
                let mut c = here + if on_lpath { lpath_step } else { step };
                if p != s {
                    c += view.penalty(state, || {
                        // Unpadded, for the distances.
                        let w = size_x + 2;
                        occ_dist_dyn[(p % w - 1) + (p / w - 1) * size_x]
                    });
                }
                if bounded || c < MAX_COST {
                    // The step back to `cell` is the opposite neighbour.
                    view.reach(p, state, 7 - n);
                    if p == s {
                        return true;
                    }
                    queue.push(c, p as u32);
                }
            }
        }
        false
    }
}

/// The wavefront's step lengths (straight, diagonal), computed as upstream's 3x3 kernel
/// computes them.
fn step_lengths(scale: f64) -> (f32, f32) {
    ((1f64.sqrt() * scale) as f32, (2f64.sqrt() * scale) as f32)
}

/// The most a step of the wavefront can add to a cost: the diagonal and the largest
/// penalty (a cell entered is at least `abs_min_radius`, and 0, from obstacles). NaN for
/// NaN parameters.
fn dearest_step(scale: f64, params: &PlanParams) -> f64 {
    let (_, diagonal) = step_lengths(scale);
    let intrusion = params.max_radius - params.abs_min_radius.max(0.0);
    f64::from(diagonal) + (params.dist_penalty * intrusion).max(0.0)
}

/// Buckets per cheapest step in the wavefront's queue: any number keeps the order exact (a
/// step then always lands in a later bucket); narrower buckets hold fewer cells each and
/// sort faster, at the price of more (mostly empty) buckets to pass over. 16 measured best
/// on the hospital floor.
const BUCKETS_PER_STEP: f64 = 16.0;

/// The bucket width for the wavefront's queue (see [`WaveQueue::new`]): a fraction of the
/// cheapest step, when no step can cost less than nothing (so costs never decrease) and the
/// dearest step spans at most a few thousand buckets; `None` (a binary heap) otherwise.
fn bucket_width(scale: f64, params: &PlanParams) -> Option<f64> {
    let (straight, _) = step_lengths(scale);
    let cheapest = f64::from((f64::from(straight) * HYSTERESIS_FACTOR) as f32);
    let dearest = dearest_step(scale, params);
    let width = cheapest / BUCKETS_PER_STEP;
    (params.dist_penalty >= 0.0 && width > 0.0 && dearest / width <= 32768.0).then_some(width)
}

/// `x` rounded down, as `x.floor() as i64` but without the library call `floor` is on
/// baseline x86-64 (the straight-line test does this twice per step).
fn floor(x: f64) -> i64 {
    let t = x as i64;
    if (t as f64) > x { t - 1 } else { t }
}

/// A parabola of the distance transform's lower envelope: rooted at column `at` with height
/// `f` (the squared vertical distance there), lowest from `numer / denom` on (`denom` 0: from
/// minus infinity).
struct Root {
    at: i128,
    f: i128,
    numer: i128,
    denom: i128,
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BinaryHeap;

    const FREE: i8 = -1;
    const OCC: i8 = 1;

    /// A grid from text rows, top row first: '#' occupied, '?' unknown, anything else free.
    fn grid(rows: &[&str]) -> (usize, usize, Vec<i8>) {
        let h = rows.len();
        let w = rows[0].len();
        let mut cells = vec![FREE; w * h];
        for (r, row) in rows.iter().enumerate() {
            let j = h - 1 - r;
            for (i, ch) in row.chars().enumerate() {
                cells[i + j * w] = match ch {
                    '#' => OCC,
                    '?' => 0,
                    _ => FREE,
                };
            }
        }
        (w, h, cells)
    }

    fn params(abs_min: f64) -> PlanParams {
        PlanParams {
            abs_min_radius: abs_min,
            max_radius: 1.0,
            dist_penalty: 1.0,
        }
    }

    fn plan_of(rows: &[&str], abs_min: f64) -> Plan {
        let (w, h, cells) = grid(rows);
        Plan::new(w, h, 1.0, (0.0, 0.0), &cells, params(abs_min)).unwrap()
    }

    const WALL: &[&str] = &[
        "..........",
        "..........",
        "....#.....",
        "....#.....",
        "....#.....",
        "....#.....",
        "....#.....",
        "..........",
    ];

    /// The wavefront as first written (`Option<usize>` links, a queue of structs), kept as the
    /// reference the packed version must match cell for cell.
    fn reference_wavefront_path(plan: &Plan, start: Cell, goal: Cell) -> Option<Vec<Cell>> {
        let this = plan;
        let n = this.size_x * this.size_y;
        let idx = |(i, j): Cell| i + j * this.size_x;
        let mut cost = vec![MAX_COST; n];
        let mut next: Vec<Option<usize>> = vec![None; n];
        let mut reached = vec![false; n];
        let dist = |k: usize| {
            if k == idx(start) {
                this.params.max_radius as f32
            } else {
                this.occ_dist[k]
            }
        };
        let g = idx(goal);
        cost[g] = 0.0;
        if start == goal {
            return Some(vec![start]);
        }
        let mut heap = BinaryHeap::new();
        let mut order = 0u64;
        reached[g] = true;
        heap.push(Queued {
            cost: 0.0,
            order,
            cell: g,
        });
        let abs_min = this.params.abs_min_radius as f32;
        while let Some(Queued { cell, .. }) = heap.pop() {
            let (oi, oj) = (cell % this.size_x, cell / this.size_x);
            for dj in -1i64..=1 {
                for di in -1i64..=1 {
                    if di == 0 && dj == 0 {
                        continue;
                    }
                    let (ni, nj) = (oi as i64 + di, oj as i64 + dj);
                    if ni < 0 || nj < 0 || ni >= this.size_x as i64 || nj >= this.size_y as i64 {
                        continue;
                    }
                    let k = ni as usize + nj as usize * this.size_x;
                    if reached[k] {
                        continue;
                    }
                    let d = dist(k);
                    if d < abs_min {
                        continue;
                    }
                    let step = (((di * di + dj * dj) as f64).sqrt() * this.scale) as f32;
                    let mut c = cost[cell] + step;
                    if f64::from(d) < this.params.max_radius {
                        // upstream compares and rounds in double arithmetic
                        c += (this.params.dist_penalty * (this.params.max_radius - f64::from(d)))
                            as f32;
                    }
                    if c < cost[k] {
                        cost[k] = c;
                        next[k] = Some(cell);
                        reached[k] = true;
                        order += 1;
                        heap.push(Queued {
                            cost: c,
                            order,
                            cell: k,
                        });
                    }
                }
            }
        }
        next[idx(start)]?;
        let mut path = vec![start];
        let mut at = idx(start);
        while let Some(k) = next[at] {
            path.push((k % this.size_x, k / this.size_x));
            at = k;
        }
        Some(path)
    }

    /// A cell waiting in the wavefront's queue: cheapest first, then first queued.
    #[derive(Debug)]
    struct Queued {
        cost: f32,
        order: u64,
        cell: usize,
    }

    impl PartialEq for Queued {
        fn eq(&self, other: &Self) -> bool {
            self.cmp(other) == Ordering::Equal
        }
    }

    impl Eq for Queued {}

    impl PartialOrd for Queued {
        fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
            Some(self.cmp(other))
        }
    }

    impl Ord for Queued {
        fn cmp(&self, other: &Self) -> Ordering {
            // BinaryHeap pops the greatest: reverse both keys.
            other
                .cost
                .total_cmp(&self.cost)
                .then_with(|| other.order.cmp(&self.order))
        }
    }

    /// A random room-like grid: walls, blobs and unknown patches.
    fn random_grid(rng: &mut rand_chacha::ChaCha8Rng, w: usize, h: usize, density: f64) -> Vec<i8> {
        use rand::Rng;
        (0..w * h)
            .map(|_| {
                if rng.random_bool(density) {
                    if rng.random_bool(0.7) { OCC } else { 0 }
                } else {
                    FREE
                }
            })
            .collect()
    }

    #[test]
    fn the_packed_wavefront_finds_the_reference_paths() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let mut found = 0;
        for round in 0..80 {
            let (w, h) = (rng.random_range(2..60), rng.random_range(2..60));
            let density = [0.0, 0.05, 0.15, 0.3][round % 4];
            let cells = random_grid(&mut rng, w, h, density);
            let scale = [1.0, 0.1, 0.25][round % 3];
            let params = PlanParams {
                abs_min_radius: [0.0, 0.5, 1.0][round % 3] * scale,
                max_radius: [1.0, 3.0][round % 2] * scale,
                dist_penalty: [1.0, 0.0, 5.0, -0.5][round % 4],
            };
            let mut plan = Plan::new(w, h, scale, (0.0, 0.0), &cells, params).unwrap();
            for _ in 0..5 {
                let s = (rng.random_range(0..w), rng.random_range(0..h));
                let g = (rng.random_range(0..w), rng.random_range(0..h));
                let want = reference_wavefront_path(&plan, s, g);
                found += usize::from(want.as_ref().is_some_and(|p| p.len() > 2));
                let got = plan.plan(plan.world_of(s), plan.world_of(g)).path;
                assert_eq!(
                    got,
                    want.unwrap_or_default(),
                    "round {round}: {s:?} -> {g:?}"
                );
            }
        }
        assert!(found > 100, "only {found} non-trivial paths compared");
    }

    #[test]
    fn floor_rounds_down() {
        for x in [
            0.0, 0.5, -0.5, -1.0, 1.0, -2.7, 3.2, 1e12, -1e12, -0.0, 1e-300, -1e-300,
        ] {
            assert_eq!(floor(x), x.floor() as i64, "{x}");
        }
    }

    /// Upstream's kernel c-space, kept as the reference the distance transform must match.
    fn kernel_distances(
        size_x: usize,
        size_y: usize,
        scale: f64,
        cells: &[i8],
        max_radius: f64,
    ) -> Vec<f32> {
        let max = max_radius as f32;
        let mut occ_dist: Vec<f32> = cells
            .iter()
            .map(|&c| if c >= 0 { 0.0 } else { max })
            .collect();
        let half = (max_radius / scale).ceil().max(0.0) as i64;
        for j in 0..size_y as i64 {
            for i in 0..size_x as i64 {
                if cells[(i + j * size_x as i64) as usize] < 0 {
                    continue;
                }
                for dj in -half..=half {
                    for di in -half..=half {
                        let (ni, nj) = (i + di, j + dj);
                        if ni < 0 || nj < 0 || ni >= size_x as i64 || nj >= size_y as i64 {
                            continue;
                        }
                        let d = (((di * di + dj * dj) as f64).sqrt() * scale) as f32;
                        let k = (ni + nj * size_x as i64) as usize;
                        if d < occ_dist[k] {
                            occ_dist[k] = d;
                        }
                    }
                }
            }
        }
        occ_dist
    }

    #[test]
    fn the_distance_transform_gives_the_kernels_distances_bit_for_bit() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for round in 0..60 {
            let (w, h) = (rng.random_range(1..70), rng.random_range(1..70));
            let density = [0.0, 0.002, 0.02, 0.1, 0.5, 1.0][round % 6];
            let cells: Vec<i8> = (0..w * h)
                .map(|_| {
                    if rng.random_bool(density) {
                        if rng.random_bool(0.5) { OCC } else { 0 }
                    } else {
                        FREE
                    }
                })
                .collect();
            let scale = [0.1, 0.05, 0.032, 1.0, 0.3][round % 5];
            let max_radius = [1.0, 0.25, 2.5, 0.0, 10.0, 0.07][round % 6];
            let fast = obstacle_distances(w, h, scale, &cells, max_radius);
            let slow = kernel_distances(w, h, scale, &cells, max_radius);
            let same = fast
                .iter()
                .zip(&slow)
                .all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(
                same,
                "{w} x {h}, density {density}, scale {scale}, max {max_radius}"
            );
        }
        // A reach past the table of squares (over 1,024 cells): distances computed directly.
        let (w, h) = (45, 38);
        let mut cells = vec![FREE; w * h];
        for k in [3, 400, 1111, 1500] {
            cells[k] = OCC;
        }
        let fast = obstacle_distances(w, h, 0.03, &cells, 40.0);
        let slow = kernel_distances(w, h, 0.03, &cells, 40.0);
        assert!(
            fast.iter()
                .zip(&slow)
                .all(|(a, b)| a.to_bits() == b.to_bits())
        );
    }

    #[test]
    fn cspace_measures_distance_to_the_nearest_obstacle() {
        let p = plan_of(WALL, 0.5);
        assert_eq!(p.occ_dist((4, 3)), 0.0);
        assert_eq!(p.occ_dist((5, 3)), 1.0);
        // Beyond max_radius the distance is capped.
        assert_eq!(p.occ_dist((0, 0)), 1.0);
        assert!((p.occ_dist((5, 6)) - 1.0).abs() < 1e-6);
        let diag = p.occ_dist((3, 0));
        assert!((diag - 1.0).abs() < 1e-6, "{diag}");
    }

    #[test]
    fn path_goes_around_an_obstacle() {
        let mut p = plan_of(WALL, 0.5);
        let r = p.plan((1.0, 4.0), (8.0, 4.0));
        assert_eq!(r.path.first(), Some(&(1, 4)));
        assert_eq!(r.path.last(), Some(&(8, 4)));
        // Never through the wall, and around one of its ends.
        assert!(r.path.iter().all(|&c| p.occ_dist(c) >= 0.5));
        assert!(r.path.iter().any(|&(_, j)| j == 0 || j >= 6));
        // Consecutive cells are neighbours.
        for w in r.path.windows(2) {
            let (a, b) = (w[0], w[1]);
            assert!(a.0.abs_diff(b.0) <= 1 && a.1.abs_diff(b.1) <= 1);
        }
        assert_eq!(r.waypoints.first(), Some(&(1.0, 4.0)));
        assert_eq!(r.waypoints.last(), Some(&(8.0, 4.0)));
        // Straight lines between waypoints stay clear.
        let cells: Vec<Cell> = r
            .waypoints
            .iter()
            .map(|&(x, y)| p.cell_of(x, y).unwrap())
            .collect();
        // (Neighbouring waypoints may cut a corner diagonally, as the path itself does.)
        for w in cells.windows(2) {
            let near = w[0].0.abs_diff(w[1].0) <= 1 && w[0].1.abs_diff(w[1].1) <= 1;
            assert!(near || p.reachable(w[0], w[1]), "{:?} -> {:?}", w[0], w[1]);
        }
        assert!(r.waypoints.len() >= 3 && r.waypoints.len() < r.path.len());
    }

    #[test]
    fn no_path_when_the_goal_is_walled_off() {
        let mut p = plan_of(
            &[
                "........", "....####", "....#...", "....#...", "....####", "........",
            ],
            0.5,
        );
        let r = p.plan((1.0, 2.0), (6.0, 2.0));
        assert!(r.path.is_empty() && r.waypoints.is_empty());
        // Off the map, too.
        assert_eq!(p.plan((1.0, 2.0), (60.0, 2.0)), PlanResult::default());
        assert_eq!(p.plan((-3.0, 2.0), (1.0, 1.0)), PlanResult::default());
    }

    #[test]
    fn unknown_cells_block_like_obstacles() {
        let mut p = plan_of(&["...?...", "...?...", "...?..."], 0.5);
        assert!(p.plan((0.0, 1.0), (6.0, 1.0)).waypoints.is_empty());
    }

    #[test]
    fn robot_radius_closes_narrow_gaps() {
        let rows = &[
            "#########",
            "#...#...#",
            "#.......#",
            "#...#...#",
            "#########",
        ];
        // A one-cell gap: passable for a point robot, not for one needing 1.5 cells.
        assert!(
            !plan_of(rows, 0.9)
                .plan((2.0, 2.0), (6.0, 2.0))
                .waypoints
                .is_empty()
        );
        assert!(
            plan_of(rows, 1.5)
                .plan((2.0, 2.0), (6.0, 2.0))
                .waypoints
                .is_empty()
        );
    }

    #[test]
    fn open_ground_reduces_to_start_and_goal() {
        let mut p = plan_of(&["............"; 6], 0.0);
        let r = p.plan((0.0, 0.0), (11.0, 5.0));
        assert!(r.path.len() >= 12);
        assert_eq!(r.waypoints, vec![(0.0, 0.0), (11.0, 5.0)]);
        assert_eq!(p.plan((3.0, 3.0), (3.2, 2.9)).waypoints, vec![(3.0, 3.0)]);
    }

    #[test]
    fn waypoint_reduction_keeps_corners() {
        // An L-shaped corridor: the corner must be a waypoint.
        let p = plan_of(
            &[
                "#######", "#.....#", "#####.#", "#####.#", "#####.#", "#######",
            ],
            0.5,
        );
        let path: Vec<Cell> = (1..=5)
            .map(|i| (i, 4))
            .chain((1..=3).rev().map(|j| (5, j)))
            .collect();
        let w = p.reduce_to_waypoints(&path);
        assert_eq!(w.first(), Some(&(1, 4)));
        assert_eq!(w.last(), Some(&(5, 1)));
        assert!(w.contains(&(5, 4)) || w.contains(&(4, 4)), "{w:?}");
        for pair in w.windows(2) {
            assert!(p.reachable(pair[0], pair[1]));
        }
        assert!(!p.reachable((1, 4), (5, 1)));
    }

    /// Upstream's `plan_update_waypoints` loop as first written, one sight test after the
    /// other: the reference the shared search must match.
    fn reference_waypoints(p: &Plan, path: &[Cell]) -> Vec<Cell> {
        let last = path.len() - 1;
        // From waypoint `at`: every step after the free run tested in turn.
        let next = |at: usize| -> usize {
            let mut run = 0.0;
            (at..last)
                .find(|&k| {
                    let blocked = run > WAYPOINT_FREE_RUN && !p.reachable(path[at], path[k + 1]);
                    run += p.scale;
                    blocked
                })
                .unwrap_or(last)
        };
        let mut out = vec![path[0]];
        let mut at = 0;
        while at < last {
            let k = next(at);
            if k == at {
                break;
            }
            at = k;
            out.push(path[at]);
        }
        out
    }

    #[test]
    fn shared_waypoint_searches_find_the_reference_waypoints() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(21);
        let mut long = 0;
        for round in 0..12 {
            let (w, h) = (260, 140);
            let cells = random_grid(&mut rng, w, h, [0.002, 0.01, 0.03][round % 3]);
            let params = PlanParams {
                abs_min_radius: 0.1,
                max_radius: 0.5,
                dist_penalty: 1.0,
            };
            let mut plan = Plan::new(w, h, 0.1, (0.0, 0.0), &cells, params).unwrap();
            for _ in 0..4 {
                let s = (rng.random_range(0..w / 4), rng.random_range(0..h));
                let g = (rng.random_range(3 * w / 4..w), rng.random_range(0..h));
                let path = plan.plan_path(plan.world_of(s), plan.world_of(g));
                if path.is_empty() {
                    continue;
                }
                long += usize::from(path.len() > 2 * PARALLEL_SIGHT_TESTS);
                assert_eq!(
                    plan.reduce_to_waypoints(&path),
                    reference_waypoints(&plan, &path),
                    "round {round}: {s:?} -> {g:?}"
                );
            }
        }
        assert!(
            long > 20,
            "only {long} paths long enough to share the search"
        );
    }

    /// A corridor 9 cells wide and 30 long, walls along both sides.
    fn corridor() -> Plan {
        let mut rows = vec!["##############################"];
        rows.extend(std::iter::repeat_n("..............................", 9));
        rows.push("##############################");
        let (w, h, cells) = grid(&rows);
        Plan::new(
            w,
            h,
            1.0,
            (0.0, 0.0),
            &cells,
            PlanParams {
                abs_min_radius: 1.0,
                max_radius: 2.0,
                dist_penalty: 1.0,
            },
        )
        .unwrap()
    }

    #[test]
    fn laser_obstacles_block_like_the_map_and_are_replaced_by_the_next() {
        let mut p = corridor();
        let straight = p.plan((1.0, 5.0), (28.0, 5.0));
        assert!(
            straight.path.iter().all(|&(_, j)| j == 5),
            "{:?}",
            straight.path
        );
        // A wall of hits across the middle but for a gap near the top.
        let wall: Vec<(f64, f64)> = (1..=6).map(|j| (15.0, f64::from(j))).collect();
        p.set_obstacles(&wall);
        assert_eq!(p.occ_dist_dyn((15, 3)), 0.0);
        assert_eq!(p.occ_dist((15, 3)), 2.0, "the map itself is unchanged");
        let round = p.plan((1.0, 5.0), (28.0, 5.0));
        assert!(!round.waypoints.is_empty());
        assert!(round.path.iter().all(|&c| p.occ_dist_dyn(c) >= 1.0));
        assert!(
            round.path.iter().any(|&(i, j)| i == 15 && j >= 8),
            "{:?}",
            round.path
        );
        // The next scan replaces the obstacles: the straight line is back.
        p.set_obstacles(&[]);
        assert_eq!(p.plan((1.0, 5.0), (28.0, 5.0)).path, straight.path);
    }

    #[test]
    fn a_local_plan_follows_the_global_path_within_its_window() {
        let mut p = corridor();
        assert!(
            p.plan_local((1.0, 5.0), 6.0).is_none(),
            "no global path yet"
        );
        let global = p.plan((1.0, 5.0), (28.0, 5.0));
        assert!(p.has_global_path());
        // From a little off the path, a window of 6 m: the local goal is the last path cell
        // inside it, at x = 3 + 6.
        let local = p.plan_local((3.0, 4.0), 6.0).unwrap();
        assert_eq!(local.path.first(), Some(&(3, 4)));
        assert_eq!(local.path.last(), Some(&(9, 5)));
        assert_eq!(local.waypoints.last(), Some(&(9.0, 5.0)));
        // The global path is kept for the next local plan.
        assert!(p.has_global_path());
        // An obstacle the laser now sees inside the window is driven round locally.
        p.set_obstacles(&[(6.0, 5.0), (6.0, 4.0), (6.0, 6.0)]);
        let round = p.plan_local((3.0, 5.0), 6.0).unwrap();
        assert!(round.path.iter().all(|&c| p.occ_dist_dyn(c) >= 1.0));
        assert_eq!(round.path.last(), Some(&(9, 5)));
        // Off the global path's region entirely: no local plan.
        assert!(p.plan_local((27.0, 5.0), 0.4).is_some());
        let _ = global;
    }

    #[test]
    fn the_carrot_lies_ahead_on_the_plan_in_clear_sight() {
        let mut p = corridor();
        p.plan((1.0, 5.0), (28.0, 5.0));
        // Up to 2 m ahead along a straight path: the farthest clear point wins (the distance
        // term favours it). As upstream counts, a look-ahead of 2 cells lands 1 cell on.
        assert_eq!(p.carrot((1.0, 5.0), 2.0, 10.0), Some((2.0, 5.0)));
        assert_eq!(p.carrot((1.0, 5.0), 4.0, 10.0), Some((4.0, 5.0)));
        // Near the goal the carrot is the goal.
        p.plan((26.0, 5.0), (27.0, 5.0));
        assert_eq!(p.carrot((26.0, 5.0), 2.0, 10.0), Some((27.0, 5.0)));
        // Hemmed in by obstacles the laser sees all round: no clear line, no carrot.
        p.plan((10.0, 5.0), (28.0, 5.0));
        let ring: Vec<(f64, f64)> = (9..=11)
            .flat_map(|i| (4..=6).map(move |j| (f64::from(i), f64::from(j))))
            .filter(|&(x, y)| (x, y) != (10.0, 5.0))
            .collect();
        p.set_obstacles(&ring);
        assert_eq!(p.carrot((10.0, 5.0), 2.0, 10.0), None);
    }

    #[test]
    fn bad_grids_are_refused() {
        assert!(Plan::new(3, 3, 1.0, (0.0, 0.0), &[FREE; 8], params(0.1)).is_none());
        assert!(Plan::new(3, 3, 0.0, (0.0, 0.0), &[FREE; 9], params(0.1)).is_none());
    }
}
