//! The uniform grid over moving bodies: a model re-registers only when the set of cells its
//! box covers changes, so moves cost O(1) and the grid is never rebuilt.

use super::body::Body;
use super::lattice::Lattice;
use crate::geom::Aabb;
use crate::node::ModelId;

/// A moving model as a grid cell lists it: its box and tree root beside its id, so that a
/// ray's cheap rejections (the caster's own tree, a box the ray misses) read one contiguous
/// list instead of two tables indexed by model (hospital: -8% instructions per step).
#[derive(Clone, Copy, Debug)]
pub(super) struct CellEntry {
    /// The model's body box (the same as `Space::aabbs`, kept in step by [`DynGrid::update`]).
    pub(super) aabb: Aabb,
    /// The model.
    pub(super) model: ModelId,
    /// The root of the model's tree.
    pub(super) root: ModelId,
}

/// The uniform grid holding dynamic bodies (model entries per cell).
pub(super) struct DynGrid {
    pub(super) lat: Lattice,
    pub(super) cells: Vec<Vec<CellEntry>>,
    /// One bit per cell, set while its list is not empty (see [`DynGrid::entries`]).
    occupied: Vec<u64>,
    /// Models whose box leaves the grid: tested by every query.
    pub(super) overflow: Vec<ModelId>,
    /// Registered cell range per model (`None`: not registered or in `overflow`).
    span: Vec<Option<[i32; 4]>>,
    in_overflow: Vec<bool>,
}

impl DynGrid {
    pub(super) fn new(bounds: Aabb, cell: f64, nmodels: usize) -> DynGrid {
        let (origin, nx, ny) = if bounds.is_empty() {
            ([0.0, 0.0], 1, 1)
        } else {
            let nx = (((bounds.max[0] - bounds.min[0]) / cell).ceil() as i64).clamp(1, 4096) as i32;
            let ny = (((bounds.max[1] - bounds.min[1]) / cell).ceil() as i64).clamp(1, 4096) as i32;
            (bounds.min, nx, ny)
        };
        DynGrid {
            lat: Lattice::new(origin, cell, nx, ny),
            cells: vec![Vec::new(); (nx * ny) as usize],
            occupied: vec![0; (nx * ny) as usize / 64 + 1],
            overflow: Vec::new(),
            span: vec![None; nmodels],
            in_overflow: vec![false; nmodels],
        }
    }

    pub(super) fn span_of(&self, b: &Aabb) -> Option<[i32; 4]> {
        self.lat.span_of(b)
    }

    fn remove(&mut self, m: ModelId) {
        if let Some(span) = self.span[m.index()].take() {
            for i in self.lat.cells_in(span) {
                let c = &mut self.cells[i];
                if let Some(k) = c.iter().position(|e| e.model == m) {
                    c.remove(k);
                }
                if c.is_empty() {
                    self.occupied[i / 64] &= !(1 << (i % 64));
                }
            }
        }
        if self.in_overflow[m.index()] {
            self.in_overflow[m.index()] = false;
            self.overflow.retain(|&v| v != m);
        }
    }

    /// Registers (or re-registers) model `m`, of the tree rooted at `root`, with box `b`.
    pub(super) fn update(&mut self, m: ModelId, b: &Aabb, root: ModelId) {
        if b.is_empty() {
            self.remove(m);
            return;
        }
        let new = self.span_of(b);
        if new.is_some() && new == self.span[m.index()] {
            // the same cells: only the box the entries carry changes
            self.each_entry(m, |e| e.aabb = *b);
            return;
        }
        if new.is_none() && self.in_overflow[m.index()] {
            return;
        }
        self.remove(m);
        match new {
            Some(span) => {
                let entry = CellEntry {
                    aabb: *b,
                    model: m,
                    root,
                };
                for i in self.lat.cells_in(span) {
                    self.cells[i].push(entry);
                    self.occupied[i / 64] |= 1 << (i % 64);
                }
                self.span[m.index()] = new;
            }
            None => {
                self.in_overflow[m.index()] = true;
                self.overflow.push(m);
            }
        }
    }

    /// Cell `i`'s entries when it has any: a ray's walk asks the bits (a few KB, which stay in
    /// cache) and reads a cell's list only where there is one, not every list header it
    /// passes (24 bytes a cell; hospital's grid 3.4 MB). Hospital end to end −1 to −3%, the
    /// 10,000-robot swarm −5% (medians of 10 and 6 alternating runs).
    #[inline(always)]
    pub(super) fn entries(&self, i: usize) -> Option<&[CellEntry]> {
        if self.occupied[i / 64] & (1 << (i % 64)) == 0 {
            None
        } else {
            Some(&self.cells[i])
        }
    }

    /// Records that model `m` now belongs to the tree rooted at `root` (re-parenting).
    pub(super) fn set_root(&mut self, m: ModelId, root: ModelId) {
        self.each_entry(m, |e| e.root = root);
    }

    /// Calls `f` on each cell entry of model `m`.
    fn each_entry(&mut self, m: ModelId, mut f: impl FnMut(&mut CellEntry)) {
        if let Some(span) = self.span[m.index()] {
            for i in self.lat.cells_in(span) {
                if let Some(e) = self.cells[i].iter_mut().find(|e| e.model == m) {
                    f(e);
                }
            }
        }
    }
}

#[cfg(test)]
impl super::Space {
    /// Per cell, then the overflow list last, its entries as `(model, box bits, root)`,
    /// sorted: what two grids that must answer every query alike have to agree on.
    pub(crate) fn dynamic_grid_as_sets(&self) -> Vec<Vec<(u32, [u64; 4], u32)>> {
        let bits = |b: &Aabb| {
            [
                b.min[0].to_bits(),
                b.min[1].to_bits(),
                b.max[0].to_bits(),
                b.max[1].to_bits(),
            ]
        };
        let g = &self.grid;
        let mut out: Vec<Vec<(u32, [u64; 4], u32)>> = g
            .cells
            .iter()
            .map(|c| {
                c.iter()
                    .map(|e| (e.model.0, bits(&e.aabb), e.root.0))
                    .collect()
            })
            .collect();
        out.push(
            g.overflow
                .iter()
                .map(|&m| (m.0, bits(&self.aabbs[m.index()]), self.roots[m.index()].0))
                .collect(),
        );
        for cell in &mut out {
            cell.sort_unstable();
        }
        out
    }
}

/// Edge of the dynamic grid's cells: three typical (median) moving bodies across, within
/// `[0.25, 2]` m — small enough that a cell holds few robots, large enough that short sensor
/// rays cross few cells (callgrind, instructions per step against four across: cave −6%,
/// hospital −4%, a 1,000-robot swarm +1%; two across: cave −11%, swarm +4%). Robots of
/// several bodies each (cave's pioneer and its laser) crowd a cell's list as much as that many
/// robots, so the cell's area shrinks by the bodies per robot tree: cave's 2 give 2.1 bodies
/// across, −4% instructions per step against 3 (hospital and the swarms, 1 body per robot, keep
/// 3; 2.5 across costs hospital +7%).
///
/// Where the moving bodies are sparse for their size, the cell is instead as wide as the mean
/// spacing between them (`1/√density` over the box they occupy, so about one body a cell):
/// smaller cells would only add empty cells for every ray to step through and cell boundaries
/// for every move to cross, and a larger grid for both to miss the cache on. The 10,000-robot
/// swarm (0.1 m robots 1 m apart) gets 0.99 m instead of 0.39 m: 4.4x → 5.1x real time (median of
/// 6 alternating runs; 1,000 robots 70.5x → 76.5x); cave's spacing (0.95 m) and hospital's
/// (0.23 m: its robots start packed) barely or never exceed their body term.
pub(super) fn dynamic_cell(bodies: &[Body], dynamic: &[bool], roots: &[ModelId]) -> f64 {
    let moving = || {
        bodies
            .iter()
            .zip(dynamic)
            .enumerate()
            .filter(|(_, (b, d))| **d && !b.is_empty())
    };
    let mut ext: Vec<f64> = moving()
        .map(|(_, (b, _))| (b.aabb.max[0] - b.aabb.min[0]).max(b.aabb.max[1] - b.aabb.min[1]))
        .collect();
    if ext.is_empty() {
        return 1.0;
    }
    let mut trees: Vec<ModelId> = moving().map(|(m, _)| roots[m]).collect();
    trees.sort_unstable();
    trees.dedup();
    let per_tree = ext.len() as f64 / trees.len() as f64;
    let mut occupied = Aabb::EMPTY;
    for (_, (b, _)) in moving() {
        occupied.merge(&b.aabb);
    }
    let area = (occupied.max[0] - occupied.min[0]) * (occupied.max[1] - occupied.min[1]);
    // no spacing for bodies that occupy no area (NaN and 0 lose to the body term in `max`)
    let spacing = (area / ext.len() as f64).sqrt();
    let mid = ext.len() / 2;
    ext.select_nth_unstable_by(mid, f64::total_cmp);
    (3.0 * ext[mid] / per_tree.sqrt())
        .max(spacing)
        .clamp(0.25, 2.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The box spanning two corners.
    fn aabb(x0: f64, y0: f64, x1: f64, y1: f64) -> Aabb {
        let mut b = Aabb::EMPTY;
        b.add([x0, y0]);
        b.add([x1, y1]);
        b
    }

    /// The entries of every cell a model covers carry its current box and root: after a move
    /// within the same cells, after a move to other cells and after re-parenting.
    #[test]
    fn cell_entries_follow_moves_and_roots() {
        let mut g = DynGrid::new(aabb(0.0, 0.0, 10.0, 10.0), 1.0, 3);
        let (m, other) = (ModelId(1), ModelId(2));
        // read as rays read them, through the occupancy bits, which must say which cells
        // hold entries
        let entries = |g: &DynGrid, m: ModelId| -> Vec<(usize, Aabb, ModelId)> {
            for c in 0..g.cells.len() {
                assert_eq!(g.entries(c).is_some(), !g.cells[c].is_empty(), "cell {c}");
            }
            (0..g.cells.len())
                .flat_map(|c| {
                    g.entries(c)
                        .unwrap_or_default()
                        .iter()
                        .filter(|e| e.model == m)
                        .map(move |e| (c, e.aabb, e.root))
                })
                .collect()
        };
        g.update(other, &aabb(1.2, 1.2, 1.4, 1.4), other);
        g.update(m, &aabb(1.5, 1.5, 2.5, 1.8), m);
        // cells (1,1) and (2,1)
        let b = aabb(1.5, 1.5, 2.5, 1.8);
        assert_eq!(entries(&g, m), vec![(11, b, m), (12, b, m)]);
        // a move inside the same cells updates the boxes in place
        let b2 = aabb(1.6, 1.5, 2.6, 1.8);
        g.update(m, &b2, m);
        assert_eq!(entries(&g, m), vec![(11, b2, m), (12, b2, m)]);
        // re-parenting changes the root in every entry
        g.set_root(m, other);
        assert_eq!(entries(&g, m), vec![(11, b2, other), (12, b2, other)]);
        // a move to other cells re-registers with the root given
        let b3 = aabb(5.2, 5.2, 5.4, 6.3);
        g.update(m, &b3, other);
        assert_eq!(entries(&g, m), vec![(55, b3, other), (65, b3, other)]);
        // the other model's entry is untouched throughout
        assert_eq!(
            entries(&g, other),
            vec![(11, aabb(1.2, 1.2, 1.4, 1.4), other)]
        );
    }

    /// Robots of side `side` (one body each, their own trees) on a square lattice `gap` apart,
    /// `n` by `n`: the cell [`dynamic_cell`] picks for them.
    fn cell_for_lattice(n: usize, side: f64, gap: f64) -> f64 {
        let bodies: Vec<Body> = (0..n * n)
            .map(|k| {
                let (x, y) = ((k % n) as f64 * gap, (k / n) as f64 * gap);
                Body::from_rects(&[[x, y, side, side]])
            })
            .collect();
        let roots: Vec<ModelId> = (0..n * n).map(|k| ModelId(k as u32)).collect();
        dynamic_cell(&bodies, &vec![true; n * n], &roots)
    }

    /// Packed robots get cells three robots across; sparse ones, cells as wide as the spacing
    /// between them (about one robot a cell), within the bounds.
    #[test]
    fn cells_follow_robot_size_when_packed_and_spacing_when_sparse() {
        // 0.1 m robots 0.15 m apart: three across (0.3 m) beats the spacing
        assert!((cell_for_lattice(20, 0.1, 0.15) - 0.3).abs() < 1e-9);
        // 0.1 m robots 1 m apart (the swarm): the spacing, a little under 1 m as the occupied
        // box ends 0.9 m short of a whole lattice step
        let sparse = cell_for_lattice(50, 0.1, 1.0);
        assert!(sparse > 0.95 && sparse < 1.0, "{sparse}");
        // 5 m apart: the upper bound
        assert_eq!(cell_for_lattice(10, 0.1, 5.0), 2.0);
        // one robot: its own box is all the area there is, the body term decides
        assert!((cell_for_lattice(1, 0.1, 1.0) - 0.3).abs() < 1e-9);
    }
}
