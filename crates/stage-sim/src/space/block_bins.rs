//! Whole static blocks in a coarse grid, for ranger fans: the few obstacles around a fan's
//! origin are gathered once, and each of its rays tests their edges directly instead of
//! walking the static grid.
//!
//! In a world of scattered obstacles (the 10,000-robot swarm: a 0.3 m box per 4 m²), a 2 m
//! IR ray crosses some ten static grid cells, mostly near no edge, and a robot's twelve rays
//! cross nearly the same cells; the blocks within a fan's reach are two to six. The answer is
//! the same as the walk's only where the walk tests every edge a ray can cross, which holds
//! for blocks whose edges are listed whole (`exposed`: no side shared with a touching block
//! of the same model; a shared side is met only by rays from inside a wall, and the walk
//! leaves it out). A cell holding any other block is marked, and a fan that reaches one walks.

use super::lattice::{Lattice, flat_lists};
use super::static_grid::chebyshev_clearance;
use crate::geom::Aabb;
use crate::node::ModelId;

/// Static grid cells per bin side: a bin is four mean edge lengths across (the static grid's
/// cells are half of one), so a 2 m fan among 0.3 m obstacles covers three or four bins a side.
const CELLS_PER_BIN: i32 = 8;
/// Padding (m) of a block's box for the rays' box test: far above rounding, far below any
/// geometry (the static grid's own `EDGE_PAD`), so the test never rejects a block one of whose
/// edges the ray crosses.
const BOX_PAD: f64 = 1e-7;
/// Most bins a fan may cover; a longer reach walks (a laser's 8 m fan would gather too much).
const MOST_BINS: i32 = 36;
/// Most blocks one fan gathers ([`BlockBins::gather`]).
pub(super) const MOST_NEAR: usize = 32;

/// A block as a bin lists it: what a gather vets it by and a ray tests it with, in one place
/// (a gather reads the lists of some ten bins per fan; indices into tables elsewhere cost a
/// cache miss each in a 10,000-robot swarm).
#[derive(Clone, Copy, Debug)]
pub(super) struct BinBlock {
    /// The block's box, padded by [`BOX_PAD`].
    pub(super) aabb: Aabb,
    pub(super) zmin: f64,
    pub(super) zmax: f64,
    /// The block's model and its index there (a hit names both).
    pub(super) model: ModelId,
    pub(super) block: u32,
    /// The block's vertices in the static index's point list.
    pub(super) start: u32,
    pub(super) end: u32,
    /// The first bin (x, y) the box covers: a block met in a later bin of a gather's span is
    /// a repeat.
    first_bin: [i32; 2],
}

/// See the module docs.
pub(super) struct BlockBins {
    lat: Lattice,
    /// Bin `c`'s blocks are `listed[first[c]..first[c + 1]]`, each block in every bin its
    /// padded box covers.
    first: Vec<u32>,
    listed: Vec<BinBlock>,
    /// Per bin, the Chebyshev distance (in bins, capped at 255) to the nearest bin listing a
    /// block whose edges are not listed whole in the static grid: the square of bins within
    /// one less of it all hold whole blocks only.
    whole_reach: Vec<u8>,
}

impl BlockBins {
    /// Bins over the static grid `fine` for `blocks` (each with its unpadded box); `whole[b]`
    /// says whether block `b`'s edges are all listed whole in that grid.
    pub(super) fn build(fine: &Lattice, blocks: &[(BinBlock, bool)]) -> BlockBins {
        let nx = (fine.nx + CELLS_PER_BIN - 1) / CELLS_PER_BIN;
        let ny = (fine.ny + CELLS_PER_BIN - 1) / CELLS_PER_BIN;
        let lat = Lattice::new(fine.origin, fine.cell * CELLS_PER_BIN as f64, nx, ny);
        let clamp = |c: [i32; 2]| [c[0].clamp(0, nx - 1), c[1].clamp(0, ny - 1)];
        let mut spans = Vec::with_capacity(blocks.len());
        let blocks: Vec<(BinBlock, bool)> = blocks
            .iter()
            .map(|&(mut bb, whole)| {
                bb.aabb = Aabb {
                    min: [bb.aabb.min[0] - BOX_PAD, bb.aabb.min[1] - BOX_PAD],
                    max: [bb.aabb.max[0] + BOX_PAD, bb.aabb.max[1] + BOX_PAD],
                };
                let (lo, hi) = (
                    clamp(lat.cell_of(bb.aabb.min)),
                    clamp(lat.cell_of(bb.aabb.max)),
                );
                spans.push([lo[0], lo[1], hi[0], hi[1]]);
                bb.first_bin = lo;
                (bb, whole)
            })
            .collect();
        let cells = (nx * ny) as usize;
        let (first, listed) = flat_lists(cells, |emit| {
            for (&(bb, _), &span) in blocks.iter().zip(&spans) {
                lat.cells_in(span).for_each(|c| emit(c, bb));
            }
        });
        // 1 where a bin lists a block not listed whole
        let mut broken = vec![0u32; cells];
        for (&(_, whole), &span) in blocks.iter().zip(&spans) {
            if !whole {
                lat.cells_in(span).for_each(|c| broken[c] = 1);
            }
        }
        BlockBins {
            lat,
            first,
            listed,
            whole_reach: chebyshev_clearance(&broken, nx as usize, ny as usize),
        }
    }

    /// The bins of the disc of radius `range` around `o` when a fan from `o` reaching `range`
    /// can gather there: the disc's box lies inside the bins, covers at most [`MOST_BINS`] of
    /// them, and all of them lie in the square around `o`'s bin that holds whole blocks only.
    /// Cheap (no bin's list or flag read but `o`'s), so that a fan that must walk finds out
    /// before it casts: a floorplan's fans, near walls of touching blocks, mostly walk.
    #[inline]
    pub(super) fn disc_span(&self, o: [f64; 2], range: f64) -> Option<[i32; 4]> {
        let [cx, cy] = self.lat.cell_inside(o)?;
        let reach = i32::from(self.whole_reach[(cy * self.lat.nx + cx) as usize]);
        // the disc reaches at least this many bins from `o`'s: most fans that must walk stop
        // here, before the span is worked out
        if reach <= (range * self.lat.inv_cell) as i32 {
            return None;
        }
        let disc = Aabb {
            min: [o[0] - range, o[1] - range],
            max: [o[0] + range, o[1] + range],
        };
        let q @ [x0, y0, x1, y1] = self.lat.span_of(&disc)?;
        let far = (cx - x0).max(x1 - cx).max(cy - y0).max(y1 - cy);
        ((x1 - x0 + 1) * (y1 - y0 + 1) <= MOST_BINS && far < reach).then_some(q)
    }

    /// Puts into `out` every block listed in the bins of `span` (from [`BlockBins::disc_span`])
    /// whose box meets `area` and that `keep` keeps, each once, and answers how many; `None`
    /// when more than [`MOST_NEAR`] are kept (the fan then walks).
    #[inline]
    pub(super) fn gather<'b>(
        &'b self,
        span: [i32; 4],
        area: &Aabb,
        mut keep: impl FnMut(&BinBlock) -> bool,
        out: &mut [&'b BinBlock; MOST_NEAR],
    ) -> Option<usize> {
        let [x0, y0, x1, _] = span;
        let mut n = 0;
        let mut cell = [x0, y0];
        for c in self.lat.cells_in(span) {
            for b in &self.listed[self.first[c] as usize..self.first[c + 1] as usize] {
                // a block spanning several bins counts in the first of them the span covers
                let f = b.first_bin;
                if f[0].max(x0) != cell[0] || f[1].max(y0) != cell[1] {
                    continue;
                }
                if !b.aabb.intersects(area) || !keep(b) {
                    continue;
                }
                if n == MOST_NEAR {
                    return None;
                }
                out[n] = b;
                n += 1;
            }
            cell[0] += 1;
            if cell[0] > x1 {
                cell = [x0, cell[1] + 1];
            }
        }
        Some(n)
    }
}

impl BinBlock {
    /// A placeholder for the unused slots of a fixed-size list.
    pub(super) const UNUSED: BinBlock = BinBlock {
        aabb: Aabb::EMPTY,
        zmin: 0.0,
        zmax: 0.0,
        model: ModelId(0),
        block: 0,
        start: 0,
        end: 0,
        first_bin: [0; 2],
    };

    /// Block `block` of `model`, with box `aabb` (unpadded), heights `zmin..=zmax` and
    /// vertices `start..end` in the static index's point list.
    pub(super) fn new(
        aabb: Aabb,
        z: [f64; 2],
        model: ModelId,
        block: u32,
        pts: [u32; 2],
    ) -> BinBlock {
        BinBlock {
            aabb,
            zmin: z[0],
            zmax: z[1],
            model,
            block,
            start: pts[0],
            end: pts[1],
            first_bin: [0; 2],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn boxed(x: f64, y: f64, w: f64) -> Aabb {
        Aabb {
            min: [x, y],
            max: [x + w, y + w],
        }
    }

    /// Bins over a 20 m square with fine cells of 0.25 m (bins of 2 m), for blocks with boxes
    /// `boxes`, listed whole or not.
    fn bins_of(boxes: &[Aabb], whole: &[bool]) -> BlockBins {
        let fine = Lattice::new([0.0, 0.0], 0.25, 80, 80);
        let blocks: Vec<(BinBlock, bool)> = boxes
            .iter()
            .zip(whole)
            .enumerate()
            .map(|(i, (&b, &w))| {
                (
                    BinBlock::new(b, [0.0, 1.0], ModelId(i as u32), 0, [0, 0]),
                    w,
                )
            })
            .collect();
        BlockBins::build(&fine, &blocks)
    }

    /// Gathers around the disc of radius `r` about `o`, from the bins its box covers: the
    /// models of the blocks.
    fn near(
        bins: &BlockBins,
        o: [f64; 2],
        r: f64,
        mut keep: impl FnMut(u32) -> bool,
    ) -> Option<Vec<u32>> {
        let span = bins.disc_span(o, r)?;
        let area = boxed(o[0] - r, o[1] - r, 2.0 * r);
        let mut out = [&BinBlock::UNUSED; MOST_NEAR];
        let n = bins.gather(span, &area, |b| keep(b.model.0), &mut out)?;
        Some(out[..n].iter().map(|b| b.model.0).collect())
    }

    #[test]
    fn a_gather_finds_each_nearby_block_once() {
        // fine cells of 0.25 m: bins of 2 m over a 20 m square
        let boxes = [
            boxed(1.0, 1.0, 0.3),
            // spans four bins
            boxed(3.8, 3.8, 0.5),
            boxed(9.0, 9.0, 0.3),
            boxed(15.0, 15.0, 0.3),
        ];
        let bins = bins_of(&boxes, &[true; 4]);
        assert_eq!(near(&bins, [2.5, 2.5], 2.0, |_| true), Some(vec![0, 1]));
        // what `keep` drops is left out
        assert_eq!(near(&bins, [2.5, 2.5], 2.0, |b| b != 0), Some(vec![1]));
        // a bin the disc covers but whose block's box misses the disc's box
        assert_eq!(near(&bins, [7.95, 7.95], 0.95, |_| true), Some(vec![]));
        // too many bins, or a disc leaving them: walk
        assert_eq!(near(&bins, [8.0, 8.0], 7.5, |_| true), None);
        assert_eq!(near(&bins, [0.0, 1.5], 1.0, |_| true), None);
    }

    #[test]
    fn a_bin_with_a_block_not_listed_whole_sends_fans_to_the_walk() {
        let boxes = [boxed(1.0, 1.0, 0.3), boxed(9.0, 9.0, 0.3)];
        let bins = bins_of(&boxes, &[false, true]);
        assert_eq!(near(&bins, [1.5, 1.5], 1.0, |_| true), None);
        assert_eq!(near(&bins, [9.5, 9.5], 1.0, |_| true), Some(vec![1]));
    }

    #[test]
    fn more_blocks_than_a_gather_holds_send_fans_to_the_walk() {
        let boxes: Vec<Aabb> = (0..40)
            .map(|i| boxed(1.0 + 0.05 * i as f64, 1.0, 0.01))
            .collect();
        let bins = bins_of(&boxes, &[true; 40]);
        assert_eq!(near(&bins, [2.0, 1.5], 1.5, |_| true), None);
        let got = near(&bins, [2.0, 1.5], 1.5, |b| b < 10).unwrap();
        assert_eq!(got, (0..10).collect::<Vec<u32>>());
    }
}
