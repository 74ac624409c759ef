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

use player_proto::MapInfo;

use super::AmclError;

/// Largest map accepted, in cells (a 16,384 x 16,384 grid; bigger is surely a bad request).
pub const MAX_CELLS: usize = 1 << 28;

/// `x` rounded down, as `x.floor() as i64` but without the library call `floor` is on
/// baseline x86-64 (ray casting does this once per cell visited).
fn floor(x: f64) -> i64 {
    let t = x as i64;
    if (t as f64) > x { t - 1 } else { t }
}

/// A grid of occupancy values with its placement.
#[derive(Clone, Debug, PartialEq)]
pub struct OccupancyMap {
    centre_x: f64,
    centre_y: f64,
    scale: f64,
    width: i64,
    height: i64,
    cells: Vec<i8>,
}

impl OccupancyMap {
    /// A map of `width` x `height` cells of `scale` metres whose cell (0, 0) has its corner at
    /// `origin` (as `player_map_info_t` places maps), all cells unknown.
    pub fn new(
        scale: f64,
        width: usize,
        height: usize,
        origin: (f64, f64),
    ) -> Result<OccupancyMap, AmclError> {
        let n = width.checked_mul(height).filter(|&n| n <= MAX_CELLS);
        let Some(n) = n else {
            return Err(AmclError::MapTooLarge { width, height });
        };
        if !(scale > 0.0 && scale.is_finite()) {
            return Err(AmclError::MapScale(scale));
        }
        Ok(OccupancyMap {
            centre_x: origin.0 + scale * width as f64 / 2.0,
            centre_y: origin.1 + scale * height as f64 / 2.0,
            scale,
            width: width as i64,
            height: height as i64,
            cells: vec![0; n],
        })
    }

    /// An all-unknown map shaped as a map device's GET_INFO answer describes.
    pub fn from_info(info: &MapInfo) -> Result<OccupancyMap, AmclError> {
        OccupancyMap::new(
            f64::from(info.scale),
            info.width as usize,
            info.height as usize,
            (info.origin.px, info.origin.py),
        )
    }

    /// Width in cells.
    pub fn width(&self) -> usize {
        self.width as usize
    }

    /// Height in cells.
    pub fn height(&self) -> usize {
        self.height as usize
    }

    /// Metres per cell.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// Copies a `w` x `h` tile of cells (rows first, as GET_DATA answers) to column `col`,
    /// row `row`. A tile that does not fit, or whose cell count is not `w * h`, is an error.
    pub fn set_tile(
        &mut self,
        col: usize,
        row: usize,
        w: usize,
        h: usize,
        data: &[i8],
    ) -> Result<(), AmclError> {
        let fits = col.checked_add(w).is_some_and(|e| e <= self.width())
            && row.checked_add(h).is_some_and(|e| e <= self.height());
        if !fits || data.len() != w * h {
            return Err(AmclError::BadTile {
                col,
                row,
                width: w,
                height: h,
                cells: data.len(),
            });
        }
        for (j, line) in data.chunks_exact(w.max(1)).take(h).enumerate() {
            let start = (row + j) * self.width() + col;
            self.cells[start..start + w].copy_from_slice(line);
        }
        Ok(())
    }

    /// Sets one cell (for building maps by hand).
    pub fn set(&mut self, i: usize, j: usize, value: i8) {
        let w = self.width();
        self.cells[j * w + i] = value;
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
        Some(self.cells[(j * self.width + i) as usize])
    }

    /// Whether a ray stops in cell (`i`, `j`): off the grid, unknown or occupied.
    fn stops(&self, i: i64, j: i64) -> bool {
        self.get(i, j).is_none_or(|v| v >= 0)
    }

    /// The range a perfect sensor at (`ox`, `oy`) looking along `oa` would read, up to
    /// `max_range`: cells are visited along the ray's major axis, one per column (or row), and
    /// the range is the cell distance from the start cell to the first cell that stops the ray
    /// (upstream's `map_calc_range`; the minor coordinate is stepped by the slope instead of
    /// recomputed from world coordinates, which picks the same cells but for rounding at
    /// exact cell boundaries).
    pub fn calc_range(&self, ox: f64, oy: f64, oa: f64, max_range: f64) -> f64 {
        let (s, c) = oa.sin_cos();
        let (ai, aj) = (self.column(ox), self.row(oy));
        let hit = |i: i64, j: i64| ((i - ai) as f64).hypot((j - aj) as f64) * self.scale;
        if c.abs() > s.abs() {
            let bi = self.column(ox + max_range * c);
            // Row of the ray at column ai + k: floor(j0 + k * slope) + height / 2.
            let j0 = (oy - self.centre_y) / self.scale + 0.5;
            let slope = oa.tan();
            let step = if ai < bi { 1 } else { -1 };
            let mut i = ai;
            while i != bi {
                let j = floor(j0 + (i - ai) as f64 * slope) + self.height / 2;
                if self.stops(i, j) {
                    return hit(i, j);
                }
                i += step;
            }
        } else {
            let bj = self.row(oy + max_range * s);
            let i0 = (ox - self.centre_x) / self.scale + 0.5;
            let slope = (std::f64::consts::FRAC_PI_2 - oa).tan();
            let step = if aj < bj { 1 } else { -1 };
            let mut j = aj;
            while j != bj {
                let i = floor(i0 + (j - aj) as f64 * slope) + self.width / 2;
                if self.stops(i, j) {
                    return hit(i, j);
                }
                j += step;
            }
        }
        max_range
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

    /// A `size` x `size` m room of `scale` m cells centred on the origin: free inside, its
    /// outermost ring of cells occupied.
    pub(crate) fn room(size: f64, scale: f64) -> OccupancyMap {
        let n = (size / scale).round() as usize;
        let mut m = OccupancyMap::new(scale, n, n, (-size / 2.0, -size / 2.0)).unwrap();
        for j in 0..n {
            for i in 0..n {
                let rim = i == 0 || j == 0 || i == n - 1 || j == n - 1;
                m.set(i, j, if rim { 1 } else { -1 });
            }
        }
        m
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
        let m = OccupancyMap::new(0.5, 10, 10, (-2.5, -2.5)).unwrap();
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
        let mut m = room(4.0, 0.1);
        m.set(30, 20, 0);
        let r = m.calc_range(0.0, 0.0, 0.0, 10.0);
        assert!((r - 1.0).abs() < 0.11, "{r}");
    }

    #[test]
    fn tiles_land_where_they_say_and_bad_ones_are_refused() {
        let mut m = OccupancyMap::new(1.0, 4, 3, (0.0, 0.0)).unwrap();
        m.set_tile(1, 1, 2, 2, &[1, 2, 3, 4]).unwrap();
        assert_eq!(m.get(1, 1), Some(1));
        assert_eq!(m.get(2, 1), Some(2));
        assert_eq!(m.get(1, 2), Some(3));
        assert_eq!(m.get(2, 2), Some(4));
        assert!(
            m.set_tile(3, 0, 2, 1, &[1, 1]).is_err(),
            "past the right edge"
        );
        assert!(m.set_tile(0, 0, 2, 2, &[1, 1, 1]).is_err(), "wrong count");
        assert!(OccupancyMap::new(1.0, 1 << 20, 1 << 20, (0.0, 0.0)).is_err());
        assert!(OccupancyMap::new(0.0, 2, 2, (0.0, 0.0)).is_err());
    }
}
