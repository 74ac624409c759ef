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
    /// The transducer's slots in the flat lists: its samples, and one for a transducer of
    /// none.
    fn slots(&self) -> usize {
        self.samples.max(1) as usize
    }

    /// Whether the transducer adds any noise to its ranges (see `with_noise`).
    fn is_noisy(&self) -> bool {
        self.noise > 0.0 || self.noise_relative > 0.0
    }

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

/// One transducer's latest scan: its part of the ranger's sample lists.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorScan<'a> {
    /// Range per sample (m); `range.max` on a miss.
    pub ranges: &'a [f64],
    /// Intensity per sample: the hit model's `ranger_return`, 0 on a miss.
    pub intensities: &'a [f64],
    /// Bearing of each sample relative to the sensor heading (rad).
    pub bearings: &'a [f64],
}

/// A ranger's configuration and data (what a server publishes as Player `ranger` data).
///
/// The samples of every transducer sit in three flat lists, transducer after transducer,
/// rather than three small lists per transducer: a swarmbot's 12 one-sample IR sensors are
/// written by every update and read by its controller every step, and 36 separate allocations
/// per robot scatter that work over memory.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RangerData {
    /// Sim time of the update that produced the scans (µs); 0 before the first update.
    pub time_us: u64,
    /// Transducer configuration, in entity order.
    pub sensors: Vec<SensorDesc>,
    /// Every transducer's ranges, one after the other (empty before the first update and after
    /// shutdown).
    ranges: Vec<f64>,
    /// Intensities, laid out as `ranges`.
    intensities: Vec<f64>,
    /// Bearings, laid out as `ranges`.
    bearings: Vec<f64>,
    /// Per transducer, one past its last sample in the flat lists (empty: no scans).
    ends: Vec<usize>,
    /// Per transducer: cos/sin of the first ray's heading and of the angular step.
    dirs: Vec<[f64; 4]>,
    /// How the transducers are cast, in entity order: each entry a number of consecutive
    /// transducers cast together (one-sample transducers at one origin with one reach, as one
    /// fan), so that an update reads its transducers' descriptions only for their origins.
    runs: Vec<usize>,
    /// No transducer adds noise (the updates skip the noise pass).
    quiet: bool,
    /// The flat lists, bearings, directions and runs are set up for the transducers.
    laid_out: bool,
    /// [`RangerData::ray_count`] of the transducers given to `new`: the step asks every ranger
    /// for it, one after another, before it shares the updates out.
    rays: usize,
}

impl RangerData {
    /// A ranger with the given transducers and no data yet.
    pub fn new(sensors: Vec<SensorDesc>) -> RangerData {
        let mut d = RangerData {
            sensors,
            ..RangerData::default()
        };
        d.rays = d.ray_count();
        // the lists the first update lays out, allocated now and at their full size: made here,
        // one ranger after another as the world is built, they lie beside the transducers
        // (made by the update, in whichever order the threads reach the rangers, they lay
        // scattered, a cache miss apiece each step in a large swarm)
        let n = d.sensors.len();
        let samples = d.sensors.iter().map(SensorDesc::slots).sum();
        d.dirs.reserve_exact(n);
        d.ends.reserve_exact(n);
        d.runs.reserve_exact(n);
        d.ranges.reserve_exact(samples);
        d.intensities.reserve_exact(samples);
        d.bearings.reserve_exact(samples);
        d
    }

    /// Total rays per update.
    pub fn ray_count(&self) -> usize {
        self.sensors.iter().map(|s| s.samples as usize).sum()
    }

    /// Clears the data (shutdown).
    pub fn clear(&mut self) {
        self.ranges.clear();
        self.intensities.clear();
        self.bearings.clear();
        self.ends.clear();
        self.laid_out = false;
        self.time_us = 0;
    }

    /// The latest scan of each transducer, in entity order (none before the first update and
    /// after shutdown).
    pub fn scans(&self) -> impl ExactSizeIterator<Item = SensorScan<'_>> + '_ {
        (0..self.ends.len()).map(|k| self.scan(k).expect("k < ends.len()"))
    }

    /// Transducer `k`'s latest scan, if there is one.
    pub fn scan(&self, k: usize) -> Option<SensorScan<'_>> {
        let r = self.span_of(k)?;
        Some(SensorScan {
            ranges: &self.ranges[r.clone()],
            intensities: &self.intensities[r.clone()],
            bearings: &self.bearings[r],
        })
    }

    /// Each transducer's first range, in entity order (`None` for a transducer without
    /// samples): what Player's sonar and Stage's swarm controllers read of one-sample
    /// transducers.
    pub fn first_ranges(&self) -> impl Iterator<Item = Option<f64>> + '_ {
        // laid out, every transducer has a slot at least, so as many slots as transducers is
        // one each: transducer k's is slot k, found without reading where each ends (in a
        // 10,000-robot swarm of IR rings, that list was a cache miss per controller per step)
        let one_each = self.laid_out && self.ranges.len() == self.ends.len();
        let mut start = 0;
        (0..self.ends.len()).map(move |k| {
            if one_each {
                return Some(self.ranges[k]);
            }
            let end = self.ends[k];
            let first = (start < end).then(|| self.ranges[start]);
            start = end;
            first
        })
    }

    /// Transducer `k`'s first range, if it has a scan with samples.
    pub fn first_range(&self, k: usize) -> Option<f64> {
        let r = self.span_of(k)?;
        self.ranges[r].first().copied()
    }

    /// Every transducer's ranges, one transducer after the other.
    pub fn ranges(&self) -> &[f64] {
        &self.ranges
    }

    /// Every transducer's intensities, laid out as [`RangerData::ranges`].
    pub fn intensities(&self) -> &[f64] {
        &self.intensities
    }

    /// Every transducer's bearings, laid out as [`RangerData::ranges`].
    pub fn bearings(&self) -> &[f64] {
        &self.bearings
    }

    /// Replaces the scans with `scans`, one per transducer (data that did not come from an
    /// update: a converter's test, a replayed log).
    pub fn set_scans<'a>(&mut self, scans: impl IntoIterator<Item = SensorScan<'a>>) {
        self.clear();
        for s in scans {
            let n = s.ranges.len();
            let fill = |dst: &mut Vec<f64>, src: &[f64]| {
                dst.extend((0..n).map(|i| src.get(i).copied().unwrap_or(0.0)))
            };
            fill(&mut self.ranges, s.ranges);
            fill(&mut self.intensities, s.intensities);
            fill(&mut self.bearings, s.bearings);
            self.ends.push(self.ranges.len());
        }
    }

    /// Where transducer `k`'s samples sit in the flat lists (`None`: no such scan).
    fn span_of(&self, k: usize) -> Option<std::ops::Range<usize>> {
        let end = *self.ends.get(k)?;
        Some(self.start_of(k)..end)
    }

    /// Where transducer `k < ends.len()`'s samples begin in the flat lists.
    fn start_of(&self, k: usize) -> usize {
        if k == 0 { 0 } else { self.ends[k - 1] }
    }

    /// Lays the flat lists out for the transducers (once, after `new` or a shutdown): each gets
    /// `samples` slots (at least one) and its bearings, which never change; works out each
    /// transducer's directions and how the transducers are cast.
    fn lay_out(&mut self) {
        self.clear();
        self.dirs.clear();
        for s in &self.sensors {
            let n = s.slots();
            let (start, incr) = fan_angles(s);
            self.bearings
                .extend((0..n).map(|t| start + t as f64 * incr));
            self.ends.push(self.bearings.len());
            let (ss, sc) = (s.pose.a + start).sin_cos();
            let (is, ic) = incr.sin_cos();
            self.dirs.push([sc, ss, ic, is]);
        }
        let total = self.bearings.len();
        self.ranges.resize(total, 0.0);
        self.intensities.resize(total, 0.0);
        // a one-sample transducer joins the run before it when that run is of one-sample
        // transducers at the same place in the body frame with the same reach
        let single = |s: &SensorDesc| s.slots() == 1;
        let place = |s: &SensorDesc| (s.pose.x, s.pose.y, s.pose.z + s.size[2] / 2.0, s.range[1]);
        self.runs.clear();
        let mut k = 0;
        while k < self.sensors.len() {
            let first = &self.sensors[k];
            let mut run = 1;
            while single(first)
                && k + run < self.sensors.len()
                && run < LONGEST_RUN
                && single(&self.sensors[k + run])
                && place(&self.sensors[k + run]) == place(first)
            {
                run += 1;
            }
            self.runs.push(run);
            k += run;
        }
        self.quiet = !self.sensors.iter().any(SensorDesc::is_noisy);
        self.laid_out = true;
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
        self.rays
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
        for s in self.scans() {
            d.u64(s.ranges.len() as u64);
            for ((&r, &i), &b) in s.ranges.iter().zip(s.intensities).zip(s.bearings) {
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
    v.returns[h.index()].ranger >= 0.0
}

/// What a transducer reads for a ray's `hit`: the range and the intensity (the model's
/// `ranger_return`), or `max` and 0 on a miss.
#[inline(always)]
fn reading(v: &View, hit: Option<RayHit>, max: f64) -> (f64, f64) {
    match hit {
        Some(h) => (h.range, v.returns[h.model.index()].ranger),
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
    let n = s.slots();
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
    if !d.laid_out {
        d.lay_out();
    }
    let (fs, fc) = frame.a.sin_cos();
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
    // a run's directions (set up once per update, not per run)
    let mut dirs = [[0.0; 2]; LONGEST_RUN];
    let mut k = 0;
    for r in 0..d.runs.len() {
        let run = d.runs[r];
        let sensor = &d.sensors[k];
        let n = sensor.slots();
        let o = origin(sensor);
        let max = sensor.range[1];
        let first_sample = d.start_of(k);
        if n == 1 {
            // one-sample transducers from one origin with one reach: one fan, so that what the
            // rays share is worked out once. Their samples are consecutive in the flat lists.
            let samples = first_sample..first_sample + run;
            let (ranges, intensities) =
                (&mut d.ranges[samples.clone()], &mut d.intensities[samples]);
            if run == 1 {
                // a lone ray: a fan's shared setup would cost more than it saves
                (ranges[0], intensities[0]) = cast_ray(v, o, first_dir(d.dirs[k]), max, root);
            } else {
                for (j, slot) in dirs[..run].iter_mut().enumerate() {
                    *slot = first_dir(d.dirs[k + j]);
                }
                cast_fan(v, o, &dirs[..run], max, root, |i, r, s| {
                    ranges[i] = r;
                    intensities[i] = s;
                });
            }
            // noise in transducer order, as ray by ray
            if !d.quiet {
                for (sensor, r) in d.sensors[k..k + run].iter().zip(ranges.iter_mut()) {
                    *r = with_noise(sensor, *r, rng);
                }
            }
            k += run;
            continue;
        }
        let [_, _, ic, is] = d.dirs[k];
        // sweep the fan by rotating the direction vector (one sine/cosine per sensor)
        let rotate = |[c, s]: [f64; 2]| [c * ic - s * is, c * is + s * ic];
        let samples = first_sample..first_sample + n;
        let (ranges, intensities) = (&mut d.ranges[samples.clone()], &mut d.intensities[samples]);
        let first = first_dir(d.dirs[k]);
        if n >= SHORT_FAN {
            // long fan: the casts in parallel chunks, each thread sweeping the directions up
            // to its chunks (the same sequence of rotations as below, so the same directions),
            // then the noise in ray order so that the random stream does not depend on how the
            // casts were split. Each chunk's part of the scan waits behind a lock of its own,
            // taken once, by whichever thread claims the chunk.
            let parts: Vec<Mutex<(&mut [f64], &mut [f64])>> = ranges
                .chunks_mut(FAN_CHUNK)
                .zip(intensities.chunks_mut(FAN_CHUNK))
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
            if sensor.is_noisy() {
                for r in ranges.iter_mut() {
                    *r = with_noise(sensor, *r, rng);
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
            cast_fan(v, o, &dirs[..n], max, root, |i, r, s| {
                ranges[i] = r;
                intensities[i] = s;
            });
            for r in ranges.iter_mut() {
                *r = with_noise(sensor, *r, rng);
            }
        }
        k += 1;
    }
    d.time_us = v.sim_time;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sensor(samples: u32, fov_deg: f64) -> SensorDesc {
        SensorDesc {
            samples,
            fov: fov_deg.to_radians(),
            ..SensorDesc::default()
        }
    }

    /// The flat lists give each transducer its own samples, in entity order: a laid-out ranger
    /// has a slot per sample (one for a transducer of none) and each fan's bearings; scans set
    /// from outside read back as given.
    #[test]
    fn scans_are_each_transducers_part_of_the_flat_lists() {
        let mut d = RangerData::new(vec![sensor(1, 30.0), sensor(3, 90.0), sensor(0, 10.0)]);
        assert_eq!(d.scans().len(), 0, "no scans before the first update");
        assert_eq!(d.first_range(0), None);
        d.lay_out();
        let lens: Vec<usize> = d.scans().map(|s| s.ranges.len()).collect();
        assert_eq!(lens, [1, 3, 1]);
        let q = 45f64.to_radians();
        assert_eq!(d.scan(1).unwrap().bearings, [-q, 0.0, q]);
        assert_eq!(d.bearings(), [0.0, -q, 0.0, q, 0.0]);
        assert!(d.scan(3).is_none());

        d.set_scans([
            SensorScan {
                ranges: &[1.0, 2.0],
                intensities: &[5.0],
                bearings: &[0.1, 0.2],
            },
            SensorScan {
                ranges: &[],
                intensities: &[],
                bearings: &[],
            },
            SensorScan {
                ranges: &[3.0],
                intensities: &[6.0],
                bearings: &[0.3],
            },
        ]);
        assert_eq!(d.ranges(), [1.0, 2.0, 3.0]);
        // a short list is padded with zeros to the transducer's sample count
        assert_eq!(d.intensities(), [5.0, 0.0, 6.0]);
        assert_eq!(d.scan(2).unwrap().bearings, [0.3]);
        let firsts: Vec<Option<f64>> = d.first_ranges().collect();
        assert_eq!(firsts, [Some(1.0), None, Some(3.0)]);
        assert_eq!((d.first_range(1), d.first_range(2)), (None, Some(3.0)));
        d.clear();
        assert_eq!((d.scans().len(), d.ranges().len()), (0, 0));
    }

    /// One-sample transducers at one place with one reach are cast together (up to
    /// LONGEST_RUN); a fan, another place or another reach starts a new run. Noise anywhere
    /// keeps the noise pass.
    #[test]
    fn runs_group_one_sample_transducers_at_one_place() {
        let at = |x: f64, range: f64| SensorDesc {
            pose: Pose::new(x, 0.0, 0.0, 0.0),
            range: [0.0, range],
            ..sensor(1, 30.0)
        };
        let mut sensors = vec![at(0.0, 2.0); 3];
        sensors.push(at(0.1, 2.0));
        sensors.push(at(0.1, 3.0));
        sensors.push(sensor(5, 90.0));
        sensors.extend(vec![at(0.0, 2.0); LONGEST_RUN + 2]);
        let mut d = RangerData::new(sensors);
        d.lay_out();
        assert_eq!(d.runs, [3, 1, 1, 1, LONGEST_RUN, 2]);
        assert!(d.quiet);
        d.sensors[4].noise = 0.01;
        d.lay_out();
        assert!(!d.quiet);
    }

    /// Laid out, each transducer's first range is its scan's first, whether every transducer
    /// has one sample (slot k is transducer k's) or some have more; the lists are made at
    /// their full size with the ranger, so laying them out moves nothing.
    #[test]
    fn first_ranges_of_laid_out_transducers_are_their_scans_first() {
        for samples in [vec![1, 1, 1], vec![1, 3, 0, 2]] {
            let sensors: Vec<SensorDesc> = samples.iter().map(|&n| sensor(n, 30.0)).collect();
            let mut d = RangerData::new(sensors);
            let at = d.ranges.as_ptr();
            d.lay_out();
            assert_eq!(d.ranges.as_ptr(), at, "{samples:?}: the ranges moved");
            for (i, r) in d.ranges.iter_mut().enumerate() {
                *r = 1.5 + i as f64;
            }
            let firsts: Vec<Option<f64>> = d.first_ranges().collect();
            let expected: Vec<Option<f64>> = d.scans().map(|s| s.ranges.first().copied()).collect();
            assert_eq!(firsts, expected, "{samples:?}");
            assert_eq!(firsts.len(), samples.len());
        }
    }
}
