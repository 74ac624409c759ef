//! The range table VFH reads: 361 ranges (mm), one per half degree from the robot's right
//! (index 0, bearing -90°) through straight ahead (180) to its left (360), filled from a laser
//! scan or a sonar ring the way Player 3.0.2's vfh driver fills it.

use player_proto::Pose3d;

/// Entries in a range table: 180° at half-degree steps, both ends included.
pub const RANGE_COUNT: usize = 361;

/// What a direction without any reading (before the first one from the right) gets: 1 km,
/// far beyond the occupancy window, so it reads as free.
pub const FAR: f64 = 1_000_000.0;

/// A range table: `table[i]` is the range (mm) at bearing `i / 2 - 90` degrees.
pub type HalfDegreeRanges = [f64; RANGE_COUNT];

/// A sonar's cone, as vfh spreads each transducer's range over the table (degrees).
const SONAR_CONE: f64 = 30.0;

/// Fills the entries without a reading with the nearest reading on their right (the first
/// ones, with nothing on their right, with [`FAR`]).
fn fill_gaps(readings: &[Option<f64>; RANGE_COUNT]) -> HalfDegreeRanges {
    let mut out = [FAR; RANGE_COUNT];
    let mut last = FAR;
    for (o, r) in out.iter_mut().zip(readings) {
        if let Some(r) = r {
            last = *r;
        }
        *o = last;
    }
    out
}

/// The table of a laser scan. As upstream, the scan is taken to start at the robot's right
/// (its `min_angle` is not looked at) with beams `resolution` radians apart: each whole degree
/// `i` of the 180° takes the beam nearest `i` degrees from the first one, and the half degrees
/// between take the reading on their right. Degrees past the last beam repeat it; a scan whose
/// resolution is not positive yields no readings beyond its first beam (upstream's division
/// by zero, read the same way).
pub fn from_laser(ranges: &[f32], resolution: f32) -> HalfDegreeRanges {
    let step_deg = f64::from(resolution).to_degrees();
    let mut readings = [None; RANGE_COUNT];
    for i in 0..=180usize {
        let beam = (i as f64 / step_deg).round_ties_even();
        // Negative, NaN and past-the-end beam numbers are skipped, as the unsigned compare
        // upstream skips them (0/-x is -0, which is beam 0).
        if !(beam >= 0.0 && beam < ranges.len() as f64) {
            continue;
        }
        readings[i * 2] = Some(f64::from(ranges[beam as usize]) * 1e3);
    }
    fill_gaps(&readings)
}

/// The table of a sonar ring: each transducer's range, plus its distance from the robot's
/// centre (sonars measure from the robot's rim, lasers from one point), is spread over a 30°
/// cone around its heading; later transducers overwrite earlier ones where cones overlap.
/// Transducers without a pose (more ranges than the geometry listed) are left out.
pub fn from_sonar(ranges: &[f32], poses: &[Pose3d]) -> HalfDegreeRanges {
    let mut readings = [None; RANGE_COUNT];
    for (range, pose) in ranges.iter().zip(poses) {
        let from_centre = pose.px.hypot(pose.py) as f32;
        let value = f64::from(from_centre + range) * 1e3;
        let heading = pose.pyaw.to_degrees() + 90.0;
        let mut b = heading - SONAR_CONE / 2.0;
        while b < heading + SONAR_CONE / 2.0 {
            let i = (b * 2.0).round_ties_even();
            if b >= 0.0 && i < RANGE_COUNT as f64 {
                readings[i as usize] = Some(value);
            }
            b += 0.5;
        }
    }
    fill_gaps(&readings)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_one_degree_laser_fills_every_whole_degree_and_the_halves_between() {
        let ranges: Vec<f32> = (0..181).map(|i| i as f32 / 100.0).collect();
        let t = from_laser(&ranges, 1f32.to_radians());
        assert_eq!(t[0], 0.0);
        assert!((t[180] - 900.0).abs() < 1e-3, "beam 90 at index 180");
        assert!(
            (t[181] - 900.0).abs() < 1e-3,
            "a half degree takes the reading on its right"
        );
        assert!((t[360] - 1800.0).abs() < 1e-3);
    }

    #[test]
    fn stages_180_beam_sick_is_stretched_over_the_180_degrees() {
        // Stage's sicklaser: 180 samples over 180°, 180/179° apart.
        let ranges: Vec<f32> = (0..180).map(|i| i as f32).collect();
        let t = from_laser(&ranges, (180f32 / 179.0).to_radians());
        assert_eq!(t[2 * 179], 178e3, "179° is beam round(179 / 1.0056) = 178");
        assert_eq!(t[360], 179e3, "the last degree takes the last beam");
    }

    #[test]
    fn a_narrow_scan_repeats_its_last_beam_leftwards() {
        // A 90° scan, 2° steps: beams cover degrees 0..=90; beyond, the last one repeats.
        let ranges = vec![2.0f32; 46];
        let mut with_near_end = ranges.clone();
        with_near_end[45] = 0.5;
        let t = from_laser(&with_near_end, 2f32.to_radians());
        assert_eq!(t[0], 2000.0);
        assert_eq!(t[180], 500.0);
        assert_eq!(t[360], 500.0);
    }

    #[test]
    fn degenerate_resolutions_read_as_free_or_as_the_first_beam() {
        let t = from_laser(&[0.5], 0.0);
        assert!(t.iter().all(|&r| r == FAR));
        let t = from_laser(&[0.5, 0.6], -0.01);
        assert!(t.iter().all(|&r| r == 500.0));
        let t = from_laser(&[], 0.01);
        assert!(t.iter().all(|&r| r == FAR));
    }

    fn pose(px: f64, py: f64, yaw_deg: f64) -> Pose3d {
        Pose3d {
            px,
            py,
            pz: 0.0,
            proll: 0.0,
            ppitch: 0.0,
            pyaw: yaw_deg.to_radians(),
        }
    }

    #[test]
    fn sonar_cones_are_spread_and_measured_from_the_centre() {
        // One sonar ahead, 0.3 m from the centre, reading 1 m: 75°..105° hold 1.3 m.
        let t = from_sonar(&[1.0], &[pose(0.3, 0.0, 0.0)]);
        assert_eq!(t[149], FAR, "right of the cone, nothing on its right: free");
        assert!((t[150] - 1300.0).abs() < 1e-3);
        assert!((t[209] - 1300.0).abs() < 1e-3);
        assert!((t[360] - 1300.0).abs() < 1e-3, "filled leftwards");
        // A later sonar overwrites the overlap; one behind the robot falls outside the table.
        let t = from_sonar(
            &[1.0, 2.0, 0.1],
            &[
                pose(0.0, 0.0, 0.0),
                pose(0.0, 0.0, 10.0),
                pose(0.0, 0.0, 180.0),
            ],
        );
        assert_eq!(t[169], 1000.0);
        assert_eq!(t[170], 2000.0, "overlap: the later sonar");
        assert_eq!(t[229], 2000.0);
        assert_eq!(t[360], 2000.0);
        // More ranges than poses: the extra ones are left out.
        let t = from_sonar(&[1.0, 0.1], &[pose(0.0, 0.0, 0.0)]);
        assert_eq!(t[180], 1000.0);
    }
}
