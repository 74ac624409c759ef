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
    #[inline]
    pub(super) fn cells_in(&self, [x0, y0, x1, y1]: [i32; 4]) -> CellsIn {
        if x1 < x0 || y1 < y0 {
            return CellsIn::default();
        }
        let width = (x1 - x0 + 1) as usize;
        CellsIn {
            next: (y0 * self.nx + x0) as usize,
            left_in_row: width,
            rows_after: (y1 - y0) as usize,
            width,
            skip: self.nx as usize - width,
        }
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

/// The cells of a span, row by row ([`Lattice::cells_in`]): a counter that steps over the
/// rest of each grid row. Every move runs through a few spans (the static grid's contact
/// shortcut, the dynamic grid's update and contact test); against a flattened range of ranges,
/// callgrind counts per step, one thread: hospital −0.8%, cave −0.8%, a 1,000-robot swarm
/// −0.9%, simple −0.2% (hospital's ordered move pass −8%).
#[derive(Clone, Debug, Default)]
pub(super) struct CellsIn {
    /// The next cell's index.
    next: usize,
    /// Cells left in the current row, `next` included.
    left_in_row: usize,
    /// Rows after the current one.
    rows_after: usize,
    /// Cells per row of the span.
    width: usize,
    /// Grid cells between the end of one row of the span and the start of the next.
    skip: usize,
}

impl Iterator for CellsIn {
    type Item = usize;

    #[inline]
    fn next(&mut self) -> Option<usize> {
        if self.left_in_row == 0 {
            if self.rows_after == 0 {
                return None;
            }
            self.rows_after -= 1;
            self.next += self.skip;
            self.left_in_row = self.width;
        }
        let i = self.next;
        self.next += 1;
        self.left_in_row -= 1;
        Some(i)
    }
}

/// Per-cell lists laid out in one flat array, for grids built once (the static edges', the
/// block bins): `each` hands `emit` every (cell, entry) pair, in the order the lists keep, and
/// is called twice (to count, then to fill). Answers `first`, where cell `c`'s entries are
/// `entries[first[c]..first[c + 1]]`, and `entries`.
pub(super) fn flat_lists<T: Copy>(
    cells: usize,
    mut each: impl FnMut(&mut dyn FnMut(usize, T)),
) -> (Vec<u32>, Vec<T>) {
    let mut count = vec![0u32; cells];
    let mut sample = None;
    each(&mut |c, e| {
        count[c] += 1;
        sample.get_or_insert(e);
    });
    let mut first = Vec::with_capacity(cells + 1);
    let mut acc = 0u32;
    for n in &count {
        first.push(acc);
        acc += n;
    }
    first.push(acc);
    let Some(sample) = sample else {
        return (first, Vec::new());
    };
    // every slot is written below; `sample` only fills them until then
    let mut entries = vec![sample; acc as usize];
    let mut fill = first[..cells].to_vec();
    each(&mut |c, e| {
        entries[fill[c] as usize] = e;
        fill[c] += 1;
    });
    (first, entries)
}

/// Where a grid walk (DDA) leaves its cell, from the distances `t_next` at which the ray
/// crosses its next x and its next y boundary: 1 when across the x boundary
/// (`t_next[0] < t_next[1]`), 0 when across the y boundary, and that distance.
///
/// Without a branch: which axis a slanted ray crosses next is a coin toss the predictor loses
/// about half the time, and the compiler, left to itself, turned the scalar form's selects
/// into a branch (callgrind's branch simulation: 13% of the hospital's mispredicted branches
/// were on that line). On x86-64 it is SSE2 (the target's baseline): `cmpltsd` and `minsd`
/// are `x < y` and `x < y ? x : y` exactly; the caller looks its steps up by the answer.
#[inline(always)]
pub(super) fn next_crossing(t_next: [f64; 2]) -> (usize, f64) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{
            _mm_cmplt_sd, _mm_cvtsd_f64, _mm_min_sd, _mm_movemask_pd, _mm_set_pd, _mm_set_sd,
        };
        // SAFETY: these intrinsics only need SSE2, which every x86-64 processor has (the
        // target's baseline, always enabled); none of them reads or writes memory
        unsafe {
            let (x, y) = (_mm_set_sd(t_next[0]), _mm_set_pd(0.0, t_next[1]));
            let x_first = _mm_movemask_pd(_mm_cmplt_sd(x, y)) & 1;
            (x_first as usize, _mm_cvtsd_f64(_mm_min_sd(x, y)))
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let x_first = t_next[0] < t_next[1];
        (
            x_first as usize,
            if x_first { t_next[0] } else { t_next[1] },
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A span's cells come row by row, each row left to right, exactly the cells inside the
    /// span; an inverted span has none.
    #[test]
    fn cells_in_lists_a_span_row_by_row() {
        let lat = Lattice::new([0.0, 0.0], 1.0, 7, 5);
        for span in [
            [0, 0, 0, 0],
            [6, 4, 6, 4],
            [2, 1, 5, 1],
            [3, 0, 3, 4],
            [1, 1, 4, 3],
            [0, 0, 6, 4],
            [3, 2, 2, 2],
            [3, 2, 3, 1],
        ] {
            let [x0, y0, x1, y1] = span;
            let mut expected = Vec::new();
            for y in y0..=y1 {
                for x in x0..=x1 {
                    expected.push((y * 7 + x) as usize);
                }
            }
            assert_eq!(lat.cells_in(span).collect::<Vec<_>>(), expected, "{span:?}");
        }
    }

    /// The branch-free choice of the next boundary answers as the comparison and select it
    /// replaces, to the bit: ties (y first), infinities (an axis-parallel ray), zeros of
    /// either sign and NaN (x never first).
    #[test]
    fn next_crossing_is_the_nearer_boundary() {
        let values = [
            0.0,
            -0.0,
            0.25,
            0.5,
            1.0,
            3.75,
            1e300,
            f64::INFINITY,
            f64::NAN,
        ];
        for &x in &values {
            for &y in &values {
                let x_first = x < y;
                let want = (x_first as usize, if x_first { x } else { y });
                let got = next_crossing([x, y]);
                assert_eq!(
                    (got.0, got.1.to_bits()),
                    (want.0, want.1.to_bits()),
                    "{x}, {y}"
                );
            }
        }
    }
}
