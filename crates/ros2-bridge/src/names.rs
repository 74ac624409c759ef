//! How stage_ros2 forms the names of a vehicle's topics and frames (`vehicle.cpp`,
//! `ranger.cpp`), and which name a vehicle gets.

use std::collections::BTreeMap;

use crate::params::Params;

/// The absolute name of topic `name` in a node in `namespace` (`/` or `/a/b`): resolved in
/// the namespace when relative, then remapped if a `-r FROM:=TO` rule names it (as written or
/// as resolved), the target resolved likewise. The bridge creates every topic by its absolute
/// name, which also spares ros2-client's relative-name joining (it doubles the root's slash).
pub fn resolve(namespace: &str, remaps: &BTreeMap<String, String>, name: &str) -> String {
    let absolute = |n: &str| {
        if n.starts_with('/') {
            n.to_string()
        } else if namespace == "/" {
            format!("/{n}")
        } else {
            format!("{namespace}/{n}")
        }
    };
    let resolved = absolute(name);
    match remaps.get(name).or_else(|| remaps.get(&resolved)) {
        Some(to) => absolute(to),
        None => resolved,
    }
}

/// Whether `name` can be a ROS 2 name token: ASCII letters, digits and underscores, not
/// starting with a digit, no doubled underscore (what rcl and ros2-client's `Name` accept). A
/// Stage name such as `position:2` or `r0.laser` is not one.
pub fn is_valid_token(name: &str) -> bool {
    !name.is_empty()
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        && !name.starts_with(|c: char| c.is_ascii_digit())
        && !name.contains("__")
}

/// The name a vehicle publishes under: its Stage name when that is a valid ROS name, else
/// stage_ros's `robot_N` (`index` among the position models), with a warning. stage_ros2 would
/// abort on the invalid name.
pub fn vehicle_name(stage_name: &str, index: usize) -> String {
    if is_valid_token(stage_name) {
        stage_name.to_string()
    } else {
        let name = format!("robot_{index}");
        tracing::warn!(
            "position model `{stage_name}` is not a valid ROS name: publishing it as `{name}`"
        );
        name
    }
}

/// The topic and frame names of one vehicle.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct VehicleNames {
    /// `<name>/` when topics are prefixed, else empty.
    pub topic_prefix: String,
    /// `<name>/` under `one_tf_tree`, else empty.
    pub frame_prefix: String,
    /// `cmd_vel`.
    pub cmd_vel: String,
    /// `odom`.
    pub odom: String,
    /// `ground_truth`.
    pub ground_truth: String,
    /// `tf`: `/tf` under one_tf_tree, else `<prefix>tf`.
    pub tf: String,
    /// `tf_static`: `/tf_static` under one_tf_tree, else `<prefix>tf_static`.
    pub tf_static: String,
    /// `cmd_pose` (ours: teleport).
    pub cmd_pose: String,
    /// `stalled` (ours).
    pub stalled: String,
    /// The odometry frame.
    pub frame_odom: String,
    /// The world frame of ground truth.
    pub frame_world: String,
    /// The body frame.
    pub frame_base_link: String,
}

impl VehicleNames {
    /// stage_ros2's `Vehicle::init`: topics are prefixed with `<name>/` when `prefixed` (there
    /// are several vehicles, or `enforce_prefixes`); frames with `<name>/` under `one_tf_tree`,
    /// whose transforms then all go to `/tf` and `/tf_static`.
    pub fn new(name: &str, prefixed: bool, params: &Params) -> VehicleNames {
        let topic_prefix = if prefixed {
            format!("{name}/")
        } else {
            String::new()
        };
        let frame_prefix = if params.one_tf_tree {
            format!("{name}/")
        } else {
            String::new()
        };
        let (tf, tf_static) = if params.one_tf_tree {
            ("/tf".to_string(), "/tf_static".to_string())
        } else {
            (
                format!("{topic_prefix}tf"),
                format!("{topic_prefix}tf_static"),
            )
        };
        VehicleNames {
            cmd_vel: format!("{topic_prefix}cmd_vel"),
            odom: format!("{topic_prefix}odom"),
            ground_truth: format!("{topic_prefix}ground_truth"),
            cmd_pose: format!("{topic_prefix}cmd_pose"),
            stalled: format!("{topic_prefix}stalled"),
            tf,
            tf_static,
            frame_odom: format!("{frame_prefix}{}", params.frame_id_odom),
            frame_world: format!("{frame_prefix}{}", params.frame_id_world),
            frame_base_link: format!("{frame_prefix}{}", params.frame_id_base_link),
            topic_prefix,
            frame_prefix,
        }
    }

    /// A ranger's scan topic and frame (`ranger.cpp`): `base_scan` and `laser`, numbered from 1
    /// (`base_scan1`, `laser1`, ...) when the vehicle has several rangers.
    pub fn ranger(&self, id: usize, several: bool) -> (String, String) {
        let n = if several {
            id.to_string()
        } else {
            String::new()
        };
        (
            format!("{}base_scan{n}", self.topic_prefix),
            format!("{}laser{n}", self.frame_prefix),
        )
    }

    /// A camera's topics and frame (`camera.cpp`): `image`, `depth`, `camera_info` and
    /// `camera`, numbered from 1 (`image1`, ..., `camera1`) when the vehicle has several cameras
    /// (stage_ros2 numbers them when it has several rangers, a slip).
    pub fn camera(&self, id: usize, several: bool) -> CameraNames {
        let n = if several {
            id.to_string()
        } else {
            String::new()
        };
        let t = &self.topic_prefix;
        CameraNames {
            image: format!("{t}image{n}"),
            depth: format!("{t}depth{n}"),
            camera_info: format!("{t}camera_info{n}"),
            frame: format!("{}camera{n}", self.frame_prefix),
        }
    }

    /// A sonar ring transducer's topic and frame (ours; stage_ros2 publishes only a ranger's
    /// first transducer): `<scan topic>/range<k>` and `<laser frame>_range<k>`, `k` from 0.
    pub fn transducer(scan_topic: &str, laser_frame: &str, k: usize) -> (String, String) {
        (
            format!("{scan_topic}/range{k}"),
            format!("{laser_frame}_range{k}"),
        )
    }
}

/// A camera's topic names and frame (see [`VehicleNames::camera`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CameraNames {
    /// `image[N]`: the colour image.
    pub image: String,
    /// `depth[N]`: the depth image.
    pub depth: String,
    /// `camera_info[N]`: the pinhole model.
    pub camera_info: String,
    /// `camera[N]`: the optical frame.
    pub frame: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_resolve_in_the_namespace_then_remap() {
        let none = BTreeMap::new();
        assert_eq!(resolve("/", &none, "odom"), "/odom");
        assert_eq!(resolve("/", &none, "/tf"), "/tf");
        assert_eq!(resolve("/team", &none, "r0/odom"), "/team/r0/odom");
        assert_eq!(resolve("/team", &none, "/clock"), "/clock");
        let remaps = BTreeMap::from([
            ("base_scan".to_string(), "scan".to_string()),
            ("/team/odom".to_string(), "/odometry".to_string()),
        ]);
        assert_eq!(resolve("/team", &remaps, "base_scan"), "/team/scan");
        assert_eq!(resolve("/team", &remaps, "odom"), "/odometry");
        assert_eq!(resolve("/team", &remaps, "cmd_vel"), "/team/cmd_vel");
    }

    #[test]
    fn ros_name_tokens() {
        for ok in ["robot_0", "r0", "_hidden", "Pioneer3"] {
            assert!(is_valid_token(ok), "{ok}");
        }
        for bad in [
            "",
            "position:2",
            "r0.laser",
            "0robot",
            "a__b",
            "a/b",
            "a-b",
            "ü",
        ] {
            assert!(!is_valid_token(bad), "{bad}");
        }
        assert_eq!(vehicle_name("r0", 3), "r0");
        assert_eq!(vehicle_name("position:2", 2), "robot_2");
    }

    #[test]
    fn one_vehicle_unprefixed_several_prefixed() {
        let p = Params::default();
        let one = VehicleNames::new("r0", false, &p);
        assert_eq!(
            (
                one.cmd_vel.as_str(),
                one.odom.as_str(),
                one.tf.as_str(),
                one.tf_static.as_str()
            ),
            ("cmd_vel", "odom", "tf", "tf_static")
        );
        assert_eq!(one.ground_truth, "ground_truth");
        assert_eq!(
            (
                one.frame_odom.as_str(),
                one.frame_base_link.as_str(),
                one.frame_world.as_str()
            ),
            ("odom", "base_link", "world")
        );
        assert_eq!(one.ranger(1, false), ("base_scan".into(), "laser".into()));
        let two = VehicleNames::new("r1", true, &p);
        assert_eq!(two.cmd_vel, "r1/cmd_vel");
        assert_eq!(two.tf, "r1/tf");
        assert_eq!(two.tf_static, "r1/tf_static");
        // frames are not prefixed without one_tf_tree: each vehicle has its own tree
        assert_eq!(two.frame_base_link, "base_link");
        assert_eq!(
            two.ranger(2, true),
            ("r1/base_scan2".into(), "laser2".into())
        );
    }

    #[test]
    fn one_tf_tree_prefixes_frames_and_shares_tf() {
        let mut p = Params::default();
        p.set("one_tf_tree", "true").unwrap();
        p.set("frame_id_base_link", "base_footprint").unwrap();
        let n = VehicleNames::new("r1", true, &p);
        assert_eq!((n.tf.as_str(), n.tf_static.as_str()), ("/tf", "/tf_static"));
        assert_eq!(n.frame_base_link, "r1/base_footprint");
        assert_eq!(n.frame_odom, "r1/odom");
        assert_eq!(n.frame_world, "r1/world");
        assert_eq!(
            n.ranger(1, false),
            ("r1/base_scan".into(), "r1/laser".into())
        );
        // one vehicle, one tree: frames prefixed, topics not (stage_ros2 does the same)
        let solo = VehicleNames::new("r0", false, &p);
        assert_eq!(solo.odom, "odom");
        assert_eq!(solo.frame_odom, "r0/odom");
        assert_eq!(
            VehicleNames::transducer("r1/base_scan", "r1/laser", 3),
            ("r1/base_scan/range3".into(), "r1/laser_range3".into())
        );
    }

    #[test]
    fn cameras_are_numbered_when_a_vehicle_has_several() {
        let mut p = Params::default();
        p.set("one_tf_tree", "true").unwrap();
        let n = VehicleNames::new("r1", true, &p);
        let two = n.camera(2, true);
        assert_eq!(
            (two.image, two.depth, two.camera_info, two.frame),
            (
                "r1/image2".into(),
                "r1/depth2".into(),
                "r1/camera_info2".into(),
                "r1/camera2".into()
            )
        );
        let solo = VehicleNames::new("r0", false, &Params::default()).camera(1, false);
        assert_eq!(
            (solo.image, solo.depth, solo.camera_info, solo.frame),
            (
                "image".into(),
                "depth".into(),
                "camera_info".into(),
                "camera".into()
            )
        );
    }
}
