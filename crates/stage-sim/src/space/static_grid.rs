//! The static edges in a uniform grid, walked cell by cell by rays (Stage's own approach, but
//! exact: cells only narrow down which edges a ray is tested against).
//!
//! * Every edge of every static block is stored, as its two end points, in each cell that a
//!   part of it a ray can meet first (its exposed parts, see `exposed`) comes within
//!   [`EDGE_PAD`] of (cell lists in one flat array), so a ray touching such a part anywhere — a
//!   corner included, floating-point error included — visits a cell that lists the edge.
//! * Each cell also stores its *clearance* `k`: the `(2k−1)²` block of cells centred on it holds
//!   no edge. A ray in such a cell jumps straight to where it leaves that block, so rays cross
//!   open space in a few steps whatever the cell size.
//! * A walk visits cells in ray order and stops once a cell begins beyond the best hit so far;
//!   the answer is the exact lexicographic minimum of (distance, model, block) over the edges
//!   tested, so it does not depend on the cell size or on the order of the lists.

use super::lattice::{Lattice, flat_lists};
use crate::geom::{Aabb, floor_i32};

/// How far (m) beyond its cells an edge may lie and still be listed there: far above the
/// floating-point error of the cell walk (≈1e-13 m in a 1 km world), far below any geometry.
const EDGE_PAD: f64 = 1e-7;
/// Most cells a grid may have (memory: ~5 bytes per cell plus the lists).
const MAX_CELLS: f64 = 4.0e6;

/// One edge, with the index of its static block.
#[derive(Clone, Copy, Debug)]
pub(super) struct GridEdge {
    pub a: [f64; 2],
    pub b: [f64; 2],
    pub block: u32,
}

/// An edge and the parts of it (sub-segments) that decide which cells list it.
pub(super) struct ListedEdge {
    pub edge: GridEdge,
    pub parts: Vec<[[f64; 2]; 2]>,
}

/// See the module docs.
pub(super) struct StaticGrid {
    pub(super) lat: Lattice,
    /// Cell `c`'s edges are `edges[first[c]..first[c + 1]]`.
    first: Vec<u32>,
    edges: Vec<GridEdge>,
    /// Clearance per cell (0: the cell lists edges), capped at 255.
    clear: Vec<u8>,
    /// Whether any part of any static edge (exposed or not) comes near the cell: where
    /// contacts are possible (see [`StaticGrid::no_edge_near`]).
    touched: Vec<bool>,
}

impl StaticGrid {
    /// Builds the grid over `edges`, each listed in the cells its parts come near; `None` when
    /// there are none.
    pub fn build(listed: &[ListedEdge]) -> Option<StaticGrid> {
        if listed.is_empty() {
            return None;
        }
        let edges = || listed.iter().map(|l| &l.edge);
        let mut bounds = Aabb::EMPTY;
        let mut len = 0.0;
        for e in edges() {
            bounds.add(e.a);
            bounds.add(e.b);
            len += ((e.b[0] - e.a[0]).powi(2) + (e.b[1] - e.a[1]).powi(2)).sqrt();
        }
        // a margin so that every edge (padded) lies strictly inside
        let margin = 1e-3 + 1e-9 * bounds.max[0].abs().max(bounds.max[1].abs());
        let origin = [bounds.min[0] - margin, bounds.min[1] - margin];
        let w = bounds.max[0] - bounds.min[0] + 2.0 * margin;
        let h = bounds.max[1] - bounds.min[1] + 2.0 * margin;
        // cells half the mean edge length: bitmap floorplans are many rectangles whose edges
        // crowd wall cells, and the empty-space jumps make the extra open cells nearly free
        // (callgrind, instructions per step against 2× the mean: simple.world −17%,
        // hospital −6%, cave −3%)
        let mean = len / listed.len() as f64;
        let mut cell = (0.5 * mean).clamp(0.05, 4.0);
        let min_cell = (w * h / MAX_CELLS).sqrt();
        if cell < min_cell {
            cell = min_cell;
        }
        if !cell.is_finite() || cell <= 0.0 {
            return None;
        }
        let nx = ((w / cell).ceil() as i32).max(1);
        let ny = ((h / cell).ceil() as i32).max(1);
        let lat = Lattice::new(origin, cell, nx, ny);
        let cells = (nx * ny) as usize;
        let mut g = StaticGrid {
            lat,
            first: Vec::new(),
            edges: Vec::new(),
            clear: Vec::new(),
            touched: vec![false; cells],
        };
        let mut scratch = Vec::new();
        (g.first, g.edges) = flat_lists(cells, |emit| {
            for l in listed {
                g.cells_of_parts(&l.parts, &mut scratch);
                scratch.iter().for_each(|&c| emit(c, l.edge));
            }
        });
        let count: Vec<u32> = g.first.windows(2).map(|w| w[1] - w[0]).collect();
        g.clear = chebyshev_clearance(&count, nx as usize, ny as usize);
        // every edge whole, the shared sides included: a body may cross those inside a wall
        let mut touched = std::mem::take(&mut g.touched);
        for l in listed {
            g.for_cells_of(l.edge.a, l.edge.b, |c| touched[c] = true);
        }
        g.touched = touched;
        Some(g)
    }

    /// Sets `out` to the cells (each once, in index order) that any of `parts` comes within
    /// [`EDGE_PAD`] of.
    fn cells_of_parts(&self, parts: &[[[f64; 2]; 2]], out: &mut Vec<usize>) {
        out.clear();
        for &[a, b] in parts {
            self.for_cells_of(a, b, |c| out.push(c));
        }
        if parts.len() > 1 {
            out.sort_unstable();
            out.dedup();
        }
    }

    /// Calls `f` with every cell the segment `a–b` comes within [`EDGE_PAD`] of.
    fn for_cells_of(&self, a: [f64; 2], b: [f64; 2], mut f: impl FnMut(usize)) {
        let lo = [a[0].min(b[0]) - EDGE_PAD, a[1].min(b[1]) - EDGE_PAD];
        let hi = [a[0].max(b[0]) + EDGE_PAD, a[1].max(b[1]) + EDGE_PAD];
        let c0 = self.lat.cell_of(lo);
        let c1 = self.lat.cell_of(hi);
        let (x0, y0) = (c0[0].max(0), c0[1].max(0));
        let (x1, y1) = (c1[0].min(self.lat.nx - 1), c1[1].min(self.lat.ny - 1));
        let axis_aligned = a[0] == b[0] || a[1] == b[1];
        for y in y0..=y1 {
            for x in x0..=x1 {
                if !axis_aligned {
                    // a slanted edge only goes into the cells its padded line crosses
                    let mn = [
                        self.lat.origin[0] + x as f64 * self.lat.cell - EDGE_PAD,
                        self.lat.origin[1] + y as f64 * self.lat.cell - EDGE_PAD,
                    ];
                    let mx = [
                        mn[0] + self.lat.cell + 2.0 * EDGE_PAD,
                        mn[1] + self.lat.cell + 2.0 * EDGE_PAD,
                    ];
                    if !segment_meets_box(a, b, mn, mx) {
                        continue;
                    }
                }
                f((y * self.lat.nx + x) as usize);
            }
        }
    }

    /// Walks the cells along the ray `o + t·d` (`inv` = 1/d) from its entry into the grid, in
    /// order, calling `visit` with each non-empty cell's edges; stops when the next cell begins
    /// beyond `limit()` (re-read after each visit) or the ray leaves the grid.
    ///
    /// `start`: the cell of `o` when `o` lies inside the grid (`Lattice::cell_inside`),
    /// worked out once for a fan of rays from one origin; `None` finds where the ray enters.
    #[inline]
    pub fn walk(
        &self,
        o: [f64; 2],
        d: [f64; 2],
        inv: [f64; 2],
        limit: f64,
        start: Option<[i32; 2]>,
        mut visit: impl FnMut(&[GridEdge]) -> f64,
    ) {
        let Some([mut cx, mut cy]) = self.lat.walk_start(o, d, inv, limit, start) else {
            return;
        };
        let mut limit = limit;
        let sx: i32 = if d[0] >= 0.0 { 1 } else { -1 };
        let sy: i32 = if d[1] >= 0.0 { 1 } else { -1 };
        // the x (y) of cell index i's boundary in the walk direction is origin + (i + fx)·cell
        let fx = (sx > 0) as i32;
        let fy = (sy > 0) as i32;
        // the boundary of index i is crossed at t = base + i·step (never, for an axis the ray
        // runs parallel to)
        let axis = |k: usize| -> (f64, f64) {
            if d[k] == 0.0 {
                (f64::INFINITY, 0.0)
            } else {
                ((self.lat.origin[k] - o[k]) * inv[k], self.lat.cell * inv[k])
            }
        };
        let (base_x, step_x) = axis(0);
        let (base_y, step_y) = axis(1);
        let tx_of = |i: i32| -> f64 { base_x + i as f64 * step_x };
        let ty_of = |i: i32| -> f64 { base_y + i as f64 * step_y };
        let (nx, ny) = (self.lat.nx as u32, self.lat.ny as u32);
        loop {
            let c = (cy * self.lat.nx + cx) as usize;
            let k = self.clear[c] as i32;
            let t_next;
            if k <= 1 {
                if k == 0 {
                    let list = &self.edges[self.first[c] as usize..self.first[c + 1] as usize];
                    limit = visit(list);
                }
                let tx = tx_of(cx + fx);
                let ty = ty_of(cy + fy);
                if tx < ty {
                    t_next = tx;
                    cx += sx;
                } else {
                    t_next = ty;
                    cy += sy;
                }
            } else {
                // leave the empty (2k−1)² block around this cell in one jump; the other
                // coordinate never moves backwards, so every step makes progress
                let r = k - 1;
                let tx = tx_of(cx + sx * r + fx);
                let ty = ty_of(cy + sy * r + fy);
                if tx < ty {
                    t_next = tx;
                    let y = floor_i32((o[1] + d[1] * tx - self.lat.origin[1]) * self.lat.inv_cell);
                    cy = if sy > 0 {
                        y.clamp(cy, cy + r)
                    } else {
                        y.clamp(cy - r, cy)
                    };
                    cx += sx * (r + 1);
                } else {
                    t_next = ty;
                    let x = floor_i32((o[0] + d[0] * ty - self.lat.origin[0]) * self.lat.inv_cell);
                    cx = if sx > 0 {
                        x.clamp(cx, cx + r)
                    } else {
                        x.clamp(cx - r, cx)
                    };
                    cy += sy * (r + 1);
                }
            }
            // a small slack keeps hits exactly at a cell boundary (ties) in reach
            // one unsigned compare per axis: a negative index wraps to a huge one
            if cx as u32 >= nx || cy as u32 >= ny || t_next > limit + 1e-9 {
                return;
            }
        }
    }

    /// How far from any point of cell `c` no listed edge lies (0 when unknown): the reach of
    /// the cell's clearance block, less a margin far above rounding. A ray from that cell that
    /// ends closer meets no edge, so its walk can be skipped.
    pub fn open_reach(&self, c: [i32; 2]) -> f64 {
        let k = self.clear[(c[1] * self.lat.nx + c[0]) as usize];
        if k >= 2 {
            f64::from(k - 1) * self.lat.cell - 1e-6
        } else {
            0.0
        }
    }

    /// Whether no part of any static edge can meet the box `b`: every cell `b` (padded)
    /// covers lies inside the grid and no edge comes near it. A body inside such a box touches
    /// no static block, so its contact test needs no BVH query. `false` when unsure (the box
    /// leaves the grid or covers many cells).
    pub fn no_edge_near(&self, b: &Aabb) -> bool {
        const PAD: f64 = 1e-6;
        let padded = Aabb {
            min: [b.min[0] - PAD, b.min[1] - PAD],
            max: [b.max[0] + PAD, b.max[1] + PAD],
        };
        let Some(span @ [x0, y0, x1, y1]) = self.lat.span_of(&padded) else {
            return false;
        };
        (x1 - x0 + 1) * (y1 - y0 + 1) <= 64 && self.lat.cells_in(span).all(|c| !self.touched[c])
    }

    /// How many different edges the cells list.
    #[cfg(test)]
    pub fn listed_edges(&self) -> usize {
        let key = |e: &GridEdge| (e.block, e.a.map(f64::to_bits), e.b.map(f64::to_bits));
        let set: std::collections::HashSet<_> = self.edges.iter().map(key).collect();
        set.len()
    }

    /// Number of cells.
    #[cfg(test)]
    pub fn cell_count(&self) -> usize {
        (self.lat.nx * self.lat.ny) as usize
    }
}

/// Whether segment `a–b` meets the closed box `[mn, mx]` (Liang–Barsky clipping).
fn segment_meets_box(a: [f64; 2], b: [f64; 2], mn: [f64; 2], mx: [f64; 2]) -> bool {
    let mut t0 = 0.0f64;
    let mut t1 = 1.0f64;
    for k in 0..2 {
        let d = b[k] - a[k];
        if d == 0.0 {
            if a[k] < mn[k] || a[k] > mx[k] {
                return false;
            }
            continue;
        }
        let (mut u, mut v) = ((mn[k] - a[k]) / d, (mx[k] - a[k]) / d);
        if u > v {
            std::mem::swap(&mut u, &mut v);
        }
        t0 = t0.max(u);
        t1 = t1.min(v);
        if t0 > t1 {
            return false;
        }
    }
    true
}

/// Chebyshev distance (in cells, capped at 255) from each cell to the nearest cell holding
/// edges; cells beyond the grid count as empty.
pub(super) fn chebyshev_clearance(count: &[u32], nx: usize, ny: usize) -> Vec<u8> {
    const FAR: u32 = 255;
    let mut d: Vec<u32> = count.iter().map(|&n| if n > 0 { 0 } else { FAR }).collect();
    // two chamfer passes with unit weights on all eight neighbours give the exact L∞ distance
    for y in 0..ny {
        for x in 0..nx {
            let i = y * nx + x;
            let mut v = d[i];
            if x > 0 {
                v = v.min(d[i - 1] + 1);
            }
            if y > 0 {
                v = v.min(d[i - nx] + 1);
                if x > 0 {
                    v = v.min(d[i - nx - 1] + 1);
                }
                if x + 1 < nx {
                    v = v.min(d[i - nx + 1] + 1);
                }
            }
            d[i] = v;
        }
    }
    for y in (0..ny).rev() {
        for x in (0..nx).rev() {
            let i = y * nx + x;
            let mut v = d[i];
            if x + 1 < nx {
                v = v.min(d[i + 1] + 1);
            }
            if y + 1 < ny {
                v = v.min(d[i + nx] + 1);
                if x + 1 < nx {
                    v = v.min(d[i + nx + 1] + 1);
                }
                if x > 0 {
                    v = v.min(d[i + nx - 1] + 1);
                }
            }
            d[i] = v;
        }
    }
    d.into_iter().map(|v| v.min(FAR) as u8).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clearance_is_chebyshev_distance() {
        let (nx, ny) = (9usize, 7usize);
        let mut count = vec![0u32; nx * ny];
        count[2 * nx + 3] = 1;
        count[6 * nx + 8] = 2;
        let got = chebyshev_clearance(&count, nx, ny);
        for y in 0..ny {
            for x in 0..nx {
                let want = [(3usize, 2usize), (8, 6)]
                    .iter()
                    .map(|&(ox, oy)| x.abs_diff(ox).max(y.abs_diff(oy)))
                    .min()
                    .unwrap();
                assert_eq!(got[y * nx + x] as usize, want, "cell ({x}, {y})");
            }
        }
    }

    #[test]
    fn floor_matches_std() {
        for x in [
            -2.5, -2.0, -1e-300, -0.0, 0.0, 0.3, 1.0, 7.999, -7.999, 1e12, -1e12,
        ] {
            assert_eq!(floor_i32(x), x.floor() as i32, "{x}");
        }
    }

    #[test]
    fn slanted_edges_go_only_into_crossed_cells() {
        let e = GridEdge {
            a: [0.0, 0.0],
            b: [10.0, 10.0],
            block: 0,
        };
        // many short edges make the cells small
        let mut edges: Vec<GridEdge> = (0..100)
            .map(|i| GridEdge {
                a: [0.1 * i as f64, 10.0],
                b: [0.1 * i as f64 + 0.05, 10.0],
                block: 1,
            })
            .collect();
        edges.push(e);
        let listed: Vec<ListedEdge> = edges
            .iter()
            .map(|&edge| ListedEdge {
                edge,
                parts: vec![[edge.a, edge.b]],
            })
            .collect();
        let g = StaticGrid::build(&listed).unwrap();
        let mut n = 0;
        g.for_cells_of(e.a, e.b, |_| n += 1);
        assert!(n < g.cell_count() / 4, "{n} of {} cells", g.cell_count());
        assert!(n >= g.lat.nx as usize, "{n} cells");
    }
}
