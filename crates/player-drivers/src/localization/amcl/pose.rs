//! Planar poses as the filter composes them: `(x, y, heading)` in a nalgebra vector, with the
//! two frame operations every model needs (Player's `pf_vector_coord_add` / `_sub`).

use nalgebra::Vector3;

/// A planar pose or pose change: x (m), y (m), heading (rad).
pub type Pose = Vector3<f64>;

/// The pose `local`, given in the frame of `frame`, expressed in the frame `frame` lives in
/// (an odometry step applied to a particle, a sensor mounted on a robot).
pub fn compose(frame: &Pose, local: &Pose) -> Pose {
    let (s, c) = frame.z.sin_cos();
    Pose::new(
        frame.x + local.x * c - local.y * s,
        frame.y + local.x * s + local.y * c,
        ::pose::angle::normalize_atan2(frame.z + local.z),
    )
}

/// The pose `pose` seen from `frame` (both in the same outer frame): the inverse of
/// [`compose`], used to turn two odometry readings into the step between them.
pub fn relative(frame: &Pose, pose: &Pose) -> Pose {
    let (s, c) = frame.z.sin_cos();
    let (dx, dy) = (pose.x - frame.x, pose.y - frame.y);
    Pose::new(
        dx * c + dy * s,
        -dx * s + dy * c,
        ::pose::angle::normalize_atan2(pose.z - frame.z),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    fn close(a: &Pose, b: &Pose) -> bool {
        (a - b).abs().max() < 1e-12
    }

    #[test]
    fn compose_turns_the_local_offset_into_the_frame() {
        let robot = Pose::new(1.0, 2.0, FRAC_PI_2);
        // One metre ahead of a robot facing +y is one metre up.
        assert!(close(
            &compose(&robot, &Pose::new(1.0, 0.0, 0.0)),
            &Pose::new(1.0, 3.0, FRAC_PI_2)
        ));
        // Headings wrap.
        let p = compose(&Pose::new(0.0, 0.0, PI - 0.1), &Pose::new(0.0, 0.0, 0.2));
        assert!((p.z - (-PI + 0.1)).abs() < 1e-12);
    }

    #[test]
    fn relative_undoes_compose() {
        let frame = Pose::new(-3.0, 0.5, 2.5);
        let local = Pose::new(0.3, -0.2, -2.9);
        let global = compose(&frame, &local);
        assert!(close(&relative(&frame, &global), &local));
        assert!(close(&compose(&frame, &relative(&frame, &global)), &global));
    }
}
