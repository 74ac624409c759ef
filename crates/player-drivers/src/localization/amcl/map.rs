//! The occupancy grid the sensor models cast rays in, laid out as Player 3.0.2's amcl lays out
//! the map it copies from a `map` device.
//!
//! Cells hold the map interface's values (-1 free, 0 unknown, +1 occupied). Rays stop at any
//! cell that is not free and at the edge of the grid, so unknown space and the outside of a
//! Stage bitmap both read as walls. World coordinates follow upstream's convention: the grid
//! is centred at the centre of the area the map's `origin`, `width` and `height` describe,
//! and a point belongs to the cell `floor((x - centre) / scale + 0.5) + width / 2` (integer
//! half-width), so with an even width cell centres fall half a cell off the tile centres.
//! That half cell is what Player's amcl localises against, kept so estimates agree with it.

use player_server::map::OccupancyGrid;

use crate::error::Error;

/// `x` rounded down, as `x.floor() as i64` but without the library call `floor` is on
/// baseline x86-64 (ray casting does this once per cell visited).
fn floor(x: f64) -> i64 {
    let t = x as i64;
    if (t as f64) > x { t - 1 } else { t }
}

/// The start of rays cast from one point: its world and fractional cell coordinates and its
/// cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayOrigin {
    ox: f64,
    oy: f64,
    i0: f64,
    j0: f64,
    ai: i64,
    aj: i64,
}

/// A map device's grid, placed as amcl places it.
#[derive(Clone, Debug, PartialEq)]
pub struct OccupancyMap {
    grid: OccupancyGrid,
    /// Per cell the chessboard distance (in cells, at most 255) to the nearest cell that stops
    /// a ray, counting the outside of the grid: 0 on such cells. A ray may skip that many
    /// cells minus one without looking (see [`OccupancyMap::calc_range`]).
    clearance: Vec<u8>,
    centre_x: f64,
    centre_y: f64,
    scale: f64,
    width: i64,
    height: i64,
}

impl OccupancyMap {
    /// The map of `grid` (as fetched from a map device); a scale that is not a positive
    /// length is an error.
    pub fn new(grid: OccupancyGrid) -> Result<OccupancyMap, Error> {
        let scale = f64::from(grid.scale());
        if !(scale > 0.0 && scale.is_finite()) {
            return Err(Error::Map(format!(
                "the map's scale {scale} is not a positive length"
            )));
        }
        let (width, height) = (grid.width(), grid.height());
        let origin = grid.origin();
        let clearance = clearance(width as usize, height as usize, grid.cells());
        Ok(OccupancyMap {
            clearance,
            centre_x: origin.px + scale * f64::from(width) / 2.0,
            centre_y: origin.py + scale * f64::from(height) / 2.0,
            scale,
            width: i64::from(width),
            height: i64::from(height),
            grid,
        })
    }

    /// The grid.
    pub fn grid(&self) -> &OccupancyGrid {
        &self.grid
    }

    /// The cell column of world x.
    pub fn column(&self, x: f64) -> i64 {
        floor((x - self.centre_x) / self.scale + 0.5) + self.width / 2
    }

    /// The cell row of world y.
    pub fn row(&self, y: f64) -> i64 {
        floor((y - self.centre_y) / self.scale + 0.5) + self.height / 2
    }

    /// The value of cell (`i`, `j`), `None` off the grid.
    pub fn get(&self, i: i64, j: i64) -> Option<i8> {
        if i < 0 || j < 0 || i >= self.width || j >= self.height {
            return None;
        }
        Some(self.grid.cells()[(j * self.width + i) as usize])
    }

    /// The chessboard distance from cell (`i`, `j`) to the nearest cell that stops a ray (off
    /// the grid, unknown or occupied), capped at 255: 0 when this cell stops it.
    fn clearance_of(&self, i: i64, j: i64) -> i64 {
        if i < 0 || j < 0 || i >= self.width || j >= self.height {
            return 0;
        }
        i64::from(self.clearance[(j * self.width + i) as usize])
    }

    /// The range a perfect sensor at (`ox`, `oy`) looking along `oa` would read, up to
    /// `max_range`: cells are visited along the ray's major axis, one per column (or row), and
    /// the range is the cell distance from the start cell to the first cell that stops the ray
    /// (upstream's `map_calc_range`; the minor coordinate is stepped by the slope instead of
    /// recomputed from world coordinates, which picks the same cells but for rounding at
    /// exact cell boundaries). Runs of cells that the clearance map shows cannot stop the ray
    /// are skipped without being looked at, which finds the same first stopping cell (and so
    /// the same range) in a fraction of the steps across open space.
    pub fn calc_range(&self, ox: f64, oy: f64, oa: f64, max_range: f64) -> f64 {
        let (s, c) = oa.sin_cos();
        self.calc_range_along(&self.ray_origin(ox, oy), s, c, max_range)
    }

    /// What every ray cast from (`ox`, `oy`) shares, computed once for all the beams of a
    /// particle.
    pub fn ray_origin(&self, ox: f64, oy: f64) -> RayOrigin {
        // The fractional cell coordinates, as `column` and `row` compute them.
        let i0 = (ox - self.centre_x) / self.scale + 0.5;
        let j0 = (oy - self.centre_y) / self.scale + 0.5;
        RayOrigin {
            ox,
            oy,
            i0,
            j0,
            ai: floor(i0) + self.width / 2,
            aj: floor(j0) + self.height / 2,
        }
    }

    /// [`OccupancyMap::calc_range`] from an origin made by [`OccupancyMap::ray_origin`], along
    /// the direction whose sine and cosine are `s`
    /// and `c` (so that a caller casting many rays can find those without a library call
    /// per ray).
    pub fn calc_range_along(&self, origin: &RayOrigin, s: f64, c: f64, max_range: f64) -> f64 {
        let &RayOrigin {
            ox,
            oy,
            i0,
            j0,
            ai,
            aj,
        } = origin;
        let hit = |i: i64, j: i64| cell_distance(i - ai, j - aj) * self.scale;
        let x_major = c.abs() > s.abs();
        let (a, b) = if x_major {
            (ai, self.column(ox + max_range * c))
        } else {
            (aj, self.row(oy + max_range * s))
        };
        if a == b {
            return max_range;
        }
        // The first cell looked at is the start's own; off the grid it stops the ray at once
        // (and the line's fixed point below needs a start on the grid).
        if self.clearance_of(ai, aj) == 0 {
            return 0.0;
        }
        let step = if a < b { 1 } else { -1 };
        // The minor coordinate along the major axis: row floor(j0 + k * slope) + height / 2
        // at column ai + k (or the same with the axes swapped).
        let (line, half) = if x_major {
            (Line::new(j0, s / c), self.height / 2)
        } else {
            (Line::new(i0, c / s), self.width / 2)
        };
        let mut k = 0;
        loop {
            let major = a + step * k;
            let minor = line.at(step * k) + half;
            let (i, j) = if x_major {
                (major, minor)
            } else {
                (minor, major)
            };
            let skip = self.clearance_of(i, j);
            if skip == 0 {
                return hit(i, j);
            }
            // The ray's next cells are one column per step and at most one row per step
            // away, so the next `skip - 1` cannot stop it (the cell jumped to is looked at).
            let jump = (skip - 1).max(1);
            if jump >= (b - major).abs() {
                return max_range;
            }
            k += jump;
        }
    }
}

/// A ray's minor cell coordinate as a function of its steps along the major axis,
/// `floor(start + k * slope)`, in fixed point with 32 fractional bits: an integer multiply
/// and shift per cell looked at instead of a floating multiply and a rounding down, which
/// dominated the ray casting. (Only a start within the grid is given, and a slope of at most
/// 1, so nothing overflows over any grid's length.)
#[derive(Clone, Copy, Debug)]
struct Line {
    start: i64,
    slope: i64,
}

impl Line {
    const ONE: f64 = 4_294_967_296.0;

    fn new(start: f64, slope: f64) -> Line {
        Line {
            start: floor(start * Line::ONE),
            slope: floor(slope * Line::ONE + 0.5),
        }
    }

    /// The minor coordinate `k` steps along (rounded down).
    #[inline]
    fn at(&self, k: i64) -> i64 {
        (self.start + k * self.slope) >> 32
    }
}

/// The length of a (`di`, `dj`) cell offset in cells: the square root of the exact integer
/// sum of squares (as correctly rounded as `hypot`, and without its library call).
fn cell_distance(di: i64, dj: i64) -> f64 {
    ((di * di + dj * dj) as f64).sqrt()
}

/// Chessboard distances (capped at 255) from every cell to the nearest cell that is not free or
/// outside the grid: the two-pass chamfer transform with the 3 x 3 mask, which is exact for
/// the chessboard metric, started from each cell's distance to the outside.
fn clearance(width: usize, height: usize, cells: &[i8]) -> Vec<u8> {
    let cap = |d: usize| d.min(255) as u8;
    let mut d: Vec<u8> = (0..width * height)
        .map(|k| {
            let (i, j) = (k % width, k / width);
            if cells[k] >= 0 {
                0
            } else {
                cap((i + 1).min(j + 1).min(width - i).min(height - j))
            }
        })
        .collect();
    let near = |d: &[u8], k: usize| d[k].saturating_add(1);
    for j in 0..height {
        for i in 0..width {
            let k = i + j * width;
            let mut v = d[k];
            if i > 0 {
                v = v.min(near(&d, k - 1));
            }
            if j > 0 {
                v = v.min(near(&d, k - width));
                if i > 0 {
                    v = v.min(near(&d, k - width - 1));
                }
                if i + 1 < width {
                    v = v.min(near(&d, k - width + 1));
                }
            }
            d[k] = v;
        }
    }
    for j in (0..height).rev() {
        for i in (0..width).rev() {
            let k = i + j * width;
            let mut v = d[k];
            if i + 1 < width {
                v = v.min(near(&d, k + 1));
            }
            if j + 1 < height {
                v = v.min(near(&d, k + width));
                if i + 1 < width {
                    v = v.min(near(&d, k + width + 1));
                }
                if i > 0 {
                    v = v.min(near(&d, k + width - 1));
                }
            }
            d[k] = v;
        }
    }
    d
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use player_proto::Pose2d;
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

    /// A `size` x `size` m room of `scale` m cells centred on the origin: free inside, its
    /// outermost ring of cells occupied.
    pub(crate) fn room_grid(size: f64, scale: f64) -> OccupancyGrid {
        let n = (size / scale).round() as u32;
        let origin = Pose2d {
            px: -size / 2.0,
            py: -size / 2.0,
            pa: 0.0,
        };
        let mut g = OccupancyGrid::new(n, n, scale as f32, origin, OccupancyGrid::FREE).unwrap();
        for k in 0..i64::from(n) {
            let last = i64::from(n) - 1;
            for (i, j) in [(k, 0), (k, last), (0, k), (last, k)] {
                g.set(i, j, OccupancyGrid::OCCUPIED);
            }
        }
        g
    }

    /// [`room_grid`] as amcl's map.
    pub(crate) fn room(size: f64, scale: f64) -> OccupancyMap {
        OccupancyMap::new(room_grid(size, scale)).unwrap()
    }

    /// The cell-by-cell ray cast as first written, the reference for the skipping one.
    fn reference_range(m: &OccupancyMap, ox: f64, oy: f64, oa: f64, max_range: f64) -> f64 {
        let stops = |i: i64, j: i64| m.get(i, j).is_none_or(|v| v >= 0);
        let (s, c) = oa.sin_cos();
        let (ai, aj) = (m.column(ox), m.row(oy));
        let hit = |i: i64, j: i64| cell_distance(i - ai, j - aj) * m.scale;
        if c.abs() > s.abs() {
            let bi = m.column(ox + max_range * c);
            if bi != ai && stops(ai, aj) {
                return 0.0;
            }
            let line = Line::new((oy - m.centre_y) / m.scale + 0.5, s / c);
            let step = if ai < bi { 1 } else { -1 };
            let mut i = ai;
            while i != bi {
                let j = line.at(i - ai) + m.height / 2;
                if stops(i, j) {
                    return hit(i, j);
                }
                i += step;
            }
        } else {
            let bj = m.row(oy + max_range * s);
            if bj != aj && stops(ai, aj) {
                return 0.0;
            }
            let line = Line::new((ox - m.centre_x) / m.scale + 0.5, c / s);
            let step = if aj < bj { 1 } else { -1 };
            let mut j = aj;
            while j != bj {
                let i = line.at(j - aj) + m.width / 2;
                if stops(i, j) {
                    return hit(i, j);
                }
                j += step;
            }
        }
        max_range
    }

    /// A grid with random walls, blobs and unknown cells.
    fn random_map(seed: u64, w: u32, h: u32, density: f64) -> OccupancyMap {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let origin = Pose2d {
            px: -1.3,
            py: 0.7,
            pa: 0.0,
        };
        let mut g = OccupancyGrid::new(w, h, 0.05, origin, OccupancyGrid::FREE).unwrap();
        for j in 0..i64::from(h) {
            for i in 0..i64::from(w) {
                if rng.random_bool(density) {
                    let v = if rng.random_bool(0.8) { 1 } else { 0 };
                    g.set(i, j, v);
                }
            }
        }
        // A few straight walls, so long rays end on them.
        for _ in 0..4 {
            let (i, j) = (rng.random_range(0..w), rng.random_range(0..h));
            for k in 0..w.max(h) {
                if rng.random_bool(0.5) {
                    g.set(i64::from(i), i64::from(k), OccupancyGrid::OCCUPIED);
                } else {
                    g.set(i64::from(k), i64::from(j), OccupancyGrid::OCCUPIED);
                }
            }
        }
        OccupancyMap::new(g).unwrap()
    }

    #[test]
    fn the_clearance_is_the_chessboard_distance_to_a_stopping_cell() {
        for (seed, w, h, density) in [(1, 30, 20, 0.02), (2, 7, 41, 0.1), (3, 1, 1, 0.0)] {
            let m = random_map(seed, w, h, density);
            let (w, h) = (i64::from(w), i64::from(h));
            for j in 0..h {
                for i in 0..w {
                    // Brute force over every stopping cell, the ring outside included.
                    let mut best = i64::MAX;
                    for jj in -1..=h {
                        for ii in -1..=w {
                            if m.get(ii, jj).is_none_or(|v| v >= 0) {
                                best = best.min((ii - i).abs().max((jj - j).abs()));
                            }
                        }
                    }
                    assert_eq!(m.clearance_of(i, j), best.min(255), "({i}, {j})");
                }
            }
        }
    }

    #[test]
    fn skipping_open_space_gives_the_cell_by_cell_ranges() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for (seed, w, h, density) in [
            (1, 400, 300, 0.0005),
            (2, 120, 90, 0.01),
            (3, 60, 700, 0.002),
            (4, 300, 300, 0.0),
        ] {
            let m = random_map(seed, w, h, density);
            let (xw, yh) = (f64::from(w) * 0.05, f64::from(h) * 0.05);
            for _ in 0..20_000 {
                // Origins on and off the map, any direction, short and long rays.
                let x = -1.3 + rng.random_range(-0.1..1.1) * xw;
                let y = 0.7 + rng.random_range(-0.1..1.1) * yh;
                let a = rng.random_range(-4.0..4.0);
                let r = [0.3, 8.0, 40.0][rng.random_range(0..3)];
                let want = reference_range(&m, x, y, a, r);
                let got = m.calc_range(x, y, a, r);
                assert_eq!(got.to_bits(), want.to_bits(), "({x}, {y}, {a}) up to {r}");
            }
        }
    }

    #[test]
    fn the_fixed_point_line_rounds_down_as_the_floating_one_but_at_boundaries() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let mut differ = 0;
        for _ in 0..20_000 {
            let start = rng.random_range(-600.0..600.0);
            let slope = rng.random_range(-1.0..=1.0);
            let line = Line::new(start, slope);
            for k in [-700i64, -3, 0, 1, 2, 77, 700] {
                let exact = start + k as f64 * slope;
                let (want, got) = (floor(exact), line.at(k));
                if want != got {
                    // Only where the floating value is within rounding of a cell boundary.
                    assert!((exact - exact.round()).abs() < 1e-6, "{start} {slope} {k}");
                    differ += 1;
                }
            }
        }
        assert!(differ < 50, "{differ}");
    }

    #[test]
    fn floor_rounds_down() {
        for x in [0.0, 0.5, -0.5, -1.0, 1.0, -2.7, 3.2, 1e12, -1e12] {
            assert_eq!(floor(x), x.floor() as i64, "{x}");
        }
    }

    #[test]
    fn world_points_map_to_cells_as_upstream() {
        // 10 x 10 cells of 0.5 m from (-2.5, -2.5): centre (0, 0), half width 5.
        let origin = Pose2d {
            px: -2.5,
            py: -2.5,
            pa: 0.0,
        };
        let grid = OccupancyGrid::new(10, 10, 0.5, origin, OccupancyGrid::UNKNOWN).unwrap();
        let m = OccupancyMap::new(grid).unwrap();
        assert_eq!(m.column(0.0), 5);
        assert_eq!(m.column(0.24), 5);
        assert_eq!(m.column(0.26), 6);
        assert_eq!(m.column(-0.26), 4);
        assert_eq!(m.row(-2.5), 0);
        assert_eq!(m.get(10, 0), None);
        assert_eq!(m.get(0, 0), Some(0));
    }

    #[test]
    fn rays_stop_at_walls_in_every_direction() {
        let m = room(4.0, 0.05); // walls' inner faces about 1.95 m from the centre
        for a in [0.0, FRAC_PI_2, PI, -FRAC_PI_2] {
            let r = m.calc_range(0.0, 0.0, a, 10.0);
            assert!((r - 1.95).abs() <= 0.06, "{a}: {r}");
        }
        // Diagonally the wall is sqrt(2) times further.
        let r = m.calc_range(0.0, 0.0, FRAC_PI_4 + 0.01, 10.0);
        assert!((r - 1.95 * 2f64.sqrt()).abs() < 0.1, "{r}");
        // A short ray ends in free space at its maximum.
        assert_eq!(m.calc_range(0.0, 0.0, 0.3, 1.0), 1.0);
        // From off the map the first cell already stops the ray.
        assert_eq!(m.calc_range(50.0, 0.0, 0.0, 5.0), 0.0);
    }

    #[test]
    fn unknown_cells_stop_rays() {
        let mut g = room_grid(4.0, 0.1);
        g.set(30, 20, OccupancyGrid::UNKNOWN);
        let m = OccupancyMap::new(g).unwrap();
        let r = m.calc_range(0.0, 0.0, 0.0, 10.0);
        assert!((r - 1.0).abs() < 0.11, "{r}");
    }

    #[test]
    fn a_map_without_a_positive_scale_is_refused() {
        for scale in [0.0, -0.1, f32::NAN] {
            let g = OccupancyGrid::new(2, 2, scale, Pose2d::default(), 0).unwrap();
            let e = OccupancyMap::new(g).unwrap_err().to_string();
            assert!(e.contains("scale"), "{e}");
        }
    }
}
