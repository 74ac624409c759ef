//! Occupancy rasters: which square cells of an axis-aligned grid polygons cover, for serving a
//! model as a grid map ([`crate::World::rasterize`]).
//!
//! A cell is covered when a polygon overlaps it by more than a sliver: the polygon meets the
//! cell shrunk by [`SLIVER`] of its side on every edge. So a polygon whose edges lie on cell
//! boundaries (a bitmap's pixels on a grid of the same pitch) covers exactly its cells despite
//! rounding, and a wall thinner than a cell still covers every cell it crosses. The test is
//! exact up to that margin: a cell is covered when a polygon edge crosses its shrunk square, or
//! when its centre is inside the polygon (then the whole square is, if no edge crosses it).
//! Two-point blocks are segments: only the crossing test applies.
//!
//! Stage 4.1.1's own `Model::Rasterize` draws only block outlines, one DDA line per edge from
//! floored end points (the cells right of and above a block's far edges included); a map of a
//! model wants its blocks solid, so we fill them.

/// The margin, as a fraction of a cell's side, a polygon must reach into a cell to cover it.
pub const SLIVER: f64 = 1e-6;

/// A boolean raster over an axis-aligned rectangle of the plane.
#[derive(Clone, Debug, PartialEq)]
pub struct Raster {
    /// Columns.
    pub width: usize,
    /// Rows; row 0 is the lowest (smallest y).
    pub height: usize,
    /// Side of a square cell (m).
    pub cell: f64,
    /// World position of the lower-left corner of cell (0, 0).
    pub origin: [f64; 2],
    /// `width × height` cells, row by row from row 0 (index `width × j + i`): true where a
    /// polygon covers the cell.
    pub cells: Vec<bool>,
}

impl Raster {
    /// An empty raster of `width × height` cells of side `cell` whose lower-left corner is at
    /// `origin`.
    pub fn new(origin: [f64; 2], cell: f64, width: usize, height: usize) -> Raster {
        Raster {
            width,
            height,
            cell,
            origin,
            cells: vec![false; width * height],
        }
    }

    /// Whether cell (i, j) is covered (false off the raster).
    pub fn get(&self, i: usize, j: usize) -> bool {
        i < self.width && j < self.height && self.cells[j * self.width + i]
    }

    /// Covers the cells `polygon` overlaps (a closed polygon; two points are a segment).
    pub fn fill_polygon(&mut self, polygon: &[[f64; 2]]) {
        let n = polygon.len();
        if n == 0 || self.width == 0 || self.height == 0 {
            return;
        }
        for k in 0..n {
            let (a, b) = (polygon[k], polygon[(k + 1) % n]);
            if n == 2 && k == 1 {
                break; // a segment has one edge
            }
            self.cover_segment(a, b);
        }
        if n >= 3 {
            self.cover_centres_inside(polygon);
        }
    }

    /// Range of cell indices along one axis whose shrunk extent meets `[lo, hi]` (world), for
    /// an axis starting at `start` with `count` cells.
    fn cells_meeting(&self, start: f64, count: usize, lo: f64, hi: f64) -> Option<(usize, usize)> {
        let eps = SLIVER * self.cell;
        // Cell k's shrunk extent is [start + k·cell + eps, start + (k+1)·cell − eps].
        let first = ((lo - start + eps) / self.cell - 1.0).ceil().max(0.0);
        let last = ((hi - start - eps) / self.cell)
            .floor()
            .min(count as f64 - 1.0);
        (first <= last).then_some((first as usize, last as usize))
    }

    /// Covers the cells whose shrunk square the segment `a`–`b` meets.
    fn cover_segment(&mut self, a: [f64; 2], b: [f64; 2]) {
        let [x0, y0] = self.origin;
        let eps = SLIVER * self.cell;
        let Some((j0, j1)) = self.cells_meeting(y0, self.height, a[1].min(b[1]), a[1].max(b[1]))
        else {
            return;
        };
        for j in j0..=j1 {
            // The part of the segment inside row j's shrunk band.
            let lo = y0 + j as f64 * self.cell + eps;
            let hi = y0 + (j + 1) as f64 * self.cell - eps;
            let dy = b[1] - a[1];
            let (xa, xb) = if dy == 0.0 {
                (a[0], b[0])
            } else {
                let t0 = ((lo - a[1]) / dy).clamp(0.0, 1.0);
                let t1 = ((hi - a[1]) / dy).clamp(0.0, 1.0);
                let x = |t: f64| a[0] + t * (b[0] - a[0]);
                (x(t0), x(t1))
            };
            if let Some((i0, i1)) = self.cells_meeting(x0, self.width, xa.min(xb), xa.max(xb)) {
                let row = j * self.width;
                self.cells[row + i0..=row + i1].fill(true);
            }
        }
    }

    /// Covers the cells whose centre is inside `polygon` (even-odd rule, scanning each row's
    /// centre line).
    fn cover_centres_inside(&mut self, polygon: &[[f64; 2]]) {
        let [x0, y0] = self.origin;
        let (mut ymin, mut ymax) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in polygon {
            ymin = ymin.min(p[1]);
            ymax = ymax.max(p[1]);
        }
        // Rows whose centre line y0 + (j + ½)·cell lies in [ymin, ymax].
        let first = ((ymin - y0) / self.cell - 0.5).ceil().max(0.0);
        let last = ((ymax - y0) / self.cell - 0.5)
            .floor()
            .min(self.height as f64 - 1.0);
        if first > last {
            return;
        }
        let mut xs = Vec::new();
        for j in first as usize..=last as usize {
            let y = y0 + (j as f64 + 0.5) * self.cell;
            xs.clear();
            for k in 0..polygon.len() {
                let (a, b) = (polygon[k], polygon[(k + 1) % polygon.len()]);
                // Half-open in y, so a vertex on the line counts once.
                if (a[1] <= y) != (b[1] <= y) {
                    xs.push(a[0] + (y - a[1]) / (b[1] - a[1]) * (b[0] - a[0]));
                }
            }
            xs.sort_by(f64::total_cmp);
            for pair in xs.chunks_exact(2) {
                // Cells whose centre x0 + (i + ½)·cell is in [pair[0], pair[1]].
                let i0 = ((pair[0] - x0) / self.cell - 0.5).ceil().max(0.0);
                let i1 = ((pair[1] - x0) / self.cell - 0.5)
                    .floor()
                    .min(self.width as f64 - 1.0);
                if i0 <= i1 {
                    let row = j * self.width;
                    self.cells[row + i0 as usize..=row + i1 as usize].fill(true);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rows from the top, `#` covered.
    fn picture(r: &Raster) -> Vec<String> {
        (0..r.height)
            .rev()
            .map(|j| {
                (0..r.width)
                    .map(|i| if r.get(i, j) { '#' } else { '.' })
                    .collect()
            })
            .collect()
    }

    fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Vec<[f64; 2]> {
        vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
    }

    #[test]
    fn cell_aligned_rectangles_cover_exactly_their_cells() {
        // A 0.1 m grid; the rectangle covers columns 1..=3, rows 1..=2, its edges on cell
        // boundaries computed with rounding error (0.1 · 3 = 0.30000000000000004).
        let mut r = Raster::new([0.0, 0.0], 0.1, 5, 4);
        r.fill_polygon(&rect(0.1, 0.1, 0.1 * 4.0, 0.1 * 3.0));
        assert_eq!(picture(&r), [".....", ".###.", ".###.", "....."]);
        // Touching rectangles (a bitmap's runs) leave no gap and spill nowhere.
        let mut r = Raster::new([-1.0, -1.0], 0.5, 4, 2);
        r.fill_polygon(&rect(-1.0, -1.0, -0.5, 0.0));
        r.fill_polygon(&rect(-0.5, -1.0, 0.5, -0.5));
        assert_eq!(picture(&r), ["#...", "###."]);
    }

    #[test]
    fn partly_covered_cells_count_and_thin_walls_survive() {
        // A rectangle from 0.25 to 0.75 of a 1 m grid covers the one cell it is in; one from
        // 0.5 to 1.5 the two it straddles.
        let mut r = Raster::new([0.0, 0.0], 1.0, 3, 1);
        r.fill_polygon(&rect(0.25, 0.25, 0.75, 0.75));
        assert_eq!(picture(&r), ["#.."]);
        let mut r = Raster::new([0.0, 0.0], 1.0, 3, 1);
        r.fill_polygon(&rect(1.5, 0.1, 2.5, 0.2));
        assert_eq!(picture(&r), [".##"]);
        // A 1 cm wall inside one column of a 10 cm grid.
        let mut r = Raster::new([0.0, 0.0], 0.1, 4, 3);
        r.fill_polygon(&rect(0.22, 0.0, 0.23, 0.3));
        assert_eq!(picture(&r), ["..#.", "..#.", "..#."]);
        // A 1 cm wall along the diagonal: near each grid corner it reaches into the cells
        // beside the diagonal ones too.
        let mut r = Raster::new([0.0, 0.0], 0.1, 4, 4);
        r.fill_polygon(&[
            [0.0, 0.0],
            [0.01, 0.0],
            [0.4, 0.39],
            [0.4, 0.4],
            [0.39, 0.4],
        ]);
        assert_eq!(picture(&r), ["..##", ".###", "###.", "##.."]);
        // A two-point block is a segment.
        let mut r = Raster::new([0.0, 0.0], 1.0, 3, 3);
        r.fill_polygon(&[[0.5, 2.5], [2.5, 2.5]]);
        assert_eq!(picture(&r), ["###", "...", "..."]);
    }

    #[test]
    fn interiors_are_filled() {
        let mut r = Raster::new([0.0, 0.0], 1.0, 7, 7);
        r.fill_polygon(&rect(0.5, 0.5, 6.5, 6.5));
        assert!(r.cells.iter().all(|&c| c), "{:?}", picture(&r));
        // A triangle.
        let mut r = Raster::new([0.0, 0.0], 1.0, 5, 5);
        r.fill_polygon(&[[0.0, 0.0], [5.0, 0.0], [0.0, 5.0]]);
        assert_eq!(picture(&r), ["#....", "##...", "###..", "####.", "#####"]);
    }

    #[test]
    fn polygons_beyond_the_raster_are_clipped() {
        let mut r = Raster::new([0.0, 0.0], 1.0, 2, 2);
        r.fill_polygon(&rect(-10.0, -10.0, 10.0, 0.5));
        assert_eq!(picture(&r), ["..", "##"]);
        r.fill_polygon(&rect(5.0, 5.0, 6.0, 6.0));
        assert_eq!(picture(&r), ["..", "##"]);
        let mut empty = Raster::new([0.0, 0.0], 1.0, 0, 0);
        empty.fill_polygon(&rect(0.0, 0.0, 1.0, 1.0));
        assert!(empty.cells.is_empty());
    }
}
