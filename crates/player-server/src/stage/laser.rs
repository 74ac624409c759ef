//! The legacy `laser` interface (Player 2 / Stage 3) on a Stage 4 ranger: the scan of its first
//! transducer (player-protocol.md §6.8). Stage 4.1.1 dropped it, and Player's `rangertolaser`
//! crashes on a Stage ranger; clients written for Player 2 still use `LaserProxy`.
//!
//! The device answers SET_CONFIG and GET_CONFIG as Player's `sicklms200` driver does, within
//! what the transducer can do: the scan can be narrowed to any part of its fan and thinned to
//! every k-th ray, ranges can be reported in the LMS200's units (`range_res` 1 mm, 1 cm or
//! 10 cm) and intensities switched off (then sent as zeros, as the LMS200 does). Every field is
//! in Player 3's units (radians, metres), as `sicklms200` reads it. A configuration the device
//! cannot serve is refused (NACK) with the reason logged; Player 2's units among them (a
//! resolution of "100"), which read as radians and metres would floor every client's ranges.
//! The configuration lasts for the server's life, as a driver's does.

use std::f64::consts::TAU;
use std::ops::Deref;

use player_proto::{
    Body, LaserConfig, LaserData, LaserDataScan, LaserGeom, LaserGetIdConfig, LaserMsg, LaserReq,
};
use stage_sim::{Pose, SensorDesc, World};

use super::{Bound, Interface, Out, Writing, pose3d, ranger};
use crate::driver::Reply;

/// The part of the transducer's scan a laser device serves (rays `first..=last`, every
/// `step`-th), the unit its ranges are reported in, and whether intensities are sent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct ScanConfig {
    first: u32,
    last: u32,
    step: u32,
    /// `None`: ranges as simulated (`range_res` reports the world's resolution).
    range_res: Option<f64>,
    intensity: bool,
}

impl ScanConfig {
    /// The whole fan at the transducer's own spacing, as simulated, intensities on (the
    /// LMS200's power-on state).
    fn whole(sensor: &SensorDesc) -> ScanConfig {
        ScanConfig {
            first: 0,
            last: sensor.samples.saturating_sub(1),
            step: 1,
            range_res: None,
            intensity: true,
        }
    }

    /// This device's configuration: the one a client set, else the whole fan.
    fn of(set: Option<&ScanConfig>, sensor: &SensorDesc) -> ScanConfig {
        set.copied().unwrap_or_else(|| ScanConfig::whole(sensor))
    }

    /// The rays served, in scan order.
    fn rays(&self) -> impl Iterator<Item = usize> {
        (self.first as usize..=self.last as usize).step_by(self.step.max(1) as usize)
    }

    /// The last ray served (`last` unless the step overshoots it).
    fn last_served(&self) -> u32 {
        self.first + (self.last - self.first) / self.step.max(1) * self.step.max(1)
    }

    /// First bearing, last bearing and step of the served scan (rad).
    fn angles(&self, sensor: &SensorDesc) -> (f64, f64, f64) {
        let (start, _, spacing) = fan(sensor);
        (
            start + f64::from(self.first) * spacing,
            start + f64::from(self.last_served()) * spacing,
            f64::from(self.step) * spacing,
        )
    }

    /// A simulated range in the configured unit: whole units, truncated as the LMS200 counts
    /// them (never above the simulated value, so never beyond the maximum range).
    fn range(&self, r: f64) -> f64 {
        let r = r.max(0.0);
        match self.range_res {
            // the small bias keeps exact multiples (2.0 in units of 0.1) from losing a unit
            Some(unit) => ((r / unit) + 1e-9).floor() * unit,
            None => r,
        }
    }
}

/// A `laser` device: what a client configured of its scan, and how many scans it published.
#[derive(Debug, Default)]
pub(super) struct Laser {
    /// `None`: the whole fan, as simulated.
    scan: Option<ScanConfig>,
    /// Scans published (DATA SCAN's `id`).
    scans: u32,
}

impl Interface for Laser {
    /// DATA SCAN: the configured part of the first transducer's scan (floats, never negative:
    /// libplayerc asserts it), its intensities (zeros when switched off) and bearings; `id`
    /// counts the scans.
    fn publish(&mut self, b: &Bound<'_, &World>, out: &mut Out<'_, '_>) -> Option<()> {
        let data = out.new_sample(b.answer(b.world.ranger_scans(b.model)), |s| s.time_us)?;
        let scan_id = self.scans;
        self.scans = self.scans.wrapping_add(1);
        let (Some(sensor), Some(scan)) = (data.sensors.first(), data.scan(0)) else {
            return None;
        };
        let cfg = ScanConfig::of(self.scan.as_ref(), sensor);
        let (min_angle, max_angle, resolution) = cfg.angles(sensor);
        let served = || cfg.rays().filter(|&i| i < scan.ranges.len());
        out.publish(LaserData::Scan(LaserDataScan {
            min_angle: min_angle as f32,
            max_angle: max_angle as f32,
            resolution: resolution as f32,
            max_range: sensor.range[1] as f32,
            ranges: served().map(|i| cfg.range(scan.ranges[i]) as f32).collect(),
            intensity: served()
                .map(|i| match (cfg.intensity, scan.intensities.get(i)) {
                    (true, Some(&v)) => intensity_byte(v),
                    _ => 0,
                })
                .collect(),
            id: scan_id,
        }));
        Some(())
    }

    fn request(&mut self, b: &mut Writing<'_>, body: &Body) -> Reply {
        let Body::Laser(LaserMsg::Req(req)) = body else {
            return Reply::NotHandled;
        };
        match req {
            LaserReq::GetGeom(None) => match geometry(b) {
                Some(g) => Reply::ack(LaserReq::GetGeom(Some(g))),
                None => Reply::Nack,
            },
            LaserReq::GetConfig(None) => match config(b, self.scan.as_ref()) {
                Some(c) => Reply::ack(LaserReq::GetConfig(Some(c))),
                None => Reply::Nack,
            },
            LaserReq::SetConfig(Some(c)) => set_config(b, &mut self.scan, c),
            LaserReq::GetId(_) => Reply::ack(LaserReq::GetId(Some(LaserGetIdConfig {
                serial_number: b.model.index() as u32,
            }))),
            // POWER and the filters: NACK (a simulated ranger is always on and unfiltered).
            _ => Reply::NotHandled,
        }
    }
}

/// The transducer's angular layout: first bearing, last bearing and the step between rays, as
/// the simulator casts them (first and last ray at ±fov/2).
fn fan(s: &SensorDesc) -> (f64, f64, f64) {
    if s.samples > 1 {
        (-s.fov / 2.0, s.fov / 2.0, s.fov / f64::from(s.samples - 1))
    } else {
        (0.0, 0.0, 0.0)
    }
}

/// A ranger intensity (the hit model's `ranger_return`) as a laser intensity byte.
fn intensity_byte(v: f64) -> u8 {
    v.round().clamp(0.0, 255.0) as u8
}

/// The range units an LMS200 reports in (m): Player's `sicklms200` takes `range_res` × 1000 as
/// whole millimetres and accepts 1, 10 or 100 of them.
const LMS200_RANGE_UNITS: [f64; 3] = [0.001, 0.01, 0.1];

/// Whether `range_res` (m, as sent: a float) is one of the LMS200's units, read as the driver
/// reads it (whole millimetres).
fn lms200_range_unit(range_res: f64) -> Option<f64> {
    let mm = range_res * 1000.0;
    LMS200_RANGE_UNITS
        .into_iter()
        .find(|unit| (mm - unit * 1000.0).abs() < 1e-3 * unit * 1000.0)
}

/// What SET_CONFIG `req` asks of `sensor`, or why the transducer cannot do it. `world_res` is
/// the simulation's resolution, the `range_res` the ranges already have.
fn choose(sensor: &SensorDesc, world_res: f64, req: &LaserConfig) -> Result<ScanConfig, String> {
    let (min, max) = (f64::from(req.min_angle), f64::from(req.max_angle));
    let resolution = f64::from(req.resolution);
    let range_res = f64::from(req.range_res);
    if !(min.is_finite() && max.is_finite() && resolution.is_finite() && range_res.is_finite()) {
        return Err("the angles, resolution and range_res must be numbers".into());
    }
    if resolution <= 0.0 || range_res <= 0.0 {
        return Err(format!(
            "resolution {} and range_res {range_res} must be above 0",
            req.resolution
        ));
    }
    // Player 3 counts every field in SI units (radians, metres), as `sicklms200` reads them:
    // Player 2's hundredths of a degree and millimetres (libplayerc's own laser test still
    // sends "100" and "1") would mean a step of 100 rad and 1 m ranges, which the LMS200
    // refuses; so do we, rather than floor every client's ranges to whole metres.
    if resolution > TAU {
        return Err(format!(
            "resolution {} rad is more than a turn: Player 3 counts radians (Player 2 counted \
             hundredths of a degree)",
            req.resolution
        ));
    }
    let world_unit = (range_res - world_res).abs() <= world_res * 1e-6;
    if !world_unit && lms200_range_unit(range_res).is_none() {
        return Err(format!(
            "range_res {range_res} m is none of the LMS200's units (0.001, 0.01 or 0.1 m) nor \
             the simulation's resolution {world_res} m"
        ));
    }
    if min > max {
        return Err(format!(
            "min_angle {:.2}° is above max_angle {:.2}°",
            min.to_degrees(),
            max.to_degrees()
        ));
    }
    let (start, end, spacing) = fan(sensor);
    let n = sensor.samples;
    let (first, last, step) = if n <= 1 {
        // One ray: it is the whole scan; there is no spacing to choose.
        let half = sensor.fov / 2.0;
        if min < -half - 1e-6 || max > half + 1e-6 {
            return Err(format!(
                "the ranger has one ray, of ±{:.2}°: min_angle {:.2}° and max_angle {:.2}° \
                 must lie within it",
                half.to_degrees(),
                min.to_degrees(),
                max.to_degrees()
            ));
        }
        (0, 0, 1)
    } else {
        // Angles snap to the nearest ray; half a spacing beyond either end still means the end.
        let ray = |a: f64| (a - start) / spacing;
        let outside = |a: f64| ray(a) < -0.5 || ray(a) > f64::from(n - 1) + 0.5;
        if outside(min) || outside(max) {
            return Err(format!(
                "min_angle {:.2}° and max_angle {:.2}° must lie within the ranger's fan \
                 [{:.2}°, {:.2}°]",
                min.to_degrees(),
                max.to_degrees(),
                start.to_degrees(),
                end.to_degrees()
            ));
        }
        let snap = |a: f64| ray(a).round().clamp(0.0, f64::from(n - 1)) as u32;
        let k = (resolution / spacing).round();
        if k < 1.0 {
            return Err(format!(
                "resolution {:.4}° is finer than the ranger's ray spacing {:.4}°",
                resolution.to_degrees(),
                spacing.to_degrees()
            ));
        }
        // a whole number of ray spacings, give or take a tenth of one
        if (resolution - k * spacing).abs() > spacing / 10.0 {
            return Err(format!(
                "resolution {:.4}° is not a whole number of the ranger's ray spacing {:.4}°",
                resolution.to_degrees(),
                spacing.to_degrees()
            ));
        }
        if k > f64::from(n - 1) {
            return Err(format!(
                "resolution {:.4}° is wider than the ranger's fan {:.2}°",
                resolution.to_degrees(),
                (end - start).to_degrees()
            ));
        }
        (snap(min), snap(max), k as u32)
    };
    // The simulation's own resolution (what GET_CONFIG reports by default): as simulated.
    let range_res = if world_unit {
        None
    } else {
        lms200_range_unit(range_res)
    };
    Ok(ScanConfig {
        first,
        last,
        step,
        range_res,
        intensity: req.intensity != 0,
    })
}

/// GET_GEOM: where the scan comes from — the first transducer's pose in the robot (the
/// ranger's pose composed with the transducer's) — and the size of the ranger device, as
/// Player's `rangertolaser` reports it from the ranger's geometry (0.156 x 0.155 for
/// Stage's `sicklaser`).
fn geometry<W: Deref<Target = World>>(b: &Bound<'_, W>) -> Option<LaserGeom> {
    let sensor = ranger::sensors(b).into_iter().next()?;
    let [x, y, z, a] = sensor.pose;
    let pose = b.pose().compose(&Pose { x, y, z, a });
    Some(LaserGeom {
        pose: pose3d(&pose),
        size: ranger::geometry(b).size,
    })
}

/// GET_CONFIG, and the body of a SET_CONFIG ACK: the configuration in effect.
fn config<W: Deref<Target = World>>(
    b: &Bound<'_, W>,
    set: Option<&ScanConfig>,
) -> Option<LaserConfig> {
    let data = b.answer(b.world.ranger_scans(b.model))?;
    let sensor = data.sensors.first()?;
    let cfg = ScanConfig::of(set, sensor);
    let (min_angle, max_angle, resolution) = cfg.angles(sensor);
    let interval_us = b.node().update_interval_us.max(1);
    Some(LaserConfig {
        min_angle: min_angle as f32,
        max_angle: max_angle as f32,
        resolution: resolution as f32,
        max_range: sensor.range[1] as f32,
        range_res: cfg.range_res.unwrap_or(b.world.config().resolution) as f32,
        intensity: u8::from(cfg.intensity),
        scanning_frequency: (1e6 / interval_us as f64) as f32,
    })
}

/// SET_CONFIG: applies what the transducer can do, or refuses with the reason logged. The
/// scanning frequency and maximum range are the worldfile's (the LMS200 ignores both too).
fn set_config<W: Deref<Target = World>>(
    b: &Bound<'_, W>,
    set: &mut Option<ScanConfig>,
    req: &LaserConfig,
) -> Reply {
    let name = &b.node().name;
    let Some(sensor) = b
        .answer(b.world.ranger_scans(b.model))
        .and_then(|d| d.sensors.first())
    else {
        tracing::warn!("laser on \"{name}\": SET_CONFIG refused: the ranger has no transducer");
        return Reply::Nack;
    };
    match choose(sensor, b.world.config().resolution, req) {
        Ok(chosen) => {
            *set = Some(chosen);
            match config(b, set.as_ref()) {
                Some(c) => Reply::ack(LaserReq::SetConfig(Some(c))),
                None => Reply::Nack,
            }
        }
        Err(why) => {
            tracing::warn!("laser on \"{name}\": SET_CONFIG refused: {why}");
            Reply::Nack
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sick(samples: u32) -> SensorDesc {
        SensorDesc {
            fov: 180f64.to_radians(),
            samples,
            range: [0.0, 8.0],
            ..SensorDesc::default()
        }
    }

    fn req(min_deg: f64, max_deg: f64, res: f64, range_res: f64, intensity: u8) -> LaserConfig {
        LaserConfig {
            min_angle: min_deg.to_radians() as f32,
            max_angle: max_deg.to_radians() as f32,
            resolution: res as f32,
            max_range: f32::NAN,
            range_res: range_res as f32,
            intensity,
            scanning_frequency: f32::NAN,
        }
    }

    #[test]
    fn fan_matches_the_simulated_rays() {
        let s = SensorDesc {
            fov: 1.0,
            samples: 5,
            ..SensorDesc::default()
        };
        assert_eq!(fan(&s), (-0.5, 0.5, 0.25));
        let one = SensorDesc {
            samples: 1,
            ..s.clone()
        };
        assert_eq!(fan(&one), (0.0, 0.0, 0.0));
        assert_eq!(intensity_byte(0.5), 1);
        assert_eq!(intensity_byte(0.0), 0);
        assert_eq!(intensity_byte(300.0), 255);
        assert_eq!(intensity_byte(-1.0), 0);
    }

    #[test]
    fn a_narrower_thinner_scan_is_served_from_the_rays() {
        // 361 rays over 180°: half a degree apart
        let s = sick(361);
        let c = choose(&s, 0.02, &req(-45.0, 45.0, 1f64.to_radians(), 0.01, 0)).unwrap();
        assert_eq!((c.first, c.last, c.step), (90, 270, 2));
        assert_eq!(c.rays().count(), 91);
        let (min, max, res) = c.angles(&s);
        assert!((min.to_degrees() + 45.0).abs() < 1e-9 && (max.to_degrees() - 45.0).abs() < 1e-9);
        assert!((res.to_degrees() - 1.0).abs() < 1e-9);
        assert_eq!(
            c.range_res,
            Some(0.01),
            "the LMS200's unit, as it reads the float"
        );
        assert!(!c.intensity);
        // the step can overshoot the last ray asked for: the scan ends on a served ray
        let odd = choose(&s, 0.02, &req(-90.0, 0.5, 1f64.to_radians(), 0.02, 1)).unwrap();
        assert_eq!((odd.first, odd.last, odd.last_served()), (0, 181, 180));
        assert_eq!(
            odd.range_res, None,
            "the world's resolution: ranges as simulated"
        );
    }

    #[test]
    fn the_nearest_rays_serve_a_sick_configuration() {
        // Stage's sicklaser: 180 rays over 180°, 1.0056° apart; ±90° at 1° is every ray
        let s = sick(180);
        let c = choose(&s, 0.02, &req(-90.0, 90.0, 1f64.to_radians(), 0.01, 1)).unwrap();
        assert_eq!((c.first, c.last, c.step), (0, 179, 1));
        // LMS200 units of range: 1 mm, 1 cm, 10 cm (sent as floats)
        for unit in [0.001, 0.01, 0.1] {
            let c = choose(&s, 0.02, &req(-90.0, 90.0, 1f64.to_radians(), unit, 1)).unwrap();
            assert_eq!(c.range_res, Some(unit));
        }
    }

    #[test]
    fn player_2_units_are_refused_not_read_as_metres() {
        // libplayerc's and libplayerc++'s laser tests: ±90°, "100" and "1" (Player 2's
        // hundredths of a degree and millimetres); the LMS200 driver refuses it too
        let s = sick(180);
        let why = choose(&s, 0.02, &req(-90.0, 90.0, 100.0, 1.0, 1)).unwrap_err();
        assert!(why.contains("radians"), "{why}");
        // a step in radians but ranges in whole metres: not an LMS200 unit
        let why = choose(&s, 0.02, &req(-90.0, 90.0, 1f64.to_radians(), 1.0, 1)).unwrap_err();
        assert!(why.contains("LMS200's units"), "{why}");
        // a step wider than the fan: 181 of its 179 spacings
        let wide = 181.0 * 180f64.to_radians() / 179.0;
        let why = choose(&s, 0.02, &req(-90.0, 90.0, wide, 0.01, 1)).unwrap_err();
        assert!(why.contains("wider than"), "{why}");
    }

    #[test]
    fn what_the_transducer_cannot_do_is_refused_with_a_reason() {
        let s = sick(180);
        let res = 1f64.to_radians();
        let refused = |r: LaserConfig| choose(&s, 0.02, &r).unwrap_err();
        assert!(refused(req(-100.0, 90.0, res, 0.01, 1)).contains("within the ranger's fan"));
        assert!(refused(req(10.0, -10.0, res, 0.01, 1)).contains("above max_angle"));
        assert!(refused(req(-90.0, 90.0, 0.5f64.to_radians(), 0.01, 1)).contains("finer"));
        assert!(refused(req(-90.0, 90.0, 1.5f64.to_radians(), 0.01, 1)).contains("whole number"));
        assert!(refused(req(-90.0, 90.0, res, 0.0, 1)).contains("above 0"));
        assert!(refused(req(-90.0, 90.0, -res, 0.01, 1)).contains("above 0"));
        assert!(refused(req(-90.0, 90.0, res, 0.05, 1)).contains("LMS200's units"));
        assert!(refused(req(-90.0, 90.0, f64::NAN, 0.01, 1)).contains("numbers"));
    }

    #[test]
    fn ranges_are_reported_in_whole_units_of_range_res() {
        let mut c = ScanConfig::whole(&sick(180));
        assert_eq!(c.range(1.2345), 1.2345);
        assert_eq!(c.range(-1.0), 0.0);
        c.range_res = Some(0.1);
        assert!((c.range(1.2345) - 1.2).abs() < 1e-12);
        assert!((c.range(2.0) - 2.0).abs() < 1e-12);
        c.range_res = Some(1.0);
        assert_eq!(c.range(7.99), 7.0);
    }
}
