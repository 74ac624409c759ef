//! The `"explore"` task's map of the free space a robot's rangers have shown, kept beside the
//! world it maps.
//!
//! Native so that `VectorStageEnv` scores every copy on the simulation's threads (and a lone
//! `StageEnv` by the same code, so both agree to the bit): marking the cells along a laser's
//! 180 rays is most of the task's cost, and done in numpy per copy it was the serial part of a
//! vector step.

use player_server::stage::convert as player_view;
use stage_sim::ModelId;

use crate::world::ranger_rays;

/// A world-frame grid of square cells, each seen free or not, and the rangers that see.
///
/// A ranger reading marks as seen the cells of the points sampled every half cell along its
/// ray (`k * cell / 2` for `k = 0, 1, ...` while short of the range read, clipped to `[0,
/// reach]`; a NaN reading marks nothing) from where its transducer sits, at the transducer's
/// heading plus the reading's bearing ([`ranger_rays`]). The grid covers the world's extent at
/// the episode's start plus the rangers' reach and a cell; points outside are not counted.
pub struct ExploreMap {
    /// Each ranger that sees and its reach (`range_max`, m).
    rangers: Vec<(ModelId, f64)>,
    /// The grid's lower-left corner (m).
    x0: f64,
    y0: f64,
    /// The side of a cell (m).
    cell: f64,
    nx: usize,
    ny: usize,
    /// Row-major by x: cell `(ix, iy)` is `seen[ix * ny + iy]`.
    seen: Vec<bool>,
    /// Cells seen so far.
    count: u64,
}

impl ExploreMap {
    /// An empty map over `extent` (`[x0, y0, x1, y1]`) grown by the largest reach of
    /// `rangers` plus one cell on every side, of `cell`-metre cells. `None` when the grid
    /// would not be a sane size (a cell far too small for the world: over 2^28 cells).
    pub fn new(rangers: Vec<(ModelId, f64)>, extent: [f64; 4], cell: f64) -> Option<Self> {
        let reach = rangers
            .iter()
            .map(|r| r.1)
            .fold(f64::NEG_INFINITY, f64::max);
        let [x0, y0, x1, y1] = extent;
        let pad = reach + cell;
        let nx = ((x1 - x0 + 2.0 * pad) / cell).ceil();
        let ny = ((y1 - y0 + 2.0 * pad) / cell).ceil();
        if !(nx >= 1.0 && ny >= 1.0 && nx * ny <= (1u64 << 28) as f64) {
            return None;
        }
        let (nx, ny) = (nx as usize, ny as usize);
        Some(ExploreMap {
            rangers,
            x0: x0 - pad,
            y0: y0 - pad,
            cell,
            nx,
            ny,
            seen: vec![false; nx * ny],
            count: 0,
        })
    }

    /// Marks what the rangers' current readings in `world` show free; returns how many cells
    /// were seen for the first time. A ranger without readings yet marks nothing.
    pub fn see(&mut self, world: &stage_sim::World) -> stage_sim::Result<u64> {
        let mut new = 0;
        for &(m, reach) in &self.rangers {
            let ranges = player_view::ranger_ranges(world.ranger_scans(m)?);
            let rays = ranger_rays(world, m)?;
            if ranges.is_empty() || rays.len() != ranges.len() {
                continue;
            }
            let step = self.cell / 2.0;
            // the sample distances: 0, step, 2 step, ... short of the reach
            let samples = (reach / step).ceil().max(0.0) as usize;
            for (&r, ray) in ranges.iter().zip(&rays) {
                if r.is_nan() {
                    continue; // no sample is short of a NaN reading: nothing marked
                }
                let end = r.max(0.0).min(reach); // clipped to [0, reach]
                let bx = (ray[0] - self.x0) / self.cell;
                let by = (ray[1] - self.y0) / self.cell;
                let (c, s) = (ray[2].cos(), ray[2].sin());
                for k in 0..samples {
                    let t = k as f64 * step;
                    if t >= end {
                        break;
                    }
                    let steps = t / self.cell;
                    let fx = bx + c * steps;
                    let fy = by + s * steps;
                    if !(fx >= 0.0 && fy >= 0.0) {
                        continue;
                    }
                    let (ix, iy) = (fx as usize, fy as usize); // floor, both >= 0
                    if ix >= self.nx || iy >= self.ny {
                        continue;
                    }
                    let seen = &mut self.seen[ix * self.ny + iy];
                    if !*seen {
                        *seen = true;
                        new += 1;
                    }
                }
            }
        }
        self.count += new;
        Ok(new)
    }

    /// `cells` cells as an area (m^2), as the task reports it.
    pub fn area(&self, cells: u64) -> f64 {
        cells as f64 * self.cell * self.cell
    }

    /// The area seen so far (m^2).
    pub fn explored(&self) -> f64 {
        self.area(self.count)
    }
}
