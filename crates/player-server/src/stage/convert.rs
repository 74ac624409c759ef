//! How Player reports Stage's data (Player's stage plugin, player-protocol.md §6): a ranger's
//! scans flattened into one list, a blob's centre and area in Player's integer arithmetic. The
//! stage driver publishes these; the in-process Python `World` reports the same values.

use stage_sim::{Blob, RangerData, SensorScan};

/// Player's ranges for a ranger (spec §8.3): one transducer gives all its samples, several give
/// the first sample of each.
pub fn ranger_ranges(d: &RangerData) -> Vec<f64> {
    flatten(d, d.ranges(), |s| s.ranges)
}

/// Intensities flattened like [`ranger_ranges`].
pub fn ranger_intensities(d: &RangerData) -> Vec<f64> {
    flatten(d, d.intensities(), |s| s.intensities)
}

/// `all` (one of `d`'s flat sample lists) when `d` has one transducer, else the first sample of
/// each transducer's part of it (`part`).
fn flatten<'a>(d: &'a RangerData, all: &[f64], part: fn(SensorScan<'a>) -> &'a [f64]) -> Vec<f64> {
    if d.scans().len() == 1 {
        all.to_vec()
    } else {
        d.scans().filter_map(|s| part(s).first().copied()).collect()
    }
}

/// Player's blob centre x: `left + (right − left)/2` (integer division).
pub fn blob_x(b: &Blob) -> u32 {
    b.left + (b.right - b.left) / 2
}

/// Player's blob centre y: `bottom + (top − bottom)/2` in C signed arithmetic.
pub fn blob_y(b: &Blob) -> u32 {
    let (t, bt) = (b.top as i64, b.bottom as i64);
    (bt + (t - bt) / 2) as u32
}

/// Player's `area = (right − left)·(top − bottom)`, which is ≤ 0 and wraps in the unsigned wire
/// field (spec §9.3 quirk, kept because clients can observe it).
pub fn blob_area(b: &Blob) -> u32 {
    let a = (b.right as i64 - b.left as i64) * (b.top as i64 - b.bottom as i64);
    a as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use stage_sim::Color;

    fn blob(left: u32, right: u32, top: u32, bottom: u32) -> Blob {
        Blob {
            color: Color::rgb(0.0, 1.0, 0.0),
            left,
            right,
            top,
            bottom,
            range: 1.0,
        }
    }

    /// Stage's rows grow downwards (top < bottom), so Player's area is negative and wraps.
    #[test]
    fn blob_centre_and_wrapped_area() {
        let b = blob(10, 20, 25, 35);
        assert_eq!((blob_x(&b), blob_y(&b)), (15, 30));
        let area = (20i64 - 10) * (25 - 35);
        assert!(area < 0);
        assert_eq!(blob_area(&b), area as u32);
        // odd spans round towards the start, as C's integer division does
        assert_eq!(
            (blob_x(&blob(3, 8, 1, 6)), blob_y(&blob(3, 8, 1, 6))),
            (5, 4)
        );
    }

    #[test]
    fn one_transducer_gives_every_sample_several_give_the_first_of_each() {
        fn scan<'a>(ranges: &'a [f64], intensities: &'a [f64]) -> SensorScan<'a> {
            SensorScan {
                ranges,
                intensities,
                bearings: &[],
            }
        }
        let (a, ta) = ([1.0, 2.0, 3.0], [10.0, 20.0, 30.0]);
        let (b, tb) = ([4.0, 5.0], [40.0, 50.0]);
        let mut d = RangerData::new(Vec::new());
        d.set_scans([scan(&a, &ta)]);
        assert_eq!(ranger_ranges(&d), [1.0, 2.0, 3.0]);
        d.set_scans([scan(&a, &ta), scan(&b, &tb), scan(&[], &[])]);
        assert_eq!(ranger_ranges(&d), [1.0, 4.0]);
        assert_eq!(ranger_intensities(&d), [10.0, 40.0]);
    }
}
