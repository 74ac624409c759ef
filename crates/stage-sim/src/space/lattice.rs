//! The cell layout both grids share (the static edges' and the moving bodies'): where a point
//! falls, the box the cells cover, and the cell a fan of rays starts in.

use crate::geom::{Aabb, floor_i32};

/// `nx × ny` square cells of side `cell` from `origin`; cell `(x, y)` is index `y·nx + x`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Lattice {
    pub(super) origin: [f64; 2],
    pub(super) cell: f64,
    pub(super) inv_cell: f64,
    pub(super) nx: i32,
    pub(super) ny: i32,
}

impl Lattice {
    pub(super) fn new(origin: [f64; 2], cell: f64, nx: i32, ny: i32) -> Lattice {
        Lattice {
            origin,
            cell,
            inv_cell: 1.0 / cell,
            nx,
            ny,
        }
    }

    /// The cell `p` falls in (outside the grid too: negative or past `nx`/`ny`).
    #[inline]
    pub(super) fn cell_of(&self, p: [f64; 2]) -> [i32; 2] {
        [
            floor_i32((p[0] - self.origin[0]) * self.inv_cell),
            floor_i32((p[1] - self.origin[1]) * self.inv_cell),
        ]
    }

    /// The cells box `b` covers, as `[x0, y0, x1, y1]`, when they all lie inside the grid.
    pub(super) fn span_of(&self, b: &Aabb) -> Option<[i32; 4]> {
        let lo = self.cell_of(b.min);
        let hi = self.cell_of(b.max);
        (lo[0] >= 0 && lo[1] >= 0 && hi[0] < self.nx && hi[1] < self.ny)
            .then_some([lo[0], lo[1], hi[0], hi[1]])
    }

    /// The cell where the walk of the ray `o + t·d` (`inv` = 1/d) begins: `start` when the
    /// caller knows the cell holding `o` ([`Lattice::cell_inside`]), else the cell where the
    /// ray enters the grid within `limit` (`None`: it does not).
    #[inline(always)]
    pub(super) fn walk_start(
        &self,
        o: [f64; 2],
        d: [f64; 2],
        inv: [f64; 2],
        limit: f64,
        start: Option<[i32; 2]>,
    ) -> Option<[i32; 2]> {
        if start.is_some() {
            return start;
        }
        let t0 = self.bounds().ray_entry(o, inv, limit)?;
        let c = self.cell_of([o[0] + d[0] * t0, o[1] + d[1] * t0]);
        Some([c[0].clamp(0, self.nx - 1), c[1].clamp(0, self.ny - 1)])
    }

    /// The indices of the cells `x0..=x1 × y0..=y1` (a span as `[x0, y0, x1, y1]`, inside
    /// the grid), row by row.
    pub(super) fn cells_in(&self, [x0, y0, x1, y1]: [i32; 4]) -> impl Iterator<Item = usize> {
        let nx = self.nx;
        (y0..=y1).flat_map(move |y| (x0..=x1).map(move |x| (y * nx + x) as usize))
    }

    /// The box the cells cover.
    pub(super) fn bounds(&self) -> Aabb {
        Aabb {
            min: self.origin,
            max: [
                self.origin[0] + self.nx as f64 * self.cell,
                self.origin[1] + self.ny as f64 * self.cell,
            ],
        }
    }

    /// The cell holding `p` when `p` lies strictly inside the grid: where every ray from `p`
    /// starts its walk (the cell a walk finds for itself), worked out once for a fan of rays
    /// from one origin.
    pub(super) fn cell_inside(&self, p: [f64; 2]) -> Option<[i32; 2]> {
        let b = self.bounds();
        let inside = (0..2).all(|k| p[k] > b.min[k] && p[k] < b.max[k]);
        let c = self.cell_of(p);
        (inside && c[0] >= 0 && c[0] < self.nx && c[1] >= 0 && c[1] < self.ny).then_some(c)
    }
}
