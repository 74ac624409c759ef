//! What the wavefront asks of every cell, packed so that its look-ups stay in cache.
//!
//! The wavefront looks at the eight neighbours of each cell it expands: whether each may still
//! be entered (not reached yet, not blocked), and when one is first reached, what entering it
//! costs and which cell it was reached from. Upstream keeps these in a 40-byte `plan_cell_t`;
//! on a hospital floor of 3.7 million cells that is far more than the caches hold, and the
//! plan's time goes into waiting for memory. Here:
//!
//! - "open", one bit per cell: inside the plan's bounds, not blocked, not reached (half a
//!   megabyte for the hospital, which the second-level cache holds), so the neighbours that
//!   cannot be entered, most of them, are turned away without touching anything else;
//! - "passable", one bit per cell: not nearer than `abs_min_radius` to an obstacle, laser
//!   obstacles included (and the map's own, without them, for straight-line tests);
//! - one `u16` per cell, read and written once when the cell is reached (one cache line for
//!   all of it, which measured faster than separate arrays):
//!   - the obstacle penalty for entering (low byte): 0 for none (at least `max_radius` from
//!     any obstacle), otherwise a class, an index into a table of the penalties of the few
//!     distances a cell can have (the kernel's), or [`ESCAPE`] for "compute it from the
//!     distance" when a very large kernel has more distances than the table holds;
//!   - the next step towards the goal (upstream's `plan_next`): the neighbour it is, 1 to 8,
//!     or 0 for none;
//!   - [`LPATH`]: on the last local plan's path (upstream's `lpathmark`).
//!
//! All are laid out over the grid with a ring of one cell around it that is never open or
//! passable, so the neighbours of a cell on the map's edge need no bounds test. Cells are
//! named by their index in that padded layout ([`CellStates::index`]). A cell's cost itself
//! is not kept: it is only read when the cell is expanded, and the queue carries it there.

use std::cmp::Ordering;

use super::plan::PlanParams;

/// The penalty class that means "compute the penalty from the distance".
const ESCAPE: u8 = 0xff;
/// A state's penalty class.
const CLASS_MASK: u16 = 0xff;
/// A state's next step (the neighbour + 1).
const NEXT_SHIFT: u32 = 8;
const NEXT_MASK: u16 = 0xf << NEXT_SHIFT;
/// A state's "on the last local path".
const LPATH: u16 = 1 << 12;

/// The eight neighbours of a cell as (column offset, row offset), in upstream's order: rows
/// from below, columns from the left. Neighbour `n` and neighbour `7 - n` are opposite.
pub(super) const NEIGHBOURS: [(i8, i8); 8] = [
    (-1, -1),
    (0, -1),
    (1, -1),
    (-1, 0),
    (1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];

/// A set of cells as one bit each.
#[derive(Clone, Debug, PartialEq)]
struct Bits(Vec<u8>);

impl Bits {
    fn new(n: usize) -> Bits {
        // One byte more, so that three bits from any cell can be read as two bytes.
        Bits(vec![0; n.div_ceil(8) + 1])
    }

    #[inline]
    fn get(&self, k: usize) -> bool {
        self.0[k / 8] >> (k % 8) & 1 != 0
    }

    #[inline]
    fn set(&mut self, k: usize, on: bool) {
        let (w, b) = (k / 8, k % 8);
        self.0[w] = (self.0[w] & !(1 << b)) | (u8::from(on) << b);
    }
}

/// Every cell's state, and the table its penalty classes index.
#[derive(Clone, Debug)]
pub(super) struct CellStates {
    /// The grid's width and height (without the ring).
    size_x: usize,
    size_y: usize,
    /// Per cell the penalty class (laser obstacles included), next step and [`LPATH`].
    states: Vec<u16>,
    /// The penalty classes from the map alone, restored when the laser's obstacles are
    /// replaced.
    map_class: Vec<u8>,
    /// The cells that are not blocked, laser obstacles included (never the ring).
    passable: Bits,
    /// The same from the map alone.
    map_passable: Bits,
    /// The cells the wavefront may still enter.
    open: Bits,
    /// The distances (as `f32` bits, ascending) that have a penalty class: class `c` is
    /// `distances[c - 1]`.
    distances: Vec<u32>,
    /// The penalty of each class (index 0: none), computed as upstream rounds it.
    penalties: Box<[f32; 256]>,
    abs_min: f32,
    max_radius: f64,
    dist_penalty: f64,
}

impl CellStates {
    /// The states of a `size_x` x `size_y` grid whose distances to the nearest obstacle are
    /// `occ_dist` (row-major, unpadded), nothing reached; `kernel_distances` are all the
    /// distances a cell can have below `max_radius` (any order, repeats allowed).
    pub(super) fn new(
        size_x: usize,
        size_y: usize,
        occ_dist: &[f32],
        kernel_distances: impl IntoIterator<Item = f32>,
        params: &PlanParams,
    ) -> CellStates {
        let abs_min = params.abs_min_radius as f32;
        let mut distances: Vec<u32> = kernel_distances
            .into_iter()
            .filter(|&d| d >= abs_min && f64::from(d) < params.max_radius && d >= 0.0)
            .map(f32::to_bits)
            .collect();
        // Non-negative floats order as their bits do.
        distances.sort_unstable();
        distances.dedup();
        distances.truncate(usize::from(ESCAPE) - 1);
        // Indexed by a class byte, so a full table of 256 needs no bounds test.
        let mut penalties = Box::new([0.0f32; 256]);
        for (c, &bits) in distances.iter().enumerate() {
            let d = f64::from(f32::from_bits(bits));
            penalties[c + 1] = (params.dist_penalty * (params.max_radius - d)) as f32;
        }
        let padded = (size_x + 2) * (size_y + 2);
        let mut cells = CellStates {
            size_x,
            size_y,
            states: Vec::new(),
            map_class: vec![0; padded],
            passable: Bits::new(padded),
            map_passable: Bits::new(padded),
            open: Bits::new(padded),
            distances,
            penalties,
            abs_min,
            max_radius: params.max_radius,
            dist_penalty: params.dist_penalty,
        };
        // The last distance seen and its class: neighbouring cells mostly share one.
        let mut last: Option<(u32, Option<u8>)> = None;
        for (j, row) in occ_dist.chunks_exact(size_x).enumerate() {
            let start = cells.index((0, j));
            for (i, &d) in row.iter().enumerate() {
                let class = match last {
                    Some((bits, class)) if bits == d.to_bits() => class,
                    _ => {
                        let class = cells.distance_class(d);
                        last = Some((d.to_bits(), class));
                        class
                    }
                };
                if let Some(c) = class {
                    cells.map_class[start + i] = c;
                    cells.map_passable.set(start + i, true);
                }
            }
        }
        cells.states = cells.map_class.iter().map(|&c| u16::from(c)).collect();
        cells.passable = cells.map_passable.clone();
        cells
    }

    /// The padded index of cell (`i`, `j`).
    #[inline]
    pub(super) fn index(&self, (i, j): (usize, usize)) -> usize {
        (i + 1) + (j + 1) * (self.size_x + 2)
    }

    /// The cell of padded index `p` (never the ring).
    pub(super) fn cell(&self, p: usize) -> (usize, usize) {
        let w = self.size_x + 2;
        (p % w - 1, p / w - 1)
    }

    /// The padded index offset of each of [`NEIGHBOURS`].
    pub(super) fn neighbour_offsets(&self) -> [isize; 8] {
        let w = (self.size_x + 2) as isize;
        NEIGHBOURS.map(|(di, dj)| isize::from(di) + isize::from(dj) * w)
    }

    /// The penalty class of a cell at distance `d` from obstacles, `None` if that blocks it.
    pub(super) fn distance_class(&self, d: f32) -> Option<u8> {
        if d < self.abs_min {
            return None;
        }
        if f64::from(d).partial_cmp(&self.max_radius) != Some(Ordering::Less) {
            return Some(0);
        }
        Some(match self.distances.binary_search(&d.to_bits()) {
            Ok(c) => c as u8 + 1,
            Err(_) => ESCAPE,
        })
    }

    /// Whether cell `p` is clear of the map's obstacles (laser obstacles not counted).
    #[inline]
    pub(super) fn map_free(&self, p: usize) -> bool {
        self.map_passable.get(p)
    }

    /// Cell `p`'s next step towards the goal of the plan that last reached it.
    pub(super) fn next_of(&self, p: usize) -> Option<usize> {
        let n = ((self.states[p] & NEXT_MASK) >> NEXT_SHIFT).checked_sub(1)?;
        let offset = self.neighbour_offsets()[usize::from(n)];
        Some((p as isize + offset) as usize)
    }

    /// Marks or unmarks cell `p` as on the local path.
    pub(super) fn set_lpath(&mut self, p: usize, on: bool) {
        if on {
            self.states[p] |= LPATH;
        } else {
            self.states[p] &= !LPATH;
        }
    }

    /// Forgets the next steps of the cells of row `j` from column `x0` to `x1`.
    pub(super) fn reset_row(&mut self, j: usize, x0: usize, x1: usize) {
        let (a, b) = (self.index((x0, j)), self.index((x1, j)));
        for s in &mut self.states[a..=b] {
            *s &= !NEXT_MASK;
        }
    }

    /// Restores every cell's class and passability to the map's own.
    pub(super) fn restore_distances(&mut self) {
        for (s, &c) in self.states.iter_mut().zip(&self.map_class) {
            *s = (*s & !CLASS_MASK) | u16::from(c);
        }
        self.passable.0.copy_from_slice(&self.map_passable.0);
    }

    /// Sets cell `p`'s class and passability (from [`CellStates::distance_class`]).
    pub(super) fn set_distance_class(&mut self, p: usize, class: Option<u8>) {
        self.states[p] = (self.states[p] & !CLASS_MASK) | u16::from(class.unwrap_or(0));
        self.passable.set(p, class.is_some());
    }

    /// Readies a wavefront inside `bounds` (inclusive cells): the passable cells inside open,
    /// the cells just outside closed. `start` is opened if `start_open` (it is treated as
    /// free whatever is near it), `goal` closed (reached, without a next step).
    pub(super) fn open_for_plan(
        &mut self,
        (x0, y0, x1, y1): (usize, usize, usize, usize),
        start: usize,
        start_open: bool,
        goal: usize,
    ) {
        if (x0, y0, x1, y1) == (0, 0, self.size_x - 1, self.size_y - 1) {
            self.open.0.copy_from_slice(&self.passable.0);
        } else {
            for j in y0..=y1 {
                for i in x0..=x1 {
                    let p = self.index((i, j));
                    self.open.set(p, self.passable.get(p));
                }
            }
            // The ring round the bounds (padded coordinates, so one below 0 is the map's own
            // ring).
            let w = self.size_x + 2;
            let (px0, py0, px1, py1) = (x0, y0, x1 + 2, y1 + 2);
            for pi in px0..=px1 {
                self.open.set(pi + py0 * w, false);
                self.open.set(pi + py1 * w, false);
            }
            for pj in py0..=py1 {
                self.open.set(px0 + pj * w, false);
                self.open.set(px1 + pj * w, false);
            }
        }
        self.open.set(start, start_open);
        self.states[goal] &= !NEXT_MASK;
        self.open.set(goal, false);
    }

    /// What the wavefront's loop works on, borrowed apart.
    pub(super) fn flood_view(&mut self) -> FloodView<'_> {
        FloodView {
            states: &mut self.states,
            open: &mut self.open.0,
            penalties: &self.penalties,
            max_radius: self.max_radius,
            dist_penalty: self.dist_penalty,
        }
    }
}

/// The cells' states and the penalty table as the wavefront's loop uses them.
pub(super) struct FloodView<'a> {
    states: &'a mut [u16],
    open: &'a mut [u8],
    penalties: &'a [f32; 256],
    max_radius: f64,
    dist_penalty: f64,
}

impl FloodView<'_> {
    /// Which of cell `p`'s [`NEIGHBOURS`] may be entered, as bits 0 to 7 (`width`: the padded
    /// row length). Taking all eight at once spares a hard-to-predict branch per neighbour.
    #[inline(always)]
    pub(super) fn open_neighbours(&self, p: usize, width: usize) -> u32 {
        // Cells q, q + 1 and q + 2 as bits 0 to 2: at most bits 7 to 9 of the two bytes
        // from q's.
        let three = |q: usize| -> u32 {
            let w = q / 8;
            let bytes = &self.open[w..w + 2];
            let pair = u32::from(u16::from_le_bytes([bytes[0], bytes[1]]));
            (pair >> (q % 8)) & 7
        };
        let below = three(p - width - 1);
        let level = three(p - 1);
        let above = three(p + width - 1);
        below | (level & 1) << 3 | (level >> 2) << 4 | above << 5
    }

    /// Cell `p`'s state.
    #[inline(always)]
    pub(super) fn state(&self, p: usize) -> u16 {
        self.states[p]
    }

    /// Whether a cell in `state` is on the last local plan's path.
    #[inline]
    pub(super) fn on_lpath(state: u16) -> bool {
        state & LPATH != 0
    }

    /// Marks cell `p` (in `state`) reached from its neighbour `back`, and closes it.
    #[inline(always)]
    pub(super) fn reach(&mut self, p: usize, state: u16, back: usize) {
        self.states[p] = (state & !NEXT_MASK) | ((back as u16 + 1) << NEXT_SHIFT);
        self.open[p / 8] &= !(1 << (p % 8));
    }

    /// The penalty for entering a cell in `state` whose distance to obstacles is `d` (asked
    /// only when its class is [`ESCAPE`]): upstream's `dist_penalty * (max_radius - d)` where
    /// `d` is below `max_radius`, rounded to `f32`.
    #[inline(always)]
    pub(super) fn penalty(&self, state: u16, d: impl FnOnce() -> f32) -> f32 {
        let class = (state & CLASS_MASK) as u8;
        if class == ESCAPE {
            (self.dist_penalty * (self.max_radius - f64::from(d()))) as f32
        } else {
            self.penalties[usize::from(class)]
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> PlanParams {
        PlanParams {
            abs_min_radius: 0.25,
            max_radius: 1.0,
            dist_penalty: 2.0,
        }
    }

    #[test]
    fn distances_map_to_blocked_classes_and_penalties_as_upstream_computes_them() {
        let kernel = [0.0f32, 0.1, 0.3, 0.3, 0.5, 0.99, 1.0, 2.0];
        let occ = [0.0f32, 0.1, 0.3, 0.5, 0.99, 1.0, 2.0, 0.7];
        let mut cells = CellStates::new(4, 2, &occ, kernel, &params());
        for (k, &d) in occ.iter().enumerate() {
            let p = cells.index((k % 4, k / 4));
            assert_eq!(cells.cell(p), (k % 4, k / 4));
            assert_eq!(cells.passable.get(p), d >= 0.25, "{d}");
            assert_eq!(cells.map_free(p), d >= 0.25, "{d}");
            if d >= 0.25 {
                let want = if f64::from(d) < 1.0 {
                    (2.0 * (1.0 - f64::from(d))) as f32
                } else {
                    0.0
                };
                let view = cells.flood_view();
                let got = view.penalty(view.state(p), || d);
                assert_eq!(got.to_bits(), want.to_bits(), "{d}");
            }
        }
        // 0.7 is not a kernel distance: it is computed from the distance.
        assert_eq!(cells.states[cells.index((3, 1))] as u8, ESCAPE);
        // The ring is never passable.
        for p in 0..6 {
            assert!(!cells.passable.get(p));
        }
        // Laser obstacles change the live class and passability, not the map's.
        let p = cells.index((3, 1));
        cells.set_distance_class(p, cells.distance_class(0.0));
        assert!(!cells.passable.get(p) && cells.map_free(p));
        cells.restore_distances();
        assert!(cells.passable.get(p) && cells.states[p] as u8 == ESCAPE);
    }

    #[test]
    fn next_steps_point_at_the_neighbour_they_name() {
        let occ = vec![1.0f32; 25];
        let mut cells = CellStates::new(5, 5, &occ, [], &params());
        let centre = cells.index((2, 2));
        for (n, (di, dj)) in NEIGHBOURS.iter().enumerate() {
            let mut view = cells.flood_view();
            let s = view.state(centre);
            view.reach(centre, s, n);
            let (i, j) = (2 + isize::from(*di), 2 + isize::from(*dj));
            assert_eq!(
                cells.next_of(centre).map(|p| cells.cell(p)),
                Some((i as usize, j as usize))
            );
            // The opposite neighbour's index is 7 - n.
            let (oi, oj) = NEIGHBOURS[7 - n];
            assert_eq!((oi, oj), (-di, -dj));
        }
        cells.reset_row(2, 0, 4);
        assert_eq!(cells.next_of(centre), None);
    }

    #[test]
    fn a_plan_opens_the_passable_cells_of_its_bounds_only() {
        let mut occ = vec![1.0f32; 6 * 5];
        occ[7] = 0.0; // cell (1, 1) blocked
        let mut cells = CellStates::new(6, 5, &occ, [], &params());
        let (s, g) = (cells.index((1, 1)), cells.index((3, 2)));
        cells.open_for_plan((0, 0, 5, 4), s, true, g);
        let open = |c: &CellStates, i: usize, j: usize| c.open.get(c.index((i, j)));
        assert!(open(&cells, 0, 0) && open(&cells, 1, 1) && !open(&cells, 3, 2));
        let view = cells.flood_view();
        // Around (2, 1): (1, 0) (2, 0) (3, 0) (1, 1) (3, 1) (1, 2) (2, 2) (3, 2): all open but
        // the goal (3, 2), bit 7.
        assert_eq!(view.open_neighbours(s + 1, 8), 0b0111_1111);
        // A window: inside open, the ring round it closed, what lies beyond untouched.
        cells.open_for_plan((2, 1, 4, 3), s, false, g);
        assert!(open(&cells, 2, 1) && open(&cells, 4, 3));
        assert!(!open(&cells, 1, 2) && !open(&cells, 5, 2) && !open(&cells, 3, 0));
        assert!(!open(&cells, 3, 4) && !open(&cells, 1, 1));
        assert!(open(&cells, 0, 0), "outside the ring: left as it was");
    }
}
