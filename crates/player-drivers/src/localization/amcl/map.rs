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

/// A map device's grid, placed as amcl places it.
#[derive(Clone, Debug, PartialEq)]
pub struct OccupancyMap {
    grid: OccupancyGrid,
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
        Ok(OccupancyMap {
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
