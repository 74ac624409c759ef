//! The pose histogram behind KLD sampling and clustering: particles binned into cells of
//! 0.5 m x 0.5 m x 10 degrees (upstream's `pf_kdtree`, whose tree only ever serves as a map
//! from cell to contents). The number of occupied cells sets how many particles the next
//! generation needs; cells touching each other (the 26 around a cell) form the clusters that
//! become the published hypotheses.

use std::collections::HashMap;

use super::pose::Pose;

/// Cell size: x (m), y (m), heading (rad), as upstream's tree.
pub const CELL_SIZE: [f64; 3] = [0.5, 0.5, 10.0 * std::f64::consts::PI / 180.0];

type Key = [i64; 3];

/// Occupied cells and, once [`Histogram::cluster`] ran, their cluster labels.
#[derive(Clone, Debug, Default)]
pub struct Histogram {
    index: HashMap<Key, usize>,
    keys: Vec<Key>,
    labels: Vec<usize>,
    cluster_count: usize,
}

/// The cell a pose falls in. Headings are binned as they are, unwrapped, as upstream does.
fn key(pose: &Pose) -> Key {
    [
        (pose.x / CELL_SIZE[0]).floor() as i64,
        (pose.y / CELL_SIZE[1]).floor() as i64,
        (pose.z / CELL_SIZE[2]).floor() as i64,
    ]
}

impl Histogram {
    /// An empty histogram.
    pub fn new() -> Histogram {
        Histogram::default()
    }

    /// Forgets every cell.
    pub fn clear(&mut self) {
        self.index.clear();
        self.keys.clear();
        self.labels.clear();
        self.cluster_count = 0;
    }

    /// Counts a particle at `pose` (only whether its cell is occupied matters).
    pub fn insert(&mut self, pose: &Pose) {
        let k = key(pose);
        let next = self.keys.len();
        self.index.entry(k).or_insert_with(|| {
            self.keys.push(k);
            next
        });
    }

    /// How many cells are occupied (the `k` of KLD sampling).
    pub fn occupied(&self) -> usize {
        self.keys.len()
    }

    /// Labels connected groups of occupied cells (26-neighbourhood), numbering groups in the
    /// order their first cell was occupied. Returns how many groups there are.
    pub fn cluster(&mut self) -> usize {
        const UNLABELLED: usize = usize::MAX;
        self.labels.clear();
        self.labels.resize(self.keys.len(), UNLABELLED);
        let mut count = 0;
        let mut stack = Vec::new();
        for start in 0..self.keys.len() {
            if self.labels[start] != UNLABELLED {
                continue;
            }
            self.labels[start] = count;
            stack.push(start);
            while let Some(cell) = stack.pop() {
                let k = self.keys[cell];
                for n in 0..27 {
                    let nk = [k[0] + n / 9 - 1, k[1] + (n % 9) / 3 - 1, k[2] + n % 3 - 1];
                    if let Some(&neighbour) = self.index.get(&nk) {
                        if self.labels[neighbour] == UNLABELLED {
                            self.labels[neighbour] = count;
                            stack.push(neighbour);
                        }
                    }
                }
            }
            count += 1;
        }
        self.cluster_count = count;
        count
    }

    /// The cluster of the cell `pose` falls in (`None` for an empty cell, or before
    /// [`Histogram::cluster`]).
    pub fn cluster_of(&self, pose: &Pose) -> Option<usize> {
        let cell = *self.index.get(&key(pose))?;
        self.labels.get(cell).copied()
    }

    /// How many clusters the last [`Histogram::cluster`] found.
    pub fn cluster_count(&self) -> usize {
        self.cluster_count
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_are_counted_once() {
        let mut h = Histogram::new();
        h.insert(&Pose::new(0.1, 0.1, 0.01));
        h.insert(&Pose::new(0.4, 0.2, 0.1));
        assert_eq!(h.occupied(), 1);
        h.insert(&Pose::new(0.6, 0.2, 0.1));
        h.insert(&Pose::new(-0.1, 0.2, 0.1));
        assert_eq!(h.occupied(), 3);
        h.clear();
        assert_eq!(h.occupied(), 0);
    }

    #[test]
    fn touching_cells_share_a_cluster_and_apart_ones_do_not() {
        let mut h = Histogram::new();
        // A diagonal chain of cells (corner contact counts) ...
        let chain = [
            Pose::new(0.25, 0.25, 0.05),
            Pose::new(0.75, 0.75, 0.2),
            Pose::new(1.25, 1.25, 0.05),
        ];
        for p in &chain {
            h.insert(p);
        }
        // ... and a cell two cells away from all of them.
        let far = Pose::new(2.75, 0.25, 0.05);
        h.insert(&far);
        assert_eq!(h.cluster(), 2);
        assert_eq!(h.cluster_of(&chain[0]), Some(0));
        assert_eq!(h.cluster_of(&chain[2]), Some(0));
        assert_eq!(h.cluster_of(&far), Some(1));
        assert_eq!(h.cluster_of(&Pose::new(9.0, 9.0, 0.0)), None);
        // Heading separates too: 20 degrees apart is two bins, not touching.
        h.clear();
        h.insert(&Pose::new(0.0, 0.0, 0.01));
        h.insert(&Pose::new(0.0, 0.0, 0.01 + 2.0 * CELL_SIZE[2]));
        assert_eq!(h.cluster(), 2);
    }
}
