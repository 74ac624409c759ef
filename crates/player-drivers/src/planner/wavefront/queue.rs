//! The wavefront's priority queue: cells waiting to be expanded, cheapest first and, among
//! equal costs, first queued first.
//!
//! That order is total, so any queue that keeps it exactly expands the same cells in the same
//! sequence and gives the same paths. When every step costs something (a positive cell size
//! and a non-negative `dist_penalty`), a cell's cost is never below the cost of the cell it
//! was reached from, so the costs popped never decrease and a buckets heap can be used: each
//! cost is filed by the highest bit in which it differs from the last cost popped, and a
//! bucket is only sorted out when everything below it is empty. It moves each entry a few
//! times at most, against the twenty-odd comparisons a binary heap makes per pop over the
//! million cells of a building's map. Negative penalties make the costs non-monotone; those
//! plans keep a binary heap.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// `cost`'s bits mapped so that unsigned order is `f32::total_cmp`'s order: the sign bit
/// flipped for positives, every bit for negatives.
fn ordered_bits(cost: f32) -> u32 {
    let bits = cost.to_bits();
    if bits >> 31 == 1 {
        !bits
    } else {
        bits | 0x8000_0000
    }
}

/// The cost [`ordered_bits`] was given.
fn cost_of(ordered: u32) -> f32 {
    f32::from_bits(if ordered >> 31 == 1 {
        ordered & 0x7fff_ffff
    } else {
        !ordered
    })
}

/// A queue of cells (as grid indices) waiting with their costs, popped cheapest first and,
/// among equal costs, first queued first.
pub(super) trait WaveOrder {
    /// Empties the queue, keeping its room.
    fn clear(&mut self);
    /// Queues `cell` at `cost`, after every cell already queued at the same cost.
    fn push(&mut self, cost: f32, cell: u32);
    /// The cheapest cell (the first queued of equals) and its cost, taken off the queue.
    fn pop(&mut self) -> Option<(f32, u32)>;
}

/// The wavefront's queue: buckets where costs never decrease, a binary heap otherwise. The
/// wavefront takes the one it has and runs on it directly, so a push or a pop dispatches on
/// nothing.
#[derive(Clone, Debug)]
pub(super) enum WaveQueue {
    /// For costs that never fall below the last one popped.
    Monotone(BucketQueue),
    /// For anything else.
    General(HeapQueue),
}

impl WaveQueue {
    /// An empty queue. `Some(width)` promises that no cost pushed is below the last popped,
    /// and that the costs of successive cells mostly differ by at least `width` (positive),
    /// which sizes the buckets; `None` makes no promise.
    pub(super) fn new(monotone: Option<f64>) -> WaveQueue {
        match monotone {
            Some(width) => WaveQueue::Monotone(BucketQueue::new(width)),
            None => WaveQueue::General(HeapQueue::default()),
        }
    }
}

/// A binary heap of (cost bits above the push count, so that one integer comparison orders
/// as (cost, order) would; cell), and the pushes so far.
#[derive(Clone, Debug, Default)]
pub(super) struct HeapQueue {
    heap: BinaryHeap<Reverse<(u64, u32)>>,
    order: u32,
}

impl WaveOrder for HeapQueue {
    fn clear(&mut self) {
        self.heap.clear();
        self.order = 0;
    }

    #[inline]
    fn push(&mut self, cost: f32, cell: u32) {
        self.order += 1;
        let key = (u64::from(ordered_bits(cost)) << 32) | u64::from(self.order);
        self.heap.push(Reverse((key, cell)));
    }

    #[inline]
    fn pop(&mut self) -> Option<(f32, u32)> {
        self.heap
            .pop()
            .map(|Reverse((key, cell))| (cost_of((key >> 32) as u32), cell))
    }
}

/// A bucket queue for costs that never decrease (Dial's, with real costs): bucket `b` holds
/// the costs in `[b * width, (b + 1) * width)`, in the order they were pushed. A bucket is
/// sorted by cost (stably, so equal costs stay first in, first out) when it becomes the
/// first, and then read from the front. A cell expanded from the first bucket costs at
/// least `width` more, so it lands in a later bucket; one that does not (rounding, or a
/// cheaper step than promised) is put in its place among the first bucket's rest. Each entry
/// is written once and sorted once in a small bucket, where a binary heap compares it about
/// twenty times across a queue of thousands. The buckets in use (from the first to the
/// farthest a step can reach) live in a ring that grows when a step reaches past it.
#[derive(Clone, Debug)]
pub(super) struct BucketQueue {
    /// The reciprocal of the bucket width (multiplying keeps the bucket number monotone in
    /// the cost, which is all the order needs, and is cheaper than dividing).
    per_width: f64,
    /// The number of the first bucket.
    first: u64,
    /// Bucket `b` at `ring[b & (ring.len() - 1)]`, for `b` from `first` on: (cost as
    /// [`ordered_bits`], cell).
    ring: Vec<Vec<(u32, u32)>>,
    /// How many entries of the first bucket have been popped; it is sorted when this is
    /// above zero.
    head: usize,
    /// Entries queued and not popped.
    count: usize,
}

impl BucketQueue {
    fn new(width: f64) -> BucketQueue {
        BucketQueue {
            per_width: 1.0 / width,
            first: 0,
            ring: vec![Vec::new(); 64],
            head: 0,
            count: 0,
        }
    }

    /// The bucket of `cost`.
    #[inline]
    fn bucket(&self, cost: f32) -> u64 {
        // Non-negative costs only (the promise); `as` saturates anything else to 0. (Through
        // i64: the conversion to a signed integer is one instruction, to an unsigned one not.)
        ((f64::from(cost) * self.per_width) as i64).max(0) as u64
    }

    /// Makes the ring hold buckets `first` to `first + ahead`.
    #[cold]
    fn grow(&mut self, ahead: usize) {
        let size = (ahead + 1).next_power_of_two() * 2;
        let mut old = std::mem::take(&mut self.ring);
        let old_mask = old.len() - 1;
        let mut ring = vec![Vec::new(); size];
        for b in self.first..self.first + old.len() as u64 {
            ring[b as usize & (size - 1)] = std::mem::take(&mut old[b as usize & old_mask]);
        }
        self.ring = ring;
    }

    /// A push into the first bucket once it is being read, or past the ring.
    #[cold]
    #[inline(never)]
    fn push_rare(&mut self, ahead: usize, key: u32, cell: u32) {
        if ahead == 0 {
            // The first bucket is sorted and partly read: after every cost not above this one.
            let head = self.head;
            let mask = self.ring.len() - 1;
            let front = &mut self.ring[self.first as usize & mask];
            let place = head + front[head..].partition_point(|&(k, _)| k <= key);
            front.insert(place, (key, cell));
            return;
        }
        self.grow(ahead);
        let mask = self.ring.len() - 1;
        self.ring[(self.first as usize + ahead) & mask].push((key, cell));
    }
}

/// Sorts a bucket by cost, stably (equal costs stay in the order they were pushed). Buckets
/// hold around ten entries on a building's map, few enough for an insertion sort; longer
/// ones go to the library's merge sort.
fn sort_bucket(bucket: &mut [(u32, u32)]) {
    if bucket.len() > 48 {
        bucket.sort_by_key(|&(k, _)| k);
        return;
    }
    for n in 1..bucket.len() {
        let entry = bucket[n];
        let mut at = n;
        // Only past strictly greater keys: an equal key stays behind the earlier one.
        while at > 0 && bucket[at - 1].0 > entry.0 {
            bucket[at] = bucket[at - 1];
            at -= 1;
        }
        bucket[at] = entry;
    }
}

impl WaveOrder for BucketQueue {
    fn clear(&mut self) {
        self.ring.iter_mut().for_each(Vec::clear);
        self.first = 0;
        self.head = 0;
        self.count = 0;
    }

    #[inline(always)]
    fn push(&mut self, cost: f32, cell: u32) {
        let key = ordered_bits(cost);
        let b = self.bucket(cost).max(self.first);
        let ahead = (b - self.first) as usize;
        self.count += 1;
        if (ahead == 0 && self.head > 0) || ahead >= self.ring.len() {
            self.push_rare(ahead, key, cell);
            return;
        }
        let mask = self.ring.len() - 1;
        self.ring[b as usize & mask].push((key, cell));
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(f32, u32)> {
        if self.count == 0 {
            return None;
        }
        let mask = self.ring.len() - 1;
        loop {
            let front = &mut self.ring[self.first as usize & mask];
            if self.head < front.len() {
                if self.head == 0 {
                    sort_bucket(front);
                }
                let (key, cell) = front[self.head];
                self.head += 1;
                self.count -= 1;
                return Some((cost_of(key), cell));
            }
            front.clear();
            self.first += 1;
            self.head = 0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ordered_bits_order_as_total_cmp_and_give_the_cost_back() {
        let costs = [
            -3.5f32,
            -0.0,
            0.0,
            1e-30,
            0.1,
            0.1000001,
            2.0,
            1e9,
            f32::INFINITY,
        ];
        for &a in &costs {
            assert_eq!(cost_of(ordered_bits(a)).to_bits(), a.to_bits());
            for &b in &costs {
                assert_eq!(
                    ordered_bits(a).cmp(&ordered_bits(b)),
                    a.total_cmp(&b),
                    "{a} {b}"
                );
            }
        }
    }

    #[test]
    fn both_queues_pop_cheapest_first_then_first_queued() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut buckets = BucketQueue::new(0.1);
        let mut binary = HeapQueue::default();
        let mut floor = 0f32;
        let mut cell = 0u32;
        let mut popped = 0;
        let mut check = |a: Option<(f32, u32)>, b: Option<(f32, u32)>, floor: &mut f32| {
            assert_eq!(a, b);
            if let Some((cost, _)) = a {
                assert!(cost >= *floor);
                *floor = cost;
                popped += 1;
            }
        };
        for round in 0..40_000 {
            if round == 20_000 {
                // Reuse after clearing.
                buckets.clear();
                binary.clear();
                floor = 0.0;
            }
            if rng.random_bool(0.55) {
                // Costs at or above the last popped, many sharing one.
                // Some below the bucket width, which must still come out in order.
                let cost = floor + [0.0, 0.0, 0.01, 0.1, 0.25, 1.5, 300.0][rng.random_range(0..7)];
                cell += 1;
                buckets.push(cost, cell);
                binary.push(cost, cell);
            } else {
                check(buckets.pop(), binary.pop(), &mut floor);
            }
        }
        while let Some(a) = buckets.pop() {
            check(Some(a), binary.pop(), &mut floor);
        }
        assert_eq!(binary.pop(), None);
        assert!(popped > 10_000, "{popped}");
    }
}
