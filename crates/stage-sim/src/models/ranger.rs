//! `ranger` and its `sensor` transducers (spec §8).

use std::sync::Mutex;

use super::{KindDesc, ModelKind};
use crate::color::Color;
use crate::digest::Digest;
use crate::node::{ModelId, Node};
use crate::pool::share_out;
use crate::pose::Pose;
use crate::rng::SimRng;
use crate::space::RayHit;
use crate::view::View;
use worldfile::models as wm;

/// One ranger transducer (`sensor` entity, spec §8.1).
#[derive(Clone, Debug, PartialEq)]
pub struct SensorDesc {
    /// Pose in the ranger's body frame.
    pub pose: Pose,
    /// Size (m); `size.z/2` raises the ray origin.
    pub size: [f64; 3],
    /// `[min, max]` range (m); only `max` limits rays.
    pub range: [f64; 2],
    /// Angular spread (rad).
    pub fov: f64,
    /// Number of rays.
    pub samples: u32,
    /// Standard deviation of additive Gaussian range noise (m); 0 = Stage's noiseless ranger.
    pub noise: f64,
    /// Standard deviation of multiplicative range noise: each range is multiplied by a draw
    /// from N(1, sd), as Stage's `lasernoise` example controller does; 0 = none.
    pub noise_relative: f64,
    /// GUI colour.
    pub color: Color,
}

impl Default for SensorDesc {
    /// Stage's defaults, from the worldfile crate's property table.
    fn default() -> Self {
        SensorDesc::from_spec(
            &wm::SensorSpec::default(),
            &mut crate::rng::SimRng::new(0, 0),
        )
    }
}

impl SensorDesc {
    /// A ranger transducer from its worldfile properties (`random` colours drawn from `rng`).
    pub(crate) fn from_spec(s: &wm::SensorSpec, rng: &mut SimRng) -> SensorDesc {
        SensorDesc {
            pose: Pose::from_array(s.pose),
            size: s.size,
            range: s.range,
            fov: s.fov,
            samples: s.samples.clamp(0, 1 << 20) as u32,
            noise: 0.0,
            noise_relative: 0.0,
            color: crate::color::from_spec(&s.color, rng),
        }
    }
}

/// Fans of at least two chunks of this many rays are cast in parallel, chunk by chunk (see
/// [`share_out`]): a 180-ray laser is a whole step's work in a one-robot world. Each chunk costs
/// a claim, a lock and its own setup; 24-32 rays was the best trade against balance
/// (simple.world, 2 cores: chunks of 10 were 8% slower, of 20 3%, of 45-60 5-10%).
const FAN_CHUNK: usize = 28;

/// One transducer's latest scan.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SensorScan {
    /// Range per sample (m); `range.max` on a miss.
    pub ranges: Vec<f64>,
    /// Intensity per sample: the hit model's `ranger_return`, 0 on a miss.
    pub intensities: Vec<f64>,
    /// Bearing of each sample relative to the sensor heading (rad).
    pub bearings: Vec<f64>,
}

/// A ranger's configuration and data (what a server publishes as Player `ranger` data).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RangerData {
    /// Sim time of the update that produced the scans (µs); 0 before the first update.
    pub time_us: u64,
    /// Transducer configuration, in entity order.
    pub sensors: Vec<SensorDesc>,
    /// Latest scan per transducer (empty before the first update and after shutdown).
    pub scans: Vec<SensorScan>,
    /// Per transducer: cos/sin of the first ray's heading and of the angular step.
    dirs: Vec<[f64; 4]>,
}

impl RangerData {
    /// A ranger with the given transducers and no data yet.
    pub fn new(sensors: Vec<SensorDesc>) -> RangerData {
        RangerData {
            time_us: 0,
            sensors,
            scans: Vec::new(),
            dirs: Vec::new(),
        }
    }

    /// Total rays per update.
    pub fn ray_count(&self) -> usize {
        self.sensors.iter().map(|s| s.samples as usize).sum()
    }

    /// Clears the data (shutdown).
    pub fn clear(&mut self) {
        self.scans.clear();
        self.time_us = 0;
    }
}

pub(crate) fn desc_from_spec(r: &wm::RangerSpec, rng: &mut SimRng) -> Vec<SensorDesc> {
    r.sensors
        .iter()
        .map(|s| SensorDesc::from_spec(s, rng))
        .collect()
}

pub(crate) fn start(sensors: &[SensorDesc], _: &Pose, _: &mut SimRng) -> RangerData {
    RangerData::new(sensors.to_vec())
}

impl ModelKind for RangerData {
    fn ray_cost(&self) -> usize {
        self.ray_count()
    }

    #[inline]
    fn update(&mut self, v: &View, m: ModelId, _: &Pose, _: &Node, rng: &mut SimRng) {
        update(v, m, self, rng)
    }

    fn shutdown(&mut self) {
        self.clear();
    }

    /// Feeds every transducer's ranges, intensities and bearings to the determinism digest.
    fn digest(&self, d: &mut Digest) {
        d.u64(self.time_us);
        for s in &self.scans {
            d.u64(s.ranges.len() as u64);
            for ((&r, &i), &b) in s.ranges.iter().zip(&s.intensities).zip(&s.bearings) {
                d.f64(r);
                d.f64(i);
                d.f64(b);
            }
        }
    }
}

/// A Stage 3 `laser`, simulated as a ranger with one sensor ([`wm::LaserSpec::as_sensor`]), and
/// the warning that says so.
pub(crate) fn laser_as_ranger(l: &wm::LaserSpec, rng: &mut SimRng) -> (KindDesc, String) {
    let sensor = SensorDesc::from_spec(&l.as_sensor(), rng);
    let why = format!(
        "Stage 3 `laser` simulated as a ranger with one {}-sample sensor",
        l.samples
    );
    (KindDesc::Ranger(vec![sensor]), why)
}

/// Whether model `h` stops ranger rays (a negative `ranger_return` lets them through).
#[inline(always)]
fn stops_rays(v: &View, h: ModelId) -> bool {
    v.nodes[h.index()].returns.ranger >= 0.0
}

/// What a transducer reads for a ray's `hit`: the range and the intensity (the model's
/// `ranger_return`), or `max` and 0 on a miss.
#[inline(always)]
fn reading(v: &View, hit: Option<RayHit>, max: f64) -> (f64, f64) {
    match hit {
        Some(h) => (h.range, v.nodes[h.model.index()].returns.ranger),
        None => (max, 0.0),
    }
}

/// One ray from `o` (x, y and the height for the z test): its [`reading`].
#[inline(always)]
fn cast_ray(v: &View, o: [f64; 3], dir: [f64; 2], max: f64, root: ModelId) -> (f64, f64) {
    let hit = v
        .space
        .raycast_dir([o[0], o[1]], dir, max, Some(o[2]), Some(root), |h| {
            stops_rays(v, h)
        });
    reading(v, hit, max)
}

/// [`cast_ray`] along each of `dirs`, handing `out` each ray's index and reading.
#[inline(always)]
fn cast_fan(
    v: &View,
    o: [f64; 3],
    dirs: &[[f64; 2]],
    max: f64,
    root: ModelId,
    mut out: impl FnMut(usize, f64, f64),
) {
    let pred = |h: ModelId| stops_rays(v, h);
    v.space.raycast_fan(
        [o[0], o[1]],
        dirs,
        max,
        Some(o[2]),
        Some(root),
        pred,
        |i, hit| {
            let (r, s) = reading(v, hit, max);
            out(i, r, s)
        },
    );
}

/// A transducer's first bearing and the step between bearings (rad; both 0 for one sample).
fn fan_angles(s: &SensorDesc) -> (f64, f64) {
    let n = s.samples.max(1);
    if n > 1 {
        (-s.fov / 2.0, s.fov / (n - 1) as f64)
    } else {
        (0.0, 0.0)
    }
}

/// `r` with the transducer's additive (clamped to its range) and multiplicative noise.
#[inline(always)]
fn with_noise(sensor: &SensorDesc, mut r: f64, rng: &mut SimRng) -> f64 {
    if sensor.noise > 0.0 {
        r = (r + rng.normal(sensor.noise)).clamp(0.0, sensor.range[1]);
    }
    if sensor.noise_relative > 0.0 {
        r *= 1.0 + rng.normal(sensor.noise_relative);
    }
    r
}

/// Fans shorter than this are cast in one call on the updating thread (longer ones in chunks).
const SHORT_FAN: usize = 2 * FAN_CHUNK;

/// Most consecutive one-sample transducers at one origin cast as one fan (hospital's
/// `swarmbot` has 12 IR sensors at its centre).
const LONGEST_RUN: usize = 16;

/// One ranger update: casts every transducer's fan from the ranger's body frame.
fn update(v: &View, m: ModelId, d: &mut RangerData, rng: &mut SimRng) {
    let frame = v.body_frame(m);
    let root = v.root(m);
    d.scans.resize_with(d.sensors.len(), SensorScan::default);
    let (fs, fc) = frame.a.sin_cos();
    if d.dirs.len() != d.sensors.len() {
        d.dirs = d
            .sensors
            .iter()
            .map(|s| {
                let (start, incr) = fan_angles(s);
                let (ss, sc) = (s.pose.a + start).sin_cos();
                let (is, ic) = incr.sin_cos();
                [sc, ss, ic, is]
            })
            .collect();
    }
    // a transducer's ray origin (x, y and the height for the z test) and its first direction
    let origin = |sensor: &SensorDesc| -> [f64; 3] {
        let (sx, sy) = (sensor.pose.x, sensor.pose.y);
        [
            frame.x + sx * fc - sy * fs,
            frame.y + sx * fs + sy * fc,
            frame.z + sensor.pose.z + sensor.size[2] / 2.0,
        ]
    };
    let first_dir = |[sc, ss, _, _]: [f64; 4]| [fc * sc - fs * ss, fs * sc + fc * ss];
    // a run's directions and readings (set up once per update, not per run)
    let mut dirs = [[0.0; 2]; LONGEST_RUN];
    let mut readings = [(0.0, 0.0); LONGEST_RUN];
    let mut k = 0;
    while k < d.sensors.len() {
        let sensor = &d.sensors[k];
        let n = sensor.samples.max(1) as usize;
        let o = origin(sensor);
        let max = sensor.range[1];
        if n == 1 {
            // this and the following one-sample transducers from the same origin with the same
            // reach: one fan, so that what the rays share is worked out once
            let mut run = 1;
            while k + run < d.sensors.len()
                && run < LONGEST_RUN
                && d.sensors[k + run].samples.max(1) == 1
                && d.sensors[k + run].range[1] == max
                && origin(&d.sensors[k + run]) == o
            {
                run += 1;
            }
            if run == 1 {
                // a lone ray: a fan's shared setup would cost more than it saves
                readings[0] = cast_ray(v, o, first_dir(d.dirs[k]), max, root);
            } else {
                for (j, slot) in dirs[..run].iter_mut().enumerate() {
                    *slot = first_dir(d.dirs[k + j]);
                }
                cast_fan(v, o, &dirs[..run], max, root, |i, r, s| {
                    readings[i] = (r, s)
                });
            }
            // noise in transducer order, as ray by ray
            for (j, &(r, s)) in readings[..run].iter().enumerate() {
                let (sensor, scan) = (&d.sensors[k + j], &mut d.scans[k + j]);
                let r = with_noise(sensor, r, rng);
                if let ([range], [intensity], [_]) = (
                    &mut scan.ranges[..],
                    &mut scan.intensities[..],
                    &scan.bearings[..],
                ) {
                    *range = r;
                    *intensity = s;
                } else {
                    *scan = SensorScan {
                        ranges: vec![r],
                        intensities: vec![s],
                        bearings: vec![0.0],
                    };
                }
            }
            k += run;
            continue;
        }
        let (start, incr) = fan_angles(sensor);
        let bearing = |t: usize| start + t as f64 * incr;
        let [_, _, ic, is] = d.dirs[k];
        // sweep the fan by rotating the direction vector (one sine/cosine per sensor)
        let rotate = |[c, s]: [f64; 2]| [c * ic - s * is, c * is + s * ic];
        let scan = &mut d.scans[k];
        scan.ranges.resize(n, 0.0);
        scan.intensities.resize(n, 0.0);
        scan.bearings.resize(n, 0.0);
        let first = first_dir(d.dirs[k]);
        if n >= SHORT_FAN {
            // long fan: the casts in parallel chunks, each thread sweeping the directions up
            // to its chunks (the same sequence of rotations as below, so the same directions),
            // then the noise in ray order so that the random stream does not depend on how the
            // casts were split. Each chunk's part of the scan waits behind a lock of its own,
            // taken once, by whichever thread claims the chunk.
            let parts: Vec<Mutex<(&mut [f64], &mut [f64])>> = scan
                .ranges
                .chunks_mut(FAN_CHUNK)
                .zip(scan.intensities.chunks_mut(FAN_CHUNK))
                .map(Mutex::new)
                .collect();
            // per thread: the index of the next direction and that direction
            let sweep = || (0usize, first);
            share_out(n, FAN_CHUNK, sweep, |(at, dir), rays| {
                while *at < rays.start {
                    *dir = rotate(*dir);
                    *at += 1;
                }
                let mut dirs = [[0.0; 2]; FAN_CHUNK];
                for slot in &mut dirs[..rays.len()] {
                    *slot = *dir;
                    *dir = rotate(*dir);
                    *at += 1;
                }
                let mut part = parts[rays.start / FAN_CHUNK]
                    .lock()
                    .unwrap_or_else(|poisoned| poisoned.into_inner());
                let (ranges, intensities) = &mut *part;
                cast_fan(v, o, &dirs[..rays.len()], max, root, |i, r, s| {
                    ranges[i] = r;
                    intensities[i] = s;
                });
            });
            drop(parts);
            // this path runs on one thread between parallel parts: skip what cannot change
            if sensor.noise > 0.0 || sensor.noise_relative > 0.0 {
                for r in scan.ranges.iter_mut() {
                    *r = with_noise(sensor, *r, rng);
                }
            }
            if scan.bearings[0] != bearing(0) || scan.bearings[n - 1] != bearing(n - 1) {
                for (t, b) in scan.bearings.iter_mut().enumerate() {
                    *b = bearing(t);
                }
            }
        } else {
            // short fan: one fan call, then the noise in ray order
            let mut dirs = [[0.0; 2]; SHORT_FAN];
            let mut dir = first;
            for slot in &mut dirs[..n] {
                *slot = dir;
                dir = rotate(dir);
            }
            let (ranges, intensities) = (&mut scan.ranges, &mut scan.intensities);
            cast_fan(v, o, &dirs[..n], max, root, |i, r, s| {
                ranges[i] = r;
                intensities[i] = s;
            });
            for t in 0..n {
                scan.ranges[t] = with_noise(sensor, scan.ranges[t], rng);
                scan.bearings[t] = bearing(t);
            }
        }
        k += 1;
    }
    d.time_us = v.sim_time;
}
