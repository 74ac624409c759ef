//! The `localize` interface (25). Covariances are fixed `double[3]` with no length word in 3.0.2.

use super::Pose2d;

xdr_struct! {
    /// One pose hypothesis.
    pub struct LocalizeHypoth = "player_localize_hypoth_t" {
        /// Mean pose.
        mean: Pose2d,
        /// Covariance diagonal (exactly three doubles).
        cov: [f64; 3],
        /// Weight.
        alpha: f64,
    }

    /// Hypotheses (DATA HYPOTHS).
    pub struct LocalizeDataHypoths = "player_localize_data_t" {
        /// Pending observations (a plain member, not an array count).
        pending_count: u32,
        /// Time of the last pending observation.
        pending_time: f64,
        /// The hypotheses.
        hypoths: Vec<LocalizeHypoth>,
    }

    /// Sets the pose estimate (SET_POSE).
    pub struct LocalizeSetPose = "player_localize_set_pose_t" {
        /// Mean pose.
        mean: Pose2d,
        /// Covariance diagonal (exactly three doubles).
        cov: [f64; 3],
    }

    /// One particle.
    pub struct LocalizeParticle = "player_localize_particle_t" {
        /// Pose.
        pose: Pose2d,
        /// Weight.
        alpha: f64,
    }

    /// The particle set (GET_PARTICLES reply).
    pub struct LocalizeGetParticles = "player_localize_get_particles_t" {
        /// Mean pose.
        mean: Pose2d,
        /// Variance.
        variance: f64,
        /// The particles.
        particles: Vec<LocalizeParticle>,
    }
}
