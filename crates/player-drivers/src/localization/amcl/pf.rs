//! The particle filter: weighted pose samples, moved by an action model, weighted by sensor
//! models, and resampled with KLD-sampling (Fox, "Adapting the sample size in particle filters
//! through KLD-sampling"), as Player 3.0.2's `pf.c`.
//!
//! The sample count adapts: resampling draws until the count exceeds what the number of
//! occupied histogram cells calls for (between `min_samples` and `max_samples`), so a spread
//! belief keeps many particles and a converged one few. After each resampling the particles
//! are clustered by histogram cell and each cluster's weight, mean and covariance become the
//! hypotheses the driver publishes.

use nalgebra::Matrix3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::histogram::Histogram;
use super::pdf::Gaussian;
use super::pose::Pose;

/// Clusters beyond this many are ignored (their particles count towards no hypothesis), as
/// upstream's fixed cluster table.
pub const MAX_CLUSTERS: usize = 100;

/// Fewest particles per thread when weighing: a particle's full scan costs tens of
/// microseconds, a thread's start about as much as one or two particles, so below this the
/// threads cost more than they save.
const PARALLEL_CHUNK: usize = 128;

/// How many threads weigh particles: every core. An update is a burst after each scan; the
/// simulation and the server take little of a core between bursts when they run in real
/// time, which is when amcl runs.
fn sensor_threads() -> usize {
    crate::cores()
}

/// One weighted pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// The pose.
    pub pose: Pose,
    /// The weight (the set's weights sum to 1).
    pub weight: f64,
}

/// A group of touching histogram cells and the statistics of its particles.
#[derive(Clone, Debug, PartialEq)]
pub struct Cluster {
    /// Particles in it.
    pub count: usize,
    /// Their total weight.
    pub weight: f64,
    /// Weighted mean (heading by circular mean).
    pub mean: Pose,
    /// Covariance: the x-y block about the mean, and in `[2][2]` the circular spread
    /// `-2 ln R` of the headings, where `R` is the length of the weighted sum of heading unit
    /// vectors *without* dividing by the cluster's weight (upstream's formula: a light
    /// cluster reports a wider heading spread than its particles have).
    pub cov: Matrix3<f64>,
}

/// How the sample count adapts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Population {
    /// Fewest samples kept (resampling always keeps more than this many).
    pub min_samples: usize,
    /// Most samples kept; initialisation uses this many.
    pub max_samples: usize,
    /// KLD bound: the largest allowed error between the sampled and the true belief.
    pub err: f64,
    /// Upper standard normal quantile of the probability that the error stays below `err`.
    pub z: f64,
}

impl Population {
    /// How many samples a belief spread over `k` histogram cells needs (Fox's bound), within
    /// `[min_samples, max_samples]`.
    pub fn limit(&self, k: usize) -> usize {
        if k <= 1 {
            return self.min_samples;
        }
        let km1 = (k - 1) as f64;
        let b = 2.0 / (9.0 * km1);
        let x = 1.0 - b + b.sqrt() * self.z;
        let n = (km1 / (2.0 * self.err) * x * x * x).ceil();
        if n < self.min_samples as f64 {
            self.min_samples
        } else if n >= self.max_samples as f64 {
            self.max_samples
        } else {
            n as usize
        }
    }
}

/// The filter.
#[derive(Clone, Debug)]
pub struct ParticleFilter {
    population: Population,
    samples: Vec<Sample>,
    spare: Vec<Sample>,
    histogram: Histogram,
    clusters: Vec<Cluster>,
    rng: ChaCha8Rng,
}

impl ParticleFilter {
    /// A filter with every sample at the origin, drawing its randomness from a generator
    /// seeded with `seed` (the same seed and inputs give the same particles).
    pub fn new(population: Population, seed: u64) -> ParticleFilter {
        let n = population.max_samples.max(1);
        ParticleFilter {
            population,
            samples: vec![
                Sample {
                    pose: Pose::zeros(),
                    weight: 1.0 / n as f64,
                };
                n
            ],
            spare: Vec::with_capacity(n),
            histogram: Histogram::new(),
            clusters: Vec::new(),
            rng: ChaCha8Rng::seed_from_u64(seed),
        }
    }

    /// The population settings.
    pub fn population(&self) -> &Population {
        &self.population
    }

    /// The current samples.
    pub fn samples(&self) -> &[Sample] {
        &self.samples
    }

    /// The clusters found at the last initialisation or resampling, by label.
    pub fn clusters(&self) -> &[Cluster] {
        &self.clusters
    }

    /// Replaces the belief by `max_samples` equally weighted draws from a Gaussian.
    pub fn init_gaussian(&mut self, mean: Pose, cov: Matrix3<f64>) {
        let pdf = Gaussian::new(mean, cov);
        let n = self.population.max_samples.max(1);
        let w = 1.0 / n as f64;
        self.samples.clear();
        self.histogram.clear();
        for _ in 0..n {
            let pose = pdf.sample(&mut self.rng);
            self.histogram.insert(&pose);
            self.samples.push(Sample { pose, weight: w });
        }
        self.cluster_stats();
    }

    /// Moves every sample with `model` (given the generator, for noise) and makes the weights
    /// uniform again, as upstream's odometry action model does.
    pub fn update_action(&mut self, mut model: impl FnMut(&mut ChaCha8Rng, &Pose) -> Pose) {
        let w = 1.0 / self.samples.len() as f64;
        for s in &mut self.samples {
            s.pose = model(&mut self.rng, &s.pose);
            s.weight = w;
        }
    }

    /// Multiplies every weight by the likelihood `model` gives its pose, then normalises. A
    /// set whose total comes to zero (or is not a number) is made uniform instead, with a
    /// warning: the observation fits no particle.
    ///
    /// Likelihoods (ray casting, the filter's main cost) are computed on every core for
    /// sets of a few hundred particles and more; each particle's weight depends only on its
    /// own pose and the total is summed in order afterwards, so the result does not depend on
    /// the thread count.
    pub fn update_sensor(&mut self, model: impl Fn(&Pose) -> f64 + Sync) {
        self.update_sensor_on(model, sensor_threads());
    }

    /// [`ParticleFilter::update_sensor`] on at most `threads` threads.
    fn update_sensor_on(&mut self, model: impl Fn(&Pose) -> f64 + Sync, threads: usize) {
        let weigh = |chunk: &mut [Sample]| {
            for s in chunk {
                s.weight *= model(&s.pose);
            }
        };
        let threads = threads.min(self.samples.len() / PARALLEL_CHUNK).max(1);
        if threads > 1 {
            let per = self.samples.len().div_ceil(threads);
            std::thread::scope(|scope| {
                let mut chunks = self.samples.chunks_mut(per);
                let mine = chunks.next();
                for chunk in chunks {
                    scope.spawn(|| weigh(chunk));
                }
                if let Some(chunk) = mine {
                    weigh(chunk);
                }
            });
        } else {
            weigh(&mut self.samples);
        }
        let total: f64 = self.samples.iter().map(|s| s.weight).sum();
        if total > 0.0 && total.is_finite() {
            for s in &mut self.samples {
                s.weight /= total;
            }
        } else {
            tracing::warn!("amcl: pdf has zero probability");
            let w = 1.0 / self.samples.len() as f64;
            for s in &mut self.samples {
                s.weight = w;
            }
        }
    }

    /// Draws the next generation with the low-variance sampler (Probabilistic Robotics,
    /// p. 110), stopping once the count exceeds the KLD limit for the cells occupied so far,
    /// then re-clusters.
    pub fn resample(&mut self) {
        let old = std::mem::take(&mut self.samples);
        let mut new = std::mem::take(&mut self.spare);
        new.clear();
        self.histogram.clear();

        let n_old = old.len();
        let step = 1.0 / n_old as f64;
        let mut r = self.rng.random::<f64>() * step;
        let mut c = old[0].weight;
        let mut i = 0;
        let mut m = 0usize;
        while new.len() < self.population.max_samples {
            let mut u = r + m as f64 * step;
            while u > c {
                i += 1;
                // Past the end (more draws than old samples, or rounding): start a fresh
                // comb with a new offset, as upstream does.
                if i >= n_old {
                    r = self.rng.random::<f64>() * step;
                    c = old[0].weight;
                    i = 0;
                    m = 0;
                    u = r;
                    continue;
                }
                c += old[i].weight;
            }
            let pose = old[i].pose;
            self.histogram.insert(&pose);
            new.push(Sample { pose, weight: 1.0 });
            if new.len() > self.population.limit(self.histogram.occupied()) {
                break;
            }
            m += 1;
        }
        let w = 1.0 / new.len() as f64;
        for s in &mut new {
            s.weight = w;
        }
        self.samples = new;
        self.spare = old;
        self.cluster_stats();
    }

    /// Clusters the histogram of the current samples and computes each cluster's statistics.
    fn cluster_stats(&mut self) {
        let count = self.histogram.cluster().min(MAX_CLUSTERS);
        // Sums: weight, weighted x, y, cos, sin, and the x-y second moments.
        let mut sums = vec![([0.0f64; 5], [[0.0f64; 2]; 2], 0usize); count];
        for s in &self.samples {
            let Some(label) = self.histogram.cluster_of(&s.pose) else {
                continue;
            };
            if label >= count {
                continue;
            }
            let (m, c, n) = &mut sums[label];
            let w = s.weight;
            *n += 1;
            m[0] += w;
            m[1] += w * s.pose.x;
            m[2] += w * s.pose.y;
            m[3] += w * s.pose.z.cos();
            m[4] += w * s.pose.z.sin();
            let p = [s.pose.x, s.pose.y];
            for (j, row) in c.iter_mut().enumerate() {
                for (k, v) in row.iter_mut().enumerate() {
                    *v += w * p[j] * p[k];
                }
            }
        }
        self.clusters = sums
            .into_iter()
            .map(|(m, c, n)| {
                let weight = m[0];
                let mean = Pose::new(m[1] / weight, m[2] / weight, m[4].atan2(m[3]));
                let mut cov = Matrix3::zeros();
                let mu = [mean.x, mean.y];
                for j in 0..2 {
                    for k in 0..2 {
                        cov[(j, k)] = c[j][k] / weight - mu[j] * mu[k];
                    }
                }
                cov[(2, 2)] = -2.0 * m[3].hypot(m[4]).ln();
                Cluster {
                    count: n,
                    weight,
                    mean,
                    cov,
                }
            })
            .collect();
    }

    /// The weighted mean position (heading 0) and the mean squared distance from it, over
    /// every sample (upstream's "CEP" statistics, sent with the particles).
    pub fn cep_stats(&self) -> (Pose, f64) {
        let (mut mn, mut mx, mut my, mut mrr) = (0.0, 0.0, 0.0, 0.0);
        for s in &self.samples {
            let (x, y, w) = (s.pose.x, s.pose.y, s.weight);
            mn += w;
            mx += w * x;
            my += w * y;
            mrr += w * (x * x + y * y);
        }
        let mean = Pose::new(mx / mn, my / mn, 0.0);
        let var = mrr / mn - (mx * mx / (mn * mn) + my * my / (mn * mn));
        (mean, var)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn population(min: usize, max: usize) -> Population {
        Population {
            min_samples: min,
            max_samples: max,
            err: 0.01,
            z: 3.0,
        }
    }

    #[test]
    fn the_kld_limit_grows_with_the_occupied_cells_within_bounds() {
        let p = population(100, 10_000);
        assert_eq!(p.limit(0), 100);
        assert_eq!(p.limit(1), 100);
        // Fox's bound for k = 2, err 0.01, z 3 (worked by hand): ceil(1 / 0.02 * x^3) with
        // x = 1 - 2/9 + 3 sqrt(2/9) = 2.19197, x^3 = 10.5322 -> 526.6 -> 527.
        assert_eq!(p.limit(2), 527);
        let mut last = 0;
        for k in 2..200 {
            let n = p.limit(k);
            assert!(n >= last, "monotone");
            last = n;
        }
        assert_eq!(p.limit(10_000), 10_000);
    }

    #[test]
    fn init_draws_max_samples_around_the_mean() {
        let mut pf = ParticleFilter::new(population(10, 2000), 1);
        let cov = Matrix3::from_diagonal(&Pose::new(0.04, 0.09, 0.01));
        pf.init_gaussian(Pose::new(2.0, -1.0, 0.5), cov);
        assert_eq!(pf.samples().len(), 2000);
        let (mean, var) = pf.cep_stats();
        assert!((mean.x - 2.0).abs() < 0.03 && (mean.y + 1.0).abs() < 0.03);
        assert!((var - 0.13).abs() < 0.02, "{var}");
        let total: f64 = pf.samples().iter().map(|s| s.weight).sum();
        assert!((total - 1.0).abs() < 1e-9);
        // One blob: one cluster holding every particle.
        assert_eq!(pf.clusters().len(), 1);
        assert_eq!(pf.clusters()[0].count, 2000);
    }

    #[test]
    fn a_peaked_likelihood_concentrates_the_particles_and_shrinks_the_set() {
        let pop = population(50, 5000);
        let mut pf = ParticleFilter::new(pop, 9);
        // Spread over a 4 m x 4 m area and a wide range of headings.
        let cov = Matrix3::from_diagonal(&Pose::new(1.0, 1.0, 1.0));
        pf.init_gaussian(Pose::new(0.0, 0.0, 0.0), cov);
        let target = Pose::new(0.8, -0.6, 0.3);
        let sensor = |p: &Pose| {
            let d2 = (p.x - target.x).powi(2) + (p.y - target.y).powi(2);
            let da = ::pose::angle::normalize_atan2(p.z - target.z);
            (-d2 / (2.0 * 0.2f64.powi(2)) - da * da / (2.0 * 0.2f64.powi(2))).exp()
        };
        // Resampling the spread belief as it is keeps many particles: it covers many cells.
        pf.resample();
        let spread_count = pf.samples().len();
        assert!(spread_count > 2000, "{spread_count}");
        for _ in 0..10 {
            pf.update_sensor(sensor);
            pf.resample();
            let n = pf.samples().len();
            assert!(n > pop.min_samples && n <= pop.max_samples, "{n}");
            // Diffuse a little, as an action model would, so the set does not collapse.
            pf.update_action(|rng, p| {
                Pose::new(
                    p.x + 0.05 * super::super::pdf::standard_normal(rng),
                    p.y + 0.05 * super::super::pdf::standard_normal(rng),
                    p.z + 0.05 * super::super::pdf::standard_normal(rng),
                )
            });
        }
        pf.update_sensor(sensor);
        pf.resample();
        let best = pf
            .clusters()
            .iter()
            .max_by(|a, b| a.weight.total_cmp(&b.weight))
            .unwrap();
        assert!(best.weight > 0.95, "{}", best.weight);
        assert!((best.mean.x - target.x).abs() < 0.1, "{:?}", best.mean);
        assert!((best.mean.y - target.y).abs() < 0.1, "{:?}", best.mean);
        assert!((best.mean.z - target.z).abs() < 0.1, "{:?}", best.mean);
        assert!(best.cov[(0, 0)] < 0.05 && best.cov[(1, 1)] < 0.05);
        // The concentrated belief needs far fewer.
        assert!(
            spread_count > 2 * pf.samples().len(),
            "{spread_count} -> {}",
            pf.samples().len()
        );
    }

    #[test]
    fn resampling_follows_the_weights() {
        let mut pf = ParticleFilter::new(population(1000, 1000), 4);
        pf.init_gaussian(Pose::zeros(), Matrix3::zeros());
        // Two poses far apart; the likelihood favours the right-hand one 3:1.
        pf.update_action(|rng, _| {
            if rng.random::<bool>() {
                Pose::new(5.0, 0.0, 0.0)
            } else {
                Pose::new(-5.0, 0.0, 0.0)
            }
        });
        pf.update_sensor(|p| if p.x > 0.0 { 3.0 } else { 1.0 });
        pf.resample();
        let right = pf.samples().iter().filter(|s| s.pose.x > 0.0).count() as f64;
        let frac = right / pf.samples().len() as f64;
        assert!((frac - 0.75).abs() < 0.05, "{frac}");
        // Two clusters, weights near 3:1.
        let mut w: Vec<f64> = pf.clusters().iter().map(|c| c.weight).collect();
        w.sort_by(f64::total_cmp);
        assert_eq!(w.len(), 2);
        assert!((w[1] - 0.75).abs() < 0.05, "{w:?}");
    }

    #[test]
    fn a_zero_likelihood_everywhere_leaves_uniform_weights() {
        let mut pf = ParticleFilter::new(population(10, 100), 2);
        pf.init_gaussian(Pose::zeros(), Matrix3::identity());
        pf.update_sensor(|_| 0.0);
        assert!(pf.samples().iter().all(|s| s.weight == 0.01));
        pf.resample();
        assert!(pf.samples().len() > 10);
    }

    #[test]
    fn weighing_on_threads_gives_the_same_weights() {
        let mut one = ParticleFilter::new(population(100, 10_000), 3);
        one.init_gaussian(Pose::zeros(), Matrix3::identity());
        let mut four = one.clone();
        let model = |p: &Pose| (-(p.x * p.x + p.y * p.y)).exp() * (1.0 + p.z.cos());
        one.update_sensor_on(model, 1);
        four.update_sensor_on(model, 4);
        assert_eq!(one.samples(), four.samples());
    }

    #[test]
    fn a_seed_repeats_a_run() {
        let run = |seed| {
            let mut pf = ParticleFilter::new(population(20, 500), seed);
            pf.init_gaussian(Pose::zeros(), Matrix3::identity());
            pf.update_sensor(|p| (-p.x * p.x).exp());
            pf.resample();
            pf.samples().to_vec()
        };
        assert_eq!(run(5), run(5));
        assert_ne!(run(5), run(6));
    }
}
