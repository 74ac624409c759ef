//! Drawing poses from a 3D Gaussian, as the filter does to scatter its initial particles and
//! to add odometric noise.
//!
//! The covariance is split into a rotation and independent standard deviations (its
//! eigen-decomposition), so a draw is three independent normals turned into the
//! covariance's axes; the normals come from the polar Box-Muller method, as upstream's
//! `pf_ran_gaussian`. Every draw takes its randomness from the generator passed in, so a
//! seeded generator repeats a run exactly.

use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use rand::Rng;

use super::pose::Pose;

/// A Gaussian over poses, ready to sample.
#[derive(Clone, Debug, PartialEq)]
pub struct Gaussian {
    mean: Pose,
    axes: Matrix3<f64>,
    sigmas: Vector3<f64>,
}

impl Gaussian {
    /// The Gaussian with this mean and covariance. A diagonal covariance (every one the driver
    /// builds) keeps its own axes, so zero variances give exactly the mean; other symmetric
    /// matrices are decomposed. Tiny negative eigenvalues from rounding count as zero.
    pub fn new(mean: Pose, cov: Matrix3<f64>) -> Gaussian {
        let off_diagonal = cov[(0, 1)] != 0.0
            || cov[(0, 2)] != 0.0
            || cov[(1, 2)] != 0.0
            || cov[(1, 0)] != 0.0
            || cov[(2, 0)] != 0.0
            || cov[(2, 1)] != 0.0;
        let (axes, variances) = if off_diagonal {
            let eig = SymmetricEigen::new(cov);
            (eig.eigenvectors, eig.eigenvalues)
        } else {
            (Matrix3::identity(), cov.diagonal())
        };
        Gaussian {
            mean,
            axes,
            sigmas: variances.map(|v| v.max(0.0).sqrt()),
        }
    }

    /// The mean.
    pub fn mean(&self) -> &Pose {
        &self.mean
    }

    /// One draw. Headings are not wrapped: the filter wraps them when it composes poses.
    pub fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> Pose {
        let r = Vector3::new(
            standard_normal(rng) * self.sigmas.x,
            standard_normal(rng) * self.sigmas.y,
            standard_normal(rng) * self.sigmas.z,
        );
        self.mean + self.axes * r
    }
}

/// A draw from N(0, 1) by the polar Box-Muller method (one of the pair is kept, as upstream
/// does, so every draw costs the same whatever came before).
pub fn standard_normal<R: Rng + ?Sized>(rng: &mut R) -> f64 {
    loop {
        let x1 = 2.0 * open_unit(rng) - 1.0;
        let x2 = 2.0 * open_unit(rng) - 1.0;
        let w = x1 * x1 + x2 * x2;
        if w < 1.0 && w > 0.0 {
            return x2 * (-2.0 * w.ln() / w).sqrt();
        }
    }
}

/// Uniform in (0, 1): upstream redraws zeros.
fn open_unit<R: Rng + ?Sized>(rng: &mut R) -> f64 {
    loop {
        let r: f64 = rng.random();
        if r > 0.0 {
            return r;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn zero_covariance_gives_the_mean_exactly() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let g = Gaussian::new(Pose::new(1.5, -2.0, 0.25), Matrix3::zeros());
        for _ in 0..10 {
            assert_eq!(g.sample(&mut rng), Pose::new(1.5, -2.0, 0.25));
        }
    }

    #[test]
    fn samples_have_the_requested_moments() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        // A correlated x-y covariance exercises the eigen-decomposition path.
        let cov = Matrix3::new(0.5, 0.3, 0.0, 0.3, 0.4, 0.0, 0.0, 0.0, 0.09);
        let g = Gaussian::new(Pose::new(1.0, 2.0, 3.0), cov);
        let n = 40_000;
        let draws: Vec<Pose> = (0..n).map(|_| g.sample(&mut rng)).collect();
        let mean = draws.iter().sum::<Pose>() / n as f64;
        assert!((mean - g.mean()).abs().max() < 0.02, "{mean}");
        let mut c = Matrix3::zeros();
        for d in &draws {
            let e = d - mean;
            c += e * e.transpose();
        }
        c /= n as f64;
        assert!((c - cov).abs().max() < 0.02, "{c}");
    }

    #[test]
    fn a_seed_repeats_its_draws() {
        let g = Gaussian::new(Pose::zeros(), Matrix3::identity());
        let run = |seed| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            (0..5).map(|_| g.sample(&mut rng)).collect::<Vec<_>>()
        };
        assert_eq!(run(1), run(1));
        assert_ne!(run(1), run(2));
    }
}
